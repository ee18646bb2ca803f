"""Compiled step-by-step kernels of the VBMM (private; the numpy API is :mod:`bpmid.models.vbmm`).

At step k every hereditary operator is affine in the current strain,
M-hat[x]_k = M0 x_k + c_k, with c_k fixed by the history (recursive: the branch states; full or
window: the stored strain history). The forward model therefore solves one scalar equation per
step, P_model(beta_k) = P_k, by a bracketed Newton iteration warm-started at beta_{k-1}, then commits
the step to the history.

Geometry vector ``geo``: th, alpha0, R0, l0, n (SI). Closure: 0 = "paper", 1 = "consistent".
Mode: 0 = recursive, 1 = sliding window, 2 = full history.
"""
from __future__ import annotations

import math

import numba
import numpy as np

BETA_MAX = 4.0 * math.pi  # rad; the solve's upper bracket (VBMM.md section 5)

STATUS_OK = 0
STATUS_ABOVE_RANGE = 1  # pressure needs beta > 4 pi
STATUS_NO_CONVERGENCE = 2


@numba.njit(cache=True, inline="always")
def u3_from_beta(beta, R0, l0, n):  # pragma: no cover - compiled
    pn2 = 4.0 * math.pi * math.pi * n * n
    D = l0 * l0 + pn2 * R0 * R0
    E = pn2 * pn2 * R0 * R0
    return -2.0 * R0 + (2.0 * math.sqrt(D * beta * beta + E) - 2.0 * l0 * beta) / (beta * beta + pn2)


@numba.njit(cache=True, inline="always")
def stretch(u3, R0, l0, n):  # pragma: no cover - compiled
    A = -math.pi * math.pi * n * n / (l0 * l0)
    B = -4.0 * math.pi * math.pi * n * n * R0 / (l0 * l0)
    return math.sqrt(1.0 + A * u3 * u3 + B * u3)


@numba.njit(cache=True)
def pressure_at(beta, geo, closure, G0, K0, cG1, cG2, cK1, cK2, scale, stiff):  # pragma: no cover
    """Gauge pressure (Pa) that holds ``beta`` given the history constants of this step."""
    th, alpha0, R0, l0, n = geo[0], geo[1], geo[2], geo[3], geo[4]
    u3 = u3_from_beta(beta, R0, l0, n)
    F = stretch(u3, R0, l0, n)
    e1 = F - 1.0
    e2 = u3 / R0
    g1 = G0 * e1 + cG1
    g2 = G0 * e2 + cG2
    lam = (K0 * e1 + cK1) + (K0 * e2 + cK2) - (2.0 / 3.0) * (g1 + g2)
    s = scale * (1.0 + stiff * e1 * e1)
    s1 = s * (2.0 * g1 + lam)
    s2 = s * (2.0 * g2 + lam)
    R = R0 + 0.5 * u3
    if closure == 0:
        gb = l0 * math.cos(alpha0) * (1.0 + u3 / R0)
        return th / R * (s2 + (s2 * gb + s1 * e1) / (1.0 - 2.0 * gb * F))
    ca = math.cos(alpha0) * (1.0 + e2)
    return th / R * (s2 + s1 * e1 / (1.0 - ca))


@numba.njit(cache=True)
def instantaneous(Minf, M):  # pragma: no cover - compiled
    """M(0) = M_inf + sum_j M_j: the modulus that acts on a step's own strain increment."""
    m0 = Minf
    for j in range(M.size):
        m0 += M[j]
    return m0


@numba.njit(cache=True)
def decay(a, dt, tau, r):  # pragma: no cover - compiled
    """a_j = exp(-dt / (tau_j r)): the decay of each branch over this step (r: fall ratio, 1 = symmetric)."""
    for j in range(tau.size):
        a[j] = math.exp(-dt / (tau[j] * r))


@numba.njit(cache=True)
def recursion_const(M, a, h, xprev):  # pragma: no cover - compiled
    """c_k of M-hat[x]_k = M0 x_k + c_k for the exact recursion (VBMM.md section 3), from the branch
    states h of the previous step and this step's decays a."""
    c = 0.0
    for j in range(M.size):
        c += M[j] * (a[j] * h[j] - xprev)
    return c


