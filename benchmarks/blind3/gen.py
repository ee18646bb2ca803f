"""blind3 generator: three synthetic test sets for `bpmid discover` (see README.md here).

    .venv/bin/python benchmarks/blind3/gen.py [--jobs 2] [--only 1:3,2:9]

Writes logs to out/blind3/sets/set{S}/case{NN}/ and answers to out/blind3/answers/set{S}_case{NN}.yaml.
Seeds: 73000 + 100 * set + case index. All data are SYNTHETIC.
"""
import argparse
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import core3 as C  # noqa: E402

ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
OUT = os.path.join(ROOT, "out", "blind3")
ATM = C.ATM
DEG = 180.0 / math.pi

# ------------------------------------------------------------------ muscles
MUSCLES = {
    1: dict(geom=dict(C.PAPER_GEOM), mat=dict(C.PAPER_FIT), fs=10.0, fine=100.0),
    2: dict(geom=dict(th=0.0024, alpha0=math.radians(27.0), R0=0.0145, l0=0.165, n=6.6),
            mat=dict(G_inf=11000.0, K_inf=7.5e6, G1=20000.0, K1=15.0e6, tau1=0.30), fs=20.0, fine=100.0),
    3: dict(geom=dict(th=0.0030, alpha0=math.radians(32.0), R0=0.0195, l0=0.235, n=8.9),
            mat=dict(G_inf=8000.0, K_inf=5.6e6, G1=16000.0, K1=11.0e6, tau1=0.16), fs=50.0, fine=200.0),
}

# (catalogue id or None, form)
SETS = {
    1: [("single", [("second_relaxation", "sr_mittag_leffler")]),
        ("single", [("braid_friction", "bf_lugre")]),
        ("single", [("pressure_lag", "pl_choked_orifice")]),
        ("single", [("asymmetric_relaxation", "ar_rate_viscosity_deflating")]),
        ("single", [("strain_stiffening", "ss_gent")]),
        ("single", [("angle_offset", "ao_remount_per_log")]),
        ("single", [("thermal_softening", "ts_ambient_ramp")]),
        ("null", [])],
    2: [("single", [("second_relaxation", "sr_two_slow_branches")]),
        ("single", [("braid_friction", "bf_dahl")]),
        ("single", [("pressure_lag", "pl_variable_transport_delay")]),
        ("single", [("asymmetric_relaxation", "ar_deflation_kelvin_voigt")]),
        ("single", [("strain_stiffening", "ss_fibre_lockup")]),
        ("single", [("angle_offset", "ao_encoder_zero_scale")]),
        ("single", [("thermal_softening", "ts_heating_cycling_amplitude")]),
        ("single", [("strain_stiffening", "ss_fung")]),
        ("pair", [("second_relaxation", "sr_two_slow_branches"), ("pressure_lag", "pl_variable_transport_delay")]),
        ("ooc", [(None, "ooc_mullins")]),
        ("null", [])],
    3: [("single", [("second_relaxation", "sr_eyring_branch")]),
        ("single", [("braid_friction", "bf_bouc_wen")]),
        ("single", [("pressure_lag", "pl_adiabatic_fill")]),
        ("single", [("asymmetric_relaxation", "ar_tanh_tau")]),
        ("single", [("strain_stiffening", "ss_fung")]),
        ("single", [("angle_offset", "ao_offset_tilt")]),
        ("single", [("thermal_softening", "ts_ambient_sinusoid")]),
        ("single", [("pressure_lag", "pl_choked_orifice")]),
        ("pair", [("braid_friction", "bf_bouc_wen"), ("thermal_softening", "ts_ambient_sinusoid")]),
        ("ooc", [(None, "ooc_air_leak")]),
        ("null", [])],
}
VARIATION = {1: 0.01, 2: 0.015, 3: 0.02}
NULL_VARIATION = {1: 0.01, 2: 0.04, 3: 0.05}


# ------------------------------------------------------------------ protocols (fractions 0..1 of the range)
def _pl(points):
    t = np.array([p[0] for p in points], float)
    u = np.array([p[1] for p in points], float)
    return t, u


