"""The out-of-family muscle: kinematics, material and every physical form, integrated on a fine time grid.

Written from the physics and from /work/shared/spec/VBMM.md sections 1-4 only; nothing here calls bpmid's model
code (bpmid.models, bpmid.effects, bpmid.twin), so the base muscle is a cross-check of bpmid's VBMM too
(``tests/test_validation_generator.py`` checks it against the golden table of VBMM.md section 8).

State-space form, integrated with its own stepping on a grid of ``h`` <= 1 ms inside each log sample (the
logged pressure is interpolated linearly between samples; the sensor samples the angle at the log times):

- pressure path (``pressure_path``): the muscle's internal pressure from the logged one: two cascaded first-order
  lags, a transport delay plus a lag, or an air leak (supply through a line, orifice leak ~ sqrt(p) to ambient).
- material: Prony branches as internal strain variables, dq/dt = de/dt - q/tau (VBMM.md eq. 5 as a state), on
  the axial and hoop strains; a branch may relax with another time constant while the axial strain falls
  (asymmetric relaxation); extra slow branches (second relaxation); a time-varying modulus factor (thermal
  softening); a Mullins damage factor eta = 1 - (1/r) erf((e_max^2 - e1^2)/m) on the rubber stress.
- braid friction, an axial stress in parallel: Dahl (dF/de = sigma0 (1 - F/Fc sgn de), integrated exactly per
  step), Bouc-Wen (dz/de = A - (b sgn(z de) + g)|z|), or a bank of Jenkins (spring + slip) elements.
- strain stiffening, an axial stress in parallel: exponential fibre recruitment C (exp(k e1) - 1 - k e1) or a
  polynomial C e1^3.
- payload inertia: the quasi-static pressure balance P_model(beta) = p becomes P_model(beta) + m beta'' + c beta' = p
  (Newmark average acceleration, no numerical damping).

Units: SI inside (m, Pa, s, rad).
"""
from __future__ import annotations

import math

import numba
import numpy as np

#: kinds of the friction / stiffening terms in the kernel
FRICTION_KINDS = {"none": 0, "dahl": 1, "bouc_wen": 2, "jenkins": 3}
STIFFENING_KINDS = {"none": 0, "exponential": 1, "polynomial": 2}


# ---------------------------------------------------------------------------------------------
# kinematics (VBMM.md section 2), scalar njit versions
# ---------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def _u3_of_beta(beta, R0, l0, n):
    c = 4.0 * math.pi * math.pi * n * n
    D = l0 * l0 + c * R0 * R0
    E = c * c * R0 * R0
    return -2.0 * R0 + (2.0 * math.sqrt(D * beta * beta + E) - 2.0 * l0 * beta) / (beta * beta + c)


@numba.njit(cache=True)
def _axial_stretch(u3, R0, l0, n):
    A = -math.pi * math.pi * n * n / (l0 * l0)
    B = -4.0 * math.pi * math.pi * n * n * R0 / (l0 * l0)
    return math.sqrt(1.0 + A * u3 * u3 + B * u3)


@numba.njit(cache=True)
def _closure(u3, s1, s2, th, alpha0, R0, l0, n, Fs):
    """Gauge pressure of the paper closure (VBMM.md section 4, literal SI)."""
    R = R0 + 0.5 * u3
    gb = l0 * math.cos(alpha0) * (1.0 + u3 / R0)
    return th / R * (s2 + (s2 * gb + s1 * (Fs - 1.0)) / (1.0 - 2.0 * gb * Fs))


def beta_of_u3(u3, geo):
    """Bending angle (rad) for radial displacement u3 (m); ``geo`` = (th, alpha0, R0, l0, n)."""
    th, a0, R0, l0, n = geo
    u3 = np.asarray(u3, float)
    A = -math.pi**2 * n**2 / l0**2
    B = -4.0 * math.pi**2 * n**2 * R0 / l0**2
    F = np.sqrt(1.0 + A * u3**2 + B * u3)
    return 2.0 * (F - 1.0) * l0 / (2.0 * R0 + u3)


