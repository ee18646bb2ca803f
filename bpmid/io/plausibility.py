"""Plausibility checks after reading, fitting and predicting: catch what a unit or reference slip looks like.

A reader that never guesses a unit still cannot tell a correct statement from a wrong one (``--pressure-unit
kPa`` on a column in bar, ``angle_deg`` holding radians, absolute pressures under ``# pressure_reference:
gauge``). These checks look at the numbers and the fit, and return warnings that name the likely cause and the
fix; every command that fits or predicts prints them on stderr (``warning: ...``), writes them into its output
file (``provenance.warnings``, and ``warnings`` where the file has such a list) and, with ``--strict``
(``io.strict``), ends with exit 2 instead.

The thresholds are stated here, once:

- :data:`R2_MIN`: a fit or prediction explaining less than half of the angle's variance
- :data:`PRESSURE_RANGE_PA`: peak gauge pressures a pneumatic muscle is driven with
- :data:`RADIAN_MAX`: a degree column whose largest angle stays below 2 pi while the pressure moves
- :data:`ATMOSPHERE_BAND_PA`: a gauge log that never drops below about one atmosphere (a rest pressure in the band)
- :data:`MIN_DURATION_S`: a motion log or relaxation test shorter than a second (seconds stated as milliseconds)
- :data:`MAX_MOTION_STEP_S`: a motion log sampled a second or more apart in a seconds column (milliseconds under a
  seconds unit, whatever their digits)
- :data:`RELAX_RAMP_MAX_S`: a relaxation test whose loading ramp lasts over ten minutes in a seconds column
- whole-number times at least half a second apart in a seconds column, motion and relaxation test logs alike
  (:func:`milliseconds_warnings`: milliseconds under a seconds unit)

A hint names the form that works: a unit flag is refused when the header already states the unit, so then the
hint is the column map that overrides it (:func:`unit_fix`, :func:`reference_fix`).
"""
from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Iterable, Mapping, Sequence

import numpy as np

from bpmid.errors import InputError

#: a fit or prediction with R^2 below this is flagged
R2_MIN = 0.5
#: an instantaneous modulus (MPa) below this is softer than the elastomers a muscle is made of (the softest
#: silicones, Ecoflex 00-10 class, are some 0.05 MPa): a unit slip, e.g. a strain in percent read as a fraction
E0_SOFTEST_MPA = 1e-2
#: an instantaneous modulus (MPa) above this is a glassy polymer's, not a rubber's (Poisson's ratio near 0.35)
GLASSY_MPA = 1e3
#: peak gauge pressure (Pa) of a pneumatic muscle run: below or above is flagged as a likely unit slip
PRESSURE_RANGE_PA = (2e3, 2e6)
#: a degree column whose largest |angle| stays at or below this while the pressure moves looks like radians
RADIAN_MAX = 2 * math.pi
#: a gauge log whose lowest pressure lies in this band (Pa) looks like absolute pressure (a muscle at rest is
#: vented to atmosphere or held at a small preload; absolute logs never drop below about one atmosphere)
ATMOSPHERE_BAND_PA = (0.88e5, 3.0e5)
#: a motion log shorter than this (s) is flagged: a muscle run lasts seconds to minutes (times in ms read as s?)
MIN_DURATION_S = 1.0
#: a motion log whose samples are this far apart (s) or more, in a column read as seconds, is flagged: a rig logs a
#: muscle at 10-1000 Hz, and a step of seconds cannot show its lag, creep or hysteresis (the VBMM's shortest time
#: constant is a fraction of a second): milliseconds under a seconds unit, fractions and all (0.1 s read as 100 s)
MAX_MOTION_STEP_S = 1.0
#: a relaxation test whose loading ramp (to the held strain) lasts longer than this (s) is flagged: a relaxation
#: test approximates a step, ramping in seconds (the shipped tests: 1.1-4 s), so a ramp of many minutes is
#: milliseconds read as seconds (a 2 s ramp read as 2000 s)
RELAX_RAMP_MAX_S = 600.0
#: a parameter within this share of its bound (for a zero bound: within 1e-6 of the other bound's size) is
#: "at the bound"
BOUND_SHARE = 1e-3

