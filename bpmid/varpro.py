"""Variable projection, written once: a least-squares model linear in some coefficients and nonlinear in
the others, with the linear ones solved inside for every trial of the nonlinear ones (Golub and Pereyra).

Inner solves (the coefficients for a given design matrix; columns scaled to unit norm first, since they
differ by orders of magnitude):

- :func:`solve_linear`: bounded least squares (BVLS) with a chosen subset of coefficients >= 0;
- :func:`solve_nnls`: every coefficient >= 0 (NNLS through a thin QR of a tall design).

Outer drivers (the nonlinear parameters):

- :func:`fit_variable_projection`: any model given as ``ParamSet -> design``; the outer parameters go
  through the shared driver :func:`bpmid.fitting.fit_least_squares` (its Jacobian by differences), and
  the result is an ordinary :class:`bpmid.fitting.FitResult` with standard errors from the joint Jacobian
  (used by the GPI and Maxwell-slip baselines);
- :func:`refine`: a :class:`Basis` whose term columns each depend on one log time constant, refined with
  Kaufman's approximation of the projected Jacobian (analytic; used by the relaxation fits, whose
  term-number search lives in :mod:`bpmid.relax.varpro`).
"""
from __future__ import annotations

import dataclasses
from typing import Callable, Protocol, Sequence

import numpy as np
from scipy.optimize import least_squares, lsq_linear, nnls

from bpmid import identifiability
from bpmid.fitting import FitResult, correlation, covariance_from_jacobian, effective_sample_size, fit_least_squares
from bpmid.params import ParamSet


def _column_norms(design: np.ndarray) -> np.ndarray:
    """Euclidean norm of every column (zero columns: 1), to scale the inner solve."""
    norm = np.linalg.norm(design, axis=0)
    norm[norm == 0] = 1.0
    return norm


def solve_linear(design: np.ndarray, y: np.ndarray, nonneg: np.ndarray) -> np.ndarray:
    """Least-squares coefficients of ``design @ theta ~ y`` with ``theta[nonneg] >= 0``.

    Parameters
    ----------
    design : (N, q) float
    y : (N,) float
    nonneg : (q,) bool

    Returns
    -------
    theta : (q,) float
    """
    lo = np.where(nonneg, 0.0, -np.inf)
    hi = np.full(nonneg.shape, np.inf)
    # columns differ by orders of magnitude (1, v, v^2, deflections): scale them so BVLS is well posed
    norm = _column_norms(design)
    sol = lsq_linear(design / norm, y, bounds=(lo, hi), method="bvls", tol=1e-12)
    return sol.x / norm


def fit_variable_projection(design_fn: Callable[[ParamSet], np.ndarray], y: np.ndarray, params: ParamSet,
                            linear: Sequence[str], nonneg: Sequence[bool], *,
                            segments: Sequence[int] | None = None, **fit_kw) -> FitResult:
    """Fit outer (nonlinear) parameters by least squares with the linear ones solved inside.

    Parameters
    ----------
    design_fn : ParamSet -> (N, q) design matrix (all logs stacked); column j multiplies ``linear[j]``
    y : (N,) measured output (stacked)
    params : every parameter; the free ones not named in ``linear`` are the outer parameters
    linear : names of the q linear coefficients (in column order)
    nonneg : (q,) which linear coefficients are constrained >= 0
    segments : per-log lengths (effective sample size)
    **fit_kw : passed to :func:`bpmid.fitting.fit_least_squares` for the outer fit

    Returns
    -------
    FitResult
        All estimated parameters (outer and linear) with standard errors from the joint Jacobian
        [d residual / d outer, design] at the optimum (covariance_from_jacobian, N_eff inflation).
        Linear coefficients at their zero bound are reported as not identifiable (``held``).
    """
    y = np.asarray(y, float)
    nonneg = np.asarray(nonneg, bool)
    linear = list(linear)
    outer_start = ParamSet(p.replace(fixed=True) if p.name in linear else p for p in params)

    def residual(p: ParamSet) -> np.ndarray:
        a = design_fn(p)
        return a @ solve_linear(a, y, nonneg) - y

    res = fit_least_squares(residual, outer_start, segments=segments, **fit_kw)
    fitted = res.params
    a = design_fn(fitted)
    theta = solve_linear(a, y, nonneg)
    r = a @ theta - y
    outer_names = list(res.free_names)

    # joint Jacobian in value space: central differences for the outer parameters, the design for the rest
    cols = []
    for name in outer_names:
        v = fitted.value(name)
        h = 1e-6 * max(abs(v), 1e-3)
        up = design_fn(fitted.replace(name, value=v + h)) @ theta
        dn = design_fn(fitted.replace(name, value=v - h)) @ theta
        cols.append((up - dn) / (2 * h))
    scale_tol = 1e-12 * max(np.abs(theta).max(initial=0.0), 1.0)
    active = ~(nonneg & (theta <= scale_tol))
    active_idx = np.flatnonzero(active)
    jac = np.column_stack(cols + [a[:, j] for j in active_idx]) if (cols or active_idx.size) else np.zeros((y.size, 0))
    n_eff = effective_sample_size(r, segments)
    norm = np.linalg.norm(jac, axis=0)
    norm[norm == 0] = 1.0
    cov = covariance_from_jacobian(jac / norm, r, n_eff) / np.outer(norm, norm)
    se = np.sqrt(np.abs(np.diag(cov)))
    names = outer_names + [linear[j] for j in active_idx]

    out = fitted
    rel_max = fit_kw.get("rel_se_max", 0.5)
    for i, name in enumerate(names):
        if np.isfinite(se[i]):
            v = float(theta[linear.index(name)]) if name in linear else float(fitted.value(name))
            why = identifiability.judge(float(se[i]), float(se[i]) / max(abs(v), 1e-300), rel_se_max=rel_max)
            # the same rule as every fit's (rule 2), reported: a constant the data barely fix is never read as
            # identifiable, even where the linear solve needs it estimated
            out = out.replace(name, stderr=float(se[i]), identifiable=why is None,
                              note="" if why is None else f"not identifiable: {why} (estimated, not held: the "
                                                          f"linear solve keeps it)")
        else:  # a singular covariance: the data do not fix this constant; never report it as measured
            out = out.replace(name, stderr=None, identifiable=False, note=identifiability.NOT_FINITE)
    held = dict(res.held)
    for j, name in enumerate(linear):
        if active[j]:
            out = out.replace(name, value=float(theta[j]), fixed=False)
        else:
            why = identifiability.AT_ZERO_BOUND
            out = out.replace(name, value=0.0, fixed=False, stderr=None, identifiable=False, note=why)
            held[name] = why
    return FitResult(out, names, cov, correlation(cov), r, r.size, n_eff, bool(res.success),
                     str(res.message), int(res.nfev), held)


