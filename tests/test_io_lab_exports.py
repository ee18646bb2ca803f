"""Lab exports that were read wrong without a word, or refused wrongly (a fuzz of ~130 re-exports of a shipped
log): a second pressure column beside the one taken by its name, a units row that contradicts the header, an
ambient pressure the file states, 'grad' for an angle, Excel's padded rows, a separator at the end of each row,
NUL bytes a logger leaves when it loses power. Each file is read back against the values written."""
from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from bpmid.cli import app
from bpmid.errors import InputError
from bpmid.io.motion_logs import IOConfig, read_motion_log

runner = CliRunner()
T = np.round(np.arange(12) * 0.1, 3)
P_KPA = np.round(18.0 + 4.0 * np.sin(T), 4)          # the muscle's gauge pressure (kPa)
A = np.round(10.0 + 5.0 * np.sin(T - 0.2), 4)        # the angle (deg)


def _rows(*cols, sep=",", end=""):
    return "".join(sep.join(f"{c[i]:.12g}" for c in cols) + end + "\n" for i in range(len(T)))


def test_a_second_pressure_column_is_never_set_aside_without_a_word(tmp_path):
    """'Supply pressure' is a name bpmid knows; 'Chamber pressure' beside it differs: refused, both named, and the
    suggested --columns reads the chosen one (the other is listed as ignored). Equal values: one channel logged
    twice, read. A setpoint named as such is no rival."""
    f = tmp_path / "two.csv"
    f.write_text("Time (s),Supply pressure (bar g),Chamber pressure (bar g),Angle (deg)\n"
                 + _rows(T, np.full(T.size, 6.0), P_KPA / 100, A))
    with pytest.raises(InputError, match="two columns could be the pressure") as e:
        read_motion_log(f)
    assert "'Chamber pressure (bar g)'" in e.value.message and "--columns 'pressure=Chamber pressure (bar g)'" in \
        e.value.message
    lg = read_motion_log(f, IOConfig(columns={"Chamber pressure (bar g)": "pressure"}))
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    assert lg.reading["ignored_columns"] == ["Supply pressure (bar g)"]
    res = runner.invoke(app, ["fit", "motion", str(f), "--out", str(tmp_path / "o.yaml")])
    assert res.exit_code == 2 and "two columns could be the pressure" in res.output and "two.csv" in res.output
    assert not (tmp_path / "o.yaml").exists()
    same = tmp_path / "same.csv"
    same.write_text("Time (s),Pressure (bar g),Pressure sensor (bar g),Angle (deg)\n"
                    + _rows(T, P_KPA / 100, P_KPA / 100, A))
    assert read_motion_log(same).reading["ignored_columns"] == ["Pressure sensor (bar g)"]
    sp = tmp_path / "sp.csv"
    sp.write_text("Time (s),Setpoint pressure (bar g),Pressure (bar g),Angle (deg)\n"
                  + _rows(T, np.full(T.size, 0.2), P_KPA / 100, A))
    np.testing.assert_allclose(read_motion_log(sp).pressure_pa, P_KPA * 1e3, atol=1e-6)


@pytest.mark.parametrize("header,row,says", [
    ("Time (s),Pressure (bar g),Angle (deg)", "s,psi,deg", "units row under the header says psi"),
    ("Time (s),Pressure (kPa g),Angle (deg)", "ms,kPa,deg", "units row under the header says ms"),
    ("Time (s),Pressure (bar g),Angle (deg)", "s,bar(a),deg", "units row under the header says bar(a)"),
])
def test_a_units_row_that_contradicts_the_header_is_refused_with_its_line(tmp_path, header, row, says):
    f = tmp_path / "u.csv"
    f.write_text(f"{header}\n{row}\n" + _rows(T, P_KPA / 100, A))
    with pytest.raises(InputError, match="make them agree") as e:
        read_motion_log(f)
    assert says in e.value.message and e.value.line == 2


def test_a_units_row_that_repeats_the_header_or_adds_the_reference_is_read(tmp_path):
    f = tmp_path / "u.csv"
    f.write_text("Time (s),Pressure (kPa),Angle (deg)\n[s],kPa g,°\n" + _rows(T, P_KPA, A))
    lg = read_motion_log(f)
    assert lg.pressure_reference == "gauge"
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)