# ---------------------------------------------------------------------------------------------
# Bouc-Wen (n = 1), exact over a strain increment
# ---------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def _lin_ode(w0, A, k, x):
    """w(x) for dw/dx = A - k w, w(0) = w0."""
    if abs(k * x) < 1e-12:
        return w0 + (A - k * w0) * x
    e = math.exp(-max(min(k * x, 700.0), -700.0))
    return A / k + (w0 - A / k) * e


@numba.njit(cache=True)
def bouc_wen_step(z, de, A, b, g):
    """z after a strain increment ``de`` of dz/de = A - (b sgn(z de) + g)|z|, exact for any increment.

    Along the motion (x = |de| travelled, w = sgn(de) z): dw/dx = A - (b + g) w while w >= 0 and
    dw/dx = A - (b - g) w while w < 0, each linear with a closed-form solution; a w < 0 that reaches 0 continues
    on the first branch. (An explicit update over a large trial increment, as the step solver tries at beta = 0,
    is unstable once (b + g)|de| is more than a few: it made the pressure balance wrong and the angle collapse.)"""
    if de == 0.0:
        return z
    s = 1.0 if de > 0.0 else -1.0
    x = abs(de)
    w = s * z
    if w < 0.0:
        k = b - g
        if abs(k) < 1e-300:
            xs = -w / A if A > 0.0 else math.inf
        else:
            arg = 1.0 - k * w / A if A > 0.0 else -1.0
            xs = math.log(arg) / k if arg > 0.0 else math.inf
        if xs >= x:
            return s * _lin_ode(w, A, k, x)
        x -= xs
        w = 0.0
    return s * _lin_ode(w, A, b + g, x)


# ---------------------------------------------------------------------------------------------
# one step's pressure balance as a function of the trial angle
# ---------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def _balance(beta, geo, Ginf, Kinf, Gj, Kj, tauj, fall_ratio, dt, soft, e1p, e2p, h1, h2, h1n, h2n,
             fr_kind, fr_par, fr_state, fr_new, st_kind, st_C, st_k, mul_rinv, mul_m, emax):
    """Model pressure (Pa, gauge) at trial angle ``beta``; writes the trial states into h1n, h2n, fr_new."""
    th, alpha0, R0, l0, n = geo[0], geo[1], geo[2], geo[3], geo[4]
    u3 = _u3_of_beta(beta, R0, l0, n)
    Fs = _axial_stretch(u3, R0, l0, n)
    e1 = Fs - 1.0
    e2 = u3 / R0
    de1 = e1 - e1p
    de2 = e2 - e2p
    # rubber: equilibrium + Prony branches (G on e1, e2 separately; lambda = K - 2/3 G on e1 + e2)
    g1 = Ginf * e1
    g2 = Ginf * e2
    kk = Kinf * (e1 + e2)
    gk = Ginf * (e1 + e2)
    for j in range(Gj.size):
        tau = tauj[j] * (fall_ratio if de1 < 0.0 else 1.0)
        a = math.exp(-dt / tau) if dt > 0.0 else 1.0
        h1n[j] = a * h1[j] + de1
        h2n[j] = a * h2[j] + de2
        g1 += Gj[j] * h1n[j]
        g2 += Gj[j] * h2n[j]
        kk += Kj[j] * (h1n[j] + h2n[j])
        gk += Gj[j] * (h1n[j] + h2n[j])
    lam = kk - (2.0 / 3.0) * gk
    s1 = 2.0 * g1 + lam
    s2 = 2.0 * g2 + lam
    eta = soft
    if mul_rinv > 0.0:
        em = max(emax, e1)
        eta *= 1.0 - mul_rinv * math.erf(max(em * em - e1 * e1, 0.0) / mul_m)
    s1 *= eta
    s2 *= eta
    # braid friction (axial stress in parallel)
    if fr_kind == 1:  # Dahl, exact for a constant-sign increment
        sg = 1.0 if de1 > 0.0 else -1.0
        Fc = fr_par[1]
        F = fr_state[0]
        if de1 != 0.0:
            F = sg * Fc + (F - sg * Fc) * math.exp(-fr_par[0] * abs(de1) / Fc)
        fr_new[0] = F
        s1 += F
    elif fr_kind == 2:  # Bouc-Wen, n = 1, integrated exactly over the strain increment (any size)
        z = bouc_wen_step(fr_state[0], de1, fr_par[1], fr_par[2], fr_par[3])
        fr_new[0] = z
        s1 += fr_par[0] * z
    elif fr_kind == 3:  # Jenkins elements: spring k_i in series with a slider of limit f_i
        F = 0.0
        m = fr_state.size
        for i in range(m):
            s = fr_state[i] + fr_par[i] * de1
            lim = fr_par[m + i]
            if s > lim:
                s = lim
            elif s < -lim:
                s = -lim
            fr_new[i] = s
            F += s
        s1 += F
    # strain stiffening (axial stress in parallel)
    if st_kind == 1:
        s1 += st_C * (math.exp(st_k * e1) - 1.0 - st_k * e1)
    elif st_kind == 2:
        s1 += st_C * e1 * e1 * e1
    return _closure(u3, s1, s2, th, alpha0, R0, l0, n, Fs)


