"""bpmid compare: generic over the registry, CLI.md columns, cost per step, verdicts, bad input."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
from _signals import triangle_with_holds
import pandas as pd
import pytest
from typer.testing import CliRunner

from bpmid.cli import app
from bpmid.compare import (FITTED_SET, CompareWarning, compare_models, overlap_warnings, verdicts,
                           write_compare)
from bpmid.errors import InputError
from bpmid.io.motion_logs import from_arrays, write_motion_log
from bpmid.models import REGISTRY
from bpmid.models.base import ModelFamily
from bpmid.models.vbmm import VBMM, Material
from bpmid.params import Param, ParamSet

ATM = 101325.0
runner = CliRunner()

#: metrics.csv / summary.csv columns, copied from CLI.md (compare); other columns may be added
CLI_COLUMNS = ["model", "log", "rmse_deg", "mape_pct", "r2", "fit_pct", "max_abs_err_deg", "us_per_step", "n_params"]


def has_cli_columns(columns) -> bool:
    """Every CLI.md column is there, in CLI.md's order (extra columns anywhere are allowed)."""
    return [c for c in columns if c in CLI_COLUMNS] == CLI_COLUMNS


# ------------------------------------------------------------------------------------------------
# a plant with creep (the VBMM's viscoelasticity) and rate-independent hysteresis (a play operator)
# ------------------------------------------------------------------------------------------------
pressure = triangle_with_holds


def play(x, r):
    z, prev = np.empty_like(x), x[0]
    for k, v in enumerate(x):
        prev = max(v - r, min(v + r, prev))
        z[k] = prev
    return z


def plant_log(name, rate, seed, friction_deg=2.0, **kw):
    t, p_bar = pressure(rate, **kw)
    pg = p_bar * 1e5 - ATM
    ang = VBMM(material=Material.paper_fit()).forward_deg(t, pg) + friction_deg * play(p_bar, 0.05)
    ang = ang + np.random.default_rng(seed).normal(0.0, 0.2, t.size)
    return from_arrays(name, t, pg, ang, pressure_reference="absolute", pressure_unit="bar")


def write_logs(folder: Path, logs) -> list[Path]:
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for lg in logs:
        out.append(write_motion_log(folder / f"{lg.name}.csv", lg, reference="absolute",
                                    comments={"synthetic": "true (test plant)"}))
    return out


@pytest.fixture(scope="module")
def rate_logs():
    train = [plant_log("train_0p2", 0.2, 1)]
    test = [plant_log("rate_0p114", 0.114, 2), plant_log("rate_0p267", 0.267, 3)]
    return train, test


# ------------------------------------------------------------------------------------------------
# a family registered by this test only: compare must handle it without any change
# ------------------------------------------------------------------------------------------------
class StaticLinearModel(ModelFamily):
    """angle = a + b (P - 0.6 bar): the simplest family, to show compare is generic over the registry."""

    name = "static-linear"
    label = "Static linear"
    min_samples = 5

    def __init__(self, offset_deg: float = 0.0):
        self.offset_deg = float(offset_deg)

    def default_params(self) -> ParamSet:
        return ParamSet([Param("a", 0.0, "deg"), Param("b", 10.0, "deg/bar")])

    def simulate(self, params, log):
        return params.value("a") + self.offset_deg + params.value("b") * (log.pressure_pa / 1e5 - 0.6)


def test_compare_is_generic_over_a_new_family(monkeypatch, rate_logs):
    monkeypatch.setitem(REGISTRY, "static-linear", f"{__name__}:StaticLinearModel")
    train, test = rate_logs
    res = compare_models(train, test, ["static-linear", "two-branch"], timing_repeats=1)
    assert has_cli_columns(res.metrics.columns) and has_cli_columns(res.summary.columns), list(res.metrics.columns)
    assert len(res.metrics) == 2 * len(test)
    assert set(res.summary["model"]) == {"static-linear", "two-branch"}
    assert (res.summary["log"] == "ALL").all()
    # the new family's fit is a real least-squares fit: it beats its own starting guess
    lin = res.outcome("static-linear")
    start = StaticLinearModel().default_params()
    y = np.concatenate([lg.angle_deg for lg in test])
    y0 = np.concatenate([StaticLinearModel().simulate(start, lg) for lg in test])
    assert res.summary.set_index("model").loc["static-linear", "rmse_deg"] < np.sqrt(np.mean((y - y0) ** 2))
    assert lin.n_params == 2
    # constructor settings come from options, per family
    res2 = compare_models(train, test, ["static-linear"], options={"static-linear": {"offset_deg": 5.0}},
                          timing=False)
    p = res2.outcome("static-linear").fit.params
    assert p.value("a") == pytest.approx(res.outcome("static-linear").fit.params.value("a") - 5.0, abs=1e-3)


