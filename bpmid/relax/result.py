"""The ``bpmid.relax/1`` result file: write it, read it back, and the whole ``fit relax`` command.

Units in the file are SI (Pa, s). Keys fixed by CLI.md: ``schema``, ``prony.E_inf``, ``prony.terms``
(``{E, tau}``), ``poisson_ratio``, ``shear.G_inf``, ``shear.terms`` (``{G, tau}``), ``bulk.K_inf``,
``bulk.terms`` (``{K, tau}``), ``metrics.rmse`` (Pa), ``metrics.r2``, ``metrics.mape_pct``, ``mode``,
``provenance``. Extra keys: ``terms_selection``, ``uncertainty``, ``data``, ``warnings`` (time constants
outside the data's time span; also printed on stderr by :func:`run_fit_relax`).

Reading back (:func:`load_relax_fit`) refuses, naming the key: a ``mode`` other than ramp or step, a
``poisson_ratio`` outside (-1, 0.5), unknown units, and ``shear``/``bulk`` blocks that contradict ``prony`` and
``poisson_ratio`` by more than :data:`CONSISTENCY_RTOL` (a modulus in the wrong unit, or G and K swapped). Moduli
may be given in Pa, kPa, MPa or GPa and time constants in s, ms or min; they are converted to Pa and s.
"""
from __future__ import annotations

import dataclasses
import functools
import math
import sys
from pathlib import Path
from typing import Sequence

import numpy as np

from bpmid.errors import InputError
from bpmid.io.results import provenance, read_result, require, write_result
from bpmid.params import parse_param_entry
from bpmid.units import MODULUS_UNITS, PA_PER_MPA, TIME_UNITS
from bpmid.viscoelastic import E_to_G, E_to_K, check_poisson

SCHEMA = "bpmid.relax/1"
MPA = PA_PER_MPA
_MODULUS_UNITS = MODULUS_UNITS
_TIME_UNITS = TIME_UNITS
#: shear/bulk moduli may differ from E/(2(1+nu)) and E/(3(1-2nu)) by this share (rounding of hand-edited files;
#: K moves 4.5 % for nu 0.4993 instead of 0.49933) and no more: a unit slip is a factor of 1000
CONSISTENCY_RTOL = 0.05
MODES = ("ramp", "step", "frequency")


def _param(value: float, stderr: float | None, unit: str) -> dict:
    ok = stderr is not None and np.isfinite(stderr)
    return {"value": float(value), "stderr": float(stderr) if ok else None, "unit": unit}



def _moduli_block(fit, factor: float, name: str, inf_name: str) -> dict:
    """``{E_inf, terms: [{E, tau}]}`` of a Prony fit (MPa inside) in Pa, scaled by ``factor`` (1 for E; the
    G/E or K/E ratio for the shear and bulk blocks), with standard errors."""
    return {inf_name: _param(fit.E_inf * MPA * factor, fit.se_E_inf * MPA * factor, "Pa"),
            "terms": [{name: _param(e * MPA * factor, se * MPA * factor, "Pa"), "tau": _param(t, st, "s")}
                      for e, se, t, st in zip(fit.E, fit.se_E, fit.tau, fit.se_tau)]}


def _clean(v):
    return None if v is None or not np.isfinite(v) else round(float(v), 4)

