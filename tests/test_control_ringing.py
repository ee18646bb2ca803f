"""Ringing of the closed loop (bpmid.control_ringing): found where it happens, with its numbers, in the status,
summary.csv, control.yaml and the warnings; fig18 draws every sample and labels each panel's marks beside it."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from bpmid import control_ringing as R
from bpmid.control import (ControlConfig, build_plant, builtin_reference, run_control, simulate_loop,
                           summary_table)
from bpmid.models.vbmm import VBMM, Material
from bpmid.twin.sensors import Sensors

MODEL = VBMM(Material.paper_fit())
QUIET = ControlConfig(sensors=Sensors())
STEP_TIMES = (15.0, 25.0, 35.0, 45.0)   # the built-in steps reference's changes


def _ringing_step(a: float, n: int = 200, rate_hz: float = 10.0, height: float = 15.0):
    """A step of the reference at sample 50 and an angle that answers as a loop with a Nyquist pole at -a: its
    error comes back at -a times itself each sample."""
    t = np.arange(n) / rate_hz
    r = np.where(np.arange(n) >= 50, 45.0 + height, 45.0)
    e = np.zeros(n)
    e[50] = height
    for k in range(51, n):
        e[k] = -a * e[k - 1]
    return t, r, r - e


# ---------------------------------------------------------------------------------------------------------------
# the detector on signals whose answer is known
# ---------------------------------------------------------------------------------------------------------------
def _walk(x, band):
    """The dead-band walk written out in plain Python, as the module first had it (the compiled kernel's twin)."""
    pts, i_hi, i_lo, direction, ext = [], 0, 0, 0, 0
    for k in range(1, len(x)):
        v = x[k]
        if direction == 0:
            i_hi = k if v > x[i_hi] else i_hi
            i_lo = k if v < x[i_lo] else i_lo
            if x[i_hi] - x[i_lo] > band:
                direction = 1 if i_hi > i_lo else -1
                pts.append(min(i_hi, i_lo))
                ext = max(i_hi, i_lo)
        elif direction > 0:
            if v > x[ext]:
                ext = k
            elif x[ext] - v > band:
                pts.append(ext)
                direction, ext = -1, k
        else:
            if v < x[ext]:
                ext = k
            elif v - x[ext] > band:
                pts.append(ext)
                direction, ext = 1, k
    if direction != 0:
        pts.append(ext)
    return pts


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_compiled_turning_points_equal_the_plain_walk_and_alternate_beyond_the_band(seed):
    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.normal(0.0, 1.0, 3000))
    band = 2.5
    p = R.turning_points(x, band)
    assert p.tolist() == _walk(x, band)
    d = np.diff(x[p])
    assert p.size > 10 and np.all(np.abs(d) > band) and np.all(np.sign(d[1:]) == -np.sign(d[:-1]))
    assert R.turning_points(np.zeros(5), band).size == 0 and R.turning_points(x[:1], band).size == 0


def test_a_lightly_damped_step_response_is_one_episode_with_its_numbers():
    t, r, y = _ringing_step(0.9)
    eps = R.episodes(t, r, y, R.swing_band_deg(0.0))
    assert len(eps) == 1
    ep = eps[0]
    assert ep.start_s == pytest.approx(5.0)   # at the step
    assert ep.period_s == pytest.approx(0.2)  # the Nyquist frequency of a 10 Hz loop
    # swings back (peak to peak): 15 (0.9 + 0.81), then 0.9 of the one before each sample, until below 1 deg
    assert ep.first_swing_deg == pytest.approx(15 * (0.9 + 0.81))
    assert ep.last_swing_deg > R.RINGING_MIN_SWING_DEG and ep.last_swing_deg * 0.9 < R.RINGING_MIN_SWING_DEG * 1.2
    n_expected = 1 + int(np.floor(np.log(R.RINGING_MIN_SWING_DEG / (15 * 1.9 * 0.9)) / np.log(0.9))) + 1
    assert abs(ep.swings - n_expected) <= 1
    assert ep.duration_s == pytest.approx(ep.swings * 0.1)


@pytest.mark.parametrize("a", [0.0, 0.3, 0.5])
def test_a_well_damped_step_response_is_no_episode(a):
    t, r, y = _ringing_step(a)
    assert R.episodes(t, r, y, R.swing_band_deg(0.0)) == []


def test_sensor_noise_alone_and_a_reference_the_angle_lags_are_no_episode():
    rng = np.random.default_rng(3)
    t = np.arange(3000) * 0.1
    r = np.full(t.size, 60.0)
    sigma = 0.1
    assert R.episodes(t, r, r + sigma * rng.standard_normal(t.size), R.swing_band_deg(sigma)) == []
    # a 1 Hz reference followed with a phase lag: the error swings every 0.5 s, with the reference, not the loop
    r = 60.0 + 10.0 * np.sin(2 * np.pi * 1.0 * t)
    y = 60.0 + 7.0 * np.sin(2 * np.pi * 1.0 * t - 0.8)
    assert R.episodes(t, r, y, R.swing_band_deg(0.0)) == []
    # a step answered at once and then held: the error's one swing is the reference's jump, not the loop's
    r = np.where(t >= 5.0, 60.0, 45.0)
    assert R.episodes(t, r, np.r_[45.0, r[:-1]], R.swing_band_deg(0.0)) == []


