"""One least-squares driver for every model family, with honest uncertainties.

- :func:`fit_least_squares` minimises a residual vector over the free parameters of a
  :class:`~bpmid.params.ParamSet` (bounds, log-scaled parameters) with ``scipy.optimize.least_squares``.
- Standard errors come from the Jacobian at the optimum, inflated for autocorrelated residuals by
  the ratio N / N_eff, where N_eff = sum over logs of n (1 - rho1) / (1 + rho1) (rho1: lag-1
  autocorrelation of that log's residual). This is the "effective sample size" method; it is named in
  every output (:data:`UNCERTAINTY_METHOD`).
- A free parameter the residual does not depend on (zero sensitivity: :func:`zero_sensitivity`) is never
  estimated, whether or not identifiability is checked: it is held at its prior value with that reason.
- Identifiability: a free parameter whose relative standard error is above ``rel_se_max``, that sits
  on a bound, or that is almost perfectly correlated with another (|r| > ``corr_max``) is reported as
  not identifiable, held at its prior (starting) value and the fit is repeated without it. It is
  never printed as if it were measured.
"""
from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Callable, Sequence

import numpy as np
from scipy.optimize import least_squares

from bpmid import identifiability
from bpmid.params import ParamSet

UNCERTAINTY_METHOD = ("Jacobian covariance s^2 (J^T J)^-1 inflated by N/N_eff, "
                      "N_eff = sum_logs n (1 - rho1)/(1 + rho1) from the lag-1 residual autocorrelation")


def lag1_autocorrelation(r: np.ndarray) -> float:
    """Lag-1 autocorrelation of a residual sequence (0 for fewer than 3 samples)."""
    r = np.asarray(r, float)
    r = r[np.isfinite(r)]
    if r.size < 3:
        return 0.0
    r = r - r.mean()
    den = float(np.dot(r, r))
    return 0.0 if den == 0 else float(np.dot(r[1:], r[:-1]) / den)


def effective_sample_size(residual: np.ndarray, segments: Sequence[int] | None = None) -> float:
    """N_eff = sum over segments of n (1 - rho1) / (1 + rho1), rho1 clipped to [0, 0.999].

    Parameters
    ----------
    residual : (N,) concatenated residuals
    segments : lengths of the consecutive pieces (one per log); None means one piece
    """
    residual = np.asarray(residual, float)
    segments = [residual.size] if segments is None else list(segments)
    if sum(segments) != residual.size:
        raise ValueError("segment lengths do not add up to the residual length")
    total, start = 0.0, 0
    for n in segments:
        rho = min(max(lag1_autocorrelation(residual[start:start + n]), 0.0), 0.999)
        total += n * (1.0 - rho) / (1.0 + rho)
        start += n
    return max(total, 1.0)


def covariance_from_jacobian(jac: np.ndarray, residual: np.ndarray, n_eff: float) -> np.ndarray:
    """Parameter covariance (optimiser space) from the Jacobian, inflated by N / N_eff.

    Returns an all-inf matrix when J^T J is singular (nothing can be said).
    """
    n, p = jac.shape
    sse = float(np.dot(residual, residual))
    dof = max(n - p, 1)
    s2 = sse / dof
    inflate = max(n / max(n_eff, 1.0), 1.0)
    try:
        _u, s, vt = np.linalg.svd(jac, full_matrices=False)
    except np.linalg.LinAlgError:
        return np.full((p, p), np.inf)
    if s.size == 0 or s[0] == 0:
        return np.full((p, p), np.inf)
    keep = s > s[0] * 1e-10
    inv = (vt[keep].T / s[keep] ** 2) @ vt[keep]
    if not np.all(keep):
        # directions the data do not constrain: any parameter with a share in them is undetermined
        null = np.abs(vt[~keep]).max(axis=0) > 1e-6
        inv[null, :] = np.inf
        inv[:, null] = np.inf
    return s2 * inflate * inv


