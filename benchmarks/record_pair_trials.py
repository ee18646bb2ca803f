"""Record the first round's pair trials on finished calibration sweeps, rerunning only the cases where the path for
two effects at once can act.

    python benchmarks/record_pair_trials.py out/pool-draw12/records.jsonl ... \\
        --configs configs/sweeps/full.yaml ... --out out/pair-trials [--workers 2]

Calibration records written before the path existed lack its numbers (``calibration_pairs``). The path is asked
only in a first round where no candidate passes alone (the gate and the path to the noise floor of
``bpmid/discover/thresholds.yaml``), and it names two candidates only if both are among its leaders
(``pair_leaders``: the three largest positive held-out gains and the three smallest Holm-corrected p, among those
tested and identifiable) and pass the round's Holm-corrected test. Every other case's outcome cannot
change, so only the cases meeting both conditions are rerun, with the calibration half's permissive settings (which
record the pair trials), on Dask; a rerun is bit-for-bit the same run, so its single-candidate records equal the
old ones (checked: a case whose records differ is reported). Then

    python benchmarks/recalibrate.py <the same records files> out/pair-trials/records.jsonl --configs ... --write

calibrates the path with the rest of the gate (a later file's record of a case replaces the earlier one).
Synthetic data: :mod:`bpmid.validation`, from the sweep configs and seeds given.
"""
from __future__ import annotations


def selected(rec: dict, thr: dict) -> bool:
    """Whether the path for two effects at once can act on this case (see the module docstring)."""
    from bpmid.discover.calibrate import _first_passing, case_records, floor_drops, pair_leader_records

    r1 = [r for r in case_records(rec) if r.round == 1]
    if not r1 or _first_passing(r1, thr["heldout_gain_min_sigma"], thr["gap_share_min"], thr["family_alpha"],
                                thr["fit_share_min"], thr["fit_share_waived_above_sigma"],
                                floor_drops(thr)) is not None:
        return False
    return sum(r.lr_p_holm < thr["family_alpha"] for r in pair_leader_records(r1)) >= 2


def main(argv=None) -> int:
    from _reruns import rerun_and_compare, rerun_setup

    from bpmid.discover.calibrate import load_thresholds

    a, cases, old, done = rerun_setup(__doc__, argv)
    thr = load_thresholds()
    todo = [i for i in sorted(old) if selected(old[i], thr) and i not in done]
    kinds = {}
    for i in todo:
        kinds[old[i]["kind"]] = kinds.get(old[i]["kind"], 0) + 1
    print(f"{len(old)} calibration cases; {len(todo)} to rerun ({kinds}), {len(done)} already done", flush=True)
    if not todo:
        return 0
    def key(rec):
        return [(x["candidate"], x["round"], x["gain_sigma"]) for x in rec["calibration_records"]]
    return rerun_and_compare(a, cases, todo, lambda rec: key(old[rec["id"]]) == key(rec),
                             lambda rec: f"{len(rec.get('calibration_pairs') or [])} pair trial(s)")

if __name__ == "__main__":
    raise SystemExit(main())