def test_the_ambient_pressure_a_file_states_turns_absolute_into_gauge(tmp_path):
    """A lab at 840 mbar: '# ambient_pressure: 840 mbar' (or an ambient column) is used, and said where from;
    a configured value that disagrees, or a line whose number has no pressure unit, is refused with the line."""
    p_abs_bar = (P_KPA * 1e3 + 84000.0) / 1e5
    f = tmp_path / "amb.csv"
    f.write_text("# pressure_reference: absolute\n# ambient_pressure: 840 mbar\n# ambient_temperature: 21 C\n"
                 "time_s,pressure_bar,angle_deg\n" + _rows(T, p_abs_bar, A))
    lg = read_motion_log(f)
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    assert lg.reading["pressure_reference"]["atmosphere_from"] == "line 2 (ambient_pressure: 840 mbar)"
    assert lg.atmosphere_pa == pytest.approx(84000.0)
    with pytest.raises(InputError, match="ambient pressure is stated twice and disagrees"):
        read_motion_log(f, IOConfig(atmosphere_pa=95000.0))
    np.testing.assert_allclose(read_motion_log(f, IOConfig(atmosphere_pa=84000.0)).pressure_pa, P_KPA * 1e3,
                               atol=1e-6)
    bad = tmp_path / "bad.csv"
    bad.write_text("# pressure_reference: absolute\n# ambient_pressure: 84\ntime_s,pressure_bar,angle_deg\n"
                   + _rows(T, p_abs_bar, A))
    with pytest.raises(InputError, match="cannot read it as a number with a pressure unit") as e:
        read_motion_log(bad)
    assert e.value.line == 2
    soft = tmp_path / "soft.csv"   # 'atmosphere' may mean something else: a bare number is not read, but said
    soft.write_text(bad.read_text().replace("ambient_pressure: 84", "atmosphere: 84"))
    assert any("may state the ambient pressure" in w and ":2:" in w for w in read_motion_log(soft).warnings)
    gauge = tmp_path / "gauge.csv"   # a gauge log: the ambient pressure is not needed, and not asked
    gauge.write_text("# pressure_reference: gauge\n# atmosphere: 84\ntime_s,pressure_kpa,angle_deg\n"
                     + _rows(T, P_KPA, A))
    np.testing.assert_allclose(read_motion_log(gauge).pressure_pa, P_KPA * 1e3, atol=1e-6)
    col = tmp_path / "col.csv"
    amb = 84.0 + 0.1 * np.arange(T.size)
    col.write_text("Time (s),Pressure (kPa a),Ambient pressure (kPa),Angle (deg)\n"
                   + _rows(T, P_KPA + amb, amb, A))
    lg = read_motion_log(col)
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    assert lg.reading["pressure_reference"]["atmosphere_from"] == "the column 'Ambient pressure (kPa)'"


def test_grad_is_read_as_degrees_only_under_a_german_name(tmp_path):
    f = tmp_path / "g.csv"
    f.write_text("# pressure_reference: gauge\nTime (s),Pressure (kPa),Angle (grad)\n" + _rows(T, P_KPA, A))
    with pytest.raises(InputError, match="gradian") as e:
        read_motion_log(f)
    assert "deg or gon" in e.value.message
    de = tmp_path / "de.csv"
    de.write_text("# pressure_reference: gauge\nZeit [s];Druck [kPa];Winkel [Grad]\n" + _rows(T, P_KPA, A, sep=";"))
    np.testing.assert_allclose(read_motion_log(de).angle_deg, A)
    gon = tmp_path / "gon.csv"
    gon.write_text("# pressure_reference: gauge\nTime (s),Pressure (kPa),Angle (gon)\n" + _rows(T, P_KPA, A / 0.9))
    np.testing.assert_allclose(read_motion_log(gon).angle_deg, A, atol=1e-3)


