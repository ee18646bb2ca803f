"""Cost of each baseline's simulate (us per step) against a pure-python loop, plus the external check.

Run: ``python benchmarks/bench_baselines.py`` (prints a table; never gates a test). The pure-python
baselines implement the same recursion sample by sample in the same process, so the ratio is the
speed-up of the compiled kernel plus vectorised envelopes.
"""
from __future__ import annotations

import time

import numpy as np

from bpmid.external import friction
from bpmid.io.motion_logs import from_arrays
from bpmid.models import model_class

N = 200_000
BUDGET_US = 5.0


def pressure_log(n: int = N, dt: float = 0.01):
    t = np.arange(n) * dt
    p = 0.7 + 0.45 * np.sin(2 * np.pi * t / 7.0) + 0.05 * np.sin(2 * np.pi * t / 1.3)
    return from_arrays("bench", t, p * 1e5)


def best_time(fn, repeat: int = 5) -> float:
    fn()  # compile / warm caches
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def python_play(u, r):
    z, out = [0.0] * len(r), []
    for uk in u:
        z = [max(uk - ri, min(uk + ri, zi)) for ri, zi in zip(r, z)]
        out.append(sum(z))
    return out


def python_stop(u, slip):
    d, prev, out = [0.0] * len(slip), u[0], []
    for uk in u:
        du, prev = uk - prev, uk
        d = [max(-s, min(s, di + du)) for s, di in zip(slip, d)]
        out.append(sum(d))
    return out


def python_first_order(eq, decay):
    y, out = eq[0], []
    for e, a in zip(eq, decay):
        y = e + (y - e) * a
        out.append(y)
    return out


def main() -> None:
    log = pressure_log()
    u = list(log.pressure_pa[:20_000] / 1e5)
    py = {"gpi": best_time(lambda: python_play(u, [0.05 * i for i in range(1, 11)]), 1) / len(u),
          "maxwell-slip": best_time(lambda: python_stop(u, [0.01, 0.05, 0.1, 0.3]), 1) / len(u),
          "three-element": best_time(lambda: python_first_order(u, u), 1) / len(u),
          "two-branch": best_time(lambda: [1.0 if b > a else -1.0 for a, b in zip(u[:-1], u[1:])], 1) / len(u)}
    print(f"simulate cost, {N} steps per call (budget {BUDGET_US} us/step)")
    print(f"{'family':<15}{'us/step':>10}{'pure python us/step':>22}{'speed-up':>10}  ok")
    for name in ("gpi", "maxwell-slip", "three-element", "two-branch"):
        model = model_class(name)()
        params = model.default_params()
        per_step = best_time(lambda: model.simulate(params, log)) / log.n * 1e6
        base = py[name] * 1e6
        print(f"{name:<15}{per_step:>10.3f}{base:>22.3f}{base / per_step:>10.1f}  {'yes' if per_step <= BUDGET_US else 'NO'}")
    print("\nexternal check: real friction hysteresis (displacement in, force out), last 2 strokes held out")
    print(f"{'file':<16}{'loop N':>8}{'MS rmse N':>11}{'MS max N':>10}{'GPI rmse N':>12}{'GPI max N':>11}")
    for res in friction.external_check_all():
        ms, gpi = res["models"]["maxwell-slip"], res["models"]["gpi"]
        print(f"{res['file']:<16}{res['loop_height_n']:>8.1f}{ms['rmse_n']:>11.2f}{ms['max_abs_err_n']:>10.2f}"
              f"{gpi['rmse_n']:>12.2f}{gpi['max_abs_err_n']:>11.2f}")


if __name__ == "__main__":
    main()
