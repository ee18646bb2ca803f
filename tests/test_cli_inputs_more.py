"""More bad-input cases through the command line (QA pass 2): exit 2 with one message naming the file, line or
key; nothing left behind. Defect numbers of the QA list in the test names' docstrings."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from bpmid.cli import app
from bpmid.errors import InputError
from bpmid.io.motion_logs import from_arrays, write_motion_log
from bpmid.io.results import provenance, read_result, write_result
from bpmid.models.vbmm import VBMM, Material, load_vbmm, vbmm_yaml_body

REPO = Path(__file__).resolve().parents[1]
FIT_LOG = REPO / "datasets" / "motion" / "fitting_set" / "fit_1p2_1p6_r1.csv"
ATM = 101325.0
runner = CliRunner()


def _one_line(r) -> str:
    lines = [ln for ln in r.output.strip().splitlines() if ln.strip()]
    assert len(lines) == 1, r.output
    assert "Traceback" not in r.output
    return lines[0]


def _params(tmp_path: Path, edit=None, name="p.yaml") -> Path:
    data = {"schema": "bpmid.vbmm/1", **vbmm_yaml_body(VBMM(material=Material.paper_fit()))}
    data["metrics"] = {"rmse_deg": 1.0, "mape_pct": 2.0, "r2": 0.9}
    if edit is not None:
        edit(data)
    p = tmp_path / name
    p.write_text(yaml.safe_dump(data, sort_keys=False))
    return p


def _small_log(folder: Path, name: str, seed: int = 0, cycles: int = 1, hold: float = 2.0) -> Path:
    dt = 0.1
    seg = [np.full(int(hold / dt), 1.2)]
    up, down = np.arange(1.2, 1.6, 0.02), np.arange(1.6, 1.2, -0.02)
    for _ in range(cycles):
        seg += [up, down]
    seg.append(np.full(int(hold / dt), 1.2))
    p_bar = np.concatenate(seg)
    t = np.arange(p_bar.size) * dt
    pg = p_bar * 1e5 - ATM
    ang = VBMM(material=Material.paper_fit()).forward_deg(t, pg) + np.random.default_rng(seed).normal(0, 0.2, t.size)
    lg = from_arrays(name, t, pg, ang, pressure_reference="absolute", pressure_unit="bar")
    return write_motion_log(folder / f"{name}.csv", lg, reference="absolute",
                            comments={"synthetic": "true (test twin)"})


def _tree(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


# ---------------------------------------------------------------------------------------------
# 16, 17: bpmid.vbmm/1 files (--params, --plant-params, --init) and schema versions
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("edit, key", [
    (lambda d: d.pop("geometry"), "'geometry'"),
    (lambda d: d.pop("closure"), "'closure'"),
    (lambda d: d["geometry"].pop("n"), "'geometry.n'"),
    (lambda d: d.update(geometry=None), "'geometry'"),
])
def test_params_without_geometry_or_closure_exit_2_naming_the_key(tmp_path, edit, key):
    """16: geometry and closure are keys that must exist (CLI.md); no paper defaults behind the user's back."""
    p = _params(tmp_path, edit)
    out = tmp_path / "pred"
    r = runner.invoke(app, ["predict", str(FIT_LOG), "--params", str(p), "--out", str(out)])
    assert r.exit_code == 2, r.output
    line = _one_line(r)
    assert "p.yaml" in line and key in line
    assert not out.exists()


def test_every_vbmm_writer_writes_geometry_and_closure(tmp_path):
    """16: files bpmid writes as bpmid.vbmm/1 (vbmm_yaml_body: run's vbmm_mat.yaml, control; fit motion's own
    body) hold geometry and closure, so they stay valid --params."""
    import inspect

    from bpmid.motion_fit import MotionFit

    model = VBMM(material=Material.paper_mat(), closure="consistent")
    body = vbmm_yaml_body(model)
    assert set(body["geometry"]) == {"th", "alpha0", "R0", "l0", "n"} and body["closure"] == "consistent"
    p = write_result(tmp_path / "m.yaml", "bpmid.vbmm/1", body, provenance(timestamp=False))
    back = load_vbmm(p)
    assert back.closure == "consistent" and back.geometry == model.geometry and back.material == model.material
    # fit motion's body goes through the one writer of the format, vbmm_yaml_body (checked above)
    src = inspect.getsource(MotionFit.yaml_body)
    assert "vbmm_yaml_body(self.model" in src and "**body" in src