@numba.njit(cache=True)
def commit(a, h, dx):  # pragma: no cover - compiled
    """Commit this step's strain increment dx to the branch states: h_j = a_j h_j + dx."""
    for j in range(h.size):
        h[j] = a[j] * h[j] + dx


@numba.njit(cache=True)
def solve_beta(p, b_prev, geo, closure, G0, K0, cG1, cG2, cK1, cK2, sc, stiff):  # pragma: no cover
    """beta (rad) with pressure_at(beta) = p (gauge Pa): bracketed Newton on [0, 4 pi] warm-started at
    b_prev. Returns (beta, status). At or below the pressure that holds u3 = 0 the answer is 0 (the
    muscle does not bend backwards)."""
    f0 = pressure_at(0.0, geo, closure, G0, K0, cG1, cG2, cK1, cK2, sc, stiff) - p
    if f0 >= 0.0:
        return 0.0, STATUS_OK
    lo, hi = 0.0, BETA_MAX
    fhi = pressure_at(hi, geo, closure, G0, K0, cG1, cG2, cK1, cK2, sc, stiff) - p
    if fhi < 0.0:
        return BETA_MAX, STATUS_ABOVE_RANGE
    x = min(max(b_prev, 1e-9), BETA_MAX - 1e-9)
    for _ in range(100):
        fx = pressure_at(x, geo, closure, G0, K0, cG1, cG2, cK1, cK2, sc, stiff) - p
        if fx > 0.0:
            hi = x
        else:
            lo = x
        hstep = 1e-7 * max(x, 1e-3)
        d = (pressure_at(x + hstep, geo, closure, G0, K0, cG1, cG2, cK1, cK2, sc, stiff) - p - fx) / hstep
        xn = x - fx / d if d > 0.0 else 0.5 * (lo + hi)
        if not (lo < xn < hi):
            xn = 0.5 * (lo + hi)
        if abs(xn - x) < 1e-13 or hi - lo < 1e-14:
            return xn, STATUS_OK
        x = xn
    return x, STATUS_NO_CONVERGENCE


@numba.njit(cache=True)
def _history_consts_sum(k, start, lumped, t, e1, e2, Ginf, Gj, tauG, Kinf, Kj, tauK, shared):  # pragma: no cover
    """c_k of all four operators (G on e1, e2; K on e1, e2) for the full sum or the sliding window, in
    one pass over the history: the kernel values at each age are computed once and serve both strains
    (and both moduli when the time constants are shared).

    ``start``: first increment summed one by one; ``lumped``: index of the lumped point (eq. 19), or -1.
    """
    G0 = instantaneous(Ginf, Gj)
    K0 = instantaneous(Kinf, Kj)
    aG1 = Ginf * e1[0]
    aG2 = Ginf * e2[0]
    aK1 = Kinf * e1[0]
    aK2 = Kinf * e2[0]
    if lumped >= 1:
        age = t[k] - t[lumped]
        mg = Ginf
        for j in range(Gj.size):
            mg += Gj[j] * math.exp(-age / tauG[j])
        mk = Kinf
        for j in range(Kj.size):
            mk += Kj[j] * math.exp(-age / tauK[j])
        aG1 += mg * (e1[lumped] - e1[0])
        aG2 += mg * (e2[lumped] - e2[0])
        aK1 += mk * (e1[lumped] - e1[0])
        aK2 += mk * (e2[lumped] - e2[0])
    for i in range(start, k):
        age = t[k] - t[i]
        mg = Ginf
        mk = Kinf
        if shared:
            for j in range(Gj.size):
                w = math.exp(-age / tauG[j])
                mg += Gj[j] * w
                mk += Kj[j] * w
        else:
            for j in range(Gj.size):
                mg += Gj[j] * math.exp(-age / tauG[j])
            for j in range(Kj.size):
                mk += Kj[j] * math.exp(-age / tauK[j])
        d1 = e1[i] - e1[i - 1]
        d2 = e2[i] - e2[i - 1]
        aG1 += mg * d1
        aG2 += mg * d2
        aK1 += mk * d1
        aK2 += mk * d2
    return aG1 - G0 * e1[k - 1], aG2 - G0 * e2[k - 1], aK1 - K0 * e1[k - 1], aK2 - K0 * e2[k - 1]


