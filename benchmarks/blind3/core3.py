"""blind3 forward model: blind2's independent VBMM kinematics/closure with blind3's own effect forms inside.

Reuses `benchmarks/blind2/core.py` only for the spec's kinematics (_u3, _F) and the paper closure (_closure),
which `benchmarks/blind2/check_golden.py` checks against VBMM.md's golden values. Everything else (the step
kernel, the effect forms, the pneumatics) is written here. SI inside: m, Pa, s, rad.

Material-side effects act inside the implicit per-step solve for the angle:
  branch kinds: 0 linear Prony branch; 1 Eyring (sinh) nonlinear dashpot; 2 rate-dependent tau while deflating
  (tau * (1 + k max(0, -de1/dt)/rate_ref)); 3 smooth asymmetric tau (tau * exp(a tanh(-de1/dt / rate_ref)))
  deflation-only Kelvin-Voigt viscous axial stress (eta * de1/dt while de1 < 0)
  stiffening of the long-term moduli: 1 Gent, 2 fibre lock-up (softplus squared), 3 Fung exponential
  thermal: a multiplier schedule on all moduli (session ramp / sinusoid / Mullins computed outside), or
           code 1: temperature state driven by the cycling amplitude |dbeta/dt| x p
  friction (a pressure added to the balance): 1 LuGre bristles on the angle, 2 Dahl on the angle,
           3 Bouc-Wen (n = 2) on the axial strain inside the axial stress
"""
import math
import os
import sys

import numpy as np
from numba import njit

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "blind2"))
from core import _u3, _F, _closure, PAPER_GEOM, PAPER_FIT  # noqa: E402

ATM = 101325.0


@njit(cache=True)
def _stiff(e1, code, sp):
    if code == 0:
        return 1.0
    lam = 1.0 + e1
    x = lam * lam + 2.0 / lam - 3.0          # I1 - 3, uniaxial incompressible
    if code == 1:                              # Gent: 1/(1 - x/Jm)
        r = x / sp[0]
        if r > 0.95:
            r = 0.95
        return 1.0 / (1.0 - r)
    if code == 2:                              # fibre lock-up: 1 + k (w softplus((e1 - el)/w) / wref)^2
        z = (e1 - sp[1]) / sp[2]
        if z > 30.0:
            s = z
        else:
            s = math.log1p(math.exp(z))
        q = sp[2] * s / sp[3]
        return 1.0 + sp[0] * q * q
    if code == 3:                              # Fung: exp(b x)
        return math.exp(sp[0] * x)
    return 1.0


