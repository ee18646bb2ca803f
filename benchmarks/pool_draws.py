"""Pool the held-out scores of several draws of the out-of-family sweep into one table (issue 12's five targets).

Each draw is scored once by ``bpmid calibrate configs/sweeps/drawN.yaml --split heldout --out out/ho-drawN``;
this reads the ``summary.yaml`` each run wrote and adds the counts up, draw by draw and in total:

    python benchmarks/pool_draws.py out/ho-draw45 out/ho-draw46 out/ho-draw47 out/ho-draw48

Synthetic data: the summaries are of :mod:`bpmid.validation` cases (each run's ``sweep.yaml`` names config and seed).
"""
from __future__ import annotations

import argparse
from pathlib import Path

import yaml

# (summary key, count of successes, label, target)
CRITERIA = (
    ("single_named_first_right", "right", "single effect named first right", ">= 90 %"),
    ("null_false_positive", "named_something", "nulls with an effect named", "none, on >= 20"),
    ("pair_both_named", "both", "both effects named in two-effect cases", ">= 80 %"),
    ("out_of_catalogue_nothing_named", "nothing", "nothing named out of the catalogue", ">= 80 %"),
    ("gap_halved_where_named", "halved", "gap at least halved where named", "always"),
)


def _summary(path: Path) -> dict:
    file = path / "summary.yaml" if path.is_dir() else path
    if not file.is_file():
        raise SystemExit(f"error: {file}: no summary.yaml (run `bpmid calibrate ... --split heldout --out {path}`)")
    data = yaml.safe_load(file.read_text())
    if data.get("split") != "heldout":
        raise SystemExit(f"error: {file}: split is {data.get('split')!r}, not 'heldout': only held-out halves are scored")
    return data


def pool(summaries: list[dict]) -> dict[str, tuple[int, int]]:
    """Total (successes, cases) per criterion over the given summaries."""
    return {key: (sum(s[key][hit] for s in summaries), sum(s[key]["n"] for s in summaries))
            for key, hit, _, _ in CRITERIA}


def _cell(hit: int, n: int) -> str:
    return f"{hit}/{n} ({100 * hit / n:.1f} %)" if n else "-"


def table(names: list[str], summaries: list[dict]) -> str:
    head = ["criterion", "target", *names, "pooled"]
    rows = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    total = pool(summaries)
    for key, hit, label, target in CRITERIA:
        cells = [_cell(s[key][hit], s[key]["n"]) for s in summaries] + [_cell(*total[key])]
        rows.append("| " + " | ".join([label, target, *cells]) + " |")
    n = sum(s["n_cases"] for s in summaries)
    return "\n".join(rows) + f"\n\n{len(summaries)} held-out halves, {n} cases (synthetic: bpmid.validation)"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("runs", nargs="+", type=Path, help="out/ho-drawN folders (or their summary.yaml)")
    args = ap.parse_args()
    summaries = [_summary(p) for p in args.runs]
    names = [(p if p.is_dir() else p.parent).name for p in args.runs]
    print(table(names, summaries))


if __name__ == "__main__":
    main()