#: how the standard errors of a fit over several independent tests are computed (:func:`with_between_tests`)
BETWEEN_TESTS_METHOD = (UNCERTAINTY_METHOD + "; each variance at least its cluster-robust (sandwich) value with the "
                        "tests as clusters, C/(C-1) (J^T J)^-1 (sum_c J_c^T r_c r_c^T J_c) (J^T J)^-1, so that the "
                        "spread from test to test counts (3 tests or more)")


def with_between_tests(cov: np.ndarray, jac: np.ndarray, residual: np.ndarray,
                       segments: Sequence[int]) -> tuple[np.ndarray, bool]:
    """``cov`` with each parameter's variance raised to at least its cluster-robust value over ``segments`` (one
    per test; correlations kept): tests of one material differ by a few % from one another (specimens, clamping),
    which the within-test noise behind ``cov`` does not see, and a constant fitted to 12 tests was reported 60
    standard errors from the generator's value. Returns (the covariance, whether any variance was raised);
    ``cov`` unchanged with fewer than 3 tests or a singular J^T J."""
    seg = [int(n) for n in segments]
    if len(seg) < 3 or sum(seg) != residual.size or not np.all(np.isfinite(cov)):
        return cov, False
    try:
        inv = np.linalg.pinv(jac.T @ jac)
    except np.linalg.LinAlgError:
        return cov, False
    meat = np.zeros_like(inv)
    start = 0
    for n in seg:
        g = jac[start:start + n].T @ residual[start:start + n]
        meat += np.outer(g, g)
        start += n
    c = len(seg)
    robust = c / (c - 1.0) * (inv @ meat @ inv)
    base = np.diag(cov)
    ratio = np.where(base > 0, np.diag(robust) / np.where(base > 0, base, 1.0), 1.0)
    f = np.sqrt(np.maximum(ratio, 1.0))
    return cov * np.outer(f, f), bool(np.any(ratio > 1.0))


#: the verdict of a parameter the residual does not depend on
ZERO_SENSITIVITY = "the data do not depend on it (zero sensitivity)"


def zero_sensitivity_verdict(param, value: float) -> str:
    """:data:`ZERO_SENSITIVITY`, saying so when the fit ended on one of the parameter's bounds: there the data
    asked for no more (a pressure lag of 0 s, a leak of 0: the effect switched off), which is not the same as a
    parameter the model ignores. Every verdict starts with :data:`ZERO_SENSITIVITY`."""
    lo, hi = float(param.lower), float(param.upper)
    # on a bound: within 1e-5 of the range (a finite range) or 1e-9 (relative) of it; a step that changes
    # nothing there leaves the optimiser a few ulps to a few millionths of the range away
    tol = 1e-5 * (hi - lo) if np.isfinite(hi - lo) else 0.0
    for end, b in (("lower", lo), ("upper", hi)):
        if np.isfinite(b) and abs(value - b) <= max(tol, 1e-9 * max(1.0, abs(b))):
            unit = f" {param.unit}" if param.unit not in ("", "1") else ""
            return (f"{ZERO_SENSITIVITY}: it ended on its {end} bound {b:g}{unit} ({value:.3g}), where the data "
                    "asked for no more of it")
    return ZERO_SENSITIVITY
#: a parameter whose sensitivity is below this share of the largest one's is taken as having none: a
#: two-point finite difference of a forward model that ignores the parameter gives about 1e-8 of it from
#: rounding alone
SENSITIVITY_REL_MIN = 1e-6
#: ... or below this in absolute terms (root-mean-square residual change for a 100 % change of the parameter)
SENSITIVITY_ABS_MIN = 1e-12


def sensitivities(jac: np.ndarray, params: ParamSet) -> np.ndarray:
    """Root-mean-square change of the residual for a 100 % change of each free parameter (the data's unit).

    ``jac`` is the Jacobian in optimiser space (log of the value for log-scaled parameters), shape (N, n_free).
    A parameter at 0 is measured per unit change."""
    jac = np.asarray(jac, float)
    if jac.size == 0:
        return np.zeros(jac.shape[1] if jac.ndim == 2 else 0)
    rms = np.sqrt(np.mean(np.where(np.isfinite(jac), jac, 0.0) ** 2, axis=0))
    scale = np.array([1.0 if p.log_scale else (abs(p.value) if p.value != 0 else 1.0) for p in params.free()])
    return rms * scale


