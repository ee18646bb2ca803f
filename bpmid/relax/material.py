"""Material data for ``bpmid fit relax``: frequency sweeps and raw sets at several temperatures.

- frequency-domain master curves (E', E'' against f) -> one Prony series fitted to both (:mod:`bpmid.relax.freq`)
- raw isothermal sets (frequency sweeps or relaxation curves, with a temperature per row and a set column) ->
  shift factors (found from the data, or given), the master curve at the reference temperature, WLF and
  polynomial shift functions (:mod:`bpmid.relax.tts`) -> the Prony fit of that master curve (frequency: joint
  E'/E'' fit; time: the step-mode fit of :func:`bpmid.relax.fit.fit_relaxation`)

The result is a ``bpmid.relax/1`` file like every relaxation fit, with ``mode: frequency`` for frequency-domain data
and a ``shift`` block (``shift.log_aT`` per temperature, ``shift.wlf.C1``, ``C2``, ``T_ref``, ``shift.poly``) when
sets were shifted.
"""
from __future__ import annotations

import dataclasses
from typing import Sequence

import numpy as np

from bpmid.errors import InputError
from bpmid.io.material_files import MaterialData
from bpmid.io.relax_logs import RelaxLog
from bpmid.progress import note
from bpmid.relax import tts


@dataclasses.dataclass
class SetCurve:
    """One isothermal set for the figure: raw axis and moduli, and its shift."""

    T: float
    x: np.ndarray
    storage: np.ndarray
    loss: np.ndarray | None
    log_aT: float
    source: str


@dataclasses.dataclass
class MaterialFit:
    """What ``fit relax`` made of material data.

    Attributes
    ----------
    domain : ``"freq"`` or ``"time"``
    fit : :class:`bpmid.relax.freq.FreqFit` (frequency) or :class:`bpmid.relax.fit.RelaxFit` (time, step mode)
    shift : the shift factors and functions, or None for a master curve given as such
    sets : the raw sets (for the figure); empty for a master curve
    modulus : ``"E"`` or ``"G"``
    sources : the files
    units_in_file : file name -> {column role: the unit the file states ('' where none)}
    set_temperature : for one set with a temperature column: {"T": set temperature (C, rounded as raw sets are
        labelled), "mean_measured": the mean measured temperature (C)}; else None
    checks : warnings ``--strict`` refuses (shift factors the data do not determine, a WLF that does not describe
        them, a modulus the fit misses by more than 300 % RMS)
    """

    domain: str
    fit: object
    shift: tts.ShiftResult | None
    sets: list
    modulus: str
    sources: list
    units_in_file: dict = dataclasses.field(default_factory=dict)
    set_temperature: dict | None = None
    checks: list = dataclasses.field(default_factory=list)

    @property
    def m(self) -> int:
        return self.fit.m

    @property
    def warnings(self) -> list:
        return list(self.fit.warnings)


def _label(d: MaterialData) -> str:
    return d.path.name if d.path is not None else d.name


def check_domains(datas: Sequence[MaterialData], logs: Sequence[RelaxLog] = ()) -> str:
    """One domain and one modulus kind per call; returns the domain. Exit-2 messages name the files."""
    if logs and datas:
        lg, d = logs[0], datas[0]
        if d.domain == "freq":
            raise InputError(f"mixed domains in one call: {_label(d)} holds frequency-domain moduli, "
                             f"{lg.path.name if lg.path else lg.name} a time-domain relaxation log; fit them "
                             "separately", path=lg.path or d.path)
        raise InputError(f"mixed kinds in one call: {_label(d)} holds relaxation curves at several temperatures, "
                         f"{lg.path.name if lg.path else lg.name} a single test log; fit them separately",
                         path=lg.path or d.path)
    first = datas[0]
    for d in datas[1:]:
        if d.domain != first.domain:
            raise InputError(f"mixed domains in one call: {_label(first)} is "
                             f"{'frequency' if first.domain == 'freq' else 'time'}-domain data, {_label(d)} is "
                             f"{'frequency' if d.domain == 'freq' else 'time'}-domain data; fit them separately",
                             path=d.path, line=int(d.lines[0]) if d.lines is not None else None)
        if d.modulus != first.modulus:
            raise InputError(f"{_label(first)} gives {first.modulus} moduli, {_label(d)} {d.modulus} moduli; "
                             "fit tensile and shear data separately", path=d.path)
    return first.domain


