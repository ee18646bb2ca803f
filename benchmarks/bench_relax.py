"""Benchmark of ``bpmid fit relax``: the measured pyvisco master curve against peer fits, and ramp vs step mode.

Run ``python benchmarks/bench_relax.py``. Peers' RMSE are recomputed here from their shipped term files;
their times are the ones measured when they were run (datasets/reference/pyvisco/README.md).
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bpmid.io.relax_logs import RelaxLog, read_relax_log  # noqa: E402
from bpmid.relax import fit_relaxation  # noqa: E402
from bpmid.twin.relaxation import PronyTruth, paper_protocol, simulate_relaxation_test  # noqa: E402

REF = ROOT / "datasets" / "reference" / "pyvisco"


def prony_rmse(t, E, E_inf, Ei, tau):
    model = E_inf + np.exp(-t[:, None] / tau[None, :]) @ Ei
    return float(np.sqrt(np.mean((E - model) ** 2)))


def peers(t, E):
    rows = []
    a = np.loadtxt(REF / "ansys_reference_prony_terms_KPf_MD.csv", delimiter=",", comments="#")
    E0 = 1739.03
    rows.append(("ANSYS reference (tau fixed, 1/decade)", a.shape[0],
                 prony_rmse(t, E, E0 * (1 - a[:, 0].sum()), E0 * a[:, 0], a[:, 1]), None))
    p = np.loadtxt(REF / "pyvisco_2.1.3_default_fit_time_user_master.csv", delimiter=",", skiprows=2)
    E0 = p[0, 3]
    rows.append(("pyvisco 2.1.3 defaults", p.shape[0], prony_rmse(t, E, E0 * (1 - p[:, 2].sum()), p[:, 4], p[:, 1]), 1.1))
    rows.append(("pyvisco 2.1.3 term selection (reported)", 26, 3.10, 14.6))
    return rows


def timed(fn, repeat=5):
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return out, best


def master_curve():
    log = read_relax_log(REF / "time_user_master.csv")
    t, E = log.time_s, log.modulus_mpa
    print(f"== pyvisco master curve: {log.n} points, {np.log10(t[-1] / t[0]):.1f} decades, "
          f"{os.cpu_count()} cores ==")
    print(f"{'fit':44s} {'terms':>5s} {'RMSE MPa':>9s} {'time s':>7s}")
    fit, sec = timed(lambda: fit_relaxation([log]))
    print(f"{'bpmid, terms auto (BIC, max 32)':44s} {fit.m:5d} {fit.rmse_mpa:9.3f} {sec:7.2f}")
    fit31, sec31 = timed(lambda: fit_relaxation([log], terms=31))
    print(f"{'bpmid, 31 terms':44s} {fit31.m:5d} {fit31.rmse_mpa:9.3f} {sec31:7.2f}")
    for name, m, rmse, sec in peers(t, E):
        print(f"{name:44s} {m:5d} {rmse:9.3f} {'' if sec is None else f'{sec:7.2f}'}")
    crit = ", ".join(f"{c['terms']}: {c['criterion']:.1f}" for c in fit.selection)
    print(f"criterion per candidate (terms: BIC): {crit}")
    print(f"bpmid auto: R2 {fit.r2:.7f}, MAPE {fit.mape_pct:.3f} %, E_inf {fit.E_inf:.2f} MPa, "
          f"largest residual {max(np.max(np.abs(lg.y - lg.y_fit)) for lg in fit.logs):.2f} MPa (segment joins)")


def synthetic(truth: PronyTruth, seed: int, label: str):
    rng = np.random.default_rng(seed)
    logs = []
    for i, test in enumerate(paper_protocol()):
        df = simulate_relaxation_test(test, truth, rng)
        logs.append(RelaxLog(f"t{i}", df.time_s.to_numpy(), df.strain.to_numpy(), df.stress_mpa.to_numpy()))
    true = np.concatenate([[truth.E_inf_mpa], truth.E_mpa, truth.tau_s])
    names = ["E_inf"] + [f"E_{j + 1}" for j in range(len(truth.E_mpa))] + [f"tau_{j + 1}" for j in range(len(truth.tau_s))]
    print(f"== {label}: 12 ramp-and-hold logs (300/400 mm/min, 15-40 %, 50 Hz, 2 mN load noise), seed {seed} ==")
    print(f"{'constant':8s} {'truth':>9s} {'ramp':>9s} {'err %':>7s} {'+-se':>9s} {'step':>9s} {'err %':>7s}")
    fits = {}
    for mode in ("ramp", "step"):
        fits[mode], sec = timed(lambda: fit_relaxation(logs, mode=mode, terms=len(truth.E_mpa)), repeat=1)
        fits[mode + "_auto"] = fit_relaxation(logs, mode=mode)
        fits[mode + "_sec"] = sec
    r, s = fits["ramp"], fits["step"]
    rv = np.concatenate([[r.E_inf], r.E, r.tau])
    rse = np.concatenate([[r.se_E_inf], r.se_E, r.se_tau])
    sv = np.concatenate([[s.E_inf], s.E, s.tau])
    for n, tv, a, se, b in zip(names, true, rv, rse, sv):
        print(f"{n:8s} {tv:9.4g} {a:9.4g} {100 * (a / tv - 1):+7.2f} {se:9.2g} {b:9.4g} {100 * (b / tv - 1):+7.2f}")
    print(f"auto terms: ramp {fits['ramp_auto'].m}, step {fits['step_auto'].m} (truth {len(truth.E_mpa)}); "
          f"fit time ramp {fits['ramp_sec']:.2f} s, step {fits['step_sec']:.2f} s")


def main():
    master_curve()
    print()
    synthetic(PronyTruth(0.0272, (0.0549,), (0.399,)), 11, "one-branch truth (the paper's constants)")
    print()
    synthetic(PronyTruth(0.0272, (0.0549, 0.0200), (0.399, 6.0)), 12, "two-branch truth")


if __name__ == "__main__":
    main()
