"""Re-export one clean motion log the ways real rigs and spreadsheets write it (run from anywhere; the files are
committed beside this script, so tests never need to run it).

    /work/venv/bin/python tests/data/rig_logs/make_corpus.py

The clean log (``clean.csv``) is a copy of datasets/motion/fitting_set/fit_1p2_1p6_r1.csv (synthetic: bpmid's
digital twin): time_s at 10 Hz, pressure_bar absolute, angle_deg. ``EXPECTED.yaml`` says, for each variant, what
bpmid must do with it: read it to the same samples as the clean file (``same``; with the flags listed), refuse it
(exit 2) with a message containing the listed words, or read it with a warning.

Writers: the csv module and plain text for the text variants, openpyxl (.xlsx), xlwt (.xls; a writer only this
script needs), scipy.io.savemat (MATLAB v5) and h5py (MATLAB v7.3 = HDF5 with a 512-byte MATLAB header).
"""
from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ATM_BAR = 1.01325


def clean():
    lines = (HERE / "clean.csv").read_text().splitlines()
    body = [ln for ln in lines if ln and not ln.startswith("#")][1:]
    a = np.array([[float(x) for x in ln.split(",")] for ln in body])
    return a[:, 0], a[:, 1], a[:, 2]  # time_s, pressure_bar (absolute), angle_deg


def table(header, rows, sep=",", fmt=None):
    out = [sep.join(header)]
    for r in rows:
        out.append(sep.join(fmt(v) if fmt else repr(float(v)) if not isinstance(v, str) else v for v in r))
    return out


def g(v, nd=6):
    return f"{v:.{nd}f}".rstrip("0").rstrip(".") if "." in f"{v:.{nd}f}" else f"{v:.{nd}f}"


def write(name, lines, *, encoding="utf-8", newline="\n", head=()):
    text = newline.join(list(head) + list(lines)) + newline
    (HERE / name).write_bytes(text.encode(encoding))