def proto_tri_rates(rng):
    pts = [(0, 0.0)]
    t = 3.0
    pts.append((t, 0.0))
    for per in rng.permutation([4.0, 8.0, 14.0, 24.0]):
        for _ in range(2):
            t += per / 2; pts.append((t, 1.0))
            t += per / 2; pts.append((t, 0.0))
    t += 5; pts.append((t, 0.0))
    return _pl(pts), "triangles at several rates"


def proto_tri_amps(rng):
    pts = [(0, 0.0), (3.0, 0.0)]
    t = 3.0
    per = rng.uniform(8, 12)
    for a in rng.permutation([0.3, 0.55, 0.8, 1.0]):
        for _ in range(2):
            t += per / 2; pts.append((t, a))
            t += per / 2; pts.append((t, 0.0))
    t += 8; pts.append((t, 0.0))
    return _pl(pts), "triangles at several amplitudes"


def proto_sines(rng, fs):
    fmax = min(0.25, fs / 40.0)
    freqs = rng.uniform(0.04, fmax, 3)
    segs = []
    t0 = 0.0
    pts_t, pts_u = [], []
    for f in freqs:
        ncyc = max(2, int(round(rng.uniform(25, 40) * f)))
        amp = rng.uniform(0.5, 1.0)
        tt = np.arange(0, ncyc / f, 0.05)
        uu = amp * 0.5 * (1 - np.cos(2 * np.pi * f * tt))
        pts_t.append(t0 + tt); pts_u.append(uu)
        t0 += ncyc / f
    pts_t.append(np.array([t0 + 0.05, t0 + 6])); pts_u.append(np.array([0.0, 0.0]))
    return (np.concatenate(pts_t) + 2.0, np.concatenate(pts_u)), "sines at %s Hz" % ", ".join("%.3f" % f for f in freqs)


def proto_steps(rng):
    pts = [(0, 0.0), (3, 0.0)]
    t = 3.0
    for _ in range(int(rng.integers(6, 9))):
        lev = rng.uniform(0.0, 1.0)
        t += 0.15; pts.append((t, lev))
        t += rng.uniform(10, 25); pts.append((t, lev))
    t += 0.15; pts.append((t, 0.0)); t += 15; pts.append((t, 0.0))
    return _pl(pts), "regulator steps with 10-25 s holds"


def proto_ramps(rng):
    pts = [(0, 0.0), (3, 0.0)]
    t = 3.0
    u = 0.0
    for _ in range(int(rng.integers(4, 6))):
        lev = rng.uniform(0.1, 1.0) if u < 0.5 else rng.uniform(0.0, 0.5)
        t += rng.uniform(2, 8); pts.append((t, lev))
        t += rng.uniform(25, 50); pts.append((t, lev))
        u = lev
    t += 4; pts.append((t, 0.0)); t += 20; pts.append((t, 0.0))
    return _pl(pts), "ramps with 25-50 s holds"


def proto_mixed(rng, fs):
    parts = []
    kinds = rng.permutation(["tri", "sine", "step", "ramp"])[: int(rng.integers(3, 5))]
    t0 = 0.0
    T, U = [np.array([0.0, 2.0])], [np.array([0.0, 0.0])]
    t0 = 2.0
    for k in kinds:
        if k == "tri":
            per = rng.uniform(5, 16); a = rng.uniform(0.5, 1.0)
            tt = np.array([0, per / 2, per, 1.5 * per, 2 * per]); uu = np.array([0, a, 0, a, 0])
        elif k == "sine":
            f = rng.uniform(0.05, min(0.2, fs / 40)); n = max(2, int(20 * f) + 2)
            tt = np.arange(0, n / f, 0.05); uu = rng.uniform(0.5, 1) * 0.5 * (1 - np.cos(2 * np.pi * f * tt))
        elif k == "step":
            l1, l2 = rng.uniform(0.3, 1.0, 2)
            h1, h2 = rng.uniform(10, 20, 2)
            tt = np.array([0, 0.15, 0.15 + h1, 0.3 + h1, 0.3 + h1 + h2, 0.45 + h1 + h2])
            uu = np.array([0, l1, l1, l2 * l1, l2 * l1, 0])
        else:
            l1 = rng.uniform(0.5, 1.0); r = rng.uniform(2, 6); h = rng.uniform(20, 40)
            tt = np.array([0, r, r + h, 2 * r + h]); uu = np.array([0, l1, l1, 0])
        T.append(t0 + tt[1:]); U.append(uu[1:])
        t0 += tt[-1]
        T.append(np.array([t0 + 4.0])); U.append(np.array([0.0]))
        t0 += 4.0
        parts.append(str(k))
    T.append(np.array([t0 + 6])); U.append(np.array([0.0]))
    return (np.concatenate(T), np.concatenate(U)), "mixed: " + " + ".join(parts)


