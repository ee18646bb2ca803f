"""Readers and reading flags: every command that reads logs takes the flags; bpmid reads its own outputs back;
relaxation logs get the same readers; rows are never read by position; stated units and references must agree."""
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from bpmid.cli import app
from bpmid.errors import InputError
from bpmid.io.motion_logs import IOConfig, read_motion_log
from bpmid.io.relax_logs import read_relax_log
from bpmid.io.tables import parse_header, read_table, split_unit

runner = CliRunner()
DATA = Path(__file__).resolve().parent / "data" / "rig_logs"
ROOT = Path(__file__).resolve().parents[1]


def _relax_csv():
    return sorted((ROOT / "datasets" / "relaxation").glob("*.csv"))[0]


@pytest.mark.parametrize("cmd", [["fit", "motion"], ["fit", "relax"], ["predict"], ["compare"], ["discover"]])
def test_every_log_command_has_the_reading_flags(cmd):
    res = runner.invoke(app, [*cmd, "--help"])
    assert res.exit_code == 0
    flags = ["--columns", "--time-unit", "--sheet", "--max-gap", "--strict"]
    if cmd != ["fit", "relax"]:
        flags += ["--pressure-reference", "--pressure-unit", "--angle-unit"]
    for f in flags:
        assert f in res.output, (cmd, f)


@pytest.mark.parametrize("cmd", [["fit", "motion"], ["discover"], ["compare", "--train"]])
def test_unstated_unit_is_refused_by_every_command(tmp_path, cmd):
    log = DATA / "bare_pressure_kpa_gauge.csv"
    args = [*cmd, str(log)] + (["--test", str(log)] if cmd[0] == "compare" else [])
    res = runner.invoke(app, [*args, "--out", str(tmp_path / ("o.yaml" if cmd[0] == "fit" else "o"))])
    assert res.exit_code == 2 and "--pressure-unit" in res.output and "bare_pressure_kpa_gauge.csv" in res.output


@pytest.fixture(scope="module")
def fit(tmp_path_factory):
    out = tmp_path_factory.mktemp("fit") / "V.yaml"
    res = runner.invoke(app, ["fit", "motion", str(DATA / "clean.csv"), "--out", str(out), "--no-plot"])
    assert res.exit_code == 0, res.output
    return out


def test_predict_with_flags_and_its_output_reads_back(tmp_path, fit):
    log = DATA / "bare_pressure_kpa_gauge.csv"
    res = runner.invoke(app, ["predict", str(log), "--params", str(fit), "--out", str(tmp_path / "p")])
    assert res.exit_code == 2 and "--pressure-unit" in res.output
    res = runner.invoke(app, ["predict", str(log), "--params", str(fit), "--out", str(tmp_path / "p"),
                              "--pressure-unit", "kPa", "--pressure-reference", "gauge"])
    assert res.exit_code == 0, res.output
    out = tmp_path / "p" / "bare_pressure_kpa_gauge.csv"
    assert out.read_text().startswith("# pressure_reference: gauge\n")
    back = read_motion_log(out, require_angle=True)            # no flags: the file says everything
    src = read_motion_log(log, IOConfig(units={"pressure": "kPa"}, pressure_reference="gauge"))
    assert np.allclose(back.pressure_pa, src.pressure_pa, atol=1e-3) and np.allclose(back.angle_deg, src.angle_deg)
    assert "angle_pred_deg" in back.reading["ignored_columns"]
    rep = yaml.safe_load((tmp_path / "p" / "predict.yaml").read_text())
    r = rep["provenance"]["reading"]["bare_pressure_kpa_gauge"]
    assert r["columns"]["pressure"]["unit_from"] == "--pressure-unit"
    assert r["pressure_reference"] == {"reference": "gauge", "from": "--pressure-reference"}
    assert rep["warnings"] == []
    # the prediction itself is a log bpmid predicts from again
    res = runner.invoke(app, ["predict", str(out), "--params", str(fit), "--out", str(tmp_path / "p2")])
    assert res.exit_code == 0, res.output


