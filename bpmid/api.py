"""The library's workflows, one call each, each returning a :mod:`bpmid.results` object.

These are what ``import bpmid`` exposes (``bpmid.fit_motion`` ...) and what the CLI commands call. Units are
explicit at this boundary: files state theirs in column names; arrays get theirs as arguments
(:func:`from_arrays`); nothing is taken to be Pa silently.

Every function takes ``config``: a :class:`bpmid.config.Config`, the path of a config YAML, or None for the
defaults. Logs are paths (read with the config's ``io`` section) or already-read log objects.
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterable, Mapping, Sequence

from bpmid.errors import InputError, warn_caller
from bpmid.units import ATMOSPHERE_PA, PA_PER_BAR


# --------------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------------
def _give(warnings: list, cfg, what: str, *, warn: bool = True) -> None:
    """A workflow's warnings to the caller as :class:`bpmid.BpmidWarning`; with ``io.strict`` in the config (the
    CLI's ``--strict``) refused instead, as the command refuses them: InputError, key ``io.strict``."""
    from bpmid.errors import _IN_COMMAND

    if _IN_COMMAND.get():   # a command prints them and applies --strict itself (plausibility.emit)
        return
    io = cfg.section("io") if hasattr(cfg, "section") else getattr(cfg, "io", None)
    if warnings and getattr(io, "strict", False):
        n = len(warnings)
        raise InputError(f"{what} was refused: {n} warning{'s' if n != 1 else ''} under io.strict; "
                         f"{'the first' if n > 1 else 'it says'}: "
                         f"{warnings[0]} (fix the input, or set io.strict: false to get the result with its warnings)",
                         key="io.strict")
    if warn:
        warn_caller(warnings)


def _config(config):
    from bpmid.config import Config, load_config, parse_config

    if config is None or isinstance(config, (str, Path)):
        return load_config(config)
    if isinstance(config, Mapping):   # the sections as a YAML file holds them: {"discover": {...}}
        return parse_config(dict(config))
    if not isinstance(config, Config):
        raise InputError(f"config must be a Config, a mapping of sections ({{'discover': {{...}}}}), a path or None, "
                         f"found {type(config).__name__}", key="config")
    return config


def _as_list(x) -> list:
    if x is None:
        return []
    if isinstance(x, (str, Path, Mapping)) or not isinstance(x, Iterable) or _is_table(x):
        return [x]   # one table is one item (iterating a DataFrame gives its column names, taken for paths)
    return list(x)


def _is_table(x) -> bool:
    """A pandas DataFrame, or a numeric array or Series: data, not a list of logs (an array or Series of file
    paths is a list of logs)."""
    if type(x).__module__.split(".")[0] not in ("pandas", "numpy"):
        return False
    if type(x).__name__ == "DataFrame":
        return True
    kind = getattr(getattr(x, "dtype", None), "kind", "O")
    return kind in "biufc"


def _not_a_log(x, key: str, what: str = "a log is a path or a MotionLog (bpmid.from_arrays)") -> InputError:
    hint = ""
    if _is_table(x):
        hint = ("; a table of samples goes in through bpmid.from_arrays(t, pressure, angle, pressure_unit=..., "
                "reference=...), one log per call (e.g. from_arrays(df['time_s'], df['pressure_kpa'], "
                "df['angle_deg'], pressure_unit='kPa', reference='gauge'))")
    return InputError(f"{what}, found {type(x).__name__}{hint}", key=key)


def _motion_logs(logs, cfg, *, require_angle: bool = False, key: str = "logs") -> tuple[list, list[Path]]:
    """(MotionLog list, the paths among the inputs) from paths and/or MotionLog objects (``key``: the argument, for
    messages)."""
    from bpmid.io.motion_logs import MotionLog, read_motion_logs

    items = _as_list(logs)
    if not items:
        raise InputError("no logs given", key=key)
    paths = [Path(x) for x in items if isinstance(x, (str, Path))]
    for p in paths:
        if not p.is_file():
            raise InputError("log file not found", path=p)
    read = iter(read_motion_logs(paths, cfg.section("io"), require_angle=require_angle) if paths else [])
    out = []
    for x in items:
        if isinstance(x, (str, Path)):
            out.append(next(read))
        elif isinstance(x, MotionLog):
            if require_angle and x.angle_deg is None:
                raise InputError("this log has no measured angle (angle_deg)", path=x.path or x.name)
            out.append(_array_gaps(x, cfg.section("io")))
        else:
            raise _not_a_log(x, key)
    from bpmid.io.motion_logs import check_distinct_names

    check_distinct_names(out, key=key)   # outputs are named by the log: two of one name would be one
    return out, paths


def _paths(items, what: str, key: str) -> list[Path]:
    """The items as paths; anything else is an InputError naming ``key`` (these calls read, hash and name files)."""
    out = []
    for x in _as_list(items):
        if not isinstance(x, (str, Path)):
            raise InputError(f"{what} must be file paths (str or Path), found {type(x).__name__}: this call reads, "
                             "hashes and names its inputs by file; write the data to a file first"
                             + ("" if "relaxation" in what else
                                " (a MotionLog: bpmid.io.motion_logs.write_motion_log(path, log))"), key=key)
        out.append(Path(x))
    return out


