"""Fill numba's on-disk cache with the kernels most tests use, split in two halves that the two xdist workers
compile side by side at the start of the session (``conftest.pytest_sessionstart``), each then waiting for the
other: every test after that reads the kernels from the cache. Without it both workers compiled the same kernels
when their first tests needed them, each for itself (about 15 s of compiling each, on a fresh clone). It decides
nothing: a kernel not cached here is compiled by the worker that needs it, as before.

``loop``: the closed loop (7-9 s to compile) and the baselines' recursions; ``open``: the VBMM forward kernel in
every mode, the catalogue's effects and the rivals, the relaxation fit's hereditary kernels."""
from __future__ import annotations

PARTS = ("loop", "open")


def _loop() -> None:
    import numpy as np

    from bpmid import control_kernels as CK
    from bpmid.control import ControlConfig, build_plant, builtin_reference, pack_model, simulate_loop
    from bpmid.io.motion_logs import from_arrays
    from bpmid.models import model_class
    from bpmid.models.vbmm import VBMM, Material

    base = VBMM(material=Material.paper_fit())
    cfg = ControlConfig()
    ref = builtin_reference("steps")
    short = type(ref)(ref.name, ref.time_s[:30], ref.angle_deg[:30])
    # the loop itself, not run_control: its Maxwell-slip feedforward runs the open-loop forward kernel, which the
    # other half compiles (both compiled it at once before)
    simulate_loop("vbmm-pi", short, base, build_plant(base, cfg=cfg), cfg)
    from bpmid.control_ringing import turning_points

    turning_points(short.angle_deg, 1.0)   # the ringing check's dead-band walk, which every control run makes
    CK.inverse_incremental(short.time_s, np.radians(short.angle_deg), *pack_model(base))
    t = np.arange(0.0, 20.0, 0.1)
    log = from_arrays("warm", t, 1e5 * (0.2 + 0.4 * np.abs(np.sin(t / 3.0))))
    for name in ("gpi", "maxwell-slip", "three-element", "two-branch"):
        try:
            fam = model_class(name)()
            fam.simulate(fam.default_params(), log)
        except Exception:
            pass


def _open() -> None:
    import glob
    import os

    import numpy as np

    import bpmid
    from bpmid.discover.rivals import RIVALS
    from bpmid.effects import CATALOGUE, get_effect
    from bpmid.effects.base import AugmentedVBMM
    from bpmid.models.vbmm import VBMM, Material

    t = np.arange(0.0, 20.0, 0.1)
    p = 1e5 * (0.2 + 0.4 * np.abs(np.sin(t / 3.0)))
    base = VBMM(material=Material.paper_fit())
    for closure in ("paper", "consistent"):
        for history in ("recursive", "window", "full"):
            VBMM(material=Material.paper_fit(), closure=closure, history=history).forward_deg(t, p)
    for e in [get_effect(e) for e in CATALOGUE] + [R() for R in RIVALS]:
        try:   # each kernel on its own: one that fails here is compiled by the worker that needs it, as before
            AugmentedVBMM(base, (e,), e.default_params()).simulate_deg(t, p)
        except Exception:
            pass
    try:       # the relaxation fit's hereditary kernels
        root = os.path.join(os.path.dirname(__file__), "..", "datasets", "relaxation")
        bpmid.fit_relaxation(sorted(glob.glob(os.path.join(root, "relax_*_[23]0pct.csv"))))
    except Exception:
        pass


def warm(part: str | None = None) -> None:
    """Compile (or read from the cache) one half of the kernels, or both (``part`` None)."""
    for name, fn in (("loop", _loop), ("open", _open)):
        if part in (None, name):
            try:
                fn()
            except Exception:
                pass


if __name__ == "__main__":
    warm()
