"""Compiled step-by-step kernels of the VBMM (private; the numpy API is :mod:`bpmid.models.vbmm`).

At step k every hereditary operator is affine in the current strain,
M-hat[x]_k = M0 x_k + c_k, with c_k fixed by the history (recursive: the branch states; full or
window: the stored strain history). The forward model therefore solves one scalar equation per
step, P_model(beta_k) = P_k, by a bracketed Newton iteration with the analytic derivative
(:func:`pressure_slope`), started from the angle extrapolated from the last two steps, then commits the
step to the history. The same arithmetic, in the same order, as the C that ``bpmid export --to c``
writes (bpmid/export/templates/vbmm.c.in): the two agree to rounding (``benchmarks/bench_vbmm.py``
prints the kernel's cost against that C). Kernels use ``error_model="numpy"``: a division by zero gives
inf/nan (caught by the bracket), not a Python exception check on every division.

Geometry vector ``geo``: th, alpha0, R0, l0, n (SI). Closure: 0 = "paper", 1 = "consistent".
Mode: 0 = recursive, 1 = sliding window, 2 = full history.
"""
from __future__ import annotations

import math

import numba
import numpy as np

BETA_MAX = 4.0 * math.pi  # rad; the solve's upper bracket (VBMM.md section 5)
#: the angle falls on a step only when it ends this far (rad) below the last one: a held angle, solved to the
#: solver's last bits, is not a fall (asymmetric relaxation; the C export and the closed loop use the same)
DIR_TOL = 1e-9

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


@numba.njit(cache=True, error_model="numpy")
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


@numba.njit(cache=True, error_model="numpy")
def geometry_constants(geo):  # pragma: no cover - compiled
    """(10,) constants of the kinematics and closures from ``geo`` (th, alpha0, R0, l0, n), computed once per
    solve instead of once per evaluation: th, R0, l0, 4 pi^2 n^2, D, E, A, B, l0 cos(alpha0), cos(alpha0)."""
    th, alpha0, R0, l0, n = geo[0], geo[1], geo[2], geo[3], geo[4]
    pn2 = 4.0 * math.pi * math.pi * n * n
    gc = np.empty(10)
    gc[0] = th
    gc[1] = R0
    gc[2] = l0
    gc[3] = pn2
    gc[4] = l0 * l0 + pn2 * R0 * R0
    gc[5] = pn2 * pn2 * R0 * R0
    gc[6] = -math.pi * math.pi * n * n / (l0 * l0)
    gc[7] = -4.0 * math.pi * math.pi * n * n * R0 / (l0 * l0)
    gc[8] = l0 * math.cos(alpha0)
    gc[9] = math.cos(alpha0)
    return gc


@numba.njit(cache=True, inline="always", error_model="numpy")
def pressure_slope(beta, gc, closure, G0, K0, cG1, cG2, cK1, cK2, scale, stiff):  # pragma: no cover
    """(P, dP/dbeta): the gauge pressure (Pa) of :func:`pressure_at` and its analytic derivative (Pa/rad),
    term by term as in the exported C (bpmid/export/templates/vbmm.c.in). ``gc``: :func:`geometry_constants`."""
    th, R0, l0, pn2, D, E, A, B, l0ca, ca0 = gc[0], gc[1], gc[2], gc[3], gc[4], gc[5], gc[6], gc[7], gc[8], gc[9]
    q = beta * beta + pn2
    rt = math.sqrt(D * beta * beta + E)
    num = 2.0 * rt - 2.0 * l0 * beta
    u3 = -2.0 * R0 + num / q
    du = ((2.0 * D * beta / rt - 2.0 * l0) * q - num * (2.0 * beta)) / (q * q)
    F = math.sqrt(1.0 + A * u3 * u3 + B * u3)
    dF = (2.0 * A * u3 + B) * du / (2.0 * F)
    e1 = F - 1.0
    e2 = u3 / R0
    de2 = du / R0
    g1 = G0 * e1 + cG1
    g2 = G0 * e2 + cG2
    lam = (K0 * e1 + cK1) + (K0 * e2 + cK2) - (2.0 / 3.0) * (g1 + g2)
    dg1 = G0 * dF
    dg2 = G0 * de2
    dlam = K0 * dF + K0 * de2 - (2.0 / 3.0) * (dg1 + dg2)
    if stiff != 0.0:
        s = scale * (1.0 + stiff * e1 * e1)
        ds = scale * stiff * 2.0 * e1 * dF
    else:
        s = scale
        ds = 0.0
    s1 = s * (2.0 * g1 + lam)
    s2 = s * (2.0 * g2 + lam)
    ds1 = ds * (2.0 * g1 + lam) + s * (2.0 * dg1 + dlam)
    ds2 = ds * (2.0 * g2 + lam) + s * (2.0 * dg2 + dlam)
    Rm = R0 + 0.5 * u3
    dRm = 0.5 * du
    if closure == 0:
        gb = l0ca * (1.0 + u3 / R0)
        dgb = l0ca * de2
        den = 1.0 - 2.0 * gb * F
        nm = s2 * gb + s1 * e1
        inner = s2 + nm / den
        dinner = ds2 + ((ds2 * gb + s2 * dgb + ds1 * e1 + s1 * dF) * den + nm * 2.0 * (dgb * F + gb * dF)) / (den * den)
    else:
        ca = ca0 * (1.0 + e2)
        dca = ca0 * de2
        inner = s2 + s1 * e1 / (1.0 - ca)
        dinner = ds2 + ((ds1 * e1 + s1 * dF) * (1.0 - ca) + s1 * e1 * dca) / ((1.0 - ca) * (1.0 - ca))
    return th / Rm * inner, th * (dinner * Rm - inner * dRm) / (Rm * Rm)


