"""Confirmation: refit the augmented model and judge it on data it has not seen.

For a candidate effect on top of the current model:

1. refit every constant (base VBMM + effects so far + the candidate's parameters, started at the candidate's
   default size) on the fitting logs;
2. new parameters must be identifiable: finite standard error, relative error below the limit, not on a bound,
   not collinear with the other constants (:func:`bpmid.fitting.fit_least_squares` holds the ones that fail at
   their starting value and refits; a candidate with none of its own parameters left estimated is rejected);
3. fitting-data statistics with the effective sample size N_eff (residuals are autocorrelated):
   LR = N_eff ln(SSE0/SSE1) with the boundary-corrected p-value 0.5 P(chi2_dp > LR) (the effect's absence is
   a bound of its parameters), F = ((SSE0-SSE1)/dp) / (SSE1/(N_eff-p1)), delta BIC = N_eff ln(SSE1/SSE0) + dp ln N_eff;
4. held-out logs: RMSE before and after; the gain is measured in units of the estimated noise floor.

Which values pass is decided by :mod:`bpmid.discover.workflow` with the calibrated thresholds.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Sequence

import numpy as np
from scipy.stats import chi2

from bpmid.discover.model import ModelState, fit_state, residuals, rmse_deg
from bpmid import identifiability
from bpmid.effects.base import Effect
from bpmid.fitting import FitResult, effective_sample_size
from bpmid.io.motion_logs import MotionLog


@dataclasses.dataclass
class Confirmation:
    """Evidence for one candidate effect (all angles in deg)."""

    effect_id: str
    state: ModelState
    fit: FitResult
    fit_rmse_before: float
    fit_rmse_after: float
    heldout_rmse_before: float
    heldout_rmse_after: float
    heldout_gain_sigma: float
    lr: float
    lr_p: float
    f_stat: float
    delta_bic: float
    n_obs: int
    n_eff: float
    dp: int
    identifiable: bool
    not_identifiable: dict
    effect_params: dict
    converged: bool
    accepted: bool = False
    reasons: list = dataclasses.field(default_factory=list)

    def to_yaml(self) -> dict:
        return {
            "effect": self.effect_id,
            "accepted": bool(self.accepted),
            "reasons_rejected": list(self.reasons),
            "heldout_rmse_before_deg": round(self.heldout_rmse_before, 4),
            "heldout_rmse_after_deg": round(self.heldout_rmse_after, 4),
            "heldout_gain_in_noise_floors": round(self.heldout_gain_sigma, 3),
            "fit_rmse_before_deg": round(self.fit_rmse_before, 4),
            "fit_rmse_after_deg": round(self.fit_rmse_after, 4),
            "likelihood_ratio": round(self.lr, 3),
            "likelihood_ratio_p": float(f"{self.lr_p:.3g}"),
            "f_statistic": round(self.f_stat, 3),
            "delta_bic": round(self.delta_bic, 3),
            "n_obs": int(self.n_obs),
            "n_eff": round(self.n_eff, 1),
            "new_parameters": int(self.dp),
            "identifiable": bool(self.identifiable),
            "not_identifiable": dict(self.not_identifiable),
            "converged": bool(self.converged),
            "parameters": self.effect_params,
        }


def boundary_lr_p(lr: float, dp: int) -> float:
    """p-value of a likelihood-ratio statistic when the effect's size sits on the boundary of its range under
    the null (absent = 0) and its other dp - 1 parameters are free: the chi-bar-squared mixture
    0.5 chi2(dp - 1) + 0.5 chi2(dp) (Self and Liang 1987; chi2(0) is a point mass at 0)."""
    if not lr > 0:
        return 1.0
    dp = max(int(dp), 1)
    lower = float(chi2.sf(lr, dp - 1)) if dp > 1 else 0.0
    return 0.5 * lower + 0.5 * float(chi2.sf(lr, dp))


def own_identifiability(res: FitResult, names: Sequence[str], *, rel_se_max: float = 0.5,
                        corr_max: float = 0.995) -> dict[str, str]:
    """The candidate's own parameters the fit does not determine, with the reason: infinite or large relative
    standard error, a value on a bound, or near-perfect correlation with any other fitted constant."""
    return identifiability.judge_own(res, names, rel_se_max=rel_se_max, corr_max=corr_max)


def confirm(state: ModelState, effect: Effect, fit_logs: Sequence[MotionLog], holdout_logs: Sequence[MotionLog],
            *, noise_floor_deg: float, base_fit_residual: np.ndarray, heldout_before: float,
            max_nfev: int | None = None, rel_se_max: float = 0.5, corr_max: float = 0.995) -> Confirmation:
    """Refit ``state`` + ``effect`` and compute the evidence (see module docstring)."""
    cand = state.with_effect(effect)
    own = [p.name for p in effect.default_params() if not p.fixed]
    fitted, res = fit_state(cand, fit_logs, max_nfev=max_nfev, check_identifiability=False)
    bad = own_identifiability(res, own, rel_se_max=rel_se_max, corr_max=corr_max)
    held: dict[str, str] = {}
    while bad and len(held) < len(own) - 1:
        # hold one parameter the data do not determine at its default and refit the rest: the last declared
        # first (a catalogue entry lists its size first, shape parameters such as time constants after it)
        name = [n for n in own if n in bad and n not in held][-1]
        held[name] = bad[name]
        cand = dataclasses.replace(cand, params=cand.params.replace(name, fixed=True))
        fitted, res = fit_state(cand, fit_logs, max_nfev=max_nfev, check_identifiability=False)
        bad = own_identifiability(res, [n for n in own if n not in held], rel_se_max=rel_se_max, corr_max=corr_max)
    bad = {**held, **bad}
    estimated = [nm for nm in own if nm not in bad]
    for nm in own:
        if nm in bad:
            fitted = dataclasses.replace(fitted, params=fitted.params.replace(
                nm, identifiable=False, stderr=None, note=f"not identifiable: {bad[nm]}"))
        elif nm in res.free_names:
            i = res.free_names.index(nm)
            fitted = dataclasses.replace(fitted, params=fitted.params.replace(
                nm, identifiable=True, stderr=float(math.sqrt(abs(res.cov[i, i])))))
    r1 = res.residual
    r0 = np.asarray(base_fit_residual, float)
    sse0, sse1 = float(r0 @ r0), max(float(r1 @ r1), 1e-300)
    n = r0.size
    n_eff = effective_sample_size(r0, [lg.n for lg in fit_logs])
    dp = max(len(estimated), 1)
    p1 = len(res.free_names)
    gain = math.log(max(sse0, 1e-300) / sse1)
    lr = n_eff * gain
    lr_p = boundary_lr_p(lr, dp)
    f_stat = ((sse0 - sse1) / dp) / (sse1 / max(n_eff - p1, 1.0))
    dbic = -n_eff * gain + dp * math.log(max(n_eff, 2.0))
    ho_after = rmse_deg(residuals(fitted, holdout_logs))
    return Confirmation(
        effect_id=effect.id, state=fitted, fit=res,
        fit_rmse_before=math.sqrt(sse0 / n), fit_rmse_after=math.sqrt(sse1 / n),
        heldout_rmse_before=heldout_before, heldout_rmse_after=ho_after,
        heldout_gain_sigma=(heldout_before - ho_after) / max(noise_floor_deg, 1e-9),
        lr=lr, lr_p=lr_p, f_stat=f_stat, delta_bic=dbic, n_obs=n, n_eff=n_eff, dp=len(estimated),
        identifiable=bool(estimated), not_identifiable=dict(bad),
        effect_params={p.name: p.to_yaml() for p in fitted.params if p.name in own},
        converged=bool(res.success))