def _pooled_sets(datas: Sequence[MaterialData]):
    out = []
    for d in datas:
        if d.temperature_c is None and len(datas) > 1 and any(x.is_raw for x in datas):
            raise InputError("a master curve without temperatures cannot be pooled with raw sets at several "
                             "temperatures", path=d.path)
        if d.temperature_c is None and len(datas) > 1:
            raise InputError(f"{len(datas)} files are pooled as sets at their temperatures, and {_label(d)} has no "
                             "temperature column (a '# Temperature:' comment line is not read): add a column T (C) "
                             "to each file, or fit one file at a time", path=d.path, key="T")
        for T, idx in d.sets():
            out.append((T, d, idx))
    return out


def build_master(datas: Sequence[MaterialData], *, ref_temp: float | None = None, shift_file=None,
                 config=None) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, tts.ShiftResult | None, list]:
    """Master curve (x reduced to ``ref_temp``, storage, loss) from the data, and the shift (None when none needed).

    Parameters
    ----------
    ref_temp : reference temperature (C); default: the set temperature nearest the median of the set temperatures
    shift_file : a CSV of user shift factors (T, log_aT); default: found from the data
    """
    domain = datas[0].domain
    pooled = _pooled_sets(datas)
    raw = len(pooled) > 1
    if not raw:
        d = datas[0]
        if d.temperature_c is None:
            if shift_file is not None:
                raise InputError("--shift applies to sets with a temperature column; this file holds one curve "
                                 "without temperatures", path=d.path, key="--shift")
            if ref_temp is not None:
                note(f"--ref-temp {ref_temp:g} C ignored: {_label(d)} is a master curve without temperatures")
            return d.x.copy(), d.storage.copy(), None if d.loss is None else d.loss.copy(), None, []
        T_set, idx = d.sets()[0]
        T_mean = float(np.mean(d.temperature_c))
        if shift_file is None:
            if ref_temp is not None and abs(T_mean - ref_temp) > 0.5:
                raise InputError(f"--ref-temp {ref_temp:g} C: {_label(d)} holds one set, measured at {T_mean:.4g} C; "
                                 "a single set cannot be moved to another temperature without shift factors: give "
                                 "them with --shift FILE (T, log_aT), or leave out --ref-temp to fit the curve at "
                                 f"{T_mean:.4g} C", path=d.path, line=d.where(int(idx[0])), key="--ref-temp")
            return d.x.copy(), d.storage.copy(), None if d.loss is None else d.loss.copy(), None, []
        # one set moved by the user's shift factor
        pooled = [(T_set, d, idx)]
        T = np.array([T_set])
        ref_temp = T_set if ref_temp is None else ref_temp
        Tu, au = tts.read_shift_file(shift_file)
        log_aT = tts.shift_from_user(T, Tu, au, ref_temp, shift_file)
        return _shifted(pooled, log_aT, tts.shift_result(T, log_aT, ref_temp, "user"), domain)
    T = np.array([p[0] for p in pooled])
    if np.unique(T).size < T.size:
        Ts = np.sort(T)
        dup = float(Ts[np.flatnonzero(np.diff(Ts) == 0)[0]])
        src = [p for p in pooled if p[0] == dup]
        at = ", ".join(f"{_label(d)} line {d.where(int(idx[0]))}" for _, d, idx in src)
        raise InputError(f"two sets at {dup:g} C ({at}; set temperatures are rounded to whole degrees); merge or "
                         "drop one", path=src[-1][1].path, line=src[-1][1].where(int(src[-1][2][0])))
    if ref_temp is None:
        ref_temp = float(T[np.argmin(np.abs(T - np.median(T)))])
        note(f"reference temperature {ref_temp:g} C (the median set temperature; set it with --ref-temp)")
    if not (T.min() - 1e-9 <= ref_temp <= T.max() + 1e-9):
        raise InputError(f"--ref-temp {ref_temp:g} C lies outside the set temperatures {T.min():g} ... {T.max():g} C",
                         key="--ref-temp")
    logx = [np.log10(d.x[idx]) for _, d, idx in pooled]
    logy = [np.log10(d.storage[idx]) for _, d, idx in pooled]
    if shift_file is not None:
        Tu, au = tts.read_shift_file(shift_file)
        log_aT = tts.shift_from_user(T, Tu, au, ref_temp, shift_file)
        pair, source = None, "user"
    else:
        anchor = float(T[np.argmin(np.abs(T - ref_temp))])
        where = [(d.path, d.where(int(idx[0]))) for _, d, idx in pooled]
        search = tts.search_shift_factors(T, logx, logy, anchor, domain=domain, where=where)
        log_aT, pair = search.log_aT, search.pair
        if abs(anchor - ref_temp) > 1e-9:  # re-reference between the two neighbouring sets
            o = np.argsort(T)
            log_aT = log_aT - float(np.interp(ref_temp, T[o], log_aT[o]))
        source = "data"
        return _shifted(pooled, log_aT, tts.shift_result(T, log_aT, ref_temp, source, pair, search), domain)
    return _shifted(pooled, log_aT, tts.shift_result(T, log_aT, ref_temp, source, pair), domain)