def expected_metrics(y, yh):
    """CLI.md's metrics written out with plain numpy (independent of bpmid.metrics)."""
    y, yh = np.asarray(y, float), np.asarray(yh, float)
    err = y - yh
    sse, sst = np.sum(err ** 2), np.sum((y - np.mean(y)) ** 2)
    return {"rmse_deg": np.sqrt(np.mean(err ** 2)), "mape_pct": 100.0 * np.mean(np.abs(err / y)),
            "r2": 1.0 - sse / sst, "fit_pct": 100.0 * (1.0 - np.sqrt(sse) / np.sqrt(sst)),
            "max_abs_err_deg": np.max(np.abs(err))}


def test_expected_metrics_by_hand():
    # y = 1, 2, 3, 4 and predictions 1, 2, 3, 6: errors 0, 0, 0, -2; mean 2.5, SST = 5, SSE = 4
    m = expected_metrics([1, 2, 3, 4], [1, 2, 3, 6])
    assert m["rmse_deg"] == 1.0 and m["max_abs_err_deg"] == 2.0 and m["mape_pct"] == pytest.approx(12.5)
    assert m["r2"] == pytest.approx(0.2) and m["fit_pct"] == pytest.approx(100 * (1 - 2 / np.sqrt(5)))


def test_metrics_and_summary_are_the_pooled_metrics(rate_logs):
    train, test = rate_logs
    res = compare_models(train, test, ["maxwell-slip", "two-branch"], sets={"a": ["rate_0p114"], "b": ["rate_0p267"]},
                         timing_repeats=2)
    for o in res.outcomes:
        for lg in test:
            row = res.metrics[(res.metrics.model == o.name) & (res.metrics.log == lg.name)].iloc[0]
            assert np.all(np.isfinite(o.predictions[lg.name]))
            want = expected_metrics(lg.angle_deg, o.predictions[lg.name])
            for col, v in want.items():
                assert row[col] == pytest.approx(v, rel=1e-9), (o.name, lg.name, col)
            assert 0 < row.rmse_deg < 20 and 0 < row.r2 < 1                # a fit, not a perfect or absurd one
            assert row.us_per_step > 0 and np.isfinite(row.us_per_step)
            assert row.set == ("a" if lg.name == "rate_0p114" else "b")
        y = np.concatenate([lg.angle_deg for lg in test])
        yh = np.concatenate([o.predictions[lg.name] for lg in test])
        srow = res.summary.set_index("model").loc[o.name]
        for col, v in expected_metrics(y, yh).items():
            assert srow[col] == pytest.approx(v, rel=1e-9), (o.name, "ALL", col)
        # pooled cost per step: time-weighted mean of the per-log costs
        m = res.metrics[res.metrics.model == o.name]
        n = np.array([lg.n for lg in test])
        assert srow.us_per_step == pytest.approx(np.sum(m.us_per_step.to_numpy() * n) / n.sum())
    assert list(res.summary["rmse_deg"]) == sorted(res.summary["rmse_deg"])
    assert list(res.summary["rank"]) == [1, 2]
    assert set(res.by_set["set"]) == {"a", "b"}


@pytest.mark.slow
def test_vbmm_not_beaten_by_rate_independent_models_on_rate_experiments(rate_logs):
    """Plant with creep and hysteresis; trained at one rate, tested at two others."""
    train, test = rate_logs
    res = compare_models(train, test, ["vbmm-fit", "gpi", "maxwell-slip", "two-branch"], timing_repeats=1)
    s = res.summary.set_index("model")
    for baseline in ("gpi", "maxwell-slip", "two-branch"):  # rate-independent (BASELINES.md)
        assert s.loc["vbmm-fit", "rmse_deg"] < s.loc[baseline, "rmse_deg"], baseline
    assert "is not beaten" in verdicts(res)[1]
    # every model has its cost per step
    assert (s["us_per_step"] > 0).all()