@pytest.mark.parametrize("text", [
    # Excel pads every row to the table's width: metadata rows above the header, an empty row, rows at the end
    "Muscle A cycle test,,\nPressure Reference,Gauge,\n,,\nOperator,J. Doe,\ntime_s,pressure_kpa,angle_deg\n{rows},,\n,,\n",
    # a tab at the end of each data row, not of the header
    "# pressure_reference: gauge\ntime_s\tpressure_kpa\tangle_deg\n{rows_tab}",
    # more instrument lines above the header than a screenful
    "".join(f"Channel {k} gain: 1.000\n" for k in range(40)) + "Pressure Reference: Gauge\n"
    "time_s,pressure_kpa,angle_deg\n{rows}",
])
def test_spreadsheet_and_instrument_layouts_are_read(tmp_path, text):
    f = tmp_path / "x.csv"
    f.write_text(text.format(rows=_rows(T, P_KPA, A), rows_tab=_rows(T, P_KPA, A, sep="\t", end="\t")))
    lg = read_motion_log(f)
    assert lg.n == T.size and lg.pressure_reference == "gauge"
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    np.testing.assert_allclose(lg.angle_deg, A)


def test_nul_bytes_after_the_rows_are_read_with_a_warning_and_micro_in_greek(tmp_path):
    f = tmp_path / "n.csv"
    f.write_bytes(("# pressure_reference: gauge\ntime_us,pressure_kpa,angle_deg\n".replace("us", "μs") +
                   _rows(T * 1e6, P_KPA, A)).encode() + b"\x00" * 512)
    lg = read_motion_log(f)
    np.testing.assert_allclose(lg.time_s, T, atol=1e-9)
    assert any("NUL bytes" in w and "line 14" in w for w in lg.warnings)


def test_elapsed_minutes_seconds_a_clock_past_midnight_and_excel_durations(tmp_path):
    """Excel's 'mm:ss.0' cells (a fraction rules out hh:mm), a clock that passes midnight, and '[h]:mm:ss.000'
    duration cells in a sheet: seconds since the first sample."""
    import datetime as dt

    import openpyxl

    t = np.array([0.0, 30.5, 59.9, 61.2, 125.0, 3601.5])
    p, a = np.linspace(10, 20, t.size), np.linspace(1, 5, t.size)
    mmss = [f"{int(x // 60):02d}:{x % 60:04.1f}" for x in t]
    f = tmp_path / "mmss.csv"
    f.write_text("# pressure_reference: gauge\nTime,pressure_kpa,angle_deg\n"
                 + "".join(f"{m},{pp:g},{aa:g}\n" for m, pp, aa in zip(mmss, p, a)))
    lg = read_motion_log(f)
    np.testing.assert_allclose(lg.time_s, t, atol=1e-9)
    assert "minutes:seconds" in lg.reading["columns"]["time"]["time_origin"]
    clock = ["23:59:58.5", "23:59:59.5", "00:00:00.5", "00:00:01.5"]
    g = tmp_path / "midnight.csv"
    g.write_text("# pressure_reference: gauge\nTime,pressure_kpa,angle_deg\n"
                 + "".join(f"{c},{10 + k},{k}\n" for k, c in enumerate(clock)))
    np.testing.assert_allclose(read_motion_log(g).time_s, [0.0, 1.0, 2.0, 3.0], atol=1e-9)
    wb = openpyxl.Workbook()
    ws = wb.active
    ws.append(["# pressure_reference: gauge"])
    ws.append(["Elapsed", "pressure_kpa", "angle_deg"])
    for x, pp, aa in zip(t, p, a):
        ws.append([dt.timedelta(seconds=float(x)), float(pp), float(aa)])
        ws.cell(ws.max_row, 1).number_format = "[h]:mm:ss.000"
    wb.save(tmp_path / "dur.xlsx")
    np.testing.assert_allclose(read_motion_log(tmp_path / "dur.xlsx").time_s, t, atol=1e-6)


