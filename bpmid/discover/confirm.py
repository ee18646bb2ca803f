"""Confirmation: refit the augmented model so that the candidate is really tested, and judge it on data it has
not seen.

For a candidate effect on top of the current model:

1. starting values: the screening regression's estimate of the effect's size (the coefficient of its shape
   column), plus a small grid over the effect's physical range (``START_VALUES`` of the catalogue entry, e.g. a
   lag of 0.02-1 s, a branch of 2-100 s; bounds otherwise). Each start is scored by one simulation, with the
   base constants' first-order compensation projected out (their sensitivities), and the best two distinct
   starts are refitted (every constant free, a fixed evaluation budget)
   (the second only when the first did not move or did not improve the fit);
2. a refit that did not move (the effect's parameters where they started and the same sum of squares) is
   **not tested**: its result says why and is never counted as evidence against the effect;
3. new parameters must be identifiable: a finite, small relative standard error, not on a bound, and not
   collinear with the base constants (judged from the part of its sensitivity no other constant's
   sensitivity spans, so a base constant that is itself poorly determined cannot make it look collinear);
4. fitting-data statistics with the effective sample size N_eff (residuals are autocorrelated):
   LR = N_eff ln(SSE0/SSE1) with the boundary-corrected p-value (chi-bar-squared), F, delta BIC (reported
   only, never a gate);
5. held-out logs: RMSE before and after (each log's own stiffness gain fitted for both models when the
   workflow scores with per-log gains); the gain is measured in units of the estimated noise floor.

Which values pass is decided by :mod:`bpmid.discover.workflow` (a Holm correction over the round's candidates).
"""
from __future__ import annotations

import dataclasses
import itertools
import math
from typing import Optional, Sequence

import numpy as np
from scipy.special import chdtrc  # chi2.sf, bit for bit, without importing scipy.stats (0.4 s)

from bpmid.discover.screen import _orthonormal  # one basis routine for screening and confirmation
from bpmid.discover.model import (ModelState, fit_state, gained_residuals, heldout_residual, nuisance_block_columns,
                                  rmse_deg, sensitivities, simulate, stacked)