def relax_fit_body(fit, poisson: float) -> dict:
    """The YAML body (everything but schema and provenance) of a :class:`~bpmid.relax.fit.RelaxFit`."""
    nu = check_poisson(poisson, key="poisson_ratio")
    g, k = E_to_G(1.0, nu), E_to_K(1.0, nu)

    moduli = functools.partial(_moduli_block, fit)
    clean = _clean

    return {
        "mode": fit.mode,
        "prony": moduli(1.0, "E", "E_inf"),
        "poisson_ratio": float(nu),
        "shear": moduli(g, "G", "G_inf"),
        "bulk": moduli(k, "K", "K_inf"),
        "metrics": {"rmse": fit.rmse_mpa * MPA, "r2": fit.r2, "mape_pct": fit.mape_pct, "quantity": fit.quantity,
                    "rmse_unit": "Pa", "n_terms": fit.m, "criterion_residuals": getattr(fit, "weighting", "absolute"),
                    "per_log_rmse": {lg.name: lg.rmse_mpa * MPA for lg in fit.logs}},
        "terms_selection": {
            "requested": fit.requested_terms, "chosen": fit.m, "criterion": fit.criterion,
            "method": "variable projection: moduli by NNLS, log time constants by nonlinear least squares; start "
                      "from NNLS on a dense log-spaced grid, merged, then terms dropped or added one at a time",
            "candidates": [{"terms": s["terms"], "rmse": s["rmse_mpa"] * MPA,
                            "criterion": None if s["criterion"] is None else float(s["criterion"])}
                           for s in fit.selection]},
        "uncertainty": {"method": fit.uncertainty_method, "n_obs": fit.n_obs, "n_eff": round(fit.n_eff, 3),
                        "parameters": list(fit.param_names),
                        "correlation": [[clean(v) for v in row] for row in fit.corr]},
        "warnings": list(getattr(fit, "warnings", [])),
        "data": {"logs": [{"name": lg.name, "source": lg.source, "samples": int(lg.t.size),
                           "strain_level": None if math.isnan(lg.hold.strain_level) else float(lg.hold.strain_level),
                           "ramp_s": float(lg.hold.ramp_s)} for lg in fit.logs],
                 "fit_seconds": round(fit.seconds, 4)},
    }


def _g_to_e(fit, nu: float):
    """A fit of shear moduli G, restated as tensile moduli E = 2 (1 + nu) G (the file's ``prony`` block is E)."""
    k = 2.0 * (1.0 + nu)
    return dataclasses.replace(fit, E_inf=fit.E_inf * k, E=fit.E * k, se_E_inf=fit.se_E_inf * k, se_E=fit.se_E * k)