def test_second_round_what_the_new_rules_must_not_refuse_or_misread(tmp_path):
    """From an adversarial look at the rules above: units rows that spell the header's unit another way, a
    description row under the header, a raw-signal column beside the calibrated one, an unreadable ambient column
    in a gauge log, instrument lines that mention the atmosphere, a relaxation log's '%' units row."""
    from bpmid.io.relax_logs import read_relax_log

    def read(name, text, **kw):
        f = tmp_path / name
        f.write_text(text)
        return read_motion_log(f, IOConfig(**kw))

    rows = _rows(T, P_KPA, A)
    lg = read("syn.csv", "# pressure_reference: gauge\nTime (s),Pressure (hPa),Angle (deg)\nsec,mbar,°\n"
              + _rows(T, P_KPA * 10, A))
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    lg = read("desc.csv", "# pressure_reference: gauge\nTime (s),Pressure (kPa),Angle (deg)\n"
              "elapsed time,chamber pressure,bending angle\n" + rows)
    assert lg.n == T.size and lg.reading["columns"]["pressure"]["column"] == "Pressure (kPa)"
    lg = read("volt.csv", "# pressure_reference: gauge\nTime (s),Pressure (kPa),Pressure (V),Angle (deg)\n"
              + _rows(T, P_KPA, P_KPA / 15.0, A))
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    assert "Pressure (V)" in lg.reading["ignored_columns"]
    with pytest.raises(InputError, match="raw signal"):
        read("volt_only.csv", "# pressure_reference: gauge\nTime (s),Pressure (V),Angle (deg)\n"
             + _rows(T, P_KPA / 15.0, A))
    amb_bad = "Time (s),Pressure (kPa {ref}),Ambient pressure (inHg),Angle (deg)\n" + _rows(T, P_KPA, P_KPA, A)
    lg = read("amb_gauge.csv", amb_bad.format(ref="g"))
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    with pytest.raises(InputError, match="inhg"):
        read("amb_abs.csv", amb_bad.format(ref="a"))
    atm = ("# pressure_reference: absolute\nAtmosphere: air, 45 %RH\nAir pressure: 6 bar\n{line}\n"
           "time_s,pressure_kpa,angle_deg\n" + _rows(T, P_KPA + 98.6, A))
    lg = read("atm.csv", atm.format(line="Ambient pressure: 986 hPa"))   # 'Air pressure: 6 bar' is the supply
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    assert lg.reading["pressure_reference"]["atmosphere_from"].endswith("(ambient_pressure: 986 hPa)")
    lg = read("atm2.csv", atm.format(line="Luftdruck: 986 hPa"))   # in German, the weather's (in 50-120 kPa)
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    with pytest.raises(InputError, match="may be the ambient pressure or the supply") as e:
        read("atm3.csv", atm.format(line="Air pressure: 98.6 kPa").replace("Air pressure: 6 bar\n", ""))
    assert e.value.line == 3   # 'Air pressure' in the ambient range: ambient or supply? asked, never guessed
    for name, header, row in (("de.csv", "Zeit (s);Druck (bar);Kammerdruck (bar);Winkel (deg)", None),
                              ("suffix.csv", "time_s,supply_pressure_bar_g,chamber_pressure_bar_g,angle_deg", None),
                              ("urow.csv", "Time,Supply pressure,Chamber pressure,Angle", "s,bar g,bar g,deg")):
        sep = ";" if ";" in header else ","
        with pytest.raises(InputError, match="two columns could be the pressure"):
            read(name, f"{header}\n" + (f"{row}\n" if row else "")
                 + _rows(T, np.full(T.size, 6.0), P_KPA / 100, A, sep=sep), pressure_reference="gauge")
    rl = tmp_path / "relax.csv"
    strain = np.full(T.size, 20.0)
    rl.write_text("Strain,Stress [MPa],Time [s]\n%,MPa,s\n" + _rows(strain, np.linspace(1.0, 0.8, T.size), T))
    np.testing.assert_allclose(read_relax_log(rl).strain, 0.2)


