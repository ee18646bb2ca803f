"""Independent synthetic test cases for `bpmid discover` (second blind generator).

Writes out/blind2/sets/<set>/<case>/ (what a user would have recorded: fitting logs, held-out logs, and for the
other muscles a case.yaml in bpmid's config format) and out/blind2/answers/<set>/<case>.yaml (the truth).
Written from shared/spec/*.md and bpmid's user docs only; the muscle and every effect are in core.py (own VBMM,
checked by check_golden.py) and below. Every file says it is synthetic and names this generator and its seed.

    python benchmarks/blind2/gen.py [--jobs 2] [--only A03,B08]
"""
import argparse
import math
import sys
import time
from multiprocessing import get_context
from pathlib import Path

import numpy as np
import yaml
from numba import njit
from scipy.optimize import nnls
from scipy.special import erfcx

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from core import ATM, PAPER_FIT, PAPER_GEOM, Muscle  # noqa: E402

ROOT = HERE.parent.parent
OUT = ROOT / "out" / "blind2"
GEN = "benchmarks/blind2/gen.py"
DT_FINE = 1e-3      # pneumatics grid (s)
DT_SIM = 1e-2       # muscle grid (s): the truth is integrated finer than any log is sampled
PSI = 6894.757293168
BASE_SEED = 52000
VARY = ("G_inf", "K_inf", "G1", "K1", "tau1")     # constants varied log to log (probe_null.py narrows it)

# ----------------------------------------------------------------------------------------------- muscles
GEOM_B = dict(th=0.0026, alpha0=math.radians(26.0), R0=0.0135, l0=0.172, n=6.3)
MAT_B = dict(G_inf=11500.0, K_inf=8.0e6, G1=21000.0, K1=12.2e6, tau1=0.32)
GEOM_C = dict(th=0.0031, alpha0=math.radians(33.0), R0=0.0182, l0=0.228, n=8.6)
MAT_C = dict(G_inf=12800.0, K_inf=9.1e6, G1=27000.0, K1=18.5e6, tau1=0.15)

SETS = {
    "A": dict(geom=PAPER_GEOM, mat=PAPER_FIT, fs=10.0, lo=(0.15, 0.25), hi=1.25, rates=(0.05, 0.4),
              var=0.01, noise="white", config=False),
    "B": dict(geom=GEOM_B, mat=MAT_B, fs=20.0, lo=(0.05, 0.3), hi=2.5, rates=(0.1, 1.0),
              var=0.015, noise="white", config=True),
    "C": dict(geom=GEOM_C, mat=MAT_C, fs=50.0, lo=(0.05, 0.3), hi=2.5, rates=(0.1, 1.0),
              var=0.02, noise="ar1", config=True),
}

# (case, truth ids, forms, out-of-catalogue name, variation override, file style)
CASES = {
    "A": [
        ("A01", ["second_relaxation"], ["kww"], None, None, "a_csv"),
        ("A02", ["braid_friction"], ["stribeck_slip"], None, None, "a_semicolon_de"),
        ("A03", ["pressure_lag"], ["line_fill_pdep"], None, None, "a_tab_bar_a"),
        ("A04", [], [], None, None, "a_csv"),
        ("A05", ["asymmetric_relaxation"], ["deflation_branch_fast"], None, None, "a_semicolon_de"),
        ("A06", ["strain_stiffening"], ["yeoh"], None, None, "a_tab_bar_a"),
        ("A07", ["angle_offset"], ["offset_gain"], None, None, "a_csv"),
        ("A08", ["thermal_softening"], ["dissipation_heat"], None, None, "a_semicolon_de"),
    ],
    "B": [
        ("B01", ["pressure_lag"], ["line_2nd_order"], None, None, "b_csv"),
        ("B02", ["strain_stiffening"], ["ogden"], None, None, "b_semicolon_cp1252"),
        ("B03", [], [], None, 0.04, "b_units_row"),
        ("B04", ["second_relaxation"], ["power_law"], None, None, "b_csv"),
        ("B05", ["thermal_softening"], ["valve_heat"], None, None, "b_semicolon_cp1252"),
        ("B06", ["braid_friction"], ["pi_stops_axial"], None, None, "b_units_row"),
        ("B07", ["second_relaxation", "braid_friction"], ["power_law", "pi_stops_axial"], None, None, "b_csv"),
        ("B08", ["angle_offset"], ["offset_gain"], None, None, "b_semicolon_cp1252"),
        ("B09", [], ["ratchet_set"], "ratcheting_permanent_set", None, "b_units_row"),
        ("B10", ["asymmetric_relaxation"], ["overstress_sign_tau"], None, None, "b_csv"),
        ("B11", ["pressure_lag"], ["slew_limited_valve"], None, None, "b_semicolon_cp1252"),
    ],
    "C": [
        ("C01", ["braid_friction"], ["gms_pressure_normal"], None, None, "c_instrument_g"),
        ("C02", [], [], None, 0.05, "c_psia_tab"),
        ("C03", ["thermal_softening"], ["conduction_warmup"], None, None, "c_psig_semicolon"),
        ("C04", ["pressure_lag", "strain_stiffening"], ["sample_hold_valve", "arruda_boyce"], None, None,
         "c_instrument_g"),
        ("C05", ["second_relaxation"], ["lognormal_spectrum"], None, None, "c_psia_tab"),
        ("C06", [], ["gravity_tip_load"], "gravity_load_on_angle", None, "c_psig_semicolon"),
        ("C07", ["asymmetric_relaxation"], ["deflation_branch_slow"], None, None, "c_instrument_g"),
        ("C08", ["strain_stiffening"], ["arruda_boyce"], None, None, "c_psia_tab"),
        ("C09", [], [], None, None, "c_psig_semicolon"),
        ("C10", ["angle_offset"], ["offset_eccentric"], None, None, "c_instrument_g"),
        ("C11", ["pressure_lag"], ["sample_hold_valve"], None, None, "c_psia_tab"),
    ],
}