def material_fit_body(mf, poisson: float) -> dict:
    """The YAML body of a :class:`bpmid.relax.material.MaterialFit` (frequency-domain data or shifted raw sets)."""
    from bpmid.relax.tts import shift_body

    nu = check_poisson(poisson, key="poisson_ratio")
    fit = _g_to_e(mf.fit, nu) if mf.modulus == "G" else mf.fit
    sources = [str(p) for p in mf.sources if p is not None]
    if mf.domain == "time":
        body = relax_fit_body(fit, nu)
        body["fitted_modulus"] = mf.modulus
        body["data"]["sources"] = sources
        body["data"]["domain"] = "time"
    else:
        g, k = E_to_G(1.0, nu), E_to_K(1.0, nu)

        moduli = functools.partial(_moduli_block, fit)
        clean = _clean

        y = np.concatenate([fit.storage, fit.loss])
        yf = np.concatenate([fit.storage_fit, fit.loss_fit])
        from bpmid import metrics

        body = {
            "mode": "frequency",
            "fitted_modulus": mf.modulus,
            "prony": moduli(1.0, "E", "E_inf"),
            "poisson_ratio": float(nu),
            "shear": moduli(g, "G", "G_inf"),
            "bulk": moduli(k, "K", "K_inf"),
            "metrics": {"rmse": metrics.rmse(y, yf) * MPA, "rmse_unit": "Pa", "r2": metrics.r2(y, yf),
                        "mape_pct": float(100 * np.mean(np.abs((yf - y) / y))),
                        "quantity": f"storage and loss modulus {mf.modulus}', {mf.modulus}''",
                        "rms_rel_storage_pct": fit.rms_rel_storage_pct, "rms_rel_loss_pct": fit.rms_rel_loss_pct,
                        "error_pct": fit.error_pct, "weighting": fit.weighting, "n_terms": fit.m,
                        "E0": fit.E0 * MPA, "E0_unit": "Pa"},
            "terms_selection": {
                "requested": fit.requested_terms, "chosen": fit.m, "criterion": fit.criterion,
                "max_error_pct": fit.max_error_pct,
                "error_measure": ("RMS over frequencies of |E*_fit - E*| / |E*| (%)" if fit.weighting == "complex"
                                  else "RMS over frequencies of the relative E' and E'' residuals (%)"),
                "method": "variable projection on E' and E'' jointly: moduli by NNLS (>= 0), log time constants by "
                          "nonlinear least squares; start from NNLS on a dense log-spaced grid, merged, then terms "
                          "dropped or added one at a time",
                "candidates": [{k2: (None if v is None else (int(v) if k2 == "terms" else float(v)))
                                for k2, v in c.items()} for c in fit.selection]},
            "uncertainty": {"method": fit.uncertainty_method, "n_obs": fit.n_obs, "n_eff": round(fit.n_eff, 3),
                            "parameters": list(fit.param_names),
                            "correlation": [[clean(v) for v in row] for row in fit.corr]},
            "warnings": list(fit.warnings),
            "data": {"domain": "frequency", "sources": sources, "frequencies": int(fit.f.size),
                     "f_min_hz": float(fit.f.min()), "f_max_hz": float(fit.f.max()),
                     "fit_seconds": round(fit.seconds, 4)},
        }
        if mf.modulus == "G":
            body["metrics"]["note"] = ("fitted to shear moduli G (the metrics are of G' and G''); prony holds "
                                       "E = 2 (1 + nu) G")
    if mf.units_in_file:  # the units as the files state them ('' = none stated, the default applies)
        body["data"]["units_in_file"] = {name: {role: (u or "(none stated)") for role, u in units.items()}
                                         for name, units in mf.units_in_file.items()}
    if getattr(mf, "set_temperature", None):  # one set at one temperature: the curve is at that temperature
        body["data"]["set_temperature_c"] = float(mf.set_temperature["T"])
        body["data"]["mean_measured_temperature_c"] = float(mf.set_temperature["mean_measured"])
    if mf.shift is not None:
        body["shift"] = shift_body(mf.shift)
        body["data"]["sets"] = len(mf.sets)
    return body


def write_relax_fit(path, fit, poisson: float, prov: dict) -> Path:
    """Write the ``bpmid.relax/1`` YAML atomically."""
    return write_result(path, SCHEMA, relax_fit_body(fit, poisson), prov)


@dataclasses.dataclass(frozen=True)
class RelaxParameters:
    """Relaxation constants read from a ``bpmid.relax/1`` file (SI units).

    Attributes
    ----------
    E_inf : Pa; E : (m,) Pa; tau : (m,) s
    poisson_ratio : dimensionless
    G_inf, K_inf : Pa; G, K : (m,) Pa (as written in the file, else converted from E)
    mode : ``"ramp"``, ``"step"`` or None when the file does not say
    path : the file
    """

    E_inf: float
    E: np.ndarray
    tau: np.ndarray
    poisson_ratio: float
    G_inf: float
    G: np.ndarray
    K_inf: float
    K: np.ndarray
    mode: str | None = None
    path: Path | None = None

    @property
    def terms(self) -> list[tuple[float, float]]:
        """[(E_j, tau_j), ...] in Pa and s."""
        return list(zip(self.E.tolist(), self.tau.tolist()))


def _si(entry, key: str, path, units: dict, default_unit: str) -> float:
    value, _se, unit = parse_param_entry(entry, path=path, key=key)
    u = (unit or default_unit).strip().lower()
    if u not in units:
        raise InputError(f"unknown unit {unit!r} (expected one of {', '.join(units)})", path=path, key=f"{key}.unit")
    return value * units[u]


