"""Compare two ``bpmid run`` output folders file by file: which CSV columns and YAML keys differ.

Run ``python benchmarks/diff_outputs.py DIR_A DIR_B``. Every CSV, YAML and text file in either folder is compared
(figures are not); the output folders' own paths are made equal first (they are recorded in provenance). Prints,
per file, the CSV columns or the YAML keys (dotted, list indices as [*]) whose values differ, and exits 1 when
anything else than those listed by ``--allow`` (and, with ``--timing``, the wall-clock keys of :data:`TIMING`)
differs. The report (report.md, report.html) is compared as text: it quotes the timings too.
"""
from __future__ import annotations

import argparse
import csv
import io
import re
import sys
from pathlib import Path

import yaml


#: what differs between two runs of one config on purpose: wall-clock times and what records them
TIMING = {
    "us_per_step", "seconds", "fit_seconds", "elapsed_s", "data.fit_seconds", "fit.seconds", "stages[*].seconds",
    "summary[*].us_per_step", "window_cost_reduction_pct", "us_per_step_longest.full",
    "us_per_step_longest.recursive", "us_per_step_longest.window", "feedforward.cost.incremental_kernel_us_per_step",
    "feedforward.cost.vectorised_inverse_us_per_sample", "feedforward.cost.share_of_period_pct",
    "provenance.created", "provenance.command", "provenance.inputs.<OUT>/relax_fit.yaml",
    "provenance.inputs.<OUT>/vbmm_fit.yaml",
} | {f"models.{m}.fit_seconds" for m in ("gpi", "maxwell-slip", "three-element", "two-branch", "vbmm-fit",
                                          "vbmm-mat")}


def _flat(obj, prefix="", out=None):
    out = {} if out is None else out
    if isinstance(obj, dict):
        for k, v in obj.items():
            _flat(v, f"{prefix}.{k}" if prefix else str(k), out)
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            _flat(v, f"{prefix}[{i}]", out)
    else:
        out[prefix] = obj
    return out


def _generic(key: str) -> str:
    return re.sub(r"\[\d+\]", "[*]", key)


def differing(a: Path, b: Path, text_a: str, text_b: str) -> set[str]:
    """Names of what differs: CSV column names, YAML keys (generic), or '<text>' for other files."""
    if a.suffix == ".csv":
        ra = list(csv.reader(io.StringIO(text_a)))
        rb = list(csv.reader(io.StringIO(text_b)))
        if not ra or not rb or ra[0] != rb[0] or len(ra) != len(rb):
            return {"<shape or header>"}
        cols = set()
        for x, y in zip(ra[1:], rb[1:]):
            for name, u, v in zip(ra[0], x, y):
                if u != v:
                    cols.add(name)
        return cols
    if a.suffix == ".yaml":
        fa, fb = _flat(yaml.safe_load(text_a)), _flat(yaml.safe_load(text_b))
        return {_generic(k) for k in set(fa) | set(fb) if fa.get(k, "<absent>") != fb.get(k, "<absent>")}
    return {"<text>"} if text_a != text_b else set()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a", type=Path)
    ap.add_argument("b", type=Path)
    ap.add_argument("--allow", default="", help="comma-separated column names / generic YAML keys that may differ")
    ap.add_argument("--timing", action="store_true", help="allow the wall-clock columns and keys of a bpmid run "
                    "(TIMING), the creation time and command line in provenance, and the sha256 of the two "
                    "outputs that carry a fit time (relax_fit.yaml, vbmm_fit.yaml) where later stages record them")
    args = ap.parse_args()
    allow = {s for s in args.allow.split(",") if s} | (TIMING if args.timing else set())
    names = sorted({p.relative_to(d).as_posix() for d in (args.a, args.b) for p in d.rglob("*")
                    if p.is_file() and p.suffix in (".csv", ".yaml", ".txt", ".md", ".html")})
    bad = False
    for n in names:
        pa, pb = args.a / n, args.b / n
        if not (pa.is_file() and pb.is_file()):
            print(f"{n}: only in {'A' if pa.is_file() else 'B'}")
            bad = True
            continue
        ta = pa.read_text(encoding="utf-8", errors="replace").replace(str(args.a.resolve()), "<OUT>").replace(
            str(args.a), "<OUT>")
        tb = pb.read_text(encoding="utf-8", errors="replace").replace(str(args.b.resolve()), "<OUT>").replace(
            str(args.b), "<OUT>")
        d = differing(pa, pb, ta, tb)
        if d:
            extra = sorted(d - allow)
            bad |= bool(extra)
            print(f"{n}: {', '.join(sorted(d))}" + (f"   NOT ALLOWED: {', '.join(extra)}" if extra else ""))
    print("identical apart from the allowed columns/keys" if not bad else "DIFFERENCES beyond the allowed ones")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