# ------------------------------------------------------------------ case construction
def pressure_range(geom, mat):
    """Gauge pressures (Pa) that hold the relaxed muscle at about 8 and 115 degrees."""
    from core import relaxed_pressure
    plo = relaxed_pressure(geom, mat, math.radians(8.0))[0]
    phi = relaxed_pressure(geom, mat, math.radians(115.0))[0]
    return plo, phi


def regulator(t1k, tp, up, plo, phi, tau=0.06):
    u = np.interp(t1k, tp, up)
    p = plo + (phi - plo) * u
    a = math.exp(-1e-3 / tau)
    out = np.empty_like(p)
    y = p[0]
    for k in range(len(p)):
        y = p[k] + (y - p[k]) * a
        out[k] = y
    return out


def make_logs(rng, fs, plo, phi):
    builders = [lambda: proto_tri_rates(rng), lambda: proto_tri_amps(rng), lambda: proto_sines(rng, fs),
                lambda: proto_steps(rng), lambda: proto_ramps(rng)]
    names = ["fit_triangles_rates", "fit_triangles_amplitudes", "fit_sines", "fit_steps", "fit_ramps_holds"]
    nfit = int(rng.integers(4, 6))
    keep = sorted(rng.choice(5, nfit, replace=False)) if nfit < 5 else list(range(5))
    if nfit == 4 and 4 not in keep:    # always keep a long-hold log
        keep[rng.integers(0, 4)] = 4
        keep = sorted(set(keep))
    logs = []
    for i in keep:
        (tp, up), desc = builders[i]()
        logs.append(dict(name=names[i], role="fit", tp=tp, up=up, desc=desc))
    for j in range(int(rng.integers(1, 3))):
        (tp, up), desc = proto_mixed(rng, fs)
        logs.append(dict(name="holdout_mixed_%d" % (j + 1), role="holdout", tp=tp, up=up, desc=desc))
    # amplitude level per log (not every log uses the full range)
    for lg in logs:
        dur = lg["tp"][-1]
        if dur < 60:   # stretch: repeat the protocol until at least 60 s
            reps = int(math.ceil(60 / dur))
            tps = [lg["tp"] + r * dur for r in range(reps)]
            ups = [lg["up"]] * reps
            tp = np.concatenate([tps[0]] + [x[1:] for x in tps[1:]])
            up = np.concatenate([ups[0]] + [x[1:] for x in ups[1:]])
            lg["tp"], lg["up"] = tp, up
        lg["tp"] = lg["tp"][: np.searchsorted(lg["tp"], 300.0, side="right")]
        lg["up"] = lg["up"][: len(lg["tp"])]
        lg["dur"] = float(min(lg["tp"][-1], 300.0))
        lg["t1k"] = np.arange(0, round(lg["dur"] * 1000) + 1) * 1e-3
        lg["plog"] = regulator(lg["t1k"], lg["tp"], lg["up"], plo, phi)
    # session clock: logs recorded one after another with rests in between
    ts = 0.0
    for lg in logs:
        lg["t_session0"] = ts
        ts += lg["dur"] + rng.uniform(30, 120)
    return logs