def main():
    t, pb, ang = clean()
    kpa_g = (pb - ATM_BAR) * 100.0
    n = t.size
    ref_abs = ["# pressure_reference: absolute"]

    # --- text dialects and encodings ----------------------------------------------------------------------
    write("instrument_kpa_gauge.csv", [f"{g(a)},{g(b, 4)},{g(c)}" for a, b, c in zip(t, kpa_g, ang)],
          head=["# Pressure Reference: Gauge", "# rig: bench 2, exported by LabVIEW",
                "Time (s),Pressure (kPa),Angle (deg)"])
    write("semicolon_decimal_comma_cp1252.csv",
          [";".join(g(v).replace(".", ",") for v in r) for r in zip(t, pb, ang)],
          head=["# Druck: absolut", "# pressure reference: ABSOLUTE", "Zeit [s];Druck [bar];Winkel [°]"],
          encoding="cp1252", newline="\r\n")
    write("excel_sep_line.csv", [";".join(g(v).replace(".", ",") for v in r) for r in zip(t, pb, ang)],
          head=["sep=;", "time_s;pressure_bar;angle_deg"], encoding="utf-8-sig", newline="\r\n")
    write("tab_crlf.tsv", ["\t".join(g(v) for v in r) for r in zip(t, pb, ang)],
          head=ref_abs + ["time_s\tpressure_bar\tangle_deg"], newline="\r\n")
    write("whitespace_aligned.txt", [f"{g(a):>10} {g(b):>10} {g(c):>10}" for a, b, c in zip(t, pb, ang)],
          head=ref_abs + ["    Time (s)  Pressure [bar]  Angle [deg]"])
    write("utf8_bom.csv", [",".join(g(v) for v in r) for r in zip(t, pb, ang)],
          head=ref_abs + ["time_s,pressure_bar,angle_deg"], encoding="utf-8-sig")
    write("utf16_tab_excel_unicode.txt", ["\t".join(g(v) for v in r) for r in zip(t, pb, ang)],
          head=ref_abs + ["Time (s)\tPressure (bar)\tBending angle (°)"], encoding="utf-16", newline="\r\n")
    write("utf16le_no_bom.csv", [",".join(g(v) for v in r) for r in zip(t, pb, ang)],
          head=ref_abs + ["time_s,pressure_bar,angle_deg"], encoding="utf-16-le")
    write("latin1_degree.csv", [",".join(g(v) for v in r) for r in zip(t, pb, ang)],
          head=ref_abs + ["time (s),pressure (bar a),angle (°)"], encoding="latin-1")
    write("units_row.csv", [f"{g(a)},{g(b, 4)},{g(c)}" for a, b, c in zip(t, kpa_g, ang)],
          head=["# pressure_reference: gauge", "time,pressure,angle", "s,kPa,deg"])
    write("time_ms_psig.csv", [f"{int(round(a * 1000))},{g(b / 0.0689475729317831, 9)},{g(c)}"
                               for a, b, c in zip(t, pb - ATM_BAR, ang)],
          head=["time_ms,pressure_psig,angle_deg"])
    t0 = dt.datetime(2024, 5, 17, 9, 30, 0, tzinfo=dt.timezone.utc)
    write("iso_timestamps.csv", [f"{(t0 + dt.timedelta(seconds=float(a))).isoformat(timespec='milliseconds')},{g(b)},"
                                 f"{g(c)}" for a, b, c in zip(t, pb, ang)],
          head=ref_abs + ["timestamp,pressure_bar,angle_deg"])
    e0 = 1715938200.0
    write("epoch_ms.csv", [f"{int(round((e0 + a) * 1000))},{g(b)},{g(c)}" for a, b, c in zip(t, pb, ang)],
          head=ref_abs + ["time_epoch_ms,pressure_bar,angle_deg"])
    write("theta_extra_columns.csv",
          [f"{g(c)},{g(a)},{21.5 + 0.01 * i:.2f},{g(b)},{g(b * 2.1)}" for i, (a, b, c) in enumerate(zip(t, pb, ang))],
          head=ref_abs + ["theta_deg,time_s,temperature_c,pressure_bar,valve_cmd_v"])
    write("capitalised_keys.csv", [",".join(g(v) for v in r) for r in zip(t, pb, ang)],
          head=["# PRESSURE-REFERENCE: Absolute", "Time_S,Pressure_Bar,Angle_Deg"])
    keep = np.ones(n, bool)
    keep[120:128] = False  # eight dropped samples (0.9 s step)
    write("gap_eight_samples.csv", [",".join(g(v) for v in r) for r in zip(t[keep], pb[keep], ang[keep])],
          head=ref_abs + ["time_s,pressure_bar,angle_deg"])

    write("title_and_key_value_lines.csv", [",".join(g(v) for v in r) for r in zip(t, pb, ang)],
          head=["Bending muscle run 3", "Date: 2024-05-17", "Pressure reference: absolute", "",
                "Time [s],Pressure [bar],Angle [deg]"])

    # --- what must be stated (refused until it is) -----------------------------------------------------
    write("no_units_at_all.csv", [",".join(g(v) for v in r) for r in zip(t, pb, ang)],
          head=["Time,Pressure,Angle"])
    write("bare_pressure_kpa_gauge.csv", [f"{g(a)},{g(b, 4)},{g(c)}" for a, b, c in zip(t, kpa_g, ang)],
          head=["time_s,pressure,angle_deg"])
    write("no_units_rig_names.csv", [f"{int(round(a * 1000))};{g(b, 4).replace('.', ',')};{g(c).replace('.', ',')}"
                                     for a, b, c in zip(t, kpa_g, ang)],
          head=["Zeitstempel;Kanal1;Kanal2"])
    write("tilt_unknown_angle_name.csv", [",".join(g(v) for v in r) for r in zip(t, pb, ang)],
          head=ref_abs + ["time_s,pressure_bar,tilt_deg"])
    rows = [",".join(g(v) for v in r) for r in zip(t, pb, ang)]
    rows[50] = f"{g(t[50])},{g(pb[50]).replace('.', ',')},{g(ang[50])}"  # one decimal comma in a comma file
    write("one_decimal_comma_in_comma_file.csv", rows, head=ref_abs + ["time_s,pressure_bar,angle_deg"])
    (HERE / "not_a_table.bin").write_bytes(bytes(np.random.default_rng(14).integers(0, 256, 700, dtype=np.uint8)))

    # --- plausibility: read, but warned (and refused with --strict) ---------------------------------------
    write("absolute_under_gauge_line.csv", [",".join(g(v) for v in r) for r in zip(t, pb, ang)],
          head=["# pressure_reference: gauge", "time_s,pressure_bar,angle_deg"])
    write("radians_in_deg_column.csv", [",".join(g(v) for v in r) for r in zip(t, pb, np.round(np.deg2rad(ang), 6))],
          head=ref_abs + ["time_s,pressure_bar,angle_deg"])

    # --- spreadsheets ------------------------------------------------------------------------------------
    import openpyxl

    wb = openpyxl.Workbook()
    ws = wb.active
    ws.title = "Notes"
    ws.append(["Bench 2 run, operator JK"])
    ws.append(["see lab book p. 41"])
    ws2 = wb.create_sheet("Run 3")
    ws2.append(["# pressure_reference: absolute"])
    ws2.append(["Time (s)", "Pressure (bar)", "Angle (deg)"])
    for r in zip(t, pb, ang):
        ws2.append([float(v) for v in r])
    wb.save(HERE / "workbook_two_sheets.xlsx")

    wb = openpyxl.Workbook()
    ws = wb.active
    ws.title = "Log"
    ws.append(["Timestamp", "Pressure (kPa g)", "Angle (deg)"])
    for a, b, c in zip(t, kpa_g, ang):
        ws.append([(t0 + dt.timedelta(seconds=float(a))).replace(tzinfo=None), round(float(b), 4), float(c)])
    wb.save(HERE / "excel_dates_kpa_g.xlsx")

    import xlwt

    book = xlwt.Workbook()
    sh = book.add_sheet("Data")
    for j, h in enumerate(["time_s", "pressure_bar", "angle_deg"]):
        sh.write(1, j, h)
    sh.write(0, 0, "# pressure_reference: absolute")
    for i, r in enumerate(zip(t, pb, ang)):
        for j, v in enumerate(r):
            sh.write(i + 2, j, float(v))
    book.save(str(HERE / "legacy.xls"))

    # --- MATLAB ------------------------------------------------------------------------------------------
    import scipy.io

    scipy.io.savemat(HERE / "matlab_v5_named.mat", {"time_s": t, "pressure_bar": pb, "angle_deg": ang,
                                                     "pressure_reference": "absolute"})
    scipy.io.savemat(HERE / "matlab_v5_struct.mat", {"run": {"t": t.reshape(-1, 1), "p": pb, "beta": ang,
                                                             "note": "bench 2"}})
    import h5py

    path = HERE / "matlab_v73.mat"
    with h5py.File(path, "w", userblock_size=512) as f:
        for name, v in (("t", t), ("p_kpa", kpa_g), ("phi", ang)):
            d = f.create_dataset(name, data=np.asarray(v, float).reshape(1, -1))  # MATLAB stores column vectors so
            d.attrs["MATLAB_class"] = np.bytes_("double")
        ref = f.create_dataset("pressure_reference", data=np.array([[ord(c)] for c in "gauge"], np.uint16))
        ref.attrs["MATLAB_class"] = np.bytes_("char")
    head = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Fri May 17 09:30:00 2024 HDF5 schema 1.00 ."
    with open(path, "r+b") as fh:
        fh.write(head.ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02IM")


if __name__ == "__main__":
    main()
