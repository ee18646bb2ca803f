"""Properties of the VBMM kernels (VBMM.md sections 3-5), checked on random histories.

- inverse(forward(P)) returns P (closed-form inverse and compiled forward solve agree), every history mode
- recursive history equals the full sum of eq. (5) on uneven sampling, several branches, split time
  constants, both closures
- sliding window (20 s) equals full history on the paper's 1800 s experiment 2 (slow)
- sliding window on a log many windows long: forward and inverse agree; hereditary_window is eq. (19) as
  written in a plain-Python reference here; dropping the old history instead of lumping it is far off
"""
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bpmid.models.vbmm import VBMM, Material, triangle_pressure

SETTINGS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@st.composite
def materials(draw):
    """1-3 branches, shared or split time constants, moduli around the paper's (Pa, s)."""
    m = draw(st.integers(1, 3))
    split = draw(st.booleans())
    G_inf = draw(st.floats(2e3, 5e4))
    K_inf = draw(st.floats(2e6, 2e7))
    G = tuple(draw(st.floats(0.0, 5e4)) for _ in range(m))
    K = tuple(draw(st.floats(0.0, 2e7)) for _ in range(m))
    tauG = tuple(draw(st.floats(0.05, 20.0)) for _ in range(m))
    tauK = tuple(draw(st.floats(0.05, 20.0)) for _ in range(m)) if split else None
    return Material(G_inf, K_inf, G, K, tauG, tauK)


@st.composite
def pressure_logs(draw, n_max=150):
    """Uneven sampling (steps 0.01-0.3 s) and a smooth random gauge pressure 0.2-1.2 bar (Pa)."""
    n = draw(st.integers(5, n_max))
    seed = draw(st.integers(0, 2**31 - 1))
    rng = np.random.default_rng(seed)
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(0.01, 0.3, n - 1))])
    # a random walk in pressure, kept in range: rising and falling stretches
    steps = rng.normal(0.0, 0.04e5, n)
    p = np.clip(0.6e5 + np.cumsum(steps), 0.2e5, 1.2e5)
    return t, p


@SETTINGS
@given(mat=materials(), log=pressure_logs(), closure=st.sampled_from(["paper", "consistent"]),
       history=st.sampled_from(["recursive", "window", "full"]))
def test_inverse_of_forward_returns_pressure(mat, log, closure, history):
    t, p = log
    model = VBMM(material=mat, closure=closure, history=history, window_s=2.0)
    out = model.forward_full(t, p)
    beta = out["beta"]
    assert np.all(out["status"] == 0)
    assert np.all(beta > 0)  # every pressure above the zero-angle one: the inverse is defined
    p_back = model.inverse(t, beta)
    np.testing.assert_allclose(p_back, p, rtol=1e-6, atol=0)


@SETTINGS
@given(mat=materials(), log=pressure_logs(n_max=300), closure=st.sampled_from(["paper", "consistent"]))
def test_recursive_equals_full_history(mat, log, closure):
    t, p = log
    rec = VBMM(material=mat, closure=closure, history="recursive").forward(t, p)
    full = VBMM(material=mat, closure=closure, history="full").forward(t, p)
    assert np.max(np.abs(rec - full)) <= 1e-9


def test_recursive_equals_full_even_sampling_paper_log():
    t = np.round(np.arange(0.0, 60.0, 0.1), 10)
    p = (triangle_pressure(t, 1.2, 2.0, 0.2) - 1.01325) * 1e5
    mat = Material(9e3, 6e6, (2e4, 5e3), (1.3e7, 4e6), (0.2, 3.0), (0.3, 8.0))
    rec = VBMM(material=mat, history="recursive").forward(t, p)
    full = VBMM(material=mat, history="full").forward(t, p)
    assert np.max(np.abs(rec - full)) <= 1e-9


def test_window_lumps_old_history():
    """The window differs from the full sum when a branch is slow compared to T_win, and equals it for T_win
    beyond the log's length (no lumping)."""
    t = np.round(np.arange(0.0, 40.0, 0.1), 10)
    p = (triangle_pressure(t, 1.2, 2.0, 0.2) - 1.01325) * 1e5
    mat = Material(9e3, 6e6, (2e4,), (1.3e7,), (30.0,))
    full = VBMM(material=mat, history="full").forward(t, p)
    short = VBMM(material=mat, history="window", window_s=5.0).forward(t, p)
    long = VBMM(material=mat, history="window", window_s=100.0).forward(t, p)
    assert np.max(np.abs(long - full)) <= 1e-12
    assert np.degrees(np.max(np.abs(short - full))) > 0.01


def experiment2_log():
    """Paper experiment 2: 60 repetitions of the variable-amplitude sequence (triangles 1.2-1.8, 2.0, 2.2 bar
    absolute at 0.2 bar/s), 10 Hz; 30 s per repetition, 1800 s in all. Returns t (s), gauge p (Pa)."""
    t = np.round(np.arange(0.0, 1800.0, 0.1), 10)
    ph = np.mod(t, 30.0)
    p_abs = np.where(ph < 6.0, triangle_pressure(ph, 1.2, 1.8, 0.2),
                     np.where(ph < 14.0, triangle_pressure(ph - 6.0, 1.2, 2.0, 0.2),
                              triangle_pressure(ph - 14.0, 1.2, 2.2, 0.2)))
    return t, (p_abs - 1.01325) * 1e5