@numba.njit(cache=True)
def simulate_fine(t, p, soft, geo, Ginf, Kinf, Gj, Kj, tauj, fall_ratio, fr_kind, fr_par, n_fr, st_kind, st_C,
                  st_k, mul_rinv, mul_m, emax0, mass, damp):
    """Angle (rad) on the fine grid ``t`` for internal gauge pressure ``p`` (Pa) and modulus factor ``soft``.

    Returns (beta, e_max at the end). Relaxed equilibrium at the first sample (branch states zero, friction
    unloaded). A pressure at or below the one holding u3 = 0 gives beta = 0 (the muscle does not bend back).
    """
    N = t.size
    nb = Gj.size
    beta = np.zeros(N)
    h1 = np.zeros(nb)
    h2 = np.zeros(nb)
    h1n = np.zeros(nb)
    h2n = np.zeros(nb)
    fr = np.zeros(max(n_fr, 1))
    frn = np.zeros(max(n_fr, 1))
    emax = emax0
    # --- relaxed equilibrium at the first pressure (dt = 0: branches get no increment from a zero state)
    e1p = 0.0
    e2p = 0.0
    b = 0.0
    target = p[0]
    zero = _balance(0.0, geo, Ginf, Kinf, Gj * 0.0, Kj * 0.0, tauj, 1.0, 0.0, soft[0], 0.0, 0.0, h1, h2, h1n, h2n,
                    0, fr_par, fr, frn, st_kind, st_C, st_k, mul_rinv, mul_m, emax)
    if target > zero:
        lo, hi = 0.0, 0.5
        while _balance(hi, geo, Ginf, Kinf, Gj * 0.0, Kj * 0.0, tauj, 1.0, 0.0, soft[0], 0.0, 0.0, h1, h2, h1n, h2n,
                       0, fr_par, fr, frn, st_kind, st_C, st_k, mul_rinv, mul_m, emax) < target and hi < 12.0:
            hi *= 2.0
        for _ in range(80):
            mid = 0.5 * (lo + hi)
            if _balance(mid, geo, Ginf, Kinf, Gj * 0.0, Kj * 0.0, tauj, 1.0, 0.0, soft[0], 0.0, 0.0, h1, h2, h1n,
                        h2n, 0, fr_par, fr, frn, st_kind, st_C, st_k, mul_rinv, mul_m, emax) < target:
                lo = mid
            else:
                hi = mid
        b = 0.5 * (lo + hi)
    beta[0] = b
    u3 = _u3_of_beta(b, geo[2], geo[3], geo[4])
    e1p = _axial_stretch(u3, geo[2], geo[3], geo[4]) - 1.0
    e2p = u3 / geo[2]
    emax = max(emax, e1p)
    omega = 0.0
    acc = 0.0
    for k in range(1, N):
        dt = t[k] - t[k - 1]
        bp = beta[k - 1]
        guess = bp + (bp - beta[k - 2] if k >= 2 else 0.0)
        # residual r(x) = P_model(x) + m a(x) + c w(x) - p ; a, w from Newmark average acceleration
        # bracket [lo, hi] with r(lo) < 0 < r(hi)
        r0 = _balance(0.0, geo, Ginf, Kinf, Gj, Kj, tauj, fall_ratio, dt, soft[k], e1p, e2p, h1, h2, h1n, h2n,
                      fr_kind, fr_par, fr, frn, st_kind, st_C, st_k, mul_rinv, mul_m, emax) - p[k]
        if mass > 0.0:
            a0 = 4.0 / (dt * dt) * (0.0 - bp - dt * omega) - acc
            r0 += mass * a0 + damp * (omega + 0.5 * dt * (acc + a0))
        if r0 >= 0.0:
            x = 0.0
        else:
            lo = 0.0
            hi = max(guess, 1e-6)
            x = hi
            for _ in range(60):
                r = _balance(hi, geo, Ginf, Kinf, Gj, Kj, tauj, fall_ratio, dt, soft[k], e1p, e2p, h1, h2, h1n,
                             h2n, fr_kind, fr_par, fr, frn, st_kind, st_C, st_k, mul_rinv, mul_m, emax) - p[k]
                if mass > 0.0:
                    ah = 4.0 / (dt * dt) * (hi - bp - dt * omega) - acc
                    r += mass * ah + damp * (omega + 0.5 * dt * (acc + ah))
                if r > 0.0:
                    break
                lo = hi
                hi = hi * 1.05 + 1e-4
            # safeguarded secant / bisection (Illinois) on [lo, hi]
            flo = r0 if lo == 0.0 else -1.0
            if lo > 0.0:
                flo = _balance(lo, geo, Ginf, Kinf, Gj, Kj, tauj, fall_ratio, dt, soft[k], e1p, e2p, h1, h2, h1n,
                               h2n, fr_kind, fr_par, fr, frn, st_kind, st_C, st_k, mul_rinv, mul_m, emax) - p[k]
                if mass > 0.0:
                    al = 4.0 / (dt * dt) * (lo - bp - dt * omega) - acc
                    flo += mass * al + damp * (omega + 0.5 * dt * (acc + al))
            fhi = r
            side = 0
            x = hi
            for _ in range(100):
                x = (lo * fhi - hi * flo) / (fhi - flo)
                if not (lo < x < hi):
                    x = 0.5 * (lo + hi)
                fx = _balance(x, geo, Ginf, Kinf, Gj, Kj, tauj, fall_ratio, dt, soft[k], e1p, e2p, h1, h2, h1n,
                              h2n, fr_kind, fr_par, fr, frn, st_kind, st_C, st_k, mul_rinv, mul_m, emax) - p[k]
                if mass > 0.0:
                    ax = 4.0 / (dt * dt) * (x - bp - dt * omega) - acc
                    fx += mass * ax + damp * (omega + 0.5 * dt * (acc + ax))
                if abs(fx) < 1e-9 or hi - lo < 1e-13:
                    break
                if fx > 0.0:
                    hi, fhi = x, fx
                    if side == 1:
                        flo *= 0.5
                    side = 1
                else:
                    lo, flo = x, fx
                    if side == -1:
                        fhi *= 0.5
                    side = -1
        # commit the step at x
        _balance(x, geo, Ginf, Kinf, Gj, Kj, tauj, fall_ratio, dt, soft[k], e1p, e2p, h1, h2, h1n, h2n,
                 fr_kind, fr_par, fr, frn, st_kind, st_C, st_k, mul_rinv, mul_m, emax)
        for j in range(nb):
            h1[j] = h1n[j]
            h2[j] = h2n[j]
        for i in range(n_fr):
            fr[i] = frn[i]
        if mass > 0.0:
            if x == 0.0:
                omega = 0.0
                acc = 0.0
            else:
                an = 4.0 / (dt * dt) * (x - bp - dt * omega) - acc
                omega = omega + 0.5 * dt * (acc + an)
                acc = an
        beta[k] = x
        u3 = _u3_of_beta(x, geo[2], geo[3], geo[4])
        e1p = _axial_stretch(u3, geo[2], geo[3], geo[4]) - 1.0
        e2p = u3 / geo[2]
        emax = max(emax, e1p)
    return beta, emax