def test_predict_output_without_angle_reads_as_a_pressure_log(tmp_path, fit):
    lines = (DATA / "clean.csv").read_text().splitlines()
    nolog = tmp_path / "p_only.csv"
    nolog.write_text("\n".join(ln.rsplit(",", 1)[0] if not ln.startswith("#") else ln for ln in lines) + "\n")
    res = runner.invoke(app, ["predict", str(nolog), "--params", str(fit), "--out", str(tmp_path / "p")])
    assert res.exit_code == 0, res.output
    back = read_motion_log(tmp_path / "p" / "p_only.csv")
    assert back.angle_deg is None and back.pressure_reference == "absolute"


def test_reference_stated_twice_must_agree(tmp_path):
    f = tmp_path / "r.csv"
    f.write_text("# Pressure Reference: Gauge\ntime_s,pressure_kpa,angle_deg\n0,10,1\n0.1,20,2\n")
    assert read_motion_log(f).pressure_reference == "gauge"
    with pytest.raises(InputError, match="disagrees") as e:
        read_motion_log(f, IOConfig(pressure_reference="absolute", stated_by={"pressure_reference":
                                                                               "--pressure-reference"}))
    assert "--pressure-reference" in e.value.message and "line 1 (pressure_reference: Gauge)" in e.value.message
    g = tmp_path / "g.csv"
    g.write_text("# pressure_reference: absolute\ntime_s,pressure_psig,angle_deg\n0,10,1\n0.1,20,2\n")
    with pytest.raises(InputError, match="disagrees"):
        read_motion_log(g)


def test_unit_stated_twice_must_agree_and_bad_flags_name_themselves(tmp_path):
    f = tmp_path / "u.csv"
    f.write_text("# pressure_reference: gauge\ntime_s,pressure_kpa,angle_deg\n0,10,1\n0.1,20,2\n")
    with pytest.raises(InputError, match="says the unit of 'pressure_kpa' is kpa"):
        read_motion_log(f, IOConfig(units={"pressure": "bar"}))
    out = tmp_path / "o.yaml"
    for flags, key in ((["--pressure-unit", "furlong"], "--pressure-unit"), (["--columns", "time"], "--columns"),
                       (["--columns", "speed=x"], "--columns"), (["--pressure-reference", "up"],
                                                                  "--pressure-reference"),
                       (["--max-gap", "-1"], "--max-gap"), (["--angle-unit", "grad2"], "--angle-unit")):
        res = runner.invoke(app, ["fit", "motion", str(f), "--out", str(out), *flags])
        assert res.exit_code == 2 and key in res.output, (flags, res.output)
    cfg = tmp_path / "c.yaml"
    cfg.write_text("io:\n  units: {pressure: furlong}\n")
    res = runner.invoke(app, ["fit", "motion", str(f), "--out", str(out), "--config", str(cfg)])
    assert res.exit_code == 2 and "io.units.pressure" in res.output


def test_config_io_section_states_units_columns_sheet_and_strict(tmp_path):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("io:\n  units: {pressure: kPa}\n  pressure_reference: gauge\n  strict: true\n"
                   "  columns: {Zeitstempel: time_ms, Kanal1: pressure, Kanal2: angle_deg}\n")
    res = runner.invoke(app, ["fit", "motion", str(DATA / "no_units_rig_names.csv"), "--out", str(tmp_path / "o.yaml"),
                              "--config", str(cfg), "--no-plot"])
    assert res.exit_code == 0, res.output          # strict, and nothing to warn about
    d = yaml.safe_load((tmp_path / "o.yaml").read_text())
    cols = d["provenance"]["reading"]["no_units_rig_names"]["columns"]
    assert cols["pressure"]["unit_from"] == "io.units.pressure" and cols["time"]["unit"] == "ms"
    assert d["provenance"]["reading"]["no_units_rig_names"]["decimal"] == "comma"


