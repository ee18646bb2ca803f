"""Screening: rank every catalogue effect by how much of the residual its signature explains.

For the current model (base VBMM + effects added so far, fitted), the residual r (model - measured, deg,
fitting logs stacked) is regressed on

- nuisance columns: the model's own sensitivities d(angle)/d(theta) for every fitted constant, so that
  plain parameter error (a stiffness or time constant slightly off) is never credited to an effect, and
- the candidate's signature columns:
  1. the effect's own shape through its model term: angle(model + effect at its default size) - angle(model),
  2. the derivatives of that augmented angle with respect to each effect parameter at the default (so the
     signature spans sizes and time constants other than the default), and
  3. the effect's hand-made regressors :meth:`bpmid.effects.base.Effect.signature_columns` (pressure rate at a
     lag, sign of the rate, a low-pass of the strain rate, elapsed time, ...), when it defines any.

Everything comes from the Effect object, so a new catalogue entry is screened without touching this file.
The score is a penalised likelihood ratio with the effective sample size N_eff (autocorrelated residuals):
``score = N_eff ln(SSE_nuisance / SSE_with_signature) - q ln(N_eff)``, q the rank the signature adds.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Sequence

import numpy as np

from bpmid.discover.model import (ModelState, gained_residuals, nuisance_block_columns, sensitivities, simulate,
                                  stacked)
from bpmid.effects.base import Effect
from bpmid.fitting import effective_sample_size
from bpmid.io.motion_logs import MotionLog


@dataclasses.dataclass
class ScreenResult:
    """One candidate's screening outcome.

    Attributes
    ----------
    effect_id : catalogue id
    score : penalised log-likelihood gain (higher = explains more of the residual)
    explained : share of the residual (after the nuisance columns) the signature explains, 0..1
    rank_added : number of independent signature columns
    rmse_after_deg : residual RMSE after projecting out nuisance and signature
    """

    effect_id: str
    score: float
    explained: float
    rank_added: int
    rmse_after_deg: float

    def to_yaml(self) -> dict:
        return {"effect": self.effect_id, "score": round(float(self.score), 3),
                "explained_fraction": round(float(self.explained), 4), "columns": int(self.rank_added),
                "rmse_after_projection_deg": round(float(self.rmse_after_deg), 4)}


def _orthonormal(A: np.ndarray, rtol: float = 1e-8) -> np.ndarray:
    """Orthonormal basis of the column space of A (SVD, relative rank cut)."""
    if A.size == 0 or A.shape[1] == 0:
        return np.zeros((A.shape[0], 0))
    A = np.where(np.isfinite(A), A, 0.0)
    norms = np.linalg.norm(A, axis=0)
    keep = norms > 0
    if not keep.any():
        return np.zeros((A.shape[0], 0))
    A = A[:, keep] / norms[keep]
    u, s, _ = np.linalg.svd(A, full_matrices=False)
    return u[:, s > rtol * max(s[0], 1e-300)] if s.size else np.zeros((A.shape[0], 0))


def signature_matrix(state: ModelState, effect: Effect, logs: Sequence[MotionLog],
                     base_sim: Sequence[np.ndarray]) -> np.ndarray:
    """(N, q) stacked signature columns of ``effect`` on top of ``state`` (see module docstring)."""
    aug = state.with_effect(effect)
    new_names = [p.name for p in effect.default_params() if not p.fixed]
    sim_e = simulate(aug, logs)
    y0 = stacked(base_sim)
    cols = [stacked(sim_e) - y0]
    if new_names:
        cols.append(sensitivities(aug, logs, new_names, base_sim=sim_e, rel_step=0.05))
    own = []
    for lg, b in zip(logs, base_sim):
        c = np.asarray(effect.signature_columns(lg, b), float)
        own.append(c.reshape(lg.n, -1))
    if own and all(o.shape[1] == own[0].shape[1] for o in own) and own[0].shape[1] > 0:
        cols.append(np.vstack(own))
    return np.column_stack([c.reshape(y0.size, -1) for c in cols])


def screen(state: ModelState, effects: Sequence[Effect], logs: Sequence[MotionLog], *,
           base_sim: Sequence[np.ndarray] | None = None, nuisance: np.ndarray | None = None,
           per_log_gain: bool = False) -> list[ScreenResult]:
    """Rank ``effects`` (those not yet in ``state``) on the fitting ``logs``; best first.

    ``per_log_gain``: the residual is the one with each log's gain fitted (as in the base fit), and the
    per-log gain columns join the nuisance columns (log-to-log variation is never credited to an effect)."""
    base_sim = simulate(state, logs) if base_sim is None else base_sim
    r = stacked(gained_residuals(base_sim, logs, per_log_gain=per_log_gain))
    J = sensitivities(state, logs, base_sim=base_sim) if nuisance is None else nuisance
    if per_log_gain and J.shape[1] > 0:
        J = np.column_stack([J, nuisance_block_columns(per_log_gain, base_sim, logs)])
    Q0 = _orthonormal(J)
    r0 = r - Q0 @ (Q0.T @ r)
    sse0 = float(r0 @ r0)
    n_eff = effective_sample_size(r, [lg.n for lg in logs])
    out = []
    for e in effects:
        if e.id in state.ids:
            continue
        S = signature_matrix(state, e, logs, base_sim)
        S = S - Q0 @ (Q0.T @ S)
        Q = _orthonormal(S, rtol=1e-6)
        q = Q.shape[1]
        r1 = r0 - Q @ (Q.T @ r0)
        sse1 = max(float(r1 @ r1), 1e-300)
        explained = 1.0 - sse1 / sse0 if sse0 > 0 else 0.0
        score = n_eff * math.log(max(sse0, 1e-300) / sse1) - q * math.log(max(n_eff, 2.0))
        out.append(ScreenResult(e.id, score, explained, q, math.sqrt(sse1 / r.size)))
    out.sort(key=lambda s: s.score, reverse=True)
    return out
