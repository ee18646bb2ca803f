"""Material-test files as instrument software writes them (TRIOS, RheoCompass, Proteus, STARe, Excel with title
rows), read against a known Prony series and WLF shift; and the ways such files used to give a wrong number
without a word (a units row against the header, sets merged across temperatures, ramp-and-hold logs pooled across
temperatures, a frequency without a unit, a column map that was ignored)."""
import numpy as np
import pytest
import yaml

from bpmid.errors import InputError
from bpmid.io.material_files import read_material_file
from bpmid.io.relax_logs import read_relax_logs
from tests.test_relax_review import C1, C2, E_INF, T_REF, fit, sweeps

F = np.logspace(-1, 2, 10)
TS = (20.0, 30.0, 40.0, 50.0, 60.0)


def _table(rows, header, units=None, delim="\t", above=(), between=None):
    """Text of an export: lines ``above`` the header, then the header, units row and data; with ``between``, the
    header (and units) repeated before each set after lines ``between(T)``, as TRIOS writes one step per set."""
    out, last = list(above), None
    for r in rows:
        if last is None or (between is not None and r[3] != last):
            if last is not None or between is not None:
                out += between(r[3]) if between is not None else []
            if last is None or between is not None:
                out.append(delim.join(header))
                out += [delim.join(units)] if units else []
        last = r[3]
        out.append(delim.join(f"{v:.6g}" for v in r[:4]))
    return "\n".join(out) + "\n"


def _check_master(res, out):
    assert res.exit_code == 0, res.output
    body = yaml.safe_load(out.read_text())
    wlf = body["shift"]["wlf"]
    assert abs(wlf["C1"] - C1) < 0.3 and abs(wlf["C2"] - C2) < 3.0
    return body


def test_instrument_block_above_the_header_utf16_and_step_tables_are_read(tmp_path):
    rows = [(f, s, l, T) for f, s, l, T, _ in sweeps(TS, F)]
    head, units = ["Angular frequency", "Storage modulus E'", "Loss modulus E''", "Temperature"], \
        ["rad/s", "MPa", "MPa", "°C"]
    rad = [(2 * np.pi * f, s, l, T) for f, s, l, T in rows]
    head = ["Angular frequency", "E'", "E''", "Temperature"]
    trios = _table(rad, head, units, above=["Filename\tsample_7", "Instrument\tDMA 850", "Geometry\tTension", ""],
                   between=lambda T: ["[step]", f"Frequency sweep ({T:.0f} °C)"])
    (tmp_path / "trios.txt").write_text(trios)
    res, out = fit(tmp_path, tmp_path / "trios.txt", "--ref-temp", T_REF)
    _check_master(res, out)
    # the same export in UTF-16 (with its byte-order mark), as some instrument software saves text
    (tmp_path / "u16.txt").write_bytes(trios.encode("utf-16"))
    res, out = fit(tmp_path, tmp_path / "u16.txt", "--ref-temp", T_REF)
    _check_master(res, out)
    # Netzsch-style slash units and Mettler-style space units, semicolons and decimal commas, a units row in brackets
    net = _table(rows, ["Freq./Hz", "E'/MPa", "E''/MPa", "Temp./°C"], delim=";", above=["Project;PU foam"])
    lines = net.splitlines()
    (tmp_path / "net.csv").write_text("\n".join(lines[:2] + [ln.replace(".", ",") for ln in lines[2:]]) + "\n")
    _check_master(*fit(tmp_path, tmp_path / "net.csv", "--ref-temp", T_REF))
    met = _table(rows, ["Frequency Hz", "E' MPa", "E'' MPa", "Temperature °C"])
    (tmp_path / "met.txt").write_text(met)
    _check_master(*fit(tmp_path, tmp_path / "met.txt", "--ref-temp", T_REF))
    ap = _table(rows, ["Frequency", "E'", "E''", "Temperature"], ["[Hz]", "[MPa]", "[MPa]", "[°C]"],
                above=["Project:\tPU", "Test:\tFS_TTS"])
    (tmp_path / "ap.txt").write_text(ap)
    _check_master(*fit(tmp_path, tmp_path / "ap.txt", "--ref-temp", T_REF))


