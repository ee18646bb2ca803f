"""The general forms of braid_friction (pressure-proportional sliding level mu, elastic stick slip; the play as
mu = slip = 0) and pressure_lag (two cascaded lags, share of the second): kernel properties, the closed loop's
causal form equal to the whole-signal form, the C export's refusal, and recovery of known truth."""
import dataclasses

import numpy as np
import pytest

from bpmid import control_kernels as CK
from bpmid.control import causal_terms
from bpmid.discover.model import ModelState, fit_state
from bpmid.effects import _kernels as K
from bpmid.effects import get_effect
from bpmid.effects.base import AugmentedVBMM
from bpmid.errors import InputError
from bpmid.io.motion_logs import from_arrays
from bpmid.models.vbmm import VBMM, triangle_pressure
from bpmid.twin.simulate import build_effect

ATM = 101325.0


def walk(seed, n=800):
    rng = np.random.default_rng(seed)
    return np.abs(4e4 + np.cumsum(rng.normal(0.0, 1500.0, n)))  # gauge Pa, wandering up and down


def triangle_log(fs=20.0, cycles=3, rates=(0.05, 0.2)):
    """Triangles 1.1-2.3 bar absolute at two rates (bar/s), as one gauge-pressure record."""
    t_all, p_all, t0 = [], [], 0.0
    for rate in rates:
        period = 2 * 1.2 / rate
        t = np.arange(int(round(cycles * period * fs)) + 1) / fs
        t_all.append(t0 + t)
        p_all.append(triangle_pressure(t, 1.1, 2.3, rate) * 1e5 - ATM)
        t0 += t[-1] + 1.0 / fs
    return np.concatenate(t_all), np.concatenate(p_all)


def test_friction_with_mu_and_slip_zero_is_the_play_operator():
    for seed, r in ((1, 2500.0), (2, 300.0), (3, 9000.0)):
        x = walk(seed)
        assert np.max(np.abs(K.friction(x, r, 0.0, 0.0) - K.play(x, r))) < 1e-8
    # the effect's defaults are the play bit for bit (the twin and the shipped datasets do not change)
    x = walk(4)
    e, ps = build_effect("braid_friction", {"r": 1200.0, "elements": 4})
    old = sum(K.play(x, ri) for ri in e.radii(1200.0)) / 4
    assert np.array_equal(e.transform_pressure(np.arange(x.size) * 0.1, x, ps), old)
    assert e.causal_pressure(ps) == (("plays", tuple(float(v) for v in e.radii(1200.0))),)


@pytest.mark.parametrize("r, mu, slip", [(0.0, 0.02, 8000.0), (500.0, 0.05, 0.0), (200.0, 0.01, 30000.0)])
def test_friction_stays_in_its_band_moves_with_its_input_and_ignores_timing(r, mu, slip):
    x = walk(7)
    y = K.friction(x, r, mu, slip)
    w = r + mu * np.maximum(x, 0.0)
    assert np.all(np.abs(y - x) <= w + 1e-9)
    dx, dy = np.diff(x), np.diff(y)
    assert np.all(dy * np.sign(dx) >= -1e-9)          # never moves against its input
    assert np.max(np.abs(y - x)) > 0.5 * np.max(w)     # and it does act
    # rate-independent: the same input values sampled twice as often give the same output at the shared samples
    x2 = np.repeat(x, 2)
    assert np.allclose(K.friction(x2, r, mu, slip)[::2], y, atol=1e-9)
    # an elastic stick rounds the reversal: after a small reversal the output has moved (a play would not)
    up_down = np.array([0.0, 4e4, 3.9e4])
    moved = K.friction(up_down, r, mu, slip)
    assert (moved[2] < moved[1]) == (slip > 0.0)


def test_friction_level_grows_with_the_pressure():
    t = np.linspace(0, 1, 5)
    # a reversal at 20 kPa and at 80 kPa: the pressure-proportional band is four times wider at the higher one
    lo = K.friction(np.array([0.0, 2e4, 0.0]), 0.0, 0.05, 0.0)
    hi = K.friction(np.array([0.0, 8e4, 0.0]), 0.0, 0.05, 0.0)
    assert (8e4 - hi[1]) == pytest.approx(4 * (2e4 - lo[1]))
    assert t.size == 5