def _shifted(pooled, log_aT, shift, domain):
    """The master curve of the pooled sets moved by their shift factors (see :func:`build_master`)."""
    sign = 1.0 if domain == "freq" else -1.0
    xs, ss, ls, sets = [], [], [], []
    for (Tk, d, idx), a in zip(pooled, log_aT):
        xs.append(d.x[idx] * 10.0 ** (sign * a))
        ss.append(d.storage[idx])
        ls.append(None if d.loss is None else d.loss[idx])
        sets.append(SetCurve(Tk, d.x[idx], d.storage[idx], None if d.loss is None else d.loss[idx], float(a),
                             _label(d)))
    x = np.concatenate(xs)
    o = np.argsort(x, kind="stable")
    loss = None if ls[0] is None else np.concatenate(ls)[o]
    return x[o], np.concatenate(ss)[o], loss, shift, sets


#: a set whose temperature drift moves the shift by more than this (decades) across the set is warned about
DRIFT_BLUR_DECADES = 0.1


def drift_warnings(datas: Sequence[MaterialData], shift) -> list[str]:
    """A set whose measured temperature drifts while it is swept shares one shift factor across temperatures whose
    own shifts differ: its points are misplaced on the master curve by up to slope x span decades (the slope of
    log a_T between the neighbouring sets). Said for each set where that exceeds :data:`DRIFT_BLUR_DECADES`."""
    if shift is None or shift.T.size < 2:
        return []
    o = np.argsort(shift.T)
    Ts, aT = shift.T[o], shift.log_aT[o]
    slope = np.abs(np.diff(aT) / np.maximum(np.diff(Ts), 1e-9))
    out = []
    for d in datas:
        if d.temperature_c is None:
            continue
        for T, idx in d.sets():
            span = float(np.ptp(d.temperature_c[idx]))
            k = int(np.argmin(np.abs(Ts - T)))
            near = slope[max(k - 1, 0):k + 1]
            blur = span * float(np.max(near)) if near.size else 0.0
            if blur > DRIFT_BLUR_DECADES:
                out.append(f"{_label(d)}: the set at {T:g} C (from line {d.where(int(idx[0]))}) drifts over "
                           f"{span:.2g} C while it is swept; the shift changes by about {blur:.2g} decades over that "
                           "span there, and the set takes one shift for all its points, so its points sit up to that "
                           "far off the master curve (hold the temperature steadier, or drop the drifting part)")
    return out