from bpmid.effects.base import Effect
from bpmid.fitting import (ZERO_SENSITIVITY, FitResult, conditional_on_held, correlated_with,
                            effective_sample_size)
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
    tested: bool = True
    not_tested_reason: str = ""
    starts: list = dataclasses.field(default_factory=list)
    lr_p_holm: float = float("nan")
    #: share of the held-out gap (the RMSE above the noise floor, in quadrature: :func:`excess_deg`) removed
    gap_share: float = float("nan")
    fit_share: float = float("nan")   # the same share on the fitting logs
    #: held-out drop in quadrature, sqrt(before^2 - after^2), in noise floors (:func:`heldout_drop_sigma`)
    drop_sigma: float = float("nan")
    #: the same drop on the held-out samples where the refit moves the prediction most (the top
    #: :data:`WHERE_IT_ACTS` of them by the change): an effect seen only in short stretches of a log (a lag, while
    #: the pressure moves) removes little of a whole log's error but most of the error where it acts
    #: (:func:`drop_where_it_acts`). Reported and recorded for calibration, never a gate: a path naming an effect
    #: on it was calibrated and cross-validated, and named no more right out of fold (docs/validation.md)
    local_drop_sigma: float = float("nan")
    accepted: bool = False
    #: which rule of the gate named it: "gap" (the gap above the noise), "floor" (down to the noise floor) or
    #: "pair" (two effects named together)
    passed_by: str = ""
    #: named on the path to the floor or as a pair: why the gate itself had refused it
    gate_reasons: list = dataclasses.field(default_factory=list)
    reasons: list = dataclasses.field(default_factory=list)
    #: named together with another effect: the joint refit whose constants are the ones named
    named_with: Optional[ModelState] = None
    #: a rival that can stand beside an effect as well as for it (:data:`bpmid.discover.rivals.IMITATES`): that
    #: effect refitted on top of this rival's fit (None: not asked), and whether it still added what the rival
    #: cannot (:func:`bpmid.discover.rivals.adds_beside`)
    effect_beside: Optional["Confirmation"] = None
    effect_beside_adds: bool = False

    @property
    def family_p(self) -> float:
        """The p-value judged against the round's family-wise level: Holm-corrected once the round set it."""
        return self.lr_p_holm if math.isfinite(self.lr_p_holm) else self.lr_p

    def to_yaml(self) -> dict:
        return {
            "effect": self.effect_id,
            "accepted": bool(self.accepted),
            "tested": bool(self.tested),
            "not_tested_reason": self.not_tested_reason or None,
            "reasons_rejected": list(self.reasons),
            "refused_by_the_gate_because": (list(self.gate_reasons) if self.passed_by == "floor" else
                                            [f"alone: {r}" for r in self.gate_reasons] if self.passed_by == "pair"
                                            else None),
            "heldout_rmse_before_deg": round(self.heldout_rmse_before, 4),
            "heldout_rmse_after_deg": round(self.heldout_rmse_after, 4),
            "heldout_gain_in_noise_floors": round(self.heldout_gain_sigma, 3),
            "heldout_drop_in_noise_floors": round(self.drop_sigma, 3) if math.isfinite(self.drop_sigma) else None,
            "heldout_drop_where_it_acts_in_noise_floors": (round(self.local_drop_sigma, 3)
                                                           if math.isfinite(self.local_drop_sigma) else None),
            "named_by": self.passed_by or None,
            "fit_rmse_before_deg": round(self.fit_rmse_before, 4),
            "fit_rmse_after_deg": round(self.fit_rmse_after, 4),
            "likelihood_ratio": round(self.lr, 3),
            "likelihood_ratio_p": float(f"{self.lr_p:.3g}"),
            "likelihood_ratio_p_holm": float(f"{self.lr_p_holm:.3g}") if math.isfinite(self.lr_p_holm) else None,
            "likelihood_ratio_p_note": p_note(self.lr_p) if self.tested else None,
            "share_of_heldout_gap_removed": round(self.gap_share, 3) if math.isfinite(self.gap_share) else None,
            "share_of_fitting_gap_removed": round(self.fit_share, 3) if math.isfinite(self.fit_share) else None,
            "f_statistic": round(self.f_stat, 3),
            "delta_bic_reported_only": round(self.delta_bic, 3),
            "n_obs": int(self.n_obs),
            "n_eff": round(self.n_eff, 1),
            "new_parameters": int(self.dp),
            "identifiable": bool(self.identifiable),
            "not_identifiable": dict(self.not_identifiable),
            "converged": bool(self.converged),
            "starts": list(self.starts),
            "parameters": self.effect_params,
        }


def boundary_lr_p(lr: float, dp: int) -> float:
    """p-value of a likelihood-ratio statistic when the effect's size sits on the boundary of its range under
    the null (absent = 0) and its other dp - 1 parameters are free: the chi-bar-squared mixture
    0.5 chi2(dp - 1) + 0.5 chi2(dp) (Self and Liang 1987; chi2(0) is a point mass at 0)."""
    if not lr > 0:
        return 1.0
    dp = max(int(dp), 1)
    lower = float(chdtrc(dp - 1, lr)) if dp > 1 else 0.0
    return 0.5 * lower + 0.5 * float(chdtrc(dp, lr))


#: below this a likelihood-ratio p is at the floor of double precision (the chi-squared tail underflows toward 0,
#: through subnormal numbers): it is written "< 1e-300", never as a value to quote
P_FLOOR = 1e-300


def p_words(p: float, *, eq: bool = True) -> str:
    """A p-value for a sentence: ``"= 0.012"`` (``"0.012"`` with ``eq=False``), or ``"< 1e-300"`` at the floor of
    double precision, so an underflow never reads as "p = 0"."""
    if p < P_FLOOR:
        return "< 1e-300"
    return f"= {p:.2g}" if eq else f"{p:.2g}"


def p_note(p: float) -> str | None:
    """``discovery.yaml``'s note beside a p-value at the floor of double precision (see :data:`P_FLOOR`)."""
    return "below 1e-300 (underflow): the value is not one to quote" if p < P_FLOOR else None


