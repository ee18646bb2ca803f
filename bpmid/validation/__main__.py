"""Write out-of-family cases to disk without running discovery (for people who want to try them by hand).

    python -m bpmid.validation configs/sweeps/small.yaml --out out/oof-cases [--split heldout] [--limit N]

writes ``OUT/cases/<id>/`` (fit/*.csv, holdout/*.csv, case.yaml, init.yaml; run each with the command in its
case.yaml) and the truth apart, in ``OUT/answers/<split>.yaml``. Synthetic data, labelled in every file.
"""
from __future__ import annotations

import argparse
import sys


def main(argv=None) -> int:
    from bpmid.errors import InputError
    from bpmid.validation.generator import make_cases, realize, write_answers, write_case
    from bpmid.validation.sweep import load_sweep

    ap = argparse.ArgumentParser(prog="python -m bpmid.validation", description=__doc__.splitlines()[0])
    ap.add_argument("sweep", help="sweep config (configs/sweeps/*.yaml); its generator and rig sections are used")
    ap.add_argument("--out", required=True, help="output folder")
    ap.add_argument("--split", default="all", choices=("calibration", "heldout", "all"))
    ap.add_argument("--limit", type=int, default=None, help="only the first N cases of the split")
    a = ap.parse_args(argv)
    try:
        cfg = load_sweep(a.sweep)
    except InputError as exc:
        print(f"error: {exc.format()}", file=sys.stderr)
        return 2
    gen = cfg.effective_generator
    cases = [c for c in make_cases(gen, cfg.sweep.seed, prefix=cfg.sweep.name) if a.split in ("all", c.split)]
    cases = cases[: a.limit] if a.limit is not None else cases
    entries: dict[str, list] = {"calibration": [], "heldout": []}
    for k, case in enumerate(cases, start=1):
        entries[case.split].append(write_case(realize(case), f"{a.out}/cases"))
        print(f"[{k}/{len(cases)}] {case.id}", file=sys.stderr, flush=True)
    for split, ent in entries.items():
        if ent:
            write_answers(ent, f"{a.out}/answers/{split}.yaml", config=gen, seed=cfg.sweep.seed)
    print(f"wrote {len(cases)} cases to {a.out}/cases and the truth to {a.out}/answers/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