# ----------------------------------------------------------------------------------------------- protocols
class Proto:
    """Supply pressure (bar gauge) on the 1 ms grid, built segment by segment like a rig's sequencer."""

    def __init__(self, p0):
        self.p = p0
        self.chunks = [np.array([p0])]

    def _add(self, arr):
        self.chunks.append(arr)
        self.p = float(arr[-1])

    @property
    def T(self):
        return (sum(len(c) for c in self.chunks) - 1) * DT_FINE

    def hold(self, T):
        n = max(1, int(round(T / DT_FINE)))
        self._add(np.full(n, self.p))

    def ramp(self, to, rate):
        T = abs(to - self.p) / rate
        n = max(1, int(round(T / DT_FINE)))
        self._add(self.p + (to - self.p) * np.arange(1, n + 1) / n)

    def step(self, to, slew=4.0):       # a regulator step: slew-limited, smoothed corner
        T = max(abs(to - self.p) / slew, 0.02)
        n = max(2, int(round(T / DT_FINE)))
        s = np.arange(1, n + 1) / n
        self._add(self.p + (to - self.p) * (s - np.sin(2 * np.pi * s) / (2 * np.pi)))

    def tri(self, lo, hi, rate, cycles):
        self.ramp(lo, rate) if abs(self.p - lo) > 1e-9 else None
        for _ in range(cycles):
            self.ramp(hi, rate)
            self.ramp(lo, rate)

    def sine(self, mid, amp, f, cycles, lead_rate=0.3):
        self.ramp(mid - amp, lead_rate) if abs(self.p - (mid - amp)) > 1e-9 else None
        n = int(round(cycles / f / DT_FINE))
        tt = np.arange(1, n + 1) * DT_FINE
        self._add(mid - amp * np.cos(2 * np.pi * f * tt))

    def array(self):
        return np.concatenate(self.chunks)


def make_protocol(kind, rng, S, long=False):
    lo = rng.uniform(*S["lo"])
    hi = S["hi"]
    r0, r1 = S["rates"]
    span = hi - lo
    P = Proto(lo)
    P.hold(rng.uniform(2, 5))
    if kind == "tri_rates":
        rates = np.sort(rng.uniform(r0, r1, 3))
        for r in rates:
            top = lo + span * rng.uniform(0.7, 1.0)
            P.tri(lo, top, r, 2)
            P.hold(rng.uniform(3, 8))
    elif kind == "tri_amps":
        r = rng.uniform(r0, 0.6 * r1)
        for fr in rng.permutation([0.35, 0.55, 0.8, 1.0]):
            P.tri(lo, lo + fr * span, r, 2)
            P.hold(rng.uniform(2, 5))
    elif kind == "stairs":
        nl = rng.integers(3, 6)
        levels = lo + span * np.sort(rng.uniform(0.2, 1.0, nl))
        for L in levels:
            P.step(L, rng.uniform(2, 6))
            P.hold(rng.uniform(10, 25))
        for L in list(levels[::-1][1:]) + [lo]:
            P.step(L, rng.uniform(2, 6))
            P.hold(rng.uniform(10, 25))
    elif kind == "sines":
        for _ in range(rng.integers(2, 4)):
            amp = 0.5 * span * rng.uniform(0.4, 0.95)
            mid = lo + amp + rng.uniform(0, span - 2 * amp)
            f = rng.uniform(0.02, 0.1 if S["fs"] <= 10 else 0.15)
            P.sine(mid, amp, f, int(rng.integers(2, 5)))
            P.hold(rng.uniform(2, 6))
    elif kind == "ramp_hold":
        for _ in range(2):
            top = lo + span * rng.uniform(0.5, 1.0)
            P.ramp(top, rng.uniform(r0, r1))
            P.hold(rng.uniform(25, 60))
            P.ramp(lo, rng.uniform(r0, r1))
            P.hold(rng.uniform(15, 35))
    elif kind == "mixed":
        blocks = ["tri", "hold", "sine", "steps", "tri", "sine", "steps", "tri"]
        rng.shuffle(blocks)
        target = rng.uniform(200, 290) if long else rng.uniform(70, 130)
        for b in blocks:
            if P.T > target:
                break
            if b == "tri":
                P.tri(lo, lo + span * rng.uniform(0.4, 1.0), rng.uniform(r0, r1), int(rng.integers(1, 4)))
            elif b == "hold":
                P.step(lo + span * rng.uniform(0.3, 0.9), 3.0)
                P.hold(rng.uniform(15, 40))
            elif b == "sine":
                amp = 0.5 * span * rng.uniform(0.3, 0.9)
                P.sine(lo + amp + rng.uniform(0, span - 2 * amp), amp, rng.uniform(0.03, 0.1),
                       int(rng.integers(2, 4)))
            else:
                for L in lo + span * rng.uniform(0.1, 1.0, 3):
                    P.step(L, rng.uniform(2, 6))
                    P.hold(rng.uniform(4, 12))
        P.ramp(lo, rng.uniform(r0, r1))
        P.hold(rng.uniform(5, 15))
    else:
        raise ValueError(kind)
    p = P.array()
    nmax = int(300.0 / DT_FINE) + 1
    if len(p) > nmax:
        p = p[:nmax]
    while len(p) * DT_FINE < 60.0:
        p = np.concatenate([p, np.full(int(10 / DT_FINE), p[-1])])
    return p