def test_key_and_value_cells_above_a_sheets_header_are_metadata(tmp_path):
    """An instrument's settings as two-cell rows above a sheet's header ('Pressure Reference' | 'Gauge'): metadata
    (the first such row was taken for the header and the sheet refused); a two-column sheet's header stays one."""
    import openpyxl

    wb = openpyxl.Workbook()
    ws = wb.active
    for row in (["Operator", "John Smith"], ["Pressure Reference", "Gauge"], ["Time (ms)", "Pressure (psi)",
                                                                              "Angle (deg)"]):
        ws.append(row)
    for i in range(6):
        ws.append([i * 20.0, 10.0 + i, 20.0 + i])
    wb.save(tmp_path / "kv.xlsx")
    lg = read_motion_log(tmp_path / "kv.xlsx")
    assert lg.n == 6 and lg.pressure_reference == "gauge" and lg.time_s[1] == pytest.approx(0.02)
    assert lg.reading["pressure_reference"]["from"] == "line 2 (pressure_reference: Gauge)"
    wb = openpyxl.Workbook()
    ws = wb.active
    ws.append(["time_s", "modulus_mpa"])
    for i in range(6):
        ws.append([i * 0.5, 1.0 + np.exp(-i)])
    wb.save(tmp_path / "relax.xlsx")
    assert read_relax_log(tmp_path / "relax.xlsx").modulus_mpa.size == 6


def test_sheet_by_name_and_ambiguous_workbooks(tmp_path):
    import openpyxl

    wb = openpyxl.Workbook()
    for k, title in enumerate(["A", "B"]):
        ws = wb.active if k == 0 else wb.create_sheet()
        ws.title = title
        ws.append(["# pressure_reference: gauge"])
        ws.append(["time_s", "pressure_kpa", "angle_deg"])
        for i in range(5):
            ws.append([i * 0.1, 10.0 * (k + 1) + i, float(i)])
    path = tmp_path / "two.xlsx"
    wb.save(path)
    with pytest.raises(InputError, match="--sheet"):
        read_motion_log(path)
    assert read_motion_log(path, IOConfig(sheet="B")).pressure_pa[0] == pytest.approx(20e3)
    with pytest.raises(InputError, match="no sheet 'C'"):
        read_motion_log(path, IOConfig(sheet="C"))


def test_row_with_a_field_too_many_is_refused_in_relaxation_logs(tmp_path):
    """Issue 15, item 2: a decimal comma in one cell of a comma-separated relaxation log."""
    src = _relax_csv().read_text().splitlines()
    k = next(i for i, ln in enumerate(src) if ln and not ln.startswith("#")) + 20
    cells = src[k].split(",")
    cells[2] = cells[2].replace(".", ",")
    src[k] = ",".join(cells)
    f = tmp_path / "relax.csv"
    f.write_text("\n".join(src) + "\n")
    out = tmp_path / "fit.yaml"
    res = runner.invoke(app, ["fit", "relax", str(f), "--out", str(out)])
    assert res.exit_code == 2 and f"relax.csv:{k + 1}" in res.output and "decimal comma" in res.output
    assert not out.exists()


