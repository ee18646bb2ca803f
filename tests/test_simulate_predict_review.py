"""What a known-truth review of simulate, predict and run found (a helper with its own numpy VBMM from VBMM.md):
each was a wrong number or label written with exit 0, or a message whose own fix gave one. Every test here
fails on the code before the mend."""
import hashlib
from pathlib import Path

import numpy as np
import pandas as pd
import yaml
from typer.testing import CliRunner

from bpmid.cli import app
from bpmid.io.motion_logs import file_is_synthetic, read_motion_log

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[1]

#: the paper's VBMM-fit constants and geometry, written by hand as a user would (Pa, s, m, rad)
TRUTH = """schema: bpmid.vbmm/1
geometry: {th: 0.002, alpha0: 0.5235987755982988, R0: 0.01673, l0: 0.1959, n: 7.43}
closure: paper
material:
  G_inf: {value: 9050.0, stderr: null, unit: Pa}
  K_inf: {value: %s, stderr: null, unit: Pa}
  branches: [{G: {value: 18300.0, stderr: null, unit: Pa}, K: {value: %s, stderr: null, unit: Pa},
              tau: {value: 0.213, stderr: null, unit: s}}]
"""
PROTO = """kind: motion
name: atm
seed: 5
sampling_hz: 10
unit: bar
pressure_reference: absolute
atmosphere_bar: %s
logs:
  - name: tri
    start: 1.2
    program:
      - hold: {duration_s: 2}
      - triangle: {low: 1.2, high: 2.0, rate: 0.2, cycles: 1}
sensors: {angle_noise_deg: 0}
"""


def _truth(tmp_path, K_inf="6434000.0", K1="13645000.0") -> Path:
    p = tmp_path / "truth.yaml"
    p.write_text(TRUTH % (K_inf, K1))
    return p


def test_a_simulated_log_made_at_another_ambient_pressure_reads_back_with_it(tmp_path):
    proto = tmp_path / "atm.yaml"
    # the muscle run at the logging rate: the model predict runs, so the constants that made the file predict it
    # exactly (in continuous time, the default, the 10 Hz model stays some 0.9 deg off it)
    proto.write_text(PROTO % "0.90" + "plant: {integration: log_rate}\n")
    params = _truth(tmp_path)
    r = runner.invoke(app, ["simulate", str(proto), "--out", str(tmp_path / "sim"), "--params", str(params)])
    assert r.exit_code == 0, r.output
    text = (tmp_path / "sim" / "tri.csv").read_text()
    assert "# atmosphere_pa: 90000\n" in text and "# plant constants: truth.yaml (--params)" in text
    # the constants that made the file predict it exactly (read against 101325 Pa it missed by 7.8 deg RMSE)
    r = runner.invoke(app, ["predict", str(tmp_path / "sim" / "tri.csv"), "--params", str(params),
                            "--out", str(tmp_path / "p")])
    assert r.exit_code == 0, r.output
    rmse = yaml.safe_load((tmp_path / "p" / "predict.yaml").read_text())["logs"]["tri"]["metrics"]["rmse_deg"]
    assert rmse < 1e-5
    # the fit file a simulation ran on is an input: its sha256 is in the manifest
    m = yaml.safe_load((tmp_path / "sim" / "manifest.yaml").read_text())
    assert m["provenance"]["inputs"] == {str(params): hashlib.sha256(params.read_bytes()).hexdigest()}
    # the standard atmosphere needs no line (the shipped datasets' bytes are unchanged)
    proto.write_text(PROTO % "1.01325")
    r = runner.invoke(app, ["simulate", str(proto), "--out", str(tmp_path / "sim2")])
    assert r.exit_code == 0, r.output
    assert "atmosphere_pa" not in (tmp_path / "sim2" / "tri.csv").read_text()


