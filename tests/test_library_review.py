"""A notebook user's trial of the library (stop 44): a user's file never replaced by a save, clock times read as
seconds, warnings from every workflow given as BpmidWarning at the caller's own line and kept in ``.warnings``,
a gap in arrays said as a gap in a file is."""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import bpmid

REPO = Path(__file__).resolve().parents[1]


def _arrays(n=600, dt=0.1):
    t = np.arange(n) * dt
    p = 0.4 + 0.2 * np.sin(t / 2.0)
    return t, p, 20.0 + 60.0 * (p - 0.2)


def _prediction():
    """A prediction of log 'm' by a VBMM fitted on it (warnings of the fit silenced)."""
    t, p, a = _arrays()
    lg = bpmid.from_arrays(t, p, a, pressure_unit="bar", reference="gauge", name="m")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return bpmid.predict([lg], bpmid.fit_motion([lg]))


def test_saving_a_prediction_never_replaces_a_file_bpmid_did_not_write(tmp_path):
    pred = _prediction()
    folder = tmp_path / "clash"
    folder.mkdir()
    (folder / "m.csv").write_text("user raw data\n")
    with pytest.raises(bpmid.InputError, match="bpmid did not write it"):
        pred.save(folder)
    assert (folder / "m.csv").read_text() == "user raw data\n"
    (folder / "m.csv").unlink()
    pred.save(folder)
    pred.save(folder)   # its own files: a rerun replaces them
    assert "bpmid predict output" in (folder / "m.csv").read_text()


@pytest.mark.parametrize("kind", ["DatetimeIndex", "datetime64", "Timedelta", "datetime objects", "zoned"])
def test_clock_times_are_seconds_since_the_first_sample(kind):
    """A DatetimeIndex was read as nanoseconds: a 60 s log became 6e10 s, fitted as a static model."""
    t, p, a = _arrays()
    idx = pd.Timestamp("2024-05-01 10:00") + pd.to_timedelta(t, unit="s")
    zoned = pd.date_range("2024-03-31 00:59:00", periods=t.size, freq="100ms", tz="Europe/Berlin")   # across DST
    given = {"DatetimeIndex": idx, "datetime64": idx.values, "Timedelta": pd.to_timedelta(t, unit="s"),
             "datetime objects": list(idx.to_pydatetime()), "zoned": zoned}[kind]
    with warnings.catch_warnings():
        warnings.simplefilter("error")   # no per-sample time-zone warnings from numpy
        lg = bpmid.from_arrays(given, p, a, pressure_unit="bar", reference="gauge")
    np.testing.assert_allclose(lg.time_s, t, atol=1e-6)
    with pytest.raises(bpmid.InputError, match="carry their own unit"):
        bpmid.from_arrays(given, p, a, pressure_unit="bar", reference="gauge", time_unit="ms")


def test_a_gap_in_arrays_is_said_as_in_a_file():
    t, p, a = _arrays()
    t[300:] += 30.0
    lg = bpmid.from_arrays(t, p, a, pressure_unit="bar", reference="gauge", name="gap")
    with pytest.warns(bpmid.BpmidWarning, match="gap of 30.1 s") as rec:
        bpmid.fit_motion([lg])
    assert any(w.filename == __file__ for w in rec)


def test_compare_warnings_reach_the_caller_and_its_warnings(tmp_path):
    """Times written in ms under a time_s header: compare printed the warning on stderr past every filter and
    kept it out of .warnings."""
    src = REPO / "datasets" / "motion" / "fitting_set" / "fit_1p2_1p6_r1.csv"
    rows = src.read_text().splitlines()
    out = [r if not r[:1].isdigit() else ",".join([f"{float(r.split(',')[0]) * 1000:g}"] + r.split(",")[1:])
           for r in rows]
    ms = tmp_path / "ms.csv"
    ms.write_text("\n".join(out) + "\n")
    test = REPO / "datasets" / "motion" / "variable_rate" / "rate_0p114_r1.csv"
    with pytest.warns(bpmid.BpmidWarning, match="apart") as rec:
        cmp = bpmid.compare([ms], [test], models="two-branch")
    assert all(w.filename == __file__ for w in rec)
    assert any("apart" in w for w in cmp.warnings)


def test_a_folder_result_refuses_a_file_path(tmp_path):
    pred = _prediction()
    with pytest.raises(bpmid.InputError, match="is a folder"):
        pred.save(tmp_path / "pred.yaml")
    assert not (tmp_path / "pred.yaml").exists()


def test_the_synthetic_stamp_names_the_twin_only_for_the_twin_s_logs(tmp_path):
    """Figures of logs another generator made said 'synthetic data (bpmid digital twin)'."""
    from bpmid.io.motion_logs import TWIN_NOTE, read_motion_logs, synthetic_note

    twin = REPO / "datasets" / "motion" / "fitting_set" / "fit_1p2_1p6_r1.csv"
    text = twin.read_text().replace("# synthetic: true (bpmid digital twin; not a measurement)",
                                    "# synthetic: true (own VBMM simulator, seed 3)")
    own = tmp_path / "own.csv"
    own.write_text(text)
    measured = tmp_path / "measured.csv"
    measured.write_text("".join(ln + "\n" for ln in text.splitlines() if not ln.startswith("# synthetic")))
    t, o, m = read_motion_logs([twin, own, measured])
    assert synthetic_note([t]) == TWIN_NOTE
    assert synthetic_note([o]) == "synthetic data (the logs' own headers say so)"
    assert synthetic_note([t, o, m]) == "partly synthetic: 2 of 3 logs" and synthetic_note([m]) is None
    for words in ("bpmid.validation out-of-family generator; not a measurement", "digital twin of our rig B"):
        other = tmp_path / "other.csv"
        other.write_text(twin.read_text().replace("bpmid digital twin; not a measurement", words))
        assert synthetic_note(read_motion_logs([other])) == "synthetic data (the logs' own headers say so)", words


def test_control_warnings_are_given_not_refused_under_io_strict(tmp_path):
    """Saturation says how the loop ran, not that an input is wrong: bpmid control writes the result with them
    under io.strict, and the library call gives them as warnings alike (it refused them)."""
    from test_simulate_predict_review import TRUTH

    params = tmp_path / "vbmm.yaml"
    params.write_text(TRUTH % (6.434e6, 3.2e6))
    with pytest.warns(bpmid.BpmidWarning, match="saturated"):
        ctl = bpmid.control(params, reference="steps", controllers="pi", seed=1, config={"io": {"strict": True}})
    assert ctl.warnings


def test_a_gap_in_arrays_is_judged_by_the_config_as_a_file_is():
    """io.max_gap_factor applies to arrays too (a fixed factor of 5 refused, under io.strict, arrays whose file
    was accepted)."""
    t = np.r_[np.arange(0, 10, 0.02), np.arange(10, 20, 0.5), np.arange(20, 30, 0.02)]
    p = np.interp(t, [0, 10, 20, 30], [0.1, 0.8, 0.8, 0.1])
    lg = bpmid.from_arrays(t, p, 20 + 60 * p, pressure_unit="bar", reference="gauge", name="evt")
    from bpmid.api import _array_gaps
    from bpmid.io.motion_logs import IOConfig

    assert not _array_gaps(lg, IOConfig(max_gap_factor=100.0)).warnings
    assert any("gap of 0.5" in w for w in _array_gaps(lg, IOConfig()).warnings)
    with pytest.raises(bpmid.InputError, match="io.max_gap_s"):
        _array_gaps(lg, IOConfig(max_gap_s=0.1))