# ----------------------------------------------------------------------------------------------- pneumatics
@njit(cache=True)
def _lag(ps, code, q):
    """Internal gauge pressure (Pa) of the muscle from the supply gauge pressure ps (Pa) on the 1 ms grid."""
    n = ps.shape[0]
    out = np.empty(n)
    dt = 1e-3
    if code == 1:       # laminar line into a gas volume: tau ~ 1/p_abs; exhaust through a silencer slower
        p = ps[0]
        for i in range(n):
            tau = q[0] * (q[1] / (p + 101325.0)) ** q[2]
            if ps[i] < p:
                tau *= q[3]
            p += (ps[i] - p) * (1.0 - math.exp(-dt / tau))
            out[i] = p
    elif code == 2:     # underdamped second-order line (fn = q[0] Hz, zeta = q[1])
        w = 2.0 * math.pi * q[0]
        z = q[1]
        x = ps[0]
        v = 0.0
        for i in range(n):
            v += dt * (w * w * (ps[i] - x) - 2.0 * z * w * v)
            x += dt * v
            out[i] = x
    elif code == 3:     # proportional valve whose flow saturates: slew-rate limit q[0] Pa/s, time constant q[1]
        p = ps[0]
        for i in range(n):
            r = (ps[i] - p) / q[1]
            if r > q[0]:
                r = q[0]
            elif r < -q[0]:
                r = -q[0]
            p += dt * r
            out[i] = p
    elif code == 4:     # valve controller updating its set point every q[0] s from a q[1] s old sample, fast fill q[2]
        hold = ps[0]
        per = max(1, int(round(q[0] / dt)))
        dly = int(round(q[1] / dt))
        ph = int(q[3])
        p = ps[0]
        a = math.exp(-dt / q[2])
        for i in range(n):
            if (i + ph) % per == 0:
                j = i - dly
                hold = ps[j] if j >= 0 else ps[0]
            p = hold + (p - hold) * a
            out[i] = p
    else:
        for i in range(n):
            out[i] = ps[i]
    return out


# ----------------------------------------------------------------------------------------------- effects
def prony_fit(g, t_lo=0.02, t_hi=3000.0, taus=None):
    """Non-negative Prony weights approximating a decaying kernel g(t)/g(0)."""
    if taus is None:
        taus = np.logspace(-0.5, 3.0, 9)
    tt = np.logspace(math.log10(t_lo), math.log10(t_hi), 300)
    A = np.exp(-tt[:, None] / taus[None, :])
    w, _ = nnls(A, g(tt))
    keep = w > 1e-4 * w.sum()
    return taus[keep], w[keep]


