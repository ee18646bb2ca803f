#!/usr/bin/env python
"""Blind-test generator for `bpmid discover` (independent of bpmid's code).

Usage: python gen.py --out out/blind/sets [--answers out/blind/answers] [--only s1_c01,...] [--jobs 2]

Physics: the VBMM of the VBMM spec (shared/spec/VBMM.md) (vbmm_indep.py, checked against the spec's golden values),
plus hidden effects in forms chosen here. All data synthetic; seeds recorded in every file.
"""
import argparse, math, os, sys, json, copy
import numpy as np
import yaml
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vbmm_indep import (Geometry, Plant, PAPER_GEOM, PAPER_FIT, ATM, relaxed_pressure, pressure_lag, payload_ring)

PSI = 6894.757293168

# ------------------------------------------------------------------ muscles
MUSCLES = {
    "paper": dict(geom=PAPER_GEOM, mat=PAPER_FIT),
    "m2": dict(geom=dict(th=0.0015, alpha0=math.radians(25), R0=0.010, l0=0.120, n=5.2),
               mat=dict(G_inf=12000., K_inf=5.1e6, branches=[dict(G=22000., K=9.8e6, tau=0.31)]),
               geom_cfg=dict(th_mm=1.5, alpha0_deg=25, R0_mm=10, l0_mm=120, n=5.2)),
    "m3": dict(geom=dict(th=0.003, alpha0=math.radians(33), R0=0.020, l0=0.250, n=9.1),
               mat=dict(G_inf=7000., K_inf=7.9e6, branches=[dict(G=15000., K=16.5e6, tau=0.17)]),
               geom_cfg=dict(th=0.003, alpha0=round(math.radians(33), 6), R0=0.020, l0=0.250, n=9.1)),
}


def pressure_scale(muscle):
    """gauge-pressure factor that makes this muscle bend like the paper's (relaxed, at 45 deg)"""
    g0 = Geometry(**PAPER_GEOM)
    m = MUSCLES[muscle]
    g = Geometry(**m["geom"])
    return relaxed_pressure(g, m["mat"], math.radians(45)) / relaxed_pressure(g0, PAPER_FIT, math.radians(45))


# ------------------------------------------------------------------ pressure programs (paper units: bar absolute)
def build(program, fs, p_start=1.2):
    """program: list of segments; returns t (s), p (bar abs, paper units). Piecewise at 1 ms, sampled at fs."""
    fine = 1e-3
    pts_t, pts_p = [0.0], [p_start]
    T, P = 0.0, p_start
    sines = []  # (t0, t1, mean, amp, f)

    def lin(to, dur):
        nonlocal T, P
        T += dur
        P = to
        pts_t.append(T)
        pts_p.append(P)

    for seg in program:
        kind = seg[0]
        if kind == "hold":
            lin(P, seg[1])
        elif kind == "ramp":
            to, rate = seg[1], seg[2]
            lin(to, abs(to - P) / rate)
        elif kind == "tri":
            lo, hi, rate, cyc = seg[1:]
            if abs(P - lo) > 1e-9:
                lin(lo, abs(P - lo) / rate)
            for _ in range(cyc):
                lin(hi, (hi - lo) / rate)
                lin(lo, (hi - lo) / rate)
        elif kind == "step":
            to, hold, slew = seg[1:]
            lin(to, abs(to - P) / slew)
            lin(to, hold)
        elif kind == "sine":
            mean, amp, f, cyc = seg[1:]
            if abs(P - mean) > 1e-9:
                lin(mean, abs(P - mean) / 0.2)
            t0 = T
            lin(mean, cyc / f)
            sines.append((t0, T, mean, amp, f))
        else:
            raise ValueError(kind)
    n = int(math.floor(T * fs + 1e-9)) + 1
    t = np.arange(n) / fs
    p = np.interp(t, pts_t, pts_p)
    for t0, t1, mean, amp, f in sines:
        m = (t >= t0) & (t <= t1)
        p[m] = mean + amp * np.sin(2 * math.pi * f * (t[m] - t0))
    return t, p