def zero_sensitivity(jac: np.ndarray, params: ParamSet) -> list[int]:
    """Indices (among the free parameters) whose sensitivity is zero for practical purposes (see the thresholds
    above). Such a parameter cannot be estimated, however small its standard error comes out (with a perfect
    fit the error is 0 times anything)."""
    s = sensitivities(jac, params)
    if s.size == 0:
        return []
    top = float(np.max(s))
    return [i for i, v in enumerate(s) if v <= SENSITIVITY_ABS_MIN or v <= SENSITIVITY_REL_MIN * top]


def correlation(cov: np.ndarray) -> np.ndarray:
    d = np.sqrt(np.abs(np.diag(cov)))
    with np.errstate(invalid="ignore", divide="ignore"):
        c = cov / np.outer(d, d)
    c[~np.isfinite(c)] = np.nan
    return c


@dataclasses.dataclass
class FitResult:
    """What every fit returns (serialisable with :meth:`uncertainty_yaml`).

    Attributes
    ----------
    params : fitted parameters, with ``stderr`` and ``identifiable`` set on the free ones
    free_names : names of the parameters that were estimated (identifiable ones only)
    cov : covariance of ``free_names`` in value units
    corr : correlation matrix of ``free_names``
    residual : final residual vector (the unit of the data)
    n_obs, n_eff : sample size and effective sample size
    success, message, nfev : optimiser status
    held : parameters found not identifiable, with the reason: held at their prior value, or where the fit with
        them free left them when the data reject the prior (the note says which)
    """

    params: ParamSet
    free_names: list[str]
    cov: np.ndarray
    corr: np.ndarray
    residual: np.ndarray
    n_obs: int
    n_eff: float
    success: bool
    message: str
    nfev: int
    held: dict[str, str] = dataclasses.field(default_factory=dict)
    method: str = UNCERTAINTY_METHOD
    #: per estimated parameter, the held ones it was correlated with (|r| >= CONDITIONAL_CORR) while they were
    #: free: its standard error is conditional on their prior values (see :func:`conditional_on_held`)
    conditional: dict[str, dict[str, float]] = dataclasses.field(default_factory=dict)

    @property
    def rmse(self) -> float:
        r = self.residual[np.isfinite(self.residual)]
        return float(np.sqrt(np.mean(r**2))) if r.size else float("nan")

    def uncertainty_yaml(self) -> dict:
        return {
            "method": self.method,
            "n_obs": int(self.n_obs),
            "n_eff": float(round(self.n_eff, 3)),
            "parameters": list(self.free_names),
            "correlation": [[None if not np.isfinite(v) else round(float(v), 4) for v in row] for row in self.corr],
            "not_identifiable": dict(self.held),
            "converged": bool(self.success),
            "optimizer_message": str(self.message),
            "nfev": int(self.nfev),
        }


def _value_space_cov(params: ParamSet, cov_x: np.ndarray) -> np.ndarray:
    scale = np.array([p.value if p.log_scale else 1.0 for p in params.free()])
    return cov_x * np.outer(scale, scale)


#: a held parameter correlated at least this much with an estimated one makes that one's standard error conditional
CONDITIONAL_CORR = 0.9
#: how a refit that does not check identifiability marks a free parameter whose standard error fails the verdict
#: (the next refit that judges it otherwise drops the note: a stale verdict beside a new standard error misleads)
UNCHECKED_NOTE = "(estimated, not held: this refit does not check identifiability)"


def correlated_with(names: Sequence[str], corr: np.ndarray, held: str) -> dict[str, float]:
    """The other parameters of ``names`` correlated with ``held`` (|r| >= :data:`CONDITIONAL_CORR`) in ``corr``."""
    names = list(names)
    if held not in names or corr.size == 0:
        return {}
    i = names.index(held)
    return {n: float(corr[i, j]) for j, n in enumerate(names)
            if j != i and np.isfinite(corr[i, j]) and abs(corr[i, j]) >= CONDITIONAL_CORR}