@numba.njit(cache=True)
def _leak(t, ps, tau_in, k_leak):
    """Internal pressure (gauge Pa) of a muscle fed through a line (time constant ``tau_in``) from the logged
    supply pressure ``ps`` and leaking to ambient through an orifice: dp/dt = (ps - p)/tau_in - k_leak sqrt(p+)."""
    p = np.empty(t.size)
    x = ps[0]
    for _ in range(200):  # steady state at the first sample
        x = ps[0] - tau_in * k_leak * math.sqrt(max(x, 0.0))
    p[0] = x
    for k in range(1, t.size):
        h = t[k] - t[k - 1]
        # implicit in the line term, explicit in the (slow) leak term
        x = (x + h / tau_in * ps[k] - h * k_leak * math.sqrt(max(x, 0.0))) / (1.0 + h / tau_in)
        p[k] = x
    return p


def _first_order(t, x, tau):
    """y' = (x - y)/tau, exact for x constant over each step, starting in equilibrium."""
    y = np.empty_like(x)
    y[0] = x[0]
    a = np.exp(-np.diff(t) / tau)
    from scipy.signal import lfilter
    if np.allclose(a, a[0]):
        out, _ = lfilter([1.0 - a[0]], [1.0, -a[0]], x[1:], zi=[a[0] * x[0]])
        y[1:] = out
        return y
    for k in range(1, x.size):  # uneven grid (not produced here, kept for completeness)
        y[k] = a[k - 1] * y[k - 1] + (1.0 - a[k - 1]) * x[k]
    return y