def test_closed_loop_causal_chain_equals_the_whole_signal_effects():
    t, p = triangle_log(fs=20.0, cycles=1)
    lag, lp = build_effect("pressure_lag", {"tau": 0.3, "share": 0.4, "dead_time": 0.05})
    fr, fp = build_effect("braid_friction", {"r": 300.0, "mu": 0.03, "slip": 6000.0, "elements": 3})
    aug = AugmentedVBMM(VBMM(), (lag, fr), lp.added(fp))
    _model, terms = causal_terms(aug, t)
    ops, par, cnt = terms.arrays()
    n, m = t.size, ops.size
    hist, y, j, st = np.zeros((m, n)), np.zeros(m), np.zeros(m, np.int64), np.zeros(par.shape)
    stepped = np.array([CK.pressure_chain(k, t, p[k], ops, par, cnt, hist, y, j, st) for k in range(n)])
    whole = fr.transform_pressure(t, lag.transform_pressure(t, p, lp), fp)
    assert np.array_equal(stepped, whole)
    assert list(ops) == [CK.OP_DELAY, CK.OP_LAG, CK.OP_LAG, CK.OP_FRICTION]
    assert not np.allclose(whole, p, atol=100.0)


def test_second_lag_share_zero_is_the_first_order_lag_and_one_half_two_equal_lags():
    assert not get_effect("pressure_lag").default_params()["pressure_lag.share"].fixed   # fitted in discovery
    t, p = triangle_log(fs=50.0, cycles=1)
    e = get_effect("pressure_lag")
    ps = e.default_params().with_values({"pressure_lag.tau": 0.2})
    assert np.array_equal(e.transform_pressure(t, p, ps), K.lag(t, p, 0.2))
    ps = ps.with_values({"pressure_lag.share": 0.5})
    assert np.array_equal(e.transform_pressure(t, p, ps), K.lag(t, K.lag(t, p, 0.1), 0.1))


def test_c_export_steps_the_non_play_friction_as_friction_operators_and_exports_two_lags():
    from bpmid.export.c import causal_vbmm

    # the same (r, mu, slip) per element as the closed loop's plant (causal_pressure), never the play form
    fr, fp = build_effect("braid_friction", {"r": 300.0, "mu": 0.02, "elements": 2})
    cv = causal_vbmm(AugmentedVBMM(VBMM(), (fr,), fp))
    assert [op for op, _v in cv.chain] == ["frictions"]
    assert cv.chain == fr.causal_pressure(fp)
    assert cv.chain[0][1] == pytest.approx([200.0, 0.02 * 2 / 3, 0.0, 400.0, 0.02 * 4 / 3, 0.0])
    lag, lp = build_effect("pressure_lag", {"tau": 0.2, "share": 0.25})
    cv = causal_vbmm(AugmentedVBMM(VBMM(), (lag,), lp))
    assert [op for op, _v in cv.chain] == ["lag", "lag"]
    assert [v for _op, v in cv.chain] == pytest.approx([0.15, 0.05])


def _recover(eid, truth: dict, start: dict, seed: int, held=()):
    """Simulate the plain VBMM + the effect at ``truth`` with 0.05 deg noise; refit only the effect's
    parameters from ``start`` (the base constants and ``held`` held at their truth)."""
    t, p = triangle_log(fs=20.0)
    e = get_effect(eid)
    truth_ps = e.default_params().with_values(truth)
    clean = AugmentedVBMM(VBMM(), (e,), truth_ps).simulate_deg(t, p)
    rng = np.random.default_rng(seed)
    log = from_arrays("sim", t, p, clean + rng.normal(0.0, 0.05, t.size))
    state = ModelState.start(VBMM()).with_effect(e)
    ps = state.params
    for n in ps.free_names():
        if n.startswith("vbmm.") or n in held:
            ps = ps.replace(n, fixed=True)
    for n in start:                  # a parameter discovery holds by default (pressure_lag.share) is freed here
        ps = ps.replace(n, fixed=False)
    state = dataclasses.replace(state, params=ps.with_values(start))
    fitted, res = fit_state(state, [log], max_nfev=80, check_identifiability=False)
    return fitted.params, res


def test_refit_recovers_a_pressure_proportional_friction_with_an_elastic_stick():
    truth = {"braid_friction.r": 0.0, "braid_friction.mu": 0.03, "braid_friction.slip": 8000.0}
    ps, res = _recover("braid_friction", truth, {**truth, "braid_friction.mu": 0.01, "braid_friction.slip": 3000.0},
                       seed=3, held=("braid_friction.r",))
    assert ps.value("braid_friction.mu") == pytest.approx(0.03, rel=0.1)
    assert ps.value("braid_friction.slip") == pytest.approx(8000.0, rel=0.2)
    assert res.rmse < 0.06


def test_refit_recovers_a_cascade_of_two_lags():
    truth = {"pressure_lag.tau": 0.3, "pressure_lag.share": 0.4}
    ps, res = _recover("pressure_lag", truth, {"pressure_lag.tau": 0.1, "pressure_lag.share": 0.1}, seed=5)
    assert ps.value("pressure_lag.tau") == pytest.approx(0.3, rel=0.1)
    assert ps.value("pressure_lag.share") == pytest.approx(0.4, abs=0.12)
    assert res.rmse < 0.06