def test_unknown_material_key_exits_2(tmp_path):
    """17: a misspelt key inside material (K_inff) is refused, not ignored."""
    p = _params(tmp_path, lambda d: d["material"].update(K_inff=d["material"]["K_inf"]))
    r = runner.invoke(app, ["predict", str(FIT_LOG), "--params", str(p), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2
    line = _one_line(r)
    assert "p.yaml" in line and "material.K_inff" in line and "unknown" in line
    p = _params(tmp_path, lambda d: d["material"]["branches"][0].update(tua=d["material"]["branches"][0]["tau"]))
    r = runner.invoke(app, ["predict", str(FIT_LOG), "--params", str(p), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and "material.branches[0].tua" in _one_line(r)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("schema", ["bpmid.vbmm/2", "bpmid.vbmm/1.1", "bpmid.vbmm/"])
def test_unsupported_vbmm_schema_version_exits_2(tmp_path, schema):
    """17: only version 1 exists."""
    p = _params(tmp_path, lambda d: d.update(schema=schema))
    r = runner.invoke(app, ["predict", str(FIT_LOG), "--params", str(p), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2
    line = _one_line(r)
    assert "p.yaml" in line and "'schema'" in line and schema in line
    assert not (tmp_path / "o").exists()


def test_read_result_refuses_other_versions_of_every_kind(tmp_path):
    """17: read_result (every reader of result files) accepts bpmid.<kind>/1 only."""
    p = tmp_path / "r.yaml"
    for schema, prefix in (("bpmid.relax/2", "bpmid.relax/"), ("bpmid.relax/01", "bpmid.relax/"),
                           ("bpmid.vbmm/2", ("bpmid.vbmm/", "bpmid.relax/"))):
        p.write_text(f"schema: {schema}\n")
        with pytest.raises(InputError, match="unsupported schema version") as exc:
            read_result(p, prefix)
        assert exc.value.key == "schema" and exc.value.path == str(p)
    p.write_text("schema: bpmid.relax/1\nmode: ramp\n")
    assert read_result(p, "bpmid.relax/")["mode"] == "ramp"
    assert read_result(p, ("bpmid.vbmm/", "bpmid.relax/"))["mode"] == "ramp"
    p.write_text("schema: bpmid.vbmm/1\n")
    with pytest.raises(InputError, match="wrong kind of file") as exc:
        read_result(p, "bpmid.relax/")
    assert exc.value.key == "schema"


def test_a_fit_of_the_wrong_kind_says_which_command_writes_the_kind_asked(tmp_path):
    """A relaxation fit given to control/predict --params, a motion fit to fit motion --init: the error named the
    schema only; it now also says which command writes the file asked for. Exit 2, nothing written."""
    from tests.test_cli_fit_motion_predict import write_log

    relax = tmp_path / "relax_fit.yaml"
    relax.write_text("schema: bpmid.relax/1\nmode: ramp\n")
    motion = tmp_path / "VBMM.yaml"
    motion.write_text("schema: bpmid.vbmm/1\n")
    log = write_log(tmp_path / "run.csv", 1.6, 20.0, seed=6)
    for args, out, words in (
            (["control", "--params", str(relax), "--reference", "steps_45_75"], tmp_path / "ctl",
             "give a motion fit (bpmid fit motion LOG... --out VBMM.yaml"),
            (["predict", str(log), "--params", str(relax)], tmp_path / "pred", "give a motion fit (bpmid fit motion"),
            (["fit", "motion", str(log), "--init", str(motion)], tmp_path / "fit.yaml",
             "takes a relaxation fit, the file bpmid fit relax writes")):
        r = runner.invoke(app, [*args, "--out", str(out)])
        assert r.exit_code == 2, r.output
        line = _one_line(r)
        assert "wrong kind of file" in line and "key 'schema'" in line and words in line, line
        assert line.count("relaxation fit") <= 1 and line.count("give a ") <= 1, line   # said once
        assert not out.exists()


def test_fit_motion_init_with_relax_schema_2_exits_2(tmp_path):
    """17: the relaxation-fit reader (--init of fit motion) refuses bpmid.relax/2 too."""
    init = tmp_path / "relax_fit.yaml"
    init.write_text("schema: bpmid.relax/2\nmode: ramp\npoisson_ratio: 0.49\n")
    out = tmp_path / "VBMM.yaml"
    r = runner.invoke(app, ["fit", "motion", str(FIT_LOG), "--init", str(init), "--out", str(out)])
    assert r.exit_code == 2
    line = _one_line(r)
    assert "relax_fit.yaml" in line and "'schema'" in line and "bpmid.relax/2" in line
    assert not out.exists()


# ---------------------------------------------------------------------------------------------
# 10, 11: control
# ---------------------------------------------------------------------------------------------
def test_control_duplicate_controller_or_reference_exits_2(tmp_path):
    """10: a controller (or a reference) listed twice is refused before any work, not a YAML crash."""
    p = _params(tmp_path)
    out = tmp_path / "c"
    r = runner.invoke(app, ["control", "--params", str(p), "--reference", "steps", "--controller", "pi,pi",
                            "--out", str(out)])
    assert r.exit_code == 2, r.output
    line = _one_line(r)
    assert "--controller" in line and "pi" in line and "twice" in line
    r = runner.invoke(app, ["control", "--params", str(p), "--reference", "steps,steps", "--controller", "pi",
                            "--out", str(out), "--no-figure"])
    assert r.exit_code == 2, r.output
    line = _one_line(r)
    assert "--reference" in line and "steps" in line and "twice" in line
    r = runner.invoke(app, ["control", "--params", str(p), "--reference", "steps", "--controller", ",",
                            "--out", str(out)])
    assert r.exit_code == 2 and "--controller" in _one_line(r)
    assert not out.exists()


def test_control_duplicate_controllers_in_config_exit_2(tmp_path):
    """10: the same rule for control.controllers of a config."""
    from bpmid.control import ControlConfig

    with pytest.raises(InputError, match="twice") as exc:
        ControlConfig(controllers=("pi", "vbmm-pi", "pi")).validate()
    assert exc.value.key == "control.controllers"


@pytest.mark.parametrize("seed", ["-3", "-1"])
def test_control_negative_seed_exits_2_naming_seed(tmp_path, seed):
    """11: --seed -3 is bad input, not an internal ValueError."""
    p = _params(tmp_path)
    out = tmp_path / "c"
    r = runner.invoke(app, ["control", "--params", str(p), "--reference", "steps", "--controller", "pi",
                            "--seed", seed, "--out", str(out)])
    assert r.exit_code == 2, r.output
    line = _one_line(r)
    assert "--seed" in line and seed in line
    assert not out.exists()
    cfg = tmp_path / "c.yaml"
    cfg.write_text("control:\n  seed: -2\n")
    r = runner.invoke(app, ["control", "--params", str(p), "--reference", "steps", "--controller", "pi",
                            "--config", str(cfg), "--out", str(out)])
    assert r.exit_code == 2 and "control.seed" in _one_line(r)
    assert not out.exists()


# ---------------------------------------------------------------------------------------------
# 20: simulate --effect message
# ---------------------------------------------------------------------------------------------
PROTO = """schema: bpmid.protocol/1
kind: motion
name: tiny
seed: 3
sampling_hz: 10
unit: bar
pressure_reference: absolute
logs:
  - name: tri
    start: 1.2
    program:
      - triangle: {low: 1.2, high: 1.6, rate: 0.2, cycles: 1}
plant:
  material: paper_fit
"""


def test_simulate_effect_out_of_range_message_reads_value_then_unit(tmp_path):
    """20: "-5 (unit 1) is outside [0, 0.9]", not "-5 1 is outside ..."."""
    proto = tmp_path / "p.yaml"
    proto.write_text(PROTO)
    out = tmp_path / "sim"
    r = runner.invoke(app, ["simulate", str(proto), "--effect", "thermal_softening:amount=-5", "--out", str(out)])
    assert r.exit_code == 2, r.output
    line = _one_line(r)
    assert "thermal_softening.amount" in line and "-5 (unit 1) is outside [0, 0.9]" in line
    assert not out.exists()


def test_control_and_simulate_refuse_a_fit_file_whose_effects_they_would_leave_out(tmp_path):
    """A fit file with an effects list (bpmid predict and export --to c run them) is refused by the commands that
    take only its VBMM constants, naming the file and the key and saying where they take effects."""
    fx = [{"id": "pressure_lag", "parameters": {"tau": 0.2}}]
    p = _params(tmp_path, lambda d: d.update(effects=fx), name="with_effects.yaml")
    out = tmp_path / "c"
    r = runner.invoke(app, ["control", "--params", str(p), "--reference", "steps", "--controller", "pi",
                            "--out", str(out)])
    assert r.exit_code == 2, r.output
    line = _one_line(r)
    assert "with_effects.yaml" in line and "effects" in line and "pressure_lag" in line and "--plant-effect" in line
    assert not out.exists()
    proto = tmp_path / "proto.yaml"
    proto.write_text(PROTO)
    r = runner.invoke(app, ["simulate", str(proto), "--params", str(p), "--out", str(tmp_path / "sim")])
    assert r.exit_code == 2, r.output
    line = _one_line(r)
    assert "with_effects.yaml" in line and "--effect" in line
    assert not (tmp_path / "sim").exists()
    # the same file without effects runs
    plain = _params(tmp_path, name="plain.yaml")
    r = runner.invoke(app, ["simulate", str(proto), "--params", str(plain), "--out", str(tmp_path / "sim2")])
    assert r.exit_code == 0, r.output


# ---------------------------------------------------------------------------------------------
# 21: discover --init without a schema
# ---------------------------------------------------------------------------------------------
def test_discover_init_without_schema_names_both_kinds(tmp_path):
    """21: the message names the two kinds --init takes."""
    c = tmp_path / "c.yaml"
    c.write_text("mode: ramp\npoisson_ratio: 0.49\n")
    out = tmp_path / "d"
    r = runner.invoke(app, ["discover", str(FIT_LOG), "--init", str(c), "--out", str(out)])
    assert r.exit_code == 2, r.output
    line = _one_line(r)
    assert "c.yaml" in line and "'schema'" in line and "expected schema bpmid.vbmm/1 or bpmid.relax/1" in line
    assert "<version>" not in line
    c.write_text("schema: bpmid.discovery/1\n")
    r = runner.invoke(app, ["discover", str(FIT_LOG), "--init", str(c), "--out", str(out)])
    assert r.exit_code == 2 and "bpmid.vbmm/1 or bpmid.relax/1" in _one_line(r)
    c.write_text("schema: bpmid.relax/2\n")
    r = runner.invoke(app, ["discover", str(FIT_LOG), "--init", str(c), "--out", str(out)])
    assert r.exit_code == 2 and "unsupported schema version" in _one_line(r)
    assert not out.exists()


# ---------------------------------------------------------------------------------------------
# 22: report
# ---------------------------------------------------------------------------------------------
def test_report_broken_yaml_is_one_line_with_file_and_line(tmp_path):
    """22: a broken stage file gives "file:line: not valid YAML", one line; nothing written."""
    d = tmp_path / "run"
    d.mkdir()
    (d / "relax_fit.yaml").write_text("schema: bpmid.relax/1\nmode: [\n")
    r = runner.invoke(app, ["report", str(d)])
    assert r.exit_code == 2, r.output
    line = _one_line(r)
    assert f"{d / 'relax_fit.yaml'}:" in line and "not valid YAML" in line
    assert sorted(p.name for p in d.iterdir()) == ["relax_fit.yaml"]


def test_report_on_a_file_says_so(tmp_path):
    """22: a file given as DIR is "a file, not a folder", not "not found"."""
    f = tmp_path / "log.csv"
    f.write_text("time_s\n0\n")
    r = runner.invoke(app, ["report", str(f)])
    assert r.exit_code == 2
    line = _one_line(r)
    assert "log.csv" in line and "is a file, not a folder" in line
    r = runner.invoke(app, ["report", str(tmp_path / "absent")])
    assert r.exit_code == 2 and "not found" in _one_line(r)


# ---------------------------------------------------------------------------------------------
# 7: run checks every input first, and leaves nothing half-written
# ---------------------------------------------------------------------------------------------
def _study(root: Path, long_term: str = "logs/long.csv", stages="[motion, history, report]") -> Path:
    logs = root / "logs"
    logs.mkdir(parents=True, exist_ok=True)
    _small_log(logs, "fit_a", 1)
    _small_log(logs, "long", 2, cycles=2)
    cfg = root / "study.yaml"
    cfg.write_text(f"run:\n  fitting_set: [logs/fit_a.csv]\n  long_term: {long_term}\n  stages: {stages}\n"
                   "  history_durations_s: [5]\n  history_repeats: 1\n")
    return cfg


def test_run_bad_later_log_is_refused_before_any_stage(tmp_path):
    """7: a NaN row in run.long_term (stage history) is found before stage motion runs; DIR is never made."""
    cfg = _study(tmp_path, long_term="logs/bad.csv")
    text = _small_log(tmp_path / "logs", "bad", 3).read_text().splitlines()
    i = next(k for k, ln in enumerate(text) if ln and ln[0].isdigit()) + 5
    cells = text[i].split(",")
    cells[1] = "nan"
    text[i] = ",".join(cells)
    (tmp_path / "logs" / "bad.csv").write_text("\n".join(text) + "\n")
    out = tmp_path / "r"
    r = runner.invoke(app, ["run", str(cfg), "--out", str(out)])
    assert r.exit_code == 2, r.output
    line = _one_line(r)
    assert f"bad.csv:{i + 1}" in line and "nan" in line.lower()
    assert not out.exists()


def test_run_discover_log_without_angle_is_refused_before_any_stage(tmp_path):
    """7: the logs of a later stage are read with that stage's reader (discover needs angles)."""
    cfg = _study(tmp_path, stages="[motion, discover]")
    nolog = tmp_path / "logs" / "noangle.csv"
    lines = (tmp_path / "logs" / "fit_a.csv").read_text().splitlines()
    nolog.write_text("\n".join(",".join(ln.split(",")[:2]) if not ln.startswith("#") else ln for ln in lines) + "\n")
    cfg.write_text(cfg.read_text() + "  discover_logs: [logs/noangle.csv]\n")
    out = tmp_path / "r"
    r = runner.invoke(app, ["run", str(cfg), "--out", str(out)])
    assert r.exit_code == 2, r.output
    assert "noangle.csv" in _one_line(r)
    assert not out.exists()


def test_run_relax_fit_named_by_config_is_checked_first(tmp_path):
    """7: a parameter file the config names (compare.relax) is read before any stage runs."""
    cfg = _study(tmp_path, stages="[motion, compare]")
    (tmp_path / "rf.yaml").write_text("schema: bpmid.relax/2\n")
    cfg.write_text(cfg.read_text() + "  test_sets: {a: [logs/long.csv]}\ncompare:\n  relax: rf.yaml\n"
                   "  models: [vbmm-mat]\n")
    out = tmp_path / "r"
    r = runner.invoke(app, ["run", str(cfg), "--out", str(out)])
    assert r.exit_code == 2, r.output
    assert "rf.yaml" in _one_line(r) and "schema" in r.output
    assert not out.exists()


def _failing_report(exc):
    def stage(inp, out, config, ctx):
        (out / "report.md").write_text("half")
        (out / "report_figures").mkdir(exist_ok=True)
        (out / "report_figures" / "x.png").write_bytes(b"x")
        raise exc
    return stage


def _kernel_interrupt() -> SystemError:
    """What Ctrl-C inside a compiled kernel looks like: SystemErrors chained to a KeyboardInterrupt."""
    inner = SystemError("returned a result with an exception set")
    inner.__cause__ = KeyboardInterrupt()
    outer = SystemError("CPUDispatcher returned a result with an exception set")
    outer.__cause__ = inner
    return outer


@pytest.mark.parametrize("exc, code", [(InputError("broken at the last stage"), 2), (KeyboardInterrupt(), 130),
                                       (_kernel_interrupt(), 130), (RuntimeError("bug"), 1)])
def test_run_failing_stage_leaves_no_new_folder(tmp_path, monkeypatch, exc, code):
    """7: stages motion and history ran and wrote files; the report stage fails (or Ctrl-C): no folder left."""
    import bpmid.run as R

    monkeypatch.setitem(R.STAGE_FUNCTIONS, "report", _failing_report(exc))
    cfg = _study(tmp_path)
    out = tmp_path / "new" / "r"
    r = runner.invoke(app, ["run", str(cfg), "--out", str(out)])
    assert r.exit_code == code, r.output
    assert not (tmp_path / "new").exists()


def test_run_failing_stage_restores_an_existing_folder(tmp_path, monkeypatch):
    """7: re-running into a folder holding an earlier run: on failure the folder is as it was, byte for byte
    (files replaced are put back, files added removed, other files untouched)."""
    import bpmid.run as R

    cfg = _study(tmp_path)
    out = tmp_path / "r"
    r = runner.invoke(app, ["run", str(cfg), "--out", str(out)])
    assert r.exit_code == 0, r.output
    (out / "notes.txt").write_text("mine")
    before = _tree(out)
    assert "run.yaml" in before and "vbmm_fit.yaml" in before and "history_modes.yaml" in before
    monkeypatch.setitem(R.STAGE_FUNCTIONS, "report", _failing_report(KeyboardInterrupt()))
    r = runner.invoke(app, ["run", str(cfg), "--out", str(out)])
    assert r.exit_code == 130, r.output
    assert _tree(out) == before
    assert sorted(os.listdir(out)) == sorted({k.split("/")[0] for k in before})  # no backup or temp folder left


def test_run_success_records_final_paths(tmp_path):
    """7: a run writes in place: provenance and report name DIR's own files, no temporary folder."""
    cfg = _study(tmp_path)
    out = tmp_path / "r"
    r = runner.invoke(app, ["run", str(cfg), "--out", str(out)])
    assert r.exit_code == 0, r.output
    hist = yaml.safe_load((out / "history_modes.yaml").read_text())
    assert str(out / "vbmm_fit.yaml") in hist["provenance"]["inputs"]
    assert not [p for p in out.iterdir() if p.name.startswith(".")]
    assert load_vbmm(out / "vbmm_mat.yaml").geometry == VBMM(material=Material.paper_fit()).geometry


# ---------------------------------------------------------------------------------------------
# usage lines
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("cmd, want", [(["run"], "[CONFIG]"), (["fit", "relax"], "LOG"), (["fit", "motion"], "LOG"),
                                       (["predict"], "LOG"), (["discover"], "LOG"), (["report"], "DIR"),
                                       (["simulate"], "PROTOCOL")])
def test_usage_lines_name_the_arguments_plainly(cmd, want):
    r = runner.invoke(app, cmd + ["--help"], terminal_width=200)
    assert r.exit_code == 0
    usage = next(ln for ln in r.output.splitlines() if ln.startswith("Usage:"))
    assert want in usage
    assert "[[" not in usage and "{" not in usage and "}" not in usage, usage