@pytest.mark.slow
def test_window_matches_full_on_1800_s_log():
    t, p = experiment2_log()
    assert t.size == 18000
    full = VBMM(history="full").forward_deg(t, p)
    window = VBMM(history="window", window_s=20.0).forward_deg(t, p)
    rec = VBMM(history="recursive").forward_deg(t, p)
    assert np.max(np.abs(window - full)) <= 1e-3
    assert np.max(np.abs(np.radians(rec - full))) <= 1e-9
    assert 14.0 < full.min() and full.max() < 90.0  # the paper's range of angles


# ------------------------------------------------------------------------------------------------
# sliding window (eq. 19) on a log many windows long: deterministic
# ------------------------------------------------------------------------------------------------
WIN_MAT = Material(9e3, 6e6, (2e4, 5e3), (1.3e7, 4e6), (0.4, 30.0))  # one branch far slower than T_win


def window_log():
    """60 s at exactly 10 Hz (t_k = k / 10, so ages of T_win = 2 s or 5 s land on T_win to rounding, on
    both sides of it), a varying gauge pressure: triangles of changing height plus a slow sine (Pa)."""
    t = np.arange(600) / 10.0
    p_abs = triangle_pressure(t, 1.2, 1.7, 0.2) + 0.15 * np.sin(2 * np.pi * t / 23.0) + 0.1
    return t, (p_abs - 1.01325) * 1e5


def window_reference(t, x, M_inf, M, tau, T_win, lump=True):
    """VBMM.md eq. (19) written out: increments older than T_win are lumped as M(t_k - t_s) (x_s - x_0), s the
    last sample at least T_win old (an age within 1e-9 T_win of T_win counts as T_win); the younger ones as in
    eq. (5), M(t_k - t_i) (x_i - x_{i-1}). ``lump=False``: the old increments are simply dropped."""
    def kernel(age):
        return M_inf + sum(m * math.exp(-age / tj) for m, tj in zip(M, tau))

    out = []
    for k in range(len(t)):
        old = [i for i in range(k + 1) if t[k] - t[i] >= T_win * (1 - 1e-9)]
        s = old[-1] if old else 0
        acc = M_inf * x[0] + (kernel(t[k] - t[s]) * (x[s] - x[0]) if lump else 0.0)
        for i in range(s + 1, k + 1):
            acc += kernel(t[k] - t[i]) * (x[i] - x[i - 1])
        out.append(acc)
    return np.array(out)


def test_window_inverse_of_forward_returns_pressure_on_a_long_log():
    """The compiled forward kernel (_history_consts_sum) and the inverse (viscoelastic.hereditary_window, a
    separate implementation) lump the same history."""
    t, p = window_log()
    model = VBMM(material=WIN_MAT, history="window", window_s=5.0)
    beta = model.forward(t, p)
    assert np.all(beta > 0)
    np.testing.assert_allclose(model.inverse(t, beta), p, rtol=1e-6, atol=0)


def test_hereditary_window_is_eq_19():
    from bpmid.viscoelastic import hereditary_window

    t = np.arange(300) / 10.0
    age = t[:, None] - t[None, :]
    age = age[np.abs(age - 2.0) < 1e-9]
    # on this grid ages of T_win = 2 s fall below, on and above 2.0 in floating point: the comparison matters
    assert (age < 2.0).any() and (age == 2.0).any() and (age > 2.0).any()
    x = VBMM(material=WIN_MAT).forward(t, window_log()[1][:300])  # a strain-like history: the angle (rad)
    M_inf, M, tau = WIN_MAT.G_inf, WIN_MAT.G, WIN_MAT.tauG
    got = hereditary_window(t, x, M_inf, M, tau, 2.0)
    want = window_reference(t, x, M_inf, M, tau, 2.0)
    scale = np.max(np.abs(want))
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * scale)
    # the lumped old history is not negligible: simply dropping it is far off
    dropped = window_reference(t, x, M_inf, M, tau, 2.0, lump=False)
    assert np.max(np.abs(got - dropped)) > 0.1 * scale


def test_the_model_refuses_falling_times_non_finite_samples_and_a_geometry_in_mm():
    """bpmid.VBMM computed silently on these before: falling times ran, a negative or millimetre geometry gave a
    constant 4 pi rad, a NaN pressure stopped with 'did not converge', a NaN angle gave NaN pressures."""
    import bpmid
    from bpmid.errors import InputError

    m = bpmid.VBMM()
    t = np.arange(0.0, 10.0, 0.1)
    p = np.full(t.size, 4e4)
    with pytest.raises(InputError, match="time must rise strictly: sample 1 at t = 9.8 s after 9.9 s"):
        m.forward(t[::-1], p)
    with pytest.raises(InputError, match="sample 51 is not finite") as e:
        m.forward(t, np.where(t > 5.05, np.nan, p))
    assert e.value.key == "p_gauge_pa"
    with pytest.raises(InputError, match="sample 51 is not finite"):
        m.inverse(t, np.where(t > 5.05, np.nan, 0.3))
    with pytest.raises(InputError, match="must be positive") as e:
        bpmid.VBMM(geometry=bpmid.Geometry(th=-1.0))
    assert e.value.key == "model.geometry.th"
    with pytest.raises(InputError, match="look like millimetres"):
        bpmid.VBMM(geometry=bpmid.Geometry(th=2.0, R0=16.73, l0=195.9))
    assert np.all(np.isfinite(m.forward(t, p)))   # a good log still runs
