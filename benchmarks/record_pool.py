"""Run the gate's calibration cases from their sweep configs alone, with the calibration half's permissive settings
(no earlier records needed): every case of each config's chosen halves, on Dask, resumable (cases already in
``OUT/records.jsonl`` are skipped).

    python benchmarks/record_pool.py configs/sweeps/full.yaml:all configs/sweeps/draw13.yaml:all \\
        configs/sweeps/draw14.yaml:heldout configs/sweeps/draw15.yaml:heldout --out out/pool [--workers 2]

These are the 720 cases the shipped gate is calibrated on (both halves of draws 12 and 13, the held-out halves of
draws 14 and 15, whose calibration halves were never run). Then

    python benchmarks/recalibrate.py out/pool/records.jsonl --configs configs/sweeps/full.yaml \\
        configs/sweeps/draw13.yaml configs/sweeps/draw14.yaml configs/sweeps/draw15.yaml [--write]

Synthetic data: :mod:`bpmid.validation`, from the sweep configs and seeds given.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("configs", nargs="+", help="CONFIG:HALF, HALF one of all, calibration, heldout")
    ap.add_argument("--out", type=Path, required=True, help="folder for records.jsonl")
    ap.add_argument("--workers", type=int, default=2, help="Dask workers (processes; default 2)")
    ap.add_argument("--only", nargs="+", default=None, metavar="ID",
                    help="run only these cases (ids as in records.jsonl), e.g. those a code change can affect; "
                         "recalibrate.py --rerun OUT/records.jsonl then takes their records over the earlier ones")
    a = ap.parse_args(argv)

    from bpmid.errors import InputError
    from bpmid.validation.sweep import load_sweep, make_cases, read_records, rerun_calibration

    chosen, example = [], ""
    for spec in a.configs:
        path, _, half = spec.rpartition(":")
        if not path or half not in ("all", "calibration", "heldout"):
            ap.error(f"{spec!r}: give CONFIG:HALF with HALF all, calibration or heldout")
        try:
            cfg = load_sweep(path)
        except InputError as e:
            ap.error(str(e))
        cases = make_cases(cfg.effective_generator, cfg.sweep.seed, prefix=cfg.sweep.name)
        example = example or (cases[0].id if cases else "")
        chosen += [(cfg, c) for c in cases if (half == "all" or c.split == half)
                   and (a.only is None or c.id in a.only)]
    if a.only is not None and len(chosen) < len(set(a.only)):
        unknown = sorted(set(a.only) - {c.id for _, c in chosen})
        ap.error(f"--only: {', '.join(unknown[:5])}{' ...' if len(unknown) > 5 else ''} not among the chosen halves "
                 f"of the configs (ids look like {example})")
    a.out.mkdir(parents=True, exist_ok=True)
    done = {r["id"] for r in read_records(a.out / "records.jsonl")}
    todo = [(cfg, c) for cfg, c in chosen if c.id not in done]
    print(f"{len(chosen)} calibration cases; {len(todo)} to run, {len(chosen) - len(todo)} already done", flush=True)
    n, t0 = [0], time.perf_counter()

    def on(rec):
        n[0] += 1
        print(f"[{n[0]}/{len(todo)}] {rec['id']} ({rec['kind']}): {rec['elapsed_s']:.1f} s, "
              f"{time.perf_counter() - t0:.0f} s in all", flush=True)
    if todo:
        rerun_calibration(todo, a.out, a.workers, on)
    print(f"done in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