def draw_effect(form, rng, S):
    """Draw the shape constants of one effect form; return (params, first amplitude guess)."""
    d = {}
    if form == "kww":
        d.update(tau=rng.uniform(6, 25), beta=rng.uniform(0.45, 0.7))
        return d, 0.2
    if form == "power_law":
        d.update(t0=rng.uniform(1.5, 4.0), alpha=rng.uniform(0.3, 0.6))
        return d, 0.15
    if form == "lognormal_spectrum":
        d.update(tau_c=rng.uniform(6, 25), width_decades=rng.uniform(0.6, 1.2))
        return d, 0.2
    if form == "stribeck_slip":
        d.update(presliding_deg=rng.uniform(1.0, 2.5), kinetic_over_static=rng.uniform(0.55, 0.8),
                 v_stribeck_deg_s=rng.uniform(0.5, 3.0))
        return d, 2000.0
    if form == "pi_stops_axial":
        r = np.logspace(math.log10(0.0008), math.log10(0.015), 12)
        k = rng.uniform(1.5, 3.0)
        w = r ** (k - 1) * np.exp(-r / rng.uniform(0.002, 0.005))
        d.update(thresholds=r.tolist(), weights=(w / w.sum()).tolist())
        return d, 2e7
    if form == "gms_pressure_normal":
        d.update(presliding_deg=sorted(rng.uniform(0.3, 4.0, 4).tolist()),
                 shares=(rng.dirichlet(np.ones(4) * 2)).tolist(), p0_bar=rng.uniform(0.2, 0.6))
        return d, 1500.0
    if form == "line_fill_pdep":
        d.update(kappa=rng.uniform(0.8, 1.2), exhaust_ratio=rng.uniform(1.3, 1.8))
        return d, 0.15
    if form == "line_2nd_order":
        d.update(zeta=rng.uniform(0.3, 0.55))
        return d, 0.4
    if form == "slew_limited_valve":
        return d, 0.8
    if form == "sample_hold_valve":
        d.update(delay_share=rng.uniform(0.3, 0.6), fill_tau=rng.uniform(0.02, 0.04),
                 phase_ms=int(rng.integers(0, 50)))
        return d, 0.2
    if form in ("deflation_branch_fast", "deflation_branch_slow"):
        d.update(tau=rng.uniform(0.6, 1.5) if form.endswith("fast") else rng.uniform(2.0, 4.0) * S["mat"]["tau1"])
        return d, 0.3
    if form == "overstress_sign_tau":
        return d, 1.5
    if form == "yeoh":
        d.update(c2_share=rng.uniform(-0.35, -0.1), e_ref=0.10)
        return d, 0.3
    if form == "ogden":
        d.update(alpha=rng.uniform(8.0, 12.0))
        return d, 0.3
    if form == "arruda_boyce":
        return d, 3.0
    if form in ("offset_gain", "offset_eccentric"):
        d.update(sign=float(rng.choice([-1.0, 1.0])), gain_error=rng.uniform(-0.0015, 0.0015),
                 ecc_share=rng.uniform(0.04, 0.1), ecc_phase=rng.uniform(0, 2 * math.pi))
        return d, 0.6
    if form == "dissipation_heat":
        d.update(tau_th=rng.uniform(60, 180))
        return d, 0.05
    if form == "valve_heat":
        d.update(tau_th=rng.uniform(60, 150), tau_shift=rng.uniform(0.5, 1.5), p_ref=1.5e5)
        return d, 0.05
    if form == "conduction_warmup":
        d.update(tau_th=rng.uniform(40, 150))
        return d, 0.05
    if form == "ratchet_set":
        d.update(n=3.0, s_ref_share=0.08)
        return d, 2e-5
    if form == "gravity_tip_load":
        d.update(phi=rng.uniform(0.0, math.radians(30)))
        return d, 3000.0
    raise ValueError(form)


