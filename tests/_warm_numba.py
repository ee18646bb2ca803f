"""Fill numba's on-disk cache with the kernels most tests use, once, in a process of its own (started by
``conftest.pytest_configure`` on the xdist controller while the two workers start and collect). Without it both
workers compile the same kernels at the same time when their first tests need them, each for itself; with it, a
worker that starts a test after a kernel was cached reads it. It decides nothing: a kernel not cached yet is
compiled by the worker as before."""
from __future__ import annotations


def warm() -> None:
    import numpy as np

    from bpmid.discover.rivals import RIVALS
    from bpmid.effects import CATALOGUE, get_effect
    from bpmid.effects.base import AugmentedVBMM
    from bpmid.models.vbmm import VBMM, Material

    t = np.arange(0.0, 20.0, 0.1)
    p = 1e5 * (0.2 + 0.4 * np.abs(np.sin(t / 3.0)))
    base = VBMM(material=Material.paper_fit())
    try:       # first: the closed loop's kernels (13 s to compile), which the study fixtures of both workers reach
               # in their control stage some 10-15 s in (compiled later here, they were compiled there too)
        from bpmid.control import ControlConfig, build_plant, builtin_reference, run_control

        cfg = ControlConfig()
        ref = builtin_reference("steps")
        short = type(ref)(ref.name, ref.time_s[:30], ref.angle_deg[:30])
        run_control(base, build_plant(base, cfg=cfg), [short], cfg, measure_cost=False)
    except Exception:
        pass
    for closure in ("paper", "consistent"):
        for history in ("recursive", "window", "full"):
            VBMM(material=Material.paper_fit(), closure=closure, history=history).forward_deg(t, p)
    effects = [get_effect(e) for e in CATALOGUE] + [R() for R in RIVALS]
    for e in effects:
        try:   # each kernel on its own: one that fails here is compiled by the worker that needs it, as before
            AugmentedVBMM(base, (e,), e.default_params()).simulate_deg(t, p)
        except Exception:
            pass
    try:       # the relaxation fit's hereditary kernels
        import glob
        import os

        import bpmid

        root = os.path.join(os.path.dirname(__file__), "..", "datasets", "relaxation")
        bpmid.fit_relaxation(sorted(glob.glob(os.path.join(root, "relax_*_[23]0pct.csv"))))
    except Exception:
        pass


if __name__ == "__main__":
    warm()
