"""What a careful user should know before trusting a verdict, said beside it: a log that sits off the others by a
constant (a sensor mounted or zeroed differently), a base model that explains little of the fitting logs, a few
samples that carry a log's error (a sensor glitch), an angle offset named on absolute pressures read against an
ambient pressure nothing states, and a pressure lag named on unevenly sampled logs.

These never change what discovery names; they are lines of the verdict (``caution: ...``) and ``cautions`` in
``discovery.yaml``. A helper's trial found each giving a confident wrong reading without a word: a +90 deg log blamed
on log-to-log variation, five +40 deg samples in a held-out log turning a clear 2 deg offset into "unexplained" with
the advice to fit on other logs, and a lab at 950 hPa read as a 5 deg angle offset.
"""
from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from bpmid.discover.diagnose import uneven_steps
from bpmid.discover.model import ModelState, residuals
from bpmid.io.motion_logs import MotionLog
from bpmid.io.plausibility import R2_MIN

#: a sample this many robust noise widths from its neighbours' mean residual is a glitch, not the model's miss
GLITCH_Z = 8.0
#: glitches are a few samples: at most this share of a log (or this many, in a short log)
GLITCH_MAX_SHARE = 0.01
GLITCH_MAX_COUNT = 5
#: ... and said when they carry at least this share of the log's squared error
GLITCH_ERROR_SHARE = 0.2
#: a log whose mean angle against the model sits this many noise floors (and degrees) off the other logs', and
#: fits to within this many noise floors once shifted, reads as a sensor mounted or zeroed differently
ODD_SHIFT_FLOORS = 10.0
ODD_SHIFT_MIN_DEG = 5.0
ODD_REST_FLOORS = 3.0
#: a log whose angle is this share larger or smaller than the model predicts, against the other logs (the least-
#: squares scale of the prediction onto the log, over the others' median), is said: runs of one muscle differ by a
#: few per cent (the issue's log-to-log variation: up to 5 %; a fifth is four times that), so this is another muscle
#: or geometry, a changed setup or a unit slip, which the per-log factors would otherwise take up as variation
LOG_SCALE_APART = 0.2
#: the base model's poor fit is said only when its RMSE is this many noise floors (a small signal in honest noise
#: gives a low R^2 too)
POOR_FIT_FLOORS = 2.0
#: a pressure change this many times the log's median change (and this share of its range) is a step, near which a
#: sample may honestly stand out
STEP_OVER_TYPICAL = 5.0
STEP_MIN_SHARE = 0.01
#: the ambient pressure io.atmosphere_pa takes when nothing states the lab's (the reader's words start so)
_ASSUMED = "io.atmosphere_pa (the standard atmosphere"


def _name(lg: MotionLog) -> str:
    return lg.path.name if lg.path is not None else lg.name


def _names(logs: Sequence[MotionLog]) -> str:
    return ", ".join(_name(lg) for lg in logs[:4]) + (", ..." if len(logs) > 4 else "")


def _glitches(lg: MotionLog, r: np.ndarray) -> np.ndarray:
    """Indices of isolated samples far from their neighbours' residual, away from the log's pressure steps (where a
    model that lags or leads misses a sample or two honestly)."""
    if r.size < 5:
        return np.zeros(0, int)
    local = r[1:-1] - 0.5 * (r[:-2] + r[2:])   # a sample against its neighbours: a spike stands out whole
    width = 1.4826 * float(np.median(np.abs(local - np.median(local))))   # robust sd of that
    if not width > 0:
        return np.zeros(0, int)
    z = np.abs(local)
    # a spike also lifts its two neighbours' reading by half: keep the peak of each
    peak = np.r_[True, z[1:] >= z[:-1]] & np.r_[z[:-1] >= z[1:], True]
    k = np.flatnonzero((z > GLITCH_Z * width) & peak) + 1
    dp = np.abs(np.diff(np.asarray(lg.pressure_pa, float)))
    if dp.size and k.size:   # a step: a pressure change far above the log's typical one (a ramp's is typical)
        steep = (dp > STEP_OVER_TYPICAL * float(np.median(dp))) & (dp > STEP_MIN_SHARE * float(np.ptp(lg.pressure_pa)))
        near = np.zeros(r.size, bool)
        for off in (-1, 0, 1, 2):
            idx = np.flatnonzero(steep) + off
            near[idx[(idx >= 0) & (idx < r.size)]] = True
        k = k[~near[k]]
    return k


