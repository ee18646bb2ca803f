"""What the calibration rerun scripts share (record_pair_trials.py, rerun_floor_cases.py): their arguments, the
cases of the given sweep configs, the calibration records to compare with and the cases already rerun."""
from __future__ import annotations

import argparse
from pathlib import Path


def rerun_setup(doc: str, argv=None):
    """(arguments, cases by id, old calibration records by id, ids already rerun into ``--out``)."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("records", nargs="+", type=Path, help="records.jsonl of finished calibration sweeps")
    ap.add_argument("--configs", nargs="+", required=True, help="the sweep configs the records were made with")
    ap.add_argument("--out", type=Path, required=True, help="folder for the rerun cases' records.jsonl")
    ap.add_argument("--workers", type=int, default=2, help="Dask workers (processes) for the reruns (default 2)")
    a = ap.parse_args(argv)

    from bpmid.validation.sweep import calibration_records, cases_by_id, read_records

    cases = cases_by_id(a.configs)
    old = calibration_records(a.records)
    missing = sorted(i for i in old if i not in cases)
    if missing:
        ap.error(f"{len(missing)} record(s) from no given config, e.g. {missing[0]}: give its sweep config")
    a.out.mkdir(parents=True, exist_ok=True)
    done = {r["id"] for r in read_records(a.out / "records.jsonl")}
    return a, cases, old, done


def rerun_and_compare(a, cases, todo, same, what) -> int:
    """Rerun the cases ``todo`` (ids) with their config's calibration settings into ``a.out``, printing each as it
    finishes with ``what(record)``; ``same(record)`` says whether it reproduced the old run. Exit code: 1 when any
    case did not."""
    import time

    from bpmid.validation.sweep import rerun_calibration

    n, t0, differ = [0], time.perf_counter(), []

    def on(rec):
        n[0] += 1
        ok = same(rec)
        if not ok:
            differ.append(rec["id"])
        print(f"[{n[0]}/{len(todo)}] {rec['id']} ({rec['kind']}): {what(rec)}, {rec['elapsed_s']:.1f} s"
              f"{'' if ok else '; records differ from the old run'}", flush=True)
    rerun_calibration([cases[i] for i in todo], a.out, a.workers, on)
    print(f"done in {time.perf_counter() - t0:.0f} s; {len(differ)} case(s) whose records differ from the old run"
          f"{': ' + ', '.join(differ) if differ else ''}")
    return 1 if differ else 0