def holm_adjusted(p: Sequence[float], m: int | None = None) -> list[float]:
    """Holm step-down adjusted p-values of ``p`` in a family of ``m`` hypotheses (m >= len(p): candidates
    screened but not refitted count as tried). Reject hypothesis i at family-wise level alpha iff
    adjusted[i] < alpha."""
    p = [float(x) if math.isfinite(x) else 1.0 for x in p]
    m = max(int(m or len(p)), len(p))
    order = sorted(range(len(p)), key=lambda i: p[i])
    out = [1.0] * len(p)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p[i]))
        out[i] = running
    return out


def own_identifiability(fitted: ModelState, res: FitResult, logs: Sequence[MotionLog], names: Sequence[str], *,
                        per_log_gain: bool, rel_se_max: float = 0.5, corr_max: float = 0.995) -> tuple[dict[str, str], dict[str, float]]:
    """The candidate's own parameters the fit does not determine (and the standard errors of the others), with the reason: a value on a bound, no
    sensitivity the other constants do not already have (collinear: sqrt(1 - R^2) of its sensitivity on the
    others' below sqrt(1 - corr_max^2)), or a large relative standard error from that unique part."""
    free = list(res.free_names)
    own = [n for n in names if n in free]
    if not own:
        return {}, {}
    sims = simulate(fitted, logs)
    J = sensitivities(fitted, logs, free, base_sim=sims, rel_step=1e-3)
    # the per-log gains / factors are nuisance constants too
    G = nuisance_block_columns(per_log_gain, sims, logs)
    r = res.residual
    s2 = float(r @ r) / max(r.size - len(free), 1)
    infl = r.size / max(effective_sample_size(r, [lg.n for lg in logs]), 1.0)
    bad, ses = {}, {}
    for nm in own:
        i = free.index(nm)
        p = res.params[nm]
        span = p.upper - p.lower
        tol = 1e-6 * (span if np.isfinite(span) else max(abs(p.value), 1.0))
        col = np.nan_to_num(J[:, i])
        others = np.column_stack([np.delete(J, i, axis=1), G])
        Q = _orthonormal(others)
        perp = col - Q @ (Q.T @ col)
        nc, npp = float(np.linalg.norm(col)), float(np.linalg.norm(perp))
        unique = npp / nc if nc > 0 else 0.0
        # J is per unit of the optimiser variable: log(value) for log-scaled parameters
        se_x = math.sqrt(s2 * infl) / npp if npp > 0 else math.inf
        se = se_x * abs(p.value) if p.log_scale else se_x
        rel = se / abs(p.value) if p.value != 0 else math.inf
        if nc == 0 or not math.isfinite(se):
            bad[nm] = "the data do not determine it (no sensitivity)"
        elif p.value - p.lower <= tol or p.upper - p.value <= tol:
            bad[nm] = _ON_BOUND
        elif unique < _UNIQUE_MIN:
            bad[nm] = f"collinear with the base constants (only {unique:.1%} of its sensitivity is its own)"
        elif rel > rel_se_max:
            bad[nm] = f"relative standard error {rel:.0%} > {rel_se_max:.0%}"
        else:
            ses[nm] = se
    return bad, ses


_ON_BOUND = "the fit ran onto a bound"

#: a parameter with less than this share of its sensitivity outside the span of the other constants' is collinear
#: (whether what remains is enough is the standard error's verdict)
_UNIQUE_MIN = 0.005




def start_grid(effect: Effect) -> list[dict[str, float]]:
    """Starting values over the effect's physical range: its ``START_VALUES`` (by short name) where declared,
    else 4 points across its bounds (log-spaced for log-scaled parameters); the default is always included."""
    ps = [p for p in effect.default_params() if not p.fixed]
    declared = getattr(effect, "START_VALUES", {}) or {}
    axes = []
    for p in ps:
        short = p.name.split(".", 1)[-1]
        vals = declared.get(short)
        if vals is None:
            lo, hi = p.lower, p.upper
            if p.log_scale and lo > 0 and np.isfinite(hi):
                vals = tuple(np.geomspace(lo, hi, 6)[1:-1])
            elif np.isfinite(lo) and np.isfinite(hi):
                vals = tuple(np.linspace(lo, hi, 6)[1:-1])
            else:
                vals = (p.value * 0.3, p.value * 3.0)
        vals = [min(max(float(v), p.lower), p.upper) for v in vals]
        axes.append((p.name, vals))
    grid = [dict(zip([a[0] for a in axes], combo)) for combo in itertools.product(*[a[1] for a in axes])]
    grid.append({p.name: p.value for p in ps})
    return grid


