"""bpmid run: every stage on a small config, reproducible numbers, config errors naming key and path."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from _signals import triangle_with_holds
import pandas as pd
import pytest
import yaml
from typer.testing import CliRunner

from bpmid.cli import app
from bpmid.errors import InputError
from bpmid.io.motion_logs import from_arrays, write_motion_log
from bpmid.models.vbmm import VBMM, Material

REPO = Path(__file__).resolve().parents[1]
ATM = 101325.0
runner = CliRunner()


def _log(folder: Path, name, rate, seed, lo=1.2, hi=1.7, cycles=2, hold=3.0) -> Path:
    t, p_bar = triangle_with_holds(rate, lo, hi, cycles, hold)
    pg = p_bar * 1e5 - ATM
    ang = VBMM(material=Material.paper_fit()).forward_deg(t, pg)
    ang = ang + np.random.default_rng(seed).normal(0.0, 0.2, t.size)
    lg = from_arrays(name, t, pg, ang, pressure_reference="absolute", pressure_unit="bar")
    return write_motion_log(folder / f"{name}.csv", lg, reference="absolute",
                            comments={"synthetic": "true (test twin)"})


SMALL_CONFIG = """
run:
  relax_logs: ["{relax}/relax_300mmmin_20pct.csv", "{relax}/relax_400mmmin_30pct.csv"]
  fitting_set: ["logs/fit_*.csv"]
  test_sets:
    variable_amplitude: ["logs/amp_*.csv"]
    variable_rate: ["logs/rate_*.csv"]
  long_term: logs/long.csv
  discover_logs: ["logs/fit_*.csv", "logs/amp_*.csv"]
  discover_holdout: ["logs/rate_*.csv"]
  history_durations_s: [20, 40]
  history_repeats: 1
  seed: 7
compare:
  models: [vbmm-mat, vbmm-fit, two-branch, maxwell-slip]
  timing: {timing}
  timing_repeats: 1
  figure_logs: 2
discover:
  candidates: [second_relaxation, pressure_lag, angle_offset, braid_friction]
  max_effects: 1