SLEW = 3.0
PROGRAMS = {
    "fit_amplitudes": [("hold", 5), ("tri", 1.2, 1.6, 0.2, 2), ("tri", 1.2, 1.8, 0.2, 2), ("tri", 1.2, 2.0, 0.2, 2),
                       ("tri", 1.2, 2.2, 0.2, 2), ("ramp", 2.0, 0.2), ("hold", 25), ("ramp", 1.2, 0.2), ("hold", 15)],
    "fit_rates": [("hold", 5), ("tri", 1.2, 2.0, 0.114, 2), ("tri", 1.2, 2.0, 0.16, 2), ("tri", 1.2, 2.0, 0.267, 2),
                  ("tri", 1.2, 2.0, 0.4, 3), ("hold", 10), ("sine", 1.6, 0.35, 0.1, 4), ("ramp", 1.2, 0.2), ("hold", 10)],
    "fit_steps": [("hold", 5), ("step", 1.5, 20, SLEW), ("step", 1.8, 20, SLEW), ("step", 2.1, 30, SLEW),
                  ("step", 1.7, 20, SLEW), ("step", 1.4, 20, SLEW), ("step", 1.2, 15, SLEW)],
    "holdout_mixed": [("hold", 5), ("tri", 1.2, 1.8, 0.2, 1), ("tri", 1.2, 2.0, 0.2, 1), ("tri", 1.2, 2.2, 0.2, 1),
                      ("tri", 1.2, 1.8, 0.2, 1), ("tri", 1.2, 2.0, 0.2, 1), ("tri", 1.2, 2.2, 0.2, 1),
                      ("step", 1.9, 25, SLEW), ("step", 1.3, 15, SLEW), ("sine", 1.6, 0.35, 0.083, 3),
                      ("ramp", 1.2, 0.2), ("hold", 10)],
    "holdout_rates": [("hold", 5), ("ramp", 1.3, 0.2), ("tri", 1.3, 2.1, 0.3, 4), ("ramp", 1.9, 0.15), ("hold", 30),
                      ("ramp", 1.2, 0.15), ("tri", 1.2, 1.7, 0.14, 2), ("hold", 10)],
}

# ------------------------------------------------------------------ cases
# effect sizes are given in paper-muscle pressure units where they are pressures (scaled by the muscle's factor)
def mslip(total_w, deltas):
    w = [total_w / len(deltas)] * len(deltas)
    return dict(kind="mslip", w=w, k=[wi / d for wi, d in zip(w, deltas)])


