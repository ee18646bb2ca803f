"""Feedforward cost per control step against the 100 ms period, and RMSE per controller and reference.

Run: python benchmarks/bench_control.py   (paper gains P = 0.04 bar/deg, I = 0.01 bar/(deg s); controller's
model = the paper's VBMM-fit constants; plant 5 % stiffer with 10 % faster relaxation, 0.1 deg sensor noise)
"""
from __future__ import annotations

import time

import numpy as np

from bpmid import control_kernels as CK
from bpmid.control import (ControlConfig, build_plant, feedforward_cost, load_references, pack_model, run_control,
                           scaled_plant_model)
from bpmid.models.vbmm import VBMM, Material


def main():
    model = VBMM(Material.paper_fit())
    cost = feedforward_cost(model)
    print("feedforward cost per control step (best of 3)")
    print(f"  incremental inverse VBMM kernel : {cost['incremental_kernel_us_per_step']:8.3f} us/step "
          f"({cost['share_of_period_pct']:.5f} % of the 100 ms period; ratio period/cost "
          f"{1e5 / cost['incremental_kernel_us_per_step']:.0f})")
    print(f"  vectorised VBMM.inverse          : {cost['vectorised_inverse_us_per_sample']:8.3f} us/sample")
    t = np.arange(20_000) * 0.1
    beta = np.radians(45 + 20 * np.sin(2 * np.pi * 0.083 * t))
    args = pack_model(model)
    # one step called from Python (a controller calling the kernel each period pays the call overhead)
    m, q = model.material.n_branches, model.material.n_branches
    st = [np.zeros(m), np.zeros(m), np.zeros(q), np.zeros(q), np.ones(m), np.ones(q), np.zeros(4)]
    CK.inverse_step(0, 0.0, beta[0], *args, *st)
    t0 = time.perf_counter()
    for k in range(1, 20_000):
        CK.inverse_step(k, 0.1, beta[k], *args, *st)
    print(f"  one inverse_step call from Python: {1e6 * (time.perf_counter() - t0) / 20_000:8.3f} us/step")

    cfg = ControlConfig()
    plant = build_plant(scaled_plant_model(model, 1.05, 0.9), [], cfg)
    refs = load_references("all", cfg.rate_hz)
    res = run_control(model, plant, refs, cfg, measure_cost=False)
    print("\nclosed loop, RMSE (deg) per controller and reference; reduction vs pi (%); loop cost per step (us)")
    print(res.table[["controller", "reference", "rmse_deg", "max_abs_err_deg", "reduction_pct", "ringing_s",
                     "ringing_swing_deg", "status", "us_per_step"]].to_string(index=False,
                                                                            float_format=lambda v: f"{v:.3f}"))
    for w in res.warnings:
        print("warning:", w)
    # how much of each pooled RMSE is ringing: the error's 5 Hz part (the Nyquist frequency of the 10 Hz loop, where
    # this loop rings) is e minus its [1/4, 1/2, 1/4] smoothing (which passes nothing at 5 Hz and keeps what is slow),
    # taken as 0 where the smoothing spans a jump of the reference (more than 2 deg in a sample: the shipped references
    # move at most about 1 deg a sample otherwise), which it would count as 5 Hz alike for every controller
    # (the two parts are not orthogonal where a step's answer is sharp: the rest can come out above the RMSE)
    print("\npooled over the references: RMSE, its 5 Hz part and the rest (RMS, deg); reduction vs pi of the rest (%)")
    parts = {}
    for r in res.runs:
        e = r.reference_deg - r.true_angle_deg
        fast = np.zeros_like(e)
        fast[1:-1] = e[1:-1] - (0.25 * e[:-2] + 0.5 * e[1:-1] + 0.25 * e[2:])
        jump = np.abs(np.diff(r.reference_deg)) > 2.0
        fast[1:-1][jump[:-1] | jump[1:]] = 0.0
        parts.setdefault(r.controller, []).append((e, fast))
    rms = lambda x: float(np.sqrt(np.mean(np.concatenate(x) ** 2)))  # noqa: E731
    rest_pi = rms([e - f for e, f in parts["pi"]])
    for c, ps in parts.items():
        rest = rms([e - f for e, f in ps])
        print(f"  {c:8s} RMSE {rms([e for e, _f in ps]):.3f}  5 Hz part {rms([f for _e, f in ps]):.3f}  rest {rest:.3f}"
              + ("" if c == "pi" else f"  rest {100 * (1 - rest / rest_pi):.1f} % below pi's"))
    # the other way: leave out, for every controller alike, the samples at which any controller rings on that
    # reference (after each episode's first sample, the reference's own jump); they hold PI's slow lag after a step too
    keep = {}
    for name in dict.fromkeys(r.reference for r in res.runs):
        mine = [r for r in res.runs if r.reference == name]
        t = mine[0].time_s
        ok = np.ones(t.size, bool)
        for r in mine:
            for ep in r.ringing:
                ok &= ~((t > ep.start_s + 1e-9) & (t <= ep.end_s + 1e-9))
        for r in mine:
            keep.setdefault(r.controller, []).append((r.reference_deg - r.true_angle_deg)[ok])
    left = sum(v.size for v in keep["pi"])
    total = sum(r.time_s.size for r in res.runs if r.controller == "pi")
    print(f"without the samples at which any controller rings ({total - left} of {total}):")
    for c, v in keep.items():
        below = "" if c == "pi" else f"  {100 * (1 - rms(v) / rms(keep['pi'])):.1f} % below pi's"
        print(f"  {c:8s} RMSE {rms(v):.3f}{below}")


if __name__ == "__main__":
    main()
