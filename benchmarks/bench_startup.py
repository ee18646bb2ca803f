"""Start-up cost of the command line, as a user meets it (whole processes, medians, ratios in one run).

Run ``python benchmarks/bench_startup.py [--repeats N]``. Prints, each against a bare interpreter measured in
the same run:

- ``bpmid --version`` and ``bpmid --help`` against ``python -c "import numpy"`` (target: within 2x)
- ``bpmid fit relax`` on pyvisco's measured master curve (with and without the figure) against
  ``python -c "import numpy, scipy.optimize"`` (target: within 2x)
- ``import bpmid`` against a bare ``python -c pass``

The commands are run interleaved (one of each per round, ``--repeats`` rounds), so a change of the machine's
load hits all of them alike; the load average is printed with the numbers. ``--only-relax`` times just the
``bpmid fit relax`` line against its baseline (more rounds in the same time). Timings never gate a test; they
depend on the machine and its load.
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MASTER = ROOT / "datasets" / "reference" / "pyvisco" / "time_user_master.csv"


def once(args: list[str], env: dict) -> float:
    t0 = time.perf_counter()
    subprocess.run(args, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--only-relax", action="store_true", help="only bpmid fit relax --no-figure and its baseline")
    a = ap.parse_args()
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    env.setdefault("NUMBA_CACHE_DIR", str(ROOT / ".numba_cache"))
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # a user's install has its bytecode cached (pip writes it)
    py = sys.executable
    bpmid = [py, "-m", "bpmid"]
    base = "python -c 'import numpy, scipy.optimize'"
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "master_fit.yaml")
        fit = bpmid + ["fit", "relax", str(MASTER), "--out", out]
        once(fit, env)  # compiled kernels into the numba cache; file-system caches and bytecode warm
        rows = [
            ("python -c pass", [py, "-c", "pass"], None),
            ("python -c 'import numpy'", [py, "-c", "import numpy"], None),
            (base, [py, "-c", "import numpy, scipy.optimize"], None),
            ("python -c 'import bpmid'", [py, "-c", "import bpmid"], "python -c pass"),
            ("bpmid --version", bpmid + ["--version"], "python -c 'import numpy'"),
            ("bpmid --help", bpmid + ["--help"], "python -c 'import numpy'"),
            ("bpmid fit relax --help", bpmid + ["fit", "relax", "--help"], "python -c 'import numpy'"),
            ("bpmid fit relax master curve --no-figure", fit + ["--no-figure"], base),
            ("bpmid fit relax master curve (with figure)", fit, base),
        ]
        if a.only_relax:
            rows = [r for r in rows if r[0] in (base, "bpmid fit relax master curve --no-figure")]
        load0 = os.getloadavg()[0]
        times: dict[str, list[float]] = {name: [] for name, _, _ in rows}
        for _ in range(a.repeats):
            for name, args, _ in rows:
                times[name].append(once(args, env))
        load1 = os.getloadavg()[0]
    got = {k: statistics.median(v) for k, v in times.items()}
    print(f"{'command':<46}{'median s':>10}{'ratio':>8}  against   ({a.repeats} interleaved rounds; load average "
          f"{load0:.2f} -> {load1:.2f} on {os.cpu_count()} cores)")
    for name, _, ref in rows:
        ratio = "" if ref is None else f"{got[name] / got[ref]:8.2f}"
        print(f"{name:<46}{got[name]:>10.3f}{ratio:>8}  {ref or ''}")
    # the ratio of the medians, and the median of the per-round ratios (each round's pair ran back to back)
    per_round = [x / y for x, y in zip(times["bpmid fit relax master curve --no-figure"], times[base])]
    print(f"fit relax (no figure) / bare numpy+scipy.optimize: {got['bpmid fit relax master curve --no-figure'] / got[base]:.2f} "
          f"(the ratio of the medians, the figure the README quotes and the 2x target judges; the median of the "
          f"per-round ratios, {statistics.median(per_round):.2f}, shows how much one round's load moves it)")


if __name__ == "__main__":
    main()