def _vbmm(params, model_cfg):
    """A VBMM from a ``bpmid.vbmm/1`` path, a :class:`VBMMFitResult` or a VBMM; plus the path when there is one."""
    from bpmid.models.vbmm import VBMM, load_vbmm, vbmm_from_mapping
    from bpmid.results import VBMMFitResult

    if isinstance(params, (str, Path)):
        return load_vbmm(params, model_cfg), Path(params)
    if isinstance(params, VBMMFitResult):
        return vbmm_from_mapping(params.to_dict(), params.source, model_cfg), params.source
    if isinstance(params, VBMM):   # a config's model section speaks to it as to a fit file's
        from bpmid.models.vbmm import with_config

        return with_config(params, model_cfg), None
    raise InputError(f"params must be a bpmid.vbmm/1 file, a VBMMFitResult or a VBMM, found {type(params).__name__}",
                     key="params")


# --------------------------------------------------------------------------------------------------
# logs
# --------------------------------------------------------------------------------------------------
def _clock_to_seconds(time_s, time_unit: str):
    """(times, where they came from): datetimes and time deltas (numpy ``datetime64``/``timedelta64``, a pandas
    ``DatetimeIndex`` or ``Timestamp`` column, ``datetime`` objects) as float seconds since the first sample, and a
    note saying so; anything else unchanged, with None. ``np.asarray(t, float)`` read such times as nanoseconds
    (a 6 s log became 6e10 s, silently)."""
    import datetime

    import numpy as np

    first = (time_s[0] if isinstance(time_s, (list, tuple)) and time_s else
             time_s.flat[0] if isinstance(time_s, np.ndarray) and time_s.dtype == object and time_s.size else None)
    if type(time_s).__module__.startswith("pandas") or (
            isinstance(first, datetime.datetime) and first.tzinfo is not None):
        import pandas as pd   # time-zone-aware clock times: to UTC first (numpy warns on each one otherwise)

        try:
            if isinstance(time_s, pd.Series) and isinstance(time_s.dtype, pd.DatetimeTZDtype):
                time_s = time_s.dt.tz_convert(None)
            elif isinstance(time_s, pd.DatetimeIndex) and time_s.tz is not None:
                time_s = time_s.tz_convert(None)
            elif isinstance(time_s, (list, tuple, np.ndarray)):
                time_s = pd.to_datetime(list(time_s), utc=True).tz_convert(None)
        except (TypeError, ValueError):
            pass
    try:
        arr = np.asarray(time_s)
    except (TypeError, ValueError):
        return time_s, None
    if arr.dtype == object and arr.size and isinstance(arr.flat[0], (datetime.datetime, datetime.timedelta)):
        try:
            arr = arr.astype("datetime64[ns]" if isinstance(arr.flat[0], datetime.datetime) else "timedelta64[ns]")
        except (TypeError, ValueError):
            return time_s, None
    if arr.dtype.kind not in "Mm":
        return time_s, None
    if time_unit.strip().lower() != "s":
        raise InputError(f"time_s holds clock times or time deltas, which carry their own unit: leave out "
                         f"time_unit={time_unit!r}", key="time_unit")
    if arr.size and np.any(np.isnat(arr)):
        raise InputError("time_s must be finite times (NaT found)", key="time_s")
    secs = (arr - arr.flat[0]).astype("timedelta64[ns]").astype(np.int64) / 1e9 if arr.size else arr.astype(float)
    return secs, "datetimes in time_s: seconds since the first sample"