def _branch_list(data: dict, block: str, name: str, path) -> tuple[float, np.ndarray, np.ndarray]:
    inf = _si(require(data, f"{block}.{name}_inf", path), f"{block}.{name}_inf", path, _MODULUS_UNITS, "Pa")
    terms = require(data, f"{block}.terms", path)
    if not isinstance(terms, list):
        raise InputError("expected a list of terms", path=path, key=f"{block}.terms")
    mods, taus = [], []
    for j, term in enumerate(terms):
        where = f"{block}.terms[{j}]"
        if not isinstance(term, dict) or name not in term or "tau" not in term:
            raise InputError(f"expected a mapping with keys {name} and tau", path=path, key=where)
        mods.append(_si(term[name], f"{where}.{name}", path, _MODULUS_UNITS, "Pa"))
        taus.append(_si(term["tau"], f"{where}.tau", path, _TIME_UNITS, "s"))
        if taus[-1] <= 0:
            raise InputError(f"time constant must be positive, found {taus[-1]:g} s", path=path, key=f"{where}.tau")
    if inf < 0:   # the key at fault, with its value (it named the terms)
        raise InputError(f"moduli must be non-negative, found {inf:g} Pa: refit (bpmid fit relax) or restore the "
                         "file's value", path=path, key=f"{block}.{name}_inf")
    bad = next((j for j, v in enumerate(mods) if v < 0), None)
    if bad is not None:
        raise InputError(f"moduli must be non-negative, found {mods[bad]:g} Pa: refit (bpmid fit relax) or restore "
                         "the file's value", path=path, key=f"{block}.terms[{bad}].{name}")
    return inf, np.array(mods, float), np.array(taus, float)


def load_relax_fit(path: str | Path) -> RelaxParameters:
    """Read a ``bpmid.relax/1`` file (one holding only the CLI.md keys is enough).

    ``shear`` and ``bulk`` are taken as written when present (their time constants must match the
    Prony terms'); when absent they are computed from E with ``poisson_ratio``.
    """
    path = Path(path)
    return relax_fit_from_mapping(read_result(path, "bpmid.relax/"), path)


def relax_fit_from_mapping(data: dict, path: Path | None = None) -> RelaxParameters:
    """:func:`load_relax_fit` for an already-loaded ``bpmid.relax/1`` mapping (``path`` names it in messages)."""
    E_inf, E, tau = _branch_list(data, "prony", "E", path)
    nu_raw = require(data, "poisson_ratio", path)
    if isinstance(nu_raw, bool) or not isinstance(nu_raw, (int, float)):
        raise InputError(f"expected a number, found {nu_raw!r}", path=path, key="poisson_ratio")
    nu = check_poisson(nu_raw, key="poisson_ratio", path=path)
    mode = data.get("mode")
    if mode is not None and mode not in MODES:
        raise InputError(f"mode must be ramp or step (or frequency, for frequency-domain fits), found {mode!r}",
                         path=path, key="mode")
    out = {}
    for block, name, conv in (("shear", "G", E_to_G), ("bulk", "K", E_to_K)):
        if block in data:
            inf, mods, taus = _branch_list(data, block, name, path)
            if taus.size != tau.size or not np.allclose(taus, tau, rtol=1e-6):
                raise InputError(f"{block}.terms time constants differ from prony.terms", path=path,
                                 key=f"{block}.terms")
            _check_consistent(f"{block}.{name}_inf", inf, conv(E_inf, nu), path, name, nu, "prony.E_inf")
            for j, (got, want) in enumerate(zip(mods, conv(E, nu))):
                _check_consistent(f"{block}.terms[{j}].{name}", got, want, path, name, nu, f"prony.terms[{j}].E")
        else:
            inf, mods = conv(E_inf, nu), conv(E, nu)
        out[name] = (float(inf), np.asarray(mods, float))
    return RelaxParameters(E_inf, E, tau, nu, out["G"][0], out["G"][1], out["K"][0], out["K"][1], mode, path)