"""


def make_study(root: Path, timing: bool = False) -> Path:
    logs = root / "logs"
    logs.mkdir(parents=True, exist_ok=True)
    _log(logs, "fit_a", 0.2, 1)
    _log(logs, "fit_b", 0.2, 2)
    _log(logs, "amp_1p9", 0.2, 3, hi=1.9)
    _log(logs, "rate_0p114", 0.114, 4, cycles=1)
    _log(logs, "rate_0p267", 0.267, 5, cycles=2)
    _log(logs, "long", 0.2, 6, cycles=8, hold=2.0)
    cfg = root / "study.yaml"
    cfg.write_text(SMALL_CONFIG.format(relax=REPO / "datasets" / "relaxation", timing=str(timing).lower()))
    return cfg


# the stages whose numbers the reproducibility check compares (the report only presents them)
NUMBER_STAGES = "[relax, motion, compare, history, discover]"


@pytest.fixture(scope="module")
def study_runs(tmp_path_factory):
    """The small study run twice into two folders (same config), with timing off so every file is reproducible
    to the byte, and without the report and the per-log comparison figures (they present the numbers compared
    here; the full run with them is the session's ``timed_small_study``)."""
    import os

    import bpmid.report.figures as RF

    root = tmp_path_factory.mktemp("study")
    cfg = make_study(root)
    text = cfg.read_text().replace("run:\n", f"run:\n  stages: {NUMBER_STAGES[:-1]}, report]\n", 1)
    text = text.replace("figure_logs: 2", "figure_logs: 0")
    outs = []

    def recorded(draw, what):  # where (which process) each of the report's own figures is drawn
        def wrapper(root_dir, info, synthetic):
            with open(Path(root_dir) / "drawn.txt", "a") as f:
                f.write(f"{what} {os.getpid()}\n")
            return draw(root_dir, info, synthetic)
        return wrapper

    # run1 one stage after another in this process, run2 the stages after the motion fit side by side
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(RF, "relax_figures", recorded(RF.relax_figures, "relax"))
        mp.setattr(RF, "compare_figures", recorded(RF.compare_figures, "compare"))
        for name, workers in (("run1", 1), ("run2", 2)):
            cfg.write_text(text.replace("run:\n", f"run:\n  workers: {workers}\n", 1))
            r = runner.invoke(app, ["run", str(cfg), "--out", str(root / name)])
            assert r.exit_code == 0, r.output
            outs.append(root / name)
    return cfg, outs


def test_run_writes_every_stage_file_with_cli_names(timed_small_study):
    out = timed_small_study  # the small study, every stage, run once per session (tests/conftest.py)
    for f in ("relax_fit.yaml", "relax_fit.png", "vbmm_fit.yaml", "vbmm_fit.png", "vbmm_mat.yaml",
              "compare/metrics.csv", "compare/summary.csv", "compare/compare.yaml", "history_modes.csv",
              "history_modes.yaml", "history_modes.png", "discover/discovery.yaml", "report.html", "report.md",
              "run.yaml"):
        assert (out / f).is_file(), f
    relax = yaml.safe_load((out / "relax_fit.yaml").read_text())
    assert relax["schema"] == "bpmid.relax/1" and "E_inf" in relax["prony"]
    fit = yaml.safe_load((out / "vbmm_fit.yaml").read_text())
    assert fit["schema"] == "bpmid.vbmm/1"
    for k in ("rmse_deg", "mape_pct", "r2"):
        assert k in fit["metrics"]
    mat = yaml.safe_load((out / "vbmm_mat.yaml").read_text())
    # VBMM-mat. is the relaxation fit's K, nothing refitted
    assert mat["material"]["K_inf"]["value"] == pytest.approx(relax["bulk"]["K_inf"]["value"], rel=1e-9)
    disc = yaml.safe_load((out / "discover" / "discovery.yaml").read_text())
    assert disc["schema"] == "bpmid.discovery/1" and "named_effects" in disc and "unexplained" in disc
    # what the reader found is recorded by the run's stages as by the commands (it used to be missing here)
    for f in ("discover/discovery.yaml", "discover/model.yaml", "history_modes.yaml"):
        prov = yaml.safe_load((out / f).read_text())["provenance"]
        assert prov["reading"] and all("columns" in r for r in prov["reading"].values()), f
        assert prov["warnings"] == [], f
    run = yaml.safe_load((out / "run.yaml").read_text())
    assert [s["name"] for s in run["stages"]] == ["relax", "motion", "compare", "history", "discover", "control", "report"]
    assert all(s["status"] == "done" for s in run["stages"])
    prov = run["provenance"]
    assert prov["seed"] == 7 and prov["config"]["sha256"] and len(prov["inputs"]) == 8
    summary = pd.read_csv(out / "compare" / "summary.csv")
    assert set(summary["model"]) == {"vbmm-mat", "vbmm-fit", "two-branch", "maxwell-slip"}
    hist = pd.read_csv(out / "history_modes.csv")
    assert set(hist["mode"]) == {"recursive", "window", "full"}
    h = yaml.safe_load((out / "history_modes.yaml").read_text())
    assert h["window_vs_full"]["max_abs_diff_deg"] < 0.05  # T_win = 20 s: many time constants


NUMBERS = {"relax_fit.yaml": ("prony", "shear", "bulk", "metrics"),
           "vbmm_fit.yaml": ("material", "metrics"), "vbmm_mat.yaml": ("material", "metrics"),
           "history_modes.yaml": ("accuracy", "window_vs_full"),
           "discover/discovery.yaml": ("named_effects", "gap", "unexplained")}


def test_two_runs_give_identical_metrics_files(study_runs):
    _cfg, (a, b) = study_runs
    for f in ("compare/metrics.csv", "compare/summary.csv", "compare/summary_by_set.csv",
              "compare/predictions/rate_0p114.csv"):
        assert (a / f).read_bytes() == (b / f).read_bytes(), f
    for f, keys in NUMBERS.items():
        da, db = yaml.safe_load((a / f).read_text()), yaml.safe_load((b / f).read_text())
        for k in keys:
            assert da[k] == db[k], f"{f}: {k}"


def test_every_file_of_a_run_carries_its_run_id_in_stage_processes_too(study_runs):
    """run2 ran its later stages in forked processes: their files carry the run's id as well; two runs of the
    same config have different ids (the report tells a stage file of one from the other's)."""
    _cfg, (a, b) = study_runs
    ids = []
    for out in (a, b):
        files = sorted(out.rglob("*.yaml"))
        assert len(files) == 8, files  # run.yaml and the stage files of relax, motion (2), compare, history, discover (2)
        ids.append({f.relative_to(out).as_posix(): yaml.safe_load(f.read_text())["provenance"]["run_id"]
                    for f in files})
        assert len(set(ids[-1].values())) == 1, ids[-1]
    assert ids[0]["run.yaml"] != ids[1]["run.yaml"]


def test_report_figures_drawn_beside_the_stages_are_the_report_stage_s(study_runs):
    """Side by side, the report's own figures are drawn in the stage processes as soon as their files are written
    (each once), and the report uses them: the same files, to the byte, as the report draws itself in a run of one
    stage after another."""
    import os

    _cfg, (a, b) = study_runs
    here = str(os.getpid())
    drawn_a = sorted(line.split() for line in (a / "drawn.txt").read_text().splitlines())
    drawn_b = sorted(line.split() for line in (b / "drawn.txt").read_text().splitlines())
    assert [w for w, _ in drawn_a] == [w for w, _ in drawn_b] == ["compare", "relax"]
    assert all(pid == here for _, pid in drawn_a)
    if sys.platform.startswith("linux"):  # side by side only where processes fork
        assert all(pid != here for _, pid in drawn_b)
    figs = sorted(p.name for p in (a / "report_figures").iterdir())
    assert figs == sorted(p.name for p in (b / "report_figures").iterdir())
    assert {"modulus_curves.png", "error_bands.png", "residuals.png"} <= set(figs)
    for f in figs:
        assert (a / "report_figures" / f).read_bytes() == (b / "report_figures" / f).read_bytes(), f
    md = (b / "report.md").read_text()
    assert all(f"report_figures/{f}" in md for f in ("modulus_curves.png", "error_bands.png", "residuals.png"))


def test_report_figures_and_timing_do_not_change_the_numbers(study_runs, timed_small_study):
    """The full run (report, figures, timing on) has the numbers of the runs without them, to the last digit;
    only the wall-clock cost per step differs."""
    _cfg, (a, _) = study_runs
    full = timed_small_study
    for f in ("compare/metrics.csv", "compare/summary.csv", "compare/summary_by_set.csv"):
        x, y = pd.read_csv(a / f), pd.read_csv(full / f)
        assert x["us_per_step"].isna().all() and (y["us_per_step"] > 0).all(), f
        pd.testing.assert_frame_equal(x.drop(columns="us_per_step"), y.drop(columns="us_per_step"), check_exact=True)
    f = "compare/predictions/rate_0p114.csv"
    assert (a / f).read_bytes() == (full / f).read_bytes(), f
    for f, keys in NUMBERS.items():
        da, db = yaml.safe_load((a / f).read_text()), yaml.safe_load((full / f).read_text())
        for k in keys:
            assert da[k] == db[k], f"{f}: {k}"


def test_timing_is_measured_when_on(tmp_path):
    """With timing on (the default) every model has a cost per step; the other columns match a run without."""
    from bpmid.compare import compare_models
    from bpmid.io.motion_logs import read_motion_logs

    make_study(tmp_path)
    logs = read_motion_logs(sorted((tmp_path / "logs").glob("fit_*.csv")))
    test = read_motion_logs(sorted((tmp_path / "logs").glob("rate_*.csv")))
    on = compare_models(logs, test, ["two-branch"], timing=True, timing_repeats=1)
    off = compare_models(logs, test, ["two-branch"], timing=False)
    assert (on.metrics["us_per_step"] > 0).all() and off.metrics["us_per_step"].isna().all()
    pd.testing.assert_frame_equal(on.metrics.drop(columns="us_per_step"), off.metrics.drop(columns="us_per_step"))


def test_a_failing_stage_beside_others_rolls_the_run_back(tmp_path, monkeypatch):
    """Stages run side by side (forked processes): one failing stops the run with its message (exit 2), and the
    folder is put back as it was, including what the other stage process wrote."""
    import bpmid.run as R

    cfg = make_study(tmp_path)
    cfg.write_text(cfg.read_text().replace("run:\n", "run:\n  stages: [history, control]\n  workers: 2\n", 1))
    out = tmp_path / "out"
    out.mkdir()
    (out / "history_modes.csv").write_text("earlier run\n")

    def failing(inp, out_dir, config, ctx):
        (out_dir / "history_modes.csv").write_text("half\n")
        raise InputError("the long-term log is broken", path="long.csv")

    monkeypatch.setitem(R.STAGE_FUNCTIONS, "history", failing)
    import sys

    assert R.stage_workers(R.RunConfig(workers=2)) == (2 if sys.platform.startswith("linux") else 1)
    r = runner.invoke(app, ["run", str(cfg), "--out", str(out)])
    assert r.exit_code == 2 and "long.csv: the long-term log is broken" in r.output, r.output
    assert sorted(p.name for p in out.iterdir()) == ["history_modes.csv"]
    assert (out / "history_modes.csv").read_text() == "earlier run\n"


def test_missing_input_names_key_and_path(tmp_path):
    cfg = make_study(tmp_path)
    text = cfg.read_text().replace("long_term: logs/long.csv", "long_term: logs/missing_long.csv")
    cfg.write_text(text)
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2
    assert "run.long_term" in r.output and "missing_long.csv" in r.output and str(cfg) in r.output
    assert not (tmp_path / "o").exists()  # checked before any work
    cfg.write_text(text.replace("logs/missing_long.csv", "logs/long.csv").replace('["logs/amp_*.csv"]',
                                                                                  '["logs/nothing_*.csv"]'))
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and "run.test_sets.variable_amplitude[0]" in r.output and "nothing_" in r.output


def test_bad_config_keys_and_stage_names_exit_2(tmp_path):
    cfg = tmp_path / "c.yaml"
    cfg.write_text("run:\n  stages: [relax, fly]\n")
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and "run.stages[1]" in r.output and "fly" in r.output
    cfg.write_text("run:\n  fitting_sets: [a.csv]\n")
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and "run.fitting_sets" in r.output
    r = runner.invoke(app, ["run", str(tmp_path / "absent.yaml")])
    assert r.exit_code == 2 and "absent.yaml" in r.output


def test_a_path_written_from_the_working_directory_is_named_with_the_config_s_folder(tmp_path, monkeypatch):
    """A config in a subfolder whose paths were written from the working directory (a trial's first study config):
    the error names the config's folder paths are read from and the path to write, for a file and a pattern."""
    (tmp_path / "lab").mkdir()
    (tmp_path / "lab" / "long.csv").write_text("time_s,pressure_kpa,angle_deg\n0,1,1\n")
    (tmp_path / "lab" / "fit_1.csv").write_text("time_s,pressure_kpa,angle_deg\n0,1,1\n")
    (tmp_path / "cfgs").mkdir()
    monkeypatch.chdir(tmp_path)
    cfg = Path("cfgs") / "study.yaml"
    cfg.write_text("run:\n  long_term: lab/long.csv\n")
    r = runner.invoke(app, ["run", str(cfg), "--out", "o"])
    assert r.exit_code == 2, r.output
    assert "key 'run.long_term':" in r.output and "file not found: cfgs/lab/long.csv" in r.output
    assert "relative to the config's folder, cfgs" in r.output and "write ../lab/long.csv" in r.output
    cfg.write_text("run:\n  fitting_set: [lab/fit_*.csv]\n")
    r = runner.invoke(app, ["run", str(cfg), "--out", "o"])
    assert r.exit_code == 2 and "run.fitting_set[0]" in r.output and "write ../lab/fit_*.csv" in r.output
    assert not Path("o").exists() and "Traceback" not in r.output


def test_the_control_stage_tracks_the_config_s_own_references(tmp_path):
    """run.control_references: a study of another muscle tracks its own reference files (a trial's control stage
    could only run the paper's shipped references, 45-90 deg, beyond its muscle's 56 deg, all saturated); they are
    read before any stage runs, recorded with their sha256, and a missing one is refused naming the key."""
    refs = tmp_path / "refs"
    refs.mkdir()
    t = np.arange(0.0, 12.0 + 1e-9, 0.1)
    ref = pd.DataFrame({"time_s": np.round(t, 3), "angle_deg": np.where(t < 6.0, 30.0, 36.0)})
    ref.to_csv(refs / "my_steps.csv", index=False)
    cfg = tmp_path / "study.yaml"
    cfg.write_text("run:\n  stages: [control]\n  control_references: [refs/my_*.csv]\n")
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    summary = pd.read_csv(tmp_path / "o" / "control" / "summary.csv")
    assert set(summary["reference"]) == {"my_steps", "ALL"}
    run = yaml.safe_load((tmp_path / "o" / "run.yaml").read_text())
    assert any(k.endswith("refs/my_steps.csv") for k in run["provenance"]["inputs"])
    # a reference file that is not there, or one the reader refuses: exit 2, the key or file named, nothing written
    cfg.write_text("run:\n  stages: [control]\n  control_references: [refs/my_steps.csv, refs/nothing.csv]\n")
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o2")])
    assert r.exit_code == 2 and "run.control_references[1]" in r.output and "nothing.csv" in r.output, r.output
    (refs / "bad.csv").write_text("time_s,angle\n0,30\n0.1,31\n")
    cfg.write_text("run:\n  stages: [control]\n  control_references: [refs/bad.csv]\n")
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o2")])
    assert r.exit_code == 2 and "bad.csv" in r.output and "Traceback" not in r.output, r.output
    assert not (tmp_path / "o2").exists()
    # two files of one name in two folders: references are told apart by name, so refused before any stage
    (tmp_path / "more").mkdir()
    ref.to_csv(tmp_path / "more" / "my_steps.csv", index=False)
    cfg.write_text("run:\n  stages: [control]\n  control_references: [refs/my_steps.csv, more/my_steps.csv]\n")
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o2")])
    assert r.exit_code == 2 and "run.control_references" in r.output and "my_steps is given twice" in r.output, r.output
    assert not (tmp_path / "o2").exists()


def test_the_readme_s_own_study_config_is_a_valid_config(tmp_path):
    """The README's example of a study config of one's own (a trial found the keys of run documented nowhere but
    in the shipped config and the error messages): every key it shows is one bpmid run reads."""
    from bpmid.config import load_config

    text = (REPO / "README.md").read_text(encoding="utf-8")
    block = text[text.index("**Your own study.**"):]
    block = block[block.index("```yaml\n") + 8:block.index("```\n", block.index("```yaml\n") + 8)]
    cfg = tmp_path / "my_study.yaml"
    cfg.write_text(block)
    config = load_config(cfg)
    rc = config.section("run")
    assert rc.control_references == ("refs/*.csv",) and set(rc.test_sets) == {"amplitude", "rate"}
    assert config.section("control").rate_hz == 20 and abs(config.section("model").geometry.R0 - 0.012) < 1e-12


def test_a_held_out_log_that_is_also_a_discovery_log_is_named_by_the_config_s_keys(tmp_path):
    """A trial's run.discover_holdout repeated a log of run.discover_logs: the refusal spoke of the discover command's
    'LOG or --holdout', which a study config does not have; it names the run keys, before anything is written."""
    cfg = make_study(tmp_path)
    cfg.write_text("run:\n  discover_logs: [logs/fit_*.csv]\n  discover_holdout: [logs/rate_0p114.csv, logs/fit_b.csv]\n"
                   "  stages: [discover]\n")
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2, r.output
    assert "run.discover_holdout[1]" in r.output and "also in run.discover_logs" in r.output
    assert "--holdout" not in r.output and not (tmp_path / "o").exists()


def test_stage_without_inputs_is_skipped_and_said_so(tmp_path):
    cfg = make_study(tmp_path)
    cfg.write_text("run:\n  long_term: logs/long.csv\n  history_durations_s: [20]\n  history_repeats: 1\n")
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    run = yaml.safe_load((tmp_path / "o" / "run.yaml").read_text())
    status = {s["name"]: s for s in run["stages"]}
    assert status["history"]["status"] == "done" and status["report"]["status"] == "done"
    assert status["relax"]["status"] == "skipped" and "run.relax_logs" in status["relax"]["note"]
    md = (tmp_path / "o" / "report.md").read_text()
    assert "Not run (no relax_fit.yaml" in md and "History modes on the long-term run" in md


def test_a_new_output_folder_honours_the_umask(tmp_path):
    """The run's folder is made hidden (mkdtemp, mode 0700) with its journal inside and renamed into place: it
    must end with the mode every other command gives a new folder (0777 less the umask), not 0700 (as did
    the parent folder the run made for it)."""
    import os
    import stat

    cfg = make_study(tmp_path)
    cfg.write_text("run:\n  long_term: logs/long.csv\n  stages: [history]\n  history_durations_s: [20]\n"
                   "  history_repeats: 1\n")
    old = os.umask(0o022)
    try:
        r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "new" / "o")])
    finally:
        os.umask(old)
    assert r.exit_code == 0, r.output
    mode = {d: stat.S_IMODE((tmp_path / d).stat().st_mode) for d in ("new", "new/o")}
    assert mode == {"new": 0o755, "new/o": 0o755}, {k: oct(v) for k, v in mode.items()}


