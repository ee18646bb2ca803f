"""Wall time of a warm ``bpmid run`` (the whole study on the shipped data, as a user runs it), with per-stage times.

Run ``python benchmarks/bench_run.py [--repeats N] [--workers W ...] [--keep DIR]``. One run first fills the numba
cache (not counted); then each setting of ``--workers`` (default ``2 1``: two stages side by side, and one stage
after another; ``0``, the default of ``bpmid run``, picks by the idle cores) is timed ``--repeats`` times,
interleaved, as whole processes (``python -m bpmid run``). Prints the median wall time per setting, the CPU time
of the run with its stage processes (user + system: what the run costs the machine, much less sensitive to other
work on it than the wall time), the median seconds of every stage (from ``run.yaml``), the time outside the
stages (start-up, reading and checking every input, run.yaml), and the load average before and after: the
machine may be shared, so read the numbers with it. Timings never gate a test.
"""
from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
STAGES = ("relax", "motion", "compare", "history", "discover", "control", "report")


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def one_run(out: Path, workers: int, env: dict) -> tuple[float, float, dict]:
    """Wall seconds, CPU seconds (user + system of the run and its stage processes) and the stages' seconds."""
    c0, t0 = _cpu(), time.perf_counter()
    subprocess.run([sys.executable, "-m", "bpmid", "run", "--out", str(out), "--workers", str(workers)], env=env,
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT)
    wall, cpu = time.perf_counter() - t0, _cpu() - c0
    rec = yaml.safe_load((out / "run.yaml").read_text())
    return wall, cpu, {s["name"]: s["seconds"] for s in rec["stages"] if s["status"] == "done"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--workers", type=int, nargs="+", default=[2, 1])
    ap.add_argument("--keep", type=Path, default=None, help="keep the last run of each setting in DIR/w<W>")
    a = ap.parse_args()
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    env.setdefault("NUMBA_CACHE_DIR", str(ROOT / ".numba_cache"))
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # a user's install has its bytecode cached
    print(f"load average before: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} (cores: {os.cpu_count()})")
    with tempfile.TemporaryDirectory() as tmp:
        base = a.keep or Path(tmp)
        one_run(Path(tmp) / "warm", 0, env)  # numba cache and file-system caches warm
        walls = {w: [] for w in a.workers}
        cpus = {w: [] for w in a.workers}
        stages = {w: {s: [] for s in STAGES} for w in a.workers}
        for _ in range(a.repeats):
            for w in a.workers:
                wall, cpu, st = one_run(base / f"w{w}", w, env)
                walls[w].append(wall)
                cpus[w].append(cpu)
                for s, v in st.items():
                    stages[w][s].append(v)
    print(f"load average after: {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f}")
    print(f"{'workers':<9}{'wall s':>8}{'CPU s':>8}  " + "".join(f"{s:>9}" for s in STAGES) + f"{'outside':>9}   "
          f"(medians of {a.repeats})")
    for w in a.workers:
        med = {s: statistics.median(v) for s, v in stages[w].items() if v}
        wall = statistics.median(walls[w])
        # side by side the stage times overlap, so "outside" (wall minus the stages) means nothing there
        outside = f"{wall - sum(med.values()):>9.2f}" if w == 1 else f"{'-':>9}"
        print(f"{w:<9}{wall:>8.2f}{statistics.median(cpus[w]):>8.2f}  "
              + "".join(f"{med.get(s, float('nan')):>9.2f}" for s in STAGES) + outside
              + ("   (stage times overlap)" if w != 1 else ""))
    print("runs of each setting, wall s: " + "; ".join(f"{w}: " + ", ".join(f"{x:.1f}" for x in walls[w])
                                                      for w in a.workers))


if __name__ == "__main__":
    main()