_P_UNITS = {"pa": 1.0, "kpa": 1e3, "bar": 1e5, "mbar": 1e2, "psi": 6894.757293168, "mpa": 1e6}


def _name(lg) -> str:
    return str(lg.path) if getattr(lg, "path", None) is not None else str(lg.name)


def _column(lg, q: str) -> dict:
    """What the reader recorded for the column of quantity ``q`` (column, unit, unit_from); {} if not read."""
    return dict(((getattr(lg, "reading", {}) or {}).get("columns", {}) or {}).get(q, {}) or {})


def _name_with_unit(q: str, unit: str) -> str:
    return f"{q}_{unit.lower()}"


def unit_fix(lg, q: str, unit: str) -> str:
    """How to state that the ``q`` column of ``lg`` is in ``unit``, in the form that works given where its current
    unit came from: a unit flag is refused as a conflict when the header (or units row) states the unit, so then
    the hint is the column map that overrides the name (``--columns time_ms=time_s``)."""
    from bpmid.io.tables import UNIT_FLAGS, _unit_part, columns_arg

    col = _column(lg, q)
    h, src = col.get("column"), col.get("unit_from")
    name = _name_with_unit(q, unit)
    flag = UNIT_FLAGS.get(q)
    if src == "from_arrays":   # a log made by bpmid.from_arrays: its arguments, not a file's
        arg = {"time": "time_unit", "angle": "angle_unit", "pressure": "pressure_unit"}.get(q, f"{q}_unit")
        return f"give from_arrays(..., {arg}={unit!r})"
    if h is None or src is None:
        return f"state {flag} {unit} (or name the column {name})" if flag else f"name the column {name}"
    mapped = f"{columns_arg(f'{name}={h}')} (config io.columns: {{'{h}': {name}}})"
    if src == "header" and _unit_part(str(h))[1] is not None:
        # a unit in brackets or after a slash ('Time (s)'): a flag or a column map that contradicts it is refused
        # (a unit stated twice must agree), so the file's header is what to correct
        raw = _unit_part(str(h))[0]
        return (f"the header {h!r} states {col.get('unit')}, and a flag or column map that says otherwise is refused "
                f"(a unit stated twice must agree): correct the header in the file to '{raw} ({unit})', or rename "
                f"the column {name}")
    if src == "header":
        refused = f", so {flag} {unit} would be refused as a conflict" if flag else ""
        return f"the header {h!r} states {col.get('unit')}{refused}: map the column with its unit, {mapped}, or " \
               f"rename the column {name}"
    if src == "units row":
        return (f"correct the units row under the header to {unit} (a flag or column map that contradicts it is "
                f"refused: a unit stated twice must agree)")
    if src.startswith("'#"):
        return f"correct the line '# {q}_unit:' to {unit}, or map the column with its unit: {mapped}"
    if src == "column map":
        return f"map the column with that unit instead: {mapped}"
    if src.startswith("--") or src.startswith("io.units"):
        return f"state {flag or src} {unit} (config io.units.{q})" if flag else f"state io.units.{q}: {unit}"
    return f"map the column with its unit: {mapped}"


def reference_fix(lg, reference: str) -> str:
    """How to state the pressure reference ``reference`` in the form that works given where the log's reference came
    from (a flag is refused when the file states the other reference)."""
    from bpmid.io.motion_logs import REFERENCE_KEYS
    from bpmid.io.tables import columns_arg

    if _column(lg, "pressure").get("unit_from") == "from_arrays":
        return f"give from_arrays(..., reference={reference!r})"
    meta = getattr(lg, "meta", {}) or {}
    fixes = [f"correct the line '# {k}: {meta[k]}' to {reference}" for k in REFERENCE_KEYS if k in meta]
    col = _column(lg, "pressure")
    if col.get("reference") is not None and col.get("reference") != reference:  # the unit carries it (psig)
        h, unit = col.get("column"), str(col.get("unit", "kpa"))
        name = f"pressure_{unit}_{'abs' if reference == 'absolute' else 'g'}"
        fixes.append(f"map the column with a unit that says {reference}: {columns_arg(f'{name}={h}')}")
    if fixes:
        return " and ".join(fixes)
    return f"state --pressure-reference {reference} (or the line '# pressure_reference: {reference}')"