def test_excel_title_rows_above_the_header_are_skipped(tmp_path):
    openpyxl = pytest.importorskip("openpyxl")
    wb = openpyxl.Workbook()
    ws = wb.active
    ws.title = "Data"
    ws.append(["DMA frequency sweep, sample 7"])
    ws.append([])
    ws.append(["Frequency (Hz)", "E' (MPa)", "E'' (MPa)", "Temperature (°C)"])
    for f, s, l, T, _ in sweeps(TS, F):
        ws.append([f, s, l, T])
    wb.save(tmp_path / "x.xlsx")
    d = read_material_file(tmp_path / "x.xlsx")
    assert d.n == len(TS) * F.size and d.lines[0] == 4 and len(d.sets()) == len(TS)
    _check_master(*fit(tmp_path, tmp_path / "x.xlsx", "--ref-temp", T_REF))


def test_a_units_row_against_the_header_is_refused_naming_both(tmp_path):
    rows = [(f, s, l, T) for f, s, l, T, _ in sweeps(TS, F)]
    for head, units, said in ((["Frequency (Hz)", "E' (kPa)", "E'' (kPa)", "T (C)"], ["Hz", "MPa", "MPa", "C"],
                               "its name says 'kpa' and the units row under the header says 'mpa'"),
                              (["Frequency (Hz)", "E' (MPa)", "E'' (MPa)", "T (C)"], ["rad/s", "MPa", "MPa", "C"],
                               "its name says 'hz' and the units row under the header says 'rad/s'")):
        p = tmp_path / "c.csv"
        p.write_text(_table(rows, head, units, delim=","))
        with pytest.raises(InputError) as e:
            read_material_file(p)
        assert said in str(e.value) and e.value.line == 2
    # units that agree in other spellings are fine
    p.write_text(_table(rows, ["Frequency (Hz)", "E' (MPa)", "E'' (MPa)", "T (C)"], ["1/s", "N/mm2", "MPa", "°C"],
                        delim=","))
    assert read_material_file(p).n == len(rows)


def test_a_frequency_without_a_unit_is_refused_but_the_documented_f_is_hz(tmp_path):
    rows = [(f, s, l, T) for f, s, l, T, _ in sweeps((20.0,), F)]
    p = tmp_path / "nu.csv"
    p.write_text(_table(rows, ["Frequency", "E' (MPa)", "E'' (MPa)", "T (C)"], delim=","))
    with pytest.raises(InputError, match="'Frequency' states no unit.*Hz or in rad/s") as e:
        read_material_file(p)
    assert e.value.key == "Frequency"
    p.write_text(_table(rows, ["f", "E' (MPa)", "E'' (MPa)", "T (C)"], delim=","))
    np.testing.assert_allclose(read_material_file(p).x, F, rtol=1e-5)


def test_a_sweep_continued_at_another_temperature_is_two_sets_and_a_drifting_set_is_refused(tmp_path):
    # 40 C from 0.1 to 3 Hz, then 30 C from 4 to 100 Hz, no Set column: two sets, not one at 35 C
    lo, hi = np.logspace(-1, 0.5, 7), np.logspace(0.6, 2, 7)
    rows = [(f, s, l, T) for f, s, l, T, _ in sweeps((40.0,), lo)] + [(f, s, l, T) for f, s, l, T, _ in
                                                                      sweeps((30.0,), hi)]
    p = tmp_path / "cont.csv"
    p.write_text(_table(rows, ["f (Hz)", "E' (MPa)", "E'' (MPa)", "T (C)"], delim=","))
    assert [T for T, _ in read_material_file(p).sets()] == [40.0, 30.0]
    # a thermocouple's one-sample glitch of +2.2 C inside the 40 C sweep starts no set
    glitch = [r[:3] + (r[3] + 2.2 if k == 3 else r[3],) for k, r in enumerate(rows)]
    p.write_text(_table(glitch, ["f (Hz)", "E' (MPa)", "E'' (MPa)", "T (C)"], delim=","))
    assert [T for T, _ in read_material_file(p).sets()] == [40.0, 30.0]
    # one frequency while the temperature ramps 20 -> 30 C in 1 C steps: not an isothermal sweep
    ramp = [(1.0, 10.0 - 0.1 * k, 1.0, 20.0 + k) for k in range(11)]
    p.write_text(_table(ramp, ["f (Hz)", "E' (MPa)", "E'' (MPa)", "T (C)"], delim=","))
    with pytest.raises(InputError, match="spans 20 to 30 C: a set is one isothermal sweep"):
        read_material_file(p)