def apply_effect(form, a, d, S, M, lag, sens, aux):
    """Put effect `form` of amplitude a into muscle M / pressure line lag / angle sensor sens."""
    mat = S["mat"]
    if form in ("kww", "power_law", "lognormal_spectrum"):
        if form == "kww":
            g = lambda t: np.exp(-(t / d["tau"]) ** d["beta"])  # noqa: E731
        elif form == "power_law":
            g = lambda t: (1 + t / d["t0"]) ** (-d["alpha"])  # noqa: E731
        else:
            s = d["width_decades"] * math.log(10)
            taus = np.exp(np.linspace(math.log(d["tau_c"]) - 2.5 * s, math.log(d["tau_c"]) + 2.5 * s, 11))
            w = np.exp(-0.5 * ((np.log(taus) - math.log(d["tau_c"])) / s) ** 2)
            w /= w.sum()
            for tj, wj in zip(taus, w):
                M.extra.append((a * wj * mat["G_inf"], a * wj * mat["K_inf"], tj, 1.0, 0))
            return
        taus, w = prony_fit(g)
        for tj, wj in zip(taus, w):
            M.extra.append((a * wj * mat["G_inf"], a * wj * mat["K_inf"], tj, 1.0, 0))
    elif form == "stribeck_slip":
        Fs = a
        k = Fs / math.radians(d["presliding_deg"])
        M.fric = (1, np.array([k, Fs, d["kinetic_over_static"] * Fs, math.radians(d["v_stribeck_deg_s"])]),
                  np.zeros((0, 3)))
    elif form == "pi_stops_axial":
        fe = np.array([[r, w, 0.0] for r, w in zip(d["thresholds"], d["weights"])])
        M.fric = (2, np.array([a, 0, 0, 0.0]), fe)
    elif form == "gms_pressure_normal":
        pref = 1.0e5
        fe = np.array([[a * s / math.radians(ps), a * s, 0.0] for ps, s in zip(d["presliding_deg"], d["shares"])])
        M.fric = (3, np.array([d["p0_bar"] * 1e5, pref, 0, 0.0]), fe)
    elif form == "line_fill_pdep":
        lag.update(code=1, q=np.array([a, 1.5e5, d["kappa"], d["exhaust_ratio"]]))
    elif form == "line_2nd_order":
        lag.update(code=2, q=np.array([1.0 / a, d["zeta"]]))
    elif form == "slew_limited_valve":
        lag.update(code=3, q=np.array([1e5 / a, 0.015]))
    elif form == "sample_hold_valve":
        lag.update(code=4, q=np.array([a, d["delay_share"] * a, d["fill_tau"], d["phase_ms"]]))
    elif form in ("deflation_branch_fast", "deflation_branch_slow"):
        M.extra.append((a * mat["G1"], a * mat["K1"], d["tau"], 1.0, 1))
    elif form == "overstress_sign_tau":
        M.mat["kind1"] = 2
        M.mat["ratio1"] = 1.0 + a
    elif form == "yeoh":
        lam = 1 + d["e_ref"]
        M.stiff = (1, np.array([a, d["c2_share"], lam * lam + 2 / lam - 3]))
    elif form == "ogden":
        M.stiff = (2, np.array([a, d["alpha"], 0.0]))
    elif form == "arruda_boyce":
        M.stiff = (3, np.array([1.0 / a, 0.0, 0.0]))
    elif form == "offset_gain":
        sens.update(offset=d["sign"] * a, gain=d["gain_error"])
    elif form == "offset_eccentric":
        sens.update(offset=d["sign"] * a, gain=0.0, ecc=d["ecc_share"] * a, ecc_phase=d["ecc_phase"])
    elif form == "dissipation_heat":
        M.therm = (1, np.array([a, d["tau_th"], aux["D_ref"], 0.0, 0.0]))
    elif form == "valve_heat":
        M.therm = (2, np.array([a, d["tau_th"], 0.0, d["tau_shift"], d["p_ref"]]))
    elif form == "conduction_warmup":
        M.therm = (3, np.zeros(5))
        sens["therm_sched"] = (a, d["tau_th"])
    elif form == "ratchet_set":
        M.creep = (1, np.array([a, d["s_ref_share"] * mat["K_inf"], d["n"]]))
    elif form == "gravity_tip_load":
        M.load = (1, np.array([a, d["phi"]]))
    else:
        raise ValueError(form)


class MuscleX(Muscle):
    """Muscle whose first branch may be made direction-dependent (overstress_sign_tau)."""

    def branches(self):
        br, kind = super().branches()
        if self.mat.get("kind1"):
            kind[0] = self.mat["kind1"]
            br[0, 3] = self.mat["ratio1"]
        return br, kind


# ----------------------------------------------------------------------------------------------- one log
def sim_logs(S, logs, mats, effects, amps, aux, nominal=False):
    """Noise-free sensor readings (deg) at the log instants for every log, simulated in recording order."""
    m = int(round(1.0 / (S["fs"] * DT_SIM)))
    ev = 0.0
    out = []
    for ps_bar, mat in zip(logs, mats):
        M = MuscleX(S["geom"], S["mat"] if nominal else mat)
        lag = {"code": 0, "q": np.zeros(4)}
        sens = {"offset": 0.0, "gain": 0.0, "ecc": 0.0, "ecc_phase": 0.0}
        for (form, d), a in zip(effects, amps):
            apply_effect(form, a, d, S, M, lag, sens, aux)
        M.ev = ev
        ps = ps_bar * 1e5
        pint = _lag(ps, lag["code"], lag["q"])[::int(round(DT_SIM / DT_FINE))]
        t = np.arange(len(pint)) * DT_SIM
        sched = None
        if "therm_sched" in sens:
            amp, tau = sens["therm_sched"]
            sched = 1.0 - amp * (1.0 - erfcx(np.sqrt(t / tau)))
        beta = np.degrees(M.run(t, pint, sched))
        ev = M.ev_out
        b = beta[::m]
        reading = sens["offset"] + (1 + sens["gain"]) * b
        if sens["ecc"]:
            ph = sens["ecc_phase"]
            reading = reading + sens["ecc"] * (np.sin(np.radians(b) + ph) - math.sin(ph))
        out.append(reading)
    return out