def screening_estimate(state: ModelState, effect: Effect, logs: Sequence[MotionLog], r_perp: np.ndarray,
                       Q0: np.ndarray, base_sim: Sequence[np.ndarray]) -> Optional[dict[str, float]]:
    """The effect's size from the screening regression: the coefficient of its shape column (the augmented
    model at the default minus the model), nuisance projected out, scales the default towards the null."""
    ps = [p for p in effect.default_params() if not p.fixed]
    null = effect.null_values()
    if not ps or ps[0].name not in null:
        return None
    size = ps[0]
    shape = stacked(simulate(state.with_effect(effect), logs)) - stacked(base_sim)
    shape = shape - Q0 @ (Q0.T @ shape)
    den = float(shape @ shape)
    if not den > 0:
        return None
    beta = -float(shape @ r_perp) / den       # residual = model - measured: the model needs + beta * shape
    v = null[size.name] + beta * (size.value - null[size.name])
    if size.log_scale and v <= 0:
        return None
    v = min(max(v, size.lower), size.upper)
    return {size.name: v, **{p.name: p.value for p in ps[1:]}}


def _sse_perp(r: np.ndarray, Q: np.ndarray) -> float:
    rp = r - Q @ (Q.T @ r)
    return float(rp @ rp)


def confirm(state: ModelState, effect: Effect, fit_logs: Sequence[MotionLog], holdout_logs: Sequence[MotionLog],
            *, noise_floor_deg: float, base_fit_residual: np.ndarray, heldout_before: float,
            max_nfev: int | None = None, rel_se_max: float = 0.5, corr_max: float = 0.995,
            nuisance: np.ndarray | None = None, per_log_gain: bool = False, n_fits: int = 2,
            heldout_before_res: np.ndarray | None = None) -> Confirmation:
    """Refit ``state`` + ``effect`` from several starts and compute the evidence (see module docstring).

    ``heldout_before_res``: the stacked held-out residual of ``state`` as scored
    (:func:`bpmid.discover.model.heldout_residual`), the same for every candidate of a round; None computes it.

    ``nuisance``: (N, k) columns of the current model's sensitivities on the fitting logs (screening's), used to
    score the starts with the base constants' compensation projected out; None computes them.
    """
    base_sim = simulate(state, fit_logs)
    r0 = np.asarray(base_fit_residual, float)
    if nuisance is None:
        nuisance = sensitivities(state, fit_logs, base_sim=base_sim)
    if per_log_gain:
        nuisance = np.column_stack([nuisance, nuisance_block_columns(per_log_gain, base_sim, fit_logs)])
    Q0 = _orthonormal(nuisance)
    own = [p.name for p in effect.default_params() if not p.fixed]
    cand0 = state.with_effect(effect)

    # 1. starts, scored by one simulation each with the base compensation projected out
    starts = start_grid(effect)
    est = screening_estimate(state, effect, fit_logs, r0 - Q0 @ (Q0.T @ r0), Q0, base_sim)
    if est is not None:
        starts.insert(0, est)
    scored = []
    for vals in starts:
        p = cand0.params.with_values(vals)
        r = stacked(gained_residuals(simulate(cand0, fit_logs, p), fit_logs, per_log_gain=per_log_gain))
        scored.append((_sse_perp(r, Q0), vals, "screening estimate" if vals is est else "grid"))
    scored.sort(key=lambda x: x[0])
    sse0_perp = _sse_perp(r0, Q0)
    chosen, seen = [], []
    for sse, vals, how in scored:
        key = tuple(round(math.log(abs(v) + 1e-12), 1) for v in vals.values())
        if key in seen:
            continue
        seen.append(key)
        chosen.append((sse, vals, how))
        if len(chosen) >= n_fits:
            break

    # 2. refits from the chosen starts; keep the lowest sum of squares
    sse0 = float(r0 @ r0)
    best = None
    start_log = []
    for _, vals, how in chosen:
        if best is not None and best[3] and best[2] < sse0 * (1 - 1e-6):
            break                      # the first refit moved and improved: the next start is not needed
        cand = dataclasses.replace(cand0, params=cand0.params.with_values(vals))
        fitted, res = fit_state(cand, fit_logs, max_nfev=max_nfev, check_identifiability=False,
                                per_log_gain=per_log_gain)
        r1 = res.residual
        sse1 = float(r1 @ r1)
        moved = any(abs(fitted.params.value(n) - vals[n]) > 1e-6 * max(abs(vals[n]), 1e-9) for n in own)
        start_log.append({"from": how, "start": {n: float(f"{v:.4g}") for n, v in vals.items()},
                          "end": {n: float(f"{fitted.params.value(n):.4g}") for n in own},
                          "fit_rmse_deg": round(math.sqrt(sse1 / max(r1.size, 1)), 4), "moved": bool(moved),
                          "evaluations": int(res.nfev)})
        if best is None or sse1 < best[2]:
            best = (fitted, res, sse1, moved, vals)
    fitted, res, sse1, moved, vals = best
    tested, why_not = True, ""
    if not any(s["moved"] for s in start_log) and sse1 >= sse0 * (1 - 1e-9):
        tested = False
        m = max(r0.size, 1)
        error = ("the fit error did not change" if sse1 <= sse0 * (1 + 1e-6) else
                 f"the fit error went from {math.sqrt(sse0 / m):.4g} to {math.sqrt(sse1 / m):.4g} deg, no better")
        why_not = (f"the refit did not move from any of its starts (the effect's parameters stayed where they "
                   f"started and {error}): the optimiser made no progress, so this is no evidence against the effect")
    elif sse1 >= sse0 * (1 - 1e-9) and scored[0][0] < sse0_perp * (1 - 1e-3):
        tested = False
        why_not = ("the refit ended no better than the model without the effect although a start in the effect's "
                   "physical range reduced the first-order residual: the optimiser failed, not the effect")

    # 3. identifiability: hold a parameter the data do not determine at its fitted value and refit the rest
    bad, ses = own_identifiability(fitted, res, fit_logs, own, per_log_gain=per_log_gain, rel_se_max=rel_se_max,
                              corr_max=corr_max)
    held: dict[str, str] = {}
    links: dict[str, dict[str, float]] = {}   # held -> the constants it traded off against while it was free
    while bad and len(held) < len(own) - 1:
        # hold first a parameter that ran onto a bound (the bound is the range's statement, and the parameter
        # it traded off against then carries the effect: e.g. a softening linear in time drives the amount to
        # its bound and leaves the time constant collinear with it), else the last undetermined one
        pending = [n for n in own if n in bad and n not in held]
        on_bound = [n for n in pending if bad[n] == _ON_BOUND]
        name = on_bound[0] if on_bound else pending[-1]
        held[name] = bad[name]
        # a parameter whose effect names a simpler form for it (a linear fill) goes back to that form when the data
        # do not determine it, unless it ran onto a bound (the data then asked for more of it than the range allows)
        simpler = getattr(effect, "UNDETERMINED_TO", {}).get(name.split(".", 1)[1])
        back = {} if simpler is None or bad[name] == _ON_BOUND else {"value": float(simpler)}
        if back:
            held[name] = f"{bad[name]}; held at {simpler:g}, the simpler form"
        links[name] = correlated_with(res.free_names, res.corr, name)
        cand = dataclasses.replace(fitted, params=fitted.params.replace(name, fixed=True, **back))
        fitted, res = fit_state(cand, fit_logs, max_nfev=max_nfev, check_identifiability=False,
                                per_log_gain=per_log_gain)
        bad, ses = own_identifiability(fitted, res, fit_logs, [n for n in own if n not in held],
                                  per_log_gain=per_log_gain, rel_se_max=rel_se_max, corr_max=corr_max)
    # a parameter a fit held (the data do not depend on it: zero sensitivity) was never estimated either: it ends
    # fixed at its start, whichever of the refits held it
    by_fit = {nm: (res.held or {}).get(nm, ZERO_SENSITIVITY) for nm in own
              if fitted.params[nm].fixed and nm not in held}
    bad = {**by_fit, **held, **bad}
    for nm in bad:   # say where it is kept (a note said 'ended on its lower bound 0' beside a held 0.5)
        if "held at" not in bad[nm] and fitted.params[nm].fixed:
            bad[nm] = (f"{bad[nm]}; held at {fitted.params[nm].value:.6g}, where the refit with it free left it"
                       if nm in held else f"{bad[nm]}; kept at {fitted.params[nm].value:.6g}, its start")
    estimated = [nm for nm in own if nm not in bad]
    for nm in own:
        if nm in bad:
            fitted = dataclasses.replace(fitted, params=fitted.params.replace(
                nm, identifiable=False, stderr=None, note=f"not identifiable: {bad[nm]}"))
        else:
            # its own verdict (the part of its sensitivity no other constant spans) replaces the generic fit's
            # note, which judged the standard error with every constant free beside it
            fitted = dataclasses.replace(fitted, params=fitted.params.replace(nm, identifiable=True,
                                                                                  stderr=ses.get(nm), note=""))
    # the constants that traded off against a held one: their standard errors assume it at the value it is held at
    # (the base model's K and tau beside a lag time constant the data do not determine apart from them)
    fitted = dataclasses.replace(fitted, params=conditional_on_held(
        fitted.params, res.free_names, links, at_fit=[nm for nm in held if "simpler form" not in held[nm]]))
    r1 = res.residual
    sse1 = max(float(r1 @ r1), 1e-300)
    n = r0.size
    n_eff = effective_sample_size(r0, [lg.n for lg in fit_logs])
    dp = max(len(estimated), 1)
    p1 = len(res.free_names)
    gain = math.log(max(sse0, 1e-300) / sse1)
    lr = n_eff * gain
    lr_p = boundary_lr_p(lr, dp)
    f_stat = ((sse0 - sse1) / dp) / (sse1 / max(n_eff - p1, 1.0))
    dbic = -n_eff * gain + dp * math.log(max(n_eff, 2.0))
    ho_res_after = heldout_residual(fitted, holdout_logs, per_log_gain)
    ho_after = rmse_deg([ho_res_after])   # scored_rmse, from the residual the drop where it acts needs too
    c = Confirmation(
        effect_id=effect.id, state=fitted, fit=res,
        fit_rmse_before=math.sqrt(sse0 / n), fit_rmse_after=math.sqrt(sse1 / n),
        heldout_rmse_before=heldout_before, heldout_rmse_after=ho_after,
        heldout_gain_sigma=(excess_deg(heldout_before, noise_floor_deg) - excess_deg(ho_after, noise_floor_deg))
        / max(noise_floor_deg, 1e-9),
        lr=lr, lr_p=lr_p, f_stat=f_stat, delta_bic=dbic, n_obs=n, n_eff=n_eff, dp=len(estimated),
        identifiable=bool(estimated), not_identifiable=dict(bad),
        effect_params={p.name: p.to_yaml() for p in fitted.params if p.name in own},
        converged=bool(res.success), tested=tested, not_tested_reason=why_not, starts=start_log)
    c.fit_share = gap_share(c.fit_rmse_before, c.fit_rmse_after, noise_floor_deg)
    c.gap_share = gap_share(heldout_before, ho_after, noise_floor_deg)
    c.drop_sigma = heldout_drop_sigma(heldout_before, ho_after, noise_floor_deg)
    ho_res_before = (heldout_residual(state, holdout_logs, per_log_gain) if heldout_before_res is None
                     else heldout_before_res)
    c.local_drop_sigma = drop_where_it_acts(ho_res_before, ho_res_after, noise_floor_deg)
    return c