def effect_shape(form, rng, ctx):
    """Draw an effect's fixed shape constants (everything but its size knob s)."""
    e1max = ctx["e1max"]
    if form == "sr_mittag_leffler":
        return dict(alpha=rng.uniform(0.4, 0.6), tau0=rng.uniform(5, 15), s0=0.2)
    if form == "sr_two_slow_branches":
        return dict(tau_a=rng.uniform(2, 5), tau_b=rng.uniform(40, 100), ratio_b=rng.uniform(0.5, 0.9), s0=0.15)
    if form == "sr_eyring_branch":
        return dict(tau=rng.uniform(8, 20), h0=rng.uniform(0.15, 0.3) * e1max, s0=0.2)
    if form == "bf_lugre":
        return dict(presliding_rad=rng.uniform(0.006, 0.015), stribeck=rng.uniform(1.2, 1.6),
                    vs=rng.uniform(0.02, 0.08), s0=2000.0)
    if form == "bf_dahl":
        return dict(char_rad=rng.uniform(0.01, 0.03), s0=2000.0)
    if form == "bf_bouc_wen":
        return dict(char_strain=rng.uniform(0.04, 0.1) * e1max, s0=1e5)
    if form == "pl_choked_orifice":
        return dict(bcrit=rng.uniform(0.25, 0.45), s0=0.05)
    if form == "pl_variable_transport_delay":
        return dict(expo=rng.uniform(1.0, 2.0), tau_v=rng.uniform(0.01, 0.03), s0=0.1)
    if form == "pl_adiabatic_fill":
        return dict(tau_h=rng.uniform(0.5, 2.0), gam=1.4, s0=0.1)
    if form == "ar_rate_viscosity_deflating":
        return dict(rate_ref=0.3 * ctx["e1rate"], s0=1.0)
    if form == "ar_deflation_kelvin_voigt":
        return dict(s0=1e5)
    if form == "ar_tanh_tau":
        return dict(rate_ref=0.3 * ctx["e1rate"], s0=0.5)
    if form == "ss_gent":
        return dict(s0=2.0)
    if form == "ss_fibre_lockup":
        return dict(el=rng.uniform(0.5, 0.7) * e1max, w=0.1 * e1max, s0=0.5)
    if form == "ss_fung":
        return dict(s0=2.0)
    if form == "ao_remount_per_log":
        return dict(sign=float(rng.choice([-1, 1])), spread=0.15, s0=0.5)
    if form == "ao_encoder_zero_scale":
        return dict(sign=float(rng.choice([-1, 1])), gain=float(rng.choice([-1, 1])) * rng.uniform(0.002, 0.004), s0=0.5)
    if form == "ao_offset_tilt":
        return dict(sign=float(rng.choice([-1, 1])), tilt_deg=rng.uniform(4, 8), s0=0.5)
    if form == "ts_ambient_ramp":
        return dict(s0=0.05)
    if form == "ts_heating_cycling_amplitude":
        return dict(tau_h=rng.uniform(60, 150), s0=0.2)
    if form == "ts_ambient_sinusoid":
        return dict(period=rng.uniform(600, 1200), phase=rng.uniform(0, 2 * np.pi), s0=0.05)
    if form == "ooc_mullins":
        return dict(width=rng.uniform(0.25, 0.4), s0=0.1)
    if form == "ooc_air_leak":
        return dict(tau_in=rng.uniform(0.002, 0.004), bcrit=0.4, s0=5.0)
    raise KeyError(form)


