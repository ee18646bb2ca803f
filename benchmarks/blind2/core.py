"""A second independent VBMM core with physical effects acting inside the integration.

Written from shared/spec/VBMM.md only (no bpmid code, no benchmarks/blind/gen.py). SI inside: m, Pa, s, rad.
The forward model solves, at every step, for the angle whose pressure equals the muscle's internal gauge
pressure, with the hereditary recursion of spec section 3. Effects enter where the physics puts them:

- extra rubber branches (slow KWW / power-law / log-normal spectra, Prony-discretised), a deflation-only branch,
  a branch whose time constant depends on the sign of its own overstress
- stiffening of the equilibrium network (Yeoh, Ogden, Arruda-Boyce/Pade) as a multiplier on the long-term moduli
- thermal softening (temperature state driven by dissipated power, by the valve's heat, or a conduction
  schedule) multiplying every modulus
- friction: a Coulomb+Stribeck slip element, Prandtl-Ishlinskii stops on the axial strain inside the axial stress,
  a generalized Maxwell-slip whose breakaway forces scale with the internal pressure
- out of catalogue: a gravity moment of a tip load, a ratcheting permanent set of the bladder
Pressure-side effects (lags) are computed on a 1 ms grid before the muscle sees the pressure (pneumatics.py).
"""
import math

import numpy as np
from numba import njit

ATM = 101325.0
PAPER_GEOM = dict(th=0.002, alpha0=math.radians(30.0), R0=0.01673, l0=0.1959, n=7.43)
PAPER_FIT = dict(G_inf=9050.0, K_inf=6.434e6, G1=18300.0, K1=13.645e6, tau1=0.213)


@njit(cache=True)
def _u3(b, R0, l0, n):
    pn2 = (math.pi * n) ** 2
    D = l0 * l0 + 4.0 * pn2 * R0 * R0
    E = 16.0 * pn2 * pn2 * R0 * R0
    return -2.0 * R0 + (2.0 * math.sqrt(D * b * b + E) - 2.0 * l0 * b) / (b * b + 4.0 * pn2)


@njit(cache=True)
def _F(u3, R0, l0, n):
    pn2 = (math.pi * n) ** 2
    A = -pn2 / (l0 * l0)
    B = -4.0 * pn2 * R0 / (l0 * l0)
    return math.sqrt(1.0 + A * u3 * u3 + B * u3)


@njit(cache=True)
def _closure(u3, F, s1, s2, th, ca0, R0, l0):
    R = R0 + 0.5 * u3
    Gb = l0 * ca0 * (1.0 + u3 / R0)
    return th / R * (s2 + (s2 * Gb + s1 * (F - 1.0)) / (1.0 - 2.0 * Gb * F))


@njit(cache=True)
def _stiff_mult(e1, code, sp):
    if code == 0:
        return 1.0
    lam = 1.0 + e1
    if code == 1:      # Yeoh: dW/dI1 / C1 with I1 - 3 of uniaxial incompressible stretch, normalised by x_ref
        x = (lam * lam + 2.0 / lam - 3.0) / sp[2]
        return 1.0 + sp[0] * (sp[1] * x + (1.0 - sp[1]) * x * x)
    if code == 2:      # Ogden one term of exponent alpha, ratio to its small-strain slope, blended with weight w
        a = sp[1]
        if abs(e1) < 1e-9:
            return 1.0
        og = (lam ** a - lam ** (-0.5 * a)) / (1.5 * a * e1)
        return 1.0 + sp[0] * (og - 1.0)
    if code == 3:      # Arruda-Boyce, Cohen's Pade inverse Langevin on the chain stretch ratio s = e1/e_lock
        s = e1 / sp[0]
        if s > 0.97:
            s = 0.97
        return (1.0 - s * s / 3.0) / (1.0 - s * s)
    return 1.0