def test_files_without_temperatures_and_a_repeated_set_are_refused_naming_the_right_ones(tmp_path):
    rows = sweeps(TS, F)
    for T in TS:
        part = [(f, s, l, t) for f, s, l, t, _ in rows if abs(t - T) < 1]
        (tmp_path / f"s{T:.0f}.csv").write_text(_table(part, ["f (Hz)", "E' (MPa)", "E'' (MPa)", "T (C)"], delim=","))
        (tmp_path / f"n{T:.0f}.csv").write_text(f"# Temperature: {T:.0f} C\n" + _table(
            [r[:3] + (0,) for r in part], ["f (Hz)", "E' (MPa)", "E'' (MPa)"], delim=",").replace(",0\n", "\n"))
    res, _ = fit(tmp_path, tmp_path / "n20.csv", tmp_path / "n30.csv")
    assert res.exit_code == 2 and "n20.csv has no temperature column" in res.output and "Traceback" not in res.output
    (tmp_path / "s30b.csv").write_text((tmp_path / "s30.csv").read_text())
    res, _ = fit(tmp_path, *(tmp_path / f"s{T:.0f}.csv" for T in TS), tmp_path / "s30b.csv", "--ref-temp", T_REF)
    assert res.exit_code == 2 and "two sets at 30 C (s30.csv line 2, s30b.csv line 2" in res.output


def test_ramp_and_hold_logs_at_different_temperatures_are_not_pooled(tmp_path):
    t = np.arange(0.0, 60.0, 0.1)
    strain = np.minimum(t, 1.0) * 0.05
    paths = []
    for T in (20.0, 40.0):
        stress = 2.0 * strain + 1.0 * strain * np.exp(-t / (5.0 * (1 if T == 20 else 0.1)))
        p = tmp_path / f"rh{T:.0f}.csv"
        p.write_text("Time (s),Strain,Stress (MPa),Temperature (°C)\n" + "".join(
            f"{a:.3f},{b:.6f},{c:.6f},{T + 0.02 * (k % 3):.2f}\n" for k, (a, b, c) in enumerate(zip(t, strain,
                                                                                               stress))))
        paths.append(p)
    with pytest.raises(InputError, match=r"tested at different temperatures \(rh20.csv 20 C \('Temperature \(°C\)'\), rh40.csv 40 C"):
        read_relax_logs(paths)
    res, _ = fit(tmp_path, *paths)
    assert res.exit_code == 2 and "fit each temperature on its own" in res.output
    T, unit, column = read_relax_logs(paths[:1])[0].temperature
    assert T == pytest.approx(20.02, abs=0.02) and unit == "C" and column == "Temperature (°C)"


def test_a_ramp_and_hold_log_whose_temperature_moves_during_the_test_is_refused(tmp_path):
    t = np.arange(0.0, 60.0, 0.1)
    strain = np.minimum(t, 1.0) * 0.05
    stress = 2.0 * strain + 1.0 * strain * np.exp(-t / 5.0)

    def log(name, temps, head="Temperature (°C)"):
        p = tmp_path / name
        p.write_text(f"Time (s),Strain,Stress (MPa),{head}\n" + "".join(
            f"{a:.3f},{b:.6f},{c:.6f},{T:.2f}\n" for a, b, c, T in zip(t, strain, stress, temps)))
        return p

    warming = log("warming.csv", 20.0 + 10.0 * t / t[-1])           # 20 -> 30 C while it relaxes
    with pytest.raises(InputError, match=r"column 'Temperature \(°C\)' moves from 20.1 C to 29.9 C during the test"):
        read_relax_logs([warming])
    res, _ = fit(tmp_path, warming)
    assert res.exit_code == 2 and "warming.csv" in res.output and "one temperature" in res.output
    assert "Traceback" not in res.output
    kelvin = log("kelvin.csv", 293.15 + 8.0 * t / t[-1], head="T [K]")  # 8 K is 8 C
    with pytest.raises(InputError, match="moves from 20.1 C to 27.9 C"):
        read_relax_logs([kelvin])
    glitch = np.full(t.size, 25.0)
    glitch[100] = 85.0                                               # one bad sample is no temperature change
    assert read_relax_logs([log("glitch.csv", glitch)])[0].temperature[0] == pytest.approx(25.1, abs=0.05)
    steady = log("steady.csv", 25.0 + 2.0 * t / t[-1])              # 2 C of drift: within one temperature
    assert read_relax_logs([steady])[0].temperature[1] == "C"