@pytest.mark.parametrize("text", [
    # an instrument's text export: columns apart by runs of spaces, names with single spaces inside
    "# pressure_reference: gauge\nElapsed Time (s)   Pressure (kPa)   Bending angle (deg)\n{ws}",
    "Time (s)    Pressure (kPa g)    Angle (deg)\n{ws}",
    # the unit after a comma in the name, in a ';' file with decimal commas
    "# pressure_reference: gauge\nTime, s;Pressure, kPa;Angle, deg\n{semi}",
])
def test_names_with_spaces_or_a_comma_before_the_unit(tmp_path, text):
    ws = "".join(f"{t:<12.12g}{p:<20.12g}{a:.12g}\n" for t, p, a in zip(T, P_KPA, A))
    semi = _rows(T, P_KPA, A, sep=";").replace(".", ",")
    f = tmp_path / "x.txt"
    f.write_text(text.format(ws=ws, semi=semi))
    lg = read_motion_log(f)
    np.testing.assert_allclose(lg.time_s, T, atol=1e-12)
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    np.testing.assert_allclose(lg.angle_deg, A)


def test_a_sheets_title_row_of_several_cells_above_its_header_is_metadata(tmp_path):
    import openpyxl

    wb = openpyxl.Workbook()
    ws = wb.active
    for row in (["Test", "Run 3", "2024-05-01"], ["Pressure Reference", "Gauge"],
                ["Time (s)", "Pressure (kPa)", "Angle (deg)", "Note"]):
        ws.append(row)
    for t, p, a in zip(T, P_KPA, A):
        ws.append([float(t), float(p), float(a)])
    wb.save(tmp_path / "t.xlsx")
    lg = read_motion_log(tmp_path / "t.xlsx")
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    assert lg.meta["test"] == "Run 3 2024-05-01" and lg.pressure_reference == "gauge"


def test_third_round_names_rows_setpoints_ambient_spellings_pandas_and_sheets(tmp_path):
    """From a third adversarial look: a row that repeats the names under a header with units, German setpoint
    compounds and statistics columns, a header's trailing separator over a column of data, the ambient pressure in
    the spellings labs write, pandas' to_string with its index, 'Time, s' with decimal commas, a sheet's header
    below a title, a date, an operator and blank rows."""
    import openpyxl

    def read(name, text, **kw):
        f = tmp_path / name
        f.write_text(text)
        return read_motion_log(f, IOConfig(**kw))

    rows = _rows(T, P_KPA, A)
    for second in ("time,pressure,angle", "Zeit,Druck,Winkel", "elapsed time,chamber pressure,bending angle"):
        lg = read("names.csv", f"Time (s),Pressure (kPa g),Angle (deg)\n{second}\n" + rows)
        np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
        assert lg.reading["name_rows_skipped"] == [2]
    lg = read("soll.csv", "Zeit [s];Solldruck [kPa];Druck [kPa];Pressure max [kPa];Winkel [deg]\n"
              + _rows(T, np.full(T.size, 30.0), P_KPA, np.full(T.size, 40.0), A, sep=";"), pressure_reference="gauge")
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    lg = read("trail.csv", "time_s,pressure_kpa,angle_deg,\n" + _rows(T, P_KPA, A, np.ones(T.size)),
              pressure_reference="gauge")
    np.testing.assert_allclose(lg.angle_deg, A)
    p_abs = P_KPA + 98.2
    for line in ("# Ambient pressure [kPa]: 98.2", "# Umgebungsdruck [hPa]: 982", "# Barometer reading: 982 hPa",
                 "# p_amb: 98.2 kPa", "Ambient pressure,98.2,kPa", "Barometer,982 hPa,"):
        lg = read("amb.csv", f"{line}\ntime_s,pressure_kpa_abs,angle_deg\n" + _rows(T, p_abs, A))
        np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6, err_msg=line)
    lg = read("ambient_temp.csv", "# Ambient: 21 C\n# Atmosphere: air, 45 %RH\ntime_s,pressure_kpa_abs,angle_deg\n"
              + _rows(T, P_KPA + 101.325, A))
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    with pytest.raises(InputError, match="two columns could be the pressure"):   # Luftdruck: ambient or supply?
        read("luft.csv", "Zeit (s);Druck (kPa a);Luftdruck (hPa);Winkel (deg)\n"
             + _rows(T, p_abs, np.full(T.size, 982.0), A, sep=";"))
    lg = read("unread.csv", "# Atm. pressure: 982 hPa\ntime_s,pressure_kpa_abs,angle_deg\n" + _rows(T, p_abs, A))
    assert any("may state the ambient pressure" in w for w in lg.warnings)   # a spelling not read: said
    pandas_txt = "   Time (s)  Chamber pressure (kPa)  Angle (deg)\n" + "".join(
        f"{k:<3d} {t:>8.3f} {p:>22.4f} {a:>12.4f}\n" for k, (t, p, a) in enumerate(zip(T, P_KPA, A)))
    lg = read("pandas.txt", pandas_txt, columns={"Chamber pressure (kPa)": "pressure"}, pressure_reference="gauge")
    np.testing.assert_allclose(lg.time_s, T, atol=1e-9)
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=0.1)
    assert "index" in lg.reading["index_column"]
    semi = _rows(T, P_KPA, A, sep=";").replace(".", ",")
    lg = read("dc.csv", "# pressure_reference: gauge\nTime, s;Pressure, kPa;Angle, deg\n" + semi)
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    wb = openpyxl.Workbook()
    ws = wb.active
    for row in (["Cycle test", "Muscle A", None], ["Date", "2026-03-01", "10:00"], ["Operator", "J. Doe", "lab 2"],
                [], [], ["Pressure Reference", "Gauge"], [], [], []):
        ws.append(row)
    ws.append(["Time (s)", "Pressure (kPa)", "Angle (deg)"])
    for t, p, a in zip(T, P_KPA, A):
        ws.append([float(t), float(p), float(a)])
    wb.save(tmp_path / "row10.xlsx")
    lg = read_motion_log(tmp_path / "row10.xlsx")
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)