@njit(cache=True)
def _static_state(b, R0, l0, n, stiff_code, sp, Ginf, Kinf, mth, ev):
    """Kinematics and the long-term (equilibrium) stresses at angle b: (u3, F, e1, e2, s1, s2)."""
    u3 = _u3(b, R0, l0, n)
    F = _F(u3, R0, l0, n)
    e1 = F - 1.0
    e2 = u3 / R0
    m = _stiff_mult(e1, stiff_code, sp) * mth
    G = Ginf * m
    K = Kinf * m
    ekk = e1 + e2
    lamb = K - 2.0 * G / 3.0
    s1 = 2.0 * G * e1 + lamb * ekk - Kinf * mth * ev
    s2 = 2.0 * G * e2 + lamb * ekk - Kinf * mth * ev
    return u3, F, e1, e2, s1, s2


@njit(cache=True)
def simulate_muscle(t, p, geo, mat, br, brkind, stiff_code, sp, therm_code, tp, thsched,
                    fric_code, fp, fe, load_code, lp, creep_code, cp, ev0):
    """Forward VBMM: angle (rad) for internal gauge pressure p (Pa) at times t (s).

    geo = [th, alpha0, R0, l0, n]; mat = [G_inf, K_inf]; br rows [G, K, tau, ratio]; brkind 0 normal,
    1 deflation-only increments, 2 time constant x ratio while the branch's axial overstress is negative.
    Returns (beta, temperature-like state, final creep set).
    """
    th, ca0, R0, l0, n = geo[0], math.cos(geo[1]), geo[2], geo[3], geo[4]
    Ginf, Kinf = mat[0], mat[1]
    nb = br.shape[0]
    N = t.shape[0]
    beta = np.zeros(N)
    Tst = np.zeros(N)
    h1 = np.zeros(nb)
    h2 = np.zeros(nb)
    hb1 = np.zeros(nb)
    hb2 = np.zeros(nb)
    gate = np.zeros(nb)
    ne = fe.shape[0]
    fz = np.zeros(ne)       # friction element states
    fzt = np.zeros(ne)
    stuck = 1.0
    vprev = 0.0
    fz0 = 0.0
    Lf = 0.0
    T = 0.0
    ev = ev0

    # ---- relaxed start at p[0] (long-term moduli only; friction as after a slow rise from zero)
    def p_static(b, mth, pk):
        u3, F, e1, e2, s1, s2 = _static_state(b, R0, l0, n, stiff_code, sp, Ginf, Kinf, mth, ev)
        if fric_code == 2:
            f = 0.0
            for i in range(ne):
                y = e1
                if y > fe[i, 0]:
                    y = fe[i, 0]
                f += fe[i, 1] * y
            s1 += fp[0] * f
        P = _closure(u3, F, s1, s2, th, ca0, R0, l0)
        if fric_code == 1:
            P += min(fp[0] * b, fp[1])
        elif fric_code == 3:
            for i in range(ne):
                L = fe[i, 1] * (max(pk, 0.0) + fp[0]) / fp[1]
                P += min(fe[i, 0] * b, L)
        if load_code == 1:
            P += lp[0] * (math.sin(b + lp[1]) - math.sin(lp[1]))
        return P

    mth0 = 1.0
    if therm_code == 3:
        mth0 = thsched[0]
    p0 = p[0]
    if p_static(0.0, mth0, p0) >= p0:
        b0 = 0.0
    else:
        lo, hi = 0.0, 0.2
        while p_static(hi, mth0, p0) < p0:
            lo = hi
            hi += 0.2
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if p_static(mid, mth0, p0) < p0:
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
    if fric_code == 1:
        fz0 = min(b0, fp[1] / fp[0])
    elif fric_code == 2:
        for i in range(ne):
            fz[i] = min(e1p, fe[i, 0])
    elif fric_code == 3:
        for i in range(ne):
            L = fe[i, 1] * (max(p0, 0.0) + fp[0]) / fp[1]
            fz[i] = min(b0, L / fe[i, 0])
    Tst[0] = T
    bprev = b0

    for k in range(1, N):
        dt = t[k] - t[k - 1]
        pk = p[k]
        # ---- multipliers known before the solve
        if therm_code == 3:
            mth = thsched[k]
        else:
            mth = 1.0 - T
        tshift = 1.0
        if therm_code == 2:
            tshift = math.exp(-tp[3] * T)
        for j in range(nb):
            tau = br[j, 2] * tshift
            if brkind[j] == 2 and h1[j] < 0.0:
                tau = tau * br[j, 3]
            a = math.exp(-dt / tau)
            hb1[j] = a * h1[j]
            hb2[j] = a * h2[j]
        if fric_code == 1:
            if stuck > 0.5:
                Lf = fp[1]
            else:
                Lf = fp[2] + (fp[1] - fp[2]) * math.exp(-(vprev / fp[3]) ** 2)

        def resid(b):
            u3, F, e1, e2, s1, s2 = _static_state(b, R0, l0, n, stiff_code, sp, Ginf, Kinf, mth, ev)
            d1 = e1 - e1p
            d2 = e2 - e2p
            for j in range(nb):
                if brkind[j] == 1 and d1 >= 0.0:
                    x1 = hb1[j]
                    x2 = hb2[j]
                else:
                    x1 = hb1[j] + d1
                    x2 = hb2[j] + d2
                Gj = br[j, 0] * mth
                Kj = br[j, 1] * mth
                lj = Kj - 2.0 * Gj / 3.0
                s1 += 2.0 * Gj * x1 + lj * (x1 + x2)
                s2 += 2.0 * Gj * x2 + lj * (x1 + x2)
            if fric_code == 2:
                f = 0.0
                for i in range(ne):
                    y = fz[i] + d1
                    r = fe[i, 0]
                    if y > r:
                        y = r
                    elif y < -r:
                        y = -r
                    f += fe[i, 1] * y
                s1 += fp[0] * f
            P = _closure(u3, F, s1, s2, th, ca0, R0, l0)
            db = b - bprev
            if fric_code == 1:
                zf = fp[0] * (fz0 + db)
                if zf > Lf:
                    zf = Lf
                elif zf < -Lf:
                    zf = -Lf
                P += zf
            elif fric_code == 3:
                for i in range(ne):
                    L = fe[i, 1] * (max(pk, 0.0) + fp[0]) / fp[1]
                    z = fe[i, 0] * (fz[i] + db)
                    if z > L:
                        z = L
                    elif z < -L:
                        z = -L
                    P += z
            if load_code == 1:
                P += lp[0] * (math.sin(b + lp[1]) - math.sin(lp[1]))
            return P - pk

        r0 = resid(0.0)
        if r0 >= 0.0:
            bk = 0.0
        else:
            lo = max(0.0, bprev - 0.02)
            rlo = resid(lo)
            while rlo > 0.0:
                lo = max(0.0, lo - 0.1)
                rlo = resid(lo)
            hi = bprev + 0.02
            rhi = resid(hi)
            while rhi < 0.0:
                lo = hi
                rlo = rhi
                hi += 0.1
                rhi = resid(hi)
            # Illinois regula falsi, bisection fallback (friction can make the residual jump)
            side = 0
            bk = 0.5 * (lo + hi)
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
        # ---- commit the step
        u3 = _u3(bk, R0, l0, n)
        F = _F(u3, R0, l0, n)
        e1 = F - 1.0
        e2 = u3 / R0
        d1 = e1 - e1p
        d2 = e2 - e2p
        for j in range(nb):
            if brkind[j] == 1 and d1 >= 0.0:
                h1[j] = hb1[j]
                h2[j] = hb2[j]
            else:
                h1[j] = hb1[j] + d1
                h2[j] = hb2[j] + d2
        db = bk - bprev
        if fric_code == 1:
            z = fz0 + db
            zmax = Lf / fp[0]
            if z > zmax:
                fz0 = zmax
                stuck = 0.0
            elif z < -zmax:
                fz0 = -zmax
                stuck = 0.0
            else:
                fz0 = z
                stuck = 1.0
            vprev = abs(db) / dt
        elif fric_code == 2:
            for i in range(ne):
                y = fz[i] + d1
                r = fe[i, 0]
                fz[i] = min(max(y, -r), r)
        elif fric_code == 3:
            for i in range(ne):
                zmax = fe[i, 1] * (max(pk, 0.0) + fp[0]) / fp[1] / fe[i, 0]
                fz[i] = min(max(fz[i] + db, -zmax), zmax)
        # ---- slow states
        if therm_code == 1:       # temperature driven by the power dissipated in the rubber's dashpots
            D = 0.0
            for j in range(nb):
                D += (br[j, 1] * (h1[j] + h2[j]) ** 2 + 2.0 * br[j, 0] * (h1[j] ** 2 + h2[j] ** 2)) / br[j, 2]
            Ttar = tp[0] * D / tp[2]
            T = Ttar + (T - Ttar) * math.exp(-dt / tp[1])
        elif therm_code == 2:     # valve/coil heat in proportion to the pressure held
            Ttar = tp[0] * max(pk, 0.0) / tp[4]
            T = Ttar + (T - Ttar) * math.exp(-dt / tp[1])
        if T > 0.5:
            T = 0.5
        if creep_code == 1:       # ratcheting permanent set under volumetric tension (never recovers)
            sv = Kinf * (e1 + e2 - ev)
            if sv > 0.0:
                ev += dt * cp[0] * (sv / cp[1]) ** cp[2]
        Tst[k] = T
        e1p, e2p = e1, e2
        beta[k] = bk
        bprev = bk
    return beta, Tst, ev


