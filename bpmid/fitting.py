"""One least-squares driver for every model family, with honest uncertainties.

- :func:`fit_least_squares` minimises a residual vector over the free parameters of a
  :class:`~bpmid.params.ParamSet` (bounds, log-scaled parameters) with ``scipy.optimize.least_squares``.
- Standard errors come from the Jacobian at the optimum, inflated for autocorrelated residuals by
  the ratio N / N_eff, where N_eff = sum over logs of n (1 - rho1) / (1 + rho1) (rho1: lag-1
  autocorrelation of that log's residual). This is the "effective sample size" method; it is named in
  every output (:data:`UNCERTAINTY_METHOD`).
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
    held : parameters found not identifiable, held at their prior value, with the reason
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


def fit_least_squares(residual_fn: Callable[[ParamSet], np.ndarray], params: ParamSet, *,
                      segments: Sequence[int] | None = None, check_identifiability: bool = True,
                      rel_se_max: float = 0.5, corr_max: float = 0.995, max_nfev: int | None = None,
                      diff_step: float | None = None, loss: str = "linear", f_scale: float = 1.0,
                      xtol: float = 1e-10, ftol: float = 1e-10) -> FitResult:
    """Least squares over the free parameters of ``params``.

    Parameters
    ----------
    residual_fn : ParamSet -> (N,) residual (model minus data, in the data's unit); must be finite
    params : starting values, bounds, which are fixed. Starting values double as the prior values
        that a non-identifiable parameter is held at.
    segments : per-log residual lengths for the effective sample size
    check_identifiability : hold non-identifiable parameters at their prior and refit
    rel_se_max, corr_max : thresholds of the identifiability verdict
    """
    prior = params
    held: dict[str, str] = {}
    current = params
    for _round in range(len(params) + 1):
        free = current.free()
        if not free:
            r = np.asarray(residual_fn(current), float)
            res = FitResult(current, [], np.zeros((0, 0)), np.zeros((0, 0)), r, r.size,
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
        n_eff = effective_sample_size(r, segments)
        cov_x = covariance_from_jacobian(sol.jac, r, n_eff)
        cov = _value_space_cov(fitted, cov_x)
        se = np.sqrt(np.abs(np.diag(cov)))
        corr = correlation(cov)
        names = fitted.free_names()
        bad: dict[str, str] = {}
        if check_identifiability:
            bad = identifiability.judge_fit(names, [fitted[n].value for n in names], se, corr, sol.x, lo, hi, rel_se_max=rel_se_max, corr_max=corr_max)
        if not bad:
            out = fitted
            for i, name in enumerate(names):
                out = out.replace(name, stderr=float(se[i]) if np.isfinite(se[i]) else None, identifiable=True)
            for name, why in held.items():
                out = out.replace(name, stderr=None, identifiable=False, note=f"not identifiable: {why}; held at prior value")
            return FitResult(out, names, cov, corr, r, r.size, n_eff, bool(sol.success), str(sol.message),
                             int(sol.nfev), held)
        # hold the worst offender at its prior value and refit (one at a time: the others may recover)
        worst = identifiability.worst(bad, names, [fitted[n].value for n in names], se)
        held[worst] = bad[worst]
        current = fitted.replace(worst, value=prior[worst].value, fixed=True)
    raise RuntimeError("identifiability loop did not terminate")  # pragma: no cover
