"""Start-up cost of the command line, as a user meets it (whole processes, medians, ratios in one run).

Run ``python benchmarks/bench_startup.py [--repeats N]``. Prints, each against a bare interpreter measured in
the same run:

- ``bpmid --version`` and ``bpmid --help`` against ``python -c "import numpy"`` (target: within 2x)
- ``bpmid fit relax`` on pyvisco's measured master curve (with and without the figure) against
  ``python -c "import numpy, scipy.optimize"`` (target: within 2x)
- ``import bpmid`` against a bare ``python -c pass``

Timings never gate a test; they depend on the machine and its load.
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


def run(args: list[str], repeats: int, env: dict) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        subprocess.run(args, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    a = ap.parse_args()
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    env.setdefault("NUMBA_CACHE_DIR", str(ROOT / ".numba_cache"))
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # a user's install has its bytecode cached (pip writes it)
    py = sys.executable
    bpmid = [py, "-m", "bpmid"]
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "master_fit.yaml")
        fit = bpmid + ["fit", "relax", str(MASTER), "--out", out]
        run(fit, 1, env)  # compiled kernels into the numba cache; file-system caches warm
        rows = [
            ("python -c pass", [py, "-c", "pass"], None),
            ("python -c 'import numpy'", [py, "-c", "import numpy"], None),
            ("python -c 'import numpy, scipy.optimize'", [py, "-c", "import numpy, scipy.optimize"], None),
            ("python -c 'import bpmid'", [py, "-c", "import bpmid"], "python -c pass"),
            ("bpmid --version", bpmid + ["--version"], "python -c 'import numpy'"),
            ("bpmid --help", bpmid + ["--help"], "python -c 'import numpy'"),
            ("bpmid fit relax --help", bpmid + ["fit", "relax", "--help"], "python -c 'import numpy'"),
            ("bpmid fit relax master curve --no-figure", fit + ["--no-figure"],
             "python -c 'import numpy, scipy.optimize'"),
            ("bpmid fit relax master curve (with figure)", fit, "python -c 'import numpy, scipy.optimize'"),
        ]
        got = {}
        print(f"{'command':<46}{'median s':>10}{'ratio':>8}  against")
        for name, args, base in rows:
            got[name] = run(args, a.repeats, env)
            ratio = "" if base is None else f"{got[name] / got[base]:8.2f}"
            print(f"{name:<46}{got[name]:>10.3f}{ratio:>8}  {base or ''}")


if __name__ == "__main__":
    main()