#: the share of the held-out samples on which :func:`drop_where_it_acts` measures an effect: those where its refit
#: changes the prediction most (a tenth: a lag of a few tenths of a second acts on the ramps' ends, a few per cent
#: of a log each); not calibrated
WHERE_IT_ACTS = 0.10


def drop_where_it_acts(before_res: np.ndarray, after_res: np.ndarray, noise_floor_deg: float,
                       share: float = WHERE_IT_ACTS) -> float:
    """The held-out error an effect removes where it acts, in quadrature and in noise floors:
    ``sqrt(mean(before^2) - mean(after^2)) / floor`` over the ``share`` of the held-out samples where the prediction
    changed most (residuals in deg, model minus measurement, the same samples before and after; 0 when it removes
    none there). Noise and the log-to-log variation spread over a whole log; an effect seen only in short
    stretches of it (a lag acts while the pressure moves) is measured where it acts rather than diluted by the
    stretches it leaves alone. Reported for every candidate; no gate uses it (see ``local_drop_sigma``)."""
    b = np.asarray(before_res, float)
    a = np.asarray(after_res, float)
    if b.shape != a.shape or b.size == 0 or not noise_floor_deg > 0 or not (np.all(np.isfinite(b))
                                                                              and np.all(np.isfinite(a))):
        return float("nan")
    change = np.abs(b - a)
    k = max(int(math.ceil(share * b.size)), 1)
    top = np.argpartition(change, b.size - k)[b.size - k:]
    drop2 = float(np.mean(b[top] ** 2) - np.mean(a[top] ** 2))
    return math.sqrt(max(drop2, 0.0)) / noise_floor_deg