def pressure_path(t, p_supply, kind: str = "none", **par) -> np.ndarray:
    """Internal gauge pressure (Pa) on the fine grid ``t`` from the logged pressure ``p_supply`` (Pa, gauge).

    kind: ``none``; ``cascade`` (two first-order lags ``tau1``, ``tau2`` in s); ``delay_lag`` (transport delay
    ``delay`` s then a lag ``tau`` s); ``leak`` (line ``tau_in`` s, orifice ``k_leak`` in sqrt(Pa)/s).
    """
    if kind == "none":
        return p_supply
    if kind == "cascade":
        return _first_order(t, _first_order(t, p_supply, par["tau1"]), par["tau2"])
    if kind == "delay_lag":
        delayed = np.interp(t - par["delay"], t, p_supply)
        return _first_order(t, delayed, par["tau"]) if par["tau"] > 0 else delayed
    if kind == "leak":
        return _leak(np.asarray(t, float), np.asarray(p_supply, float), float(par["tau_in"]), float(par["k_leak"]))
    raise ValueError(f"unknown pressure path {kind!r}")


def equilibrium_pressure(beta_rad, geo, Ginf: float, Kinf: float) -> np.ndarray:
    """Gauge pressure (Pa) holding angle ``beta_rad`` in relaxed equilibrium (long-term moduli only)."""
    out = []
    g = np.asarray(geo, float)
    for b in np.atleast_1d(beta_rad):
        out.append(_balance(float(b), g, Ginf, Kinf, np.zeros(0), np.zeros(0), np.ones(0), 1.0, 0.0, 1.0, 0.0, 0.0,
                            np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0), 0, np.zeros(1), np.zeros(1),
                            np.zeros(1), 0, 0.0, 1.0, 0.0, 1.0, 0.0))
    return np.array(out)