SETS = {
    "set1": dict(muscle="paper", fs=10, unit="bar_abs", noise=dict(kind="white", sigma=0.30), cv=0.01,
                 fit=["fit_amplitudes", "fit_rates", "fit_steps"], holdout=["holdout_mixed", "holdout_rates"],
                 cases={
        "c01": dict(truth=["second_relaxation"], form="two slow Prony branches (tau 6 s and 40 s, weights 0.06/0.05 of the long-term moduli)",
                    eff=dict(extra=[(0.06, 6.0), (0.05, 40.0)])),
        "c02": dict(truth=["braid_friction"], form="Maxwell-slip: 6 elasto-slip elements driven by the angle, total band 1.8 kPa",
                    eff=dict(friction=mslip(1800.0, [0.01, 0.02, 0.04, 0.07, 0.10, 0.15]))),
        "c03": dict(truth=["pressure_lag"], form="orifice-volume fill: dp/dt = dP/(tau0 sqrt(1+|dP|/2 kPa)), tau0 0.10 s, plus 0.05 s transport delay",
                    eff=dict(lag=dict(kind="orifice", tau0=0.10, dp0=2000.0, delay=0.05))),
        "c04": dict(truth=["asymmetric_relaxation"], form="branch time constant x0.25 while the angle falls (deflation faster), switch on the angle's last increment",
                    eff=dict(asym=dict(kind="switch", ratio=0.25))),
        "c05": dict(truth=["strain_stiffening"], form="power law: long-term moduli x (1 + 0.15 (eps1/0.11)^3)",
                    eff=dict(stiff=dict(kind="power", c=0.15, m=3, xref=0.11))),
        "c06": dict(truth=["angle_offset"], form="constant sensor zero offset +0.9 deg",
                    eff=dict(offset=dict(c=0.9))),
        "c07": dict(truth=["thermal_softening"], form="all moduli x (1 - 0.08 (1 - exp(-t/150 s))), each log from a cool muscle",
                    eff=dict(thermal=dict(kind="time", d=0.08, T=150.0))),
        "c08": dict(truth=[], form="null (1 % log-to-log variation only)", eff={}),
    }),
    "set2": dict(muscle="m2", fs=20, unit="kpa_gauge", noise=dict(kind="white", sigma=0.25), cv=0.015,
                 fit=["fit_amplitudes", "fit_rates", "fit_steps"], holdout=["holdout_mixed", "holdout_rates"],
                 cases={
        "c01": dict(truth=["second_relaxation"], form="distributed slow relaxation: 3 branches tau 4/15/50 s, weights 0.03/0.04/0.04",
                    eff=dict(extra=[(0.03, 4.0), (0.04, 15.0), (0.04, 50.0)])),
        "c02": dict(truth=["braid_friction"], form="Dahl friction vs angle, Fc 1.0 kPa (paper units), sigma0 = Fc/0.03 rad",
                    eff=dict(friction=dict(kind="dahl", Fc=1000.0, sigma0=1000.0 / 0.03))),
        "c03": dict(truth=["pressure_lag"], form="0.15 s dead time + first-order 0.06 s",
                    eff=dict(lag=dict(kind="delay_first", delay=0.15, tau=0.06))),
        "c04": dict(truth=["asymmetric_relaxation"], form="branch tau x exp(ln(0.3)(1-tanh(dp/dt / 2 kPa/s))/2): smooth, deflation 0.3x",
                    eff=dict(asym=dict(kind="tanh", ratio=0.3, rate0=2000.0))),
        "c05": dict(truth=["strain_stiffening"], form="Fung exponential: long-term moduli x (exp(2.2 eps1)-1)/(2.2 eps1)",
                    eff=dict(stiff=dict(kind="fung", b=2.2))),
        "c06": dict(truth=["angle_offset"], form="constant zero offset -0.6 deg (small: 2.4 sigma)",
                    eff=dict(offset=dict(c=-0.6))),
        "c07": dict(truth=["thermal_softening"], form="moduli x (1 - 0.10 (1 - exp(-W/W0))), W cumulative |P dbeta| work, W0 1.2e6 Pa rad (paper units)",
                    eff=dict(thermal=dict(kind="work", d=0.10, W0=1.2e6))),
        "c08": dict(truth=["braid_friction", "second_relaxation"], form="pair: Maxwell-slip 4 elements band 1.4 kPa + one slow branch tau 20 s weight 0.08",
                    eff=dict(friction=mslip(1400.0, [0.015, 0.04, 0.08, 0.12]), extra=[(0.08, 20.0)])),
        "c09": dict(truth=[], ooc="mullins_softening", form="OUT OF CATALOGUE: Mullins-type softening, long-term moduli x (1 - 0.15 (1 - eps1/eps1_max_so_far)); each log from a recovered (virgin) muscle",
                    eff=dict(mullins=dict(d=0.15))),
        "c10": dict(truth=[], form="null with 4 % log-to-log variation", eff={}, cv=0.04),
        "c11": dict(truth=[], form="null (1.5 % variation)", eff={}),
    }),
    "set3": dict(muscle="m3", fs=50, unit="psi_ms", noise=dict(kind="ar1", sigma=0.30, phi=0.8), cv=0.02,
                 fit=["fit_amplitudes", "fit_rates", "fit_steps"], holdout=["holdout_mixed"],
                 cases={
        "c01": dict(truth=["second_relaxation"], form="stretched-exponential-like spectrum: 5 branches tau 2/5/12/30/80 s, weights 0.02/0.025/0.03/0.025/0.02",
                    eff=dict(extra=[(0.02, 2.0), (0.025, 5.0), (0.03, 12.0), (0.025, 30.0), (0.02, 80.0)])),
        "c02": dict(truth=["braid_friction"], form="Bouc-Wen friction vs angle (A 30/rad, b=g=15, n=1), Fc 1.2 kPa (paper units)",
                    eff=dict(friction=dict(kind="boucwen", A=30.0, b=15.0, g=15.0, n=1.0, Fc=1200.0))),
        "c03": dict(truth=["pressure_lag"], form="second-order tubing (fn 1.0 Hz, zeta 0.8) + 0.08 s dead time",
                    eff=dict(lag=dict(kind="second", fn=1.0, zeta=0.8, delay=0.08))),
        "c04": dict(truth=["asymmetric_relaxation"], form="branch tau x2.5 while the angle falls (deflation SLOWER)",
                    eff=dict(asym=dict(kind="switch", ratio=2.5))),
        "c05": dict(truth=["strain_stiffening"], form="Gent-like lock-up: long-term moduli / (1 - (eps1/0.30)^2)",
                    eff=dict(stiff=dict(kind="gent", xm=0.30))),
        "c06": dict(truth=["angle_offset"], form="marker mounting offset: +1.2 deg + 0.05 deg sin(beta)",
                    eff=dict(offset=dict(c=1.2, s=0.05))),
        "c07": dict(truth=["thermal_softening"], form="moduli x (1 - 0.12 (t/200)/(1 + t/200)), each log from a cool muscle",
                    eff=dict(thermal=dict(kind="hyper", d=0.12, T=200.0))),
        "c08": dict(truth=["strain_stiffening", "asymmetric_relaxation"], form="pair: power law 1 + 0.12 (eps1/0.11)^2 + deflation tau x0.3",
                    eff=dict(stiff=dict(kind="power", c=0.12, m=2, xref=0.11), asym=dict(kind="switch", ratio=0.3))),
        "c09": dict(truth=[], ooc="payload_ringing", form="OUT OF CATALOGUE: tip payload ringing, measured angle = 2nd-order (1.6 Hz, zeta 0.12) response to the muscle's angle",
                    eff=dict(ring=dict(fn=1.6, zeta=0.12))),
        "c10": dict(truth=[], form="null with 5 % log-to-log variation", eff={}, cv=0.05),
        "c11": dict(truth=[], form="null (2 % variation)", eff={}),
    }),
}


