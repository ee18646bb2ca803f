"""The VBMM refuses what it cannot describe instead of answering at its 4 pi rad limit (exit 0, 720 deg on every
sample, before): a geometry that needs a negative pressure to hold any bend, and a branch with two time
constants for one modulus."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from bpmid.cli import app
from bpmid.errors import InputError
from bpmid.models.vbmm import VBMM, Material
from bpmid.models.vbmm.model import Geometry

REPO = Path(__file__).resolve().parents[1]
runner = CliRunner()


@pytest.mark.parametrize("R0", [6e-3, 4e-3, 1.673e-3])
def test_a_radius_of_a_few_wall_thicknesses_is_refused_naming_the_geometry(R0):
    geo = dataclasses.replace(Geometry(), R0=R0)
    with pytest.raises(InputError, match="negative pressure to hold a bend") as ei:
        VBMM(material=Material.paper_fit(), geometry=geo)
    assert ei.value.key == "model.geometry" and "R0 " in ei.value.message


def test_the_paper_muscle_and_a_narrower_one_still_bend():
    for R0 in (16.73e-3, 8e-3):
        m = VBMM(material=Material.paper_fit(), geometry=dataclasses.replace(Geometry(), R0=R0))
        beta = np.degrees(m.forward(np.arange(4) * 0.1, np.array([0.0, 1e4, 2e4, 4e4])))
        assert abs(beta[0]) < 1e-9 and np.all(np.diff(beta) > 0) and beta[-1] < 180.0


def _fit_file(tmp_path: Path) -> Path:
    """The paper's constants as a bpmid.vbmm/1 file (written by hand, as a user would)."""
    from test_simulate_predict_review import TRUTH

    out = tmp_path / "vbmm.yaml"
    out.write_text(TRUTH % (6.434e6, 3.2e6))
    return out


def test_predict_control_and_export_refuse_a_fit_file_with_a_decimal_slip_in_R0(tmp_path):
    fit = _fit_file(tmp_path)
    d = yaml.safe_load(fit.read_text())
    d["geometry"]["R0"] = 1.673e-3   # for 1.673e-2
    bad = tmp_path / "r0.yaml"
    bad.write_text(yaml.safe_dump(d, sort_keys=False))
    log = REPO / "datasets/motion/variable_rate/rate_0p114_r1.csv"
    for args in (["predict", str(log), "--params", str(bad), "--out", str(tmp_path / "p")],
                 ["control", "--params", str(bad), "--reference", "steps", "--out", str(tmp_path / "c"), "--no-figure"],
                 ["export", str(bad), "--to", "c", "--out", str(tmp_path / "x")]):
        r = runner.invoke(app, args)
        assert r.exit_code == 2, (args[0], r.output)
        assert str(bad) in r.output and "key 'geometry'" in r.output and "negative pressure" in r.output, r.output
        assert not (tmp_path / args[args.index("--out") + 1].split("/")[-1]).exists()
    # a config's geometry names the config's key
    cfg = tmp_path / "small.yaml"
    cfg.write_text("model:\n  geometry:\n    R0_mm: 1.673\n")
    r = runner.invoke(app, ["fit", "motion", str(log), "--config", str(cfg), "--out", str(tmp_path / "f.yaml")])
    assert r.exit_code == 2 and "model.geometry" in r.output and "negative pressure" in r.output, r.output


def test_a_branch_with_tau_and_tauK_is_refused(tmp_path):
    fit = _fit_file(tmp_path)
    d = yaml.safe_load(fit.read_text())
    d["material"]["branches"][0]["tauK"] = {"value": 1.0, "stderr": None, "unit": "s"}
    bad = tmp_path / "both.yaml"
    bad.write_text(yaml.safe_dump(d, sort_keys=False))
    r = runner.invoke(app, ["predict", str(REPO / "datasets/motion/variable_rate/rate_0p114_r1.csv"), "--params",
                            str(bad), "--out", str(tmp_path / "p")])
    assert r.exit_code == 2 and "material.branches[0].tauK" in r.output and "not both" in r.output, r.output


def test_a_solve_that_finds_no_angle_is_an_input_error_naming_the_geometry(tmp_path):
    """n = 1e6 turns: the bracketed solve cannot converge (its pressure does not rise steadily with the bend);
    that was a RuntimeError, an 'internal error' with exit 1."""
    fit = _fit_file(tmp_path)
    d = yaml.safe_load(fit.read_text())
    d["geometry"]["n"] = 1e6
    bad = tmp_path / "n.yaml"
    bad.write_text(yaml.safe_dump(d, sort_keys=False))
    r = runner.invoke(app, ["predict", str(REPO / "datasets/motion/variable_rate/rate_0p114_r1.csv"), "--params",
                            str(bad), "--out", str(tmp_path / "p")])
    assert r.exit_code == 2 and "found no angle" in r.output and "n 1e+06" in r.output, r.output
    assert "internal error" not in r.output and not (tmp_path / "p").exists()


def test_fit_motion_refuses_a_plot_path_no_figure_format_has_before_fitting(tmp_path):
    log = REPO / "datasets/motion/fitting_set/fit_1p2_1p6_r1.csv"
    r = runner.invoke(app, ["fit", "motion", str(log), "--out", str(tmp_path / "f.yaml"), "--plot",
                            str(tmp_path / "f.txt")])
    assert r.exit_code == 2 and "key '--plot'" in r.output and "'f.txt' names none" in r.output, r.output
    assert not (tmp_path / "f.yaml").exists()


def test_the_report_summary_cautions_control_runs_that_do_not_track():
    import pandas as pd

    from bpmid.report.inputs import ControlInfo

    tab = pd.DataFrame({"controller": ["pi", "vbmm-pi", "pi"], "reference": ["a", "a", "ALL"],
                        "rmse_deg": [13.0, 9.4, 13.0], "status": ["oscillating,unstable", "oscillating", "x"]})
    k = ControlInfo(Path("."), tab, {"kp": {"value": 0.04}, "ki": {"value": 0.01}}, 10.0, {}, [], {})
    assert k.troubled_runs() == "1 of 2 runs unstable, 2 of 2 runs oscillating" and k.paper_gains()
    ok = ControlInfo(Path("."), tab.assign(status="saturated"), {}, 10.0, {}, [], {})
    assert ok.troubled_runs() == ""