def from_arrays(time_s, pressure, angle_deg=None, *, pressure_unit: str | None = None,
                reference: str | None = None, name: str = "log", atmosphere_pa: float = ATMOSPHERE_PA,
                time_unit: str = "s", angle_unit: str = "deg"):
    """A motion log from arrays, with the pressure's unit and reference stated.

    Parameters
    ----------
    time_s : (N,) times, strictly increasing, in ``time_unit`` (seconds unless stated); clock times or time
        deltas (``datetime64``, a pandas ``DatetimeIndex``) are taken as seconds since the first sample
    pressure : (N,) pressure in ``pressure_unit``
    angle_deg : (N,) measured bending angle in ``angle_unit`` (degrees unless stated), or None (a pressure-only
        log, e.g. for ``predict``)
    pressure_unit : ``"bar"``, ``"kPa"``, ``"Pa"``, ``"hPa"``, ``"MPa"``, ``"mbar"`` or ``"psi"`` (required): the units
        the command line's ``--pressure-unit`` takes, also with the reference after them (``"psig"``, ``"psia"``,
        ``"bar(a)"``, ``"kPa abs"``), which then states ``reference``
    reference : ``"gauge"`` or ``"absolute"`` (required unless ``pressure_unit`` carries it; the two must agree)
    name : the log's name (output file names)
    atmosphere_pa : ambient pressure (Pa) for an absolute reference (50-120 kPa)
    time_unit : ``"s"``, ``"ms"`` or ``"min"``: the unit of ``time_s``
    angle_unit : ``"deg"`` or ``"rad"``: the unit of ``angle_deg``

    Raises
    ------
    InputError : a missing unit or reference, arrays of different lengths, times not increasing, or a pressure
        that cannot be in the stated unit (a muscle driven by less than 0.01 bar, or by vacuum)
    """
    import numpy as np

    from bpmid.io.ambient import AMBIENT_RANGE_PA
    from bpmid.io.motion_logs import MotionLog
    from bpmid.units import (ANGLE_UNITS, PRESSURE_UNITS, TIME_UNITS, millipascal_slip, split_pressure_unit,
                             to_gauge_pa)

    if pressure_unit is None:
        raise InputError("state the pressure's unit: from_arrays(..., pressure_unit='bar'|'kPa'|'Pa', ...)",
                         key="pressure_unit")
    if (slip := millipascal_slip(pressure_unit)) is not None:
        raise InputError(slip, key="pressure_unit")
    # the units the command line's --pressure-unit takes (one list, bpmid.units): a reference after the unit
    # (psig, bar(a), kPa abs) states the reference
    unit, unit_ref = split_pressure_unit(pressure_unit) if isinstance(pressure_unit, str) else (None, None)
    if unit is None:
        raise InputError(f"unknown pressure unit {pressure_unit!r} (known: {', '.join(PRESSURE_UNITS)}, or with the "
                         f"reference after it: psig, psia, bar(a), kPa abs)", key="pressure_unit")
    if reference is None and unit_ref is None:
        raise InputError("state the pressure's reference: from_arrays(..., reference='gauge'|'absolute'), or a unit "
                         "that carries it (pressure_unit='psig', 'bar(a)')", key="reference")
    if reference is not None and unit_ref is not None and reference != unit_ref:
        raise InputError(f"pressure_unit={pressure_unit!r} is {unit_ref}, reference={reference!r} says otherwise: a "
                         f"reference stated twice must agree; drop one", key="reference")
    reference = reference if reference is not None else unit_ref
    for key, value, known in (("time_unit", time_unit, TIME_UNITS), ("angle_unit", angle_unit, ANGLE_UNITS)):
        if not isinstance(value, str) or value.strip().lower() not in known:
            raise InputError(f"unknown {key.split('_')[0]} unit {value!r} (known: {', '.join(known)})", key=key)
    if isinstance(atmosphere_pa, bool) or not isinstance(atmosphere_pa, (int, float, np.number)) \
            or not AMBIENT_RANGE_PA[0] <= float(atmosphere_pa) <= AMBIENT_RANGE_PA[1]:
        raise InputError(f"atmosphere_pa must be an ambient pressure in Pa, {AMBIENT_RANGE_PA[0]:g} to "
                         f"{AMBIENT_RANGE_PA[1]:g} (101325 at sea level), found {atmosphere_pa!r}", key="atmosphere_pa")
    if not isinstance(name, str) or not name.strip() or name in (".", "..") or any(c in name for c in "/\\\0"):
        raise InputError(f"a log's name names its output files: give a plain file stem, found {name!r}", key="name")
    time_s, from_clock = _clock_to_seconds(time_s, time_unit)
    try:
        if any(np.iscomplexobj(x) for x in (time_s, pressure, angle_deg) if x is not None):
            raise TypeError("complex numbers")
        t = np.asarray(time_s, float) * (1.0 if from_clock else TIME_UNITS[time_unit.strip().lower()])
        given = np.asarray(pressure, float)
        a = None if angle_deg is None else np.asarray(angle_deg, float) * ANGLE_UNITS[angle_unit.strip().lower()]
    except (TypeError, ValueError) as exc:
        raise InputError(f"time_s, pressure and angle_deg must be arrays of numbers ({exc})", key=name) from None
    if t.ndim != 1 or given.shape != t.shape or (a is not None and a.shape != t.shape):
        raise InputError(f"time_s, pressure and angle_deg must be 1-D arrays of one length, found shapes "
                         f"{t.shape}, {given.shape}, {None if a is None else a.shape}", key=name)
    # each refusal names the array and the first index, as the file readers name the line
    for label, arr in (("time_s", t), ("pressure", given), ("angle_deg", a)):
        if arr is not None and not np.all(np.isfinite(arr)):
            k = int(np.flatnonzero(~np.isfinite(arr))[0])
            raise InputError(f"{label} must be finite numbers: {label}[{k}] is {float(np.asarray(arr)[k])!r} (NaN or "
                             f"infinite values are not allowed; drop or fill that sample)", key=name)
    if t.size < 2:
        raise InputError(f"time_s must hold at least two samples, found {t.size}", key=name)
    if not np.all(np.diff(t) > 0):
        k = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
        how = "repeats" if t[k] == t[k - 1] else "goes backwards"
        raise InputError(f"time_s must increase: it {how} at time_s[{k}] ({t[k - 1]:.6g} s then {t[k]:.6g} s); "
                         f"sort the samples, or drop one of two written at the same time", key=name)
    gauge = to_gauge_pa(given, unit, reference, atmosphere_pa=atmosphere_pa)
    span = float(np.max(gauge))
    if span < 1e3:
        raise InputError(f"the largest gauge pressure is {span:.4g} Pa ({span / PA_PER_BAR:.4g} bar) for pressure_unit="
                         f"{pressure_unit!r}, reference={reference!r}: no muscle moves on that; check the unit "
                         "and the reference", key="pressure_unit")
    if float(np.min(gauge)) < -0.05 * PA_PER_BAR:
        raise InputError(f"pressure {float(np.min(gauge)) / PA_PER_BAR:.3g} bar gauge is below atmosphere: a wrong "
                         "reference (absolute vs gauge) or unit", key="reference")
    # what the plausibility checks read (a whole-number time a second apart in seconds: milliseconds?), with where
    # each unit came from, so that their hints name this function's arguments
    said = "from_arrays"
    reading = {"format": "arrays (bpmid.from_arrays)",
               "columns": {"time": {"column": "time_s", "unit": "s" if from_clock else time_unit.strip().lower(),
                                    "unit_from": from_clock or said},
                           "pressure": {"column": "pressure", "unit": unit, "unit_from": said},
                           **({"angle": {"column": "angle_deg", "unit": angle_unit.strip().lower(),
                                         "unit_from": said}} if a is not None else {})}}
    return MotionLog(name=name, time_s=t, pressure_pa=gauge, angle_deg=a, pressure_reference=reference,
                     pressure_unit=unit, pressure_as_given=given.copy(), atmosphere_pa=float(atmosphere_pa),
                     reading=reading)


