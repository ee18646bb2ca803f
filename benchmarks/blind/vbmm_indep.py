"""Independent VBMM implementation (from the VBMM spec (shared/spec/VBMM.md) only) plus plant effects.

Written for the blind test of `bpmid discover`; shares no code with bpmid.
SI inside: m, Pa, s, rad.
"""
import math
import numpy as np
from scipy.optimize import brentq
from scipy import signal

ATM = 101325.0


class Geometry:
    def __init__(self, th, alpha0, R0, l0, n):
        self.th, self.alpha0, self.R0, self.l0, self.n = th, alpha0, R0, l0, n
        pn = math.pi * n
        self.A = -pn * pn / (l0 * l0)
        self.B = -4 * pn * pn * R0 / (l0 * l0)
        self.D = l0 * l0 + 4 * pn * pn * R0 * R0
        self.E = 16 * pn ** 4 * R0 * R0
        self.ca0 = math.cos(alpha0)

    def u3_of_beta(self, b):
        pn = math.pi * self.n
        return -2 * self.R0 + (2 * math.sqrt(self.D * b * b + self.E) - 2 * self.l0 * b) / (b * b + 4 * pn * pn)

    def strains(self, u3):
        F = math.sqrt(1 + self.A * u3 * u3 + self.B * u3)
        return F, F - 1.0, u3 / self.R0

    def beta_of_u3(self, u3):
        F = math.sqrt(1 + self.A * u3 * u3 + self.B * u3)
        return 2 * (F - 1) * self.l0 / (2 * self.R0 + u3)

    def pressure(self, u3, F, s1, s2, closure="paper"):
        R = self.R0 + u3 / 2
        if closure == "paper":
            Gb = self.l0 * self.ca0 * (1 + u3 / self.R0)
            return self.th / R * (s2 + (s2 * Gb + s1 * (F - 1)) / (1 - 2 * Gb * F))
        ca = self.ca0 * (1 + u3 / self.R0)
        return self.th / R * (s2 + s1 * (F - 1) / (1 - ca))


PAPER_GEOM = dict(th=0.002, alpha0=math.radians(30), R0=0.01673, l0=0.1959, n=7.43)
PAPER_FIT = dict(G_inf=9050.0, K_inf=6.434e6, branches=[dict(G=18300.0, K=13.645e6, tau=0.213)])


def relaxed_pressure(geom, mat, beta):
    u3 = geom.u3_of_beta(beta)
    F, e1, e2 = geom.strains(u3)
    G, K = mat["G_inf"], mat["K_inf"]
    ekk = e1 + e2
    s1 = 2 * G * e1 + (K - 2 * G / 3) * ekk
    s2 = 2 * G * e2 + (K - 2 * G / 3) * ekk
    return geom.pressure(u3, F, s1, s2)