def conditional_on_held(params: ParamSet, free_names: Sequence[str], links: dict[str, dict[str, float]],
                        at_fit: Sequence[str] = ()) -> ParamSet:
    """Say, on each estimated parameter, which held parameters its standard error is conditional on.

    ``links`` maps a held parameter to the estimated ones it was correlated with while it was free. Holding it at
    its prior value fixes the combination the data determine, so the estimate's standard error assumes the prior
    value is right: a muscle whose held constant differs from the prior shifts the estimate by more than that
    error. The note says so; the value and standard error are unchanged."""
    per: dict[str, dict[str, float]] = {}
    for h, others in links.items():
        for n, r in others.items():
            if n in free_names and n != h:
                per.setdefault(n, {})[h] = r
    out = params
    for n, hs in per.items():
        p = out[n]
        if p.fixed or p.stderr is None:
            continue
        which = ", ".join(f"{h} (r = {r:+.3f} while it was free)" for h, r in hs.items())
        where = ("where the free fit left it" if all(h in at_fit for h in hs) else
                 "at its prior value" if not any(h in at_fit for h in hs) else "at its value")
        other = "at another value" if any(h in at_fit for h in hs) else "other than the prior"
        note = (f"{identifiability.CONDITIONAL} {which} {where}: the data determine a "
                f"combination of them, so a {', '.join(hs)} {other} moves this constant by more "
                f"than its standard error")
        # a refit of the same parameters says it again: the note replaces an earlier one, never repeats it
        kept = [part for part in (p.note or "").split("; ") if part and not part.startswith(identifiability.CONDITIONAL)]
        out = out.replace(n, note="; ".join(kept + [note]))
    return out