def dissipation_ref(S, logs, mats):
    """Mean dissipated power density of the base muscle over the given logs (scale of dissipation_heat)."""
    D = []
    for ps_bar, mat in zip(logs, mats):
        M = MuscleX(S["geom"], mat)
        p = (ps_bar * 1e5)[::int(round(DT_SIM / DT_FINE))]
        t = np.arange(len(p)) * DT_SIM
        beta = M.run(t, p)
        # dashpot power from the branch's overstress, recomputed from the angle history
        from core import _F, _u3
        geo = S["geom"]
        u3 = np.array([_u3(b, geo["R0"], geo["l0"], geo["n"]) for b in beta])
        F = np.array([_F(u, geo["R0"], geo["l0"], geo["n"]) for u in u3])
        e1, e2 = F - 1, u3 / geo["R0"]
        a = math.exp(-DT_SIM / mat["tau1"])
        h1 = np.zeros_like(e1)
        h2 = np.zeros_like(e2)
        for k in range(1, len(e1)):
            h1[k] = a * h1[k - 1] + e1[k] - e1[k - 1]
            h2[k] = a * h2[k - 1] + e2[k] - e2[k - 1]
        D.append((mat["K1"] * (h1 + h2) ** 2 + 2 * mat["G1"] * (h1 ** 2 + h2 ** 2)) / mat["tau1"])
    return float(np.mean(np.concatenate(D)))


def effect_rms(S, logs, mats, effects, amps, aux, base, ho_idx):
    sims = sim_logs(S, logs, mats, effects, amps, aux)
    d = np.concatenate([sims[i] - base[i] for i in ho_idx])
    return float(np.sqrt(np.mean(d * d))), sims


def scale_effect(S, logs, mats, eff, a0, aux, base, ho_idx, target):
    """Amplitude at which the effect alone gives held-out RMS deviation `target` (deg); secant in log-log."""
    a, la, lf = a0, None, None
    best = None
    for _ in range(16):
        f, _ = effect_rms(S, logs, mats, [eff], [a], aux, base, ho_idx)
        if best is None or abs(math.log(max(f, 1e-9) / target)) < abs(math.log(max(best[1], 1e-9) / target)):
            best = (a, f)
        if abs(f / target - 1) < 0.02:
            break
        lf_new = math.log(max(f, 1e-9))
        if la is not None and abs(lf_new - lf) > 1e-6 and abs(math.log(a) - la) > 1e-9:
            slope = (lf_new - lf) / (math.log(a) - la)
            slope = min(max(slope, 0.2), 4.0)
        else:
            slope = 1.0
        la, lf = math.log(a), lf_new
        step = (math.log(target) - lf_new) / slope
        step = max(min(step, 2.5), -2.5)
        a = math.exp(la + step)
    return best


# ----------------------------------------------------------------------------------------------- files
def fmt_rows(cols, fmts, sep, dec_comma=False):
    lines = []
    for row in zip(*cols):
        s = sep.join(f % v for f, v in zip(fmts, row))
        if dec_comma:
            s = s.replace(".", ",")
        lines.append(s)
    return lines


def write_log(path, style, S, t, p_gauge_bar, angle, temp, meta):
    """Write one log as a lab would export it. Returns the file name."""
    syn = f"# synthetic: made by {GEN} (independent generator) seed {meta['seed']} - not measured data"
    head = [syn, f"# muscle: {meta['muscle']}", f"# recorded: {meta['recorded']}"]
    enc = "utf-8"
    newline = "\n"
    if style == "a_csv":
        name = path.with_suffix(".csv")
        lines = head + ["# pressure_reference: absolute", "time_s,pressure_bar,angle_deg"]
        lines += fmt_rows([t, p_gauge_bar + ATM / 1e5, angle], ["%.1f", "%.4f", "%.3f"], ",")
    elif style == "a_semicolon_de":
        name = path.with_suffix(".csv")
        lines = head + ["# pressure_reference: absolute", "Zeit (s);Druck (bar);Winkel (deg)"]
        lines += fmt_rows([t, p_gauge_bar + ATM / 1e5, angle], ["%.1f", "%.4f", "%.3f"], ";", dec_comma=True)
        newline = "\r\n"
    elif style == "a_tab_bar_a":
        name = path.with_suffix(".txt")
        lines = head + ["Time (s)\tPressure (bar(a))\tAngle (deg)\tTemperature (°C)"]
        lines += fmt_rows([t, p_gauge_bar + ATM / 1e5, angle, temp], ["%.1f", "%.4f", "%.3f", "%.2f"], "\t")
    elif style == "b_csv":
        name = path.with_suffix(".csv")
        lines = head + ["# pressure_reference: gauge", "time_s,pressure_kpa,angle_deg,temperature_c"]
        lines += fmt_rows([t, p_gauge_bar * 100, angle, temp], ["%.2f", "%.2f", "%.3f", "%.2f"], ",")
    elif style == "b_semicolon_cp1252":
        name = path.with_suffix(".csv")
        lines = head + ["# Pressure Reference: Gauge", "Time [s];Pressure [kPa];Angle [°];Temperature [°C]"]
        lines += fmt_rows([t, p_gauge_bar * 100, angle, temp], ["%.2f", "%.2f", "%.3f", "%.2f"], ";",
                          dec_comma=True)
        enc = "cp1252"
        newline = "\r\n"
    elif style == "b_units_row":
        name = path.with_suffix(".tsv")
        lines = head + ["# pressure_reference: gauge", "Time\tPressure\tAngle\tTemperature", "s\tkPa\tdeg\tC"]
        lines += fmt_rows([t, p_gauge_bar * 100, angle, temp], ["%.2f", "%.2f", "%.3f", "%.2f"], "\t")
    elif style == "c_instrument_g":
        name = path.with_suffix(".csv")
        lines = [syn, "Instrument: BPM bench DAQ 4ch", f"Muscle: {meta['muscle']}", f"Recorded: {meta['recorded']}",
                 "Sample Rate: 50 Hz", "Pressure Reference: Gauge", "Time (ms),P [psi],Angle (deg),Temp (C)"]
        lines += fmt_rows([np.round(t * 1000), p_gauge_bar * 1e5 / PSI, angle, temp],
                          ["%.0f", "%.3f", "%.3f", "%.2f"], ",")
    elif style == "c_psia_tab":
        name = path.with_suffix(".txt")
        lines = head + ["Time (ms)\tPressure (psia)\tAngle (deg)"]
        lines += fmt_rows([np.round(t * 1000), (p_gauge_bar * 1e5 + ATM) / PSI, angle], ["%.0f", "%.3f", "%.3f"],
                          "\t")
    elif style == "c_psig_semicolon":
        name = path.with_suffix(".csv")
        lines = head + ["Time (ms);P [psig];Angle (deg);Temp (C)"]
        lines += fmt_rows([np.round(t * 1000), p_gauge_bar * 1e5 / PSI, angle, temp],
                          ["%.0f", "%.3f", "%.3f", "%.2f"], ";")
    else:
        raise ValueError(style)
    name.write_bytes((newline.join(lines) + newline).encode(enc))
    return name.name