def test_verdicts_say_when_a_baseline_wins():
    summary = pd.DataFrame({"model": ["gpi", "vbmm-fit"], "log": ["ALL", "ALL"], "rmse_deg": [1.0, 2.0]})
    by_set = pd.DataFrame({"model": ["gpi", "vbmm-fit", "gpi", "vbmm-fit"], "log": ["amp", "amp", "rate", "rate"],
                           "rmse_deg": [0.5, 2.5, 3.0, 1.5], "set": ["amp", "amp", "rate", "rate"]})
    lines = verdicts((summary, by_set))
    assert lines[0].startswith("Ranking by pooled test RMSE: 1. gpi")
    assert any("On all test logs, the baseline gpi (1.000 deg) beats the best VBMM variant vbmm-fit" in x for x in lines)
    assert any("On amp, the baseline gpi" in x and "beats" in x for x in lines)
    assert any("On rate, the best VBMM variant vbmm-fit" in x and "not beaten" in x for x in lines)


def test_verdicts_say_when_a_baseline_beats_the_weaker_vbmm_variant():
    summary = pd.DataFrame({"model": ["vbmm-fit", "three-element", "vbmm-mat", "gpi"], "log": ["ALL"] * 4,
                            "rmse_deg": [2.3, 2.8, 2.9, 4.2]})
    lines = verdicts((summary, None))
    assert any("vbmm-fit" in x and "not beaten" in x for x in lines)
    assert any("the baseline three-element (2.800 deg) beats the VBMM variant vbmm-mat (2.900 deg)" in x for x in lines)
    assert not any("beats the VBMM variant vbmm-fit" in x for x in lines)


