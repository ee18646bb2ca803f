"""Discovery's model evaluation (one simulation of every log, as each residual of a refit) against the bare
compiled forward kernel on the same logs and constants, in the same process.

    python benchmarks/bench_discover_eval.py [--rounds 7] [--evals 200]

Data: the paper-sized set (:func:`bpmid.discover.calibrate.paper_sized_set`: paper protocols, 10 Hz, 7 fitting +
4 held-out logs; synthetic, seed 0, no effect hidden), the 11 logs together. Three evaluations are timed:
``kernel`` (``_vbmm_kernels.forward_kernel`` called directly on each log: the floor), ``vbmm`` (``simulate`` of
the base model: what a base refit pays) and ``lag`` (``simulate`` with a pressure lag added: a refit of a candidate
effect, the lag's own kernel included). Prints the median microseconds per evaluation over ``--rounds``
rounds of ``--evals`` evaluations each, interleaved, and the ratio of each to the kernel: the Python around the
kernel is what this ratio measures (a stop-45 change cut it; every number the evaluation returns is unchanged).
Timings never gate a test.
"""
from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

from bpmid.discover.calibrate import paper_sized_set, start_model
from bpmid.discover.model import ModelState, simulate
from bpmid.effects import get_effect
from bpmid.models import _vbmm_kernels as K
from bpmid.models.vbmm.model import _CLOSURES, _MODES


def kernel_eval(model, logs) -> list[np.ndarray]:
    m = model.material
    G, tauG, Kb, tauK = (np.asarray(v, float) for v in (m.G, m.tauG, m.K, m.tau_K))
    geo = model.geometry.vector()
    out = []
    for lg in logs:
        t = np.ascontiguousarray(lg.time_s, float)
        out.append(K.forward_kernel(t, np.ascontiguousarray(lg.pressure_pa, float), geo, _CLOSURES[model.closure],
                                    float(m.G_inf), G, tauG, float(m.K_inf), Kb, tauK, _MODES[model.history],
                                    float(model.window_s), float(model.fall_ratio), float(model.stiffening),
                                    np.ones_like(t))[0])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--evals", type=int, default=200)
    a = ap.parse_args()
    fit, ho = paper_sized_set(None, seed=0)
    logs = list(fit) + list(ho)
    base = start_model()
    state = ModelState.start(base)
    lag = state.with_effect(get_effect("pressure_lag"))
    # the same numbers: the base evaluation is the kernel's angle in degrees
    for a_, b_ in zip(simulate(state, logs), kernel_eval(state.fitted_vbmm(), logs)):
        np.testing.assert_allclose(a_, np.degrees(b_), rtol=0, atol=1e-12)
    runs = {"kernel": lambda: kernel_eval(state.fitted_vbmm(), logs), "vbmm": lambda: simulate(state, logs),
            "lag": lambda: simulate(lag, logs)}
    for f in runs.values():   # compile and warm
        f()
    times = {k: [] for k in runs}
    for _ in range(a.rounds):
        for k, f in runs.items():
            t0 = time.perf_counter()
            for _ in range(a.evals):
                f()
            times[k].append((time.perf_counter() - t0) / a.evals * 1e6)
    med = {k: statistics.median(v) for k, v in times.items()}
    n = sum(lg.n for lg in logs)
    print(f"{len(logs)} logs, {n} samples; load average {os.getloadavg()[0]:.2f} (cores: {os.cpu_count()})")
    print(f"{'evaluation':12s} {'us/eval':>10s} {'x kernel':>9s}")
    for k, v in med.items():
        print(f"{k:12s} {v:10.1f} {v / med['kernel']:9.2f}")


if __name__ == "__main__":
    main()