def test_the_band_is_the_floor_or_three_sigmas_of_a_readings_change():
    assert R.swing_band_deg(0.0) == R.RINGING_MIN_SWING_DEG
    assert R.swing_band_deg(1.0) == pytest.approx(3.0 * np.sqrt(2.0))


# ---------------------------------------------------------------------------------------------------------------
# the closed loop
# ---------------------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def steps_runs():
    """PI and VBMM-PI on the built-in steps, plant = the controller's model, no sensor noise, at the paper's gains
    (P times the rubber's instantaneous gain about 0.9: the loop rings) and at half the P gain (well damped)."""
    ref = builtin_reference("steps")
    plant = build_plant(MODEL, [], QUIET)
    paper = [simulate_loop(c, ref, MODEL, plant, QUIET) for c in ("pi", "vbmm-pi")]
    half = dataclasses.replace(QUIET, kp_bar_per_deg=0.02)
    damped = [simulate_loop(c, ref, MODEL, plant, half) for c in ("pi", "vbmm-pi")]
    return paper, damped, half


def test_the_paper_gains_ring_after_each_step_and_say_so_with_numbers(steps_runs):
    paper, _damped, _half = steps_runs
    tab = summary_table(paper, QUIET).set_index(["controller", "reference"])
    row = tab.loc[("pi", "steps")]
    assert "oscillating" in row.status
    # averaged over the whole run the command reverses on a quarter of the steps or fewer: the old verdict missed it
    assert row.reversal_pct < QUIET.oscillation_limit_pct
    assert row.ringing_episodes >= 3 and row.ringing_period_s == pytest.approx(0.2)
    assert row.ringing_swing_deg > 5.0 and 0.6 <= row.ringing_longest_s < 5.0
    starts = [ep.start_s for ep in paper[0].ringing]
    assert all(min(abs(s - st) for st in STEP_TIMES) <= 0.1 for s in starts)   # where: at the steps
    assert tab.loc[("pi", "ALL"), "ringing_episodes"] == row.ringing_episodes
    assert "oscillating" in tab.loc[("pi", "ALL"), "status"]


def test_a_higher_gain_rings_longer_and_a_lower_one_not_at_all(steps_runs):
    paper, damped, half = steps_runs
    for run in damped:
        assert run.ringing == [] and "oscillating" not in run.metrics(half)["status"]
    ref = builtin_reference("steps")
    hot = dataclasses.replace(QUIET, kp_bar_per_deg=0.05)
    run = simulate_loop("pi", ref, MODEL, build_plant(MODEL, [], hot), hot)
    assert sum(ep.duration_s for ep in run.ringing) > sum(ep.duration_s for ep in paper[0].ringing)


def test_a_plant_with_a_pressure_lag_damps_the_ringing_and_twice_the_gain_rings_slower():
    # seed 004's dead time and a valve lag: the loop no longer answers within the sample, and the paper's gains settle;
    # twice the P gain rings again, at about 1 Hz (not the Nyquist frequency), and is found the same way
    lag = ["pressure_lag:tau=0.25,dead_time=0.15"]
    run = simulate_loop("pi", builtin_reference("steps"), MODEL, build_plant(MODEL, lag, QUIET), QUIET)
    assert run.ringing == []
    hot = dataclasses.replace(QUIET, kp_bar_per_deg=0.08)
    run = simulate_loop("pi", builtin_reference("steps"), MODEL, build_plant(MODEL, lag, hot), hot)
    assert run.ringing and "oscillating" in run.metrics(hot)["status"]
    assert all(0.6 <= ep.period_s <= 1.6 for ep in run.ringing)


def test_warnings_summary_and_control_yaml_carry_the_ringing(tmp_path):
    import pandas as pd
    import yaml

    from bpmid.control import write_control
    from bpmid.io.results import provenance

    cfg = QUIET
    plant = build_plant(MODEL, [], cfg)
    res = run_control(MODEL, plant, [builtin_reference("steps")], cfg, controllers=["pi", "vbmm-pi"],
                      measure_cost=False)
    said = [w for w in res.warnings if w.startswith("pi on steps: oscillating")]
    assert said and "swings back and forth" in said[0] and "period 0.2 s" in said[0] and "Nyquist" in said[0]
    note = [w for w in res.warnings if w.startswith("ringing and the reductions against pi: every controller rings")]
    assert note and "pi's too, holds ringing" in note[0]
    write_control(res, tmp_path / "c", cfg, provenance([], seed=0, command="test"), model=MODEL, plant=plant,
                  figure=False)
    tab = pd.read_csv(tmp_path / "c" / "summary.csv")
    assert {"ringing_episodes", "ringing_s", "ringing_longest_s", "ringing_from_s", "ringing_swing_deg",
            "ringing_period_s"} <= set(tab.columns)
    body = yaml.safe_load((tmp_path / "c" / "control.yaml").read_text())
    eps = [e for e in body["ringing"]["episodes"] if e["controller"] == "pi"]
    assert len(eps) == int(tab.set_index(["controller", "reference"]).loc[("pi", "steps"), "ringing_episodes"])
    assert body["ringing"]["band_deg"]["pi on steps"] == R.RINGING_MIN_SWING_DEG
    assert {"start_s", "end_s", "swings", "first_swing_deg", "largest_swing_deg", "period_s"} <= set(eps[0])