def fit_least_squares(residual_fn: Callable[[ParamSet], np.ndarray], params: ParamSet, *,
                      segments: Sequence[int] | None = None, check_identifiability: bool = True,
                      rel_se_max: float = 0.5, corr_max: float = 0.995, max_nfev: int | None = None,
                      diff_step: float | None = None, loss: str = "linear", f_scale: float = 1.0,
                      xtol: float = 1e-10, ftol: float = 1e-10,
                      held_links: dict[str, dict[str, float]] | None = None,
                      prior_from_data: bool = False) -> FitResult:
    """Least squares over the free parameters of ``params``.

    Parameters
    ----------
    residual_fn : ParamSet -> (N,) residual (model minus data, in the data's unit); must be finite
    params : starting values, bounds, which are fixed. Starting values double as the prior values
        that a non-identifiable parameter is held at.
    segments : per-log residual lengths for the effective sample size
    check_identifiability : hold non-identifiable parameters at their prior and refit
    rel_se_max, corr_max : thresholds of the identifiability verdict
    held_links : for parameters a caller already holds (fixed in ``params``), the free ones each was correlated
        with (:func:`correlated_with`), so that their standard errors are said to be conditional too
    prior_from_data : the starting values are a start computed from the same data (a baseline's equation-error
        fit), not prior knowledge: a parameter whose hold at its start the data reject (likelihood ratio above
        :data:`HOLD_LR_MAX`) is held where the fit with it free left it instead, and its note says so
    """
    prior = params
    held: dict[str, str] = {}
    at_fit: dict[str, str] = {}   # held where the free fit left it: holding it at its prior, the data rejected
    links: dict[str, dict[str, float]] = dict(held_links or {})
    current = params
    last = None                   # (name held last, its fitted value, the fit before the hold: cost, n_eff, n)
    for _round in range(2 * len(params) + 2):
        free = current.free()
        if not free:
            r = np.asarray(residual_fn(current), float)
            if prior_from_data and last is not None and last[0] not in at_fit and hold_rejected(r, last[2]):
                current = _hold_at_fit(current, last, r, at_fit, held)
                continue
            res = FitResult(_held_notes(current, held, at_fit), [], np.zeros((0, 0)), np.zeros((0, 0)), r, r.size,
                            effective_sample_size(r, segments), True, "no free parameters", 1, held)
            return res
        x0 = current.free_vector()
        lo, hi = current.free_bounds()
        x0 = np.clip(x0, np.nextafter(lo, np.inf), np.nextafter(hi, -np.inf))

        def fun(x, _cur=current):
            r = np.asarray(residual_fn(_cur.with_free_vector(x)), float)
            if not np.all(np.isfinite(r)):
                r = np.where(np.isfinite(r), r, 1e6)
            return r

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            sol = least_squares(fun, x0, bounds=(lo, hi), x_scale="jac", loss=loss, f_scale=f_scale,
                                max_nfev=max_nfev, diff_step=diff_step, xtol=xtol, ftol=ftol, gtol=1e-10)
        fitted = current.with_free_vector(sol.x)
        r = sol.fun
        if prior_from_data and last is not None and last[0] not in at_fit and hold_rejected(r, last[2]):
            current = _hold_at_fit(current, last, r, at_fit, held)
            continue
        n_eff = effective_sample_size(r, segments)
        cov_x = covariance_from_jacobian(sol.jac, r, n_eff)
        cov = _value_space_cov(fitted, cov_x)
        se = np.sqrt(np.abs(np.diag(cov)))
        corr = correlation(cov)
        names = fitted.free_names()
        bad: dict[str, str] = {}
        insensitive = zero_sensitivity(sol.jac, fitted)
        for i in insensitive:  # never "estimated", identifiability check or not: the data say nothing about it
            bad[names[i]] = zero_sensitivity_verdict(fitted[names[i]], fitted[names[i]].value)
        judged = identifiability.judge_fit(names, [fitted[n].value for n in names], se, corr, sol.x, lo, hi,
                                           rel_se_max=rel_se_max, corr_max=corr_max)
        if check_identifiability:
            for name, why in judged.items():  # a zero-sensitivity verdict stands
                bad.setdefault(name, why)
        if not bad:
            out = fitted
            for i, name in enumerate(names):
                out = out.replace(name, stderr=float(se[i]) if np.isfinite(se[i]) else None, identifiable=True)
                if name in judged:   # unchecked (a refit that holds nothing): free, but never read as identifiable
                    out = out.replace(name, identifiable=False,
                                      note=f"not identifiable: {judged[name]} {UNCHECKED_NOTE}")
                elif UNCHECKED_NOTE in (out[name].note or ""):   # an earlier refit's verdict, not this one's
                    out = out.replace(name, note="; ".join(part for part in out[name].note.split("; ")
                                                           if UNCHECKED_NOTE not in part))
            out = _held_notes(out, held, at_fit)
            out = conditional_on_held(out, names, links, at_fit)
            return FitResult(out, names, cov, corr, r, r.size, n_eff, bool(sol.success), str(sol.message),
                             int(sol.nfev), held, conditional=links)
        # hold the worst offender at its prior value and refit (one at a time: the others may recover)
        worst = max(bad, key=lambda n: (2 if bad[n].startswith(ZERO_SENSITIVITY) else 0 if "correlated" in bad[n] else 1,
                                        se[names.index(n)] / max(abs(fitted[n].value), 1e-300)))
        held[worst] = bad[worst]
        links[worst] = correlated_with(names, corr, worst)
        last = (worst, fitted[worst].value, (float(r @ r), n_eff, r.size))
        current = fitted.replace(worst, value=prior[worst].value, fixed=True)
    raise RuntimeError("identifiability loop did not terminate")  # pragma: no cover


#: a hold at the prior is rejected by the data when the likelihood ratio of the fit with the parameter free over
#: the fit with it held (on the effective sample size, one degree of freedom) exceeds this: chi2(1) at p = 0.001
HOLD_LR_MAX = 10.83