def plant_effects(eff, mat, pscale):
    """translate a case's effect spec into Plant effects (muscle-specific)"""
    pe = {}
    if "extra" in eff:
        pe["extra_branches"] = [dict(G=w * mat["G_inf"], K=w * mat["K_inf"], tau=tau) for w, tau in eff["extra"]]
    if "asym" in eff:
        a = dict(eff["asym"])
        if "rate0" in a:
            a["rate0"] *= pscale
        pe["asym"] = a
    if "stiff" in eff:
        pe["stiff"] = eff["stiff"]
    if "thermal" in eff:
        th = dict(eff["thermal"])
        if "W0" in th:
            th["W0"] *= pscale
        pe["thermal"] = th
    if "mullins" in eff:
        pe["mullins"] = eff["mullins"]
    if "friction" in eff:
        f = copy.deepcopy(eff["friction"])
        if f["kind"] == "mslip":
            f["w"] = [x * pscale for x in f["w"]]
            f["k"] = [x * pscale for x in f["k"]]
        elif f["kind"] == "dahl":
            f["Fc"] *= pscale
            f["sigma0"] *= pscale
        else:
            f["Fc"] *= pscale
        pe["friction"] = f
    return pe


def simulate_log(case_seed, li, logname, setd, case, want_clean=True):
    muscle = MUSCLES[setd["muscle"]]
    fs = setd["fs"]
    cv = case.get("cv", setd["cv"])
    pscale = pressure_scale(setd["muscle"])
    rng_c = np.random.default_rng(np.random.SeedSequence([case_seed, li, 0]))
    rng_s = np.random.default_rng(np.random.SeedSequence([case_seed, li, 1]))
    z = rng_c.standard_normal(3)
    f_lt, f_br, f_tau = np.exp(cv * z)
    mat = copy.deepcopy(muscle["mat"])
    mat["G_inf"] *= f_lt
    mat["K_inf"] *= f_lt
    for b in mat["branches"]:
        b["G"] *= f_br
        b["K"] *= f_br
        b["tau"] *= f_tau
    t, p_paper = build(PROGRAMS[logname], fs)
    p_sup = (p_paper - 1.01325) * 1e5 * pscale  # true supply gauge pressure, Pa
    eff = case["eff"]
    geom = Geometry(**muscle["geom"])
    pe = plant_effects(eff, mat, pscale)
    p_int = pressure_lag(t, p_sup, eff["lag"]) if "lag" in eff else p_sup
    beta = Plant(geom, mat, pe).simulate(t, p_int)
    ang = np.degrees(beta)
    if "ring" in eff:
        ang = np.degrees(payload_ring(t, beta, eff["ring"]["fn"], eff["ring"]["zeta"]))
    if "offset" in eff:
        ang = ang + eff["offset"]["c"] + eff["offset"].get("s", 0.0) * np.sin(beta)
    clean = None
    if want_clean and eff:
        clean = np.degrees(Plant(geom, mat, {}).simulate(t, p_sup))
    # sensors
    nz = setd["noise"]
    sig = nz["sigma"]
    w = rng_s.standard_normal(len(t))
    if nz["kind"] == "white":
        e = sig * w
    else:
        phi = nz["phi"]
        e = np.empty(len(t))
        e[0] = sig * w[0]
        s = sig * math.sqrt(1 - phi * phi)
        for k in range(1, len(t)):
            e[k] = phi * e[k - 1] + s * w[k]
    ang_meas = np.round((ang + e) / 0.01) * 0.01
    p_meas = p_sup + 100.0 * pscale * rng_s.standard_normal(len(t))  # 1 mbar (paper units) pressure noise
    info = dict(log=logname, modulus_factor_longterm=float(f_lt), modulus_factor_branch=float(f_br), tau_factor=float(f_tau),
                samples=len(t), duration_s=float(t[-1]))
    raw = float(np.sqrt(np.mean((ang - clean) ** 2))) if clean is not None else 0.0
    info["raw_effect_rms_deg"] = raw
    info["noiseless_angle_range_deg"] = [float(ang.min()), float(ang.max())]
    return t, p_meas, ang_meas, info