def test_relaxation_logs_get_the_same_readers(tmp_path):
    src = _relax_csv()
    clean = read_relax_log(src)
    lines = src.read_text().splitlines()
    head = [ln for ln in lines if ln.startswith("#")]
    body = [ln for ln in lines if ln and not ln.startswith("#")]
    semi = tmp_path / "semi.csv"
    semi.write_bytes(("\r\n".join(head + ["Zeit [s];Dehnung (-);Spannung [MPa]".replace("Dehnung", "strain")
                                          .replace("Spannung", "stress")]
                                  + [ln.replace(",", ";").replace(".", ",") for ln in body[1:]]) + "\r\n")
                     .encode("cp1252"))
    import openpyxl
    import scipy.io

    wb = openpyxl.Workbook()
    ws = wb.active
    ws.append(["time", "strain", "stress"])
    ws.append(["ms", "%", "kPa"])
    for ln in body[1:]:
        t, e, s = (float(v) for v in ln.split(","))
        ws.append([t * 1000, e * 100, s * 1000])
    xl = tmp_path / "relax.xlsx"
    wb.save(xl)
    a = np.array([[float(v) for v in ln.split(",")] for ln in body[1:]])
    mat = tmp_path / "relax.mat"
    scipy.io.savemat(mat, {"time_s": a[:, 0], "strain": a[:, 1], "stress_mpa": a[:, 2]})
    for f in (semi, xl, mat):
        r = read_relax_log(f)
        assert np.allclose(r.time_s, clean.time_s) and np.allclose(r.strain, clean.strain)
        assert np.allclose(r.stress_mpa, clean.stress_mpa, atol=1e-9)
    # and through the CLI, with --time-unit for a bare time column
    bare = tmp_path / "bare.csv"
    bare.write_text("\n".join(["time,strain,stress_mpa"] + [f"{float(x.split(',')[0]) * 1000:g},"
                                                             f"{x.split(',', 1)[1]}" for x in body[1:]]) + "\n")
    res = runner.invoke(app, ["fit", "relax", str(bare), "--out", str(tmp_path / "b.yaml"), "--no-figure"])
    assert res.exit_code == 2 and "--time-unit" in res.output
    res = runner.invoke(app, ["fit", "relax", str(bare), "--out", str(tmp_path / "b.yaml"), "--no-figure",
                              "--time-unit", "ms"])
    assert res.exit_code == 0, res.output
    d = yaml.safe_load((tmp_path / "b.yaml").read_text())
    assert d["provenance"]["reading"]["bare"]["columns"]["time"]["unit_from"] == "--time-unit"


def test_two_columns_for_one_quantity(tmp_path):
    f = tmp_path / "d.csv"
    f.write_text("# pressure_reference: gauge\ntime_s,pressure_bar,pressure_kpa,angle_deg\n0,0.1,10,1\n0.1,0.2,20,2\n")
    assert read_motion_log(f).pressure_pa[1] == pytest.approx(20e3)          # agreeing copies: one is used
    f.write_text("# pressure_reference: gauge\ntime_s,pressure_bar,pressure_kpa,angle_deg\n0,0.1,10,1\n0.1,0.2,30,2\n")
    with pytest.raises(InputError, match="disagree"):
        read_motion_log(f)


@pytest.mark.parametrize("header,q,unit", [
    ("Time (s)", "time", "s"), ("p / bar", "pressure", "bar"), ("Druck in kPa", "pressure", "kpa"),
    ("pressure_psig", "pressure", "psi"), ("theta_rad", "angle", "rad"), ("Winkel [°]", "angle", "deg"),
    ("time_epoch_ms", "time", "epoch_ms"), ("run.t", "time", None), ("angle_pred_deg", None, None),
    ("pressure", "pressure", None),
    # quantity/unit without spaces (DIN 1313), split only at a unit bpmid knows: 'dp/dt' is no unit
    ("t/s", "time", "s"), ("p/bar", "pressure", "bar"), ("angle/deg", "angle", "deg"), ("strain/%", "strain", "%"),
    ("Zeit/ms", "time", "ms"), ("dp/dt", None, None),
])
def test_header_forms(header, q, unit):
    assert parse_header(header) == (q, unit)


def test_pressure_units_carry_the_reference():
    assert split_unit("pressure", "bar(a)") == ("bar", "absolute")
    assert split_unit("pressure", "kPa g") == ("kpa", "gauge")
    assert split_unit("pressure", "psia") == ("psi", "absolute")
    assert split_unit("pressure", "mbar") == ("mbar", None)


def test_whitespace_and_single_column_tables(tmp_path):
    f = tmp_path / "w.txt"
    f.write_text("time_s   modulus_mpa\n0.1   5\n1   4\n10 3\n")
    assert np.allclose(read_table(f, required=("time", "modulus")).columns["modulus"], [5, 4, 3])