def excess_deg(rmse_deg: float, noise_floor_deg: float) -> float:
    """The part of an RMSE above the noise (deg): ``sqrt(rmse^2 - floor^2)``, 0 at or below the floor.

    Sensor noise and a model's systematic error add in quadrature, so a systematic error of 0.3 noise floors
    raises the RMSE by only 4 % of the floor: a gain or a share taken on RMSE differences would hide a real effect
    that a refitted base model has already half absorbed. Every gap of the gate is this excess."""
    return math.sqrt(max(rmse_deg * rmse_deg - noise_floor_deg * noise_floor_deg, 0.0))


def heldout_drop_sigma(before_deg: float, after_deg: float, noise_floor_deg: float) -> float:
    """The held-out error an effect removes, in quadrature and in noise floors: ``sqrt(before^2 - after^2) /
    floor`` (0 when it removes none). Unlike the gap above the floor (:func:`excess_deg`), it does not depend on
    where the floor sits: once a refitted base model has absorbed most of an effect, the held-out error is within a
    few per cent of the floor, and the floor's own uncertainty decides whether any gap is left; the drop still
    measures what the effect explains on logs it was not fitted on."""
    if not (math.isfinite(before_deg) and math.isfinite(after_deg)) or not noise_floor_deg > 0:
        return float("nan")
    return math.sqrt(max(before_deg * before_deg - after_deg * after_deg, 0.0)) / noise_floor_deg