class Basis(Protocol):
    """Columns of the design matrix for given log time constants.

    ``columns(theta)`` returns ``(A, dA)``: ``A`` is (N, n_fixed + m) with the ``n_fixed`` fixed
    columns first, then one column per entry of ``theta`` (shape (m,)); ``dA`` is (N, m), the
    derivative of each term column with respect to its own log time constant.
    """

    n_fixed: int

    def columns(self, theta: np.ndarray, derivative: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        ...


@dataclasses.dataclass
class VPSolution:
    """A refined model.

    Attributes
    ----------
    theta : (m,) log time constants (log of s), sorted ascending
    coef : (n_fixed + m,) non-negative coefficients (fixed columns first)
    residual : (N,) data minus model
    sse : float, sum of squared residuals
    nfev : function evaluations of the refinement
    """

    theta: np.ndarray
    coef: np.ndarray
    residual: np.ndarray
    sse: float
    nfev: int = 0

    @property
    def m(self) -> int:
        return int(self.theta.size)


def solve_nnls(A: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Non-negative least squares via a thin QR (the N x p problem becomes p x p)."""
    scale = _column_norms(A)
    As = A / scale
    if A.shape[0] > 4 * A.shape[1]:
        q, r = np.linalg.qr(As, mode="reduced")
        c, _ = nnls(r, q.T @ y, maxiter=50 * A.shape[1])
    else:
        c, _ = nnls(As, y, maxiter=50 * A.shape[1])
    return c / scale


def _project(basis: Basis, y: np.ndarray, theta: np.ndarray, derivative: bool):
    A, dA = basis.columns(theta, derivative)
    c = solve_nnls(A, y)
    return A, dA, c


def evaluate(basis: Basis, y: np.ndarray, theta) -> VPSolution:
    """NNLS moduli and residual for fixed ``theta``."""
    theta = np.sort(np.asarray(theta, float))
    A, _, c = _project(basis, y, theta, False)
    r = y - A @ c
    return VPSolution(theta, c, r, float(r @ r))


def refine(basis: Basis, y: np.ndarray, theta0, bounds: tuple[float, float], *,
           max_nfev: int = 200, tol: float = 1e-10) -> VPSolution:
    """Refine log time constants by variable projection (moduli by NNLS at every step).

    Parameters
    ----------
    basis : design-matrix builder
    y : (N,) data
    theta0 : (m,) starting log time constants
    bounds : (lo, hi) bounds on every log time constant
    """
    theta0 = np.clip(np.sort(np.asarray(theta0, float)), bounds[0] + 1e-9, bounds[1] - 1e-9)
    if theta0.size == 0:
        return evaluate(basis, y, theta0)
    nf = basis.n_fixed
    cache: dict = {}

    def state(th):
        key = th.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = _project(basis, y, th, True)
        return cache[key]

    def fun(th):
        A, _, c = state(th)
        return y - A @ c

    def jac(th):
        A, dA, c = state(th)
        active = np.flatnonzero(c > 0)
        D = dA * c[nf:]
        if active.size:
            q, _ = np.linalg.qr(A[:, active], mode="reduced")
            D = D - q @ (q.T @ D)
        return -D

    sol = least_squares(fun, theta0, jac=jac, bounds=bounds, method="trf", x_scale=1.0,
                        xtol=tol, ftol=tol, gtol=tol, max_nfev=max_nfev)
    out = evaluate(basis, y, sol.x)
    out.nfev = int(sol.nfev)
    return out