def test_mat_variables_of_unequal_length_are_refused(tmp_path):
    import scipy.io

    f = tmp_path / "m.mat"
    scipy.io.savemat(f, {"time_s": np.arange(5.0), "pressure_kpa": np.arange(4.0), "angle_deg": np.arange(5.0)})
    with pytest.raises(InputError, match="differ in length"):
        read_motion_log(f, IOConfig(pressure_reference="gauge"))


def test_missing_reader_library_says_what_to_install(tmp_path, monkeypatch):
    import builtins

    real = builtins.__import__

    def no_h5py(name, *a, **kw):
        if name == "h5py":
            raise ImportError("no h5py")
        return real(name, *a, **kw)

    monkeypatch.setattr(builtins, "__import__", no_h5py)
    f = tmp_path / "v73.mat"
    shutil.copy(DATA / "matlab_v73.mat", f)
    with pytest.raises(InputError, match=r"bpmid\[formats\]"):
        read_motion_log(f)


def test_clock_times_and_excel_time_cells(tmp_path):
    f = tmp_path / "clock.csv"
    f.write_text("# pressure_reference: gauge\nTime;Pressure (kPa);Angle (deg)\n09:30:00,000;10,5;1\n"
                 "09:30:00,100;11;2\n09:30:00,250;12;3\n")
    lg = read_motion_log(f)
    assert np.allclose(lg.time_s, [0, 0.1, 0.25]) and np.allclose(lg.pressure_pa, [10.5e3, 11e3, 12e3])
    import datetime as dt

    import openpyxl

    wb = openpyxl.Workbook()
    ws = wb.active
    ws.append(["Time", "Pressure (bar g)", "Angle (deg)"])
    for i in range(4):
        ws.append([dt.time(9, 30, i), 0.1 * i, float(i)])
    x = tmp_path / "clock.xlsx"
    wb.save(x)
    lg = read_motion_log(x)
    assert np.allclose(lg.time_s, [0, 1, 2, 3]) and lg.pressure_reference == "gauge"


def test_a_broken_first_row_is_named_not_taken_for_a_header(tmp_path):
    f = tmp_path / "b.csv"
    f.write_text("# pressure_reference: gauge\ntime_s,pressure_kpa,angle_deg\n0,1,5,2\n" + "0.1,2,3\n" * 4)
    with pytest.raises(InputError, match="row has 4 fields, the header has 3") as e:
        read_motion_log(f)
    assert e.value.line == 3


def test_column_map_entries_for_other_files_are_fine_and_named_when_needed(tmp_path):
    f = tmp_path / "m.csv"
    f.write_text("# pressure_reference: gauge\nStoppuhr (s),pressure_kpa,angle_deg\n0,1,2\n0.1,2,3\n")
    lg = read_motion_log(f, IOConfig(columns={"Stoppuhr (s)": "time", "Uhrzeit": "time", "Kraft": "load_n"}))
    assert lg.n == 2 and lg.reading["unmatched_map"] == ["Uhrzeit", "Kraft"]  # as the user wrote them
    with pytest.raises(InputError, match="the column map names 'Stopuhr'"):
        read_motion_log(f, IOConfig(columns={"Stopuhr": "time"}))


@pytest.mark.parametrize("name,io,word", [
    ("bare_pressure_kpa_gauge.csv", {"units": {"pressure": "Pa"}, "pressure_reference": "gauge"}, "in kpa"),
    ("bare_pressure_kpa_gauge.csv", {"units": {"pressure": "bar"}, "pressure_reference": "gauge"},
     "more than a pneumatic muscle takes"),
    ("no_units_at_all.csv", {"units": {"time": "ms", "pressure": "bar", "angle": "deg"},
                             "pressure_reference": "absolute"}, "--time-unit s"),
])
def test_a_wrong_statement_is_caught_by_the_plausibility_checks(name, io, word):
    """A unit stated wrongly (a kPa column said to be Pa or bar, seconds said to be ms) is warned about."""
    from bpmid.io import plausibility as plaus

    w = plaus.motion_data_warnings([read_motion_log(DATA / name, IOConfig(**io))])
    assert any(word in x for x in w), w
    assert not plaus.motion_data_warnings([read_motion_log(DATA / "clean.csv")])