# ---------------------------------------------------------------- plant
class Plant:
    """Forward VBMM beta(P) with optional physical effects.

    effects (dict, all optional):
      extra_branches: list of {G, K, tau}      (slow relaxation, added to the material)
      asym: {kind: 'switch'|'tanh', ratio, rate0}   deflation/inflation time-constant ratio
      stiff: {kind: 'power'|'fung'|'gent', c, m, xm}  multiplier on long-term stress vs eps1
      thermal: {kind: 'time'|'work'|'hyper', d, T, W0}  all moduli x (1 - softening)
      mullins: {d}  long-term moduli x (1 - d (1 - e1/e1max)) below the max strain seen in this log
      friction: {kind: 'mslip'|'dahl'|'boucwen', ...}  pressure-equivalent force vs beta
    """

    def __init__(self, geom, mat, effects=None, closure="paper"):
        self.g = geom
        self.mat = mat
        self.eff = effects or {}
        self.closure = closure
        br = list(mat["branches"]) + list(self.eff.get("extra_branches", []))
        self.br = br

    def simulate(self, t, p_gauge):
        g, mat, eff = self.g, self.mat, self.eff
        nb = len(self.br)
        Gj = [b["G"] for b in self.br]
        Kj = [b["K"] for b in self.br]
        tj = [b["tau"] for b in self.br]
        Ginf, Kinf = mat["G_inf"], mat["K_inf"]
        asym = eff.get("asym")
        stiff = eff.get("stiff")
        thermal = eff.get("thermal")
        mull = eff.get("mullins")
        fric = eff.get("friction")
        N = len(t)
        beta = np.zeros(N)
        h1 = [0.0] * nb
        h2 = [0.0] * nb
        # friction state
        if fric:
            if fric["kind"] == "mslip":
                ks, ws = fric["k"], fric["w"]
                z = [0.0] * len(ks)
            else:
                zf = 0.0
        work = 0.0
        e1max = 0.0

        def stiff_mult(e1):
            if not stiff:
                return 1.0
            x = abs(e1)
            if stiff["kind"] == "power":
                return 1 + stiff["c"] * (x / stiff["xref"]) ** stiff["m"]
            if stiff["kind"] == "fung":
                b = stiff["b"]
                return (math.exp(b * x) - 1) / (b * x) if x > 1e-12 else 1.0
            if stiff["kind"] == "gent":
                return 1.0 / (1 - (x / stiff["xm"]) ** 2)
            raise ValueError

        def fric_force(b, bprev, state):
            db = b - bprev
            if fric["kind"] == "mslip":
                f = 0.0
                for i in range(len(ks)):
                    zi = state[i] + ks[i] * db
                    if zi > ws[i]:
                        zi = ws[i]
                    elif zi < -ws[i]:
                        zi = -ws[i]
                    f += zi
                return f
            if fric["kind"] == "dahl":
                Fc, s0 = fric["Fc"], fric["sigma0"]
                sg = 1.0 if db > 0 else -1.0
                # exact integration of dF/db = s0 (1 - F sg / Fc) over the increment
                tgt = sg * Fc
                return tgt + (state - tgt) * math.exp(-s0 * abs(db) / Fc)
            if fric["kind"] == "boucwen":
                # z' = A x' - b|x'||z|^(n-1) z - g x'|z|^n, scaled: force = Fc * z
                A, bb, gg, nn, Fc = fric["A"], fric["b"], fric["g"], fric["n"], fric["Fc"]
                zz = state
                m = max(1, int(abs(db) / 2e-4) + 1)
                d = db / m
                for _ in range(m):
                    zz = zz + A * d - bb * abs(d) * abs(zz) ** (nn - 1) * zz - gg * d * abs(zz) ** nn
                return Fc * zz
            raise ValueError

        def fric_update(b, bprev, state):
            if fric["kind"] == "mslip":
                db = b - bprev
                return [min(max(state[i] + ks[i] * db, -ws[i]), ws[i]) for i in range(len(ks))]
            f = fric_force(b, bprev, state)
            return f if fric["kind"] == "dahl" else f / fric["Fc"]

        fstate = (z if fric and fric["kind"] == "mslip" else (0.0 if fric else None))

        # initial relaxed state at first pressure
        def p_relaxed(b):
            u3 = g.u3_of_beta(b)
            F, e1, e2 = g.strains(u3)
            m = stiff_mult(e1)
            ekk = e1 + e2
            G, K = Ginf * m, Kinf * m
            s1 = 2 * G * e1 + (K - 2 * G / 3) * ekk
            s2 = 2 * G * e2 + (K - 2 * G / 3) * ekk
            return g.pressure(u3, F, s1, s2, self.closure)

        p0 = p_gauge[0]
        b0 = 0.0 if p0 <= 0 else brentq(lambda b: p_relaxed(b) - p0, 0.0, 2.5, xtol=1e-13)
        beta[0] = b0
        u3p = g.u3_of_beta(b0)
        _, e1p, e2p = g.strains(u3p)
        e1max = abs(e1p)
        bprev = b0
        for k in range(1, N):
            dt = t[k] - t[k - 1]
            dp = p_gauge[k] - p_gauge[k - 1]
            a = []
            for j in range(nb):
                tau = tj[j]
                if asym and j == 0:
                    if asym["kind"] == "switch":
                        # direction from the previous angle increment (deflating when the angle falls)
                        if k >= 2 and beta[k - 1] < beta[k - 2]:
                            tau = tau * asym["ratio"]
                    elif asym["kind"] == "tanh":
                        r = dp / dt
                        tau = tau * math.exp(0.5 * math.log(asym["ratio"]) * (1 - math.tanh(r / asym["rate0"])))
                a.append(math.exp(-dt / tau))
            # softening multipliers
            mth = 1.0
            if thermal:
                if thermal["kind"] == "time":
                    mth = 1 - thermal["d"] * (1 - math.exp(-t[k] / thermal["T"]))
                elif thermal["kind"] == "work":
                    mth = 1 - thermal["d"] * (1 - math.exp(-work / thermal["W0"]))
                elif thermal["kind"] == "hyper":
                    x = t[k] / thermal["T"]
                    mth = 1 - thermal["d"] * x / (1 + x)
            Pk = p_gauge[k]
            hb1 = [a[j] * h1[j] - e1p for j in range(nb)]
            hb2 = [a[j] * h2[j] - e2p for j in range(nb)]

            def resid(b):
                u3 = g.u3_of_beta(b)
                F, e1, e2 = g.strains(u3)
                m = stiff_mult(e1) * mth
                if mull:
                    ae = abs(e1)
                    if ae < e1max:
                        m *= 1 - mull["d"] * (1 - ae / e1max)
                G, K = Ginf * m, Kinf * m
                g1 = G * e1
                g2 = G * e2
                k12 = K * (e1 + e2)
                g12 = G * (e1 + e2)
                for j in range(nb):
                    x1 = hb1[j] + e1
                    x2 = hb2[j] + e2
                    Gm = Gj[j] * mth
                    Km = Kj[j] * mth
                    g1 += Gm * x1
                    g2 += Gm * x2
                    k12 += Km * (x1 + x2)
                    g12 += Gm * (x1 + x2)
                s1 = 2 * g1 + k12 - 2 * g12 / 3
                s2 = 2 * g2 + k12 - 2 * g12 / 3
                P = g.pressure(u3, F, s1, s2, self.closure)
                if fric:
                    P += fric_force(b, bprev, fstate)
                return P - Pk

            lo = max(0.0, bprev - 0.5)
            hi = bprev + 0.5
            rlo = resid(lo)
            if rlo >= 0:
                if lo == 0.0:
                    bk = 0.0
                else:
                    bk = brentq(resid, 0.0, lo + 1e-12, xtol=1e-13) if resid(0.0) < 0 else 0.0
            else:
                while resid(hi) < 0:
                    hi += 0.5
                bk = brentq(resid, lo, hi, xtol=1e-13)
            # commit
            u3 = g.u3_of_beta(bk)
            F, e1, e2 = g.strains(u3)
            for j in range(nb):
                h1[j] = hb1[j] + e1
                h2[j] = hb2[j] + e2
            if fric:
                fstate = fric_update(bk, bprev, fstate)
            work += abs(Pk * (bk - bprev))
            e1max = max(e1max, abs(e1))
            e1p, e2p = e1, e2
            beta[k] = bk
            bprev = bk
        return beta