def test_fourth_round_stacked_headers_counters_maps_and_ambient_lookalikes(tmp_path):
    """From a fourth adversarial look: a second header row whose units differ is refused (the first row was read
    before, the second after an earlier mend); a whitespace table's named counter is no pandas index; a comma file
    with a tab at the end of each line stays a comma file; a mapped channel header keeps its map over a
    description row with other units; an ambient temperature column does not block an absolute log."""
    def read(name, text, **kw):
        f = tmp_path / name
        f.write_text(text)
        return read_motion_log(f, IOConfig(**kw))

    rows = _rows(T, P_KPA, A)
    for second in ("Time (ms),Pressure (kPa g),Angle (deg)", "Zeit,Druck (bar),Winkel"):
        with pytest.raises(InputError, match="units row under the header says") as e:
            read("stack.csv", f"Time (s),Pressure (kPa g),Angle (deg)\n{second}\n" + rows)
        assert e.value.line == 2
    counter = "n time_s pressure_kpa angle_deg\n" + "".join(
        f"{k + 1} {t:.12g} {p:.12g} {a:.12g}\n" for k, (t, p, a) in enumerate(zip(T, P_KPA, A)))
    lg = read("counter.txt", counter, pressure_reference="gauge")
    np.testing.assert_allclose(lg.time_s, T, atol=1e-12)
    lg = read("tab_end.csv", "# pressure_reference: gauge\ntime_s,pressure_kpa,angle_deg\t\n" + _rows(T, P_KPA, A,
                                                                                                     end="\t"))
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    lg = read("kanal.csv", "Kanal 1;Kanal 2;Kanal 3\nZeit (ms);Druck (bar);Winkel (rad)\n" + _rows(T, P_KPA, A, sep=";"),
              columns={"Kanal 1": "time_s", "Kanal 2": "pressure_kpa", "Kanal 3": "angle_deg"},
              pressure_reference="gauge")
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    lg = read("amb_t.csv", "Time (s),Pressure (kPa a),Ambient temperature (C),Angle (deg)\n"
              + _rows(T, P_KPA + 101.325, np.full(T.size, 21.0), A))
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    lg = read("padded_3cell.csv", "Operator,J. Doe,\nAmbient pressure,98.2,kPa\ntime_s,pressure_kpa_abs,angle_deg\n"
              + _rows(T, P_KPA + 98.2, A))
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)