#: a frequency-domain fit that misses E' or E'' by more than this RMS relative error (%) is warned about: the two
#: columns are then not the storage and loss moduli of one material as read (tan delta under an E'' header: 820 %).
#: Measured sweeps fitted with few terms miss E'' by up to about 125 % (the reference DMA sweeps with 2-6 terms:
#: 91-124 %; with the terms BIC picks, 29-52 %), so the line sits well above what the measured data we hold give
MODULUS_MISFIT_PCT = 300.0


def misfit_warnings(datas: Sequence[MaterialData], fit) -> list[str]:
    """A storage or loss modulus the Prony series misses by more than :data:`MODULUS_MISFIT_PCT` RMS: said with
    what usually causes it (a tan delta column under a loss-modulus header, the two columns in different units)."""
    errs = {"storage": getattr(fit, "rms_rel_storage_pct", None), "loss": getattr(fit, "rms_rel_loss_pct", None)}
    bad = {k: v for k, v in errs.items() if v is not None and np.isfinite(v) and v > MODULUS_MISFIT_PCT}
    if not bad:
        return []
    m = datas[0].modulus if datas else "E"
    names = {"storage": f"{m}'", "loss": f"{m}''"}
    where = ", ".join(_label(d) for d in datas)
    missed = " and ".join(f"{names[k]} by {v:.3g} %" for k, v in bad.items())
    return [f"{where}: the Prony series misses {missed} RMS ({names['storage']} {errs['storage']:.3g} %, "
            f"{names['loss']} {errs['loss']:.3g} %): the two columns are not the storage and loss moduli of one "
            f"linear viscoelastic material as read. If the loss column holds tan(delta) (= {names['loss']}/"
            f"{names['storage']}, dimensionless), write {names['loss']} = {names['storage']} tan(delta) in its place; "
            "check that both columns are in the units their headers state"]


def fit_material(datas: Sequence[MaterialData], *, terms="auto", max_error_pct: float | None = None,
                 ref_temp: float | None = None, shift_file=None, config=None) -> MaterialFit:
    """Shift (if raw) and fit (see the module docstring)."""
    from bpmid.relax import RelaxConfig
    from bpmid.relax.fit import fit_relaxation
    from bpmid.relax.freq import fit_frequency

    cfg = config or RelaxConfig()
    if not datas:
        raise InputError("no data files given")
    domain = check_domains(datas)
    x, storage, loss, shift, sets = build_master(datas, ref_temp=ref_temp, shift_file=shift_file, config=cfg)
    where = datas[0].path if len(datas) == 1 else None
    if domain == "freq":
        fit = fit_frequency(x, storage, loss, modulus=datas[0].modulus, terms=terms, max_error_pct=max_error_pct,
                            config=cfg, path=where)
    else:
        name = datas[0].name + ("_master" if shift is not None else "")
        # equal reduced times from different sets are kept (both are data); the modulus curve needs no strict order
        log = RelaxLog(name=name, time_s=x, modulus_mpa=storage, source="modulus", path=where)
        fit = fit_relaxation([log], terms=terms, mode="step", config=cfg, max_error_pct=max_error_pct)
    units = {_label(d): dict(d.units_in_file) for d in datas}
    one = None
    if len(datas) == 1 and not datas[0].is_raw and datas[0].temperature_c is not None:
        one = {"T": datas[0].sets()[0][0], "mean_measured": round(float(np.mean(datas[0].temperature_c)), 4)}
    checks = (tts.shift_warnings(shift) + tts.wlf_warnings(shift) + drift_warnings(datas, shift)) \
        if shift is not None else []
    if domain == "freq":
        checks += misfit_warnings(datas, fit)
    return MaterialFit(domain, fit, shift, sets, datas[0].modulus, [d.path for d in datas], units, one, checks)