def milliseconds_warnings(lg) -> list[str]:
    """The time check every log gets (motion and relaxation test logs alike): samples at least half a second apart,
    every time a whole number, in a column read as seconds: likely milliseconds under a seconds unit."""
    t = np.asarray(lg.time_s, float)
    if t.size > 2 and _column(lg, "time").get("unit") == "s":
        dt = float(np.median(np.diff(t)))
        # whole numbers up to rounding (times scaled in floating point: 0.1 * 1000 is 100.00000000000001)
        if dt >= 0.5 and np.all(np.abs(t - np.round(t)) <= 1e-9 * np.maximum(1.0, np.abs(t))):
            return [f"{_name(lg)}: samples are {dt:g} s apart and every time is a whole number: if the times are "
                    f"milliseconds, {unit_fix(lg, 'time', 'ms')}"]
    return []


def _units_that_fit(peak_given: float) -> list[str]:
    lo, hi = PRESSURE_RANGE_PA
    return [u for u, f in _P_UNITS.items() if lo <= peak_given * f <= hi * 0.5]


def pressure_slip(lg) -> str | None:
    """What a log's pressure peak says when it lies outside :data:`PRESSURE_RANGE_PA` (too little to drive a muscle,
    or more than one takes): a likely unit slip, the units it would make sense in and the form that states one
    (:func:`unit_fix`); None for a peak in the range. Said as a warning after reading and in predict's refusal of
    a pressure beyond the model's range."""
    p = np.asarray(lg.pressure_pa, float)
    if not p.size:
        return None
    peak = float(np.max(np.abs(p)))
    unit = str(getattr(lg, "pressure_unit", "pa"))
    given = np.asarray(lg.pressure_as_given if lg.pressure_as_given is not None else p, float)
    peak_given = float(np.max(np.abs(given))) if given.size else 0.0
    lo, hi = PRESSURE_RANGE_PA
    fits = [u for u in _units_that_fit(peak_given) if u != unit]
    hint = f"; in {' or '.join(fits)} it would make sense" if fits else ""
    if peak < lo and np.ptp(p) > 0:
        return (f"the pressure peaks at {peak:.4g} Pa ({peak_given:g} {unit}), too little to drive a pneumatic muscle: "
                f"likely a unit slip{hint}. {_pressure_fix(lg, fits)}")
    if peak > hi:
        return (f"the pressure peaks at {peak / 1e5:.4g} bar ({peak_given:g} {unit}), more than a pneumatic muscle "
                f"takes: likely a unit slip{hint}. {_pressure_fix(lg, fits)}")
    return None


def _pressure_fix(lg, fits: Sequence[str]) -> str:
    if fits:
        return f"If it is {fits[0]}, {unit_fix(lg, 'pressure', fits[0])}"
    return f"Check the column's unit; to state another, {unit_fix(lg, 'pressure', '<unit>')}"


#: an angle held at exactly its largest value on at least this share of a log's samples (and CLIP_RUN in a row)
CLIP_SHARE = 0.02
CLIP_RUN = 3


