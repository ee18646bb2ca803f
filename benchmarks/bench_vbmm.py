"""Benchmarks of the VBMM (a script that prints tables; timings never gate a test).

1. forward model, recursive history, one branch: us per step, against a pure-Python/numpy baseline
   (the same per-step bracketed Newton solve in interpreted Python) measured in the same run
2. cost per step against log length (60-1800 s at 10 Hz) for the three history modes: the shape of the
   paper's Fig. 17(b) (full history grows linearly, sliding window and recursive stay flat)
3. ``fit motion`` on a paper-sized data set: the fitting set (cyclic 1.2-1.6 bar abs, 60 s) plus five logs
   (variable-amplitude sequence 1.2-1.8/2.0/2.2 bar abs at 0.2 bar/s, 30 s each), 10 Hz, 0.5 deg noise

Run:  python benchmarks/bench_vbmm.py [--quick]
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np

from bpmid.io.motion_logs import from_arrays
from bpmid.models.vbmm import VBMM, Geometry, Material, triangle_pressure
from bpmid.motion_fit import fit_motion

ATM_BAR = 1.01325


def experiment2_pressure(duration_s: float, dt: float = 0.1):
    """Repetitions of the variable-amplitude sequence (30 s each), gauge Pa."""
    t = np.round(np.arange(0.0, duration_s, dt), 10)
    ph = np.mod(t, 30.0)
    p_abs = np.where(ph < 6.0, triangle_pressure(ph, 1.2, 1.8, 0.2),
                     np.where(ph < 14.0, triangle_pressure(ph - 6.0, 1.2, 2.0, 0.2),
                              triangle_pressure(ph - 14.0, 1.2, 2.2, 0.2)))
    return t, (p_abs - ATM_BAR) * 1e5


def python_forward_recursive(t, p, mat: Material, geo: Geometry = Geometry()):
    """Baseline: the same recursive forward solve in plain Python (math module, no compilation)."""
    th, a0, R0, l0, n = geo.th, geo.alpha0, geo.R0, geo.l0, geo.n
    pn2 = 4 * math.pi**2 * n**2
    D, E = l0**2 + pn2 * R0**2, pn2**2 * R0**2
    A, B = -math.pi**2 * n**2 / l0**2, -4 * math.pi**2 * n**2 * R0 / l0**2
    Gi, Ki, G1, K1, tau = mat.G_inf, mat.K_inf, mat.G[0], mat.K[0], mat.tauG[0]

    def kin(beta):
        u3 = -2 * R0 + (2 * math.sqrt(D * beta * beta + E) - 2 * l0 * beta) / (beta * beta + pn2)
        F = math.sqrt(1 + A * u3 * u3 + B * u3)
        return u3, F, F - 1, u3 / R0

    def pressure(beta, G0, K0, c):
        u3, F, e1, e2 = kin(beta)
        g1, g2 = G0 * e1 + c[0], G0 * e2 + c[1]
        lam = K0 * e1 + c[2] + K0 * e2 + c[3] - 2 / 3 * (g1 + g2)
        s1, s2 = 2 * g1 + lam, 2 * g2 + lam
        gb = l0 * math.cos(a0) * (1 + u3 / R0)
        return th / (R0 + 0.5 * u3) * (s2 + (s2 * gb + s1 * e1) / (1 - 2 * gb * F))

    out = np.zeros(len(t))
    h = [0.0, 0.0, 0.0, 0.0]
    e_prev = (0.0, 0.0)
    b = 0.0
    for k in range(len(t)):
        if k == 0:
            G0, K0, c = Gi, Ki, (0.0, 0.0, 0.0, 0.0)
        else:
            a = math.exp(-(t[k] - t[k - 1]) / tau)
            G0, K0 = Gi + G1, Ki + K1
            c = (G1 * (a * h[0] - e_prev[0]), G1 * (a * h[1] - e_prev[1]),
                 K1 * (a * h[2] - e_prev[0]), K1 * (a * h[3] - e_prev[1]))
        lo, hi = 0.0, 4 * math.pi
        x = max(b, 1e-9)
        if pressure(0.0, G0, K0, c) < p[k]:
            for _ in range(100):
                fx = pressure(x, G0, K0, c) - p[k]
                if fx > 0:
                    hi = x
                else:
                    lo = x
                hs = 1e-7 * max(x, 1e-3)
                d = (pressure(x + hs, G0, K0, c) - p[k] - fx) / hs
                xn = x - fx / d if d > 0 else 0.5 * (lo + hi)
                if not lo < xn < hi:
                    xn = 0.5 * (lo + hi)
                if abs(xn - x) < 1e-13:
                    x = xn
                    break
                x = xn
            b = x
        else:
            b = 0.0
        _u3, _F, e1, e2 = kin(b)
        if k > 0:
            a = math.exp(-(t[k] - t[k - 1]) / tau)
            h = [a * h[0] + e1 - e_prev[0], a * h[1] + e2 - e_prev[1], a * h[2] + e1 - e_prev[0], a * h[3] + e2 - e_prev[1]]
        e_prev = (e1, e2)
        out[k] = b
    return out


def best_of(fn, repeat=3):
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def bench_forward(quick: bool):
    t, p = experiment2_pressure(1800.0)
    m = VBMM(material=Material.paper_fit())
    m.forward(t[:5], p[:5])  # compile / load cache
    sec = best_of(lambda: m.forward(t, p), 5)
    us = sec / t.size * 1e6
    nb = 600 if quick else 3000
    beta_py = python_forward_recursive(t[:nb], p[:nb], Material.paper_fit())
    assert np.max(np.abs(beta_py - m.forward(t[:nb], p[:nb]))) < 1e-9, "baseline disagrees with the kernel"
    sec_py = best_of(lambda: python_forward_recursive(t[:nb], p[:nb], Material.paper_fit()), 1 if quick else 2)
    us_py = sec_py / nb * 1e6
    print("\n1. forward model beta(P), recursive history, one branch (1800 s log, 18000 steps)")
    print(f"   {'implementation':<36}{'us/step':>10}{'ratio':>10}")
    print(f"   {'bpmid (numba kernel)':<36}{us:>10.3f}{1.0:>10.1f}")
    print(f"   {'pure Python baseline (same solve)':<36}{us_py:>10.3f}{us_py / us:>10.1f}")
    print(f"   target <= 2 us/step: {'met' if us <= 2.0 else 'NOT met'}; the paper's sliding window: about 4 us/step")
    return us


def bench_modes(quick: bool):
    lengths = [60, 120, 300, 600, 1200, 1800] if not quick else [60, 300, 600]
    print("\n2. cost per step (us) against log length, 10 Hz, paper's experiment 2 pressure (cf. Fig. 17(b))")
    print(f"   {'length (s)':>10}{'steps':>8}{'recursive':>12}{'window 20 s':>13}{'full':>12}{'full/rec':>10}")
    models = {h: VBMM(material=Material.paper_fit(), history=h, window_s=20.0) for h in ("recursive", "window", "full")}
    for mdl in models.values():
        mdl.forward(np.arange(5.0), np.full(5, 5e4))
    rows = []
    for L in lengths:
        t, p = experiment2_pressure(float(L))
        row = {}
        for h, mdl in models.items():
            row[h] = best_of(lambda: mdl.forward(t, p), 3 if h != "full" or L <= 600 else 1) / t.size * 1e6
        rows.append((L, row))
        print(f"   {L:>10}{t.size:>8}{row['recursive']:>12.3f}{row['window']:>13.3f}{row['full']:>12.2f}"
              f"{row['full'] / row['recursive']:>10.0f}")
    (L0, r0), (L1, r1) = rows[0], rows[-1]
    print(f"   growth {L0} s -> {L1} s: full x{r1['full'] / r0['full']:.1f} (log length x{L1 / L0:.0f}), "
          f"window x{r1['window'] / r0['window']:.2f}, recursive x{r1['recursive'] / r0['recursive']:.2f}")


def bench_fit(quick: bool):
    rng = np.random.default_rng(20240611)
    true = VBMM(material=Material.paper_fit())
    logs = []
    t = np.round(np.arange(0.0, 60.0, 0.1), 10)
    p = (triangle_pressure(t, 1.2, 1.6, 0.2) - ATM_BAR) * 1e5
    logs.append(from_arrays("fitting", t, p, true.forward_deg(t, p) + rng.normal(0, 0.5, t.size)))
    for i in range(5):
        t, p = experiment2_pressure(30.0)
        logs.append(from_arrays(f"va_{i + 1}", t, p, true.forward_deg(t, p) + rng.normal(0, 0.5, t.size)))
    fit_motion(logs[:1])  # warm-up (compiled kernels loaded)
    t0 = time.perf_counter()
    res = fit_motion(logs)
    sec = time.perf_counter() - t0
    v = res.fit.params.values()
    print("\n3. fit motion on a paper-sized data set (fitting set 60 s + five 30 s logs, "
          f"{sum(lg.n for lg in logs)} samples), prior = paper VBMM-mat")
    print(f"   wall time {sec:.2f} s (target <= 10 s: {'met' if sec <= 10 else 'NOT met'}), "
          f"{res.fit.nfev} evaluations in the last round, RMSE {res.metrics['rmse_deg']:.3f} deg (noise 0.5)")
    tm = Material.paper_fit()
    for name, truth in (("K_inf", tm.K_inf), ("K_1", tm.K[0]), ("tau_1", tm.tauG[0])):
        print(f"   {name:<6} fitted {v[name]:.5g}  true {truth:.5g}  error {100 * (v[name] / truth - 1):+.2f} %")
    print(f"   held at prior (not identifiable): {', '.join(sorted(res.fit.held)) or 'none'}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="shorter runs (smoke test)")
    args = ap.parse_args(argv)
    print(f"bpmid VBMM benchmarks (python {sys.version.split()[0]}, {os.cpu_count()} CPUs visible, "
          f"NUMBA_NUM_THREADS={os.environ.get('NUMBA_NUM_THREADS', 'default')}; kernels are single-threaded)")
    bench_forward(args.quick)
    bench_modes(args.quick)
    bench_fit(args.quick)


if __name__ == "__main__":
    main()