def _array_gaps(lg, io):
    """A log made by :func:`from_arrays`, judged for gaps as the file readers judge a file (``io.max_gap_factor``
    warns, ``io.max_gap_s`` refuses), under the config the workflow runs with."""
    import dataclasses

    import numpy as np

    t = np.asarray(lg.time_s, float)
    if t.size < 2 or (lg.reading or {}).get("format") != "arrays (bpmid.from_arrays)":
        return lg
    dt = np.diff(t)
    if io.max_gap_s is not None and np.any(dt > io.max_gap_s):
        k = int(np.flatnonzero(dt > io.max_gap_s)[0])
        raise InputError(f"{lg.name}: gap of {dt[k]:g} s between samples {k} and {k + 1}, longer than io.max_gap_s "
                         f"{io.max_gap_s:g} s; raise or drop that setting to take the log", key="io.max_gap_s")
    med = float(np.median(dt))
    gaps = np.flatnonzero(dt > io.max_gap_factor * med)
    if not gaps.size:
        return lg
    k = int(gaps[0])
    w = (f"{lg.name}: gap of {dt[k]:g} s between samples {k} and {k + 1} (t = {t[k]:g} s) where the usual step is "
         f"{med:g} s" + (f" ({gaps.size} gaps)" if gaps.size > 1 else "") + "; taken as is: across a gap the input "
         "is taken to hold its last sample and change in one step at the next (io.max_gap_factor, io.max_gap_s)")
    reading = {**(lg.reading or {}), "gaps": {"count": int(gaps.size), "first_sample": k + 1,
                                              "longest_s": float(np.max(dt[gaps]))}}
    return dataclasses.replace(lg, warnings=[x for x in lg.warnings if "gap of" not in x] + [w], reading=reading)


def read_motion_logs(paths, *, config=None, require_angle: bool = False) -> list:
    """Read motion logs (CSV: ``time_s``, ``pressure_bar|kpa|pa`` with a stated reference, optional ``angle_deg``)."""
    return _motion_logs(paths, _config(config), require_angle=require_angle)[0]


def read_relax_logs(paths, *, config=None) -> list:
    """Read relaxation logs (``time_s,strain,stress_mpa``, ``time_s,extension_mm,load_n`` or ``time_s,modulus_mpa``)."""
    from bpmid.io.relax_logs import read_relax_logs as _read

    cfg = _config(config)
    rc = cfg.section("relax")
    gap = rc.max_gap_factor if rc.max_gap_factor is not None else cfg.section("io").max_gap_factor
    return _read([Path(p) for p in _as_list(paths)], column_map=rc.columns,
                 gauge_length_mm=rc.specimen.gauge_length_mm, cross_section_mm2=rc.specimen.cross_section_mm2,
                 gap_factor=gap)