@numba.njit(cache=True)
def forward_kernel(t, p, geo, closure, Ginf, Gj, tauG, Kinf, Kj, tauK, mode, window,
                   fall_ratio, stiff, scale):  # pragma: no cover - compiled
    """beta (rad) for gauge pressures ``p`` (Pa) at times ``t`` (s).

    Returns (beta, e1, e2, status); status[k] is STATUS_OK, STATUS_ABOVE_RANGE or STATUS_NO_CONVERGENCE.
    ``fall_ratio`` multiplies every tau on steps where the pressure falls (recursive mode only);
    ``stiff`` is the strain-stiffening coefficient (moduli scale by 1 + stiff e1^2); ``scale`` (N,) a
    per-step modulus scale (thermal softening). Defaults 1, 0, ones give the plain VBMM.
    """
    n = t.size
    R0, l0, nn = geo[2], geo[3], geo[4]
    beta = np.zeros(n)
    e1 = np.zeros(n)
    e2 = np.zeros(n)
    status = np.zeros(n, np.int64)
    hG1 = np.zeros(Gj.size)
    hG2 = np.zeros(Gj.size)
    hK1 = np.zeros(Kj.size)
    hK2 = np.zeros(Kj.size)
    aG = np.ones(Gj.size)
    aK = np.ones(Kj.size)
    G0full = instantaneous(Ginf, Gj)
    K0full = instantaneous(Kinf, Kj)
    shared = Gj.size == Kj.size
    if shared:
        for j in range(Gj.size):
            if tauG[j] != tauK[j]:
                shared = False
    ls = -1  # window: last sample older than the window so far
    b_prev = 0.0
    for k in range(n):
        if k == 0:
            G0, K0 = Ginf, Kinf
            cG1 = cG2 = cK1 = cK2 = 0.0
        else:
            G0, K0 = G0full, K0full
            dt = t[k] - t[k - 1]
            r = fall_ratio if (mode == 0 and p[k] < p[k - 1]) else 1.0
            decay(aG, dt, tauG, r)
            decay(aK, dt, tauK, r)
            if mode == 0:
                cG1 = recursion_const(Gj, aG, hG1, e1[k - 1])
                cG2 = recursion_const(Gj, aG, hG2, e2[k - 1])
                cK1 = recursion_const(Kj, aK, hK1, e1[k - 1])
                cK2 = recursion_const(Kj, aK, hK2, e2[k - 1])
            else:
                # full or window: one fused pass over the stored history (the lumped point of the
                # window only moves forward, so it is tracked, not searched for)
                lumped = -1
                if mode == 1:
                    # a sample T_win old (to rounding) is the lumped point t_s = t_k - T_win of eq. (19)
                    while ls + 1 < k and t[k] - t[ls + 1] >= window * (1.0 - 1e-9):
                        ls += 1
                    lumped = ls
                start = lumped + 1 if lumped >= 1 else 1
                cG1, cG2, cK1, cK2 = _history_consts_sum(k, start, lumped, t, e1, e2, Ginf, Gj, tauG,
                                                         Kinf, Kj, tauK, shared)
        b, status[k] = solve_beta(p[k], b_prev, geo, closure, G0, K0, cG1, cG2, cK1, cK2, scale[k], stiff)
        beta[k] = b
        u3 = u3_from_beta(b, R0, l0, nn)
        e1[k] = stretch(u3, R0, l0, nn) - 1.0
        e2[k] = u3 / R0
        if k > 0:
            commit(aG, hG1, e1[k] - e1[k - 1])
            commit(aG, hG2, e2[k] - e2[k - 1])
            commit(aK, hK1, e1[k] - e1[k - 1])
            commit(aK, hK2, e2[k] - e2[k - 1])
        b_prev = b
    return beta, e1, e2, status