# ---------------------------------------------------------------- pressure dynamics (muscle sees p_int, log sees p_supply)
def pressure_lag(t, ps, spec, fine_dt=1e-3):
    """Internal (muscle) gauge pressure from the logged supply gauge pressure."""
    tf = np.arange(t[0], t[-1] + 1e-12, fine_dt)
    delay = spec.get("delay", 0.0)
    psf = np.interp(tf - delay, t, ps)  # transport delay (holds first value before t0)
    pf = np.empty_like(psf)
    kind = spec["kind"]
    if kind == "orifice":
        tau0, d0 = spec["tau0"], spec["dp0"]
        p = psf[0]
        for i in range(len(tf)):
            dlt = psf[i] - p
            p += fine_dt * dlt / (tau0 * math.sqrt(1 + abs(dlt) / d0))
            pf[i] = p
    elif kind == "delay_first":
        tau = spec["tau"]
        a = math.exp(-fine_dt / tau)
        pf = signal.lfilter([1 - a], [1, -a], psf, zi=[a * psf[0]])[0]
    elif kind == "second":
        wn, z = 2 * math.pi * spec["fn"], spec["zeta"]
        sysd = signal.cont2discrete(([wn * wn], [1, 2 * z * wn, wn * wn]), fine_dt, method="bilinear")
        b, a_ = np.squeeze(sysd[0]), sysd[1]
        zi = signal.lfilter_zi(b, a_) * psf[0]
        pf = signal.lfilter(b, a_, psf, zi=zi)[0]
    else:
        raise ValueError(kind)
    return np.interp(t, tf, pf)


def payload_ring(t, beta, fn, zeta):
    """Measured angle of a tip payload on a compliant mount: 2nd-order response to the muscle's angle."""
    wn = 2 * math.pi * fn
    fine = 1e-3
    tf = np.arange(t[0], t[-1] + 1e-12, fine)
    bf = np.interp(tf, t, beta)
    sysd = signal.cont2discrete(([wn * wn], [1, 2 * zeta * wn, wn * wn]), fine, method="bilinear")
    b, a_ = np.squeeze(sysd[0]), sysd[1]
    zi = signal.lfilter_zi(b, a_) * bf[0]
    out = signal.lfilter(b, a_, bf, zi=zi)[0]
    return np.interp(t, tf, out)
