"""The model the discovery loop grows: the VBMM's fitted constants plus the effects added so far.

A :class:`ModelState` holds the base :class:`~bpmid.models.vbmm.VBMM`, the effects in the order they were
added and one :class:`~bpmid.params.ParamSet` with every free constant: the base material constants
(``vbmm.K_inf``, ``vbmm.K_<j>``, ``vbmm.tau_<j>``; moduli in Pa, time constants in s) and each effect's
``<id>.<name>`` parameters. Everything here is shared by screening and confirmation: simulation on a
set of logs, the least-squares fit, and finite-difference sensitivities.

Units: angles in degrees, pressure gauge Pa, time s.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Sequence

import numpy as np

from bpmid.effects.base import AugmentedVBMM, Effect
from bpmid.errors import InputError
from bpmid.fitting import FitResult, fit_least_squares
from bpmid.io.motion_logs import MotionLog
from bpmid.models.vbmm import DISCOVERY_BOUNDS, VBMM, Material, material_params
from bpmid.params import Param, ParamSet

#: residual (deg) used where the model cannot be evaluated (pressure beyond its range)
FAIL_RESIDUAL_DEG = 1e3


def base_params(model: VBMM) -> ParamSet:
    """The base constants the discovery fits: K_inf and every branch's K and tau (G is held: it barely moves
    the angle next to K, VBMM.md)."""
    return material_params(model.material, prefix="vbmm.", bounds=DISCOVERY_BOUNDS)  # the VBMM's one naming


@dataclasses.dataclass(frozen=True)
class ModelState:
    """Base VBMM + effects + all their constants.

    Attributes
    ----------
    base : the VBMM whose material the ``vbmm.*`` parameters overwrite
    effects : effects in the order added
    params : ``vbmm.*`` and ``<id>.*`` parameters
    """

    base: VBMM
    effects: tuple[Effect, ...] = ()
    params: ParamSet = dataclasses.field(default_factory=lambda: ParamSet([]))

    @classmethod
    def start(cls, base: VBMM) -> "ModelState":
        return cls(base, (), base_params(base))

    @property
    def ids(self) -> list[str]:
        return [e.id for e in self.effects]

    def material(self, params: ParamSet | None = None) -> Material:
        p = self.params if params is None else params
        m = self.base.material
        nb = m.n_branches
        K = tuple(p.value(f"vbmm.K_{j}") for j in range(1, nb + 1))
        tau = tuple(p.value(f"vbmm.tau_{j}") for j in range(1, nb + 1))
        return Material(m.G_inf, p.value("vbmm.K_inf"), m.G, K, tau if m.tauK is None else m.tauG,
                        None if m.tauK is None else tau)

    def augmented(self, params: ParamSet | None = None) -> AugmentedVBMM:
        p = self.params if params is None else params
        return AugmentedVBMM(self.base.replace(material=self.material(p)), tuple(self.effects), p)

    def with_effect(self, effect: Effect, effect_params: ParamSet | None = None) -> "ModelState":
        extra = effect.default_params() if effect_params is None else effect_params
        return ModelState(self.base, self.effects + (effect,), self.params.added(extra))

    def fitted_vbmm(self) -> VBMM:
        return self.base.replace(material=self.material())


#: model evaluations (one = one simulation of one set of logs) since import: the cost counter of the scaling bench
EVALUATIONS = {"count": 0}


def simulate(state: ModelState, logs: Sequence[MotionLog], params: ParamSet | None = None) -> list[np.ndarray]:
    """Predicted angle (deg) per log; NaN where the model refuses the pressure (beyond its range)."""
    EVALUATIONS["count"] += 1
    aug = state.augmented(params)
    out = []
    for lg in logs:
        try:
            out.append(np.asarray(aug.simulate_log(lg), float))
        except (InputError, RuntimeError, FloatingPointError, ValueError):
            out.append(np.full(lg.n, np.nan))
    return out


def residuals(state: ModelState, logs: Sequence[MotionLog], params: ParamSet | None = None) -> list[np.ndarray]:
    """Model minus measurement (deg) per log."""
    return [s - lg.angle_deg for s, lg in zip(simulate(state, logs, params), logs)]


def stacked(parts: Sequence[np.ndarray]) -> np.ndarray:
    r = np.concatenate([np.asarray(p, float) for p in parts]) if parts else np.zeros(0)
    return np.where(np.isfinite(r), r, FAIL_RESIDUAL_DEG)


def rmse_deg(parts: Sequence[np.ndarray]) -> float:
    r = stacked(parts)
    return float(np.sqrt(np.mean(r**2))) if r.size else float("nan")


#: a per-log gain is confined to this range (a few per cent of log-to-log variation, never a different muscle)
GAIN_RANGE = (0.7, 1.4)


def log_gains(sims: Sequence[np.ndarray], logs: Sequence[MotionLog], *, normalise: bool) -> np.ndarray:
    """Per-log least-squares gains g_i = <sim_i, y_i> / <sim_i, sim_i> of the predicted angle on each log's
    measured angle (a stiffness-like nuisance factor: log-to-log variation of the constants), clipped to
    :data:`GAIN_RANGE`; ``normalise`` divides them by their geometric mean (fitting: the common stiffness stays
    with the model's constants)."""
    g = []
    for s, lg in zip(sims, logs):
        s = np.asarray(s, float)
        ok = np.isfinite(s)
        den = float(s[ok] @ s[ok])
        g.append(float(s[ok] @ lg.angle_deg[ok]) / den if den > 0 else 1.0)
    g = np.clip(np.nan_to_num(np.array(g, float), nan=1.0), *GAIN_RANGE)
    if normalise and g.size:
        g = g / math.exp(float(np.mean(np.log(g))))
    return g


def gained_residuals(sims: Sequence[np.ndarray], logs: Sequence[MotionLog], *, per_log_gain: bool,
                     normalise: bool = True) -> list[np.ndarray]:
    """Model minus measurement (deg) per log, each log's prediction times its gain when ``per_log_gain``."""
    if not per_log_gain:
        return [s - lg.angle_deg for s, lg in zip(sims, logs)]
    g = log_gains(sims, logs, normalise=normalise)
    return [gi * s - lg.angle_deg for gi, s, lg in zip(g, sims, logs)]


def scored_rmse(state: ModelState, logs: Sequence[MotionLog], *, per_log_gain: bool) -> float:
    """Held-out RMSE (deg); with ``per_log_gain`` every log's own gain is fitted on it (for every model
    alike), so a log whose constants differ by a few per cent is not scored as a missing effect."""
    return rmse_deg(gained_residuals(simulate(state, logs), logs, per_log_gain=per_log_gain, normalise=False))


def fit_state(state: ModelState, logs: Sequence[MotionLog], *, max_nfev: int | None = None,
              check_identifiability: bool = True, per_log_gain: bool = False) -> tuple[ModelState, FitResult]:
    """Least-squares fit of every free constant of ``state`` on ``logs`` (angle error, deg); with
    ``per_log_gain`` each log's prediction is scaled by its own gain (closed form, geometric mean 1)."""
    segments = [lg.n for lg in logs]

    def fn(p: ParamSet) -> np.ndarray:
        return stacked(gained_residuals(simulate(state, logs, p), logs, per_log_gain=per_log_gain))

    res = fit_least_squares(fn, state.params, segments=segments, check_identifiability=check_identifiability,
                            max_nfev=max_nfev, xtol=1e-8, ftol=1e-8)
    return dataclasses.replace(state, params=res.params), res


def sensitivities(state: ModelState, logs: Sequence[MotionLog], names: Sequence[str] | None = None,
                  base_sim: Sequence[np.ndarray] | None = None, rel_step: float = 1e-3) -> np.ndarray:
    """(N, k) forward-difference derivatives of the stacked predicted angle (deg) with respect to the
    parameters ``names`` (default: every free one), per unit of the optimiser variable (log for log-scaled)."""
    names = state.params.free_names() if names is None else list(names)
    y0 = stacked(simulate(state, logs) if base_sim is None else base_sim)
    cols = []
    for n in names:
        p = state.params[n]
        if p.log_scale:
            h = rel_step
            v = p.value * math.exp(h)
        else:
            h = rel_step * max(abs(p.value), abs(p.upper - p.lower) * 1e-2 if np.isfinite(p.upper - p.lower) else 1.0,
                               1e-6)
            v = p.value + h if p.value + h <= p.upper else p.value - h
            h = v - p.value
        y1 = stacked(simulate(state, logs, state.params.replace(n, value=v)))
        cols.append((y1 - y0) / h)
    return np.column_stack(cols) if cols else np.zeros((y0.size, 0))