def simulate(case, lg, effects, noise_free=True):
    """Noise-free angle (deg) at the log's sample times, for this log's constants, with the effects given
    as a list of (form, shape, s)."""
    M = case["muscle"]
    geom = M["geom"]
    mat = dict(lg["mat"])
    fine = M["fine"]
    step = int(round(1000 / fine))
    t1k = lg["t1k"]
    plog = lg["plog"]
    pint = plog
    extra = []        # (G, K, tau, c3, c4, kind)
    stiff = (0, np.zeros(4))
    sched_f = None
    therm = (0, np.zeros(3))
    kv = 0.0
    fric = (0, np.zeros(5))
    sensor = []
    mullins = None
    for form, sh, s in effects:
        if form == "sr_mittag_leffler":
            taus, w = C.ml_spectrum(sh["alpha"], sh["tau0"])
            for tj, wj in zip(taus, w):
                extra.append((s * wj * mat["G_inf"], s * wj * mat["K_inf"], tj, 0, 1, 0))
        elif form == "sr_two_slow_branches":
            extra.append((s * mat["G_inf"], s * mat["K_inf"], sh["tau_a"], 0, 1, 0))
            extra.append((s * sh["ratio_b"] * mat["G_inf"], s * sh["ratio_b"] * mat["K_inf"], sh["tau_b"], 0, 1, 0))
        elif form == "sr_eyring_branch":
            extra.append((s * mat["G_inf"], s * mat["K_inf"], sh["tau"], sh["h0"], 1, 1))
        elif form == "bf_lugre":
            Fc = s
            fric = (1, np.array([Fc / sh["presliding_rad"], Fc, sh["stribeck"] * Fc, sh["vs"], 0.0]))
        elif form == "bf_dahl":
            fric = (2, np.array([s / sh["char_rad"], s, 0, 0, 0]))
        elif form == "bf_bouc_wen":
            fric = (3, np.array([s, 1.0 / sh["char_strain"], 0, 0, 0]))
        elif form == "pl_choked_orifice":
            pint = C.pneu_orifice(t1k, pint, s, sh["bcrit"])
        elif form == "pl_variable_transport_delay":
            pint = C.pneu_var_delay(t1k, pint, s, sh["expo"], sh["tau_v"])
        elif form == "pl_adiabatic_fill":
            pint = C.pneu_adiabatic(t1k, pint, s, sh["tau_h"], sh["gam"])
        elif form == "ooc_air_leak":
            pint = C.pneu_leak(t1k, pint, sh["tau_in"], s, sh["bcrit"])
        elif form == "ar_rate_viscosity_deflating":
            mat["_kind1"] = (2, s, sh["rate_ref"])
        elif form == "ar_tanh_tau":
            mat["_kind1"] = (3, s, sh["rate_ref"])
        elif form == "ar_deflation_kelvin_voigt":
            kv = s
        elif form == "ss_gent":
            stiff = (1, np.array([1.0 / s, 0, 0, 0]))
        elif form == "ss_fibre_lockup":
            stiff = (2, np.array([s, sh["el"], sh["w"], sh["w"]]))
        elif form == "ss_fung":
            stiff = (3, np.array([s, 0, 0, 0]))
        elif form == "ts_ambient_ramp":
            ts = lg["t_session0"] + t1k
            sched_f = (sched_f if sched_f is not None else 1.0) * (1.0 - s * ts / case["session_len"])
        elif form == "ts_ambient_sinusoid":
            ts = lg["t_session0"] + t1k
            sched_f = (sched_f if sched_f is not None else 1.0) * (
                1.0 - s * np.sin(2 * np.pi * ts / sh["period"] + sh["phase"]))
        elif form == "ts_heating_cycling_amplitude":
            therm = (1, np.array([s, sh["tau_h"], case["phi"] - case["plo"]]))
        elif form == "ooc_mullins":
            mullins = (s, sh["width"])
        elif form.startswith("ao_"):
            sensor.append((form, sh, s))
        else:
            raise KeyError(form)
    if mullins is not None:
        from scipy.special import erf
        pmax = np.maximum.accumulate(pint)
        rng_p = case["phi"] - case["plo"]
        m = 1.0 - mullins[0] * erf(np.maximum(0.0, pmax - pint) / (mullins[1] * rng_p))
        sched_f = (sched_f if sched_f is not None else 1.0) * m
    tf = t1k[::step]
    pf = pint[::step]
    sched = np.ones(len(tf)) if sched_f is None else np.asarray(sched_f, float)[::step] * np.ones(len(tf))
    rows = [(mat["G1"], mat["K1"], mat["tau1"], 0.0, 1.0, 0)]
    if "_kind1" in mat:
        kcode, a, rr = mat["_kind1"]
        rows = [(mat["G1"], mat["K1"], mat["tau1"], a, rr, kcode)]
    rows += extra
    br = np.array([r[:5] for r in rows], float)
    kind = np.array([r[5] for r in rows], np.int64)
    geo = np.array([geom["th"], geom["alpha0"], geom["R0"], geom["l0"], geom["n"]], float)
    b = C.simulate3(tf, pf, geo, np.array([mat["G_inf"], mat["K_inf"]]), br, kind, stiff[0],
                    np.asarray(stiff[1], float), sched, therm[0], np.asarray(therm[1], float), float(kv),
                    fric[0], np.asarray(fric[1], float), 0.0)
    sub = int(round(fine / M["fs"]))
    ang = b[::sub] * DEG
    for form, sh, s in sensor:
        if form == "ao_remount_per_log":
            ang = ang + sh["sign"] * s * lg["remount"]
        elif form == "ao_encoder_zero_scale":
            ang = ang * (1.0 + sh["gain"]) + sh["sign"] * s
        elif form == "ao_offset_tilt":
            br_ = ang / DEG
            ang = np.degrees(np.arctan2(np.sin(br_) * math.cos(math.radians(sh["tilt_deg"])), np.cos(br_))) \
                + sh["sign"] * s
            ang = np.where(ang < -90, ang + 360, ang)
    return ang