def write_log(path, setname, case_id, seed, t, p_gauge, ang, unit):
    lines = []
    if unit == "bar_abs":
        lines.append("# pressure_reference: absolute")
        lines.append(f"# synthetic: true (blindgen independent generator, {setname}/{case_id}, seed {seed}; not a measurement)")
        lines.append("time_s,pressure_bar,angle_deg")
        pb = (p_gauge + ATM) / 1e5
        for a, b, c in zip(t, pb, ang):
            lines.append(f"{a:.1f},{b:.4f},{c:.2f}")
    elif unit == "kpa_gauge":
        lines.append("# pressure_reference: gauge")
        lines.append(f"# synthetic: true (blindgen independent generator, {setname}/{case_id}, seed {seed}; not a measurement)")
        lines.append("time_s,pressure_kpa,angle_deg")
        for a, b, c in zip(t, p_gauge / 1e3, ang):
            lines.append(f"{a:.2f},{b:.3f},{c:.2f}")
    elif unit == "psi_ms":
        # NOTE: first written with this comment line AFTER the three metadata lines; bpmid 0.1.0 then refuses the
        # file ("pressure reference unknown ... a line '# pressure_reference: gauge' at the top of the file").
        # Moved to the top, as the message asks (see report).
        lines.append("# pressure_reference: gauge")
        lines.append(f"Title: BPM bench log (SYNTHETIC, blindgen independent generator, {setname}/{case_id}, seed {seed}; not a measurement)")
        lines.append("Instrument: blindgen virtual DAQ")
        lines.append("Sample rate: 50 Hz")
        lines.append("Time (ms),Pressure (psi),Angle (deg)")
        for a, b, c in zip(t, p_gauge / PSI, ang):
            lines.append(f"{int(round(a * 1000))},{b:.4f},{c:.2f}")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def gen_case(args):
    setname, cid, outdir, ansdir = args
    setd = SETS[setname]
    case = setd["cases"][cid]
    seed = 7000 + 100 * int(setname[-1]) + int(cid[1:])
    cdir = os.path.join(outdir, setname, cid)
    os.makedirs(cdir, exist_ok=True)
    logs = [(n, "fit") for n in setd["fit"]] + [(n, "holdout") for n in setd["holdout"]]
    infos = []
    for li, (name, role) in enumerate(logs):
        t, p, a, info = simulate_log(seed, li, name, setd, case)
        ext = "csv"
        write_log(os.path.join(cdir, f"{name}.{ext}"), setname, cid, seed, t, p, a, setd["unit"])
        info["file"] = f"{name}.{ext}"
        info["role"] = role
        infos.append(info)
    cfg = None
    m = MUSCLES[setd["muscle"]]
    if "geom_cfg" in m:
        cfg = {"model": {"geometry": m["geom_cfg"]}}
        with open(os.path.join(cdir, "case.yaml"), "w") as f:
            f.write(f"# synthetic case (blindgen, {setname}/{cid}, seed {seed}): this rig's muscle geometry\n")
            yaml.safe_dump(cfg, f, sort_keys=False)
    with open(os.path.join(cdir, "README.txt"), "w") as f:
        f.write(f"SYNTHETIC data (blindgen independent generator), {setname}/{cid}, seed {seed}.\n"
                f"Fit on: {', '.join(i['file'] for i in infos if i['role']=='fit')}\n"
                f"Hold out: {', '.join(i['file'] for i in infos if i['role']=='holdout')}\n")
    nz = setd["noise"]
    ans = dict(set=setname, case=cid, seed=seed, truth=case["truth"], out_of_catalogue=case.get("ooc"),
               form=case["form"], muscle=setd["muscle"], geometry_si=m["geom"], material_nominal=m["mat"],
               pressure_scale_vs_paper=pressure_scale(setd["muscle"]), sampling_hz=setd["fs"],
               angle_noise=dict(nz, sigma_deg=nz["sigma"]), angle_resolution_deg=0.01,
               pressure_noise_pa=100.0 * pressure_scale(setd["muscle"]),
               log_to_log_cv=case.get("cv", setd["cv"]), effect_spec=case["eff"], logs=infos)
    ho = [i for i in infos if i["role"] == "holdout"]
    ans["raw_effect_rms_holdout_deg"] = float(np.sqrt(np.mean([i["raw_effect_rms_deg"] ** 2 for i in ho])))
    ans["raw_effect_over_sigma"] = ans["raw_effect_rms_holdout_deg"] / nz["sigma"]
    os.makedirs(os.path.join(ansdir, setname), exist_ok=True)
    with open(os.path.join(ansdir, setname, f"{cid}.yaml"), "w") as f:
        yaml.safe_dump(json.loads(json.dumps(ans)), f, sort_keys=False)
    return setname, cid, ans["raw_effect_over_sigma"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="out/blind/sets")
    ap.add_argument("--answers", default="out/blind/answers")
    ap.add_argument("--only", default="")
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args()
    jobs = [(s, c, a.out, a.answers) for s in SETS for c in SETS[s]["cases"]]
    if a.only:
        keep = set(a.only.split(","))
        jobs = [j for j in jobs if f"{j[0]}_{j[1]}" in keep or j[0] in keep]
    if a.jobs > 1:
        from multiprocessing import Pool
        with Pool(a.jobs) as pool:
            res = pool.map(gen_case, jobs, chunksize=1)
    else:
        res = [gen_case(j) for j in jobs]
    for s, c, r in res:
        print(f"{s}/{c}: raw effect on held-out = {r:.2f} sigma")


if __name__ == "__main__":
    main()