def data_cautions(base: ModelState, final: ModelState, fit_logs: Sequence[MotionLog],
                  ho_logs: Sequence[MotionLog], floor: float) -> tuple[list[str], bool]:
    """Sentences about the logs, and whether a held-out log's error rests on a few samples or on the log sitting
    off the others (the verdict then does not blame the fitting logs' coverage). A log is judged against the final
    model (the base model with every effect named), so that an effect a log exercises more than the others is not
    taken for a fault of the log; the fit's quality is the base model's, against the noise."""
    out: list[str] = []
    held_out_odd = False
    fit_res = residuals(final, fit_logs)
    ho_res = residuals(final, ho_logs)
    base_res = np.concatenate(residuals(base, fit_logs)) if fit_logs else np.zeros(0)
    a = np.concatenate([lg.angle_deg for lg in fit_logs]) if fit_logs else np.zeros(0)
    ss = float(np.sum((a - np.mean(a)) ** 2)) if a.size else 0.0
    r2 = 1.0 - float(np.sum(base_res ** 2)) / ss if ss > 0 else float("nan")
    base_rmse = float(np.sqrt(np.mean(base_res ** 2))) if base_res.size else 0.0
    every = [(lg, p, "fitting") for lg, p in zip(fit_logs, fit_res)] + [(lg, p, "held-out")
                                                                        for lg, p in zip(ho_logs, ho_res)]
    level = np.array([-float(np.mean(p)) for _, p, _ in every])   # measurement minus model, on average
    shifts = [level[i] - float(np.median(np.delete(level, i))) if level.size > 1 else 0.0 for i in range(level.size)]
    if np.isfinite(r2) and r2 < R2_MIN and base_rmse > POOR_FIT_FLOORS * floor:
        far = int(np.argmax(np.abs(shifts))) if shifts else None
        which = (f"; the log furthest off the others is {_name(every[far][0])} ({shifts[far]:+.3g} deg on average)"
                 if far is not None and abs(shifts[far]) > ODD_SHIFT_MIN_DEG else "")
        out.append(f"the base model explains little of the fitting logs' angle (R^2 {r2:.2f} < {R2_MIN:g}, RMSE "
                   f"{base_rmse:.3g} deg against a noise floor of {floor:.3g}): its constants, and any verdict resting "
                   f"on them, are not to be trusted; look for a log that is off, or a unit or reference slip{which}")
    for i, (lg, p, role) in enumerate(every):
        k = _glitches(lg, p)
        share = float(np.sum(p[k] ** 2) / max(float(np.sum(p ** 2)), 1e-300)) if k.size else 0.0
        rest = float(np.std(p))   # what is left once the log's own mean is taken out
        if 0 < k.size <= max(GLITCH_MAX_SHARE * p.size, GLITCH_MAX_COUNT) and share >= GLITCH_ERROR_SHARE:
            out.append(f"{role} log {_name(lg)}: {k.size} isolated sample(s) (the first at t = "
                       f"{float(lg.time_s[k[0]]):.4g} s) sit far from their neighbours and carry {share:.0%} of "
                       f"its squared error: a sensor glitch or a knock? Leave them out and run again"
                       + (": the held-out score rests on them" if role == "held-out" else ""))
        elif abs(shifts[i]) > max(ODD_SHIFT_FLOORS * floor, ODD_SHIFT_MIN_DEG) and rest < ODD_REST_FLOORS * floor:
            out.append(f"{role} log {_name(lg)} sits {shifts[i]:+.3g} deg off the other logs against the model, and "
                       f"fits to within {rest:.2g} deg once shifted (a sensor mounted or zeroed differently?): check "
                       "it before reading the verdict")
        else:
            continue
        held_out_odd |= role == "held-out"
    for role, lg, scale, others in _scales_apart(every):
        out.append(f"{role} log {_name(lg)} bends {abs(scale / others - 1.0):.0%} "
                   f"{'more' if scale > others else 'less'} than the model predicts at its pressures, against the "
                   f"other logs (the least-squares scale of the prediction onto it, about their means: {scale:.2f}; the others' median "
                   f"{others:.2f}): runs of one muscle differ by a few per cent, so this looks like another muscle "
                   f"or geometry, a changed setup or a unit slip, which discovery would read as log-to-log "
                   f"variation of the constants; check it before reading the verdict")
        held_out_odd |= role == "held-out"
    return out, held_out_odd


