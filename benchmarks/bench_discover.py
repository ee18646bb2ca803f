"""The discovery loop on the project's own twin: calibration check, confusion matrix, and the cost curve.

    python benchmarks/bench_discover.py                  # evaluate the committed thresholds on fresh twin seeds
    python benchmarks/bench_discover.py --scaling        # run time and model evaluations at 1x, 4x, 16x data
    python benchmarks/bench_discover.py --calibrate OUT  # calibrate on the twin into OUT (a check only: the
                                                         # shipped thresholds come from the out-of-family
                                                         # generator, ``bpmid calibrate configs/sweeps/full.yaml``)

Data: :func:`bpmid.discover.calibrate.paper_sized_set` (paper protocols, 10 Hz, 7 fitting + 4 held-out logs),
each catalogue effect hidden in the twin's variant of the physics where it has one (braid friction from 4 slip
elements where the model uses one play operator; a pressure lag plus a 0.1 s dead time where the model uses a
lag), plus null data with no effect. Calibration: seeds 0-2, sizes 0.6 and 1.0 of the default, noise 0.10/0.20/
0.15 deg, loop run with permissive thresholds. Evaluation: fresh seeds 10-12 (size 1.0, noise 0.15 deg) and
6 null seeds, loop run with the calibrated thresholds. Takes a few minutes on 2 cores.
"""
from __future__ import annotations

import argparse
import json
import dataclasses
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from bpmid.discover.calibrate import (load_thresholds, paper_sized_set, records_from_result, start_model,
                                      thresholds_from_records, write_thresholds)
from bpmid.discover.workflow import DiscoverConfig, discover
from bpmid.effects import CATALOGUE, get_effect

#: the twin's variants: forms different from the catalogue's model terms
TWIN_SETTINGS = {"braid_friction": {"elements": 4}, "pressure_lag": {"dead_time": 0.1}}
NOISE_BY_SEED = {0: 0.10, 1: 0.20, 2: 0.15}
from bpmid.discover.calibrate import PERMISSIVE  # noqa: E402


def run_case(args):
    truth, size, seed, noise, permissive = args
    eff = None if truth == "none" else get_effect(truth, **TWIN_SETTINGS.get(truth, {}))
    fit, ho = paper_sized_set(eff, size=size, seed=seed, noise_deg=noise)
    cfg = DiscoverConfig(**PERMISSIVE) if permissive else DiscoverConfig()
    t0 = time.perf_counter()
    res = discover(fit, start_model(), holdout=ho, cfg=cfg)
    return {"truth": truth, "size": size, "seed": seed, "noise": noise, "named": list(res.named_effects),
            "before": res.heldout_before, "after": res.heldout_after, "floor": res.noise_floor_deg,
            "seconds": time.perf_counter() - t0, "records": [dataclasses.asdict(r) for r in records_from_result(truth, res)]}


def run_all(cases, jobs):
    out = []
    with ProcessPoolExecutor(max_workers=jobs) as ex:
        for k, r in enumerate(ex.map(run_case, cases), start=1):
            out.append(r)
            print(f"  [{k}/{len(cases)}] {r['truth']:<22} size {r['size']:.1f} seed {r['seed']:>2}: named "
                  f"{r['named'] or '-'}  held-out {r['before']:.3f} -> {r['after']:.3f} deg (floor {r['floor']:.3f}) "
                  f"{r['seconds']:.1f} s", file=sys.stderr, flush=True)
    return out


def calibrate(jobs, out):
    from bpmid.discover.calibrate import Record
    cases = [(e, s, seed, NOISE_BY_SEED[seed], True) for e in CATALOGUE for s in (0.6, 1.0) for seed in (0, 1, 2)]
    cases += [("none", 1.0, seed, NOISE_BY_SEED[seed % 3], True) for seed in range(6)]
    print(f"calibration: {len(cases)} simulated data sets, permissive thresholds", file=sys.stderr)
    runs = run_all(cases, jobs)
    records = [Record(**r) for run in runs for r in run["records"]]
    with open("benchmarks/discover_calibration_records.json", "w") as fh:
        json.dump(runs, fh, indent=1)
    thr = thresholds_from_records(records)
    meta = {"produced_by": "python benchmarks/bench_discover.py --calibrate",
            "data": "paper_sized_set: 7 effects x sizes (0.6, 1.0) x seeds (0, 1, 2), noise 0.10/0.20/0.15 deg, "
                    "twin variants " + ", ".join(f"{k}{v}" for k, v in TWIN_SETTINGS.items()) + "; 6 null sets",
            "rule": "thresholds_from_records: the (gain, gap share, family alpha) with the most right decisions "
                    "minus twice the false positives"}
    write_thresholds(thr, meta, out)
    print("calibrated:", {k: round(v, 3) if isinstance(v, float) else v for k, v in thr.items()})