def gap_share(before_deg: float, after_deg: float, noise_floor_deg: float) -> float:
    """Share of the gap above the noise (:func:`excess_deg`) removed going from ``before`` to ``after``; NaN when
    there is no gap above the floor before."""
    gb = excess_deg(before_deg, noise_floor_deg)
    if not gb > 0:
        return float("nan")
    return (gb - excess_deg(after_deg, noise_floor_deg)) / gb


@dataclasses.dataclass
class PairTrial:
    """Two candidates refitted together (all angles in deg, gains in noise floors).

    ``first`` is the candidate with the larger held-out gain alone; ``joint`` is the confirmation of ``second``
    refitted on top of ``first``'s refit (every constant free), so its state holds both effects.
    """

    first: Confirmation
    second: Confirmation
    joint: Confirmation
    heldout_rmse_before: float
    heldout_rmse_after: float
    gain_sigma: float          # the pair's held-out gain above the noise (as a single candidate's)
    gap_share: float           # share of the held-out gap above the floor the pair removes
    gain_first_given_second: float   # held-out gain of adding ``first`` to ``second`` alone
    gain_second_given_first: float   # held-out gain of adding ``second`` to ``first`` alone
    p_first_given_second: float      # likelihood-ratio p of ``first`` beside ``second`` (fitting logs)
    p_second_given_first: float
    n_pairs: int = 1           # pairs tried in the round (the conditional p-values are Bonferroni-corrected by it)
    accepted: bool = False
    reasons: list = dataclasses.field(default_factory=list)

    @property
    def ids(self) -> tuple[str, str]:
        return self.first.effect_id, self.second.effect_id

    @property
    def tested(self) -> bool:
        return bool(self.first.tested and self.second.tested and self.joint.tested)

    @property
    def identifiable(self) -> bool:
        return bool(self.first.identifiable and self.second.identifiable and self.joint.identifiable)

    @property
    def min_gain_given_other(self) -> float:
        return min(self.gain_first_given_second, self.gain_second_given_first)

    @property
    def p_corrected(self) -> float:
        """The larger conditional p-value, Bonferroni-corrected over the pairs tried in the round."""
        return min(1.0, max(self.p_first_given_second, self.p_second_given_first) * max(self.n_pairs, 1))

    def to_yaml(self) -> dict:
        def r(x, d=3):
            return round(float(x), d) if math.isfinite(x) else None
        return {"effects": list(self.ids), "accepted": bool(self.accepted),
                "reasons_rejected": list(self.reasons),
                "heldout_rmse_before_deg": r(self.heldout_rmse_before, 4),
                "heldout_rmse_after_deg": r(self.heldout_rmse_after, 4),
                "heldout_gain_in_noise_floors": r(self.gain_sigma),
                "share_of_heldout_gap_removed": r(self.gap_share),
                "heldout_gain_of_each_beside_the_other": {self.first.effect_id: r(self.gain_first_given_second),
                                                          self.second.effect_id: r(self.gain_second_given_first)},
                "likelihood_ratio_p_of_each_beside_the_other": {
                    self.first.effect_id: float(f"{self.p_first_given_second:.3g}"),
                    self.second.effect_id: float(f"{self.p_second_given_first:.3g}")},
                "pairs_tried": int(self.n_pairs),
                "likelihood_ratio_p_bonferroni": float(f"{self.p_corrected:.3g}"),
                "tested": self.tested, "identifiable": self.identifiable,
                "parameters": {p.name: p.to_yaml() for p in self.joint.state.params
                               if p.name.split(".", 1)[0] in self.ids}}


