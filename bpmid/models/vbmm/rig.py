"""The rig a fitted VBMM's constants belong to, as its fit file records it: the sampling step of the logs it was
fitted on and the ambient their absolute pressures were turned to gauge with.

The model's hereditary sum (VBMM.md eq. 5) takes each pressure step as a jump at its sample, so the constants hold
for the step they were fitted at (:func:`bpmid.models.vbmm.model.sampling_note`). Whatever runs a fit file (``bpmid
predict``, the C export) reads the rig from here; :func:`step_warnings` says when a log is run at another step.

Units: s, Pa.
"""
from __future__ import annotations

import math
from typing import Iterable, Mapping

import numpy as np


def _finite(x) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def fit_rig(data: dict) -> tuple[list[float], list[float], bool]:
    """What a fit file records of the rig its constants belong to: the sampling step of each fitting log (s: its
    median step ``fit.logs[*].step_s``; in files written before it was recorded, duration / (samples - 1)), the
    ambient pressures (Pa) its logs' absolute pressures were turned to gauge with, and whether any log was read as
    gauge already. Values that are not numbers (a hand-edited file) are left out."""
    fit = data.get("fit") if isinstance(data.get("fit"), dict) else {}
    steps = []
    for lg in fit.get("logs") or ():
        if not isinstance(lg, dict):
            continue
        step = _finite(lg.get("step_s"))
        if step is None:
            n, dur = _finite(lg.get("samples")), _finite(lg.get("duration_s"))
            step = dur / (n - 1) if n is not None and dur is not None and n > 1 else None
        if step is not None and step > 0:
            steps.append(step)
    prov = data.get("provenance") if isinstance(data.get("provenance"), dict) else {}
    atm, gauge = set(), False
    for rd in (prov.get("reading") or {}).values():
        ref = rd.get("pressure_reference") if isinstance(rd, dict) else None
        if not isinstance(ref, dict):
            continue
        a = _finite(ref.get("atmosphere_pa"))
        if ref.get("reference") == "absolute" and a is not None and a > 0:
            atm.add(a)
        elif ref.get("reference") == "gauge":
            gauge = True
    return steps, sorted(atm), gauge


def fitted_pressure_span(data: Mapping | None) -> tuple[float, float] | None:
    """The gauge pressures (Pa) a fit file's constants were fitted on, lowest to highest over its fitting logs
    (``fit.logs[*].pressure_gauge_pa``), or None when it records none (written before it did, or not a motion fit).
    Entries that are not two numbers (a hand-edited file) are left out."""
    fit = (data or {}).get("fit")
    spans = []
    for lg in (fit.get("logs") or ()) if isinstance(fit, Mapping) else ():
        pair = lg.get("pressure_gauge_pa") if isinstance(lg, Mapping) else None
        if isinstance(pair, (list, tuple)) and len(pair) == 2:
            lo, hi = _finite(pair[0]), _finite(pair[1])
            if lo is not None and hi is not None:
                spans.append((lo, hi))
    if not spans:
        return None
    return min(lo for lo, _ in spans), max(hi for _, hi in spans)


#: logs whose steps differ by less than this share have one step (rounding of the logged times)
STEP_SPREAD = 0.01


def step_off(dt: float, fit_body: Mapping | None, material) -> tuple[float, str, float] | None:
    """How far a model of ``material`` run at step ``dt`` (s) acts from the fit's: (the share of the shortest branch's
    moduli it is off, the fit's step in words, that branch's time constant), or None when the fit file records no
    step (written before it did) or the model has no time constant. The hereditary sum's error against the smooth
    history grows as about step / (2 tau) of the shortest branch's moduli, so the share is the step's difference
    from the nearest fitting log's over 2 tau (:data:`~bpmid.models.vbmm.model.SAMPLING_NOTE_SHARE` is where it is
    said)."""
    steps, _atm, _gauge = fit_rig(dict(fit_body or {}))
    if not steps or not material.time_constants:
        return None
    tau = min(material.time_constants)
    lo, hi = min(steps), max(steps)
    fitted = f"{lo:.4g} s" if hi <= lo * (1.0 + STEP_SPREAD) else f"{lo:.4g}-{hi:.4g} s"
    return min(abs(dt - s) for s in steps) / (2.0 * tau), fitted, tau


def step_warnings(logs: Iterable, fit_body: Mapping | None, material) -> list[str]:
    """A warning for each log sampled at a step other than the fit's, by enough to move the prediction
    (:func:`step_off` over :data:`~bpmid.models.vbmm.model.SAMPLING_NOTE_SHARE`, the share at which a fit notes its
    step). A rate slip, such as milliseconds read as seconds, gets the log's own check instead
    (:data:`~bpmid.io.plausibility.MAX_MOTION_STEP_S`)."""
    from bpmid.io.plausibility import MAX_MOTION_STEP_S
    from bpmid.models.vbmm.model import SAMPLING_NOTE_SHARE

    out = []
    for lg in logs:
        t = np.asarray(lg.time_s, float)
        if t.size < 2:
            continue
        dt = float(np.median(np.diff(t)))
        if dt >= MAX_MOTION_STEP_S:   # a rate no rig logs at: the log's own check says it, with the unit fix
            continue
        off = step_off(dt, fit_body, material)
        if off is not None and off[0] > SAMPLING_NOTE_SHARE:
            share, fitted, tau = off
            name = str(lg.path) if getattr(lg, "path", None) is not None else str(lg.name)
            out.append(f"{name}: samples are {dt:.4g} s apart ({1.0 / dt:.3g} Hz), the constants were fitted on logs "
                       f"sampled every {fitted}; the model's hereditary sum takes each pressure step as a jump at its "
                       f"sample, so at this step the moduli of its shortest branch ({tau:.3g} s) act some "
                       f"{100.0 * share:.0f} % off the fitted ones and the prediction is not the fitted model's (check "
                       f"the time unit; resample the log to the fit's step, or fit on logs taken at this rate)")
    return out


def loop_step_warning(rate_hz: float, fit, model, *, what: str) -> list[str]:
    """A warning when a loop runs ``model`` (a VBMM; ``what``: the controller's model, the plant's), fitted as the
    ``bpmid.vbmm/1`` file or result ``fit`` records, at a rate whose step differs from the fit's by enough to move
    it (:func:`step_off`)."""
    from bpmid.effects.fitfile import fit_body
    from bpmid.models.vbmm.model import SAMPLING_NOTE_SHARE

    dt = 1.0 / float(rate_hz)
    off = step_off(dt, fit_body(fit)[0], model.material)
    if off is None or off[0] <= SAMPLING_NOTE_SHARE:
        return []
    share, fitted, tau = off
    return [f"the loop runs {what} every {dt:.4g} s ({rate_hz:g} Hz), its constants were fitted on logs sampled every "
            f"{fitted}: the model's hereditary sum takes each pressure step as a jump at its sample, so at this step "
            f"the moduli of its shortest branch ({tau:.3g} s) act some {100.0 * share:.0f} % off the fitted ones; run "
            f"the loop at the fit's rate (config control.rate_hz) or fit on logs taken at the loop's rate"]

