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


if __name__ == "__main__":
    main()