def hold_rejected(r_held: np.ndarray, before: tuple[float, float, int]) -> bool:
    """True when holding a parameter at its prior raised the fit error by more than the data allow: a
    correlated parameter's prior (often an equation-error start) can sit far off the ridge its partner follows,
    and the refit cannot make up for it (a two-branch rational fit went from 0.5 to 7 deg that way)."""
    cost0, n_eff0, n0 = before
    cost1 = float(r_held @ r_held)
    if not (np.isfinite(cost1) and cost0 > 0 and n0 > 0):
        return False
    lr = max(n_eff0, 1.0) * math.log(max(cost1, cost0) / cost0)
    return lr > HOLD_LR_MAX


def _hold_at_fit(current: ParamSet, last: tuple, r_held: np.ndarray, at_fit: dict, held: dict) -> ParamSet:
    """Hold ``last``'s parameter where the free fit left it instead of at its prior (said in its note)."""
    name, value, (cost0, _n_eff0, n0) = last
    rms0, rms1 = math.sqrt(cost0 / n0), math.sqrt(float(r_held @ r_held) / r_held.size)
    at_fit[name] = (f"held where the fit with it free left it: at its prior {current[name].value:.6g} the fit "
                    f"error rose from {rms0:.4g} to {rms1:.4g}, which the data reject")
    return current.replace(name, value=value, fixed=True)


def _held_notes(params: ParamSet, held: dict, at_fit: dict) -> ParamSet:
    for name, why in held.items():
        where = at_fit.get(name, "held at prior value")
        params = params.replace(name, stderr=None, identifiable=False, note=f"not identifiable: {why}; {where}")
    return params


#: an R^2 at or below this is "none of the variation explained" (a constant at the data's mean gives 0 up to rounding)
R2_MIN = 1e-6


def check_explained(y, y_hat, *, quantity: str, unit: str, paths=(), hint: str = "") -> float:
    """Refuse (InputError) a fit that explains none of the variation of the data: R^2 <= 0 (up to
    :data:`R2_MIN`) or not a number.

    Such a fit's constants are not measurements, whatever their standard errors say: either the data barely
    vary (a constant-pressure or constant-stress log: R^2 is then 0/0 or a huge negative number) or the model
    does worse than the mean. Returns R^2 when it is positive.

    Parameters
    ----------
    y, y_hat : data and fit, pooled over the logs (same unit)
    quantity, unit : words for the message ("angle", "deg")
    paths : the logs (named in the message; the only one becomes the message's file)
    hint : what the user can do
    """
    y = np.asarray(y, float)
    y_hat = np.asarray(y_hat, float)
    ok = np.isfinite(y) & np.isfinite(y_hat)
    yy, yh = y[ok], y_hat[ok]
    ss_tot = float(np.sum((yy - yy.mean()) ** 2)) if yy.size else 0.0
    ss_res = float(np.sum((yy - yh) ** 2)) if yy.size else math.nan
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else math.nan
    if r2 > R2_MIN:
        return r2
    paths = [p for p in paths if p is not None]
    spread = float(np.ptp(yy)) if yy.size else 0.0
    scale = max(float(np.max(np.abs(yy))) if yy.size else 0.0, 1e-300)
    if spread <= 1e-9 * scale or ss_tot == 0:
        why = (f"the measured {quantity} does not vary (range {spread:.3g} {unit}), so no fit can be judged "
               "against it and its dynamic constants are not determined")
    else:
        why = (f"the fit explains none of the variation of the {quantity} (R^2 = {r2:.3g} <= 0; RMSE "
               f"{math.sqrt(ss_res / max(yy.size, 1)):.3g} {unit} against a spread of {spread:.3g} {unit}): its "
               "constants are not estimates")
    from bpmid.errors import InputError

    where = paths[0] if len(paths) == 1 else None
    logs = "" if len(paths) <= 1 else f" (logs: {', '.join(str(p) for p in paths[:4])}{', ...' if len(paths) > 4 else ''})"
    raise InputError(why + logs + (f"; {hint}" if hint else ""), path=where)

