"""Rescore spent held-out draws after a change that can reach only some of their cases: rerun those cases with this
checkout's discovery, and compare with what each draw scored (or, with ``--over``, with a previous rescore).

    python benchmarks/rescore_spent.py out/ho-draw52 ... out/ho-draw57 \\
        --configs configs/sweeps/draw52.yaml ... configs/sweeps/draw57.yaml --reach leaders --out out/rescore-leaders
    python benchmarks/rescore_spent.py out/ho-draw56 ... out/ho-draw59 --configs configs/sweeps/draw5{6..9}.yaml \\
        --reach named --kinds pair single --over out/rescore-leaders --out out/rescore-later [--workers 2]

Development data, not a score: these draws were already scored once and their misses read. A fresh draw scores.

Which cases (``--reach``; discovery is deterministic, so a case the change cannot reach runs exactly as before):

- ``leaders`` (stop 50's change, ``pair_leaders``): the paths for two effects at once refit, two at a time, the pairs
  of a first round's leaders whose two members both pass the round's Holm-corrected test alone. Before stop 50 the
  leaders were the three largest positive held-out gains; now the three with the smallest Holm-corrected p on the
  fitting logs join them. Rerun: a case whose recorded first round gives a new such pair.
- ``named`` (stop 51's change: every round scores with the base model's per-log factors): only rounds after the
  first changed. Rerun: a case whose first round named something (only those have a later round).

``--kinds`` keeps only cases of those kinds (single, null, pair, out_of_catalogue). Each case rerun is regenerated from
its sweep config and seed and judged with the shipped thresholds. Synthetic data: :mod:`bpmid.validation`.
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


def named_first(rec: dict) -> bool:
    """Whether the recorded case named something (its first round did: only then is there a later round)."""
    return bool(rec.get("named"))


REACH = {"leaders": reached, "named": lambda rec, alpha: named_first(rec)}


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
    ap.add_argument("--reach", choices=sorted(REACH), default="leaders",
                    help="which cases the change can reach (see above); default: leaders")
    ap.add_argument("--kinds", nargs="+", choices=["single", "null", "pair", "out_of_catalogue"],
                    help="rerun only cases of these kinds (default: every kind)")
    ap.add_argument("--over", nargs="+", type=Path, default=[],
                    help="folders of a previous rescore whose records replace the draws' as the decisions to compare "
                         "with (the code before this change decided them so)")
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
    for d in a.over:
        if not (d / "records.jsonl").is_file():
            ap.error(f"{d}: no records.jsonl: give folders written by this script")
        for rec in read_records(d / "records.jsonl"):
            if rec["id"] in old and not rec.get("error"):
                old[rec["id"]] = rec
    for rec in old.values():
        if (not a.kinds or rec["kind"] in a.kinds) and REACH[a.reach](rec, alpha):
            cfg, case = made[rec["id"]]
            todo.append((case, cfg.discover_config("heldout", thresholds)))
    a.out.mkdir(parents=True, exist_ok=True)
    path = a.out / "records.jsonl"
    new = {r["id"]: r for r in read_records(path)} if path.is_file() else {}
    run = [t for t in todo if t[0].id not in new]
    print(f"{len(old)} held-out case(s); {len(todo)} reached ({a.reach}; {len(run)} to run)", flush=True)
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
    before = "right as scored" + (" (or as --over left them)" if a.over else "")
    print(f"\n| kind | cases | {before} | right with this discovery |\n|---|---|---|---|")
    for kind, (n, b, c) in sorted(tally.items()):
        print(f"| {kind} | {n} | {b} ({100 * b / n:.1f} %) | {c} ({100 * c / n:.1f} %) |")
    changed = [i for i in new if i in old and new[i]["named"] != old[i]["named"]]
    for i in changed:
        print(f"changed: {i} ({old[i]['kind']}, truth {old[i]['truth_ids']}): {old[i]['named']} -> {new[i]['named']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
