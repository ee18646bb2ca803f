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