@njit(cache=True)
def simulate3(t, p, geo, mat, br, kind, stiff_code, sp, sched, therm_code, tp, kv_eta,
              fric_code, fp, sensor_unused):
    th, ca0, R0, l0, n = geo[0], math.cos(geo[1]), geo[2], geo[3], geo[4]
    Ginf, Kinf = mat[0], mat[1]
    nb = br.shape[0]
    N = t.shape[0]
    beta = np.zeros(N)
    h1 = np.zeros(nb)
    h2 = np.zeros(nb)
    hb1 = np.zeros(nb)
    hb2 = np.zeros(nb)
    T = 0.0
    rate_prev = 0.0
    z = 0.0          # friction state
    # relaxed start: long-term network only (+ friction at its "after a slow rise" value)
    p0 = p[0]
    m0 = sched[0]

    def pstat(b):
        u3 = _u3(b, R0, l0, n)
        F = _F(u3, R0, l0, n)
        e1 = F - 1.0
        e2 = u3 / R0
        m = _stiff(e1, stiff_code, sp) * m0
        G = Ginf * m
        K = Kinf * m
        lamb = K - 2.0 * G / 3.0
        s1 = 2.0 * G * e1 + lamb * (e1 + e2)
        s2 = 2.0 * G * e2 + lamb * (e1 + e2)
        return _closure(u3, F, s1, s2, th, ca0, R0, l0)

    if pstat(0.0) >= p0:
        b0 = 0.0
    else:
        lo, hi = 0.0, 0.2
        while pstat(hi) < p0:
            lo = hi
            hi += 0.2
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if pstat(mid) < p0:
                lo = mid
            else:
                hi = mid
            if hi - lo < 1e-14:
                break
        b0 = 0.5 * (lo + hi)
    beta[0] = b0
    u3 = _u3(b0, R0, l0, n)
    F = _F(u3, R0, l0, n)
    e1p = F - 1.0
    e2p = u3 / R0
    bprev = b0

    for k in range(1, N):
        dt = t[k] - t[k - 1]
        pk = p[k]
        if therm_code == 1:
            mth = sched[k] * (1.0 - T)
        else:
            mth = sched[k]
        for j in range(nb):
            tau = br[j, 2]
            if kind[j] == 1:           # Eyring: faster relaxation at large overstress
                x = abs(h1[j]) / br[j, 3]
                if x > 1e-8:
                    tau = tau * x / math.sinh(min(x, 50.0))
            elif kind[j] == 2:
                tau = tau * (1.0 + br[j, 3] * max(0.0, -rate_prev) / br[j, 4])
            elif kind[j] == 3:
                tau = tau * math.exp(br[j, 3] * math.tanh(-rate_prev / br[j, 4]))
            a = math.exp(-dt / tau)
            hb1[j] = a * h1[j]
            hb2[j] = a * h2[j]

        def resid(b):
            u3 = _u3(b, R0, l0, n)
            F = _F(u3, R0, l0, n)
            e1 = F - 1.0
            e2 = u3 / R0
            m = _stiff(e1, stiff_code, sp) * mth
            G = Ginf * m
            K = Kinf * m
            lamb = K - 2.0 * G / 3.0
            s1 = 2.0 * G * e1 + lamb * (e1 + e2)
            s2 = 2.0 * G * e2 + lamb * (e1 + e2)
            d1 = e1 - e1p
            d2 = e2 - e2p
            for j in range(nb):
                x1 = hb1[j] + d1
                x2 = hb2[j] + d2
                Gj = br[j, 0] * mth
                Kj = br[j, 1] * mth
                lj = Kj - 2.0 * Gj / 3.0
                s1 += 2.0 * Gj * x1 + lj * (x1 + x2)
                s2 += 2.0 * Gj * x2 + lj * (x1 + x2)
            if kv_eta > 0.0 and d1 < 0.0:
                s1 += kv_eta * d1 / dt
            if fric_code == 3:        # Bouc-Wen n=2 on e1 (4 substeps), stress fp[0] * zz
                zz = z
                dx = d1 / 4.0
                for _ in range(4):
                    zz += fp[1] * (dx - 0.5 * abs(dx) * zz * abs(zz) - 0.5 * dx * zz * zz)
                s1 += fp[0] * zz
            P = _closure(u3, F, s1, s2, th, ca0, R0, l0)
            db = b - bprev
            if fric_code == 1:        # LuGre bristles on the angle: fp = [sigma0, Fc, Fs, vs, sigma1]
                v = db / dt
                g = fp[1] + (fp[2] - fp[1]) * math.exp(-(v / fp[3]) ** 2)
                zn = (z + v * dt) / (1.0 + fp[0] * abs(v) * dt / g)
                P += fp[0] * zn + fp[4] * (zn - z) / dt
            elif fric_code == 2:      # Dahl (i = 1) on the angle: fp = [sigma, Fc]
                if db != 0.0:
                    sg = 1.0 if db > 0.0 else -1.0
                    zn = sg * fp[1] + (z - sg * fp[1]) * math.exp(-fp[0] * abs(db) / fp[1])
                else:
                    zn = z
                P += zn
            return P - pk

        r0 = resid(0.0)
        if r0 >= 0.0:
            bk = 0.0
        else:
            lo = max(0.0, bprev - 0.02)
            rlo = resid(lo)
            while rlo > 0.0 and lo > 0.0:
                lo = max(0.0, lo - 0.1)
                rlo = resid(lo)
            hi = bprev + 0.02
            rhi = resid(hi)
            while rhi < 0.0:
                lo = hi
                rlo = rhi
                hi += 0.1
                rhi = resid(hi)
            side = 0
            for it in range(200):
                if hi - lo < 1e-13:
                    break
                if rhi - rlo > 0.0:
                    c = (lo * rhi - hi * rlo) / (rhi - rlo)
                else:
                    c = 0.5 * (lo + hi)
                if not (lo < c < hi) or it % 8 == 7:
                    c = 0.5 * (lo + hi)
                rc = resid(c)
                if rc == 0.0:
                    lo = c
                    hi = c
                    break
                if rc < 0.0:
                    lo = c
                    rlo = rc
                    if side == -1:
                        rhi *= 0.5
                    side = -1
                else:
                    hi = c
                    rhi = rc
                    if side == 1:
                        rlo *= 0.5
                    side = 1
            bk = 0.5 * (lo + hi)
        # commit
        u3 = _u3(bk, R0, l0, n)
        F = _F(u3, R0, l0, n)
        e1 = F - 1.0
        e2 = u3 / R0
        d1 = e1 - e1p
        d2 = e2 - e2p
        for j in range(nb):
            h1[j] = hb1[j] + d1
            h2[j] = hb2[j] + d2
        db = bk - bprev
        if fric_code == 3:
            dx = d1 / 4.0
            for _ in range(4):
                z += fp[1] * (dx - 0.5 * abs(dx) * z * abs(z) - 0.5 * dx * z * z)
        elif fric_code == 1:
            v = db / dt
            g = fp[1] + (fp[2] - fp[1]) * math.exp(-(v / fp[3]) ** 2)
            z = (z + v * dt) / (1.0 + fp[0] * abs(v) * dt / g)
        elif fric_code == 2:
            if db != 0.0:
                sg = 1.0 if db > 0.0 else -1.0
                z = sg * fp[1] + (z - sg * fp[1]) * math.exp(-fp[0] * abs(db) / fp[1])
        if therm_code == 1:   # heating ~ cycling amplitude: target tp[0] * |dbeta/dt| * p / tp[2], time constant tp[1]
            Ttar = tp[0] * abs(db) / dt * max(pk, 0.0) / tp[2]
            T = Ttar + (T - Ttar) * math.exp(-dt / tp[1])
            if T > 0.5:
                T = 0.5
        rate_prev = d1 / dt
        e1p, e2p = e1, e2
        beta[k] = bk
        bprev = bk
    return beta