def test_a_short_log_in_seconds_is_warned_about_without_a_unit_to_suggest(tmp_path):
    """A 0.3 s log whose column already says seconds: the warning says it is short, not "seconds, not s"."""
    from bpmid.io import plausibility as plaus

    f = tmp_path / "short.csv"
    f.write_text("# pressure_reference: gauge\ntime_s,pressure_pa,angle_deg\n0,20000,15\n0.1,40000,16\n"
                 "0.2,60000,18\n0.3,40000,20\n")
    w = plaus.motion_data_warnings([read_motion_log(f)])
    assert any("lasts only 0.3 s" in x and "too short" in x for x in w), w
    assert not any("not s," in x or "--time-unit s" in x for x in w), w


def test_control_references_use_the_same_readers(tmp_path):
    from bpmid.control import read_reference

    f = tmp_path / "ref.csv"
    f.write_bytes("Zeit [s];Winkel [°]\r\n0,0;45,0\r\n0,1;46,5\r\n0,2;48,0\r\n".encode("cp1252"))
    ref = read_reference(f, 10.0)
    assert np.allclose(ref.angle_deg, [45, 46.5, 48])
    f.write_text("time_s,angle_deg\n0,45\n0.1,46,5\n0.2,48\n")
    with pytest.raises(InputError, match="row has 3 fields"):
        read_reference(f, 10.0)