@numba.njit(cache=True, inline="always", error_model="numpy")
def instantaneous(Minf, M):  # pragma: no cover - compiled
    """M(0) = M_inf + sum_j M_j: the modulus that acts on a step's own strain increment."""
    m0 = Minf
    for j in range(M.size):
        m0 += M[j]
    return m0


@numba.njit(cache=True, inline="always", error_model="numpy")
def decay(a, dt, tau, r):  # pragma: no cover - compiled
    """a_j = exp(-dt / (tau_j r)): the decay of each branch over this step (r: fall ratio, 1 = symmetric)."""
    for j in range(tau.size):
        a[j] = math.exp(-dt / (tau[j] * r))


@numba.njit(cache=True, inline="always", error_model="numpy")
def recursion_const(M, a, h, xprev):  # pragma: no cover - compiled
    """c_k of M-hat[x]_k = M0 x_k + c_k for the exact recursion (VBMM.md section 3), from the branch
    states h of the previous step and this step's decays a."""
    c = 0.0
    for j in range(M.size):
        c += M[j] * (a[j] * h[j] - xprev)
    return c


@numba.njit(cache=True, inline="always", error_model="numpy")
def commit(a, h, dx):  # pragma: no cover - compiled
    """Commit this step's strain increment dx to the branch states: h_j = a_j h_j + dx."""
    for j in range(h.size):
        h[j] = a[j] * h[j] + dx


@numba.njit(cache=True, error_model="numpy")
def solve_beta(p, b_start, geo, closure, G0, K0, cG1, cG2, cK1, cK2, sc, stiff):  # pragma: no cover
    """:func:`solve_beta_gc` with the geometry constants computed from ``geo`` (th, alpha0, R0, l0, n);
    returns (beta, status)."""
    b, st, _slope = solve_beta_gc(p, b_start, geometry_constants(geo), closure, G0, K0, cG1, cG2, cK1, cK2, sc, stiff)
    return b, st


