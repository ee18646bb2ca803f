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
import math
import sys
from pathlib import Path
from typing import Sequence

import numpy as np

from bpmid.errors import InputError
from bpmid.io.results import provenance, read_result, require, write_result
from bpmid.params import parse_param_entry
from bpmid.viscoelastic import E_to_G, E_to_K, check_poisson

SCHEMA = "bpmid.relax/1"
MPA = 1e6
_MODULUS_UNITS = {"pa": 1.0, "kpa": 1e3, "mpa": 1e6, "gpa": 1e9}
_TIME_UNITS = {"s": 1.0, "ms": 1e-3, "min": 60.0}
#: shear/bulk moduli may differ from E/(2(1+nu)) and E/(3(1-2nu)) by this share (rounding of hand-edited files;
#: K moves 4.5 % for nu 0.4993 instead of 0.49933) and no more: a unit slip is a factor of 1000
CONSISTENCY_RTOL = 0.05
MODES = ("ramp", "step")


def _param(value: float, stderr: float | None, unit: str) -> dict:
    ok = stderr is not None and np.isfinite(stderr)
    return {"value": float(value), "stderr": float(stderr) if ok else None, "unit": unit}


def relax_fit_body(fit, poisson: float) -> dict:
    """The YAML body (everything but schema and provenance) of a :class:`~bpmid.relax.fit.RelaxFit`."""
    nu = check_poisson(poisson, key="poisson_ratio")
    g, k = E_to_G(1.0, nu), E_to_K(1.0, nu)

    def moduli(factor: float, name: str, inf_name: str) -> dict:
        return {inf_name: _param(fit.E_inf * MPA * factor, fit.se_E_inf * MPA * factor, "Pa"),
                "terms": [{name: _param(e * MPA * factor, se * MPA * factor, "Pa"), "tau": _param(t, st, "s")}
                          for e, se, t, st in zip(fit.E, fit.se_E, fit.tau, fit.se_tau)]}

    def clean(v):
        return None if v is None or not np.isfinite(v) else round(float(v), 4)

    return {
        "mode": fit.mode,
        "prony": moduli(1.0, "E", "E_inf"),
        "poisson_ratio": float(nu),
        "shear": moduli(g, "G", "G_inf"),
        "bulk": moduli(k, "K", "K_inf"),
        "metrics": {"rmse": fit.rmse_mpa * MPA, "r2": fit.r2, "mape_pct": fit.mape_pct, "quantity": fit.quantity,
                    "rmse_unit": "Pa", "n_terms": fit.m,
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
    if inf < 0 or any(v < 0 for v in mods):
        raise InputError("moduli must be non-negative", path=path, key=f"{block}.terms")
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
        raise InputError(f"mode must be ramp or step, found {mode!r}", path=path, key="mode")
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


def run_fit_relax(logs: Sequence[str | Path], out: str | Path, *, terms: str | int | None = None,
                  mode: str | None = None, poisson: float | None = None, config=None,
                  figure: str | Path | None | bool = True) -> tuple[Path, Path | None, object]:
    """What ``bpmid fit relax`` does: read the logs, fit, write the YAML and the figure.

    Parameters
    ----------
    logs : relaxation log files
    out : the YAML to write
    terms, mode, poisson : override the config (``relax.terms``, ``relax.mode``, ``relax.poisson``)
    config : a loaded :class:`bpmid.config.Config` or None
    figure : True for ``<out stem>.png`` beside the YAML, a path, or False/None for no figure

    Returns
    -------
    (yaml path, figure path or None, RelaxFit)
    """
    from bpmid.config import load_config
    from bpmid.io.atomic import staged_file
    from bpmid.io.relax_logs import read_relax_logs
    from bpmid.relax.fit import fit_relaxation

    config = config if config is not None else load_config(None)
    cfg = config.section("relax")
    gap = cfg.max_gap_factor if cfg.max_gap_factor is not None else config.section("io").max_gap_factor
    nu = check_poisson(cfg.poisson if poisson is None else poisson, key="--poisson" if poisson is not None
                       else "relax.poisson")
    if terms is None:
        terms = cfg.terms
    elif isinstance(terms, str) and terms.strip().lower() != "auto":
        try:
            terms = int(terms)
        except ValueError:
            raise InputError(f"--terms takes a whole number or auto, found {terms!r}", key="--terms") from None
    elif isinstance(terms, str):
        terms = "auto"
    mode = cfg.mode if mode is None else mode
    paths = [Path(p) for p in logs]
    records = read_relax_logs(paths, column_map=cfg.columns, gauge_length_mm=cfg.specimen.gauge_length_mm,
                              cross_section_mm2=cfg.specimen.cross_section_mm2, gap_factor=gap)
    fit = fit_relaxation(records, terms=terms, mode=mode, config=cfg)
    for w in fit.warnings:
        print(f"warning: {w}", file=sys.stderr, flush=True)
    out = Path(out)
    fig_path = None
    if figure:
        from bpmid.plots.options import figure_path

        fig_path = figure_path(out.with_suffix(".png") if figure is True else Path(figure))
    prov = provenance(paths, config=config)
    synthetic = any((str(r.meta.get("synthetic", "")).lower().replace("(", " ").split() or [""])[0] in ("true", "yes", "1")
                    for r in records)
    if fig_path is not None:
        from bpmid.plots.common import save_figure
        from bpmid.plots.relax import relax_figure

        # both are staged: on any failure neither file appears
        with staged_file(out) as tmp_yaml, staged_file(fig_path) as tmp_fig:
            write_relax_fit(tmp_yaml, fit, nu, prov)
            save_figure(relax_figure(fit, synthetic=synthetic), tmp_fig)
    else:
        write_relax_fit(out, fit, nu, prov)
    return out, fig_path, fit
