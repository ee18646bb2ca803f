"""One set of operator kernels: the closed loop's causal pressure chain (control_kernels.pressure_chain) runs
the same one-step kernels as the whole-signal operators of the effects catalogue, so the two agree bit for bit."""
import numpy as np

from bpmid import control_kernels as CK
from bpmid.effects import _kernels as K


def test_causal_chain_equals_the_whole_signal_operators_exactly():
    rng = np.random.default_rng(11)
    n = 1500
    t = np.concatenate(([0.0], np.cumsum(rng.uniform(0.004, 0.03, n - 1))))  # uneven sampling, s
    p = 4e4 + np.cumsum(rng.normal(0.0, 400.0, n))                          # gauge Pa
    ops = np.array([CK.OP_DELAY, CK.OP_LAG, CK.OP_PLAYS], np.int64)
    par = np.array([[0.07], [0.25], [1500.0]])                                # dead time s, tau s, half-width Pa
    cnt = np.ones(3, np.int64)
    hist, y, j, play = np.zeros((3, n)), np.zeros(3), np.zeros(3, np.int64), np.zeros(par.shape)
    stepped = np.array([CK.pressure_chain(k, t, p[k], ops, par, cnt, hist, y, j, play) for k in range(n)])
    whole = K.play(K.lag(t, K.delay(t, p, 0.07), 0.25), 1500.0)
    assert np.array_equal(stepped, whole)
    # and each operator does something on this signal (the test cannot pass on identities)
    assert not np.array_equal(K.delay(t, p, 0.07), p) and not np.array_equal(K.lag(t, p, 0.25), p)
    assert not np.array_equal(K.play(p, 1500.0), p)


def test_one_step_kernels_match_their_definitions():
    assert K.play_step(0.0, 5.0, 2.0) == 3.0 and K.play_step(4.0, 5.0, 2.0) == 4.0 and K.play_step(9.0, 5.0, 2.0) == 7.0
    a = np.exp(-0.1 / 0.5)
    assert K.lag_step(1.0, 2.0, 2.0, 0.1, 0.5) == a * 1.0 + (1.0 - a) * 2.0  # a constant input: y relaxes to it
    t = np.array([0.0, 1.0, 2.0])
    x = np.array([0.0, 10.0, 30.0])
    assert K.delay_step(t, x, 2, 1.5, 0) == (20.0, 1)
    assert K.delay_step(t, x, 2, -1.0, 0) == (0.0, 0)
    assert K.delay_step(t, x, 1, 1.5, 0) == (10.0, 1)  # beyond the last sample given: held
