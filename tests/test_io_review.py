"""Log reading after a new-user review: unit statements that disagree, plausibility hints that work, column maps
that match nothing. Small inline logs only; every CLI case goes through Typer's CliRunner."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from bpmid.cli import app
from bpmid.errors import InputError
from bpmid.io.motion_logs import IOConfig, read_motion_log
from bpmid.models.vbmm import VBMM, Material, vbmm_yaml_body

runner = CliRunner()


def _params(tmp_path: Path) -> Path:
    data = {"schema": "bpmid.vbmm/1", **vbmm_yaml_body(VBMM(material=Material.paper_fit()))}
    data["metrics"] = {"rmse_deg": 1.0, "mape_pct": 2.0, "r2": 0.9}
    p = tmp_path / "p.yaml"
    p.write_text(yaml.safe_dump(data, sort_keys=False))
    return p


def _motion(head: str, header: str = "time_s,pressure_bar,angle_deg", *, n: int = 40, t_scale: float = 1.0,
            a_scale: float = 1.0, p_scale: float = 1.0) -> str:
    """A small absolute-pressure log (a ramp up and down, 0.1 s steps): ``head`` lines, then the header and rows."""
    rng = np.random.default_rng(7)
    t = np.arange(n) * 0.1
    p = 1.2 + 0.4 * np.sin(np.pi * t / t[-1])
    a = VBMM(material=Material.paper_fit()).forward_deg(t, p * 1e5 - 101325.0) + rng.normal(0, 0.1, n)
    rows = "".join(f"{ti * t_scale:.10g},{pi * p_scale:.5f},{ai * a_scale:.5f}\n" for ti, pi, ai in zip(t, p, a))
    return head + header + "\n" + rows


def _write(tmp_path: Path, name: str, text: str) -> Path:
    f = tmp_path / name
    f.write_text(text)
    return f


# ---- item 1: a '# <quantity>_unit:' line that contradicts the header -------------------------------------------
@pytest.mark.parametrize("line, column, says", [
    ("# pressure_unit: kPa", "pressure_bar", "kPa"),
    ("# angle_unit: rad", "angle_deg", "rad"),
    ("# Time unit: ms", "time_s", "ms"),
])
def test_a_unit_line_that_contradicts_the_header_is_refused(tmp_path, line, column, says):
    log = _write(tmp_path, "c.csv", _motion(f"# pressure_reference: absolute\n{line}\n"))
    out = tmp_path / "out"
    res = runner.invoke(app, ["predict", str(log), "--params", str(_params(tmp_path)), "--out", str(out)])
    assert res.exit_code == 2, res.output
    assert f"c.csv:2, key '{column}'" in res.output  # the file, the comment's line, the column
    assert f"says {'time' if 'Time' in line else line.split('_')[0][2:]} is in {says}" in res.output
    assert "a unit stated twice must agree" in res.output and "delete or correct the line" in res.output
    assert not out.exists()


def test_a_unit_line_that_agrees_or_stands_alone_still_works(tmp_path):
    agree = _write(tmp_path, "a.csv", _motion("# pressure_reference: absolute\n# Pressure unit: BAR\n"))
    alone = _write(tmp_path, "b.csv", _motion("# pressure_reference: absolute\n# pressure_unit: bar\n",
                                              "time_s,pressure,angle_deg"))
    ref = _write(tmp_path, "r.csv", _motion("# pressure_unit: bar(a)\n"))  # the line may carry the reference
    logs = [read_motion_log(f) for f in (agree, alone, ref)]
    for lg in logs:
        assert np.allclose(lg.pressure_pa, logs[0].pressure_pa) and lg.pressure_reference == "absolute"
    assert logs[1].reading["columns"]["pressure"]["unit_from"] == "'# pressure_unit:' line"
    res = runner.invoke(app, ["predict", str(agree), str(alone), "--params", str(_params(tmp_path)), "--out",
                              str(tmp_path / "out")])
    assert res.exit_code == 0, res.output


def test_a_unit_line_that_contradicts_a_units_row_names_the_row(tmp_path):
    f = _write(tmp_path, "u.csv", _motion("# angle_unit: rad\n# pressure_reference: absolute\n",
                                          "time,pressure,angle\ns,bar,deg"))
    with pytest.raises(InputError, match=r"the units row under the header \(line 4\) says deg") as e:
        read_motion_log(f)
    assert e.value.line == 1 and e.value.key == "angle"


# ---- item 7: a units row that contradicts the name is worded by where the unit came from ----------------------
def test_a_units_row_conflict_names_the_units_row_not_brackets(tmp_path):
    f = _write(tmp_path, "r.csv", _motion("# pressure_reference: absolute\n", "time_s,pressure_bar,angle_deg\ns,kPa,deg"))
    res = runner.invoke(app, ["predict", str(f), "--params", str(_params(tmp_path)), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2, res.output
    assert "r.csv:3, key 'pressure_bar'" in res.output  # the units row's line
    assert "the units row under the header says kPa" in res.output and "brackets" not in res.output
    assert "rename the column pressure_kpa" in res.output
    g = _write(tmp_path, "b.csv", _motion("# pressure_reference: absolute\n", "time_s,pressure_kpa (bar),angle_deg"))
    with pytest.raises(InputError, match=r"its brackets say bar"):
        read_motion_log(g)


def test_an_unknown_unit_that_is_a_pressure_reference_says_what_works(tmp_path):
    """'p_abs': 'abs' is no unit but a reference, read as the reference (a word of the pressure's name); the unit is
    stated nowhere, and the message offers the forms that read the file, and they do."""
    f = _write(tmp_path, "p.csv", _motion("", "time_s,p_abs,angle_deg"))
    params = str(_params(tmp_path))
    res = runner.invoke(app, ["predict", str(f), "--params", params, "--out", str(tmp_path / "o")])
    assert res.exit_code == 2, res.output
    msg = " ".join(res.output.split())
    assert "the unit of column 'p_abs' (pressure) is stated nowhere" in msg and "--pressure-unit kPa" in msg
    for flags in (["--columns", "pressure_bar_abs=p_abs"], ["--pressure-unit", "bar"],
                  ["--columns", "pressure=p_abs", "--pressure-unit", "bar", "--pressure-reference", "absolute"]):
        out = tmp_path / f"o{len(flags)}"
        res = runner.invoke(app, ["predict", str(f), "--params", params, "--out", str(out), *flags])
        assert res.exit_code == 0, res.output


def test_an_unknown_unit_in_a_units_row_says_to_correct_the_row(tmp_path):
    f = _write(tmp_path, "u.csv", _motion("# pressure_reference: absolute\n", "t,p,angle\nsecs.,bar,deg"))
    with pytest.raises(InputError, match=r"unknown unit 'secs\.' for time .*correct the units row, or map the "
                                         r"column: --columns time_s=t") as e:
        read_motion_log(f)
    assert e.value.line == 3
    assert read_motion_log(f, IOConfig(columns={"t": "time_s"})).n == 40


# ---- item 6: column maps -------------------------------------------------------------------------------------
RELAX_SEMI = "Zeit [s];Dehnung [-];Spannung [MPa]\n" + "".join(
    f"{0.02 * i:.2f};{min(0.002 * i, 0.1):.4f};{0.5 * min(0.002 * i, 0.1) * (1 + np.exp(-0.02 * i)):.6f}\n"
    .replace(".", ",") for i in range(120))


def test_a_map_key_matches_a_header_that_carries_its_unit(tmp_path):
    """'Dehnung' names 'Dehnung [-]' (the header parser reads name and unit apart); the unit comes from the header."""
    f = _write(tmp_path, "semi.csv", RELAX_SEMI)
    out = tmp_path / "r.yaml"
    res = runner.invoke(app, ["fit", "relax", str(f), "--columns", "strain=Dehnung,stress=Spannung", "--out",
                              str(out), "--no-figure"])
    assert res.exit_code == 0, res.output
    reading = yaml.safe_load(out.read_text())["provenance"]["reading"]["semi"]["columns"]
    assert reading["strain"]["column"] == "Dehnung [-]" and reading["stress"]["unit"] == "mpa"
    # a header named exactly as the key wins over one that only carries the key as its name
    from bpmid.io.tables import read_table
    g = _write(tmp_path, "two.csv", "Zeit,Zeit [ms],strain,stress_mpa\n0,0,0,0\n1,1000,0.1,0.1\n")
    t = read_table(g, column_map={"Zeit": "time_s"}, required=("time",))
    assert t.headers["time"] == "Zeit" and np.allclose(t.columns["time"], [0, 1])


def test_map_entries_that_match_no_column_are_named(tmp_path):
    f = _write(tmp_path, "semi.csv", RELAX_SEMI)
    for cols, named in (("strain=Dehnug,stress=Spanung", "'Dehnug', 'Spanung'"), ("strain=Dehnug,stress=Spannung",
                                                                                  "'Dehnug'")):
        res = runner.invoke(app, ["fit", "relax", str(f), "--columns", cols, "--out", str(tmp_path / "r.yaml")])
        assert res.exit_code == 2, res.output
        assert f"the column map names {named}, not a column of this file" in " ".join(res.output.split())


def test_a_reversed_io_columns_map_is_said_to_be_reversed(tmp_path):
    f = _write(tmp_path, "r.csv", _motion("# pressure_reference: absolute\n", "t,p_abs,bend"))
    cfg = _write(tmp_path, "c.yaml", "io:\n  columns: {time_s: t, pressure_bar: p_abs, angle_deg: bend}\n")
    params = str(_params(tmp_path))
    res = runner.invoke(app, ["predict", str(f), "--params", params, "--config", str(cfg), "--out",
                              str(tmp_path / "o")])
    assert res.exit_code == 2, res.output
    msg = " ".join(res.output.split())
    assert "the map looks reversed" in msg and "io.columns maps file column -> quantity" in msg
    assert "io.columns: {t: time_s, p_abs: pressure_bar, bend: angle_deg}" in msg
    assert "--columns time_s=t,pressure_bar=p_abs,angle_deg=bend" in msg
    # a reversed map on a file that reads without it is said too (it was silent), and not applied
    import warnings as _w

    import bpmid

    rad = Path(__file__).parent / "data" / "rig_logs" / "radians_in_deg_column.csv"
    with _w.catch_warnings(record=True) as got:
        _w.simplefilter("always")
        bpmid.fit_motion([rad], config={"io": {"columns": {"angle_rad": "angle_deg"}}})
    said = [str(x.message) for x in got if "looks reversed" in str(x.message)]
    assert said and "io.columns: {angle_deg: angle_rad}" in said[0] and "the map was not applied" in said[0]
    # the two forms the message gives both read the file
    cfg.write_text("io:\n  columns: {t: time_s, p_abs: pressure_bar, bend: angle_deg}\n")
    for extra in (["--config", str(cfg)], ["--columns", "time_s=t,pressure_bar=p_abs,angle_deg=bend"]):
        res = runner.invoke(app, ["predict", str(f), "--params", params, "--out", str(tmp_path / extra[0][2:]),
                                  *extra])
        assert res.exit_code == 0, res.output


def test_a_map_key_that_nearly_names_a_column_is_not_called_reversed_and_every_hint_reads_the_file(tmp_path):
    """Two angle columns: --columns angle_deg=angle_imu (the column is angle_imu_deg) was said to look reversed and
    advised angle_imu=angle_deg, which was refused for an unknown unit 'imu' with the advice angle_deg=angle_deg (a
    map of the column to itself). Each message now gives a map that takes the column meant, and it works."""
    rng = np.random.default_rng(3)
    t = np.arange(40) * 0.1
    p = 1.2 + 0.4 * np.sin(np.pi * t / t[-1])
    a = VBMM(material=Material.paper_fit()).forward_deg(t, p * 1e5 - 101325.0)
    imu = a + 4.0 + rng.normal(0, 0.1, t.size)
    f = _write(tmp_path, "g1.csv", "# pressure_reference: absolute\ntime_s,pressure_bar,angle_deg,angle_imu_deg\n"
               + "".join(f"{ti:.1f},{pi:.5f},{ai:.4f},{bi:.4f}\n" for ti, pi, ai, bi in zip(t, p, a, imu)))
    params = str(_params(tmp_path))

    def run(cols: str, out: str):
        return runner.invoke(app, ["predict", str(f), "--params", params, "--columns", cols, "--out",
                                   str(tmp_path / out)])

    res = run("angle_deg=angle_imu", "a")
    msg = " ".join(res.output.split())
    assert res.exit_code == 0 and "looks reversed" not in msg and "angle_imu=angle_deg" not in msg, res.output
    assert "the column map names 'angle_imu', not a column of this file, which has 'angle_imu_deg'" in msg
    assert "--columns angle_deg=angle_imu_deg" in msg
    res = run("angle_imu=angle_deg", "b")
    msg = " ".join(res.output.split())
    assert res.exit_code == 2 and "g1.csv:2, key 'angle_deg'" in msg and "unknown unit 'imu'" in msg, res.output
    assert "angle_deg=angle_deg" not in msg and "--columns angle=angle_imu_deg" in msg
    for cols, out in (("angle_deg=angle_imu_deg", "c"), ("angle=angle_imu_deg", "d")):
        res = run(cols, out)
        assert res.exit_code == 0, res.output
        assert "angle_imu_deg" in (tmp_path / out / "predict.yaml").read_text()
    # a map of a column to a name with no unit, the column's own name reading already: drop the entry
    with pytest.raises(InputError, match="reads as the angle by its own name: drop the entry"):
        read_motion_log(f, IOConfig(columns={"angle_deg": "angle_xyz"}))


def test_predicts_refusal_of_a_pressure_beyond_the_model_names_the_line_and_the_unit_slip(tmp_path):
    """kPa values under a pressure_bar header: predict refused 'pressure 2.6e+06 Pa gauge at t = ... s is above the
    model's range' with neither a line nor a unit hint (fit motion's warning had both); it now names the file's line
    and column and gives the same hint, and the hint reads the file."""
    t = np.arange(50) * 0.1
    kpa = 20.0 + 250.0 * np.sin(np.pi * t / t[-1])
    rows = "".join(f"{ti:.1f},{pi:.3f},{10 + 0.05 * pi:.3f}\n" for ti, pi in zip(t, kpa))
    f = _write(tmp_path, "kb.csv", "# pressure_reference: gauge\ntime_s,pressure_bar,angle_deg\n" + rows)
    params = str(_params(tmp_path))
    res = runner.invoke(app, ["predict", str(f), "--params", params, "--out", str(tmp_path / "a")])
    msg = " ".join(res.output.split())
    assert res.exit_code == 2 and not (tmp_path / "a").exists(), res.output
    import re as _re
    m = _re.search(r"kb\.csv:(\d+), key 'pressure_bar': .*above the model's range", msg)
    assert m, msg
    line = int(m.group(1))
    said = f.read_text().splitlines()[line - 1].split(",")[1]
    assert f"the log gives {float(said):g} bar (gauge) there" in msg
    assert "likely a unit slip" in msg and "--columns pressure_kpa=pressure_bar" in msg
    res = runner.invoke(app, ["predict", str(f), "--params", params, "--out", str(tmp_path / "b"), "--columns",
                              "pressure_kpa=pressure_bar"])
    assert res.exit_code == 0, res.output
    # the library's call names the line too
    import bpmid

    with pytest.raises(InputError) as e:
        bpmid.predict([f], params=params)
    assert e.value.line == line and e.value.key == "pressure_bar"


# ---- item 4: a plausibility hint names the form that works -------------------------------------------------------
def _warnings(output: str) -> list[str]:
    return [" ".join(w.split()) for w in output.split("warning: ")[1:]]


@pytest.mark.parametrize("header, scale, fix, refused", [
    ("time_s,pressure_bar,angle_deg", {"t_scale": 1000.0}, "--columns time_ms=time_s", "--time-unit ms"),
    ("time_s,pressure_bar,angle_deg", {"a_scale": np.pi / 180}, "--columns angle_rad=angle_deg", "--angle-unit rad"),
])
def test_a_hint_for_a_unit_the_header_states_is_the_column_map_and_it_works(tmp_path, header, scale, fix, refused):
    f = _write(tmp_path, "h.csv", _motion("# pressure_reference: absolute\n", header, **scale))
    params = str(_params(tmp_path))
    res = runner.invoke(app, ["predict", str(f), "--params", params, "--out", str(tmp_path / "a")])
    assert res.exit_code == 0, res.output
    hint = [w for w in _warnings(res.output) if fix in w]
    assert hint and f"{refused} would be refused as a conflict" in hint[0], res.output
    assert not any(f"state {refused}" in w for w in _warnings(res.output))
    flag, value = refused.split()
    res = runner.invoke(app, ["predict", str(f), "--params", params, "--out", str(tmp_path / "b"), flag, value])
    assert res.exit_code == 2 and "drop one or make them agree" in res.output  # the flag really is refused
    res = runner.invoke(app, ["predict", str(f), "--params", params, "--out", str(tmp_path / "c"), *fix.split()])
    assert res.exit_code == 0 and not _warnings(res.output), res.output


def test_a_hint_for_a_unit_a_flag_states_is_the_flag(tmp_path):
    f = _write(tmp_path, "f.csv", _motion("# pressure_reference: absolute\n", "t,pressure_bar,angle_deg",
                                          t_scale=1000.0))
    res = runner.invoke(app, ["predict", str(f), "--params", str(_params(tmp_path)), "--out", str(tmp_path / "a"),
                              "--time-unit", "s"])
    assert res.exit_code == 0, res.output
    assert any("if the times are milliseconds, state --time-unit ms" in w for w in _warnings(res.output)), res.output


def test_a_reference_hint_names_what_states_the_reference(tmp_path):
    """Absolute pressures under a psig header: --pressure-reference absolute would conflict with the unit."""
    f = _write(tmp_path, "g.csv", _motion("", "time_s,pressure_psig,angle_deg", p_scale=1e5 / 6894.757293168))
    params = str(_params(tmp_path))
    res = runner.invoke(app, ["predict", str(f), "--params", params, "--out", str(tmp_path / "a")])
    w = [x for x in _warnings(res.output) if "absolute pressures read as gauge" in x]
    assert w and "--columns pressure_psi_abs=pressure_psig" in w[0] and "--pressure-reference" not in w[0], res.output
    res = runner.invoke(app, ["predict", str(f), "--params", params, "--out", str(tmp_path / "b"), "--columns",
                              "pressure_psi_abs=pressure_psig"])
    assert res.exit_code == 0 and not _warnings(res.output), res.output


# ---- item 3: the milliseconds check of motion logs, shared with relaxation test logs -----------------------------
def _relax_text(t_scale: float) -> str:
    """A ramp (0.5 s) and hold (5.5 s) of a one-term Prony solid, sampled every 20 ms, seeded noise."""
    rng = np.random.default_rng(3)
    t = np.arange(301) * 0.02
    eps = np.minimum(t / 0.5, 1.0) * 0.1
    e_inf, e1, tau = 0.5, 1.0, 0.8  # MPa, MPa, s
    h, sig = 0.0, np.zeros_like(t)
    for k in range(1, t.size):
        dt = t[k] - t[k - 1]
        h = h * np.exp(-dt / tau) + e1 * (eps[k] - eps[k - 1]) * tau / dt * (1 - np.exp(-dt / tau))
        sig[k] = e_inf * eps[k] + h
    sig += rng.normal(0, 1e-4, t.size)
    return "time_s,strain,stress_mpa\n" + "".join(f"{ti * t_scale:.10g},{e:.6f},{s:.6f}\n"
                                                  for ti, e, s in zip(t, eps, sig))


def test_milliseconds_under_seconds_in_a_relaxation_log_are_warned_about(tmp_path):
    f = _write(tmp_path, "relax_ms.csv", _relax_text(1000.0))
    out = tmp_path / "r.yaml"
    res = runner.invoke(app, ["fit", "relax", str(f), "--out", str(out), "--no-figure", "--terms", "1"])
    assert res.exit_code == 0, res.output
    w = [x for x in _warnings(res.output) if "samples are 20 s apart and every time is a whole number" in x]
    assert w and "--columns time_ms=time_s" in w[0], res.output
    doc = yaml.safe_load(out.read_text())
    assert any("samples are 20 s apart" in x for x in doc["warnings"])
    strict = tmp_path / "strict.yaml"
    res = runner.invoke(app, ["fit", "relax", str(f), "--out", str(strict), "--no-figure", "--terms", "1",
                              "--strict"])
    assert res.exit_code == 2 and "samples are 20 s apart" in res.output and not strict.exists()
    fixed = tmp_path / "fixed.yaml"
    res = runner.invoke(app, ["fit", "relax", str(f), "--out", str(fixed), "--no-figure", "--terms", "1",
                              "--columns", "time_ms=time_s"])
    assert res.exit_code == 0 and not any("whole number" in x for x in _warnings(res.output)), res.output
    # the same log in seconds: no such warning
    g = _write(tmp_path, "relax_s.csv", _relax_text(1.0))
    res = runner.invoke(app, ["fit", "relax", str(g), "--out", str(tmp_path / "s.yaml"), "--no-figure", "--terms", "1"])
    assert res.exit_code == 0 and not any("whole number" in x for x in _warnings(res.output)), res.output


def test_the_shipped_relaxation_logs_raise_no_milliseconds_warning():
    from bpmid.io import plausibility as plaus
    from bpmid.io.relax_logs import read_relax_log

    files = sorted((Path(__file__).resolve().parents[1] / "datasets" / "relaxation").glob("*.csv"))
    assert len(files) >= 12
    for f in files:
        assert not plaus.milliseconds_warnings(read_relax_log(f)), f


def test_a_unit_line_and_a_flag_that_disagree_are_refused_and_agreeing_ones_read(tmp_path):
    # the header states no unit; the file's '# time_unit:' line and --time-unit both do: stated twice, they must
    # agree (the flag used to win silently)
    f = _write(tmp_path, "t.csv", _motion("# pressure_reference: absolute\n# time_unit: ms\n",
                                          header="t,pressure_bar,angle_deg", t_scale=1000.0))
    params = _params(tmp_path)
    r = runner.invoke(app, ["predict", str(f), "--params", str(params), "--out", str(tmp_path / "o"),
                            "--time-unit", "s"])
    assert r.exit_code == 2, r.output
    assert "'# time_unit: ms'" in r.output and "--time-unit" in r.output and ":2" in r.output
    assert not (tmp_path / "o").exists()
    ok = runner.invoke(app, ["predict", str(f), "--params", str(params), "--out", str(tmp_path / "o2"),
                             "--time-unit", "ms"])
    assert ok.exit_code == 0, ok.output
    alone = runner.invoke(app, ["predict", str(f), "--params", str(params), "--out", str(tmp_path / "o3")])
    assert alone.exit_code == 0, alone.output
    assert (tmp_path / "o2" / "t.csv").read_bytes() == (tmp_path / "o3" / "t.csv").read_bytes()


def test_a_vacuum_refusal_names_the_form_that_works_for_where_the_unit_came_from(tmp_path):
    # the header states the unit: --pressure-unit would be refused, so the hint is the column map
    f = _write(tmp_path, "v.csv", "# pressure_reference: gauge\ntime_s,pressure_kpa,angle_deg\n0,-20,10\n0.1,30,11\n"
                                  "0.2,40,12\n")
    r = runner.invoke(app, ["fit", "motion", str(f), "--out", str(tmp_path / "o.yaml")])
    assert r.exit_code == 2 and ":3" in r.output
    text = " ".join(r.output.split())
    assert "--columns pressure_bar=pressure_kpa" in text and "(--pressure-unit)" not in text
    # a bare column whose unit a flag gave: the flag is the hint
    g = _write(tmp_path, "w.csv", "time_s,p,angle_deg\n0,-0.2,10\n0.1,0.3,11\n0.2,0.4,12\n")
    r = runner.invoke(app, ["fit", "motion", str(g), "--out", str(tmp_path / "o2.yaml"), "--columns", "pressure=p",
                            "--pressure-unit", "bar", "--pressure-reference", "gauge"])
    assert r.exit_code == 2 and "(--pressure-unit)" in " ".join(r.output.split())
    assert not (tmp_path / "o.yaml").exists() and not (tmp_path / "o2.yaml").exists()


@pytest.mark.parametrize("where", ["first", "after_metadata", "between_metadata"])
def test_a_comment_line_among_an_instruments_metadata_lines_is_read(tmp_path, where):
    """An instrument export's 'key: value' lines above the header, with the '# pressure_reference:' line first,
    after them or between them: read the same (it was ignored after them and the file refused)."""
    meta = ["Title: bench log (synthetic)", "Instrument: virtual DAQ", "Sample rate: 10 Hz"]
    line = "# pressure_reference: absolute"
    at = {"first": 0, "after_metadata": 3, "between_metadata": 2}[where]
    head = "".join(x + "\n" for x in meta[:at] + [line] + meta[at:])
    f = _write(tmp_path, "log.csv", _motion(head, "Time (ms),Pressure (psi),Angle (deg)", t_scale=1e3,
                                            p_scale=14.503773773))
    lg = read_motion_log(f)
    assert lg.pressure_reference == "absolute" and "pressure_reference" in lg.reading["pressure_reference"]["from"]
    assert lg.time_s[1] == pytest.approx(0.1) and lg.n == 40
    assert lg.pressure_pa.max() == pytest.approx(1.6e5 - 101325.0, rel=0.02)   # absolute 1.6 bar, read as gauge


@pytest.mark.parametrize("sep", ["\t", ";", " "])
def test_a_key_value_line_of_as_many_words_as_columns_is_not_taken_for_the_header(tmp_path, sep):
    """'Operator: John Smith' and 'Pressure Reference: Gauge' (three words, no '#') right above a three-column header:
    metadata, not the header (they were taken for it, and the file refused: 'found columns Pressure, Reference:,
    Gauge'). A table split on spaces, with a decimal comma, still finds its header."""
    head = "Instrument: virtual DAQ\nOperator: John Smith\nPressure Reference: Absolute\n"
    header = sep.join(["Time (ms)", "Pressure (psi)", "Angle (deg)"] if sep != " " else ["Time_ms", "Pressure_psi",
                                                                                         "Angle_deg"])
    body = _motion("", header, t_scale=1e3, p_scale=14.503773773).split("\n", 1)[1].replace(",", sep)
    if sep == " ":
        body = body.replace(".", ",")   # a decimal comma in a table split on spaces
    f = _write(tmp_path, "log.txt", head + header + "\n" + body)
    lg = read_motion_log(f)
    assert lg.n == 40 and lg.time_s[1] == pytest.approx(0.1)
    assert lg.pressure_reference == "absolute" and lg.reading["pressure_reference"]["from"] == \
        "line 3 (pressure_reference: Absolute)"
    assert lg.pressure_pa.max() == pytest.approx(1.6e5 - 101325.0, rel=0.02)


@pytest.mark.parametrize("sep", [";", ",", "\t"])
def test_key_and_value_in_two_cells_above_the_header_are_metadata(tmp_path, sep):
    """An instrument that writes its settings as two-cell rows ('Pressure Reference;Gauge') above the header: the
    rows are metadata, read like 'key: value' lines (the reference was not found and the file refused)."""
    head = f"Operator{sep}John Smith\nPressure Reference{sep}Absolute\nSample rate (Hz){sep}10\n"
    header = sep.join(["Time (ms)", "Pressure (psi)", "Angle (deg)"])
    body = _motion("", header, t_scale=1e3, p_scale=14.503773773).split("\n", 1)[1]
    if sep != ",":
        body = body.replace(",", sep)
    lg = read_motion_log(_write(tmp_path, "log.csv", head + header + "\n" + body))
    assert lg.n == 40 and lg.pressure_reference == "absolute"
    assert lg.reading["pressure_reference"]["from"] == "line 2 (pressure_reference: Absolute)"


_LVM_HEAD = ("LabVIEW Measurement\t\nWriter_Version\t2\nReader_Version\t2\nSeparator\tTab\nDecimal_Separator\t.\n"
             "Multi_Headings\tNo\nX_Columns\tOne\nTime_Pref\tRelative\nOperator\tJohn Smith\nDate\t2026/11/27\n"
             "Time\t10:00:00.000\n***End_of_Header***\t\n\t\nChannels\t2\t\nSamples\t40\t40\t\n"
             "Date\t2026/11/27\t2026/11/27\t\nTime\t10:00:00\t10:00:00\t\nX_Dimension\tTime\tTime\t\n"
             "X0\t0.0000000000000000E+0\t0.0000000000000000E+0\t\nDelta_X\t0.100000\t0.100000\t\n"
             "***End_of_Header***\t\t\t\n")


@pytest.mark.parametrize("trail", ["", "\t"])
def test_a_labview_measurement_file_is_read(tmp_path, trail):
    """A LabVIEW .lvm export: its two header blocks are metadata, X_Value is the time in s (X_Dimension Time), the
    'Comment' column may be left off the rows; the channels' units as the user named them."""
    body = _motion("", "X_Value\tPressure (psia)\tAngle (deg)\tComment", p_scale=14.503773773)
    rows = body.split("\n", 1)[1].replace(",", "\t").replace("\n", trail + "\n")
    lg = read_motion_log(_write(tmp_path, "run.lvm", _LVM_HEAD + body.split("\n", 1)[0] + "\n" + rows))
    assert lg.n == 40 and lg.time_s[1] == pytest.approx(0.1) and lg.pressure_reference == "absolute"
    assert lg.pressure_pa.max() == pytest.approx(1.6e5 - 101325.0, rel=0.02)


def test_a_labview_file_with_several_segments_or_no_header_end_is_refused(tmp_path):
    body = _motion("", "X_Value\tPressure (psia)\tAngle (deg)").replace(",", "\t")
    seg = _LVM_HEAD.split("***End_of_Header***\t\n", 1)[1]
    f = _write(tmp_path, "two.lvm", _LVM_HEAD + body + seg + body)
    with pytest.raises(InputError, match="2 segments, each with its own header: export one segment per file") as e:
        read_motion_log(f)
    assert e.value.line is not None
    g = _write(tmp_path, "cut.lvm", _LVM_HEAD.split("***End_of_Header***")[0] + body)
    with pytest.raises(InputError, match="without its '\\*\\*\\*End_of_Header\\*\\*\\*' line"):
        read_motion_log(g)


@pytest.mark.parametrize("temp", ["T (K)", "T [°C]", "t (degC)"])
def test_a_one_letter_temperature_column_is_not_taken_for_the_time(tmp_path, temp):
    """'T (K)' beside 'Time (s)' is the rig's temperature: listed among the ignored columns, never read as a second
    time column (it was, and the file refused with 'unknown unit k for time')."""
    f = _write(tmp_path, "log.csv", "# pressure_reference: gauge\n" + f"Time (s),Pressure (kPa),Angle (deg),{temp}\n"
               + "".join(f"{0.1 * k:.1f},{5.0 * k},{10 + k},{295 + 0.01 * k}\n" for k in range(40)))
    lg = read_motion_log(f)
    assert lg.n == 40 and lg.time_s[1] == pytest.approx(0.1) and temp in lg.reading["ignored_columns"]


# ---- 'mPa' is the millipascal: never read as the megapascal it would be without regard to case ------------------
@pytest.mark.parametrize("header, extra, line, key", [
    ("time_s,pressure (mPa),angle_deg", [], 2, "pressure (mPa)"),
    ("time_s,pressure,angle_deg", ["--pressure-unit", "mPa"], None, "--pressure-unit"),
])
def test_a_pressure_in_mpa_as_written_is_refused_naming_where(tmp_path, header, extra, line, key):
    log = _write(tmp_path, "m.csv", _motion("# pressure_reference: absolute\n", header, p_scale=0.1))
    out = tmp_path / "out"
    res = runner.invoke(app, ["predict", str(log), "--params", str(_params(tmp_path)), "--out", str(out), *extra])
    assert res.exit_code == 2, res.output
    assert (f"m.csv:{line}, key '{key}'" if line else f"m.csv, key '{key}'") in res.output
    assert "millipascal" in res.output and "write MPa" in res.output
    assert not out.exists()
    # the megapascal, written MPa or in bpmid's own lower-case suffix, is read (0.12 MPa is 1.2 bar)
    for ok in ("time_s,pressure (MPa),angle_deg", "time_s,pressure_mpa,angle_deg"):
        log = _write(tmp_path, "ok.csv", _motion("# pressure_reference: absolute\n", ok, p_scale=0.1))
        t = read_motion_log(log)
        assert float(t.pressure_pa.max()) == pytest.approx(1.6e5 - 101325.0, rel=1e-3)


def test_a_modulus_in_mpa_as_written_is_refused_in_relaxation_and_dma_files(tmp_path):
    t = np.linspace(0.01, 50, 60)
    body = "".join(f"{a:.6g},{1 + 2 * np.exp(-a / 10):.6g}\n" for a in t)
    cases = {"e.csv": ("time_s,modulus_mPa\n" + body, 1, "modulus_mPa"),
             "d.csv": ("f,E_stor,E_loss\nHz,mPa,mPa\n1,2,0.1\n2,2.1,0.2\n", 2, "E_stor")}
    for name, (text, line, key) in cases.items():
        f = _write(tmp_path, name, text)
        out = tmp_path / f"{name}.yaml"
        res = runner.invoke(app, ["fit", "relax", str(f), "--out", str(out)])
        assert res.exit_code == 2, res.output
        assert f"{name}:{line}, key '{key}'" in res.output and "millipascal" in res.output
        assert not out.exists()


# ---- a point between groups of three digits in a file not separated by commas: never guessed -------------------
def test_whole_numbers_with_thousands_points_are_refused_and_decimal_columns_still_read(tmp_path):
    rows = [(0, 187), (100, 640), (200, 991), (300, 1008), (400, 1188)]
    text = "# pressure_reference: gauge\nZeit (ms);Druck (mbar);Winkel (deg)\n" + "".join(
        f"{t};{f'{p:,d}'.replace(',', '.')};{a}\n" for (t, p), a in zip(rows, (1, 5, 9, 12, 14)))
    log = _write(tmp_path, "th.csv", text)
    with pytest.raises(InputError, match="thousands separator") as e:
        read_motion_log(log)
    assert e.value.line == 6 and e.value.key == "Druck (mbar)" and "1008" in e.value.message
    res = runner.invoke(app, ["predict", str(log), "--params", str(_params(tmp_path)), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and "th.csv:6, key 'Druck (mbar)'" in res.output and not (tmp_path / "o").exists()
    # decimals of other lengths, every value's decimals written out, or a comma-separated file: decimal points
    for name, sep, cells in (("g.csv", ";", ["187", "640.5", "991", "1.008", "1.188"]),
                             ("f.csv", ";", ["187.000", "640.000", "991.000", "1.008", "1.188"]),
                             ("c.csv", ",", ["187", "640", "991", "1.008", "1.188"])):
        body = "".join(f"{t}{sep}{c}{sep}{a}\n" for (t, _p), c, a in zip(rows, cells, (1, 5, 9, 12, 14)))
        f = _write(tmp_path, name, f"# pressure_reference: gauge\ntime_ms{sep}pressure_mbar{sep}angle_deg\n" + body)
        assert read_motion_log(f).pressure_pa[3] == pytest.approx(100.8)


def test_thousands_points_before_a_decimal_comma_are_read_and_ambiguous_ones_refused_naming_them(tmp_path):
    """'18.775,0' in a ';' file with decimal commas is 18775.0 (German Excel's number format), never 'a unit in each
    cell'; a whole '18.775' among decimal commas is refused naming the thousands separator and a form that reads."""
    pa = [18775.0, 18275.0, 991.5, 21050.0, 20000.0]
    def de(x):
        return f"{x:,.1f}".replace(",", "X").replace(".", ",").replace("X", ".")
    head = "# pressure_reference: gauge\nZeit (s);Druck (Pa);Winkel (deg)\n"
    f = _write(tmp_path, "de.csv", head + "".join(f"{k},0;{de(p)};1{k},5\n" for k, p in enumerate(pa)))
    log = read_motion_log(f)
    assert np.allclose(log.pressure_pa, pa) and np.allclose(log.angle_deg, [10.5, 11.5, 12.5, 13.5, 14.5])
    assert "Druck (Pa)" in str(log.reading)
    whole = _write(tmp_path, "int.csv", head + "".join(f"{k},0;{de(p)[:-2]};1{k},5\n" for k, p in enumerate(pa)))
    with pytest.raises(InputError, match=r"thousands separator \(18775\)") as e:
        read_motion_log(whole)
    assert e.value.line == 3 and e.value.key == "Druck (Pa)" and "18.775,0" in e.value.message
    mixed = _write(tmp_path, "mixed.csv", head + "0,0;18.775,0;1,5\n1,0;18.75,0;2,5\n2,0;1.000,0;3,5\n")
    with pytest.raises(InputError, match="written otherwise") as e:
        read_motion_log(mixed)
    assert e.value.line == 4 and e.value.key == "Druck (Pa)"
    # the same cells quoted in a comma-separated file: named a thousands separator, not a unit in each cell
    quoted = _write(tmp_path, "q.csv", "# pressure_reference: gauge\ntime_s,pressure_pa,angle_deg\n"
                    + "".join(f'{k},"{de(p)}",1{k}.5\n' for k, p in enumerate(pa)))
    with pytest.raises(InputError, match="a thousands separator beside the decimal separator") as e:
        read_motion_log(quoted)
    assert "unit written in each cell" not in e.value.message and e.value.line == 3


# ---- an ambient-pressure column under a one-word name ------------------------------------------------------------
@pytest.mark.parametrize("name", ["Ambient (hPa)", "Barometer (hPa)", "baro_hpa", "Atmospheric [hPa]"])
def test_an_ambient_column_under_a_one_word_name_is_the_ambient_pressure(tmp_path, name):
    body = "".join(f"{0.1 * k:.1f},{0.84 + 0.05 * k:.3f},840\n" for k in range(10))
    log = _write(tmp_path, "amb.csv", f"# pressure_reference: absolute\ntime_s,pressure_bar,{name}\n" + body)
    p = read_motion_log(log).pressure_pa
    assert p == pytest.approx(5e3 * np.arange(10), abs=1e-6)          # gauge against 840 hPa, not 1013.25
    # a temperature under the same word is set aside, and the ambient pressure is the standard atmosphere
    t = _write(tmp_path, "amb_t.csv", "# pressure_reference: absolute\ntime_s,pressure_bar,Ambient (C)\n"
               + "".join(f"{0.1 * k:.1f},{1.2 + 0.05 * k:.3f},21\n" for k in range(10)))
    assert read_motion_log(t).pressure_pa[0] == pytest.approx(120000 - 101325.0)


# ---- a column map's unit against the header's; a refused cell quoted as written -----------------------------------
def test_a_column_map_unit_that_contradicts_the_header_is_refused_and_the_names_reference_kept(tmp_path):
    body = "".join(f"{0.1 * k:.1f},{20 + 5 * k:.3f},{3 * k:.3f}\n" for k in range(20))
    log = _write(tmp_path, "k.csv", "time_s,Pressure (kPa g),angle_deg\n" + body)
    with pytest.raises(InputError, match="a unit stated twice must agree") as e:
        read_motion_log(log, IOConfig(columns={"Pressure (kPa g)": "pressure_psig"}))
    assert e.value.key == "Pressure (kPa g)" and "pressure_psig" in e.value.message
    # the same unit under another spelling, or no unit in the map: read, the name's gauge reference kept
    for target in ("pressure_kpa", "pressure", "pressure_kpa_gauge"):
        lg = read_motion_log(log, IOConfig(columns={"Pressure (kPa g)": target}))
        assert lg.pressure_pa[1] == pytest.approx(25e3)
    res = runner.invoke(app, ["predict", str(log), "--params", str(_params(tmp_path)), "--out", str(tmp_path / "o"),
                              "--columns", "pressure_psig=Pressure (kPa g)"])
    assert res.exit_code == 2 and "k.csv:1, key 'Pressure (kPa g)'" in res.output


def test_a_cell_that_is_no_number_is_quoted_as_written_in_a_decimal_comma_file(tmp_path):
    log = _write(tmp_path, "d.csv", "# pressure_reference: gauge\ntime_s;pressure_kpa;angle_deg\n0,0;20,5;1,0\n"
                 "0,1;1,201.0;2,0\n")
    with pytest.raises(InputError) as e:
        read_motion_log(log)
    assert "'1,201.0' is not a number" in e.value.message and e.value.line == 4
    # a point between thousands before the decimal comma is no such cell: 1.201,0 is 1201.0
    ok = _write(tmp_path, "k.csv", "# pressure_reference: gauge\ntime_s;pressure_kpa;angle_deg\n0,0;20,5;1,0\n"
                "0,1;1.201,0;2,0\n")
    assert read_motion_log(ok).pressure_pa[1] == pytest.approx(1201.0e3)


def test_a_column_with_a_pressure_unit_but_an_unknown_name_is_refused_with_its_own_units_name(tmp_path):
    log = _write(tmp_path, "a.csv", _motion("# pressure_reference: absolute\n", "time_s,Absolutdruck (bar),angle_deg"))
    with pytest.raises(InputError) as e:
        read_motion_log(log)
    msg = e.value.message
    assert e.value.key == "Absolutdruck (bar)" and "has a pressure unit" in msg
    assert "--columns 'pressure=Absolutdruck (bar)'" in msg and "rename it pressure_bar" in msg


def test_a_column_without_a_name_that_holds_numbers_is_said_not_dropped(tmp_path):
    """A blank header cell over numbers (a merged Excel header, a trailing separator in the header only of the
    header row) was dropped without a word; a pandas row index stays unsaid."""
    from bpmid.io.motion_logs import read_motion_log

    rows = "".join(f"{k * 0.1:.1f},{1.2 + 0.01 * k:.3f},{1.25 + 0.01 * k:.3f},{k * 0.5:.2f}\n" for k in range(30))
    blank = _write(tmp_path, "blank.csv", "# pressure_reference: absolute\nTime,Pressure,,Angle\ns,bar,bar,deg\n"
                   + rows)
    lg = read_motion_log(blank)
    said = [w for w in lg.warnings if "column 3 has no name in the header but holds numbers (units row: bar)" in w]
    assert said and "it was not read" in said[0]
    assert "column 3" in lg.reading["ignored_columns"]
    index = _write(tmp_path, "index.csv", "# pressure_reference: absolute\n,time_s,pressure_bar,angle_deg\n" + "".join(
        f"{k},{k * 0.1:.1f},{1.2 + 0.01 * k:.3f},{k * 0.5:.2f}\n" for k in range(30)))
    assert not [w for w in read_motion_log(index).warnings if "no name" in w]


def test_clock_times_beside_a_date_column_keep_a_jump_of_days(tmp_path):
    """Date,Time columns: the date was set aside, so a log that jumped two days read as one continuous run (no
    gap, --max-gap could not refuse it); the two are now joined."""
    from bpmid.io.motion_logs import read_motion_log

    rows = []
    for k in range(40):
        day = "2025-03-01" if k < 20 else "2025-03-03"
        rows.append(f"{day},10:00:{k * 0.5:06.3f},{1.2 + 0.01 * k:.3f},{k * 0.5:.2f}\n")
    f = _write(tmp_path, "dated.csv", "# pressure_reference: absolute\nDate,Time,pressure_bar,angle_deg\n"
               + "".join(rows))
    lg = read_motion_log(f)
    assert np.diff(lg.time_s)[19] == pytest.approx(2 * 86400.0 + 0.5)
    assert lg.reading["columns"]["time"]["date_from"] == "Date"
    assert any("gap of 1.728e+05 s" in w or "gap of 172800" in w for w in lg.warnings), lg.warnings
    one_day = _write(tmp_path, "oneday.csv", "# pressure_reference: absolute\nDatum,Zeit,pressure_bar,angle_deg\n"
                     + "".join(r.replace("2025-03-03", "2025-03-01") for r in rows))
    assert np.allclose(np.diff(read_motion_log(one_day).time_s), 0.5)


def test_a_table_is_read_by_its_bytes_not_its_extension(tmp_path):
    """A TSV saved as .xls (LabVIEW, loggers) was refused with xlrd's 'Expected BOF record', and a workbook named
    .csv as 'binary data'; both are read now, and an HTML table named .xls is refused saying what it is."""
    import pandas as pd

    from bpmid.io.motion_logs import read_motion_log

    text = "time_s\tpressure_kpa_g\tangle_deg\n" + "".join(f"{k * 0.1:.1f}\t{20 + k:.1f}\t{k * 0.5:.2f}\n"
                                                           for k in range(30))
    tsv = _write(tmp_path, "logger.xls", text)
    ref = read_motion_log(_write(tmp_path, "logger.tsv", text))
    assert np.array_equal(read_motion_log(tsv).pressure_pa, ref.pressure_pa)
    book = tmp_path / "book.xlsx"
    pd.DataFrame({"time_s": ref.time_s, "pressure_kpa_g": ref.pressure_pa / 1e3,
                  "angle_deg": ref.angle_deg}).to_excel(book, index=False)
    named_csv = tmp_path / "book.csv"
    named_csv.write_bytes(book.read_bytes())
    assert np.allclose(read_motion_log(named_csv).angle_deg, ref.angle_deg)
    html = _write(tmp_path, "web.xls", "<html><body><table><tr><td>time_s</td></tr></table></body></html>")
    with pytest.raises(InputError, match="an HTML or XML table saved with the extension .xls"):
        read_motion_log(html)


def test_two_columns_of_one_name_are_told_to_be_renamed(tmp_path):
    from bpmid.io.motion_logs import read_motion_log

    f = _write(tmp_path, "dup.csv", "# pressure_reference: absolute\ntime_s,pressure_bar,angle_deg,angle_deg\n"
               + "".join(f"{k * 0.1:.1f},{1.2 + 0.01 * k:.3f},{k * 0.5:.2f},{k * 0.7:.2f}\n" for k in range(20)))
    with pytest.raises(InputError, match="two columns share the name 'angle_deg' and give different angles: rename "
                                         "one in the header"):
        read_motion_log(f)


def test_a_reference_written_as_a_word_of_the_pressure_name_is_read(tmp_path):
    """'Gauge pressure (kPa)', 'Absolute pressure (psi)', 'Druck rel. [bar]', 'Pressure (kPa) [gauge]': the word
    states the reference (they were refused as an unknown reference, or as a conflict of kPa with gauge); a flag
    that contradicts it is refused."""
    from bpmid.io.motion_logs import read_motion_log
    from bpmid.io.motion_logs import IOConfig

    def log(name, head, p):
        return _write(tmp_path, name, f"Time (s),{head},Angle (deg)\n" + "".join(
            f"{k * 0.1:.1f},{v:.4f},{k * 0.5:.2f}\n" for k, v in enumerate(p)))

    kpa = 20.0 + np.arange(30.0)
    for name, head, vals, ref, gauge in (
            ("g.csv", "Gauge pressure (kPa)", kpa, "gauge", kpa * 1e3),
            ("b.csv", "Pressure (kPa) [gauge]", kpa, "gauge", kpa * 1e3),
            ("d.csv", "Druck rel. [bar]", kpa / 100.0, "gauge", kpa * 1e3),
            ("a.csv", "Absolute pressure (psi)", (kpa * 1e3 + 101325.0) / 6894.757, "absolute", kpa * 1e3)):
        lg = read_motion_log(log(name, head, vals))
        assert lg.pressure_reference == ref and np.allclose(lg.pressure_pa, gauge, atol=1e-3 * 6894.757), name
    with pytest.raises(InputError, match="the pressure reference is stated twice and disagrees"):
        read_motion_log(tmp_path / "g.csv", IOConfig(pressure_reference="absolute"))


def test_year_first_slash_dates_and_12_hour_clocks_are_read(tmp_path):
    """'2025/03/01 10:00:00.000' (year first: unambiguous) and '12:59:50.000 PM' were misreported as a column
    without a unit, and the unit the message offered then failed on the text."""
    from bpmid.io.motion_logs import read_motion_log

    def log(name, stamps):
        return _write(tmp_path, name, "# pressure_reference: absolute\ntime,pressure_bar,angle_deg\n" + "".join(
            f"{s},{1.2 + 0.01 * k:.3f},{k * 0.5:.2f}\n" for k, s in enumerate(stamps)))

    ymd = [f"2025/03/01 10:00:{k * 0.5:06.3f}" for k in range(20)]
    assert np.allclose(read_motion_log(log("ymd.csv", ymd)).time_s, np.arange(20) * 0.5)
    pm = [f"12:59:{50 + k * 0.5:06.3f} PM" if 50 + k * 0.5 < 60 else f"1:00:{50 + k * 0.5 - 60:06.3f} PM"
          for k in range(20)]
    assert np.allclose(read_motion_log(log("pm.csv", pm)).time_s, np.arange(20) * 0.5)
    with pytest.raises(InputError, match="day-first in some locales"):   # day or month first: still refused
        read_motion_log(log("dmy.csv", [f"01/03/2025 10:00:{k * 0.5:06.3f}" for k in range(20)]))


def test_messages_for_an_epoch_header_a_repeated_header_and_units_in_cells(tmp_path):
    """'epoch_ms' names its unit (it was 'no name bpmid knows ... rename it time_s', which reads ms as s); a
    header repeated mid-file and a unit in every cell are said for what they are."""
    from bpmid.io.motion_logs import read_motion_log

    rows = [(k * 100, 1.2 + 0.01 * k, k * 0.5) for k in range(20)]
    ep = _write(tmp_path, "ep.csv", "# pressure_reference: absolute\nepoch_ms,pressure_bar,angle_deg\n"
                + "".join(f"{1.7e12 + t:.1f},{p:.3f},{a:.2f}\n" for t, p, a in rows))
    assert np.allclose(read_motion_log(ep).time_s, np.arange(20) * 0.1)
    zm = _write(tmp_path, "zm.csv", "# pressure_reference: absolute\nstamp_ms,pressure_bar,angle_deg\n"
                + "".join(f"{t},{p:.3f},{a:.2f}\n" for t, p, a in rows))
    with pytest.raises(InputError, match="rename it time_ms"):
        read_motion_log(zm)
    body = "".join(f"{t / 1000:.1f},{p:.3f},{a:.2f}\n" for t, p, a in rows)
    head = "# pressure_reference: absolute\ntime_s,pressure_bar,angle_deg\n"
    joined = _write(tmp_path, "joined.csv", head + body + "time_s,pressure_bar,angle_deg\n" + body)
    with pytest.raises(InputError, match="the header again: two logs joined into one file"):
        read_motion_log(joined)
    cells = _write(tmp_path, "cells.csv", head + "".join(f"{t / 1000:.2f} s,{p:.4f} bar,{a:.2f} deg\n"
                                                         for t, p, a in rows))
    with pytest.raises(InputError, match=r"a unit written in each cell \('s' after the number\)"):
        read_motion_log(cells)


def test_columns_with_commas_in_brackets_and_several_candidates(tmp_path):
    """--columns keeps data(:,1) whole (it split at the comma), and such a MATLAB matrix column has no unit in
    its brackets; a missing pressure with two candidates by unit names both, the hint quoted for a shell."""
    from bpmid.cli._logopts import _split_pairs

    assert _split_pairs("time_s=data(:,1),pressure_bar_abs=data(:,2)") == ["time_s=data(:,1)",
                                                                           "pressure_bar_abs=data(:,2)"]
    with pytest.raises(InputError, match="a bracket is opened and not closed"):
        _split_pairs("time=data(:,1,pressure=p")
    from bpmid.io.tables import _unit_part

    assert _unit_part("data(:,1)") == ("data(:,1)", None) and _unit_part("Time (s)") == ("Time", "s")
    from bpmid.io.motion_logs import read_motion_log

    f = _write(tmp_path, "two.csv", "# pressure_reference: absolute\ntime_s,Pressure sensor 1 (bar),Pressure sensor 2 "
               "(bar),angle_deg\n" + "".join(f"{k * 0.1:.1f},{1.2 + 0.01 * k:.3f},{1.3:.3f},{k:.1f}\n"
                                             for k in range(20)))
    with pytest.raises(InputError, match=r"--columns 'pressure=Pressure sensor 1 \(bar\)'.*'Pressure sensor 2 "
                                         r"\(bar\)' also has a pressure unit"):
        read_motion_log(f)


def _lvm(x_columns: str, y_units: str, data_head: str, rows: list[str]) -> str:
    head = (f"LabVIEW Measurement\t\nWriter_Version\t2\nSeparator\tTab\nDecimal_Separator\t.\nMulti_Headings\tNo\n"
            f"X_Columns\t{x_columns}\nTime_Pref\tRelative\n***End_of_Header***\t\n\t\nChannels\t2\t\n"
            f"Samples\t{len(rows)}\t{len(rows)}\t\nY_Unit_Label\t{y_units}\t\nX_Dimension\tTime\tTime\t\n"
            f"X0\t0.0E+0\t0.0E+0\t\nDelta_X\t0.050000\t0.050000\t\n***End_of_Header***\t\n{data_head}\n")
    return head + "\n".join(rows) + "\n"


def test_labview_channel_units_and_a_file_without_x_columns_are_read(tmp_path):
    """Units in the segment header's Y_Unit_Label were 'stated nowhere'; X_Columns No (time = X0 + k Delta_X) was
    'missing column for time'."""
    from bpmid.io.motion_logs import IOConfig, read_motion_log

    vals = [(k * 0.05, 1.2 + 0.01 * k, 14.0 + k) for k in range(30)]
    one = _write(tmp_path, "one.lvm", _lvm("One", "bar\tDeg", "X_Value\tPressure\tAngle\tComment",
                                           [f"{t:.6f}\t{p:.6f}\t{a:.6f}" for t, p, a in vals]))
    none = _write(tmp_path, "none.lvm", _lvm("No", "bar\tDeg", "Pressure\tAngle\tComment",
                                             [f"{p:.6f}\t{a:.6f}" for _, p, a in vals]))
    cfg = IOConfig(pressure_reference="absolute")
    a, b = read_motion_log(one, cfg), read_motion_log(none, cfg)
    assert np.allclose(a.time_s, np.arange(30) * 0.05) and np.allclose(b.time_s, a.time_s)
    assert np.allclose(a.pressure_as_given, [p for _, p, _ in vals]) and a.pressure_unit == "bar"
    assert np.array_equal(a.pressure_pa, b.pressure_pa) and np.array_equal(a.angle_deg, b.angle_deg)


def test_repeated_times_say_why_and_utf32_is_read(tmp_path):
    """A sample written twice and a time column coarser than the sampling (mm:ss.0 at 20 Hz) are told apart; a
    UTF-32 file (with its BOM) is read (its columns were shown as NUL-interleaved text)."""
    from bpmid.io.motion_logs import read_motion_log

    head = "# pressure_reference: absolute\ntime_s,pressure_bar,angle_deg\n"
    rows = [f"{k * 0.05:.2f},{1.2 + 0.001 * k:.4f},{k * 0.1:.2f}\n" for k in range(40)]
    twice = _write(tmp_path, "twice.csv", head + "".join(rows[:10] + [rows[9]] + rows[10:]))
    with pytest.raises(InputError, match="a sample written twice"):
        read_motion_log(twice)
    coarse = _write(tmp_path, "coarse.csv", head + "".join(
        f"{round(k * 0.05, 1):.1f},{1.2 + 0.001 * k:.4f},{k * 0.1:.2f}\n" for k in range(40)))
    with pytest.raises(InputError, match="written coarser than the log is sampled"):
        read_motion_log(coarse)
    u32 = tmp_path / "u32.csv"
    u32.write_bytes((head + "".join(rows)).encode("utf-32"))
    assert np.allclose(read_motion_log(u32).time_s, np.arange(40) * 0.05)


def test_review_of_the_new_readers_regressions(tmp_path):
    """A month-first or weekday Date column beside clock times is set aside as before (the join refused such
    logs), and said when it changes within the log; a row index that no longer starts at 0 stays unsaid; a mapped
    column keeps the reference its name states (a contradicting flag is refused)."""
    from bpmid.io.motion_logs import IOConfig, read_motion_log

    def log(name, head, rows):
        return _write(tmp_path, name, head + "".join(rows))

    us = log("us.csv", "# pressure_reference: absolute\nDate,Time,pressure_bar,angle_deg\n",
             [f"{'03/01/2025' if k < 10 else '03/02/2025'},10:00:{k * 0.5:06.3f},{1.2 + 0.01 * k:.3f},{k:.1f}\n"
              for k in range(20)])
    lg = read_motion_log(us)
    assert np.allclose(lg.time_s, np.arange(20) * 0.5)
    assert any("changes from '03/01/2025' to '03/02/2025'" in w and "ISO 8601" in w for w in lg.warnings)
    idx = log("idx.csv", "# pressure_reference: absolute\n,time_s,pressure_bar,angle_deg\n",
              [f"{k},{k * 0.1:.1f},{1.2 + 0.01 * k:.3f},{k:.1f}\n" for k in range(5, 40, 2)])
    assert not [w for w in read_motion_log(idx).warnings if "no name" in w]
    absp = log("absp.csv", "time_s,Absolute pressure (psi),angle_deg\n",
               [f"{k * 0.1:.1f},{17.5 + 0.1 * k:.2f},{k:.1f}\n" for k in range(20)])
    cols = {"Absolute pressure (psi)": "pressure"}
    assert read_motion_log(absp, IOConfig(columns=cols)).pressure_reference == "absolute"
    with pytest.raises(InputError, match="the pressure reference is stated twice and disagrees"):
        read_motion_log(absp, IOConfig(columns=cols, pressure_reference="gauge"))


def test_one_pressure_logged_absolute_and_gauge_is_read_as_gauge(tmp_path):
    """'Pressure abs (bar)' beside 'Pressure rel (bar)': one channel two ways (they differ by the atmosphere), was
    refused as two disagreeing pressures; the gauge one is read and the other set aside."""
    from bpmid.io.motion_logs import read_motion_log

    f = _write(tmp_path, "two.csv", "time_s,Pressure abs (bar),Pressure rel (bar),angle_deg\n" + "".join(
        f"{k * 0.1:.1f},{1.01325 + 0.2 + 0.01 * k:.5f},{0.2 + 0.01 * k:.5f},{k:.1f}\n" for k in range(20)))
    lg = read_motion_log(f)
    assert lg.pressure_reference == "gauge" and lg.reading["columns"]["pressure"]["column"] == "Pressure rel (bar)"
    assert "Pressure abs (bar)" in lg.reading["ignored_columns"]
    assert np.allclose(lg.pressure_pa, (0.2 + 0.01 * np.arange(20)) * 1e5)


def test_review_of_the_labview_and_name_word_readers(tmp_path):
    """A LabVIEW file without x columns and with decimal commas (its made-up time was written with a point: 'mixed
    decimal separators'); an empty Y_Unit_Label cell keeps the later channels' units in place; 'Pressure gauge
    (bar)' names the instrument, not a gauge reference."""
    from bpmid.io.motion_logs import IOConfig, read_motion_log

    rows = [f"{1.2 + 0.01 * k:.6f}\t{14.0 + k:.6f}".replace(".", ",") for k in range(20)]
    text = _lvm("No", "bar\tDeg", "Pressure\tAngle\tComment", rows).replace("Decimal_Separator\t.",
                                                                               "Decimal_Separator\t,")
    text = text.replace("Delta_X\t0.050000\t0.050000", "Delta_X\t0,050000\t0,050000")
    lg = read_motion_log(_write(tmp_path, "comma.lvm", text), IOConfig(pressure_reference="absolute"))
    assert np.allclose(lg.time_s, np.arange(20) * 0.05) and np.allclose(lg.pressure_as_given[:2], [1.2, 1.21])
    three = _lvm("One", "bar\t\tDeg", "X_Value\tPressure\tAux\tAngle\tComment",
                 [f"{k * 0.05:.6f}\t{1.2 + 0.01 * k:.6f}\t0.5\t{14.0 + k:.6f}" for k in range(20)])
    lg = read_motion_log(_write(tmp_path, "aux.lvm", three), IOConfig(pressure_reference="absolute"))
    assert lg.reading["columns"]["angle"]["column"] == "Angle (Deg)"
    f = _write(tmp_path, "gauge.csv", "# pressure_reference: absolute\ntime_s,Pressure gauge (bar),angle_deg\n"
               + "".join(f"{k * 0.1:.1f},{1.2 + 0.01 * k:.3f},{k:.1f}\n" for k in range(20)))
    with pytest.raises(InputError, match=r"--columns 'pressure=Pressure gauge \(bar\)'"):
        read_motion_log(f)        # an instrument's name: mapped by the user, never read as a gauge reference