# --------------------------------------------------------------------------------------------------
# workflows
# --------------------------------------------------------------------------------------------------
def fit_relaxation(logs, *, terms: int | str | None = None, mode: str | None = None, poisson: float | None = None,
                   config=None, max_error_pct: float | None = None, ref_temp: float | None = None, shift=None,
                   _flags: bool = False):
    """Fit a Prony series E(t) = E_inf + sum_j E_j exp(-t/tau_j) to relaxation logs (``bpmid fit relax``).

    Parameters
    ----------
    logs : relaxation log paths, frequency sweeps (storage and loss modulus) or raw sets at several temperatures
    terms : number of Prony terms or ``"auto"`` (default: ``relax.terms`` of the config)
    mode : ``"ramp"`` or ``"step"`` (default: the config's, or step for modulus curves)
    poisson : Poisson's ratio for G and K (default ``relax.poisson``)
    max_error_pct : the fewest terms whose error (%) is at most this, instead of ``terms``
    ref_temp : reference temperature (C) of a master curve built from raw sets at several temperatures
    shift : a CSV of shift factors (T in C, log_aT) to use instead of finding them from the data
    _flags : name the arguments as the command line's options in error messages (the CLI sets it)

    Returns
    -------
    bpmid.results.RelaxationResult : ``.raw`` is the live fit (its ``warnings`` are raised as
    :class:`bpmid.BpmidWarning` too);
    ``.save(path, figure=True)`` writes what ``bpmid fit relax`` writes
    """
    from bpmid.relax.result import fit_relax_files
    from bpmid.results import RelaxationResult

    paths = _paths(logs, "relaxation logs", "logs")
    if not paths:
        raise InputError("no relaxation logs given", key="logs")
    run = fit_relax_files(paths, terms=terms, mode=mode, poisson=poisson, config=_config(config),
                          max_error_pct=max_error_pct, ref_temp=ref_temp, shift=shift, flags=_flags)
    result = RelaxationResult(run.body, run.provenance, raw=run.fit)
    result._synthetic = run.synthetic
    warn_caller(run.body.get("warnings") or [])   # the file's warnings, for time-domain and material fits alike
    return result


def fit_motion(logs, *, init=None, config=None):
    """Fit the VBMM's moduli and time constants to pressure-angle logs (``bpmid fit motion``).

    Parameters
    ----------
    logs : motion log paths or :func:`from_arrays` logs, with measured angles
    init : where the fit starts: a relaxation fit (``bpmid.relax/1`` path or :class:`RelaxationResult`) or None
        (``motion.relax_fit`` of the config, else the paper's constants)

    Returns
    -------
    bpmid.results.VBMMFitResult : ``.model`` is the fitted VBMM
    """
    from bpmid.io.results import provenance
    from bpmid.io import plausibility as plaus
    from bpmid.models.vbmm.fit import fit_motion as _fit
    from bpmid.results import RelaxationResult, VBMMFitResult

    cfg = _config(config)
    motion, paths = _motion_logs(logs, cfg, require_angle=True)
    inputs = list(paths)
    if isinstance(init, RelaxationResult):
        if init.source is not None:
            inputs.append(init.source)
        init = init.to_dict()
    elif isinstance(init, (str, Path)):
        if not Path(init).is_file():
            raise InputError("relaxation fit not found", path=init, key="init")
        inputs.append(Path(init))
    elif init is not None:
        raise InputError(f"init must be a relaxation fit (a bpmid.relax/1 path or a RelaxationResult), found "
                         f"{type(init).__name__}", key="init")
    fit = _fit(motion, config=cfg, init=init)
    src = init
    mc = cfg.section("motion")
    if src is None and mc.relax_fit is not None:
        src = cfg.resolve_path(mc.relax_fit)
    g_inf = fit.prior.value("G_inf") if "G_inf" in fit.prior.names() else None
    warnings = (plaus.reader_warnings(motion) + (plaus.init_warnings(src, g_inf) if src is not None else [])
                + plaus.motion_fit_warnings(fit))
    _give(warnings, cfg, "the motion fit")
    body = {**fit.yaml_body(), "warnings": warnings}
    return VBMMFitResult(body, plaus.attach(provenance(inputs, config=cfg), motion, warnings), raw=fit)


def predict(logs, params, *, config=None):
    """Run a fitted VBMM free on pressure logs (``bpmid predict``).

    Parameters
    ----------
    logs : motion log paths or :func:`from_arrays` logs (angles optional: with them, metrics are computed)
    params : the VBMM: a ``bpmid.vbmm/1`` path (with its ``effects`` list, if it has one), a
        :class:`VBMMFitResult` or a ``bpmid.models.vbmm.VBMM``

    Returns
    -------
    bpmid.results.PredictionResult : ``.predictions`` maps log name -> predicted angle (deg)
    """
    from bpmid.io.results import provenance
    from bpmid.io import plausibility as plaus
    from bpmid.effects.fitfile import augmented_from_file
    from bpmid.models.vbmm import VBMM
    from bpmid.predict import predict as _predict, predict_yaml_body
    from bpmid.results import PredictionResult

    cfg = _config(config)
    model, ppath = _vbmm(params, cfg.section("model"))
    if not isinstance(params, VBMM):
        model = augmented_from_file(model, params)  # the fit's effects list acts too (never silently dropped)
    motion, paths = _motion_logs(logs, cfg)
    preds = _predict(motion, model)
    warnings = plaus.reader_warnings(motion) + plaus.prediction_warnings(preds)
    fit_body = params.to_dict() if hasattr(params, "to_dict") else None
    if ppath is not None and str(ppath).endswith((".yaml", ".yml")) and Path(ppath).is_file():
        from bpmid.io.results import read_result
        from bpmid.models.vbmm import fitted_history_note

        fit_body = read_result(ppath, "bpmid.vbmm/")
        note = fitted_history_note(fit_body.get("model"), model.base if hasattr(model, "base") else model)
        if note:
            warnings.insert(0, f"{ppath}: {note}")
    warnings += plaus.beyond_fit_warnings(motion, fit_body)
    from bpmid.models.vbmm.rig import step_warnings

    warnings += step_warnings(motion, fit_body, (model.base if hasattr(model, "base") else model).material)
    _give(warnings, cfg, "the prediction")
    body = {**predict_yaml_body(preds, params=ppath, model=model), "warnings": warnings}
    prov = plaus.attach(provenance(list(paths) + ([ppath] if ppath else []), config=cfg), motion, warnings)
    out = PredictionResult(body, prov, raw=preds)
    out._model = model  # what save() hands the writer (the same settings as body["model"])
    return out