def test_default_config_is_found_from_any_working_directory(tmp_path, monkeypatch):
    import bpmid.run as R

    monkeypatch.chdir(tmp_path)
    path = R.default_config_path()
    assert path == REPO / "configs" / "paper.yaml"
    from bpmid.config import load_config

    cfg = load_config(path)
    inp = R.resolve_run_inputs(cfg)  # every shipped input the paper config names exists
    assert len(inp.fitting_set) >= 1 and set(inp.test_sets) == {"variable_amplitude", "variable_rate"}
    assert inp.long_term is not None and inp.relax_logs
    monkeypatch.setattr(R, "DEFAULT_CONFIG", Path("configs") / "no_such.yaml")
    with pytest.raises(InputError, match="default configs/paper.yaml was not found"):
        R.default_config_path()


def test_negative_workers_is_refused_before_any_work(tmp_path):
    cfg = make_study(tmp_path)
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "out"), "--workers", "-1"])
    assert r.exit_code == 2 and "--workers" in r.output
    assert not (tmp_path / "out").exists()


def test_side_by_side_jobs_wait_for_the_stage_they_are_drawn_from(tmp_path, monkeypatch):
    """A figure job that waits for a stage starts only once that stage is done, even with a process free; what it
    returns reaches ctx['drawn']; a job waiting for a stage that never runs is a bug, said as such."""
    import time

    import bpmid.run as R

    # (the function forks: bpmid calls it only where processes fork, see stage_workers; so does CI)
    def slow(inp, out, config, ctx):
        time.sleep(0.3)
        (out / "slow.done").write_text("done")
        return ["slow.done"]

    def quick(inp, out, config, ctx):
        return []

    monkeypatch.setitem(R.STAGE_FUNCTIONS, "slowstage", slow)
    monkeypatch.setitem(R.STAGE_FUNCTIONS, "quickstage", quick)
    out = tmp_path

    def figure():
        return {"seen": (out / "slow.done").read_text()}  # FileNotFoundError if it ran too early

    ctx: dict = {}
    done = R._run_side_by_side(["slowstage", ("fig", figure, "slowstage"), "quickstage"], 2, None, out, None, ctx)
    assert set(done) == {"slowstage", "quickstage"} and ctx["drawn"] == {"seen": "done"}
    with pytest.raises(RuntimeError, match="waits for nostage"):
        R._run_side_by_side([("fig", figure, "nostage")], 2, None, out, None, {})