def test_reading_once_parses_a_file_once_and_hands_out_copies(tmp_path, monkeypatch):
    """Inside reading_once (bpmid run) a log read again the same way is parsed once; each reader gets its own copy;
    a changed file, other options or a read outside the block parse again; a failed read is not kept."""
    import os

    import bpmid.io.motion_logs as ML
    import bpmid.io.relax_logs as RL
    from bpmid.io.read_once import reading_once

    src = sorted((ROOT / "datasets" / "motion" / "fitting_set").glob("*.csv"))[0]
    log_path = tmp_path / "fit.csv"
    shutil.copy(src, log_path)
    calls = []
    real = ML._read_motion_log
    monkeypatch.setattr(ML, "_read_motion_log", lambda *a: calls.append(a[0]) or real(*a))
    with reading_once():
        a = read_motion_log(log_path, require_angle=True)
        b = read_motion_log(log_path, require_angle=True)
        assert len(calls) == 1
        np.testing.assert_array_equal(a.angle_deg, b.angle_deg)
        b.angle_deg[:] = 0.0  # one caller's change never reaches another
        c = read_motion_log(log_path, require_angle=True)
        assert len(calls) == 1 and np.array_equal(c.angle_deg, a.angle_deg) and c.angle_deg.any()
        read_motion_log(log_path, IOConfig(max_gap_factor=50.0), require_angle=True)  # other options: parsed
        assert len(calls) == 2
        st = log_path.stat()
        log_path.write_text(log_path.read_text().replace("\n", "\n", 1) + "\n")  # changed on disk
        os.utime(log_path, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
        read_motion_log(log_path, require_angle=True)
        assert len(calls) == 3
        with pytest.raises(InputError, match="missing.csv"):
            read_motion_log(tmp_path / "missing.csv")
        assert len(calls) == 4  # parsed, failed, not kept
        rel = _relax_csv()
        r1, r2 = read_relax_log(rel), read_relax_log(rel)
        assert r1 is not r2 and np.array_equal(r1.stress_mpa, r2.stress_mpa)
        rcalls = []
        monkeypatch.setattr(RL, "_read_relax_log", lambda *a: rcalls.append(a) or None)
        read_relax_log(rel)
        assert rcalls == []  # the relaxation log came from the first read
    read_motion_log(log_path, require_angle=True)
    read_motion_log(log_path, require_angle=True)
    assert len(calls) == 6  # outside the block every read parses


def test_an_unknown_column_with_a_known_unit_is_named_with_the_map_to_give(tmp_path):
    f = tmp_path / "log.csv"
    f.write_text("# pressure_reference: absolute\ntime_s,pressure_bar,foo_deg\n0,1.2,14\n0.1,1.3,15\n0.2,1.4,16\n")
    with pytest.raises(InputError) as e:
        read_motion_log(f, require_angle=True)
    msg = str(e.value)
    assert e.value.key == "foo_deg" and "has an angle unit" in msg and "--columns angle=foo_deg" in msg


def test_a_log_without_a_header_row_says_how_to_give_one(tmp_path):
    # the shipped friction logs are tab-separated numbers without a header (datasets/reference/friction)
    f = tmp_path / "noheader.csv"
    f.write_text("0.000\t1.014\t53.464\n40.000\t1.017\t53.464\n50.000\t1.018\t53.448\n")
    with pytest.raises(InputError) as e:
        read_motion_log(f, require_angle=True)
    msg = e.value.format()
    assert "noheader.csv:1" in msg and "no header row" in msg
    assert "add a first line naming the columns" in msg and "--columns" in msg


@pytest.mark.parametrize("name", ["log.csv.gz", "log.csv"])
def test_a_gzipped_log_is_named_as_gzip_with_what_to_do(tmp_path, name):
    import gzip

    f = tmp_path / name
    f.write_bytes(gzip.compress(b"# pressure_reference: gauge\ntime_s,pressure_kpa,angle_deg\n0,10,14\n0.1,11,15\n"))
    with pytest.raises(InputError) as e:
        read_motion_log(f, require_angle=True)
    msg = e.value.format()
    assert name in msg and "gzip" in msg and "decompress" in msg


@pytest.mark.parametrize("cut, words", [("22.65,1.7673", "row has 2 fields"), ("22.65,1.767391,", "an empty cell")])
def test_a_log_cut_off_in_its_last_line_says_it_looks_truncated(tmp_path, cut, words):
    body = "# pressure_reference: absolute\ntime_s,pressure_bar,angle_deg\n" + "".join(
        f"{0.05 * k:.2f},{1.1 + 0.001 * k:.6f},{20 + 0.1 * k:.2f}\n" for k in range(40))
    f = tmp_path / "cut.csv"
    f.write_text(body + cut)   # copied while the logger was still writing: no line end after the last line
    with pytest.raises(InputError) as e:
        read_motion_log(f, require_angle=True)
    msg = e.value.format()
    assert "cut.csv:43" in msg and words in msg and "no line end" in msg and "cut off" in msg
    f.write_text(body + cut + "\n")   # the same row with its line end: refused, but not called truncated
    with pytest.raises(InputError) as e:
        read_motion_log(f, require_angle=True)
    assert words in e.value.format() and "cut off" not in e.value.format()


def test_a_column_map_that_takes_another_quantitys_column_says_whose_unit_its_name_states(tmp_path):
    # a friction log's force column mapped as the angle: the name states N, so "stated nowhere, --angle-unit deg"
    # misled; the error says N is a unit of load, not of angle, and keeps the way to state it if it is the angle
    log = tmp_path / "fric.csv"
    log.write_text("time_s,pressure_kpa,force_N\n0,10,1\n0.1,12,2\n0.2,14,3\n0.3,15,3\n", encoding="utf-8")
    r = runner.invoke(app, ["fit", "motion", str(log), "--columns", "angle=force_N", "--out", str(tmp_path / "v.yaml")])
    assert r.exit_code == 2 and "fric.csv:1" in r.output, r.output
    assert "name says N, a unit of load, not of angle" in r.output and "--angle-unit deg" in r.output, r.output
    assert not (tmp_path / "v.yaml").exists()
    # a column whose name states no unit keeps the plain message
    log.write_text("time_s,pressure_kpa,deflection\n0,10,1\n0.1,12,2\n0.2,14,3\n0.3,15,3\n", encoding="utf-8")
    r = runner.invoke(app, ["fit", "motion", str(log), "--columns", "angle=deflection", "--out", str(tmp_path / "v.yaml")])
    assert r.exit_code == 2 and "is stated nowhere" in r.output and "a unit of" not in r.output, r.output
