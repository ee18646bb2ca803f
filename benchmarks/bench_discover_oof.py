"""Score ``bpmid discover`` on the held-out half of the out-of-family generator and print the table.

    python benchmarks/bench_discover_oof.py                         # held-out half of configs/sweeps/draw50.yaml
                                                                    # (the README's table), the shipped thresholds
    python benchmarks/bench_discover_oof.py --config configs/sweeps/full.yaml   # the first draw (seed 12)
    python benchmarks/bench_discover_oof.py --calibrate             # calibrate on the other half first
    python benchmarks/bench_discover_oof.py --limit 6 --workers 2   # a quick subset (first 6 held-out cases)

Data: :mod:`bpmid.validation` (independent physics; at least two physical forms per catalogue id, payload inertia,
Mullins and an air leak outside the catalogue, three geometries, 10-100 Hz, bar/kPa/psi absolute or gauge, white
and AR(1) noise, 0-5 % log-to-log variation, effects from just detectable to large, nulls and pairs). The split is
a hash of each case id, so calibration never sees a held-out case. Results stream to OUT/records.jsonl; rerunning
with the same --out resumes. Runs on Dask (``pip install 'bpmid[cluster]'``); --scheduler uses a running cluster.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default=str(REPO / "configs" / "sweeps" / "draw50.yaml"),
                    help="sweep config (default: the draw the README's table scores)")
    ap.add_argument("--out", default=str(REPO / "out" / "bench_discover_oof"), help="output folder (resumable)")
    ap.add_argument("--calibrate", action="store_true", help="calibrate on the calibration half first")
    ap.add_argument("--thresholds", default=None, help="thresholds file for the held-out half")
    ap.add_argument("--limit", type=int, default=None, help="only the first N cases of each half")
    ap.add_argument("--workers", type=int, default=None, help="LocalCluster workers (default: cores)")
    ap.add_argument("--scheduler", default=None, help="address of a running Dask scheduler")
    a = ap.parse_args(argv)

    from bpmid.validation.sweep import confusion_markdown, load_sweep, run_sweep

    cfg = load_sweep(a.config)
    t0 = time.perf_counter()
    res = run_sweep(cfg, a.out, split="all" if a.calibrate else "heldout", scheduler=a.scheduler,
                    workers=a.workers, thresholds_path=a.thresholds, max_cases=a.limit,
                    progress=lambda m: print(m, file=sys.stderr, flush=True))
    wall = time.perf_counter() - t0
    print(confusion_markdown(res.summary))
    ho = [r for r in res.records if r["split"] == "heldout"]
    secs = sorted(r["elapsed_s"] for r in ho)
    if secs:
        print(f"held-out cases: {len(ho)}; per case (generate + discover) median {secs[len(secs) // 2]:.1f} s, "
              f"max {secs[-1]:.1f} s; wall {wall:.0f} s (this run; resumed cases are not rerun)")
    print(f"records: {res.files['records']}; tables: {res.files.get('confusion_md')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
