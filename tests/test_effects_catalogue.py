"""The catalogue effects: exact null values, kernel properties, and each effect's signature in simulated
logs against the no-effect twin (the "where it shows" column of DISCOVER.md)."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from bpmid.effects import CATALOGUE, get_effect
from bpmid.effects import _kernels as K
from bpmid.effects.base import AugmentedVBMM
from bpmid.errors import InputError
from bpmid.models.vbmm import VBMM, triangle_pressure
from bpmid.twin.simulate import build_effect

ATM = 101325.0
BASE = VBMM()


def triangle(lo_bar, hi_bar, rate_bar_s, cycles, fs=10.0, hold_s=0.0):
    period = 2 * (hi_bar - lo_bar) / rate_bar_s
    t = np.arange(int(round((cycles * period + hold_s) * fs)) + 1) / fs
    p = np.where(t <= cycles * period, triangle_pressure(t, lo_bar, hi_bar, rate_bar_s), lo_bar)
    return t, p * 1e5 - ATM


def sim(eid, t, p, **values):
    if eid is None:
        return BASE.forward_deg(t, p)
    effect, params = build_effect(eid, values)
    return AugmentedVBMM(BASE, (effect,), params).simulate_deg(t, p)


def loop_width(t, p, beta, level_pa, last_cycle_from):
    """Falling minus rising angle at ``level_pa`` within the last cycle (deg)."""
    sel = t >= last_cycle_from
    pp, bb = p[sel], beta[sel]
    k = int(np.argmax(pp))
    up = np.interp(level_pa, pp[:k + 1], bb[:k + 1])
    down = np.interp(level_pa, pp[k:][::-1], bb[k:][::-1])
    return down - up


# -- null values ----------------------------------------------------------------------------------
@pytest.mark.parametrize("eid,settings_", [(e, {}) for e in CATALOGUE] + [("braid_friction", {"elements": 4}),
                                                                         ("pressure_lag", {"dead_time": 0.0})])
def test_null_values_give_the_plain_vbmm_exactly(eid, settings_):
    t, p = triangle(1.2, 2.0, 0.2, 2, hold_s=10)
    effect = get_effect(eid, **settings_)
    params = effect.default_params().with_values(effect.null_values())
    got = AugmentedVBMM(BASE, (effect,), params).simulate_deg(t, p)
    assert np.array_equal(got, BASE.forward_deg(t, p))
    # and the default (moderate) size does change the output
    assert not np.allclose(AugmentedVBMM(BASE, (effect,), effect.default_params()).simulate_deg(t, p), got)


@pytest.mark.parametrize("eid", list(CATALOGUE))
def test_every_effect_documents_its_parameters(eid):
    effect = get_effect(eid)
    assert effect.meaning and effect.where_it_shows and effect.__doc__
    for prm in effect.default_params():
        assert prm.name.startswith(eid + ".") and prm.unit and prm.lower <= prm.value <= prm.upper
    for name, v in effect.null_values().items():
        prm = effect.default_params()[name]
        assert prm.lower <= v <= prm.upper


# -- kernels --------------------------------------------------------------------------------------
@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-1e5, 1e5), min_size=2, max_size=60), st.floats(0, 5e4))
def test_play_operator_stays_in_its_band_and_ignores_timing(xs, r):
    x = np.array(xs)
    y = K.play(x, r)
    assert np.all(np.abs(y - x) <= r * (1 + 1e-12) + 1e-9)
    # rate independence: repeating every sample (a slower input) gives the same values
    y2 = K.play(np.repeat(x, 3), r)
    assert np.allclose(y2[2::3], y)


def test_lag_kernel_is_exact_for_ramps_and_uneven_sampling():
    tau, m = 0.3, 2.0
    t = np.cumsum(np.r_[0.0, np.random.default_rng(1).uniform(0.01, 0.3, 80)])
    y = K.lag(t, m * t, tau)
    # steady start at 0; exact response of tau y' = m t - y, y(0) = 0
    exact = m * (t - tau * (1 - np.exp(-t / tau)))
    assert np.allclose(y, exact, atol=1e-12)
    assert np.array_equal(K.lag(t, m * t, 0.0), m * t)


def test_delay_kernel_shifts_a_ramp():
    t = np.arange(100) / 10.0
    y = K.delay(t, 3.0 * t, 0.25)
    assert np.allclose(y[5:], 3.0 * (t[5:] - 0.25))
    assert np.all(y[:3] == 0.0)


def test_bad_effect_values_are_refused_with_their_key():
    with pytest.raises(InputError, match="braid_friction.elements"):
        build_effect("braid_friction", {"elements": 0})
    with pytest.raises(InputError, match="pressure_lag.tua"):
        build_effect("pressure_lag", {"tua": 0.1})
    with pytest.raises(InputError, match="pressure_lag.tau"):
        build_effect("pressure_lag", {"tau": -1.0})
    with pytest.raises(InputError, match="unknown effect id"):
        build_effect("backlash", {})


# -- signatures against the no-effect twin --------------------------------------------------------
def extra_loop(eid, rate, **values):
    """Loop width added by the effect at 1.6 bar, last of three cycles 1.2-2.0 bar."""
    t, p = triangle(1.2, 2.0, rate, 3, fs=max(10.0, 40 * rate))
    period = 2 * 0.8 / rate
    lvl = 1.6e5 - ATM
    return (loop_width(t, p, sim(eid, t, p, **values), lvl, 2 * period)
            - loop_width(t, p, sim(None, t, p), lvl, 2 * period))


def test_pressure_lag_widens_loops_more_at_faster_rates():
    # over the rates a rig runs (the paper's 0.114-0.267 bar/s inside)
    widen = [extra_loop("pressure_lag", r, dead_time=0.1) for r in (0.02, 0.1, 0.3)]
    assert 0 < widen[0] < widen[1] < widen[2]
    assert widen[2] > 5 * widen[0]


def test_braid_friction_leaves_a_loop_that_does_not_vanish_at_slow_rates():
    widths = {}
    for rate in (0.002, 0.0005):  # quasi-static: 800 and 3200 s per cycle
        t, p = triangle(1.2, 2.0, rate, 2, fs=2.0)
        start = 1.6 / rate
        lvl = 1.6e5 - ATM
        widths[rate] = (loop_width(t, p, sim(None, t, p), lvl, start),
                        loop_width(t, p, sim("braid_friction", t, p, elements=4), lvl, start))
    (plain_fast, fric_fast), (plain_slow, fric_slow) = widths[0.002], widths[0.0005]
    assert plain_slow < 0.1 and plain_slow < 0.3 * plain_fast    # the viscoelastic loop goes with the rate
    assert fric_slow > 3.0 and fric_slow > 0.85 * fric_fast       # the friction loop does not
    # and it is about the same at the paper's rate: rate-independent
    assert extra_loop("braid_friction", 0.2, elements=4) == pytest.approx(fric_slow - plain_slow, rel=0.3)


def test_thermal_softening_drifts_with_elapsed_time():
    t, p = triangle(1.2, 2.0, 0.2, 60)  # 480 s of identical cycles
    d = sim("thermal_softening", t, p) - sim(None, t, p)
    period = 80  # samples
    peaks = [d[k * period + 40] for k in range(60)]
    assert peaks[0] < 0.1 < peaks[10] < peaks[30] < peaks[59]
    assert np.all(np.diff(peaks) > 0)


def test_second_relaxation_creeps_after_the_first_time_constant():
    t = np.arange(0, 60.01, 0.1)
    p = np.where(t < 2.0, 1.2e5 + 0.4e5 * t, 2.0e5) - ATM
    plain, slow = sim(None, t, p), sim("second_relaxation", t, p)
    i3, iend = np.searchsorted(t, 2.0 + 30 * 0.213), -1   # thirty first time constants into the hold
    assert plain[iend] - plain[i3] < 0.01
    assert slow[iend] - slow[i3] > 2.0


def test_asymmetric_relaxation_shows_only_once_the_pressure_falls():
    t, p = triangle(1.2, 2.0, 0.2, 2)
    d = sim("asymmetric_relaxation", t, p) - sim(None, t, p)
    rising = t <= 4.0
    assert np.all(d[rising] == 0.0)
    assert np.max(np.abs(d[(t > 4.0) & (t <= 8.0)])) > 1.0


def _steps_and_holds(fs=20.0):
    """Gauge pressure (Pa): 1.2 bar absolute, a step to 2.2 bar, held 12 s, a step back, held 12 s."""
    t = np.arange(0.0, 30.0, 1.0 / fs)
    pa = np.where((t >= 2.0) & (t < 14.0), 2.2, 1.2) * 1e5 - 101325.0
    return t, pa


def test_asymmetric_relaxation_switches_on_the_angle_so_the_transient_after_a_step_down_runs_at_its_rate():
    """Seed 004 measures the deflation rate on the transient after a pressure step down, at constant pressure:
    the falling rate applies while the angle falls, so the forward model and the inverse (which reads the
    direction from the angle) agree through the holds, and the relaxation after the step down runs fall_ratio
    times faster."""
    t, p = _steps_and_holds()
    m = BASE.replace(fall_ratio=0.25)
    beta = m.forward(t, p)
    assert m.inverse(t, beta) == pytest.approx(p, abs=0.05)            # Pa: the inverse gives the pressure back
    after = (t > 14.0)
    assert np.all(np.diff(beta[after]) <= 1e-12)                       # the angle falls through the hold
    # the slow part of the transient (the branch relaxing) decays four times faster than the plain model's
    plain = BASE.forward(t, p)
    def settle(b):   # time after the step for the angle to come within 1 % of its final fall
        rest = b[after] - b[-1]
        return t[after][np.argmax(np.abs(rest) <= 0.01 * np.abs(rest[0]))] - 14.0
    assert settle(beta) < 0.5 * settle(plain)


def test_asymmetric_relaxation_is_not_switched_by_the_logged_pressures_noise_while_it_is_held():
    """A logged pressure's noise (20 Pa) while held changes the angle by about the noise's own effect, not by a
    rate switched at random on every step the noisy pressure happens to fall."""
    t, p = _steps_and_holds()
    noisy = p + np.random.default_rng(4).normal(0.0, 20.0, t.size)
    m = BASE.replace(fall_ratio=0.25)
    d_asym = np.degrees(m.forward(t, noisy) - m.forward(t, p))
    d_plain = np.degrees(BASE.forward(t, noisy) - BASE.forward(t, p))
    assert np.sqrt(np.mean(d_asym**2)) < 2.0 * np.sqrt(np.mean(d_plain**2)) + 1e-4


def test_strain_stiffening_grows_with_amplitude_and_lowers_peaks():
    diffs = []
    for hi in (1.8, 2.0, 2.2):
        t, p = triangle(1.2, hi, 0.2, 1)
        d = sim("strain_stiffening", t, p) - sim(None, t, p)
        diffs.append(d[np.argmax(p)])
    assert diffs[0] < 0 and diffs[2] < diffs[1] < diffs[0]


def test_angle_offset_is_a_constant():
    t, p = triangle(1.2, 2.0, 0.2, 2)
    d = sim("angle_offset", t, p, offset=1.5) - sim(None, t, p)
    assert np.allclose(d, 1.5)


def test_braid_friction_elements_spread_the_slip_limits_around_the_same_mean():
    e = get_effect("braid_friction", elements=4)
    r = e.radii(1000.0)
    assert r.mean() == pytest.approx(1000.0) and r.min() > 0 and r.max() < 2000.0
    assert list(get_effect("braid_friction").radii(1000.0)) == [1000.0]


@pytest.mark.parametrize("eid", list(CATALOGUE))
def test_signature_columns_have_one_row_per_sample(eid):
    from bpmid.io.motion_logs import from_arrays

    t, p = triangle(1.2, 2.0, 0.2, 2)
    log = from_arrays("x", t, p, sim(None, t, p))
    cols = get_effect(eid).signature_columns(log, sim(None, t, p))
    assert cols.shape[0] == t.size and cols.shape[1] >= 1 and np.all(np.isfinite(cols))
    # a signature says something on a typical triangle log: no column is zero, or zero but for a few samples
    for j in range(cols.shape[1]):
        c = cols[:, j]
        assert np.max(np.abs(c)) > 0 and np.mean(c != 0) > 0.25, (eid, j)
        if eid in CONSTANT_SIGNATURE:
            assert np.ptp(c) == 0, (eid, j)
        else:  # it varies along the log, or it could not be told from a constant offset
            assert np.std(c) > 1e-2 * np.max(np.abs(c)), (eid, j, np.std(c))


#: effects whose signature is a constant by design (DISCOVER.md: "constant residual component")
CONSTANT_SIGNATURE = {"angle_offset"}


# -- the cached model and material arrays a fit reuses -------------------------------------------
def test_augmented_model_is_made_once_and_gives_what_a_fresh_one_gives():
    effect, params = build_effect("second_relaxation", {"weight": 0.3, "tau": 8.0})
    aug = AugmentedVBMM(BASE, (effect,), params)
    assert aug.model() is aug.model()                     # one model for every log of an evaluation
    assert aug.model().material.n_branches == BASE.material.n_branches + 1
    t, p = triangle(1.2, 2.0, 0.2, 2)
    fresh = AugmentedVBMM(BASE, (effect,), params)
    np.testing.assert_array_equal(aug.simulate_deg(t, p), fresh.simulate_deg(t, p))
    np.testing.assert_array_equal(aug.simulate_deg(t, p), aug.model().forward_deg(t, p))


def test_material_arrays_are_its_constants_and_shared_tau_is_tauG():
    m = BASE.material
    G, tauG, Kb, tauK = m.arrays
    assert m.arrays is m.arrays
    np.testing.assert_array_equal(G, m.G)
    np.testing.assert_array_equal(Kb, m.K)
    np.testing.assert_array_equal(tauG, m.tauG)
    np.testing.assert_array_equal(tauK, m.tauG)   # shared time constants (tauK None)
    split = m.__class__(m.G_inf, m.K_inf, m.G, m.K, m.tauG, tuple(2 * v for v in m.tauG))
    np.testing.assert_array_equal(split.arrays[3], 2 * np.asarray(m.tauG))