def test_files_written_before_the_new_parameters_still_load_with_the_older_form():
    from bpmid.effects.fitfile import effects_from_yaml

    effects, ps = effects_from_yaml([
        {"id": "pressure_lag", "parameters": {"tau": {"value": 0.2, "unit": "s"}}},
        {"id": "braid_friction", "settings": {"elements": 2}, "parameters": {"r": {"value": 900.0, "unit": "Pa"}}}])
    assert ps.value("pressure_lag.share") == 0.0 and ps.value("braid_friction.mu") == 0.0
    assert ps.value("braid_friction.slip") == 0.0 and effects[1].is_play(ps)
    with pytest.raises(InputError, match="missing key"):   # the original parameters stay required
        effects_from_yaml([{"id": "pressure_lag", "parameters": {"share": {"value": 0.2, "unit": "1"}}}])


def test_describe_prints_dimensionless_parameters_without_a_unit():
    # the verdict's wording: "share = 0", not "share = 0 1"; units kept where there is one
    lag, lp = build_effect("pressure_lag", {"tau": 0.2})
    text = lag.describe(lp)
    assert "tau = 0.2 s" in text and "share = 0" in text and "share = 0 1" not in text
    # in a discovery verdict a held parameter says it was not fitted
    held = lp.replace("pressure_lag.share", fixed=True)
    assert "share = 0 (held, not fitted)" in lag.describe(held, mark_held=True) and "held" not in text
    assert "tau = 0.2 s (held" not in lag.describe(held, mark_held=True)
    # one the data did not determine (a refit held it) says that instead: it was fitted, then held
    undetermined = lp.replace("pressure_lag.sat", fixed=True, note="not identifiable: relative standard error 537% > 50%")
    assert "sat = 0 1/kPa (held: the data did not determine it)" in lag.describe(undetermined, mark_held=True)


# --------------------------------------------------------------------------------------------------
# the flow-limited fill (pressure_lag.sat): an orifice's flow grows as the square root of the difference
# --------------------------------------------------------------------------------------------------
def test_flow_limited_lag_with_sat_zero_is_the_first_order_lag_and_a_large_step_fills_at_a_limited_rate():
    t, p = triangle_log(fs=50.0, cycles=1)
    assert np.array_equal(K.flow_lag(t, p, 0.2, 0.0), K.lag(t, p, 0.2))
    ts = np.arange(0.0, 5.0, 0.01)
    for sat in (1e-4, 1e-3):
        small = K.flow_lag(ts, np.where(ts > 0.5, 1e3, 0.0), 0.1, sat) / 1e3      # a 1 kPa step
        large = K.flow_lag(ts, np.where(ts > 0.5, 1e5, 0.0), 0.1, sat) / 1e5      # a 1 bar step
        for y in (small, large):   # no overshoot, monotone, settles at the input
            assert np.all(np.diff(y) >= -1e-12) and y.max() <= 1.0 + 1e-12 and y[-1] > 0.999
        rise = lambda y: ts[np.argmax(y >= 1.0 - np.exp(-1.0))] - 0.5   # noqa: E731
        assert rise(large) > 2.0 * rise(small)          # the large step takes longer: the flow is limited
    assert abs(rise(K.lag(ts, np.where(ts > 0.5, 1.0, 0.0), 0.1)) - 0.1) < 0.011   # the linear lag: tau


def test_flow_limited_lag_is_refused_by_the_closed_loop_and_the_c_export_naming_what_to_do():
    from bpmid.export.c import causal_vbmm

    lag, lp = build_effect("pressure_lag", {"tau": 0.2, "sat": 1.0})
    aug = AugmentedVBMM(VBMM(), (lag,), lp)
    with pytest.raises(InputError, match="pressure_lag changes the pressure in a way the closed loop cannot step"):
        causal_terms(aug, np.arange(0.0, 1.0, 0.1))
    with pytest.raises(InputError) as e:
        causal_vbmm(aug)
    assert e.value.key == "effects[0].parameters.sat" and "pressure_lag.sat: 0" in str(e.value)
    lin, lp0 = build_effect("pressure_lag", {"tau": 0.2, "sat": 0.0})   # a linear fill exports as before
    assert [op for op, _v in causal_vbmm(AugmentedVBMM(VBMM(), (lin,), lp0)).chain] == ["lag"]


def test_refit_recovers_a_flow_limited_fill():
    truth = {"pressure_lag.tau": 0.3, "pressure_lag.sat": 0.5}
    ps, res = _recover("pressure_lag", truth, {"pressure_lag.tau": 0.1, "pressure_lag.sat": 0.1}, seed=6,
                       held=("pressure_lag.share",))
    assert ps.value("pressure_lag.tau") == pytest.approx(0.3, rel=0.15)
    assert ps.value("pressure_lag.sat") == pytest.approx(0.5, rel=0.3)
    assert res.rmse < 0.06