@numba.njit(cache=True, inline="always", error_model="numpy")
def solve_beta_gc(p, b_start, gc, closure, G0, K0, cG1, cG2, cK1, cK2, sc, stiff):  # pragma: no cover
    """beta (rad) with pressure_at(beta) = p (gauge Pa): Newton's method with the analytic derivative,
    bracketed on [0, 4 pi], from ``b_start`` (the caller's warm start). Returns (beta, status). At or below
    the pressure that holds u3 = 0 the answer is 0 (the muscle does not bend backwards). Returns (beta, status, dP/dbeta at the last evaluation).

    The bracket ends are evaluated only when a Newton step leaves the bracket (P rises with beta, so a
    root inside means both ends have the right sign); the same solve as the exported C."""
    lo, hi = 0.0, BETA_MAX
    checked_lo = False
    checked_hi = False
    x = min(max(b_start, 1e-9), BETA_MAX - 1e-9)
    d = 0.0
    for _ in range(100):
        fx, d = pressure_slope(x, gc, closure, G0, K0, cG1, cG2, cK1, cK2, sc, stiff)
        fx -= p
        if fx > 0.0:
            hi = x
        else:
            lo = x
        xn = x - fx / d if d > 0.0 else 0.5 * (lo + hi)
        if d > 0.0 and lo < xn and xn < hi and abs(xn - x) < 1e-7:
            # quadratic convergence: after a Newton step this small the error is of order its square
            return xn, STATUS_OK, d
        if not (lo < xn and xn < hi):
            if lo == 0.0 and not checked_lo:
                checked_lo = True
                if pressure_slope(0.0, gc, closure, G0, K0, cG1, cG2, cK1, cK2, sc, stiff)[0] - p >= 0.0:
                    return 0.0, STATUS_OK, d
            if hi == BETA_MAX and not checked_hi:
                checked_hi = True
                if pressure_slope(BETA_MAX, gc, closure, G0, K0, cG1, cG2, cK1, cK2, sc, stiff)[0] - p < 0.0:
                    return BETA_MAX, STATUS_ABOVE_RANGE, d
            xn = 0.5 * (lo + hi)
        if abs(xn - x) < 1e-13 or hi - lo < 1e-14:
            return xn, STATUS_OK, d
        x = xn
    return x, STATUS_NO_CONVERGENCE, d