def test_a_study_on_a_measured_relaxation_curve_is_not_called_synthetic(tmp_path):
    """The study is synthetic only when every log it reads is: relaxation logs count too (a study of the measured
    pyvisco master curve read 'Data: SYNTHETIC')."""
    from bpmid.io.motion_logs import file_is_synthetic

    assert all(file_is_synthetic(p) for p in (REPO / "datasets" / "relaxation").glob("*.csv"))
    assert not file_is_synthetic(REPO / "datasets" / "reference" / "pyvisco" / "time_user_master.csv")
    (tmp_path / "mine.csv").write_text("# synthetic: true (my own generator)\nt,E_relax\n1,2\n")
    (tmp_path / "lab.csv").write_text("# operator: A. Person\nt,E_relax\n1,2\n")
    assert file_is_synthetic(tmp_path / "mine.csv") and not file_is_synthetic(tmp_path / "lab.csv")
    # beside one of bpmid's synthetic motion logs the study is mixed: not called measured (27 of 37 logs synthetic
    # read 'Data: measured logs' in the review that found it); run.yaml counts them, the report names them
    synth = REPO / "datasets" / "motion" / "fitting_set" / "fit_1p2_1p6_r1.csv"
    cfg = tmp_path / "m.yaml"
    cfg.write_text(f"run:\n  relax_logs: [\"{REPO / 'datasets/reference/pyvisco/time_user_master.csv'}\"]\n"
                   f"  fitting_set: [\"{synth}\"]\n  stages: [relax, report]\nrelax:\n  terms: 8\n")
    res = CliRunner().invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    run = yaml.safe_load((tmp_path / "o" / "run.yaml").read_text())
    assert run["synthetic"] is False
    assert run["data_logs"] == {"total": 2, "synthetic": 1, "synthetic_files": [str(synth)]}
    page = " ".join((tmp_path / "o" / "report.md").read_text().split())
    assert "Data: MIXED. 1 of 2 logs" in page and str(synth.parent) in page
    assert "Data: measured logs" not in page and "Data: SYNTHETIC" not in page