def clipped_top(a: np.ndarray, p: np.ndarray) -> tuple[float, int, int] | None:
    """(the value, the samples at it, the longest run) when a log's angle is clipped at its top: the largest value
    repeated exactly on at least :data:`CLIP_SHARE` of the samples (at least 5), :data:`CLIP_RUN` of them in a
    row, while the pressure ``p`` goes on rising, by at least a tenth of its range, past the pressure at which the
    angle reached it. A sensor that reads a moving muscle never holds its largest value while the pressure rises; a
    saturated range or a stop does (a hold at the top pressure, or the top of a loop read with coarse resolution
    while the pressure falls, repeats it without a rise). None otherwise."""
    ok = np.isfinite(a) & np.isfinite(p)
    a, p = a[ok], p[ok]
    if a.size < 20 or np.ptp(a) <= 0 or np.ptp(p) <= 0:
        return None
    top = float(np.max(a))
    at = a == top
    n_top = int(at.sum())
    if n_top < max(5, CLIP_SHARE * a.size):
        return None
    # runs of consecutive samples at the top; a clip holds the reading while the pressure still RISES past the
    # pressure at which the angle reached it (a coarse sensor at the top of a loop repeats its reading while the
    # pressure falls: the muscle lags, it is not clipped)
    edges = np.diff(np.concatenate([[0], at.astype(np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    run = int(np.max(ends - starts)) if starts.size else 0
    rise = max((float(np.max(p[a:b]) - p[a]) for a, b in zip(starts, ends)), default=0.0)
    if run < CLIP_RUN or rise < 0.1 * np.ptp(p):
        return None
    return top, n_top, run


def motion_data_warnings(logs: Iterable) -> list[str]:
    """Warnings about motion logs whose numbers a unit or reference slip explains (no fit needed)."""
    out: list[str] = []
    for lg in logs:
        where = _name(lg)
        p = np.asarray(lg.pressure_pa, float)
        peak = float(np.max(np.abs(p))) if p.size else 0.0
        unit = str(getattr(lg, "pressure_unit", "pa"))
        given = np.asarray(lg.pressure_as_given if lg.pressure_as_given is not None else p, float)
        peak_given = float(np.max(np.abs(given))) if given.size else 0.0
        lo, hi = PRESSURE_RANGE_PA
        if lg.pressure_reference == "gauge" and p.size and ATMOSPHERE_BAND_PA[0] <= float(np.min(p)) <= \
                ATMOSPHERE_BAND_PA[1]:
            out.append(f"{where}: the gauge pressure never drops below {np.min(p) / 1e5:.3g} bar, one atmosphere "
                       f"or more: these look like absolute pressures read as gauge. If so, "
                       f"{reference_fix(lg, 'absolute')}")
        else:
            slip = pressure_slip(lg)
            if slip is not None:
                out.append(f"{where}: {slip}")
        a = getattr(lg, "angle_deg", None)
        stated = (getattr(lg, "reading", {}) or {}).get("columns", {}).get("angle", {}).get("unit", "deg")
        if a is not None and np.size(a) and stated in ("deg", "degree", "degrees", "°"):
            amax = float(np.max(np.abs(a)))
            if 0.05 < amax <= RADIAN_MAX and np.ptp(p) > 0.2 * max(peak, 1.0):
                out.append(f"{where}: the bending angle never exceeds {amax:.3g} deg while the pressure moves: these "
                           f"look like radians in a degree column. If so, {unit_fix(lg, 'angle', 'rad')}")
            clip = clipped_top(np.asarray(a, float), p)
            if clip is not None:
                top, n_top, run = clip
                out.append(f"{where}: the bending angle sits at exactly {top:.6g} deg, its largest value, on {n_top} "
                           f"samples ({100.0 * n_top / np.size(a):.0f} %, up to {run} in a row): a sensor's range or a "
                           f"mechanical stop clips it, and the model, which bends freely, cannot follow; leave out "
                           f"the clipped stretches or log with the limit out of reach")
        t = np.asarray(lg.time_s, float)
        tcol = _column(lg, "time")
        ms = milliseconds_warnings(lg)
        out += ms
        if not ms and t.size > 2 and tcol.get("unit") == "s":
            dt = float(np.median(np.diff(t)))
            if dt >= MAX_MOTION_STEP_S:
                out.append(f"{where}: samples are {dt:.4g} s apart ({1.0 / dt:.3g} Hz), too slow to show a pneumatic "
                           f"muscle's lag, creep and hysteresis (a rig logs at 10-1000 Hz): if the times are "
                           f"milliseconds, {unit_fix(lg, 'time', 'ms')}")
        if t.size > 2 and float(t[-1] - t[0]) < MIN_DURATION_S:
            if tcol.get("unit") == "s":
                # the column already says seconds: no unit to suggest, only the warning that so short a log says
                # little about creep and hysteresis
                out.append(f"{where}: the log lasts only {float(t[-1] - t[0]):.3g} s ({t.size} samples): too short "
                           f"to show creep or hysteresis; check that the time column holds seconds")
            else:
                out.append(f"{where}: the log lasts only {float(t[-1] - t[0]):.3g} s ({t.size} samples): if the times "
                           f"are seconds, not {tcol.get('unit', 'the stated unit')}, {unit_fix(lg, 'time', 's')}")
    return out


def _at_bound(p) -> str | None:
    """'lower bound x' / 'upper bound x' when the value sits on a bound (relative closeness 1e-3, or exactly 0)."""
    lo, hi, v = float(p.lower), float(p.upper), float(p.value)
    for b, word in ((lo, "lower"), (hi, "upper")):
        if not math.isfinite(b):
            continue
        other = hi if word == "lower" else lo
        scale = abs(b) if b != 0 else 1e-6 * (abs(other) if math.isfinite(other) and other != 0 else 1.0)
        if abs(v - b) <= BOUND_SHARE * scale:
            return f"{word} bound {b:g}"
    return None


def motion_fit_warnings(result) -> list[str]:
    """Warnings after ``fit motion``: the data checks, a poor fit, constants stuck at a bound."""
    out = motion_data_warnings(result.logs)
    r2 = float(result.metrics.get("r2", float("nan")))
    if not r2 >= R2_MIN:
        out.append(f"the fit explains little of the angle (R^2 {r2:.3g} < {R2_MIN:g}): the constants are not to be "
                   f"trusted. Likely a unit or reference slip (check --pressure-unit, --pressure-reference, "
                   f"--angle-unit against the rig) or the wrong column (--columns)")
    rej = (getattr(result, "linear", None) or {}).get("holds_rejected")
    if rej:
        out.append(f"the motion logs reject the starting values (the relaxation fit's, or the paper's without one) "
                   f"for the constants they do not determine "
                   f"({', '.join(rej['held'])}): held there, the fit stayed at {rej['rmse_held_deg']:.3g} deg against "
                   f"{rej['rmse_free_deg']:.3g} deg with them free, so they are estimated and marked not identifiable; "
                   f"their values mean little on their own. The starting values and these logs disagree: another "
                   f"material, a unit slip, or a term the logs see otherwise (fewer terms, relax.terms, or "
                   f"motion.fixed, bring the fit back to constants the logs determine)")
    free = set(getattr(result.fit, "free_names", ()))
    for p in result.fit.params:
        if p.name not in free:
            continue
        b = _at_bound(p)
        if b is not None:
            out.append(f"{p.name} = {p.value:.6g} {p.unit} sits at its {b}: the data push it out of the range "
                       f"the model allows, which a unit or reference slip often does; check the units, or widen "
                       f"motion.bounds.{p.name} if the value is physical")
    return out


#: a long-term shear modulus below this (Pa) is far softer than any rubber tube (the paper's: 9 kPa)
MIN_PLAUSIBLE_G_PA = 100.0


def init_warnings(init, g_inf_pa: float | None = None) -> list[str]:
    """Warnings about where a motion fit started: the warnings its relaxation fit (a ``bpmid.relax/1`` path or
    mapping) came with, carried over rather than lost, and a start whose long-term shear modulus no rubber has."""
    out = []
    body, name = None, "the relaxation fit"
    if isinstance(init, (str, Path)):
        name = f"the relaxation fit {init}"
        from bpmid.config import read_yaml   # bpmid's one YAML reader

        try:
            body = read_yaml(Path(init))[0]
        except InputError:   # the fit itself read it: a file unreadable now says nothing more here
            body = None
    elif isinstance(init, Mapping):
        body = init
    said = [str(w) for w in (body or {}).get("warnings") or []] if isinstance(body, Mapping) else []
    if said:
        out.append(f"{name} this fit starts from came with {len(said)} warning(s) of its own, and the constants "
                   f"it starts from (and holds where the motion logs do not determine them) carry them: "
                   f"'{said[0]}'" + (f" (and {len(said) - 1} more)" if len(said) > 1 else ""))
    g = g_inf_pa
    if g is not None and 0 < float(g) < MIN_PLAUSIBLE_G_PA:
        out.append(f"{name} gives a long-term shear modulus of {float(g):.3g} Pa, far softer than any rubber (the "
                   f"paper's muscle: 9 kPa): check its specimen (gauge length and cross-section, relax.specimen) "
                   f"and units before trusting constants held at it")
    return out


def prediction_warnings(preds: Sequence) -> list[str]:
    """Warnings after ``predict``: the data checks, and a poor match where the log has angles."""
    out = motion_data_warnings([p.log for p in preds])
    for p in preds:
        if p.metrics is None:
            continue
        r2 = float(p.metrics.get("r2", float("nan")))
        if r2 != r2:
            out.append(f"{_name(p.log)}: the measured angle does not vary, so R^2 and the fit % are undefined (null in "
                       f"the output): check that angle_deg is the sensor's column")
        elif not r2 >= R2_MIN:
            out.append(f"{_name(p.log)}: the prediction explains little of the measured angle (R^2 {r2:.3g} < "
                       f"{R2_MIN:g}): check the log's units and pressure reference (--pressure-unit, "
                       f"--pressure-reference, --angle-unit) and that the parameters are for this muscle")
    return out


def relax_warnings(records: Sequence, fit) -> list[str]:
    """Warnings after ``fit relax``: times that look like milliseconds (the motion logs' check), strain that looks
    like percent, a modulus no elastomer has, a poor fit."""
    out: list[str] = []
    # each test log's loading ramp (s), as the fit read it (step and ramp mode alike: its hold curve)
    ramps = {str(lg.name): float(lg.hold.ramp_s) for lg in getattr(fit, "logs", None) or ()
             if getattr(lg, "hold", None) is not None}
    for r in records:
        where = _name(r)
        if not getattr(r, "is_modulus_curve", False):
            # the motion logs' check, shared; modulus curves are sampled evenly in log time (whole-number times
            # decades apart are common there), so it says nothing about them
            ms = milliseconds_warnings(r)
            out += ms + ([] if ms else _relax_time_warnings(r, ramps.get(str(r.name))))
        if r.strain is not None and r.strain.size and float(np.max(r.strain)) > 1.0:
            if getattr(r, "source", "") == "load-extension":   # strain = extension / gauge length: the length's
                out.append(f"{where}: the strain reaches {float(np.max(r.strain)):.4g} (over 100 %), the extension "
                           f"over the gauge length: check relax.specimen.gauge_length_mm (or the file's "
                           f"'# gauge_length_mm:' line) and that the extension is in mm")
            else:
                out.append(f"{where}: the strain reaches {float(np.max(r.strain)):.4g} (over 100 %): if the column is "
                           f"in percent, say so (strain_pct or 'Strain (%)')")
    r2 = float(getattr(fit, "r2", float("nan")))
    if not r2 >= R2_MIN:
        out.append(f"the relaxation fit explains little (R^2 {r2:.3g} < {R2_MIN:g}): check the stress and time units "
                   f"(--time-unit, io.units) and the columns used (--columns)")
    E0 = float(fit.E_inf + np.sum(fit.E))
    if E0 > 1e4 or 0 < E0 < E0_SOFTEST_MPA:
        out.append(f"the instantaneous modulus is {E0:.4g} MPa, outside what the elastomers of a muscle have "
                   f"({E0_SOFTEST_MPA:g} to 1e4 MPa; the softest silicones are some 0.05 MPa): likely a stress, load "
                   f"or strain unit slip; state the units in the header (stress_mpa, load_n, strain or strain_pct)"
                   + (" - a strain column in percent under a plain 'strain' name reads 100 times too large and the "
                      "modulus 100 times too small" if E0 < E0_SOFTEST_MPA and any(
                          r.strain is not None and r.strain.size and float(np.max(r.strain)) <= 1.0
                          for r in records) else ""))
    return out


def _relax_time_warnings(r, ramp_s: float | None) -> list[str]:
    """A relaxation test log whose times look like another unit than its column states: the whole test within a
    second (seconds under a milliseconds unit), or a loading ramp of many minutes in a seconds column
    (milliseconds under a seconds unit, fractions and all)."""
    t = np.asarray(r.time_s, float)
    if t.size < 3:
        return []
    col = _column(r, "time")
    unit = col.get("unit", "s")
    span = float(t[-1] - t[0])
    if span < MIN_DURATION_S:
        fix = (f"if the times are seconds, not {unit}, {unit_fix(r, 'time', 's')}" if unit != "s" else
               "check that the time column holds seconds")
        return [f"{_name(r)}: the test lasts only {span:.3g} s ({t.size} samples), too short for a relaxation test "
                f"(a ramp of seconds and a hold of minutes): {fix}"]
    if unit == "s" and ramp_s is not None and ramp_s > RELAX_RAMP_MAX_S:
        return [f"{_name(r)}: the loading ramp lasts {ramp_s:.4g} s and the test {span:.4g} s: a relaxation test "
                f"ramps in seconds to approximate a step, so these look like milliseconds read as seconds. If so, "
                f"{unit_fix(r, 'time', 'ms')}"]
    return []


def poisson_warnings(fit, nu: float, stated: bool) -> list[str]:
    """A warning when Poisson's ratio is the default (the paper's rubber, nearly incompressible) but the fitted
    instantaneous modulus is a glassy polymer's (above 1 GPa): G and K, and the FEA cards' bulk modulus, follow it."""
    E0 = float(fit.E_inf + np.sum(fit.E))
    if stated or E0 <= GLASSY_MPA:
        return []
    K = E0 / (3.0 * (1.0 - 2.0 * nu))
    return [f"Poisson's ratio is the default {nu:g} (the paper's rubber, nearly incompressible), but the instantaneous "
            f"modulus is {E0 / 1e3:.3g} GPa, a glassy polymer's, whose ratio is nearer 0.35: the shear and bulk "
            f"moduli follow it (K0 = {K / 1e3:.3g} GPa here, as in the FEA cards `bpmid export` writes); give the "
            f"material's own with --poisson (config relax.poisson)"]


def reader_warnings(logs: Iterable) -> list[str]:
    """The readers' own warnings (gaps, ignored columns) of every log, once each."""
    seen, out = set(), []
    for lg in logs:
        for w in getattr(lg, "warnings", None) or []:
            if w not in seen:
                seen.add(w)
                out.append(w)
    return out


def log_warnings(logs: Sequence) -> list[str]:
    """What reading and a first look at motion logs say (the readers' own warnings, then unit and reference slips),
    before any model runs on them."""
    return reader_warnings(logs) + motion_data_warnings(logs)


def reading_block(logs: Iterable) -> dict:
    """log name -> what its reader found and assumed (for the output's provenance)."""
    return {str(lg.name): dict(getattr(lg, "reading", {}) or {}) for lg in logs}


def strict_key(io_cfg) -> str:
    """Where the refusal of warnings came from: the ``--strict`` flag, or ``io.strict`` of the config."""
    return (getattr(io_cfg, "stated_by", None) or {}).get("strict", "io.strict")


def emit(warnings: Sequence[str], *, strict: bool = False, what: str = "the result", key: str = "--strict") -> None:
    """Print each warning on stderr (a command), or give it to a library caller as a :class:`bpmid.BpmidWarning`
    (which Python's warning filters then handle); with ``strict``, refuse (exit 2) before anything is written."""
    from bpmid.errors import _IN_COMMAND, warn_caller

    if not _IN_COMMAND.get():
        warn_caller(warnings)
    else:
        for w in warnings:
            print(f"warning: {w}", file=sys.stderr, flush=True)
    if strict and warnings:
        more = f" (and {len(warnings) - 1} more above)" if len(warnings) > 1 else ""
        undo = "leave out --strict" if key == "--strict" else f"set {key}: false"
        raise InputError(f"{what} was not written: {len(warnings)} warning(s) refused by {key}{more}; the "
                         f"first: {warnings[0]} (fix the input, or {undo} to write with the warnings)", key=key)


def attach(prov: dict, logs: Iterable, warnings: Sequence[str]) -> dict:
    """Add the reading record and the warnings to a provenance block (in place; returned for chaining)."""
    prov["reading"] = reading_block(logs)
    prov["warnings"] = list(warnings)
    return prov


def compare_warnings(summary) -> list[str]:
    """Warnings after ``compare``: when even the best model explains little of the test angles."""
    try:
        r2 = np.asarray(summary["r2"], float)
    except (KeyError, TypeError, ValueError):
        return []
    if r2.size and not np.nanmax(r2) >= R2_MIN:
        return [f"no model explains much of the test logs (best R^2 {np.nanmax(r2):.3g} < {R2_MIN:g}): likely a unit "
                f"or reference slip in the logs (--pressure-unit, --pressure-reference, --angle-unit) or the wrong "
                f"columns (--columns)"]
    return []


def assumed_ambient_note(logs: Iterable) -> str | None:
    """A note for measured logs whose absolute pressures were turned to gauge with the standard atmosphere, which
    nothing stated (no ambient line or column, no flag or config): at 950 hPa (altitude, weather) that moves every
    gauge pressure by 6 kPa and the fitted moduli by some 10-30 %. None when every log states its ambient, is
    gauge, or is bpmid's own synthetic data (made at the standard atmosphere)."""
    from bpmid.io.motion_logs import is_synthetic

    named = [lg.name for lg in logs
             if str(((lg.reading or {}).get("pressure_reference") or {}).get("atmosphere_from") or "").startswith(
                 "io.atmosphere_pa (the standard atmosphere") and not is_synthetic([lg])]
    if not named:
        return None
    which = ", ".join(named[:4]) + (f" and {len(named) - 4} more" if len(named) > 4 else "")
    return (f"pressure: the absolute pressures of {which} were turned to gauge with the standard atmosphere "
            "(101 325 Pa), which nothing in the logs states; at another ambient (altitude, weather) state it: a line "
            "'# ambient_pressure: 950 mbar', an ambient column (ambient_pressure_kpa), or io.atmosphere_pa in a "
            "config (io: {atmosphere_pa: 95000})")


#: how far beyond the fitted pressures (a share of their span) a predicted log may go before it is said: the
#: paper's own test logs reach up to 1.5 spans above its fitting set on purpose; a unit slip goes far beyond (psi
#: read as kPa: x6.9)
BEYOND_FIT_SHARE = 3.0


def beyond_fit_warnings(logs: Iterable, fit_body: Mapping | None) -> list[str]:
    """Logs predicted at gauge pressures well outside those the constants were fitted on (``fit.logs[*].
    pressure_gauge_pa`` of a ``bpmid.vbmm/1`` file; files written before it existed say nothing): the model
    extrapolates there, and a unit slip (kPa values under a psi header) shows first as such a range."""
    from bpmid.models.vbmm.rig import fitted_pressure_span

    span = fitted_pressure_span(fit_body)
    if span is None:
        return []
    lo, hi = span
    pad = BEYOND_FIT_SHARE * max(hi - lo, 1.0)
    out = []
    for lg in logs:
        pmin, pmax = (float(v) for v in np.percentile(lg.pressure_pa, [0.5, 99.5]))   # a spike is no range
        if pmax > hi + pad or pmin < lo - pad:
            out.append(f"{_name(lg)}: its gauge pressure runs {pmin / 1e5:.3g} to {pmax / 1e5:.3g} bar, far beyond the "
                       f"{lo / 1e5:.3g}-{hi / 1e5:.3g} bar the constants were fitted on: the prediction extrapolates "
                       "(check the log's pressure unit and reference; or fit on logs that cover this range)")
    return out