def _scales_apart(every) -> list[tuple[str, MotionLog, float, float]]:
    """(role, log, its scale, the others' median) for each log whose least-squares scale of the model's prediction
    onto its measured angle (both about their means) sits over :data:`LOG_SCALE_APART` from the other logs' median (``every``: (log,
    residual, role) with the residual model minus measurement, deg)."""
    scales = []
    for lg, p, _role in every:   # each about its own mean: a sensor zeroed differently is another caution's
        y = np.asarray(lg.angle_deg, float)
        sim = np.asarray(p, float) + y
        ok = np.isfinite(sim) & np.isfinite(y)
        s, m = sim[ok] - np.mean(sim[ok]), y[ok] - np.mean(y[ok])
        den = float(s @ s)
        scales.append(float(s @ m) / den if den > 0 else float("nan"))
    out = []
    for i, (lg, _p, role) in enumerate(every):
        rest = [x for j, x in enumerate(scales) if j != i and np.isfinite(x)]
        if not rest or not np.isfinite(scales[i]):
            continue
        others = float(np.median(rest))
        if others > 0 and abs(scales[i] / others - 1.0) > LOG_SCALE_APART:
            out.append((role, lg, scales[i], others))
    return out


def sampling_cautions(logs: Sequence[MotionLog], named: Sequence[str]) -> list[str]:
    """A sentence when a delay is named on logs whose time step changes within them: the model's hereditary sum takes
    each pressure change as a step at its sample, so where the step grows it lags the muscle, a delay the fit can
    take up as a pressure lag."""
    uneven = [lg for lg in logs if uneven_steps(lg.time_s)]
    if not uneven or "pressure_lag" not in named:
        return []
    return [f"{len(uneven)} of the {len(logs)} logs ({_names(uneven)}) are sampled unevenly (their time steps differ by more "
            "than 1 %): the model applies each pressure change at its sample, so where the step grows it trails the "
            "muscle by up to half a step, and the pressure_lag named here may be that, not the rig. Log at an even "
            "rate, or resample evenly, and run again"]


def ambient_cautions(logs: Sequence[MotionLog], named: Sequence[str]) -> list[str]:
    """A sentence when an angle offset is named on absolute pressures turned into gauge with the standard atmosphere,
    which nothing in the logs or the config states: a lab's ambient pressure 60 hPa lower reads every gauge pressure
    6 kPa high, which the fit takes up as an angle offset."""
    assumed = [lg for lg in logs if lg.pressure_reference == "absolute"
               and str(((lg.reading or {}).get("pressure_reference") or {}).get("atmosphere_from", "")).startswith(
                   _ASSUMED)]
    if not assumed or "angle_offset" not in named:
        return []
    return [f"{len(assumed)} of the {len(logs)} logs ({_names(assumed)}) hold absolute pressures turned into gauge with the "
            f"standard atmosphere, 101325 Pa, which nothing states: in a lab at 950 hPa every gauge pressure reads "
            f"6.3 kPa high, which bends the muscle further at every pressure, and the angle_offset named here may be "
            "that, not the sensor. State the lab's ambient pressure (io.atmosphere_pa in the config, a "
            "'# atmosphere_pa:' line or an ambient column) and run again"]


