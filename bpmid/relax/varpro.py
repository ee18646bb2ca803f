"""Variable projection for sums of non-negative exponential-type columns.

A model is y ~ A(theta) c with c >= 0, where theta = log(tau) (one entry per Prony term) and the
columns of A are either fixed (the E_inf column) or depend on one entry of theta each. For given
theta the moduli c come from non-negative least squares (NNLS); theta is refined by nonlinear least
squares on the projected residual r(theta) = y - A(theta) c(theta), with Kaufman's approximation of
its Jacobian. Time constants live in log space because they span many decades.

The start does not depend on luck: NNLS on a dense log-spaced grid of time constants gives a sparse
support; neighbouring grid points of that support are merged into one term each; a path of models
with fewer terms (drop the term whose loss costs least, refine) and more terms (insert the new time
constant that helps most, refine) then gives one refined model per candidate number of terms.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Callable

import numpy as np

# the projection itself (NNLS inner solve, Kaufman refinement) is the package's one variable projection
from bpmid.varpro import Basis, VPSolution, evaluate, refine, solve_nnls  # noqa: F401  (re-exported)


def _drop_dead(sol: VPSolution, nf: int) -> np.ndarray:
    """Time constants whose modulus is not exactly zero (NNLS zeros are dead terms)."""
    return sol.theta[sol.coef[nf:] > 0]


def grid_start(basis: Basis, y: np.ndarray, bounds: tuple[float, float], per_decade: int) -> np.ndarray:
    """NNLS on a dense log-spaced grid; neighbouring support points merged into one term each.

    Returns
    -------
    (m0,) log time constants, ascending (moduli-weighted mean of each merged cluster)
    """
    n = max(int(math.ceil((bounds[1] - bounds[0]) / math.log(10.0) * per_decade)) + 1, 2)
    grid = np.linspace(bounds[0], bounds[1], n)
    A, _ = basis.columns(grid, False)
    c = solve_nnls(A, y)[basis.n_fixed:]
    # weight clusters by each column's contribution (coefficient x column norm), not the bare coefficient
    w = c * np.linalg.norm(A[:, basis.n_fixed:], axis=0)
    idx = np.flatnonzero(c > 0)
    if idx.size == 0:
        return np.array([0.5 * (bounds[0] + bounds[1])])
    groups = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
    return np.array([np.average(grid[g], weights=w[g]) for g in groups])


def _screen_drops(basis: Basis, y: np.ndarray, theta: np.ndarray) -> np.ndarray | None:
    """For every term j, the NNLS residual (squared) of the design without column j, up to one constant shared by
    all j: from one thin QR of the whole design, ||A_-j c - y||^2 = ||R_-j c - Q^T y||^2 + ||(I - QQ^T) y||^2, so
    each candidate costs a small (p x p-1) NNLS instead of a QR of the tall design. None when the design is not
    tall enough for the QR route (the inner solve then works on the design itself) or a small solve fails."""
    from scipy.optimize import nnls

    A, _ = basis.columns(theta, False)
    n, p = A.shape
    if n <= 4 * p:
        return None
    norm = np.linalg.norm(A, axis=0)
    norm[norm == 0] = 1.0
    q, r = np.linalg.qr(A / norm, mode="reduced")
    qty = q.T @ y
    cols = np.arange(p)
    out = np.empty(theta.size)
    try:
        for j in range(theta.size):
            _, rn = nnls(r[:, cols != basis.n_fixed + j], qty, maxiter=50 * (p - 1))
            out[j] = rn * rn
    except (RuntimeError, ValueError):
        return None
    return out


#: candidates whose screened SSE is within this share of sum(y^2) (or 1e-6 of the best) of the best one are
#: evaluated exactly, so the choice is the one the exact evaluation of every candidate makes (the screening's
#: rounding error is about 1e-16 of sum(y^2))
_SCREEN_MARGIN = 1e-9


def drop_one(basis: Basis, y: np.ndarray, sol: VPSolution) -> np.ndarray:
    """The m-1 time constants left after removing the term whose loss raises the SSE least.

    Every candidate is screened from one QR of the whole design (:func:`_screen_drops`); those within a margin
    of the best screened value are evaluated exactly and the first with the least SSE wins, as when every
    candidate is evaluated exactly (the fallback when screening is not possible)."""
    idx = range(sol.m)
    screened = _screen_drops(basis, y, sol.theta) if sol.m > 1 else None
    if screened is not None:
        lo = float(screened.min())
        tol = _SCREEN_MARGIN * float(y @ y) + 1e-6 * lo
        idx = [j for j in range(sol.m) if screened[j] <= lo + tol]
    best, best_sse = None, np.inf
    for j in idx:
        th = np.delete(sol.theta, j)
        s = evaluate(basis, y, th).sse
        if s < best_sse:
            best, best_sse = th, s
    return best


def add_one(basis: Basis, y: np.ndarray, sol: VPSolution, bounds: tuple[float, float]) -> np.ndarray:
    """The m+1 time constants after inserting the new one (gap midpoints and ends) that helps most."""
    th = np.sort(sol.theta)
    edges = np.concatenate(([bounds[0]], th, [bounds[1]]))
    cands = 0.5 * (edges[1:] + edges[:-1])
    # also splits of each existing term, for curves that need two close time constants
    cands = np.concatenate((cands, th - 0.3, th + 0.3))
    cands = np.clip(cands, bounds[0] + 1e-6, bounds[1] - 1e-6)
    best, best_sse = None, np.inf
    for c in cands:
        trial = np.sort(np.append(th, c))
        s = evaluate(basis, y, trial).sse
        if s < best_sse:
            best, best_sse = trial, s
    return best


def model_path(basis: Basis, y: np.ndarray, bounds: tuple[float, float], *, per_decade: int,
               m_min: int, m_max: int, score: Callable[[VPSolution], float] | None = None,
               patience: int = 3, max_nfev: int = 200,
               on_step: Callable[[int], None] | None = None) -> dict[int, VPSolution]:
    """Refined models for numbers of terms between ``m_min`` and ``m_max``.

    The grid start gives m0 terms. Above ``m_max`` terms are dropped greedily without refinement
    (cheap); from there the path goes down to ``m_min`` and up to ``m_max``, refining every model.
    With a ``score`` (lower is better, e.g. an information criterion) a direction stops after
    ``patience`` consecutive models that do not beat the best score so far.

    Parameters
    ----------
    m_min, m_max : range of numbers of terms (1 <= m_min <= m_max)
    score : VPSolution -> float, or None to visit the whole range
    on_step : called with the number of terms after each refinement (progress)

    Returns
    -------
    dict m -> VPSolution for the numbers of terms visited. A refinement in which NNLS sets some
    moduli to zero is reported under its number of live terms.
    """
    nf = basis.n_fixed
    theta = grid_start(basis, y, bounds, per_decade)
    cur = evaluate(basis, y, theta)
    while cur.m > m_max:
        cur = evaluate(basis, y, drop_one(basis, y, cur))
    out: dict[int, VPSolution] = {}

    def keep(s: VPSolution) -> VPSolution:
        live = _drop_dead(s, nf)
        if live.size < s.m:
            s = dataclasses.replace(evaluate(basis, y, live), nfev=s.nfev)
        if s.m >= 1 and (s.m not in out or s.sse < out[s.m].sse):
            out[s.m] = s
        if on_step:
            on_step(s.m)
        return s

    top = keep(refine(basis, y, cur.theta, bounds, max_nfev=max_nfev))

    def walk(step) -> None:
        c = top
        best = score(c) if score else -np.inf
        worse = 0
        while True:
            nxt = step(c)
            if nxt is None:
                return
            nxt = keep(refine(basis, y, nxt, bounds, max_nfev=max_nfev))
            if nxt.m == c.m:  # the new term died in the refinement
                return
            c = nxt
            if score:
                v = score(c)
                if v < best:
                    best, worse = v, 0
                else:
                    worse += 1
                    if worse >= patience:
                        return

    walk(lambda c: drop_one(basis, y, c) if c.m > m_min else None)
    walk(lambda c: add_one(basis, y, c, bounds) if c.m < m_max else None)
    return {m: s for m, s in out.items() if m_min <= m <= m_max}