def test_a_stage_asked_for_without_its_inputs_or_a_config_with_no_data_is_refused(tmp_path):
    """run.stages naming a stage whose inputs the config does not give (skipped, exit 0, before), and a config
    that only overrides settings (control on default constants alone, exit 0, before): exit 2 naming the key,
    nothing written. Naming the stages that need no data still runs them."""
    cases = {"run:\n  stages: [compare]\n": ("run.stages[0]", "stage compare is asked for but cannot run"),
             "model:\n  history: window\n": ("key 'run'", "gives no data for any stage"),
             "run:\n  stages: [report, report]\n": ("run.stages", "named twice"),
             "run:\n  seed: -5\n": ("run.seed", "seed >= 0")}
    for i, (text, (key, words)) in enumerate(cases.items()):
        cfg = tmp_path / f"c{i}.yaml"
        cfg.write_text(text)
        r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / f"o{i}")])
        assert r.exit_code == 2 and key in r.output and words in r.output, r.output
        assert not (tmp_path / f"o{i}").exists()
    # a config that names only the stages needing no data runs them (on default constants)
    cfg = tmp_path / "ctl.yaml"
    cfg.write_text("run:\n  stages: [control]\ncontrol:\n  controllers: [pi]\n")
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "ok")])
    assert r.exit_code == 0 and (tmp_path / "ok" / "control" / "summary.csv").is_file(), r.output