def test_fifth_round_ordinary_exports(tmp_path):
    """Ordinary files that read wrong or were refused: an Arduino log's raw channel beside its calibrated one, a
    supply or tank channel and an IMU angle beside bpmid's plain names, numpy's savetxt header, an instrument's
    'Time Units: ms' / 'Pressure Units: psi' lines, MATLAB's datetime text, a materials tester's metadata block with
    value-and-unit rows; and a predict output of an absolute log read against 98.5 kPa reads back the same."""
    from bpmid.io.motion_logs import write_motion_log
    from bpmid.io.relax_logs import read_relax_log

    def read(name, text, **kw):
        f = tmp_path / name
        f.write_text(text)
        return read_motion_log(f, IOConfig(**kw))

    lg = read("arduino.csv", "millis,pressure_raw,pressure_kpa,angle_deg\n"
              + "".join(f"{int(t * 1000)},{int(p * 40)},{p:.12g},{a:.12g}\n" for t, p, a in zip(T, P_KPA, A)),
              columns={"millis": "time_ms"}, pressure_reference="gauge")
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    assert "pressure_raw" in lg.reading["ignored_columns"]
    lg = read("supply.csv", "time_s,pressure_kpa,p_supply_kpa,tank_pressure_kpa,angle_deg,angle_imu_deg\n"
              + _rows(T, P_KPA, np.full(T.size, 600.0), np.full(T.size, 800.0), A, A + 0.5), pressure_reference="gauge")
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    np.testing.assert_allclose(lg.angle_deg, A)
    assert sum("set aside" in w for w in lg.warnings) == 3   # never in silence: each named, with its --columns
    for other in ("p_meas_kpa", "pressure2_kpa", "p_out_kpa"):   # bpmid's plain name holds a constant supply
        with pytest.raises(InputError, match="barely moves"):
            read("held.csv", f"time_s,pressure_kpa,{other},angle_deg\n" + _rows(T, 600.0 + 0.01 * T, P_KPA, A),
                 pressure_reference="gauge")
    with pytest.raises(InputError, match="two columns could be the pressure"):   # the muscle's own: asked
        read("chamber.csv", "time_s,pressure_kpa,chamber_pressure_kpa,angle_deg\n"
             + _rows(T, np.full(T.size, 600.0), P_KPA, A), pressure_reference="gauge")
    lg = read("savetxt.txt", "# time_s pressure_kpa angle_deg\n"
              + "".join(f"{t:.18e} {p:.18e} {a:.18e}\n" for t, p, a in zip(T, P_KPA, A)), pressure_reference="gauge")
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    psi = 6894.757293168
    lg = read("instr.txt", "Instrument: XYZ-100\nSample Rate: 10 Hz\nPressure Reference: Gauge\nTime Units: ms\n"
              "Pressure Units: psi\nAngle Units: deg\nTime\tPressure\tAngle\n"
              + _rows(T * 1000, P_KPA * 1e3 / psi, A, sep="\t"))
    np.testing.assert_allclose(lg.time_s, T, atol=1e-9)
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e3, atol=1e-6)
    stamps = [f"01-Mar-2026 10:00:{t:06.3f}" for t in T]
    lg = read("matlab.csv", "Timestamp,pressure_kpa,angle_deg\n"
              + "".join(f"{s},{p:.12g},{a:.12g}\n" for s, p, a in zip(stamps, P_KPA, A)), pressure_reference="gauge")
    np.testing.assert_allclose(lg.time_s, T, atol=1e-6)
    rl = tmp_path / "bluehill.csv"
    rl.write_text('"Results Table 1"\n"Sample ID","S-03"\n"Specimen label","1"\n"Gauge length","50","mm"\n'
                  '"Width","4","mm"\n\n"Time","Strain","Stress"\n"(s)","(%)","(MPa)"\n'
                  + "".join(f'"{t:.3f}","20","{1.0 - 0.01 * k:.4f}"\n' for k, t in enumerate(T)))
    np.testing.assert_allclose(read_relax_log(rl).strain, 0.2)
    lg = read("abs.csv", "# atmosphere_pa: 98500\ntime_s,pressure_kpa_abs,angle_deg\n" + _rows(T, P_KPA + 98.5, A))
    back = read_motion_log(write_motion_log(tmp_path / "back.csv", lg, unit="kpa"))
    np.testing.assert_allclose(back.pressure_pa, P_KPA * 1e3, atol=1e-6)