def compare(train=None, test=None, *, models: Sequence[str] | str | None = None, relax=None, config=None):
    """Fit every model on the training logs only and score each free-running on the test logs (``bpmid compare``).

    Parameters
    ----------
    train, test : motion log paths (default: ``compare.train`` / ``compare.test_sets`` of the config)
    models : registry names (see :data:`bpmid.REGISTRY`) or a comma list; default the config's, else all
    relax : relaxation fit path for vbmm-mat (default ``compare.relax`` of the config)

    Returns
    -------
    bpmid.results.ComparisonResult : ``.table`` is the ranked summary
    """
    from bpmid.compare import compare_files, compare_yaml_body, resolve_inputs
    from bpmid.models import parse_model_list
    from bpmid.results import ComparisonResult

    cfg = _config(config)
    if isinstance(models, str):
        models = parse_model_list(models)
    elif models is not None:
        models = parse_model_list(",".join(models))
    from bpmid.results import RelaxationResult

    if isinstance(relax, RelaxationResult) and relax.source is not None:
        relax = relax.source   # a loaded fit: its file
    if isinstance(relax, RelaxationResult):
        raise InputError("relax is a RelaxationResult not saved to a file: compare names and hashes its inputs by "
                         "file, so save it first (relax.save('relax_fit.yaml')) and pass that path or the result "
                         "bpmid.load gives", key="relax")
    if relax is not None and not isinstance(relax, (str, Path)):
        raise InputError(f"relax must be a bpmid.relax/1 file path (or a RelaxationResult loaded from one), found "
                         f"{type(relax).__name__}", key="relax")
    train_paths, test_sets, relax_path = resolve_inputs(cfg.section("compare"), cfg,
                                                        train=_paths(train, "training logs", "train") or None,
                                                        test=_paths(test, "test logs", "test") or None, relax=relax)
    result, prov, how = compare_files(train_paths, test_sets, models=models, config=cfg, relax_fit=relax_path)
    body = compare_yaml_body(result, how["relax_fit"])
    from bpmid.io.motion_logs import is_synthetic

    body["synthetic"] = is_synthetic(list(result.train) + list(result.test))   # every log synthetic
    # .warnings: the overlaps compare_yaml_body holds and what reading and scoring said (given as BpmidWarning)
    body["warnings"] = list(dict.fromkeys(list(body.get("warnings") or []) + list(prov.get("warnings") or [])))
    out = ComparisonResult(body, prov, raw=result)
    out._figure_logs = how["n_figure_logs"]
    return out


def discover(logs, *, holdout=None, init=None, config=None):
    """Name the effects the VBMM lacks (``bpmid discover``): fit the base VBMM, diagnose the residual, screen
    every catalogue effect, confirm on held-out logs, add one effect at a time.

    Parameters
    ----------
    logs : motion logs with measured angles
    holdout : held-out logs (default: a fixed split of ``logs``)
    init : starting constants: a ``bpmid.vbmm/1`` or ``bpmid.relax/1`` path, or a VBMMFitResult / RelaxationResult
        (default: the paper's VBMM-fit constants)

    Returns
    -------
    bpmid.results.DiscoveryResult : ``.named_effects``, ``summary()`` carries the verdict
    """
    from bpmid.discover import discover as _discover
    from bpmid.io.results import provenance
    from bpmid.models.vbmm import starting_vbmm
    from bpmid.results import DiscoveryResult

    cfg = _config(config)
    fit_logs, paths = _motion_logs(logs, cfg, require_angle=True)
    ho_logs, ho_paths = (_motion_logs(holdout, cfg, require_angle=True, key="holdout") if holdout is not None
                         else (None, []))
    if init is not None and not isinstance(init, (str, Path)) and not hasattr(init, "to_dict"):
        raise InputError(f"init is a bpmid.vbmm/1 or bpmid.relax/1 file, or a fit result (bpmid.fit_motion, "
                         f"bpmid.fit_relaxation, bpmid.load), found {type(init).__name__}", key="init")
    base, base_from, init_path = starting_vbmm(init, cfg.section("model"))
    from bpmid.io import plausibility as plaus

    every = list(fit_logs) + list(ho_logs or [])
    warnings = plaus.log_warnings(every)   # what `bpmid discover` prints
    _give(warnings, cfg, "the discovery", warn=False)   # io.strict refuses the logs' warnings before the work
    res = _discover(fit_logs, base, holdout=ho_logs, cfg=cfg.section("discover"))
    warn_caller(warnings + [f"discovery: {c}" for c in res.cautions]
                + (["part of the gap stays unexplained by the catalogue"] if res.unexplained else []))
    body = res.to_yaml()
    body["base_from"] = base_from
    prov = provenance(list(paths) + list(ho_paths) + ([init_path] if init_path else [])
                      + ([Path(res.thresholds_file)] if res.thresholds_file else []), config=cfg)
    return DiscoveryResult(body, plaus.attach(prov, every, warnings), raw=res)


