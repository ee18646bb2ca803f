"""Settings outside their meaning are refused naming the config file and key (they ran, exit 0, before: a negative
threshold made discovery's verdict contradict itself, an ambient of 0 bar made control's numbers meaningless),
and a model option a family refuses names compare.options.<model>.<key> in the config file."""
from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from bpmid.cli import app

REPO = Path(__file__).resolve().parents[1]
runner = CliRunner()


@pytest.mark.parametrize("line, key", [
    ("atmosphere_bar: 0", "control.atmosphere_bar"), ("oscillation_limit_pct: -5", "control.oscillation_limit_pct"),
    ("ms_elements: 0", "control.ms_elements"), ("ms_poly_degree: -1", "control.ms_poly_degree"),
    ("rate_hz: 1.0e-3", "control.rate_hz"), ("p_max_bar_abs: 1.0e6", "control.p_max_bar_abs")])
def test_control_settings_out_of_range(tmp_path, line, key):
    from test_simulate_predict_review import TRUTH

    params = tmp_path / "vbmm.yaml"
    params.write_text(TRUTH % (6.434e6, 3.2e6))
    cfg = tmp_path / "c.yaml"
    cfg.write_text(f"control:\n  {line}\n")
    r = runner.invoke(app, ["control", "--params", str(params), "--config", str(cfg), "--reference", "steps",
                            "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and str(cfg) in r.output and f"key '{key}'" in r.output, r.output
    assert not (tmp_path / "o").exists()


def test_a_negative_unexplained_threshold_is_refused(tmp_path):
    cfg = tmp_path / "d.yaml"
    cfg.write_text("discover:\n  unexplained_gap_sigma: -1\n")
    case = REPO / "datasets" / "discovery" / "case_05"
    r = runner.invoke(app, ["discover", *map(str, sorted(case.glob("train_*.csv"))), "--holdout",
                            str(case / "holdout_mixed.csv"), "--config", str(cfg), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and "discover.unexplained_gap_sigma" in r.output, r.output


@pytest.mark.parametrize("option, key", [("gpi: {envelope: bogus}", "compare.options.gpi.envelope"),
                                         ("maxwell-slip: {n_elements: 0}", "compare.options.maxwell-slip.n_elements")])
def test_a_model_option_a_family_refuses_names_the_config_and_its_key(tmp_path, option, key):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(f"compare:\n  options:\n    {option}\n")
    m = REPO / "datasets" / "motion"
    r = runner.invoke(app, ["compare", "--train", str(m / "fitting_set" / "fit_1p2_1p6_r1.csv"), "--test",
                            str(m / "variable_rate" / "rate_0p114_r1.csv"), "--models", "gpi,maxwell-slip",
                            "--config", str(cfg), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and str(cfg) in r.output and f"key '{key}'" in r.output, r.output


def test_fit_motion_carries_the_warnings_of_the_relaxation_fit_it_starts_from(tmp_path):
    """A load/extension log with a gauge length of 0.05 mm (for 50): fit relax warns about the gauge length (it
    blamed a strain column the file does not have), and fit motion --init on that fit says the fit came with
    warnings and that its shear modulus is no rubber's (it said nothing, warnings: [])."""
    import numpy as np
    import yaml

    t = np.arange(0.0, 30.0, 0.05)
    ext = np.minimum(t / 1.0, 1.0) * 7.5                      # mm, a 1 s ramp to 7.5 mm, then held
    load = 12 * 0.4 * (0.6 * ext / 50 + 0.4 * (ext / 50) * np.exp(-np.maximum(t - 1.0, 0) / 2.0))
    log = tmp_path / "ext.csv"
    log.write_text("time_s,extension_mm,load_n\n" + "".join(f"{a:.4f},{b:.6f},{c:.6f}\n" for a, b, c in zip(t, ext, load)))
    cfg = tmp_path / "spec.yaml"
    cfg.write_text("relax:\n  specimen:\n    gauge_length_mm: 0.05\n    cross_section_mm2: 12\n")
    r = runner.invoke(app, ["fit", "relax", str(log), "--config", str(cfg), "--out", str(tmp_path / "r.yaml")])
    assert r.exit_code == 0, r.output
    assert "gauge_length_mm" in r.output and "if the column is in percent" not in r.output, r.output
    fit = REPO / "datasets" / "motion" / "fitting_set" / "fit_1p2_1p6_r1.csv"
    r = runner.invoke(app, ["fit", "motion", str(fit), "--init", str(tmp_path / "r.yaml"), "--out", str(tmp_path / "m.yaml"),
                            "--no-plot"])
    assert r.exit_code == 0, r.output
    warnings = yaml.safe_load((tmp_path / "m.yaml").read_text())["warnings"]
    assert any("came with" in w and "warning(s) of its own" in w for w in warnings), warnings
    assert any("far softer than any rubber" in w for w in warnings), warnings


def test_r2_of_a_constant_angle_is_undefined_not_a_rounding_artefact(tmp_path):
    """A constant angle column: R^2 printed as -4.2e30 before (the sum of squares about the mean of a constant is
    rounding, not 0); now undefined (null) with a warning naming the column."""
    import numpy as np
    import yaml

    from bpmid import metrics as M
    from test_simulate_predict_review import TRUTH

    y = np.full(200, 45.3)
    assert np.isnan(M.r2(y, y + 0.1)) and np.isnan(M.fit_pct(y, y + 0.1))
    assert M.r2(np.arange(5.0), np.arange(5.0)) == 1.0
    src = (REPO / "datasets/motion/variable_rate/rate_0p114_r1.csv").read_text().splitlines()
    rows = [ln if not ln[:1].isdigit() else ",".join(ln.split(",")[:2] + ["45.0"]) for ln in src]
    log = tmp_path / "const.csv"
    log.write_text("\n".join(rows) + "\n")
    params = tmp_path / "vbmm.yaml"
    params.write_text(TRUTH % (6.434e6, 3.2e6))
    r = runner.invoke(app, ["predict", str(log), "--params", str(params), "--out", str(tmp_path / "p")])
    assert r.exit_code == 0 and "R^2 undefined" in r.output and "does not vary" in r.output, r.output
    body = yaml.safe_load((tmp_path / "p" / "predict.yaml").read_text())
    assert "r2: null" in (tmp_path / "p" / "predict.yaml").read_text() and body


def test_a_relaxation_log_cut_to_its_hold_is_pointed_to_step_mode(tmp_path):
    """A ramp-and-hold log whose ramp was cut off: ramp mode finds no relaxing term and said 'the stress does not
    relax in them' (it does); now it names the log and --mode step, which fits it."""
    import numpy as np

    src = (REPO / "datasets/relaxation/relax_300mmmin_15pct.csv").read_text().splitlines()
    head = [ln for ln in src if not ln[:1].isdigit()]
    rows = [ln for ln in src if ln[:1].isdigit()]
    strain = np.array([float(r.split(",")[1]) for r in rows])
    k = int(np.flatnonzero(strain >= 0.998 * np.median(strain[int(0.8 * strain.size):]))[0])
    log = tmp_path / "hold_only.csv"
    log.write_text("\n".join(head + rows[k:]) + "\n")
    r = runner.invoke(app, ["fit", "relax", str(log), "--out", str(tmp_path / "r.yaml")])
    assert r.exit_code == 2 and "start(s) at the hold" in r.output and "--mode step" in r.output, r.output
    r = runner.invoke(app, ["fit", "relax", str(log), "--mode", "step", "--out", str(tmp_path / "r.yaml")])
    assert r.exit_code == 0, r.output


@pytest.mark.parametrize("text, key, words", [
    ("motion:\n  bounds:\n    K_inf: [-1.0e6, 1.0e9]\n", "motion.bounds.K_inf", ">= 0"),
    # metres under the mm keys fitted at exit 0 with a 10 um radius
    ("model:\n  geometry: {th_mm: 0.0015, alpha0_deg: 25, R0_mm: 0.01, l0_mm: 0.12, n: 5}\n", "model.geometry",
     "too small for a muscle"),
    # a trial's datasheet geometry under the SI keys was refused for alpha0 alone, with nothing on what to write
    ("model:\n  geometry: {th: 2.5, alpha0: 25, R0: 12, l0: 150, n: 6}\n", "model.geometry",
     "look like millimetres: give them as th_mm, R0_mm, l0_mm (and alpha0_deg)"),
    ("model:\n  geometry: {th_mm: 2.5, alpha0: 25, R0_mm: 12, l0_mm: 150, n: 6}\n", "model.geometry.alpha0",
     "degrees given under alpha0? alpha0 takes radians (0.4363), alpha0_deg degrees (alpha0_deg: 25)")])
def test_a_motion_fit_setting_out_of_its_meaning_is_refused(tmp_path, text, key, words):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(text)
    r = runner.invoke(app, ["fit", "motion", str(REPO / "datasets/motion/fitting_set/fit_1p2_1p6_r1.csv"),
                            "--config", str(cfg), "--out", str(tmp_path / "m.yaml")])
    assert r.exit_code == 2 and key in r.output and words in r.output, r.output


def test_the_specimen_that_made_stress_and_strain_is_recorded(tmp_path):
    """relax_fit.yaml said nothing of the gauge length and cross-section that turned load and extension into
    stress and strain; the reading record now gives them and where each came from."""
    import yaml

    src = REPO / "datasets/relaxation/relax_300mmmin_15pct.csv"
    rows = [ln for ln in src.read_text().splitlines() if ln[:1].isdigit()]
    log = tmp_path / "machine.csv"
    log.write_text("# gauge_length_mm: 50\ntime_s,extension_mm,load_n\n" + "".join(
        f"{r.split(',')[0]},{float(r.split(',')[1]) * 50:.6g},{float(r.split(',')[2]) * 12:.6g}\n" for r in rows))
    cfg = tmp_path / "c.yaml"
    cfg.write_text("relax:\n  specimen:\n    cross_section_mm2: 12\n")
    r = runner.invoke(app, ["fit", "relax", str(log), "--config", str(cfg), "--out", str(tmp_path / "r.yaml")])
    assert r.exit_code == 0, r.output
    body = yaml.safe_load((tmp_path / "r.yaml").read_text())
    spec = body["provenance"]["reading"]["machine"]["specimen"]
    assert spec["gauge_length_mm"] == 50 and spec["cross_section_mm2"] == 12
    assert spec["from"] == {"gauge_length_mm": "file header", "cross_section_mm2": "config relax.specimen"}


def test_a_refusal_under_strict_names_where_strict_came_from(tmp_path):
    """io.strict in a config was refused under the key '--strict', a flag the user never gave."""
    rows = (REPO / "datasets/motion/fitting_set/fit_1p2_1p6_r1.csv").read_text().splitlines()
    ms = tmp_path / "ms.csv"   # times in ms under a seconds header: a warning
    ms.write_text("\n".join(r if not r[:1].isdigit() else ",".join([f"{float(r.split(',')[0]) * 1000:g}"]
                                                                    + r.split(",")[1:]) for r in rows) + "\n")
    cfg = tmp_path / "strict.yaml"
    cfg.write_text("io:\n  strict: true\n")
    r = runner.invoke(app, ["fit", "motion", str(ms), "--config", str(cfg), "--out", str(tmp_path / "a.yaml")])
    assert r.exit_code == 2 and "key 'io.strict'" in r.output and "set io.strict: false" in r.output, r.output
    r = runner.invoke(app, ["fit", "motion", str(ms), "--strict", "--out", str(tmp_path / "b.yaml")])
    assert r.exit_code == 2 and "key '--strict'" in r.output and "leave out --strict" in r.output, r.output