def test_a_protocol_asking_for_another_geometry_is_told_how(tmp_path):
    proto = tmp_path / "g.yaml"
    proto.write_text((PROTO % "1.01325") + "plant: {geometry: {th_mm: 3}}\n")
    r = runner.invoke(app, ["simulate", str(proto), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and "plant.geometry" in r.output and "--params FIT.yaml" in r.output
    assert not (tmp_path / "o").exists()


def test_an_unread_pressure_unit_is_converted_never_relabelled(tmp_path):
    t = np.arange(0, 5, 0.1)
    log = tmp_path / "rig.csv"
    log.write_text("time_s,Pressure (inH2O)\n" + "".join(f"{x:.1f},{300 + 10 * x:.3f}\n" for x in t))
    r = runner.invoke(app, ["predict", str(log), "--params", str(_truth(tmp_path)), "--out", str(tmp_path / "o"),
                            "--pressure-reference", "gauge"])
    out = " ".join(r.output.split())
    assert r.exit_code == 2 and "convert the column to kPa first" in out and "0.249089" in out
    assert "--columns" not in out          # relabelling it as kPa read inH2O numbers as kPa: 218 deg for 68
    for unit, factor in (("mm Hg", "0.133322"), ("in. H2O", "0.249089"), ("N/mm2", "1000"), ("kgf/cm^2", "98.0665"),
                         ("Torr abs", "0.133322"), ("mmHg g", "0.133322")):   # other spellings of them
        log.write_text(f"time_s,Pressure ({unit})\n0,300\n0.1,301\n")
        r = runner.invoke(app, ["predict", str(log), "--params", str(_truth(tmp_path)), "--out", str(tmp_path / "o"),
                                "--pressure-reference", "gauge"])
        out = " ".join(r.output.split())
        assert r.exit_code == 2 and f"multiply the values by {factor}" in out and "--columns" not in out, unit
    # a unit bpmid does not know at all: the map is offered only for values that are in fact in kPa
    log.write_text("time_s,Pressure (kPascal)\n" + "".join(f"{x:.1f},{30 + x:.3f}\n" for x in t))
    r = runner.invoke(app, ["predict", str(log), "--params", str(_truth(tmp_path)), "--out", str(tmp_path / "o"),
                            "--pressure-reference", "gauge"])
    assert r.exit_code == 2 and "only if the values are in fact in kPa" in " ".join(r.output.split())


def test_predict_refuses_a_config_geometry_the_fit_was_not_made_for(tmp_path):
    log = tmp_path / "g.csv"
    log.write_text("time_s,pressure_kpa,angle_deg\n" + "".join(f"{x:.1f},{20 + 8 * x:.3f},0\n" for x in range(10)))
    params = _truth(tmp_path)
    cfg = tmp_path / "muscleA.yaml"
    cfg.write_text("model: {geometry: {th_mm: 2.5, alpha0_deg: 28, R0_mm: 12, l0_mm: 150, n: 6}}\n"
                   "io: {pressure_reference: gauge}\n")
    r = runner.invoke(app, ["predict", str(log), "--params", str(params), "--config", str(cfg),
                            "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and "model.geometry" in r.output and "R0 12 mm" in " ".join(r.output.split())
    assert not (tmp_path / "o").exists()
    # the fit's own geometry stated again is no conflict; predict.yaml says which muscle it predicted
    cfg.write_text("model: {geometry: {th_mm: 2, alpha0_deg: 30, R0_mm: 16.73, l0_mm: 195.9, n: 7.43}}\n"
                   "io: {pressure_reference: gauge}\n")
    r = runner.invoke(app, ["predict", str(log), "--params", str(params), "--config", str(cfg),
                            "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    geo = yaml.safe_load((tmp_path / "o" / "predict.yaml").read_text())["model"]["geometry"]
    assert geo["R0"] == 0.01673 and geo["n"] == 7.43


def test_a_users_folder_called_datasets_says_nothing_about_synthetic(tmp_path):
    measured = tmp_path / "datasets" / "lab1" / "run.csv"
    measured.parent.mkdir(parents=True)
    measured.write_text("time_s,pressure_kpa,angle_deg\n0,20,10\n0.1,21,10.5\n")
    assert not file_is_synthetic(measured)
    shipped = sorted((ROOT / "datasets" / "relaxation").glob("*.csv"))[0]
    assert file_is_synthetic(shipped)
    assert not file_is_synthetic(next((ROOT / "datasets" / "reference").rglob("*.csv")))


def test_predict_keeps_an_ambient_column_and_a_synthetic_label(tmp_path):
    t = np.round(np.arange(0, 20, 0.1), 2)
    amb = 95.0 + 4.0 * t / t[-1]                               # kPa, drifting
    p_abs = amb + 20 + 40 * (1 - np.cos(2 * np.pi * t / 10))
    log = tmp_path / "abs.csv"
    log.write_text("# synthetic: true (test data)\n# pressure_reference: absolute\n"
                   "time_s,pressure_kpa,ambient_pressure_kpa\n"
                   + "".join(f"{a:.2f},{b:.4f},{c:.4f}\n" for a, b, c in zip(t, p_abs, amb)))
    params = _truth(tmp_path)
    r = runner.invoke(app, ["predict", str(log), "--params", str(params), "--out", str(tmp_path / "p")])
    assert r.exit_code == 0, r.output
    out = tmp_path / "p" / "abs.csv"
    first = pd.read_csv(out, comment="#")
    assert np.allclose(first.ambient_pressure_kpa, amb, atol=1e-6)
    assert file_is_synthetic(out) and "atmosphere_pa" not in out.read_text()
    body = yaml.safe_load((tmp_path / "p" / "predict.yaml").read_text())
    assert body["synthetic"] is True and body["synthetic_logs"] == ["abs"]
    # read back (its mean ambient alone shifted the angle by up to 1.5 deg): the same gauge pressure and angle
    back = read_motion_log(out)
    assert np.allclose(back.pressure_pa, (p_abs - amb) * 1e3, atol=0.01)
    r = runner.invoke(app, ["predict", str(out), "--params", str(params), "--out", str(tmp_path / "p2")])
    assert r.exit_code == 0, r.output
    again = pd.read_csv(tmp_path / "p2" / "abs.csv", comment="#")
    assert np.abs(again.angle_pred_deg - first.angle_pred_deg).max() < 1e-5


def test_moduli_typed_in_mpa_are_blamed_on_the_fit_file_not_the_log(tmp_path):
    log = tmp_path / "g.csv"
    log.write_text("time_s,pressure_kpa\n0,20\n0.1,21\n")
    r = runner.invoke(app, ["predict", str(log), "--params", str(_truth(tmp_path, "6.434", "13.645")),
                            "--pressure-reference", "gauge", "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and "truth.yaml" in r.output and "material.K_inf" in r.output
    assert "g.csv" not in r.output


def test_a_pressure_beyond_a_float_names_its_line(tmp_path):
    log = tmp_path / "huge.csv"
    log.write_text("time_s,pressure_kpa\n0,20\n0.1,1e308\n")
    r = runner.invoke(app, ["predict", str(log), "--params", str(_truth(tmp_path)), "--pressure-reference", "gauge",
                            "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and "huge.csv:3" in r.output and "too large" in r.output
    assert "RuntimeWarning" not in r.output


def test_a_config_stating_the_papers_muscle_or_closure_is_not_ignored_for_another_fit(tmp_path):
    """A config that wrote out the paper's geometry or `closure: paper` was taken for no statement at all (only
    values other than the defaults were compared), so a fit of another muscle ran without a word; control ignored
    any config geometry, and discover --init fitted the init file's muscle instead of the config's."""
    other = tmp_path / "other.yaml"
    other.write_text((TRUTH % ("6434000.0", "13645000.0")).replace("R0: 0.01673", "R0: 0.012")
                     .replace("closure: paper", "closure: consistent"))
    log = tmp_path / "g.csv"
    log.write_text("time_s,pressure_kpa,angle_deg\n" + "".join(f"{x / 10:.1f},{30 + x:.1f},10\n" for x in range(40)))
    cfg = tmp_path / "paper.yaml"
    for body, key in (("model: {geometry: {th_mm: 2, alpha0_deg: 30, R0_mm: 16.73, l0_mm: 195.9, n: 7.43}}\n",
                       "model.geometry"), ("model: {closure: paper}\n", "model.closure")):
        cfg.write_text(body + "io: {pressure_reference: gauge}\n")
        r = runner.invoke(app, ["predict", str(log), "--params", str(other), "--config", str(cfg),
                                "--out", str(tmp_path / "o")])
        assert r.exit_code == 2 and key in r.output, r.output
    cfg.write_text("model: {geometry: {th_mm: 2.5, alpha0_deg: 28, R0_mm: 12, l0_mm: 150, n: 6}}\n")
    r = runner.invoke(app, ["control", "--params", str(_truth(tmp_path)), "--config", str(cfg), "--reference",
                            "steps", "--out", str(tmp_path / "c")])
    assert r.exit_code == 2 and "model.geometry" in r.output and not (tmp_path / "c").exists()
    # a fit as discovery's start: its constants are refitted, so the config's muscle is the one fitted, and said
    from bpmid.config import load_config
    from bpmid.models.vbmm import starting_vbmm

    model, where, _ = starting_vbmm(_truth(tmp_path), load_config(cfg).section("model"))
    assert model.geometry.R0 == 0.012 and "the geometry from the config" in where


def test_a_vbmm_object_runs_with_the_configs_history_mode(tmp_path):
    import bpmid
    from bpmid.models.vbmm import load_vbmm

    log = tmp_path / "g.csv"
    log.write_text("time_s,pressure_kpa\n" + "".join(f"{x / 10:.1f},{30 + 20 * (x % 20 > 9):.1f}\n" for x in range(80)))
    cfg = tmp_path / "w.yaml"
    cfg.write_text("model: {history: window, window_s: 0.3}\nio: {pressure_reference: gauge}\n")
    params = _truth(tmp_path)
    by_file = bpmid.predict([log], params, config=cfg)
    by_object = bpmid.predict([log], load_vbmm(params), config=cfg)   # it ran the exact history: 8 deg apart
    assert by_object.body["model"]["history"] == "window" and by_object.body["model"]["window_s"] == 0.3
    assert np.array_equal(by_object.predictions["g"], by_file.predictions["g"])


def test_one_rule_says_a_file_is_synthetic(tmp_path):
    """A log saying only '# generator: bpmid simulate' was synthetic to run.yaml's count and measured to predict."""
    from bpmid.io.motion_logs import is_synthetic

    for head, truth in (("# generator: bpmid simulate (protocol x)\n", True), ("# synthetic: false\n", False),
                        ("# source: bpmid digital twin\n", True), ("# operator: A. Person\n", False)):
        p = tmp_path / "g.csv"
        p.write_text(head + "# pressure_reference: gauge\ntime_s,pressure_kpa,angle_deg\n0,20,10\n0.1,21,10.5\n")
        assert file_is_synthetic(p) is truth
        assert is_synthetic([read_motion_log(p, require_angle=True)]) is truth


def test_simulate_with_a_fit_refuses_a_protocol_closure_it_would_drop(tmp_path):
    proto = tmp_path / "c.yaml"
    proto.write_text((PROTO % "1.01325") + "plant: {closure: consistent}\n")
    r = runner.invoke(app, ["simulate", str(proto), "--params", str(_truth(tmp_path)), "--out", str(tmp_path / "o")])
    assert r.exit_code == 2 and "plant.closure" in r.output and not (tmp_path / "o").exists()
    proto.write_text((PROTO % "1.01325") + "plant: {closure: paper, material: paper_mat}\n")   # the fit's own: fine
    r = runner.invoke(app, ["simulate", str(proto), "--params", str(_truth(tmp_path)), "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