def test_overlap_is_detected_by_path_and_by_content(rate_logs, tmp_path, capsys):
    train, test = rate_logs
    paths = write_logs(tmp_path, train)
    from bpmid.io.motion_logs import read_motion_logs

    on_disk = read_motion_logs(paths)
    assert overlap_warnings(on_disk, on_disk) and "also a training log" in overlap_warnings(on_disk, on_disk)[0]
    copy = dict(vars(train[0]))
    copy["name"] = "renamed"
    from bpmid.io.motion_logs import MotionLog

    msgs = overlap_warnings(train, [MotionLog(**copy)])
    assert msgs and "same data as training log train_0p2" in msgs[0]
    assert overlap_warnings(train, test) == []
    # re-exported: time shifted by an hour, pressure rounded as an export in psi rounds it, a stretch of rows
    # dropped: still the training log's data (only bit-identical copies were caught)
    lg = train[0]
    keep = np.r_[0:lg.n // 3, lg.n // 3 + 40:lg.n]
    p_psi = np.round(lg.pressure_pa / 6894.757, 2) * 6894.757
    redo = dataclasses.replace(lg, name="reexported", time_s=lg.time_s[keep] + 3600.0, pressure_pa=p_psi[keep],
                               angle_deg=np.round(lg.angle_deg[keep], 3))
    from bpmid.compare import near_copies

    assert overlap_warnings(train, [redo]) == []      # not set aside: a quiet rig's replicate looks the same
    said = near_copies(train, [redo])
    assert "test log reexported repeats training log train_0p2 within rounding" in said["reexported"]
    cut = dataclasses.replace(redo, name="cut", time_s=redo.time_s[5:] - redo.time_s[5],
                              pressure_pa=redo.pressure_pa[5:], angle_deg=redo.angle_deg[5:])
    assert "cut" in near_copies(train, [cut])          # cut at the start and re-zeroed: aligned on its first sample
    # the same run with other noise on the angle (a replicate) is a test, and said to be none of these
    rng = np.random.default_rng(3)
    rep = dataclasses.replace(lg, name="replicate", angle_deg=lg.angle_deg + rng.normal(0.0, 0.3, lg.n))
    assert overlap_warnings(train, [rep]) == [] and near_copies(train, [rep]) == {}
    with pytest.warns(CompareWarning, match="repeats training log train_0p2 within rounding"):
        res = compare_models(train, [redo, test[0]], ["two-branch"], timing=False)
    assert set(res.metrics["set"]) == {"test"}         # scored as a test, with the warning
    # inside a command (bpmid compare, and bpmid run's compare stage, which used to show a raw Python warning with
    # a source line) it is said on stderr as the command's other warnings are, and raised as none
    import warnings as W

    from bpmid.errors import command_prints_warnings

    with W.catch_warnings(record=True) as caught, command_prints_warnings():
        W.simplefilter("always")
        compare_models(train, [redo, test[0]], ["two-branch"], timing=False)
    assert not [w for w in caught if issubclass(w.category, CompareWarning)]
    assert "warning: test log reexported repeats training log train_0p2" in capsys.readouterr().err
    with pytest.warns(CompareWarning):
        res = compare_models(train, [MotionLog(**copy), test[0]], ["two-branch"], timing=False)
    # the copy is scored, marked, and left out of the pooled score: ALL is the real test log alone
    m = res.metrics.set_index("log")
    assert m.loc["renamed", "set"] == FITTED_SET and m.loc[test[0].name, "set"] == "test"
    assert res.summary["rmse_deg"].iloc[0] == pytest.approx(m.loc[test[0].name, "rmse_deg"], rel=1e-12)
    with pytest.raises(InputError, match="every test log is also a training log"):
        compare_models(train, [MotionLog(**copy)], ["two-branch"], timing=False)


# ------------------------------------------------------------------------------------------------
# the command
# ------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def log_files(rate_logs, tmp_path_factory):
    d = tmp_path_factory.mktemp("logs")
    train, test = rate_logs
    return write_logs(d, train), write_logs(d, test)


def test_cli_writes_contract_files_and_figures(log_files, tmp_path):
    train, test = log_files
    out = tmp_path / "cmp"
    r = runner.invoke(app, ["compare", "--train", *map(str, train), "--test", *map(str, test),
                            "--models", "two-branch,maxwell-slip", "--out", str(out)])
    assert r.exit_code == 0, r.output
    m = pd.read_csv(out / "metrics.csv")
    s = pd.read_csv(out / "summary.csv")
    assert has_cli_columns(m.columns) and has_cli_columns(s.columns), (list(m.columns), list(s.columns))
    assert len(m) == 4 and set(m["log"]) == {"rate_0p114", "rate_0p267"}
    assert len(s) == 2 and set(s["log"]) == {"ALL"}
    assert (s["us_per_step"] > 0).all() and (s["n_params"] > 0).all()
    for f in ("compare_timeseries.png", "compare_loops.png", "compare_errors.png", "compare_summary.png",
              "compare.yaml", "predictions/rate_0p114.csv"):
        assert (out / f).is_file(), f
    import yaml

    cy = yaml.safe_load((out / "compare.yaml").read_text())
    assert cy["schema"] == "bpmid.compare/1" and cy["synthetic"] is True
    assert cy["synthetic_logs"] == sorted(Path(p).stem for p in [*train, *test])   # every log names itself
    assert set(cy["models"]) == {"two-branch", "maxwell-slip"}
    assert len(cy["provenance"]["inputs"]) == 3
    assert "rank" in r.output and "two-branch" in r.output


def test_cli_unknown_model_exit_2(log_files, tmp_path):
    train, test = log_files
    r = runner.invoke(app, ["compare", "--train", str(train[0]), "--test", str(test[0]), "--models", "gpi,lstm",
                            "--out", str(tmp_path / "x")])
    assert r.exit_code == 2
    assert "unknown model 'lstm'" in r.output and "vbmm-fit" in r.output
    assert not (tmp_path / "x").exists()


def test_cli_overlap_warns_but_runs(log_files, tmp_path):
    train, test = log_files
    r = runner.invoke(app, ["compare", "--train", str(train[0]), "--test", str(train[0]), str(test[0]),
                            "--models", "two-branch", "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    assert "warning:" in r.output and "also a training log" in r.output
    import yaml

    assert yaml.safe_load((tmp_path / "o" / "compare.yaml").read_text())["warnings"]
    m = pd.read_csv(tmp_path / "o" / "metrics.csv").set_index("log")
    assert m.loc[train[0].stem, "set"] == FITTED_SET
    summ = pd.read_csv(tmp_path / "o" / "summary.csv")
    assert summ["rmse_deg"].iloc[0] == pytest.approx(m.loc[test[0].stem, "rmse_deg"], rel=1e-5)


def test_cli_log_too_short_exit_2(tmp_path, log_files):
    _train, test = log_files
    short = plant_log("short", 0.2, 5).slice(0, 12)
    (p,) = write_logs(tmp_path, [short])
    r = runner.invoke(app, ["compare", "--train", str(p), "--test", str(test[0]), "--models", "maxwell-slip",
                            "--out", str(tmp_path / "s")])
    assert r.exit_code == 2
    assert "too few to identify" in r.output and "maxwell-slip" in r.output
    assert not (tmp_path / "s").exists()


def test_cli_missing_files_and_relax_exit_2(log_files, tmp_path):
    train, test = log_files
    r = runner.invoke(app, ["compare", "--train", str(tmp_path / "nope.csv"), "--test", str(test[0]),
                            "--out", str(tmp_path / "m")])
    assert r.exit_code == 2 and "nope.csv" in r.output
    r = runner.invoke(app, ["compare", "--train", str(train[0]), "--test", str(test[0]), "--models", "vbmm-mat",
                            "--relax", str(tmp_path / "relax.yaml"), "--out", str(tmp_path / "m")])
    assert r.exit_code == 2 and "relax.yaml" in r.output and "--relax" in r.output


def test_cli_config_names_the_logs(log_files, tmp_path):
    train, test = log_files
    cfg = tmp_path / "cmp.yaml"
    cfg.write_text("compare:\n  models: [two-branch]\n  timing: false\n"
                   f"  train: [{train[0]}]\n  test_sets:\n    rates: ['{test[0].parent}/rate_*.csv']\n")
    r = runner.invoke(app, ["compare", "--config", str(cfg), "--out", str(tmp_path / "c")])
    assert r.exit_code == 0, r.output
    by_set = pd.read_csv(tmp_path / "c" / "summary_by_set.csv")
    assert list(by_set["set"]) == ["rates"]
    m = pd.read_csv(tmp_path / "c" / "metrics.csv")
    assert m["us_per_step"].isna().all()  # timing: false leaves the wall-clock column empty
    cfg.write_text("compare:\n  models: [two-branch]\n  test_sets:\n    rates: ['nothing_*.csv']\n"
                   f"  train: [{train[0]}]\n")
    r = runner.invoke(app, ["compare", "--config", str(cfg), "--out", str(tmp_path / "d")])
    assert r.exit_code == 2 and "compare.test_sets.rates[0]" in r.output and "nothing_" in r.output


def test_write_compare_is_all_or_nothing(rate_logs, tmp_path, monkeypatch):
    train, test = rate_logs
    res = compare_models(train, test, ["two-branch"], timing=False)
    import bpmid.plots.compare as P

    def boom(*a, **k):
        raise RuntimeError("figure failed")

    monkeypatch.setattr(P, "summary_bars", boom)
    with pytest.raises(RuntimeError):
        write_compare(res, tmp_path / "w", {"command": "test"})
    assert not (tmp_path / "w" / "metrics.csv").exists()


def test_paper_comparison_config_names_the_shipped_sets():
    from bpmid.compare import resolve_inputs
    from bpmid.config import load_config

    repo = Path(__file__).resolve().parents[1]
    cfg = load_config(repo / "configs" / "compare_paper.yaml")
    train, sets, relax = resolve_inputs(cfg.section("compare"), cfg)
    assert train and all("fitting_set" in str(p) for p in train)
    assert set(sets) == {"variable_amplitude", "variable_rate"} and all(len(v) >= 3 for v in sets.values())
    assert not {p.resolve() for p in train} & {p.resolve() for v in sets.values() for p in v}
    assert set(cfg.section("compare").models) == set(REGISTRY)
    assert relax is None


def test_figure_logs_show_different_protocols_of_each_set():
    from types import SimpleNamespace

    from bpmid.compare import figure_logs

    names = {"amp": [f"amp_{a}_r{r}" for a in ("1p8", "2p0", "2p2") for r in (1, 2)],
             "rate": [f"rate_{a}_r{r}" for a in ("slow", "fast") for r in (1, 2)]}
    logs = [SimpleNamespace(name=n) for v in names.values() for n in v]
    res = SimpleNamespace(test=logs, sets=names)
    assert [lg.name for lg in figure_logs(res, 4)] == ["amp_1p8_r1", "amp_2p2_r2", "rate_slow_r1", "rate_fast_r2"]
    assert [lg.name for lg in figure_logs(res, 3)] == ["amp_1p8_r1", "amp_2p2_r2", "rate_slow_r1"]
    assert len(figure_logs(res, 50)) == 10 and figure_logs(res, 0) == []


def test_a_mix_of_measured_and_synthetic_logs_is_labelled_as_a_mix(tmp_path, monkeypatch):
    """One log without its synthetic line (a user's measurement beside the twin's logs): compare.yaml's
    ``synthetic`` (every log) is false and ``synthetic_logs`` names the others; a synthetic test log's predictions
    say so on their first line, the measured one's do not; the figures are stamped "partly synthetic", not left
    bare (before: no stamp, and the synthetic logs drawn as "measured")."""
    import yaml

    import bpmid.plots.common as common

    repo = Path(__file__).resolve().parents[1]
    src = [repo / "datasets/motion/fitting_set/fit_1p2_1p6_r1.csv", repo / "datasets/motion/fitting_set/fit_1p2_1p6_r2.csv",
           repo / "datasets/motion/variable_rate/rate_0p114_r1.csv", repo / "datasets/motion/variable_rate/rate_0p114_r2.csv"]
    paths = []
    for i, p in enumerate(src):
        text = p.read_text()
        if i == 0:   # the "measured" training log
            text = "".join(ln for ln in text.splitlines(keepends=True) if not ln.startswith("# synthetic"))
        q = tmp_path / p.name
        q.write_text(text)
        paths.append(q)
    stamps = []
    monkeypatch.setattr(common, "label_synthetic", lambda fig, note="": stamps.append(note))
    r = runner.invoke(app, ["compare", "--train", str(paths[0]), str(paths[1]), "--test", str(paths[2]), str(paths[3]),
                            "--models", "two-branch", "--out", str(tmp_path / "out")])
    assert r.exit_code == 0, r.output
    body = yaml.safe_load((tmp_path / "out" / "compare.yaml").read_text())
    assert body["synthetic"] is False
    assert body["synthetic_logs"] == ["fit_1p2_1p6_r2", "rate_0p114_r1", "rate_0p114_r2"]
    first = (tmp_path / "out" / "predictions" / "rate_0p114_r1.csv").read_text().splitlines()[0]
    assert first.startswith("# synthetic: true")
    assert pd.read_csv(tmp_path / "out" / "predictions" / "rate_0p114_r1.csv", comment="#").shape[0] > 10
    assert stamps and all(s for s in stamps)
    assert any(s.startswith("partly synthetic: 3 of 4 logs") for s in stamps)   # the summary: every log
    assert "synthetic data (bpmid digital twin)" in stamps                         # the test logs' own figures


def test_a_rerun_with_fewer_test_logs_says_the_earlier_runs_predictions_are_still_there(log_files, tmp_path):
    train, test = log_files
    out = tmp_path / "cmp"
    r = runner.invoke(app, ["compare", "--train", str(train[0]), "--test", str(test[1]), str(test[0]),
                            "--models", "two-branch", "--out", str(out)])
    assert r.exit_code == 0 and "this run did not write" not in r.output, r.output
    r = runner.invoke(app, ["compare", "--train", str(train[0]), "--test", str(test[0]),
                            "--models", "two-branch", "--out", str(out)])
    assert r.exit_code == 0, r.output
    assert f"also holds 1 file(s) this run did not write (an earlier run's, left as they were: {test[1].stem}.csv)" \
        in " ".join(r.output.split()), r.output
    assert (out / "predictions" / f"{test[1].stem}.csv").is_file()   # left alone, as the docs say


def test_vbmm_mat_at_the_log_step_runs_relaxation_constants_as_the_material_they_are(tmp_path):
    """Relaxation constants hold in continuous time; the sum sampled at 10 Hz takes each step as a jump, so run
    straight in it they act stiffer in the fast branch. On the twin's muscle (continuous time, logged at 10 Hz, no
    noise, no rig effects) with the twin's own constants, ``at_log_step`` (each branch modulus divided by the
    continuous factor at the log's step) follows the log within 0.1 deg, the constants straight miss it by more than
    0.5 deg; the default stays the paper's (straight); a non-boolean setting is refused naming its key."""
    import yaml

    from bpmid.compare import build_model
    from bpmid.io.motion_logs import read_motion_log
    from bpmid.models.vbmm.family import VBMMMatModel
    from bpmid.twin.simulate import simulate

    proto = {"kind": "motion", "name": "m", "seed": 2, "sampling_hz": 10, "logs": [
        {"name": "tri", "start": 1.2, "program": [{"triangle": {"low": 1.2, "high": 1.8, "rate": 0.3, "cycles": 3}},
                                                  {"hold": {"duration_s": 3}}]}],
        "sensors": {"angle_noise_deg": 0, "angle_resolution_deg": 0, "angle_drift_deg": 0,
                    "pressure_noise_bar": 0, "pressure_resolution_bar": 0}}
    (tmp_path / "p.yaml").write_text(yaml.safe_dump(proto))
    sim = simulate(tmp_path / "p.yaml")
    (tmp_path / "tri.csv").write_bytes(sim.files["tri.csv"])
    log = read_motion_log(tmp_path / "tri.csv")

    def rmse(model):
        return float(np.sqrt(np.mean((model.simulate(model.default_params(), log) - log.angle_deg) ** 2)))

    assert VBMMMatModel(relax_fit=Material.paper_fit()).at_log_step is False
    assert rmse(build_model("vbmm-mat", {"at_log_step": True, "relax_fit": Material.paper_fit()})) < 0.1
    assert rmse(VBMMMatModel(relax_fit=Material.paper_fit())) > 0.5
    with pytest.raises(InputError) as e:
        build_model("vbmm-mat", {"at_log_step": "yes", "relax_fit": Material.paper_fit()})
    assert e.value.key == "compare.options.vbmm-mat.at_log_step"


def test_vbmm_mat_fit_never_refits_and_checks_its_training_logs():
    """VBMM-mat. is the relaxation constants, never refitted: its own ``fit`` holds every constant (even parameters
    handed in free) and refuses a training angle the model cannot produce, as before ``at_step`` was added (which
    swallowed the method into itself, leaving the generic least-squares fit that refitted free constants)."""
    from bpmid.models.vbmm.family import VBMMMatModel

    log = plant_log("tr", 0.2, 1)
    m = VBMMMatModel(relax_fit=Material.paper_fit())
    free = m.default_params()
    for name in free.names():
        free = free.replace(name, fixed=False)
    res = m.fit([log], params=free)
    assert all(p.fixed for p in res.params)
    assert res.params.value("K_1") == pytest.approx(Material.paper_fit().K[0])
    bad = dataclasses.replace(log, angle_deg=log.angle_deg - 50.0)
    with pytest.raises(InputError, match="outside the model's range"):
        m.fit([bad])


def test_a_test_log_at_another_step_than_vbmm_fit_was_fitted_on_is_warned_about():
    """VBMM-fit's constants hold for the step of its training logs (docs/model.md); run on a 100 Hz test log after a
    10 Hz fit it scored worse with no word, where bpmid predict on the same fit warns. The comparison says it (the
    predict warning, named by model), for VBMM-fit only and only for the log at the other step."""
    train = [plant_log(f"tr{i}", 0.2, i) for i in range(2)]
    same = plant_log("same", 0.3, 5)
    fast = plant_log("fast", 0.3, 6, dt=0.01)
    with pytest.warns(CompareWarning) as rec:
        res = compare_models(train, [same, fast], ["vbmm-fit", "two-branch"], timing=False)
    said = [str(w.message) for w in rec if "samples are" in str(w.message)]
    assert len(said) == 1 and said[0].startswith("vbmm-fit: fast: samples are 0.01 s apart") \
        and "fitted on logs sampled every 0.1 s" in said[0], said
    assert res.warnings == said