#: how far a log's conditions may sit outside those a gate was calibrated on before it is said: the noise floor by
#: this factor, the lag-1 correlation of the noise by this much, the sampling rate by this factor
GATE_NOISE_FACTOR = 1.25
GATE_RHO_MARGIN = 0.15
GATE_RATE_FACTOR = 1.2


def _span(v) -> tuple[float, float] | None:
    """(low, high) of a generator's range or list of choices (numbers: checked when the file was read), None when
    the calibration does not say."""
    if v is None:
        return None
    vals = [float(x) for x in (v if isinstance(v, list) else [v])]
    return min(vals), max(vals)


def _said(lo: float, hi: float, unit: str, digits: str = ".3g") -> str:
    a, b = f"{lo:{digits}}", f"{hi:{digits}}"
    return f"{a}{unit}" if a == b else f"{a}-{b}{unit}"


def gate_cautions(thresholds_file: str | None, cal: Mapping, logs: Sequence[MotionLog], noise: dict) -> list[str]:
    """Sentences when the gate comes from a thresholds file (``bpmid calibrate``'s) whose calibration warned (too few
    cases, paths closed), or which was calibrated on other conditions than these logs show: a noise floor, noise
    colour or sampling rate outside the sweep's. ``cal``: the file's checked ``calibration`` block
    (:func:`bpmid.discover.calibrate.thresholds_calibration`). A gate's false-positive rate is measured only on the
    conditions it was calibrated on; a helper's trial used thresholds made for 25 Hz AR(1) noise on 10 Hz white-noise
    logs without a word. The shipped gate is not judged here (its conditions are the README's)."""
    if not thresholds_file:
        return []
    name = str(thresholds_file)
    out = [f"the gate's calibration ({name}) warned: {w.removeprefix('warning: ')}" for w in cal.get("warnings") or []]
    gen = cal.get("generator") or {}
    off, was = [], []
    sig = float(noise.get("sigma_deg", float("nan")))
    span = _span(gen.get("noise_deg"))
    if span and np.isfinite(sig):
        was.append(f"angle noise {_said(*span, ' deg')}")
        if not span[0] / GATE_NOISE_FACTOR <= sig <= span[1] * GATE_NOISE_FACTOR:
            off.append(f"a noise floor of {sig:.3g} deg")
    rho = float(noise.get("rho", float("nan")))
    span = _span(gen.get("noise_rho"))
    if span and np.isfinite(rho):
        was.append(f"lag-1 correlation {_said(*span, '', '.2g')}")
        if not span[0] - GATE_RHO_MARGIN <= rho <= span[1] + GATE_RHO_MARGIN:
            off.append(f"a lag-1 correlation of the noise of {rho:.2g}")
    span = _span(gen.get("sampling_hz"))
    rates = [1.0 / lg.dt_s for lg in logs if lg.n > 1 and lg.dt_s > 0]   # each log's median step
    if span and rates:
        was.append(f"{_said(*span, ' Hz', '.4g')}")
        lo, hi = min(rates), max(rates)
        if lo < span[0] / GATE_RATE_FACTOR or hi > span[1] * GATE_RATE_FACTOR:
            off.append(f"sampling at {_said(lo, hi, ' Hz', '.4g')}")
    if off:
        out.append(f"the gate ({name}) was calibrated on {', '.join(was)}; these logs show {' and '.join(off)}: "
                   "outside what it was calibrated on, so how often it names a wrong effect here is not measured. "
                   "Calibrate on these conditions (bpmid calibrate, the sweep's rig: section) or use the shipped gate")
    return out