def simulate(protocol, *, params=None, effects: Sequence[str] = (), seed: int | None = None,
             timestamp: bool = True):
    """Run a protocol file (``bpmid.protocol/1``) on the digital twin (``bpmid simulate``); nothing is written
    until ``.save(folder)``.

    Parameters
    ----------
    protocol : protocol path (shipped ones: :func:`bpmid.data.path` ``("configs/datasets/<name>.yaml")``)
    params : VBMM constants of the plant (``bpmid.vbmm/1`` path; default the protocol's preset)
    effects : catalogue effects to inject, ``"ID[:key=value,...]"`` each
    seed : overrides the protocol's seed
    timestamp : record the creation time (False: byte-reproducible)

    Returns
    -------
    bpmid.results.SimulationResult : synthetic logs (labelled so) and their manifest
    """
    from bpmid.results import SimulationResult
    from bpmid.twin.simulate import simulate as _simulate

    import numbers

    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0):
        raise InputError(f"seed must be a non-negative integer, found {seed!r}", key="seed")
    from bpmid.results import VBMMFitResult

    if isinstance(params, VBMMFitResult) and params.source is not None:
        params = params.source   # a loaded fit: its file
    if params is not None and not isinstance(params, (str, Path)):
        raise InputError(f"params must be a bpmid.vbmm/1 file path (or a VBMMFitResult loaded from one), found "
                         f"{type(params).__name__}", key="params")
    sim = _simulate(protocol, params_path=params, effects=tuple(_as_list(effects)), seed=seed, timestamp=timestamp)
    return SimulationResult(sim.manifest, sim.manifest.get("provenance"), raw=sim)


def control(params, *, reference: str | Sequence[str] = "all", controllers: Sequence[str] | str | None = None,
            plant_params=None, plant_effects: Sequence[str] = (), config=None, **settings):
    """Closed-loop tracking with PI, VBMM-PI and MS-PI at the control rate (``bpmid control``).

    Parameters
    ----------
    params : the controller's VBMM (``bpmid.vbmm/1`` path or :class:`VBMMFitResult` or VBMM)
    reference : shipped reference names, CSV paths (``time_s, angle_deg``) or ``"all"``; a list or a comma list
    controllers : any of ``pi``, ``vbmm-pi``, ``ms-pi`` (default: ``control.controllers`` of the config)
    plant_params : the plant's VBMM (default the controller's)
    plant_effects : catalogue effects of the plant, ``"ID[:key=value,...]"`` each
    settings : fields of the config section ``control`` by name with their units in the name
        (``kp_bar_per_deg``, ``ki_bar_per_deg_s``, ``seed``, ``plant_modulus_scale``, ``plant_tau_scale``,
        ``pressure_dynamics`` ...)

    Returns
    -------
    bpmid.results.ControlResult : ``.table`` is the summary (RMSE per controller and reference)
    """
    import dataclasses

    from bpmid.control import (build_plant, control_yaml_body, load_references, references_reading, run_control,
                               scaled_plant_model)
    from bpmid.io.results import provenance
    from bpmid.results import ControlResult

    cfg_all = _config(config)
    cfg = cfg_all.section("control")
    known = {f.name for f in dataclasses.fields(cfg)}
    for k in settings:
        if k not in known:
            raise InputError(f"unknown control setting (known: {', '.join(sorted(known))})", key=k)
    if isinstance(controllers, str):
        controllers = [c.strip() for c in controllers.split(",") if c.strip()]
    if controllers is not None:
        settings["controllers"] = tuple(controllers)
    if settings:
        cfg = dataclasses.replace(cfg, **settings)
        cfg.validate()
    controllers = list(cfg.controllers)
    model_cfg = cfg_all.section("model")
    from bpmid.effects.fitfile import refuse_effects_list
    from bpmid.models.vbmm import VBMM

    model, ppath = _vbmm(params, model_cfg)
    plant_base, plant_path = _vbmm(plant_params, model_cfg) if plant_params is not None else (model, None)
    for fit in (params, plant_params):
        if fit is not None and not isinstance(fit, VBMM):
            refuse_effects_list(fit, "bpmid control", "give the plant's effects with --plant-effect ID:key=value")
    plant_base = scaled_plant_model(plant_base, cfg.plant_modulus_scale, cfg.plant_tau_scale)
    plant = build_plant(plant_base, list(_as_list(plant_effects)), cfg)
    if not isinstance(reference, str) and (_is_table(reference) or any(
            not isinstance(r, (str, Path)) for r in _as_list(reference))):
        bad = reference if _is_table(reference) else next(r for r in _as_list(reference)
                                                          if not isinstance(r, (str, Path)))
        raise InputError(f"reference is a shipped reference's name, a CSV path (time_s, angle_deg) or 'all', found "
                         f"{type(bad).__name__}: write the reference to a CSV first", key="reference")
    spec = reference if isinstance(reference, str) else ",".join(str(r) for r in reference)
    refs = load_references(spec, cfg.rate_hz, io=cfg_all.section("io"))
    res = run_control(model, plant, refs, cfg, controllers=controllers)
    from bpmid.models.vbmm.rig import loop_step_warning

    for fit, m, what in ((params, model, "the controller's model"), (plant_params, plant_base, "the plant's model")):
        if fit is not None and not isinstance(fit, VBMM):
            res.warnings[:0] = loop_step_warning(cfg.rate_hz, fit, m, what=what)
    # given as BpmidWarning; not refused under io.strict: they say how the loop ran, not that an input is wrong
    # (bpmid control and bpmid run print them and write the result alike)
    warn_caller(list(res.warnings))
    inputs = [p for p in (ppath, plant_path) if p is not None] + [r.path for r in refs if r.path is not None]
    prov = provenance(inputs, config=cfg_all if cfg_all.path else None, seed=cfg.seed)
    prov["reading"] = references_reading(refs)
    out = ControlResult(control_yaml_body(res, cfg, model=model, plant=plant), prov, raw=res)
    out._write_context = {"cfg": cfg, "model": model, "plant": plant}
    return out


