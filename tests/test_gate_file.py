"""A thresholds file in use (``bpmid discover --thresholds``): values a calibration never writes are refused by key,
and the conditions and warnings of the calibration that made it are said beside a verdict on other logs."""
import math

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from bpmid.cli import app
from bpmid.discover.calibrate import THRESHOLDS_PATH, load_thresholds, thresholds_calibration
from bpmid.discover.cautions import gate_cautions
from bpmid.errors import InputError
from bpmid.io.motion_logs import from_arrays

CASE = THRESHOLDS_PATH.parents[2] / "datasets" / "discovery" / "case_01"


def _file(tmp_path, name="thr.yaml", **changes):
    d = yaml.safe_load(THRESHOLDS_PATH.read_text())
    cal = changes.pop("calibration", None)
    d.update(changes)
    if cal:
        d["calibration"].update(cal)
    p = tmp_path / name
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    return p


@pytest.mark.parametrize("key, value, words", [
    ("heldout_gain_min_sigma", -5, "0 or more noise floors"),
    ("family_alpha", 0.0, "a family-wise level between 0 and 1"),
    ("family_alpha", 1.5, "a family-wise level between 0 and 1"),
    ("gap_share_min", 1.5, "a share from 0 to 1"),
    ("to_floor_ratio_max", 0, "above 0 noise floors"),
    ("pair_gain_min_sigma", float("nan"), "must be a number"),
    ("fit_share_min", "high", "must be a number"),
    ("pair_over_gain_min_sigma", True, "must be a number")])
def test_a_value_no_calibration_writes_is_refused_by_its_key(tmp_path, key, value, words):
    """A hand-edited gain of -5 was used in silence (a helper's trial)."""
    with pytest.raises(InputError) as e:
        load_thresholds(_file(tmp_path, **{key: value}))
    assert e.value.key == key and words in str(e.value)


def test_closed_paths_and_the_shipped_values_are_accepted(tmp_path):
    thr = load_thresholds(_file(tmp_path, pair_share_min=math.inf, to_floor_drop_min_sigma=math.inf))
    assert thr["pair_share_min"] == math.inf and thr["to_floor_drop_min_sigma"] == math.inf
    assert load_thresholds()["family_alpha"] == pytest.approx(1e-9)


def test_cli_discover_names_the_file_and_the_key_before_any_work(tmp_path):
    bad = _file(tmp_path, heldout_gain_min_sigma=-5)
    r = CliRunner().invoke(app, ["discover", *map(str, sorted(CASE.glob("train_*.csv"))), "--holdout",
                                 *map(str, sorted(CASE.glob("holdout_*.csv"))), "--thresholds", str(bad),
                                 "--out", str(tmp_path / "d")])
    assert r.exit_code == 2, r.output
    assert "key 'heldout_gain_min_sigma'" in r.output and "found -5" in r.output and str(bad) in r.output
    assert not (tmp_path / "d").exists()


def _logs(hz, n=3):
    rng = np.random.default_rng(5)
    t = np.arange(0, 60, 1.0 / hz)
    return [from_arrays(f"log{k}", t, 2e4 * (1 + np.sin(t)), rng.normal(0, 0.3, t.size)) for k in range(n)]


def test_a_gate_calibrated_on_other_conditions_is_said_with_what_differs(tmp_path):
    warned = "warning: the thresholds were calibrated on 11 judged case(s), 2 of them null: too few"
    f = _file(tmp_path, calibration={"generator": {"noise_deg": [0.25, 0.25], "noise_rho": [0.5, 0.5],
                                                   "sampling_hz": [25.0]}, "warnings": [warned]})
    cal = thresholds_calibration(f)
    said = gate_cautions(str(f), cal, _logs(10), {"sigma_deg": 0.30, "rho": 0.02})
    assert len(said) == 2
    assert said[0] == f"the gate's calibration ({f}) warned: " + warned.removeprefix("warning: ")
    assert "calibrated on angle noise 0.25 deg, lag-1 correlation 0.5, 25 Hz" in said[1]
    assert "a lag-1 correlation of the noise of 0.02 and sampling at 10 Hz" in said[1]
    assert "noise floor" not in said[1]          # 0.30 deg is within 1.25 times 0.25 deg
    # the same conditions: only the calibration's own warning; a far noise floor is said
    assert gate_cautions(str(f), cal, _logs(25), {"sigma_deg": 0.26, "rho": 0.45}) == said[:1]
    far = gate_cautions(str(f), cal, _logs(25), {"sigma_deg": 0.05, "rho": 0.45})
    assert "a noise floor of 0.05 deg" in far[1] and "sampling" not in far[1]
    # the shipped gate (no file given) is not judged here
    assert gate_cautions(None, {}, _logs(10), {"sigma_deg": 0.30, "rho": 0.02}) == []



def test_a_typo_or_an_unreadable_calibration_block_is_refused_before_any_work(tmp_path):
    """A typo read as the key missing; a calibration block discover could not read crashed after the whole fit."""
    d = yaml.safe_load(THRESHOLDS_PATH.read_text())
    d["gap_share_minn"] = d.pop("gap_share_min")
    p = tmp_path / "typo.yaml"
    p.write_text(yaml.safe_dump(d))
    with pytest.raises(InputError) as e:
        load_thresholds(p)
    assert e.value.key == "gap_share_minn" and "did you mean gap_share_min?" in str(e.value)
    for cal, key in (({"warnings": 5}, "calibration.warnings"), ("hello", "calibration"),
                     ({"generator": {"noise_deg": "abc"}}, "calibration.generator.noise_deg"),
                     ({"generator": [1, 2]}, "calibration.generator")):
        d = yaml.safe_load(THRESHOLDS_PATH.read_text())
        d["calibration"] = cal
        p.write_text(yaml.safe_dump(d))
        with pytest.raises(InputError) as e:
            load_thresholds(p)
        assert e.value.key == key, (cal, e.value.key)
        with pytest.raises(InputError):   # the only way to the cautions: never a crash there
            thresholds_calibration(p)
