"""Rerun the calibration cases whose noise floor the current estimator reads differently: those with a log it
leaves out of the pooled floor (its own reading is its signal: ``bpmid.discover.diagnose.noise_floor``), or
check that there is none.

    python benchmarks/rerun_floor_cases.py out/pool-draw12/records.jsonl ... \\
        --configs configs/sweeps/full.yaml ... --out out/floor-reruns [--workers 2]

It lists the cases with a log left out (none, for the shipped rule on the shipped calibration records): a case
with no log left out gets exactly the floor the estimator gave before the rule existed (the same differences,
pooled in the same order), so its discovery, and its calibration records, are unchanged. It does not detect other
changes to the estimator. Only the listed cases are rerun, with the calibration half's permissive settings (which
record the pair trials too), on Dask. Each case's logs are regenerated from its sweep
config and seed and read back as discovery reads them, to decide. Then

    python benchmarks/recalibrate.py <the same records files> out/pair-trials/records.jsonl \\
        out/floor-reruns/records.jsonl --configs ... --write

calibrates on the records as the current code makes them (a later file's record of a case replaces the earlier
one). Synthetic data: :mod:`bpmid.validation`, from the sweep configs and seeds given.
"""
from __future__ import annotations

import concurrent.futures as cf
import tempfile
import time
from pathlib import Path


def left_out_logs(case) -> tuple[str, list[str], float]:
    """(case id, the logs the noise floor leaves out, the floor in deg) of one case, from its logs as written."""
    import shutil

    from bpmid.discover.diagnose import noise_floor
    from bpmid.validation.sweep import read_written_case, realize, write_case

    root = Path(tempfile.mkdtemp(prefix="bpmid-floor-"))
    try:
        write_case(realize(case), root)
        _, _, fit, ho = read_written_case(root / case.id)
        nf = noise_floor(fit + ho)
        return case.id, list(nf["left_out"]), float(nf["sigma_deg"])
    finally:
        shutil.rmtree(root, ignore_errors=True)


def main(argv=None) -> int:
    from _reruns import rerun_setup

    from bpmid.validation.sweep import rerun_calibration

    a, cases, old, done = rerun_setup(__doc__, argv)
    t0 = time.perf_counter()
    todo = []
    with cf.ProcessPoolExecutor(max_workers=a.workers) as ex:
        futs = [ex.submit(left_out_logs, cases[i][1]) for i in sorted(old) if i not in done]
        for k, f in enumerate(cf.as_completed(futs), 1):
            cid, out, floor = f.result()
            if out:
                todo.append(cid)
                was = old[cid].get("noise_floor_deg")
                print(f"[{k}/{len(futs)}] {cid}: left out {', '.join(out)}; floor {floor:.4f} deg"
                      + (f" (record: {was:.4f})" if was is not None else ""), flush=True)
    todo.sort()
    print(f"{len(old)} calibration cases; {len(todo)} with a log left out of the floor, to rerun; {len(done)} "
          f"already done ({time.perf_counter() - t0:.0f} s)", flush=True)
    if not todo:
        return 0
    n = [0]

    def on(rec):
        n[0] += 1
        print(f"[{n[0]}/{len(todo)}] {rec['id']} ({rec['kind']}): named {rec.get('named')} (was "
              f"{old[rec['id']].get('named')}), floor {rec.get('noise_floor_deg')}, {rec['elapsed_s']:.1f} s",
              flush=True)
    rerun_calibration([cases[i] for i in todo], a.out, a.workers, on)
    print(f"done in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