def _check_consistent(key: str, got: float, want: float, path, name: str, nu: float, e_key: str) -> None:
    """A shear or bulk modulus (Pa) must agree with the one prony and poisson_ratio give."""
    if not np.isclose(got, want, rtol=CONSISTENCY_RTOL, atol=1e-9 * max(abs(want), 1.0)):
        rel = "E/(2(1+nu))" if name == "G" else "E/(3(1-2nu))"
        ratio = got / want if want else math.inf
        raise InputError(f"{key} = {got:g} Pa disagrees with {rel} = {want:g} Pa from {e_key} and poisson_ratio = "
                         f"{nu:g} (ratio {ratio:.4g}): one of them is in the wrong unit or for another Poisson's "
                         "ratio", path=path, key=key)


def _opt(name: str, flags: bool) -> str:
    """How an argument is named in an error message: ``--ref-temp`` for the command line, ``ref_temp`` else."""
    return "--" + name.replace("_", "-") if flags else name


def check_mode(mode: str | None, *, flags: bool = False) -> None:
    """Refuse a ``mode`` other than None, ramp or step."""
    if mode is not None and mode not in ("ramp", "step"):
        raise InputError(f"{_opt('mode', flags)} takes ramp or step, found {mode!r}", key=_opt("mode", flags))


def _terms_option(terms, cfg, flags: bool = True):
    if terms is None:
        return cfg.terms
    if isinstance(terms, str) and terms.strip().lower() != "auto":
        try:
            return int(terms)
        except ValueError:
            raise InputError(f"{_opt('terms', flags)} takes a whole number or auto, found {terms!r}",
                             key=_opt("terms", flags)) from None
    if isinstance(terms, str):
        return "auto"
    return terms


@dataclasses.dataclass
class RelaxRun:
    """One ``fit relax`` computation: the live fit, the file's body and provenance.

    Attributes
    ----------
    fit : :class:`bpmid.relax.fit.RelaxFit`, or :class:`bpmid.relax.material.MaterialFit` for frequency sweeps
        and raw sets at several temperatures
    body : the ``bpmid.relax/1`` keys (without schema and provenance)
    provenance : the provenance block
    synthetic : whether the logs say they are synthetic (the figure says so)
    """

    fit: object
    body: dict
    provenance: dict
    synthetic: bool = False


def _fit_material(paths, material, config, *, terms, mode, poisson, max_error_pct, ref_temp, shift,
                  flags) -> RelaxRun:
    """``fit relax`` on frequency sweeps or raw sets at several temperatures (see :mod:`bpmid.relax.material`)."""
    from bpmid.io.material_files import read_material_file
    from bpmid.io.relax_logs import read_relax_logs
    from bpmid.relax.material import check_domains, fit_material

    cfg = config.section("relax")
    nu = check_poisson(cfg.poisson if poisson is None else poisson, key=_opt("poisson", flags) if poisson is not None
                       else "relax.poisson")
    # the column map of the io section (--columns) and of the relax section (the relax map wins per header)
    cmap = {**config.section("io").columns, **cfg.columns}
    datas = [read_material_file(p, column_map=cmap, sheet=config.section("io").sheet) for p in material]
    others = [p for p in paths if p not in material]
    if others:
        gap = cfg.max_gap_factor if cfg.max_gap_factor is not None else config.section("io").max_gap_factor
        logs = read_relax_logs(others, column_map=cfg.columns, gauge_length_mm=cfg.specimen.gauge_length_mm,
                               cross_section_mm2=cfg.specimen.cross_section_mm2, gap_factor=gap)
        check_domains(datas, logs)
    domain = check_domains(datas)
    if mode not in (None, "step") or (mode == "step" and domain == "freq"):
        what = ("frequency-domain data" if domain == "freq" else
                "relaxation curves at several temperatures (they are fitted as modulus curves, step mode)")
        raise InputError(f"{_opt('mode', flags)} {mode} does not apply to {what}", key=_opt("mode", flags))
    if max_error_pct is None:
        max_error_pct = cfg.max_error_pct
    try:
        mf = fit_material(datas, terms=_terms_option(terms, cfg, flags), max_error_pct=max_error_pct,
                          ref_temp=ref_temp, shift_file=shift, config=cfg)
    except InputError as exc:   # what reading warned about (kelvin under a degrees C header...) may be the cause
        read = [w for d in datas for w in d.warnings]
        if not read:
            raise
        raise type(exc)(f"{exc.message} (reading the data warned: {'; '.join(read)})", path=exc.path,
                        line=exc.line, key=exc.key) from None
    from bpmid.io import plausibility as plaus
    from bpmid.relax import PAPER_POISSON

    # implausible values under a stated unit, shift factors the data do not determine: --strict refuses them
    checks = ([w for d in datas for w in d.warnings] + list(getattr(mf, "checks", []))
              + plaus.poisson_warnings(mf.fit, nu, stated=poisson is not None or cfg.poisson != PAPER_POISSON))
    if checks and config.section("io").strict:
        plaus.emit(checks, strict=True, what="the relaxation fit", key=plaus.strict_key(config.section("io")))
    mf.fit.warnings = list(mf.fit.warnings) + [w for w in checks if w not in mf.fit.warnings]
    inputs = paths + ([Path(shift)] if shift is not None else [])
    prov = provenance(inputs, config=config)
    prov["warnings"] = list(checks)
    return RelaxRun(mf, material_fit_body(mf, nu), prov)