def evaluate(jobs):
    thr = load_thresholds()
    cases = [(e, 1.0, seed, 0.15, False) for e in CATALOGUE for seed in (10, 11, 12)]
    cases += [("none", 1.0, seed, 0.15, False) for seed in range(10, 16)]
    print(f"evaluation: {len(cases)} fresh data sets, thresholds {thr}", file=sys.stderr)
    runs = run_all(cases, jobs)
    labels = list(CATALOGUE) + ["none"]
    M = np.zeros((len(labels), len(labels)), int)
    for r in runs:
        first = r["named"][0] if r["named"] else "none"
        M[labels.index(r["truth"]), labels.index(first)] += 1
    short = {lab: lab[:10] for lab in labels}
    print("\nConfusion matrix (rows: hidden effect, columns: effect named first), fresh seeds:")
    print("| hidden \\ named | " + " | ".join(short[lab] for lab in labels) + " |")
    print("|---" * (len(labels) + 1) + "|")
    for i, lab in enumerate(labels):
        print(f"| {lab} | " + " | ".join(str(v) for v in M[i]) + " |")
    null = [r for r in runs if r["truth"] == "none"]
    eff = [r for r in runs if r["truth"] != "none"]
    fp_null = sum(bool(r["named"]) for r in null)
    extra = sum(len(r["named"]) > 1 for r in eff)
    correct = sum(bool(r["named"]) and r["named"][0] == r["truth"] for r in eff)
    shrink = [(r["after"] - r["floor"]) <= 0.5 * (r["before"] - r["floor"]) for r in eff]
    ratio = [r["before"] / r["floor"] for r in eff]
    print(f"\nnamed first correctly: {correct}/{len(eff)}")
    print(f"false-positive rate on null data: {fp_null}/{len(null)} = {fp_null / len(null):.0%}")
    print(f"extra effects named after the true one: {extra}/{len(eff)}")
    print(f"held-out gap shrank by at least half: {sum(shrink)}/{len(eff)}")
    print(f"base held-out RMSE / noise floor: min {min(ratio):.1f}, median {np.median(ratio):.1f}")
    print(f"runtime per data set: median {np.median([r['seconds'] for r in runs]):.1f} s, "
          f"max {max(r['seconds'] for r in runs):.1f} s")


def scaling():
    """Discovery on k times the data (every protocol's cycles repeated k times: the same logs, k times longer):
    wall time and model evaluations (one = one simulation of a set of logs). Evaluation budgets are fixed, so the
    evaluations stay flat and the time grows with the samples each evaluation integrates."""
    from bpmid.discover import model as M
    from bpmid.discover.calibrate import PROTOCOLS
    eff = get_effect("pressure_lag")
    rows = []
    for k in (1, 4, 16):
        protos = {name: (list(seg) * k, p0) for name, (seg, p0) in PROTOCOLS.items()}
        fit, ho = paper_sized_set(eff, seed=3, noise_deg=0.15, protocols=protos)
        n = sum(lg.n for lg in fit + ho)
        M.EVALUATIONS["count"] = 0
        t0 = time.perf_counter()
        res = discover(fit, start_model(), holdout=ho)
        rows.append((k, n, time.perf_counter() - t0, M.EVALUATIONS["count"], res.named_effects))
        print(f"{k:>2}x data: {n} samples, {rows[-1][2]:.1f} s, {rows[-1][3]} model evaluations, named {res.named_effects}",
              flush=True)
    print("\n| data | samples | time (s) | time / time at 1x | model evaluations |\n|---|---|---|---|---|")
    for k, n, dt, ev, _ in rows:
        print(f"| {k}x | {n} | {dt:.1f} | {dt / rows[0][2]:.1f} | {ev} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--calibrate", default=None, metavar="OUT", help="calibrate on the twin into OUT (a check)")
    ap.add_argument("--scaling", action="store_true", help="cost curve at 1x, 4x, 16x data")
    ap.add_argument("--jobs", type=int, default=min(2, os.cpu_count() or 1))
    a = ap.parse_args()
    if a.scaling:
        scaling()
        return
    if a.calibrate:
        calibrate(a.jobs, a.calibrate)
    evaluate(a.jobs)


if __name__ == "__main__":
    main()