def test_seventh_round_creep_tests_and_one_channel_in_two_rounded_units(tmp_path):
    """A creep test holds the muscle's pressure while the supply or a tank moves: bpmid's plain name is still the
    log's (set aside with a warning, not refused); one channel exported in two units, each rounded, is one channel."""
    def read(name, text, **kw):
        f = tmp_path / name
        f.write_text(text)
        return read_motion_log(f, IOConfig(**kw))

    held = np.full(T.size, 300.0)
    for other in ("p_supply_kpa", "tank_pressure_kpa", "vacuum_kpa"):
        lg = read("creep.csv", f"time_s,pressure_kpa,{other},angle_deg\n"
                  + _rows(T, held, 600.0 - 400.0 * T, A), pressure_reference="gauge")
        np.testing.assert_allclose(lg.pressure_pa, 300e3)
        assert any("set aside" in w and other in w for w in lg.warnings)
    psi = 6894.757293168
    lg = read("two_units.csv", "time_s,pressure_kpa,pressure_psi,angle_deg,angle_rad\n" + "".join(
        f"{t:.12g},{p:.12g},{p * 1e3 / psi:.2f},{a:.12g},{np.radians(a):.4f}\n" for t, p, a in zip(T, P_KPA * 10, A)),
        pressure_reference="gauge")
    np.testing.assert_allclose(lg.pressure_pa, P_KPA * 1e4, atol=1e-6)


def test_a_decimal_comma_stored_as_text_in_a_sheet_is_told_to_be_formatted_as_a_number(tmp_path):
    import openpyxl

    wb = openpyxl.Workbook()
    ws = wb.active
    ws.append(["# pressure_reference: gauge"])
    ws.append(["time_s", "pressure_kpa", "angle_deg"])
    for k in range(5):
        ws.append([0.1 * k, "20,5" if k == 2 else 20.0 + k, float(k)])
    wb.save(tmp_path / "text.xlsx")
    with pytest.raises(InputError) as e:
        read_motion_log(tmp_path / "text.xlsx")
    msg = e.value.message
    assert "'20,5' is not a number" in msg and "format the column's cells as numbers" in msg
    assert "comma-separated file" not in msg


def test_dotted_day_first_date_times_are_read_and_slashed_dates_refused(tmp_path):
    """'30.03.2025 01:59:40,0' (a German instrument's stamp, with the decimal comma of a ';' file) is day-first by
    its form: read as seconds since the first. '03/04/2025 12:59:40.0 PM' may be 3 April or 4 March: refused."""
    t = np.array([0.0, 0.1, 0.25, 1.5, 61.0])
    stamps = ["30.03.2025 01:59:40,0", "30.03.2025 01:59:40,1", "30.03.2025 01:59:40,25", "30.03.2025 01:59:41,5",
              "30.03.2025 02:00:41,0"]
    f = tmp_path / "de.csv"
    f.write_text("# pressure_reference: gauge\nZeit;Druck (kPa);Winkel (deg)\n"
                 + "".join(f"{s};{20 + k},5;{k},0\n" for k, s in enumerate(stamps)))
    lg = read_motion_log(f)
    np.testing.assert_allclose(lg.time_s, t, atol=1e-9)
    assert lg.pressure_pa[1] == pytest.approx(21.5e3)
    g = tmp_path / "us.csv"
    g.write_text("# pressure_reference: gauge\nTime,pressure_kpa,angle_deg\n"
                 + "".join(f"03/04/2025 12:59:4{k}.0 PM,{20 + k},{k}\n" for k in range(4)))
    with pytest.raises(InputError, match="date with slashes") as e:
        read_motion_log(g)
    assert e.value.line == 3 and "ISO 8601" in e.value.message