@numba.njit(cache=True, error_model="numpy")
def _history_consts_sum(k, start, lumped, t, e1, e2, Ginf, Gj, tauG, Kinf, Kj, tauK, shared):  # pragma: no cover
    """c_k of all four operators (G on e1, e2; K on e1, e2) for the full sum or the sliding window, in
    one pass over the history: the kernel values at each age are computed once and serve both strains
    (and both moduli when the time constants are shared).

    ``start``: first increment summed one by one; ``lumped``: index of the lumped point (eq. 19), or -1.

    A term with age / tau > 745 is skipped: exp() of it is 0 or the smallest subnormal (at most 5e-324),
    far below the rounding of the sum, so the result is bit-identical, and exp() of arguments below about
    -708 (subnormal results) is several times slower than elsewhere. Per step the cost stays linear in
    the history's length.
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
                x = age / tauG[j]
                if x <= 745.0:
                    w = math.exp(-x)
                    mg += Gj[j] * w
                    mk += Kj[j] * w
        else:
            for j in range(Gj.size):
                x = age / tauG[j]
                if x <= 745.0:
                    mg += Gj[j] * math.exp(-x)
            for j in range(Kj.size):
                x = age / tauK[j]
                if x <= 745.0:
                    mk += Kj[j] * math.exp(-x)
        d1 = e1[i] - e1[i - 1]
        d2 = e2[i] - e2[i - 1]
        aG1 += mg * d1
        aG2 += mg * d2
        aK1 += mk * d1
        aK2 += mk * d2
    return aG1 - G0 * e1[k - 1], aG2 - G0 * e2[k - 1], aK1 - K0 * e1[k - 1], aK2 - K0 * e2[k - 1]


@numba.njit(cache=True, error_model="numpy")
def forward_kernel(t, p, geo, closure, Ginf, Gj, tauG, Kinf, Kj, tauK, mode, window,
                   fall_ratio, stiff, scale):  # pragma: no cover - compiled
    """beta (rad) for gauge pressures ``p`` (Pa) at times ``t`` (s).

    Returns (beta, e1, e2, status); status[k] is STATUS_OK, STATUS_ABOVE_RANGE or STATUS_NO_CONVERGENCE.
    ``fall_ratio`` multiplies every tau on steps where the angle falls (recursive mode only): the muscle's
    own motion, so the relaxation transient after a pressure step down, at constant pressure, runs at the falling
    rate too, and the logged pressure's noise does not switch it. The step is solved with the last step's
    direction; when the angle moves the other way, it is solved again with the other direction's rate, and kept
    when that one is consistent (otherwise, a reversal within the step, the first solve stands);
    ``stiff`` is the strain-stiffening coefficient (moduli scale by 1 + stiff e1^2); ``scale`` (N,) a
    per-step modulus scale (thermal softening). Defaults 1, 0, ones give the plain VBMM.
    """
    n = t.size
    R0, l0 = geo[2], geo[3]
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
    gc = geometry_constants(geo)
    shared = Gj.size == Kj.size
    if shared:
        for j in range(Gj.size):
            if tauG[j] != tauK[j]:
                shared = False
    ls = -1  # window: last sample older than the window so far
    b_prev = 0.0
    b_prev2 = 0.0
    dt_prev = 0.0
    d_prev = 0.0
    dt_a = -1.0  # the step length and fall ratio the decays aG, aK were computed for
    r_a = -1.0
    falling = False  # the direction of the angle's last step (asymmetric relaxation)
    asym = mode == 0 and fall_ratio != 1.0
    for k in range(n):
        dt = 0.0
        r = 1.0
        if k == 0:
            G0, K0 = Ginf, Kinf
            cG1 = cG2 = cK1 = cK2 = 0.0
        else:
            G0, K0 = G0full, K0full
            dt = t[k] - t[k - 1]
            r = fall_ratio if (asym and falling) else 1.0
            if dt != dt_a or r != r_a:  # even sampling: one exp per branch per log, not per step
                decay(aG, dt, tauG, r)
                decay(aK, dt, tauK, r)
                dt_a = dt
                r_a = r
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
        # warm start: the angle extrapolated linearly from the last two steps
        # corrected by the pressure's departure from its own extrapolation through the last slope dP/dbeta
        x0 = b_prev
        if k > 1 and dt_prev > 0.0:
            x0 = b_prev + (b_prev - b_prev2) * (dt / dt_prev)
            if d_prev > 0.0:
                x0 = x0 + (p[k] - (p[k - 1] + (p[k - 1] - p[k - 2]) * (dt / dt_prev))) / d_prev
        # asymmetric relaxation: solved with the last step's direction; when the angle moves the other way, once
        # more with the other direction's rate (one call site: the solver is inlined, so a second would double it)
        fall_try = falling
        b = 0.0
        for attempt in range(2 if (asym and k > 0) else 1):
            if attempt == 1:
                fall_try = not falling
                r = fall_ratio if fall_try else 1.0
                decay(aG, dt, tauG, r)
                decay(aK, dt, tauK, r)
                r_a = r
                cG1 = recursion_const(Gj, aG, hG1, e1[k - 1])
                cG2 = recursion_const(Gj, aG, hG2, e2[k - 1])
                cK1 = recursion_const(Kj, aK, hK1, e1[k - 1])
                cK2 = recursion_const(Kj, aK, hK2, e2[k - 1])
            bt, st, dt_slope = solve_beta_gc(p[k], x0, gc, closure, G0, K0, cG1, cG2, cK1, cK2, scale[k], stiff)
            if attempt == 0:
                b, status[k], d_prev = bt, st, dt_slope
                if (bt < b_prev - DIR_TOL) == fall_try:
                    break
            elif (bt < b_prev - DIR_TOL) == fall_try:    # consistent: the angle turned
                b, status[k], d_prev = bt, st, dt_slope
                falling = fall_try
            else:                               # neither is consistent: the first solve stands, with its decays
                r = fall_ratio if falling else 1.0
                decay(aG, dt, tauG, r)
                decay(aK, dt, tauK, r)
                r_a = r
        beta[k] = b
        # u3_from_beta and stretch with the constants of gc (the same values, computed once per log)
        u3 = -2.0 * R0 + (2.0 * math.sqrt(gc[4] * b * b + gc[5]) - 2.0 * l0 * b) / (b * b + gc[3])
        e1[k] = math.sqrt(1.0 + gc[6] * u3 * u3 + gc[7] * u3) - 1.0
        e2[k] = u3 / R0
        if k > 0:
            commit(aG, hG1, e1[k] - e1[k - 1])
            commit(aG, hG2, e2[k] - e2[k - 1])
            commit(aK, hK1, e1[k] - e1[k - 1])
            commit(aK, hK2, e2[k] - e2[k - 1])
        b_prev2 = b_prev
        b_prev = b
        dt_prev = dt
    return beta, e1, e2, status