def fit_relax_files(logs: Sequence[str | Path], *, terms: str | int | None = None, mode: str | None = None,
                    poisson: float | None = None, config=None, max_error_pct: float | None = None,
                    ref_temp: float | None = None, shift: str | Path | None = None, flags: bool = False) -> RelaxRun:
    """Read relaxation logs (or frequency sweeps, or raw sets at several temperatures) and fit them: the one
    path behind :func:`bpmid.fit_relaxation`, ``bpmid fit relax`` and ``bpmid run``'s relax stage.

    Parameters
    ----------
    logs : relaxation log files
    terms, mode, poisson : override the config (``relax.terms``, ``relax.mode``, ``relax.poisson``)
    config : a loaded :class:`bpmid.config.Config` or None
    max_error_pct : the fewest terms meeting this error (%) instead of ``terms`` (default ``relax.max_error_pct``)
    ref_temp : reference temperature (C) of the master curve built from raw sets at several temperatures
    shift : a CSV of shift factors (T, log_aT) to use instead of finding them from the data
    flags : name the arguments as the command line's options in error messages (``--terms``)

    Frequency-domain files (f with storage and loss modulus, CSV or an Eplexor .xls export) and relaxation curves at
    several temperatures go through :mod:`bpmid.relax.material`; ``fit`` is then a
    :class:`bpmid.relax.material.MaterialFit`. Warnings (``fit.warnings``) are not printed here.
    """
    from bpmid.config import load_config
    from bpmid.io.material_files import is_material_file
    from bpmid.io.relax_logs import read_relax_logs
    from bpmid.relax.fit import fit_relaxation

    check_mode(mode, flags=flags)
    config = config if config is not None else load_config(None)
    paths = [Path(p) for p in logs]
    cmap = {**config.section("io").columns, **config.section("relax").columns}
    material = [p for p in paths if is_material_file(p, cmap, config.section("io").sheet)]
    if material:
        return _fit_material(paths, material, config, terms=terms, mode=mode, poisson=poisson,
                             max_error_pct=max_error_pct, ref_temp=ref_temp, shift=shift, flags=flags)
    if ref_temp is not None or shift is not None:
        raise InputError(f"{_opt('ref_temp', flags)} and {_opt('shift', flags)} apply to raw sets at several "
                         "temperatures (a file with columns T and Set) or to frequency sweeps",
                         key=_opt("ref_temp", flags) if ref_temp is not None else _opt("shift", flags))
    cfg = config.section("relax")
    gap = cfg.max_gap_factor if cfg.max_gap_factor is not None else config.section("io").max_gap_factor
    nu = check_poisson(cfg.poisson if poisson is None else poisson, key=_opt("poisson", flags) if poisson is not None
                       else "relax.poisson")
    terms = _terms_option(terms, cfg, flags)
    mode = cfg.mode if mode is None else mode
    if max_error_pct is None:
        max_error_pct = cfg.max_error_pct
    records = read_relax_logs(paths, column_map=cfg.columns, gauge_length_mm=cfg.specimen.gauge_length_mm,
                              cross_section_mm2=cfg.specimen.cross_section_mm2, gap_factor=gap,
                              io_cfg=config.section("io"))
    fit = fit_relaxation(records, terms=terms, mode=mode, config=cfg, max_error_pct=max_error_pct)
    from bpmid.fitting import check_explained  # R^2 <= 0 or NaN: no constants are written
    from bpmid.io import plausibility as plaus
    from bpmid.relax import PAPER_POISSON

    check_explained(np.concatenate([lf.y for lf in fit.logs]), np.concatenate([lf.y_fit for lf in fit.logs]),
                    quantity=fit.quantity, unit="MPa", paths=paths,
                    hint="a relaxation log needs a stress (or modulus) that follows a strain step and relaxes; "
                         "check the stress column and its unit")
    checks = (plaus.reader_warnings(records) + plaus.relax_warnings(records, fit)
              + plaus.poisson_warnings(fit, nu, stated=poisson is not None or cfg.poisson != PAPER_POISSON))
    if checks and config.section("io").strict:  # --strict: refuse before anything is written
        plaus.emit(checks, strict=True, what="the relaxation fit", key=plaus.strict_key(config.section("io")))
    fit.warnings = list(fit.warnings) + checks
    prov = plaus.attach(provenance(paths, config=config), records, checks)
    synthetic = any((str(r.meta.get("synthetic", "")).lower().replace("(", " ").split() or [""])[0] in ("true", "yes", "1")
                    for r in records)
    return RelaxRun(fit, relax_fit_body(fit, nu), prov, synthetic)