def geometry_yaml(g):
    return {"th_mm": round(g["th"] * 1e3, 4), "alpha0_deg": round(math.degrees(g["alpha0"]), 4),
            "R0_mm": round(g["R0"] * 1e3, 4), "l0_mm": round(g["l0"] * 1e3, 4), "n": g["n"]}


# ----------------------------------------------------------------------------------------------- one case
def make_case(set_name, spec, seed):
    t0 = time.time()
    case, truth, forms, oof, var_override, style = spec
    S = dict(SETS[set_name])
    rng = np.random.default_rng(seed)
    var = var_override if var_override is not None else S["var"]
    sigma = float(rng.uniform(0.1, 0.3))
    phi = float(rng.uniform(0.5, 0.85)) if S["noise"] == "ar1" else 0.0
    # protocols: four or five fitting logs, one or two held-out logs
    fit_kinds = ["tri_rates", "stairs", "sines", "tri_amps", "ramp_hold"]
    rng.shuffle(fit_kinds)
    nfit = int(rng.integers(4, 6))
    fit_kinds = fit_kinds[:nfit]
    if "stairs" not in fit_kinds and "ramp_hold" not in fit_kinds:
        fit_kinds[-1] = "stairs"
    nho = int(rng.integers(1, 3))
    logs = [make_protocol(k, rng, S) for k in fit_kinds]
    logs += [make_protocol("mixed", rng, S, long=(i == 0)) for i in range(nho)]
    ho_idx = list(range(nfit, nfit + nho))
    # log-to-log variation of the material constants (lognormal, sd = var)
    mats = []
    for _ in logs:
        m = dict(S["mat"])
        for k in ("G_inf", "K_inf", "G1", "K1", "tau1"):
            f = math.exp(rng.normal(0.0, var))
            if k in VARY:
                m[k] *= f
        mats.append(m)
    # effects: shape constants, then amplitude scaled to a drawn held-out ratio
    base = sim_logs(S, logs, mats, [], [], {})
    aux = {}
    if "dissipation_heat" in forms:
        aux["D_ref"] = dissipation_ref(S, [logs[i] for i in ho_idx], [mats[i] for i in ho_idx])
    effects, amps, targets, achieved_alone = [], [], [], []
    for form in forms:
        d, a0 = draw_effect(form, rng, S)
        R = float(rng.uniform(2.0, 3.0) if len(forms) > 1 else rng.uniform(2.0, 4.0))
        target = sigma * math.sqrt(R * R - 1)
        a, f = scale_effect(S, logs, mats, (form, d), a0, aux, base, ho_idx, target)
        effects.append((form, d))
        amps.append(a)
        targets.append(R)
        achieved_alone.append(math.sqrt(1 + (f / sigma) ** 2))
    sims = sim_logs(S, logs, mats, effects, amps, aux) if effects else base
    nominal = sim_logs(S, logs, mats, [], [], {}, nominal=True)
    d_eff = np.concatenate([sims[i] - base[i] for i in ho_idx])
    d_all = np.concatenate([sims[i] - nominal[i] for i in ho_idx])
    ratio = math.sqrt(1 + np.mean(d_eff ** 2) / sigma ** 2)
    ratio_var = math.sqrt(1 + np.mean(d_all ** 2) / sigma ** 2)
    # sensor noise, pressure transducer noise, ambient temperature column
    cdir = OUT / "sets" / set_name / case
    cdir.mkdir(parents=True, exist_ok=True)
    for old in cdir.iterdir():
        old.unlink()
    m = int(round(1.0 / (S["fs"] * DT_FINE)))
    files_fit, files_ho = [], []
    hour = 9.0
    for i, (ps, reading) in enumerate(zip(logs, sims)):
        p_log = ps[::m][: len(reading)]
        n = len(reading)
        t = np.arange(n) / S["fs"]
        w = rng.normal(0.0, 1.0, n)
        if phi:
            e = np.empty(n)
            e[0] = w[0] * sigma
            c = sigma * math.sqrt(1 - phi * phi)
            for k in range(1, n):
                e[k] = phi * e[k - 1] + c * w[k]
        else:
            e = sigma * w
        angle = reading + e
        p_noisy = p_log + rng.normal(0.0, 0.0006, n)
        temp = 22.5 + 0.4 * math.sin(hour) + rng.normal(0, 0.03, n) + 0.002 * t / 60.0
        ho = i in ho_idx
        stem = (f"heldout_{i - nfit + 1}" if ho else f"run{i + 1:02d}_{fit_kinds[i]}")
        meta = dict(seed=seed, muscle=("paper BPM" if set_name == "A" else f"bench muscle {set_name}"),
                    recorded=f"session 1 run {i + 1} {int(hour):02d}h{int((hour % 1) * 60):02d}")
        name = write_log(cdir / stem, style, S, t, p_noisy, angle, temp, meta)
        (files_ho if ho else files_fit).append(name)
        hour += len(ps) * DT_FINE / 3600 + 0.05
    if S["config"]:
        cfg = {"model": {"geometry": geometry_yaml(S["geom"])}}
        (cdir / "case.yaml").write_text(
            f"# synthetic: made by {GEN} (independent generator) seed {seed}\n"
            + yaml.safe_dump(cfg, sort_keys=False))
    answer = {
        "case": f"{set_name}/{case}", "seed": seed, "generator": GEN,
        "truth": list(truth), "forms": list(forms), "out_of_catalogue": oof,
        "kind": ("pair" if len(truth) == 2 else "out_of_catalogue" if oof else "null" if not forms else "single"),
        "sigma_deg": round(sigma, 4), "noise": ("AR(1) phi=%.3f (sigma is the marginal sd)" % phi) if phi else "white",
        "variation_sd": var, "sample_rate_hz": S["fs"],
        "target_ratio_alone": [round(r, 3) for r in targets],
        "achieved_ratio_alone": [round(r, 3) for r in achieved_alone],
        "achieved_ratio": round(ratio, 3),
        "ratio_incl_variation_vs_nominal": round(ratio_var, 3),
        "ratio_definition": "sqrt(sigma^2 + mean_heldout(reading_with_effects - reading_without)^2)/sigma, same "
                            "per-log constants; the _vs_nominal one against the nominal constants",
        "amplitudes": [float(a) for a in amps],
        "effect_params": [{k: (float(v) if isinstance(v, (float, np.floating)) else v) for k, v in d.items()}
                          for _, d in effects],
        "fit_logs": files_fit, "holdout_logs": files_ho,
        "config": "case.yaml" if S["config"] else None,
        "seconds": round(time.time() - t0, 1),
    }
    adir = OUT / "answers" / set_name
    adir.mkdir(parents=True, exist_ok=True)
    (adir / f"{case}.yaml").write_text(yaml.safe_dump(answer, sort_keys=False))
    return f"{set_name}/{case}: {forms or 'null'} ratio {ratio:.2f} (targets {targets}) {time.time() - t0:.1f}s"


def _job(args):
    return make_case(*args)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--only", default="")
    a = ap.parse_args()
    only = set(x for x in a.only.split(",") if x)
    jobs = []
    for si, (sn, cases) in enumerate(CASES.items()):
        for ci, spec in enumerate(cases):
            if only and spec[0] not in only:
                continue
            jobs.append((sn, spec, BASE_SEED + 100 * si + ci))
    # compile the kernels once before forking
    MuscleX(PAPER_GEOM, PAPER_FIT).run(np.arange(3) * 0.1, np.array([1e4, 2e4, 3e4]))
    _lag(np.zeros(3), 1, np.array([0.1, 1.5e5, 1.0, 1.0]))
    t0 = time.time()
    if a.jobs > 1:
        with get_context("fork").Pool(a.jobs) as pool:
            for msg in pool.imap_unordered(_job, jobs):
                print(msg, flush=True)
    else:
        for j in jobs:
            print(_job(j), flush=True)
    print(f"done in {time.time() - t0:.1f} s")


if __name__ == "__main__":
    main()