def heldout_gap(case, effects):
    """RMS difference (deg) between the effect model and the true base model on the held-out logs."""
    num, den = 0.0, 0
    for lg in case["logs"]:
        if lg["role"] != "holdout":
            continue
        a = simulate(case, lg, effects)
        b0 = lg["_base"]
        num += float(np.sum((a - b0) ** 2)); den += len(a)
    return math.sqrt(num / den)


def scale_effect(case, form, sh, R, sigma):
    target = sigma * math.sqrt(R * R - 1.0)
    s = sh["s0"]
    hist = []
    d = heldout_gap(case, [(form, sh, s)])
    hist.append((s, d))
    for it in range(12):
        if abs(d / target - 1) < 0.02:
            break
        if len(hist) >= 2 and abs(math.log(hist[-1][1]) - math.log(hist[-2][1])) > 1e-6:
            (s1, d1), (s2, d2) = hist[-2], hist[-1]
            slope = (math.log(d2) - math.log(d1)) / (math.log(s2) - math.log(s1))
            slope = min(max(slope, 0.3), 3.0)
        else:
            slope = 1.0
        step = (math.log(target) - math.log(max(d, 1e-9))) / slope
        step = max(min(step, 2.5), -2.5)
        s = s * math.exp(step)
        d = heldout_gap(case, [(form, sh, s)])
        hist.append((s, d))
    return s, d