def test_a_log_s_reading_error_names_the_study_config_s_io_keys_not_flags_run_does_not_take(tmp_path):
    # bpmid run has no --pressure-unit, --columns ...: a log without a pressure unit said "the flag
    # --pressure-unit kPa" only; it names io.units.pressure, where a study config states it
    logs = tmp_path / "logs"
    logs.mkdir()
    t = np.arange(0.0, 20.0, 0.1)
    rows = "".join(f"{a:.1f},{30 + 20 * np.sin(a):.4f},{40 + 10 * np.sin(a):.4f}\n" for a in t)
    (logs / "fit.csv").write_text("time_s,pressure,angle_deg\n" + rows, encoding="utf-8")
    cfg = tmp_path / "study.yaml"
    cfg.write_text("run:\n  fitting_set: [logs/fit.csv]\n  stages: [motion]\n", encoding="utf-8")
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o")])
    out = " ".join(r.output.split())
    assert r.exit_code == 2 and "fit.csv" in out, r.output
    assert "bpmid run takes no reading flags: set them in the study config's io section" in out, r.output
    assert "--pressure-unit is io.units.pressure" in out and not (tmp_path / "o").exists(), r.output
    # the command that has the flag still names it alone
    r = runner.invoke(app, ["fit", "motion", str(logs / "fit.csv"), "--out", str(tmp_path / "v.yaml")])
    assert r.exit_code == 2 and "--pressure-unit" in r.output and "reading flags" not in r.output, r.output