class Muscle:
    """Geometry + material + effects; .run(t, p_internal_gauge_Pa) -> angle in rad."""

    def __init__(self, geom, mat, extra_branches=(), closure="paper"):
        assert closure == "paper"
        self.geo = np.array([geom["th"], geom["alpha0"], geom["R0"], geom["l0"], geom["n"]], float)
        self.mat = dict(mat)
        self.extra = list(extra_branches)      # list of (G, K, tau, ratio, kind)
        self.stiff = (0, np.zeros(3))
        self.therm = (0, np.zeros(5))
        self.thsched = None
        self.fric = (0, np.zeros(4), np.zeros((0, 3)))
        self.load = (0, np.zeros(2))
        self.creep = (0, np.zeros(3))
        self.ev = 0.0

    def branches(self):
        m = self.mat
        rows = [(m["G1"], m["K1"], m["tau1"], 1.0, 0)] + list(self.extra)
        br = np.array([r[:4] for r in rows], float)
        kind = np.array([r[4] for r in rows], np.int64)
        return br, kind

    def run(self, t, p, thsched=None):
        br, kind = self.branches()
        sched = thsched if thsched is not None else np.ones(len(t))
        beta, T, ev = simulate_muscle(
            np.asarray(t, float), np.asarray(p, float), self.geo,
            np.array([self.mat["G_inf"], self.mat["K_inf"]]), br, kind,
            self.stiff[0], np.asarray(self.stiff[1], float), self.therm[0], np.asarray(self.therm[1], float),
            np.asarray(sched, float), self.fric[0], np.asarray(self.fric[1], float),
            np.asarray(self.fric[2], float).reshape(-1, 3) if len(self.fric[2]) else np.zeros((0, 3)),
            self.load[0], np.asarray(self.load[1], float), self.creep[0], np.asarray(self.creep[1], float),
            float(self.ev))
        self.last_T = T
        self.ev_out = ev
        return beta


def relaxed_pressure(geom, mat, beta):
    th, ca0, R0, l0, n = geom["th"], math.cos(geom["alpha0"]), geom["R0"], geom["l0"], geom["n"]
    u3 = _u3(beta, R0, l0, n)
    F = _F(u3, R0, l0, n)
    e1, e2 = F - 1.0, u3 / R0
    G, K = mat["G_inf"], mat["K_inf"]
    lam = K - 2 * G / 3
    s1 = 2 * G * e1 + lam * (e1 + e2)
    s2 = 2 * G * e2 + lam * (e1 + e2)
    return _closure(u3, F, s1, s2, th, ca0, R0, l0), u3, e1, e2