# ---------------------------------------------------------------------------------------------------------------
# fig18
# ---------------------------------------------------------------------------------------------------------------
def _legend_beside(fig, ax):
    """The figure legends whose top lies within the height of ``ax`` (each panel's legend sits beside it)."""
    fig.canvas.draw()
    rnd = fig.canvas.get_renderer()
    box = ax.get_window_extent(rnd)
    out = []
    for leg in fig.legends:
        top = leg.get_window_extent(rnd).y1
        if box.y0 - 1 <= top <= box.y1 + 1:
            out += [t.get_text() for t in leg.get_texts()]
    return out


def test_fig18_labels_each_panels_marks_beside_it_and_draws_every_sample(steps_runs):
    from bpmid.plots.control import BOUNDARY_LABEL, LIMITS_LABEL, RINGING_LABEL, fig18, zoom_window

    paper, _damped, _half = steps_runs
    sines = builtin_reference("sines")
    plant = build_plant(MODEL, [], QUIET)
    runs = paper + [simulate_loop(c, sines, MODEL, plant, QUIET) for c in ("pi", "vbmm-pi")]
    fig = fig18(runs, limits_bar=(QUIET.p_min_bar_abs, QUIET.p_max_bar_abs))
    a, b, c, d = fig.axes[:4]
    # the artists' own labels, panel by panel
    la = a.get_legend_handles_labels()[1]
    assert {"reference", "PI", "VBMM-PI", BOUNDARY_LABEL} <= set(la) and LIMITS_LABEL not in la
    assert c.get_legend_handles_labels()[1] == [LIMITS_LABEL]
    # the boundaries (vertical, in a, b, c) and the limits (horizontal, in c) are drawn unlike each other
    bound = [ln for ln in a.get_lines() if ln.get_label() == BOUNDARY_LABEL][0]
    limit = [ln for ln in c.get_lines() if ln.get_label() == LIMITS_LABEL][0]
    assert bound.get_linestyle() != limit.get_linestyle()
    assert np.ptp(bound.get_xdata()) == 0 and np.ptp(limit.get_ydata()) == 0
    # the legends, by where they sit
    beside_a, beside_b, beside_c, beside_d = (_legend_beside(fig, x) for x in (a, b, c, d))
    assert {"reference", "PI", "VBMM-PI", BOUNDARY_LABEL} <= set(beside_a) and LIMITS_LABEL not in beside_a
    assert beside_b == [RINGING_LABEL]
    assert beside_c == [LIMITS_LABEL]
    assert {"PI", "VBMM-PI"} <= set(beside_d) and LIMITS_LABEL not in beside_d
    # every sample: the time panels hold each run's samples end to end, solid (a dash pattern hid the ringing)
    pi_line = [ln for ln in a.get_lines() if ln.get_label() == "PI"][0]
    assert len(pi_line.get_xdata()) == sum(r.time_s.size for r in runs if r.controller == "pi")
    assert pi_line.get_linestyle() == "-"
    # (d): the longest ringing, every sample of it, a marker each
    name, t0, t1, _words = zoom_window(runs)
    assert name == "steps"
    run = paper[0]
    k = (run.time_s >= t0 - 1e-9) & (run.time_s <= t1 + 1e-9)
    zl = [ln for ln in d.get_lines() if ln.get_label() == "PI"][0]
    np.testing.assert_array_equal(zl.get_xdata(), run.time_s[k])
    np.testing.assert_array_equal(zl.get_ydata(), run.angle_deg[k])
    assert zl.get_marker() not in (None, "None", "", " ")
    assert "rings" in d.get_title(loc="left")


def test_the_warning_gives_the_largest_swing_summary_csv_gives_when_it_is_not_the_longest_episodes():
    """The warning described the longest episode (10.2 deg) while summary.csv's ringing_swing_deg is the largest
    of any (18.85 deg): the warning now gives that one too when they differ."""
    from bpmid.control import ringing_words

    long_small = R.Episode(10.0, 12.0, 20, 8.0, 8.0, 1.0, 0.2)
    short_big = R.Episode(30.0, 31.0, 8, 18.0, 18.0, 2.0, 0.2)
    said = ringing_words([long_small, short_big], 10.0)
    assert "the longest from 10 s for 2 s" in said and "the largest swing back in any episode 18 deg" in said
    assert R.summary([long_small, short_big])["ringing_swing_deg"] == 18.0
    assert "largest swing back in any" not in ringing_words([long_small], 10.0)
