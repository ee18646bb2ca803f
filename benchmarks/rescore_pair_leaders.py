"""Rescore spent held-out draws after stop 50's change to the pairs refitted together (``pair_leaders``): rerun
only the cases the change can reach, with this checkout's discovery, and compare with what each draw scored.

    python benchmarks/rescore_pair_leaders.py out/ho-draw52 ... out/ho-draw57 \\
        --configs configs/sweeps/draw52.yaml ... configs/sweeps/draw57.yaml --out out/rescore-leaders [--workers 2]

Development data, not a score: these draws were already scored once and their misses read. A fresh draw scores.

Which cases: the paths for two effects at once refit, two at a time, the pairs of a first round's leaders whose two
members both pass the round's Holm-corrected test alone. Before stop 50 the leaders were the three largest positive
held-out gains; now the three with the smallest Holm-corrected p on the fitting logs join them. A case whose
recorded first round gives no new such pair runs exactly as before (discovery is deterministic), so only the others
are rerun: each is regenerated from its sweep config and seed and judged with the shipped thresholds. Synthetic
data: :mod:`bpmid.validation`.
"""
from __future__ import annotations

import argparse
import collections
import concurrent.futures as cf
import json
import math
import time
from pathlib import Path

ALPHA_KEY = "family_alpha"


def _pairs(lead, alpha):
    return {frozenset((a.candidate, b.candidate)) for i, a in enumerate(lead) for b in lead[i + 1:]
            if a.lr_p_holm < alpha and b.lr_p_holm < alpha}


def reached(rec: dict, alpha: float) -> bool:
    """Whether stop 50's leaders give this recorded case a pair to refit that the previous leaders did not."""
    from bpmid.discover.calibrate import case_records, pair_leader_records
    from bpmid.discover.workflow import PAIR_LEADERS

    r1 = [r for r in case_records(rec) if r.round == 1 and not r.rival]
    ok = [r for r in r1 if r.tested and r.identifiable and math.isfinite(r.gain_sigma)]
    before = [r for r in sorted(ok, key=lambda r: -r.gain_sigma) if r.gain_sigma > 0][:PAIR_LEADERS]
    return bool(_pairs(pair_leader_records(r1), alpha) - _pairs(before, alpha))


def right(rec: dict) -> bool:
    from bpmid.validation.sweep import case_right
    return bool(case_right(rec))


def _run(args):
    case, dcfg = args
    from bpmid.progress import set_quiet
    from bpmid.validation.sweep import run_case
    set_quiet(True)
    return run_case(case, "heldout", dcfg)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("draws", nargs="+", type=Path, help="folders written by `bpmid calibrate ... --split heldout`")
    ap.add_argument("--configs", nargs="+", required=True, help="the sweep configs the draws were made with")
    ap.add_argument("--out", type=Path, required=True, help="folder for the rerun cases' records.jsonl")
    ap.add_argument("--thresholds", default="bpmid/discover/thresholds.yaml", help="the gate to judge with")
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args(argv)

    from bpmid.discover.calibrate import load_thresholds
    from bpmid.validation.sweep import cases_by_id, read_records

    made = cases_by_id(a.configs)   # id -> (its sweep config, the case)
    thresholds = load_thresholds(a.thresholds)
    alpha = float(thresholds[ALPHA_KEY])
    old, todo = {}, []
    for d in a.draws:
        if not (d / "records.jsonl").is_file():
            ap.error(f"{d}: no records.jsonl: give folders written by `bpmid calibrate ... --split heldout`")
        for rec in read_records(d / "records.jsonl"):
            if rec.get("phase") != "heldout" or rec.get("error"):
                continue
            if rec["id"] not in made:
                ap.error(f"{d}: case {rec['id']} is made by none of --configs: give its sweep config")
            old[rec["id"]] = rec
            if reached(rec, alpha):
                cfg, case = made[rec["id"]]
                todo.append((case, cfg.discover_config("heldout", thresholds)))
    a.out.mkdir(parents=True, exist_ok=True)
    path = a.out / "records.jsonl"
    new = {r["id"]: r for r in read_records(path)} if path.is_file() else {}
    run = [t for t in todo if t[0].id not in new]
    print(f"{len(old)} held-out case(s); {len(todo)} reached by the new leaders ({len(run)} to run)", flush=True)
    t0 = time.perf_counter()
    with cf.ProcessPoolExecutor(a.workers) as ex, open(path, "a") as f:
        for k, rec in enumerate(ex.map(_run, run), start=1):
            f.write(json.dumps(rec) + "\n")
            f.flush()
            new[rec["id"]] = rec
            print(f"[{k}/{len(run)}] {rec['id']} ({rec['kind']}) {rec['truth_ids']}: "
                  f"{old[rec['id']]['named']} -> {rec['named']}", flush=True)
    print(f"reran in {time.perf_counter() - t0:.0f} s")
    tally = collections.defaultdict(lambda: [0, 0, 0])   # kind -> [cases, right before, right now]
    for i, rec in old.items():
        now = new.get(i, rec)
        t = tally[rec["kind"]]
        t[0] += 1
        t[1] += right(rec)
        t[2] += right(now)
    print("\n| kind | cases | right as scored | right with this discovery |\n|---|---|---|---|")
    for kind, (n, b, c) in sorted(tally.items()):
        print(f"| {kind} | {n} | {b} ({100 * b / n:.1f} %) | {c} ({100 * c / n:.1f} %) |")
    changed = [i for i in new if i in old and new[i]["named"] != old[i]["named"]]
    for i in changed:
        print(f"changed: {i} ({old[i]['kind']}, truth {old[i]['truth_ids']}): {old[i]['named']} -> {new[i]['named']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