def build_case(S, idx, dry=False):
    seed = 73000 + 100 * S + idx
    rng = np.random.default_rng(seed)
    kind, effs = SETS[S][idx - 1]
    M = MUSCLES[S]
    var = NULL_VARIATION[S] if kind == "null" else VARIATION[S]
    plo, phi = pressure_range(M["geom"], M["mat"])
    case = dict(set=S, idx=idx, seed=seed, kind=kind, muscle=M, plo=plo, phi=phi, variation=var)
    case["sigma"] = float(rng.uniform(0.1, 0.3))
    case["phi_ar"] = float(rng.uniform(0.5, 0.85)) if S == 3 else 0.0
    logs = make_logs(rng, M["fs"], plo, phi)
    case["logs"] = logs
    case["session_len"] = logs[-1]["t_session0"] + logs[-1]["dur"]
    for lg in logs:
        f = np.exp(rng.normal(0.0, var, 5))
        m = M["mat"]
        lg["mat"] = dict(G_inf=m["G_inf"] * f[0], K_inf=m["K_inf"] * f[1], G1=m["G1"] * f[2], K1=m["K1"] * f[3],
                         tau1=m["tau1"] * f[4])
        lg["factors"] = [float(x) for x in f]
        lg["remount"] = float(1.0 + 0.15 * rng.normal())
    # context for the shape draws
    from core import relaxed_pressure
    e1max = float(relaxed_pressure(M["geom"], M["mat"], math.radians(115.0))[2])
    case["ctx"] = dict(e1max=e1max, e1rate=e1max / 5.0)
    for lg in logs:
        lg["_base"] = simulate(case, lg, [])
    # effects
    effects = []
    ratios = []
    for cid, form in effs:
        sh = effect_shape(form, rng, case["ctx"])
        R = float(rng.uniform(2.0, 3.0) if kind == "pair" else rng.uniform(1.8, 4.0))
        s, d = scale_effect(case, form, sh, R, case["sigma"])
        achieved = math.sqrt(case["sigma"] ** 2 + d ** 2) / case["sigma"]
        effects.append((form, sh, s))
        ratios.append(dict(id=cid, form=form, target_ratio=R, achieved_ratio=achieved, size=float(s),
                           shape={k: float(v) for k, v in sh.items()}))
    comb = None
    if effects:
        d = heldout_gap(case, effects)
        comb = math.sqrt(case["sigma"] ** 2 + d ** 2) / case["sigma"]
    # per-log size of the (combined) effect against the true base model, fitting logs included
    per_log = []
    for lg in logs:
        a = simulate(case, lg, effects) if effects else lg["_base"]
        rms = float(np.sqrt(np.mean((a - lg["_base"]) ** 2)))
        per_log.append(dict(log=lg["name"], role=lg["role"], effect_rms_deg=rms,
                            ratio=math.sqrt(case["sigma"] ** 2 + rms ** 2) / case["sigma"]))
    if dry:
        return dict(case="set%d/case%02d" % (S, idx), per_log=per_log, sigma=case["sigma"])
    # write logs
    cdir = os.path.join(OUT, "sets", "set%d" % S, "case%02d" % idx)
    os.makedirs(cdir, exist_ok=True)
    for f in os.listdir(cdir):
        os.remove(os.path.join(cdir, f))
    files = []
    for li, lg in enumerate(logs):
        ang = simulate(case, lg, effects) if effects else lg["_base"]
        n = len(ang)
        if S == 3:
            e = np.empty(n)
            ph = case["phi_ar"]
            e[0] = rng.normal() * case["sigma"]
            w = rng.normal(size=n) * case["sigma"] * math.sqrt(1 - ph * ph)
            for k in range(1, n):
                e[k] = ph * e[k - 1] + w[k]
        else:
            e = rng.normal(size=n) * case["sigma"]
        t = np.arange(n) / M["fs"]
        step = int(round(1000 / M["fs"]))
        p = lg["plog"][::step][:n] + rng.normal(size=n) * 50.0
        fname = write_log(cdir, S, idx, seed, li, lg, t, p, ang + e)
        files.append(dict(file=fname, role=lg["role"], protocol=lg["desc"], duration_s=lg["dur"],
                          per_log_factors_Ginf_Kinf_G1_K1_tau1=lg["factors"],
                          t_session0_s=float(lg["t_session0"])))
        lg["_file"] = fname
    # geometry config (sets 2-3)
    if S in (2, 3):
        g = M["geom"]
        with open(os.path.join(cdir, "case.yaml"), "w") as fh:
            fh.write("# SYNTHETIC: made by benchmarks/blind3 (seed %d), not a measurement\n" % seed)
            fh.write("model:\n  geometry: {th_mm: %.3f, alpha0_deg: %.3f, R0_mm: %.3f, l0_mm: %.3f, n: %.3f}\n"
                     % (g["th"] * 1e3, math.degrees(g["alpha0"]), g["R0"] * 1e3, g["l0"] * 1e3, g["n"]))
    ans = dict(case="set%d/case%02d" % (S, idx), seed=seed, kind=kind,
               truth_ids=[r["id"] for r in ratios if r["id"]],
               effects=ratios, combined_ratio=comb, sigma_deg=case["sigma"], ar1_phi=case["phi_ar"],
               variation_sd=var, muscle=dict(geom={k: float(v) for k, v in M["geom"].items()},
                                            mat=M["mat"], log_rate_hz=M["fs"], truth_rate_hz=M["fine"]),
               pressure_range_gauge_pa=[float(plo), float(phi)], logs=files, per_log_effect_size=per_log)
    os.makedirs(os.path.join(OUT, "answers"), exist_ok=True)
    with open(os.path.join(OUT, "answers", "set%d_case%02d.yaml" % (S, idx)), "w") as fh:
        yaml.safe_dump(ans, fh, sort_keys=False)
    return ans