def test_a_bare_T_beside_a_time_column_is_set_aside_as_a_temperature_and_said(tmp_path):
    from bpmid.io.motion_logs import read_motion_log

    t = np.arange(0.0, 60.0, 0.1)
    strain = np.minimum(t, 1.0) * 0.05
    stress = 2.0 * strain + 1.0 * strain * np.exp(-t / 5.0)
    paths = []
    for T in (20.0, 40.0):
        p = tmp_path / f"bare{T:.0f}.csv"
        p.write_text("Time (s),Strain,Stress (MPa),T\n" + "".join(
            f"{a:.3f},{b:.6f},{c:.6f},{T:.1f}\n" for a, b, c in zip(t, strain, stress)))
        paths.append(p)
    log = read_relax_logs(paths[:1])[0]
    assert np.allclose(log.time_s, t) and log.temperature == (pytest.approx(20.0), None, "T")
    assert any("set aside the column 'T'" in w and "--columns time=T" in w for w in log.warnings)
    with pytest.raises(InputError, match="tested at different temperatures"):
        read_relax_logs(paths)                       # the set-aside T is still compared, as written
    m = tmp_path / "motion.csv"
    m.write_text("time_s,T,pressure_kpa_g,angle_deg\n" + "".join(f"{k * 0.1:.1f},23.5,{k:.1f},{k / 10:.2f}\n"
                                                               for k in range(50)))
    ml = read_motion_log(m)
    assert np.allclose(ml.time_s, np.arange(50) * 0.1)
    assert any("set aside the column 'T'" in w for w in ml.warnings)


def test_the_column_map_reaches_material_files_and_keeps_the_headers_unit(tmp_path):
    rows = [(f, s, l, T) for f, s, l, T, _ in sweeps(TS, F)]
    p = tmp_path / "odd.csv"
    p.write_text(_table(rows, ["Stimulus (rad/s)", "E' (MPa)", "E'' (MPa)", "Chamber (C)"], delim=","))
    res, _ = fit(tmp_path, p, "--ref-temp", T_REF)
    assert res.exit_code == 2 and "--columns f=<your column>" in res.output
    # mapped to f, the header's rad/s still holds (not the f's documented Hz)
    res, out = fit(tmp_path, p, "--ref-temp", T_REF, "--columns", "f=Stimulus (rad/s),T=Chamber (C)")
    body = _check_master(res, out)
    assert body["data"]["units_in_file"]["odd.csv"]["f"] == "rad/s"
    res, _ = fit(tmp_path, p, "--ref-temp", T_REF, "--columns", "f_hz=Stimulus (rad/s),T=Chamber (C)")
    assert res.exit_code == 2 and "the column map (--columns, config columns) says 'hz' and its name says 'rad/s'" \
        in res.output
    assert E_INF > 0