def run_study(config=None, out=None):
    """The whole study (``bpmid run``): relaxation fit, motion fit, comparison, history modes, discovery and the
    report, every stage's files in ``out``.

    Parameters
    ----------
    config : study config path or Config (default: the shipped ``configs/paper.yaml``)
    out : output folder (default: ``run.out`` of the config, else ``out/<config name>``)

    Returns
    -------
    bpmid.results.StudyResult : ``.results`` maps each stage's output to its result object
    """
    from bpmid.results import load
    from bpmid.run import default_config_path, run_study as _run

    if config is None:
        config = default_config_path()
    cfg = _config(config)
    rc = cfg.section("run")
    name = Path(cfg.path).stem if cfg.path is not None else "study"
    out_dir = Path(out) if out is not None else Path(rc.out) if rc.out else Path("out") / name
    _run(cfg, out_dir)
    return load(out_dir)


def export(fit, to: str, out, *, model: str | None = None) -> list[Path]:
    """A fitted model for another tool (``bpmid export``): dependency-free C99 for a real-time controller, or
    Abaqus/ANSYS/COMSOL material cards of a relaxation fit; written whole or not at all.

    Parameters
    ----------
    fit : a fit file (``bpmid.vbmm/1``, ``bpmid.compare/1``, ``bpmid.control/1`` for ``to="c"``; ``bpmid.relax/1``
        for the FEA cards), or a result loaded from one (``bpmid.load``): the export reads the file, and the
        generated code names it with its sha256 (a result fitted in this session: ``result.save("fit.yaml")``, then
        export ``"fit.yaml"``)
    to : "c", "abaqus", "ansys" or "comsol"
    out : output folder (created; a file in it that bpmid did not write is never replaced)
    model : for ``to="c"`` of a comparison or control result: "vbmm-fit", "vbmm-mat" or "maxwell-slip"

    Returns
    -------
    list of Path : the files written
    """
    from bpmid.export import export as _export
    from bpmid.results import Result

    if isinstance(fit, Result):
        if fit.source is None:
            raise InputError(f"this {type(fit).__name__} was not loaded from a file: the export reads a fit file (its "
                             "sha256 goes into what it writes); save it (result.save('fit.yaml')) and pass the file: "
                             "bpmid.export('fit.yaml', ...)", key="fit")
        path = Path(fit.source)
    elif isinstance(fit, (str, Path)):
        path = Path(fit)
    else:
        raise InputError(f"fit is a fit file's path or a result loaded from one (bpmid.load), not a "
                         f"{type(fit).__name__}", key="fit")
    if path.is_dir():
        from bpmid.export import refuse_folder

        refuse_folder(path)
    if not path.is_file():
        raise InputError("fit file not found", path=path, key="fit")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError("out must be a folder, found a file", path=out, key="out")
    try:
        return _export(path, to, out, model=model)
    except InputError as exc:
        if exc.key != "--out":
            raise
        raise InputError(exc.message, path=exc.path, line=exc.line, key="out") from None   # this call's argument


__all__ = ["from_arrays", "read_motion_logs", "read_relax_logs", "fit_relaxation", "fit_motion", "predict",
           "compare", "discover", "simulate", "control", "run_study", "export"]