def run_fit_relax(logs: Sequence[str | Path], out: str | Path, *, terms: str | int | None = None,
                  mode: str | None = None, poisson: float | None = None, config=None,
                  figure: str | Path | None | bool = True, max_error_pct: float | None = None,
                  ref_temp: float | None = None, shift: str | Path | None = None
                  ) -> tuple[Path, Path | None, object]:
    """What ``bpmid fit relax`` does: :func:`bpmid.fit_relaxation` (read, fit), warnings on stderr, then
    ``result.save`` (the YAML and the figure, both or neither). Kept for ``bpmid run``'s relax stage.

    Parameters
    ----------
    out : the YAML to write
    figure : True for ``<out stem>.png`` beside the YAML, a path, or False/None for no figure
    (the others as :func:`fit_relax_files`)

    Returns
    -------
    (yaml path, figure path or None, RelaxFit or MaterialFit)
    """
    from bpmid.api import fit_relaxation

    result = fit_relaxation(logs, terms=terms, mode=mode, poisson=poisson, config=config,
                            max_error_pct=max_error_pct, ref_temp=ref_temp, shift=shift, _flags=True)
    return save_relax_result(result, out, figure)


def save_relax_result(result, out: str | Path, figure: str | Path | None | bool = True
                      ) -> tuple[Path, Path | None, object]:
    """Print a fit's warnings on stderr and save it (``result.save``); returns (yaml, figure or None, fit)."""
    for w in result.raw.warnings:
        print(f"warning: {w}", file=sys.stderr, flush=True)
    out = Path(out)
    fig_path = None
    if figure:
        from bpmid.plots.options import figure_path

        fig_path = figure_path(out.with_suffix(".png") if figure is True else Path(figure))
    result.save(out, figure=fig_path)
    return out, fig_path, result.raw