def ml_spectrum(alpha, tau0, npts=25, span=3.0):
    """Prony discretisation of the Mittag-Leffler (fractional Zener / Cole-Cole) relaxation function
    E_alpha(-(t/tau0)^alpha): spectrum per d ln(tau) = sin(a pi) / (pi (r^a + r^-a + 2 cos(a pi))), r = tau0/tau."""
    u = np.linspace(-span, span, npts) * math.log(10.0)
    taus = tau0 * np.exp(u)
    r = tau0 / taus
    H = math.sin(alpha * math.pi) / (math.pi * (r ** alpha + r ** -alpha + 2 * math.cos(alpha * math.pi)))
    w = H * (u[1] - u[0])
    return taus, w / w.sum()


# ---------------------------------------------------------------- pneumatics on a fine grid (1 kHz)
@njit(cache=True)
def _psi(pr, b):
    if pr <= b:
        return 1.0
    q = (pr - b) / (1.0 - b)
    return math.sqrt(max(0.0, 1.0 - q * q))


@njit(cache=True)
def pneu_orifice(t, plog, tau_c, bcrit):
    """Choked/unchoked (ISO 6358) orifice between the logged line pressure and the muscle volume (isothermal):
    dp/dt = +-(p_up / tau_c) psi(p_down/p_up). Gauge Pa in and out; substeps of 0.1 ms."""
    N = t.shape[0]
    out = np.zeros(N)
    pm = plog[0] + ATM
    out[0] = plog[0]
    for k in range(1, N):
        dt = (t[k] - t[k - 1]) / 10.0
        pl = plog[k] + ATM
        for _ in range(10):
            if pl >= pm:
                f = pl / tau_c * _psi(pm / pl, bcrit)
            else:
                f = -pm / tau_c * _psi(pl / pm, bcrit)
            pm += dt * f
        out[k] = pm - ATM
    return out


@njit(cache=True)
def pneu_adiabatic(t, plog, tau_f, tau_h, gam):
    """Linear-resistance fill of a rigid gas volume, adiabatic charging with heat exchange to the wall:
    n' = (p_line - p)/R; inflow: T' = n'/n (gam T0 - T) + (T0 - T)/tau_h; outflow: T' = n'/n (gam - 1) T + ...
    p = n T (normalised: T0 = 1, n = p_abs at T0). tau_f = R * n-scale; gauge Pa in/out; substeps 0.1 ms."""
    N = t.shape[0]
    out = np.zeros(N)
    nn = plog[0] + ATM
    T = 1.0
    out[0] = plog[0]
    for k in range(1, N):
        dt = (t[k] - t[k - 1]) / 10.0
        pl = plog[k] + ATM
        for _ in range(10):
            pm = nn * T
            dn = (pl - pm) / tau_f
            if dn >= 0.0:
                dT = dn / nn * (gam * 1.0 - T) + (1.0 - T) / tau_h
            else:
                dT = dn / nn * (gam - 1.0) * T + (1.0 - T) / tau_h
            nn += dt * dn
            T += dt * dT
        out[k] = nn * T - ATM
    return out


@njit(cache=True)
def pneu_leak(t, plog, tau_in, kleak, bcrit):
    """Line fills the muscle through a fast linear restriction (tau_in); a leak orifice to atmosphere (choked
    above 1/bcrit atmospheres) drains it: dp/dt = (p_line - p)/tau_in - kleak p_abs psi(p_atm/p_abs)."""
    N = t.shape[0]
    out = np.zeros(N)
    pm = plog[0] + ATM
    # start at the steady state of the first pressure
    for _ in range(20000):
        pl = plog[0] + ATM
        f = (pl - pm) / tau_in - kleak * pm * _psi(ATM / pm, bcrit)
        pm += 1e-4 * f
    out[0] = pm - ATM
    for k in range(1, N):
        dt = (t[k] - t[k - 1]) / 10.0
        pl = plog[k] + ATM
        for _ in range(10):
            f = (pl - pm) / tau_in - kleak * pm * _psi(ATM / max(pm, ATM), bcrit)
            pm += dt * f
        out[k] = pm - ATM
    return out


def pneu_var_delay(t, plog, d0, expo, tau_v):
    """Transport delay growing at low pressure, d = d0 (p_atm / p_abs)^expo, then a short first-order volume."""
    pabs = plog + ATM
    d = d0 * (ATM / pabs) ** expo
    src = np.interp(t - d, t, plog, left=plog[0])
    out = np.empty_like(src)
    out[0] = src[0]
    a = np.exp(-np.diff(t) / tau_v)
    y = src[0]
    for k in range(1, len(t)):
        y = src[k] + (y - src[k]) * a[k - 1]
        out[k] = y
    return out