def test_history_durations_beyond_the_long_log_and_a_window_as_long_as_it_are_said(tmp_path):
    """run.history_durations_s: [20, 400] on a 46 s log wrote one row of 46 s for the 400 asked, and a 100 s window
    on it compared the full sum with itself (window - full 0.0), both without a word."""
    logs = tmp_path / "logs"
    logs.mkdir()
    _log(logs, "long", 0.2, 6, cycles=8, hold=2.0)
    cfg = tmp_path / "study.yaml"
    cfg.write_text("run:\n  long_term: logs/long.csv\n  stages: [history]\n  history_durations_s: [20, 400]\n"
                   "  history_repeats: 1\nmodel:\n  window_s: 100\n")
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    assert "run.history_durations_s: 400 s is beyond the long log" in r.output
    assert "model.window_s (100 s) is not shorter than the long log" in r.output
    cfg.write_text("run:\n  long_term: logs/long.csv\n  stages: [history]\n  history_durations_s: [20]\n"
                   "  history_repeats: 1\n")
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o2")])
    assert r.exit_code == 0, r.output
    assert "history_durations_s" not in r.output and "window_s" not in r.output


def test_the_history_stage_warns_when_its_constants_do_not_fit_the_long_log(tmp_path):
    """stages: [history] without a fitting set runs the paper's constants; on another muscle's long log they
    explained R^2 0.04 of the angle and history_modes.yaml reported the three modes' errors without a word (bpmid
    predict warns below R^2 0.5)."""
    logs = tmp_path / "logs"
    logs.mkdir()
    t, p_bar = triangle_with_holds(0.2, 1.2, 1.7, 8, 2.0)
    pg = p_bar * 1e5 - ATM
    other = 0.2 * VBMM(material=Material.paper_fit()).forward_deg(t, pg) + 10.0   # a much stiffer muscle
    other = other + np.random.default_rng(11).normal(0.0, 0.2, t.size)
    write_motion_log(logs / "long.csv", from_arrays("long", t, pg, other, pressure_reference="absolute",
                                                    pressure_unit="bar"),
                     reference="absolute", comments={"synthetic": "true (test twin)"})
    cfg = tmp_path / "study.yaml"
    cfg.write_text("run:\n  long_term: logs/long.csv\n  stages: [history]\n  history_durations_s: [20]\n"
                   "  history_repeats: 1\n")
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    assert "explain little of the long log's angle" in r.output and "run.fitting_set" in r.output
    body = yaml.safe_load((tmp_path / "o" / "history_modes.yaml").read_text())
    assert any("explain little" in w for w in body["provenance"]["warnings"])
    # the report's history section says it too, and does not call the paper's constants "fitted"
    r = runner.invoke(app, ["report", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    md = (tmp_path / "o" / "report.md").read_text()
    section = md.split("## History modes on the long-term run")[1].split("\n## ")[0]
    assert "Warning: long: the constants used (the paper's VBMM-fit constants) explain little" in section
    assert "The fitted VBMM" not in section
    cfg.write_text(cfg.read_text() + "io:\n  strict: true\n")
    r = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o2")])
    assert r.exit_code == 2 and not (tmp_path / "o2").exists()