def pair_trial(first: Confirmation, second: Confirmation, effect_second: Effect, fit_logs: Sequence[MotionLog],
               holdout_logs: Sequence[MotionLog], *, noise_floor_deg: float, heldout_before: float,
               max_nfev: int | None = None, per_log_gain=False, n_pairs: int = 1) -> PairTrial:
    """Refit ``effect_second`` on top of ``first``'s refit (:func:`confirm`, every constant free) and measure
    what each of the two adds beside the other: on the held-out logs (gain above the noise, in noise floors)
    and on the fitting logs (likelihood ratio with the effective sample size, boundary-corrected)."""
    floor = noise_floor_deg
    joint = confirm(first.state, effect_second, fit_logs, holdout_logs, noise_floor_deg=floor,
                    base_fit_residual=first.fit.residual, heldout_before=first.heldout_rmse_after,
                    max_nfev=max_nfev, per_log_gain=per_log_gain)
    after = joint.heldout_rmse_after
    ex = lambda x: excess_deg(x, floor)  # noqa: E731
    # the first beside the second: the joint fit against the second's own refit
    r_b, r_ab = np.asarray(second.fit.residual, float), np.asarray(joint.fit.residual, float)
    sse_b, sse_ab = float(r_b @ r_b), max(float(r_ab @ r_ab), 1e-300)
    n_eff = effective_sample_size(r_b, [lg.n for lg in fit_logs])
    p_first = boundary_lr_p(n_eff * math.log(max(sse_b, 1e-300) / sse_ab), max(first.dp, 1))
    return PairTrial(
        first=first, second=second, joint=joint, heldout_rmse_before=heldout_before, heldout_rmse_after=after,
        gain_sigma=(ex(heldout_before) - ex(after)) / max(floor, 1e-9),
        gap_share=gap_share(heldout_before, after, floor),
        gain_first_given_second=(ex(second.heldout_rmse_after) - ex(after)) / max(floor, 1e-9),
        gain_second_given_first=(ex(first.heldout_rmse_after) - ex(after)) / max(floor, 1e-9),
        p_first_given_second=p_first, p_second_given_first=joint.lr_p if joint.tested else 1.0, n_pairs=n_pairs)