def test_second_review_of_the_reader(tmp_path):
    """A second trial's files: each was read wrong, refused for the wrong reason, or refused with advice that did not
    work."""
    rows = [(f, s, l, T) for f, s, l, T, _ in sweeps(TS, F)]

    def write(name, text):
        (tmp_path / name).write_text(text)
        return tmp_path / name

    # millihertz and megahertz are one spelling once lower-cased: refused, never read 1e9 off
    with pytest.raises(InputError, match="mHz or MHz"):
        read_material_file(write("m.csv", _table([(1e3 * f, s, l, T) for f, s, l, T in rows],
                                                 ["Frequency (mHz)", "E' (MPa)", "E'' (MPa)", "T (C)"], delim=",")))
    # a parameters line naming two known columns above the header; Proteus's '##' header; a comment line between
    # header and units row; a Set column's '1' in the units row; an elapsed clock time beside the frequency
    above = ["Parameters", "Temperature\tFrequency", "25\t1", ""]
    d = read_material_file(write("p.txt", _table(rows, ["Frequency", "E'", "E''", "Temperature"],
                                                 ["Hz", "MPa", "MPa", "°C"], above=above)))
    assert d.n == len(rows) and len(d.sets()) == len(TS)
    pro = _table(rows, ["Freq./Hz", "E'/MPa", "E''/MPa", "Temp./°C"], delim=";", above=["#Instrument: DMA 303"])
    assert read_material_file(write("pro.csv", pro.replace("Freq./Hz", "##Freq./Hz"))).n == len(rows)
    text = _table(rows, ["f", "E_stor", "E_loss", "T", "Set"][:4], ["Hz", "MPa", "MPa", "C"], delim=",")
    lines = text.splitlines()
    assert read_material_file(write("c.csv", "\n".join([lines[0], "# exported by DMA v2"] + lines[1:]))).n == len(rows)
    with_set = [r + (k // F.size,) for k, r in enumerate(rows)]
    t2 = "f,E_stor,E_loss,T,Set\nHz,MPa,MPa,C,1\n" + "".join(",".join(f"{v:.6g}" for v in r) + "\n" for r in with_set)
    assert read_material_file(write("u1.csv", t2)).n == len(rows)
    clock = "Time\tFrequency\tE'\tE''\tTemperature\n[hh:mm:ss]\t[Hz]\t[MPa]\t[MPa]\t[°C]\n" + "".join(
        f"00:00:{k % 60:02d}\t{f:.6g}\t{s:.6g}\t{l:.6g}\t{T:.4g}\n" for k, (f, s, l, T) in enumerate(rows))
    assert read_material_file(write("clock.txt", clock)).n == len(rows)
    # UTF-16 without a byte-order mark; a step table whose units change is refused as such, not misrouted
    (tmp_path / "nobom.txt").write_bytes(_table(rows, ["Frequency", "E'", "E''", "Temperature"],
                                                ["Hz", "MPa", "MPa", "°C"]).encode("utf-16-le"))
    assert read_material_file(tmp_path / "nobom.txt").n == len(rows)
    steps = _table(rows, ["Frequency", "E'", "E''", "Temperature"], ["Hz", "MPa", "MPa", "°C"],
                   between=lambda T: ["[step]"])
    k = steps.index("[step]", steps.index("[step]") + 1)
    res, _ = fit(tmp_path, write("s.txt", steps[:k] + steps[k:].replace("MPa", "Pa")), "--ref-temp", T_REF)
    assert res.exit_code == 2 and "the table repeated at line" in res.output and "Pa, Pa" in res.output
    summary = _table(rows, ["Frequency", "E'", "E''", "Temperature"], ["Hz", "MPa", "MPa", "°C"]) + "[Summary]\tx\n"
    with pytest.raises(InputError, match=r"starts a section '\[Summary\]'"):
        read_material_file(write("sum.txt", summary))


def test_the_map_picks_one_of_two_temperatures_and_long_names_keep_their_units(tmp_path):
    rows = [(f, s, l, T) for f, s, l, T, _ in sweeps(TS, F)]
    text = "Frequency (Hz),Storage modulus E' MPa,Loss modulus E'' MPa,Temperature (°C),Sample temp °C\n" + "".join(
        f"{f:.6g},{s:.6g},{l:.6g},{T + 3:.4g},{T:.4g}\n" for f, s, l, T in rows)
    (tmp_path / "two.csv").write_text(text)
    d = read_material_file(tmp_path / "two.csv")  # the furnace's: said, with the other set aside
    assert np.allclose(d.temperature_c, [T + 3 for *_, T in rows], atol=0.01)
    assert any("'Sample temp °C' set aside" in w for w in d.warnings)
    d = read_material_file(tmp_path / "two.csv", column_map={"Sample temp °C": "T"})  # its °C holds
    assert np.allclose(d.temperature_c, [T for *_, T in rows], atol=0.01)
    assert any("'Temperature (°C)' set aside" in w for w in d.warnings)
    openpyxl = pytest.importorskip("openpyxl")
    wb = openpyxl.Workbook()
    wb.active.title = "Parameters"
    wb.active.append(["Frequency (Hz)", "Temperature (°C)"])
    wb.active.append([1.0, 25.0])
    ws = wb.create_sheet("Exported Data")
    ws.append(["Frequency (Hz)", "E' (MPa)", "E'' (MPa)", "Temperature (°C)"])
    for r in rows:
        ws.append(list(r))
    wb.save(tmp_path / "two.xlsx")
    assert read_material_file(tmp_path / "two.xlsx").sheet == "Exported Data"
    with pytest.raises(InputError, match="no sheet 'Data'"):
        read_material_file(tmp_path / "two.xlsx", sheet="Data")


def test_a_set_whose_temperature_drifts_while_it_is_swept_is_warned(tmp_path):
    rng = np.random.default_rng(5)
    rows = []
    for f, s, l, T, _ in sweeps(TS, F, noise=0.002):
        k = int(np.argmin(np.abs(F - f)))
        rows.append((f, s, l, T + (1.5 * (k / (F.size - 1) - 0.5) if abs(T - 30.0) < 0.5 else 0.0) + 0.01 * rng.standard_normal()))
    (tmp_path / "drift.csv").write_text(_table(rows, ["f (Hz)", "E' (MPa)", "E'' (MPa)", "T (C)"], delim=","))
    res, out = fit(tmp_path, tmp_path / "drift.csv", "--ref-temp", T_REF)
    assert res.exit_code == 0, res.output
    said = [w for w in yaml.safe_load(out.read_text())["warnings"] if "drifts" in w]
    assert len(said) == 1 and "the set at 30 C" in said[0] and "drifts over 1.5 C" in said[0]


def test_ramp_and_hold_temperatures_in_f_without_a_unit_or_under_another_name_are_compared(tmp_path):
    t = np.arange(0.0, 30.0, 0.1)
    strain = np.minimum(t, 1.0) * 0.05

    def log(name, head, T):
        p = tmp_path / name
        p.write_text(f"time_s,strain,stress_mpa,{head}\n" + "".join(
            f"{a:.3f},{b:.6f},{2 * b + b * np.exp(-a / 5):.6f},{T:.2f}\n" for a, b in zip(t, strain)))
        return p

    base = log("c20.csv", "Temperature (°C)", 20.0)
    for name, head, T in (("f104.csv", "Temperature °F", 104.0), ("bare.csv", "Temperature", 40.0),
                          ("ch.csv", "Chamber temperature (°C)", 40.0)):
        with pytest.raises(InputError, match="tested at different temperatures"):
            read_relax_logs([base, log(name, head, T)])
    assert len(read_relax_logs([base, log("f70.csv", "Temperature (°F)", 70.0)])) == 2  # 21.1 C: one temperature
    # a map that names the test temperature: read as a temperature (a T would otherwise be the time), and compared
    ch = log("ch2.csv", "Chamber (°C)", 40.0)
    with pytest.raises(InputError, match=r"ch2.csv 40 C \('Chamber \(°C\)'\)"):
        read_relax_logs([base, ch], column_map={"Chamber (°C)": "T"})


def test_a_short_glitch_and_a_machine_temperature_do_not_refuse_a_ramp_and_hold_log(tmp_path):
    """Two glitch samples in a short log (the 1st-99th percentiles alone let them through in long logs only), and
    a motor's temperature rising, refused the log; a rolling median and the specimen's columns only."""
    t = np.arange(0.0, 12.5, 0.1)
    strain = np.minimum(t, 1.0) * 0.05
    stress = 2.0 * strain + 1.0 * strain * np.exp(-t / 5.0)
    temps = np.full(t.size, 25.0)
    temps[[40, 41]] = 90.0
    p = tmp_path / "short.csv"
    p.write_text("Time (s),Strain,Stress (MPa),Temperature (°C),Motor temperature (°C)\n" + "".join(
        f"{a:.3f},{b:.6f},{c:.6f},{T:.2f},{30 + 2 * a:.2f}\n" for a, b, c, T in zip(t, strain, stress, temps)))
    lg = read_relax_logs([p])[0]
    assert lg.temperature[2] == "Temperature (°C)" and lg.temperature[0] == pytest.approx(26.0, abs=1.5)


def test_a_brief_temperature_excursion_that_comes_back_is_warned_not_refused(tmp_path):
    """An open thermocouple for 0.8 s (1372 C, then back) refused the log; it is said and the log read."""
    t = np.arange(0.0, 62.0, 0.02)
    strain = np.minimum(t, 1.0) * 0.05
    stress = 2.0 * strain + 1.0 * strain * np.exp(-t / 5.0)
    temps = np.full(t.size, 23.0)
    temps[1000:1040] = 1372.0
    p = tmp_path / "tc.csv"
    p.write_text("Time (s),Strain,Stress (MPa),Temperature (°C)\n" + "".join(
        f"{a:.3f},{b:.6f},{c:.6f},{T:.1f}\n" for a, b, c, T in zip(t, strain, stress, temps)))
    lg = read_relax_logs([p])[0]
    assert lg.temperature[0] == pytest.approx(23.0)
    assert any("leaves 23 C for 40 of" in w and "comes back" in w for w in lg.warnings)


def test_kelvin_under_a_celsius_header_and_the_reverse_are_warned_and_below_absolute_zero_refused(tmp_path):
    """A sweep at 293-333 K under 'T (C)' read as 293-333 C with no word (a trial's file); 20-60 C under 'T (K)' read
    as -253 to -213 C. Each is warned about with the column and the fix; the right headers read without a warning;
    a temperature below absolute zero is refused naming its line."""
    header = ["f (Hz)", "E' (MPa)", "E'' (MPa)", "T ({})"]
    rows = [(f, s, l, T) for f, s, l, T, _ in sweeps(TS, F)]
    kelvin = [r[:3] + (r[3] + 273.15,) for r in rows]
    p = tmp_path / "k.csv"
    p.write_text(_table(kelvin, [*header[:3], header[3].format("C")], delim=","))
    d = read_material_file(p)
    assert any("kelvin under a degrees C header?" in w and "column 'T (C)' is 293" in w and "'T (K)'" in w
               for w in d.warnings), d.warnings
    p.write_text(_table(kelvin, [*header[:3], header[3].format("K")], delim=","))
    d = read_material_file(p)
    assert not [w for w in d.warnings if "header?" in w] and [T for T, _ in d.sets()] == list(TS)
    p.write_text(_table(rows, [*header[:3], header[3].format("K")], delim=","))
    assert any("degrees C under a kelvin header?" in w and "name the column 'T (C)'" in w
               for w in read_material_file(p).warnings)
    p.write_text(_table(rows, [*header[:3], header[3].format("C")], delim=","))
    assert not [w for w in read_material_file(p).warnings if "header?" in w]
    below = [r[:3] + ({4: -280.0, 9: -300.0}.get(k, r[3]),) for k, r in enumerate(rows)]
    p.write_text(_table(below, [*header[:3], header[3].format("C")], delim=","))
    with pytest.raises(InputError, match="below absolute zero") as e:
        read_material_file(p)
    assert e.value.line == 6   # the first such line, not the lowest value's


def test_the_unit_warning_names_the_units_row_and_reaches_an_error_the_fit_then_raises(tmp_path):
    """Kelvin under a units row's 'C': the fix is the units row (renaming the column 'T (K)' is refused as two units
    for one column), and when the fit then fails on what that slip causes (--ref-temp 20 C outside 293-333 'C') the
    error repeats the reading's warning instead of dropping it (it was printed only after a fit that succeeded)."""
    from bpmid.relax.result import fit_relax_files

    rows = [(f, s, l, T + 273.15) for f, s, l, T, _ in sweeps(TS, F)]
    p = tmp_path / "ku.csv"
    p.write_text(_table(rows, ["f", "E_stor", "E_loss", "T"], units=["Hz", "MPa", "MPa", "C"], delim=","))
    assert any("kelvin under a degrees C header?" in w and "write K in the units row under the header for column "
               "'T'" in w for w in read_material_file(p).warnings), read_material_file(p).warnings
    with pytest.raises(InputError, match="outside the set temperatures") as e:
        fit_relax_files([p], ref_temp=20.0)
    assert "reading the data warned" in e.value.message and "kelvin under a degrees C header?" in e.value.message
    assert e.value.key == "--ref-temp"
