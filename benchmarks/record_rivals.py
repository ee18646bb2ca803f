"""Record the rival outside the catalogue (bpmid.discover.rivals) on finished calibration sweeps: rerun every
calibration case with the calibration half's permissive settings, which refit and record each round's rival.

    python benchmarks/record_rivals.py out/pool-draw12/records.jsonl ... [--rerun out/pair-trials/records.jsonl] \\
        --configs configs/sweeps/full.yaml ... --out out/rival-records [--workers 2]

Calibration records written before the rival existed lack it, and the rival can withhold a name in any round, so
every case is rerun (on Dask, resumable: cases already in ``OUT/records.jsonl`` are skipped). The rival is refitted
after the candidates and changes nothing they record, so a rerun's candidate records must equal the old ones (and
its pair trials the old reruns' where there were any): a case whose records differ is reported, and the script
then exits 1. Then

    python benchmarks/recalibrate.py <the same records files> --rerun out/pair-trials/records.jsonl \\
        out/rival-records/records.jsonl --configs ... --write

calibrates the gate with the rival's rule in force (a later file's record of a case replaces the earlier one).
Synthetic data: :mod:`bpmid.validation`, from the sweep configs and seeds given.
"""
from __future__ import annotations

from pathlib import Path


def same_candidates(old: dict, new: dict) -> bool:
    """Whether every candidate record of the old run is in the new one with the same numbers (and the rival's,
    where the old run recorded it). Records written before the path to the noise floor lack its numbers, and
    before it existed a permissive run could stop after a first round where no candidate had a finite gap share (a
    null): what they lack is not compared."""
    now = {(x["candidate"], x["round"], bool(x.get("rival"))): x for x in new.get("calibration_records") or []}
    for x in old.get("calibration_records") or []:
        y = now.get((x["candidate"], x["round"], bool(x.get("rival"))))
        if y is None or any(x.get(k) is not None and x.get(k) != y.get(k)
                            for k in ("gain_sigma", "lr_p", "lr_p_holm", "gap_share", "fit_share", "drop_sigma",
                                      "after_over_floor", "tested", "identifiable")):
            return False
    return True


def main(argv=None) -> int:
    import sys

    argv = list(sys.argv[1:] if argv is None else argv)
    rerun = []
    if "--rerun" in argv:   # old reruns (pair trials) replace the old records they rerun, for the comparison
        i = argv.index("--rerun")
        j = i + 1
        while j < len(argv) and not argv[j].startswith("--"):
            rerun.append(Path(argv[j]))
            j += 1
        del argv[i:j]
    from _reruns import rerun_and_compare, rerun_setup

    from bpmid.validation.sweep import calibration_records

    a, cases, old, done = rerun_setup(__doc__, argv)
    for i, r in calibration_records(rerun).items():
        if i in old:
            old[i] = r
    todo = [i for i in sorted(old) if old[i].get("calibration_records") and i not in done]
    print(f"{len(old)} calibration cases; {len(todo)} to rerun, {len(done)} already done", flush=True)
    if not todo:
        return 0
    return rerun_and_compare(
        a, cases, todo, lambda rec: same_candidates(old[rec["id"]], rec),
        lambda rec: f"{sum(1 for x in rec.get('calibration_records') or [] if x.get('rival'))} rival record(s)")

if __name__ == "__main__":
    raise SystemExit(main())