def write_log(cdir, S, idx, seed, li, lg, t, p_gauge_pa, ang):
    head = "# SYNTHETIC: made by benchmarks/blind3 (seed %d), not a measurement\n" % seed
    name = lg["name"] + ".csv"
    path = os.path.join(cdir, name)
    if S == 1:
        with open(path, "w") as fh:
            fh.write(head + "# pressure_reference: absolute\ntime_s,pressure_bar,angle_deg\n")
            for a, b, c in zip(t, (p_gauge_pa + ATM) / 1e5, ang):
                fh.write("%.2f,%.5f,%.3f\n" % (a, b, c))
    elif S == 2:
        semi = (li % 2 == 1)
        with open(path, "w", newline="") as fh:
            if semi:
                fh.write(head + "# pressure_reference: gauge\r\ntime_s;pressure_kpa;angle_deg\r\n")
                for a, b, c in zip(t, p_gauge_pa / 1e3, ang):
                    fh.write(("%.3f;%.3f;%.3f\r\n" % (a, b, c)).replace(".", ","))
            else:
                fh.write(head + "# pressure_reference: gauge\ntime_s,pressure_kpa,angle_deg\n")
                for a, b, c in zip(t, p_gauge_pa / 1e3, ang):
                    fh.write("%.3f,%.3f,%.3f\n" % (a, b, c))
    else:
        psi = 6894.757293168
        absolute = (idx % 2 == 0)
        with open(path, "w") as fh:
            fh.write(head)
            fh.write("Instrument: BPM-DAQ 4ch (synthetic)\nSample Rate: 50 Hz\nOperator: blind3\n")
            if absolute:
                fh.write("Time (ms)\tPressure (psia)\tAngle (deg)\n")
                pv = (p_gauge_pa + ATM) / psi
            else:
                # first attempt wrote a plain 'Pressure Reference: Gauge' line (no '#'): bpmid took that
                # 3-token line as the column header (exit 2; see README "Findings"); the docs' form with '#':
                fh.write("# Pressure Reference: Gauge\nTime (ms)\tPressure (psi)\tAngle (deg)\n")
                pv = p_gauge_pa / psi
            for a, b, c in zip(t * 1000.0, pv, ang):
                fh.write("%.0f\t%.4f\t%.3f\n" % (a, b, c))
    return name


def _job(a):
    S, i = a
    t0 = time.time()
    ans = build_case(S, i)
    return S, i, time.time() - t0, ans["combined_ratio"], [r["achieved_ratio"] for r in ans["effects"]]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--only", default="")
    a = ap.parse_args()
    if a.only:
        todo = [tuple(int(x) for x in s.split(":")) for s in a.only.split(",")]
    else:
        todo = [(S, i) for S in SETS for i in range(1, len(SETS[S]) + 1)]
    if a.jobs > 1:
        with ProcessPoolExecutor(a.jobs) as ex:
            for r in ex.map(_job, todo):
                print("set%d case%02d %.1fs combined %s singles %s" % r, flush=True)
    else:
        for x in todo:
            print("set%d case%02d %.1fs combined %s singles %s" % _job(x), flush=True)


if __name__ == "__main__":
    main()
