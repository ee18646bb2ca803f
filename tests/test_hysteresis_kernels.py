"""Properties of the compiled hysteresis kernels (play/stop operators, Maxwell-slip elements)."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from bpmid.models._hysteresis_kernels import direction_with_deadband, first_order_ramp, play_bank, stop_bank
from bpmid.models.gpi import GPIModel
from bpmid.models.maxwell_slip import MaxwellSlipModel

TABLE1_K = np.array([10.0, 7.5, 1.6, 0.9])  # seed 003 Table 1 / EXPERIMENTS.md
TABLE1_W = np.array([0.05, 0.075, 0.056, 0.081])

turning = st.lists(st.floats(-2.0, 2.0, allow_nan=False), min_size=2, max_size=8)
thresholds = st.lists(st.floats(0.0, 1.0, allow_nan=False), min_size=1, max_size=4)


def path(points, per_segment):
    """Piecewise-linear input through the turning points, ``per_segment`` samples per segment."""
    segs = [np.linspace(a, b, per_segment + 1)[:-1] for a, b in zip(points[:-1], points[1:])]
    return np.concatenate(segs + [np.array([points[-1]])])


def tanh_env(v, amp, slope, shift, offset=0.0):
    return amp * np.tanh(slope * v + shift) + offset


@settings(max_examples=40, deadline=None)
@given(turning, thresholds, st.integers(1, 6), st.integers(2, 5),
       st.floats(0.5, 2.0), st.floats(0.3, 1.5), st.floats(-0.3, 0.3))
def test_play_operator_is_rate_independent(points, r, n1, factor, amp, slope, offset):
    # the same input path sampled at two rates: the coarse samples are a subset of the fine ones
    r = np.array(r)
    coarse, fine = path(points, n1), path(points, n1 * factor)
    outs = []
    for u in (coarse, fine):
        gl, gr = tanh_env(u, amp, slope, 0.0), tanh_env(u, amp, slope * 0.8, 0.1, offset)
        outs.append(play_bank(gl, gr, r, np.zeros(r.size)))
    np.testing.assert_allclose(outs[1][::factor], outs[0], rtol=0, atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-3.0, 3.0, allow_nan=False), min_size=2, max_size=200), thresholds,
       st.floats(0.5, 2.0), st.floats(0.3, 1.5))
def test_play_output_stays_in_band(u, r, amp, slope):
    u, r = np.array(u), np.array(r)
    gl, gr = tanh_env(u, amp, slope, 0.0), tanh_env(u, amp, slope, 0.0, 0.05)
    z = play_bank(gl, gr, r, np.full(r.size, 10.0))  # even from a state far outside
    assert np.all(z >= gl[:, None] - r - 1e-12)
    assert np.all(z <= gr[:, None] + r + 1e-12)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-2.0, 2.0, allow_nan=False), min_size=1, max_size=5),
       st.floats(-1.0, 0.0), st.floats(0.0, 0.5), st.floats(0.1, 0.5), st.floats(0.05, 0.5), thresholds)
def test_wiping_out_of_inner_loops(history, x0, dm, dM, dM2, r):
    # from a minimum x0: up to M1, down to m1 >= x0, up to M2 > M1. Passing M1 wipes out (M1, m1):
    # the state at M2 equals the one reached by going from x0 straight to M2.
    m1 = x0 + dm
    M1 = m1 + dM
    M2 = M1 + dM2
    pre = list(history) + [x0]
    r = np.array(r)
    with_loop = path(pre + [M1, m1, M2], 7)
    without = path(pre + [M2], 7)
    for bank in ("play", "stop"):
        if bank == "play":
            a = play_bank(np.tanh(with_loop), np.tanh(with_loop) + 0.1, r, np.zeros(r.size))[-1]
            b = play_bank(np.tanh(without), np.tanh(without) + 0.1, r, np.zeros(r.size))[-1]
        else:
            a = stop_bank(with_loop, r, np.zeros(r.size))[-1]
            b = stop_bank(without, r, np.zeros(r.size))[-1]
        np.testing.assert_allclose(a, b, atol=1e-12)


def test_classical_pi_special_case():
    # identity envelopes: the textbook play operator, and closed-form values on a simple path
    model = GPIModel(n_operators=3, envelope="identity", orientation="lag")
    p = model.default_params().with_values({"p0": 2.0, "c": 1.0, "w1": 0.5, "w2": 0.3, "w3": 0.2,
                                            "r1": 0.1, "r2": 0.3, "r3": 0.6})
    u = path([0.0, 1.0, 0.5, 0.8], 50)
    y = model.simulate_arrays(p, u)
    r, w = np.array([0.1, 0.3, 0.6]), np.array([0.5, 0.3, 0.2])
    z, ref = np.zeros(3), []
    for uk in u:  # F_r[u](k) = max(u - r, min(u + r, F_r[u](k-1)))
        z = np.maximum(uk - r, np.minimum(uk + r, z))
        ref.append(2.0 * uk + 1.0 + w @ z)
    np.testing.assert_allclose(y, ref, atol=1e-12)
    # at the top of the first rise (u = 1): each operator sits at 1 - r
    top = 50
    np.testing.assert_allclose(y[top], 2.0 + 1.0 + w @ (1.0 - r), atol=1e-12)
    # after falling by 0.5: operators with 2 r >= 0.5 have not moved, the others follow u + r
    z_fall = np.where(2 * r >= 0.5, 1.0 - r, 0.5 + r)
    np.testing.assert_allclose(y[100], 2.0 * 0.5 + 1.0 + w @ z_fall, atol=1e-12)


def test_maxwell_slip_table1_elements_saturate_at_w():
    slip = TABLE1_W / TABLE1_K
    np.testing.assert_allclose(slip, [0.005, 0.01, 0.035, 0.09])
    u = path([0.0, 0.3, -0.3, 0.3], 600)
    d = stop_bank(u, slip, np.zeros(4))
    force = d * TABLE1_K
    # element forces never exceed their saturation value and reach it on long strokes
    assert np.all(np.abs(force) <= TABLE1_W + 1e-12)
    np.testing.assert_allclose(force[600], TABLE1_W)      # end of the first rise: all slip forward
    np.testing.assert_allclose(force[1200], -TABLE1_W)    # end of the fall: all slip backward
    # the virgin curve: F(x) = sum k_i min(x, D_i) with x the travel from the relaxed start
    x = u[:601]
    virgin = np.minimum(x[:, None], slip) @ TABLE1_K
    np.testing.assert_allclose(force[:601].sum(axis=1), virgin, atol=1e-12)


def test_maxwell_slip_virgin_method_recovers_table1():
    u = path([0.0, 0.4, 0.0, 0.4, 0.1, 0.3], 400)
    model = MaxwellSlipModel(n_elements=4, poly_degree=1, method="virgin")
    truth = model.default_params().with_values({"s0": 0.3, "s1": 2.0, **dict(zip(model.stiffness_names, TABLE1_K)),
                                                **dict(zip(model.slip_names, TABLE1_W / TABLE1_K))})
    res = model.fit_arrays([u], [model.simulate_arrays(truth, u)])
    tab = model.element_table(res.params)
    np.testing.assert_allclose(tab["k"], TABLE1_K, rtol=1e-3)
    np.testing.assert_allclose(tab["w"], TABLE1_W, rtol=1e-3)


def test_first_order_ramp_matches_analytic_step():
    # constant coefficients and input: y = y_eq + (y0 - y_eq) exp(-t/tau), for any (even huge) step
    t = np.linspace(0, 5, 11)
    tau, y_eq = 0.7, 3.0
    y = first_order_ramp(np.full(t.size, y_eq), np.diff(t, prepend=0) / tau, 0.0)
    np.testing.assert_allclose(y, y_eq * (1 - np.exp(-t / tau)), atol=1e-12)


def test_direction_dead_band_ignores_noise():
    rng = np.random.default_rng(3)
    u = np.concatenate([np.linspace(0, 1, 100), np.full(100, 1.0), np.linspace(1, 0, 100)])
    d = direction_with_deadband(u + rng.normal(0, 1e-3, u.size), 0.01)
    assert np.all(d[:200] > 0)   # the noisy hold does not flip it
    assert np.all(d[215:] < 0)   # the fall does, within the dead band


def test_first_order_ramp_is_exact_for_a_linear_input_and_unbiased_in_time():
    """A ramp input e = s t through T y' + y = e: y = s (t - T) + s T exp(-t/T) exactly, for any step; holding the
    input at each step's end sample instead leads it by about half a sample."""
    T, s = 0.4, 3.0
    for dt in (0.01, 0.1, 1.0):
        t = np.arange(0.0, 6.0, dt)
        exact = s * (t - T) + s * T * np.exp(-t / T)
        y = first_order_ramp(s * t, np.full(t.size, dt / T), 0.0)
        np.testing.assert_allclose(y, exact, atol=1e-12)
        held = np.zeros(t.size)   # the input held at each step's end sample
        for k in range(1, t.size):
            held[k] = s * t[k] + (held[k - 1] - s * t[k]) * np.exp(-dt / T)
        lead = np.mean(held[t > 3] - exact[t > 3]) / s          # time by which the held output leads
        assert lead > 0.25 * dt                                  # 0.5 dt for small steps
    # no time passing keeps the output; a very fast element follows its equilibrium
    y = first_order_ramp(np.array([0.0, 5.0]), np.array([0.0, 0.0]), 1.0)
    assert y[1] == 1.0
    y = first_order_ramp(np.array([0.0, 5.0]), np.array([0.0, 800.0]), 1.0)
    assert y[1] == pytest.approx(5.0, abs=1e-2)
