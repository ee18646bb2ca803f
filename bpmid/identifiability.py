"""Identifiability, written once: when the data do not determine a fitted constant, and why.

A fitted constant is *not identifiable* (reported, never as measured, and held at its prior value where
the fit is repeated without it) when

1. its standard error is not finite (a singular Jacobian: the data carry no information on it);
2. its relative standard error ``se / |value|`` is above ``rel_se_max`` (0.5 by default);
3. the fit ran onto one of its bounds (the optimum is not interior, the standard error means nothing);
4. its correlation with another fitted constant is above ``corr_max`` in absolute value (0.995 by
   default): of the strongest such pair the one with the larger relative error goes.

Rules 1-3 are judged per parameter, rule 4 once the others pass. Users:

- :func:`bpmid.fitting.fit_least_squares` -> :func:`judge_fit` (every nonlinear fit: VBMM, baselines,
  discovery), holding the worst offender (:func:`worst`) and refitting until none is left;
- :func:`bpmid.discover.confirm.own_identifiability` -> :func:`judge_own` (a candidate effect's own
  constants, each judged against every other constant: rule 4 per parameter, no refit);
- the VBMM's linear start (:mod:`bpmid.models.vbmm.fit`) and :func:`bpmid.varpro.fit_variable_projection`
  use the pieces (:func:`strongest_pair`, :data:`NOT_FINITE`, :data:`AT_ZERO_BOUND`).
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

#: rule 1 (nonlinear fits: the Jacobian is singular in that direction)
SINGULAR = "the data do not determine it (singular Jacobian)"
#: rule 1 as the variable projection reports it (joint covariance of the outer and linear constants)
NOT_FINITE = "not identifiable: its standard error is not finite (singular covariance)"
#: rule 3
ON_BOUND = "the fit ran onto a bound"
#: rule 3 for a linear coefficient constrained >= 0 (variable projection)
AT_ZERO_BOUND = "at its non-negativity bound 0 (the data give it no weight)"


def relative_se(se: float, value: float) -> float:
    """``se / |value|`` (infinite for a zero value)."""
    return se / abs(value) if value != 0 else math.inf


def on_bound(x: float, lo: float, hi: float, tol: float) -> bool:
    """Whether ``x`` is within ``tol`` of a finite bound."""
    return bool((np.isfinite(lo) and x - lo <= tol) or (np.isfinite(hi) and hi - x <= tol))


def rel_text(rel: float, cap: float | None = 10.0) -> str:
    """A relative error as a percentage (``>1000%`` at or above ``cap``; ``cap=None``: always in full)."""
    return f"{rel:.0%}" if cap is None or rel < cap else ">1000%"


#: how a fit's note says that an estimate's standard error assumes a held constant's prior value
CONDITIONAL = "standard error conditional on the held"


def conditional_caveat(note: str | None) -> str:
    """The caveat a note carries (``"standard error conditional on the held tau_1 (r = ...) at its prior value"``),
    or "" when it carries none."""
    k = (note or "").find(CONDITIONAL)
    return "" if k < 0 else note[k:].split(":")[0]


def judge(se: float, rel: float, *, rel_se_max: float, bound: bool = False, cap: float | None = 10.0) -> str | None:
    """Rules 1-3 for one parameter: the reason it is not identifiable, or None."""
    if not np.isfinite(se):
        return SINGULAR
    if rel > rel_se_max:
        return f"relative standard error {rel_text(rel, cap)} > {rel_se_max:.0%}"
    if bound:
        return ON_BOUND
    return None


def strongest_pair(abs_offdiag: np.ndarray, rel: Sequence[float], corr_max: float) -> tuple[int, int, int, int] | None:
    """Rule 4: of the most strongly correlated pair (if above ``corr_max``) the one to hold.

    Parameters
    ----------
    abs_offdiag : (n, n) absolute correlations with the diagonal removed
    rel : (n,) relative standard errors (the larger one of the pair goes)

    Returns
    -------
    (k, other, i, j): the index to hold, its partner, and the pair (i, j) as found; None if no pair
    exceeds ``corr_max``.
    """
    i, j = np.unravel_index(np.argmax(abs_offdiag), abs_offdiag.shape)
    if not abs_offdiag[i, j] > corr_max:
        return None
    k = i if rel[i] >= rel[j] else j
    return int(k), int(j if k == i else i), int(i), int(j)


def judge_fit(names: Sequence[str], values: Sequence[float], se: np.ndarray, corr: np.ndarray, x: np.ndarray,
              lo: np.ndarray, hi: np.ndarray, *, rel_se_max: float, corr_max: float) -> dict[str, str]:
    """Rules 1-4 for the free parameters of one nonlinear fit.

    ``x``, ``lo``, ``hi`` are the optimiser's coordinates and bounds (the bound test is done there, with a
    tolerance of 1e-6 of the span, at least 1e-6); ``values``, ``se`` and ``corr`` are in value space.
    Returns {name: reason} (empty: every parameter is identifiable).
    """
    bad: dict[str, str] = {}
    span = hi - lo
    for i, name in enumerate(names):
        tol = 1e-6 * max(1.0, abs(span[i]) if np.isfinite(span[i]) else 1.0)
        why = judge(se[i], relative_se(se[i], values[i]), rel_se_max=rel_se_max, bound=on_bound(x[i], lo[i], hi[i], tol))
        if why:
            bad[name] = why
    if not bad and len(names) > 1:
        c = np.abs(np.nan_to_num(corr, nan=0.0)) - np.eye(len(names))
        rel = [se[i] / max(abs(values[i]), 1e-300) for i in range(len(names))]
        pair = strongest_pair(c, rel, corr_max)
        if pair:
            k, other, i, j = pair
            bad[names[k]] = f"correlated with {names[other]} (r = {corr[i, j]:+.3f})"
    return bad


def worst(bad: dict[str, str], names: Sequence[str], values: Sequence[float], se: np.ndarray) -> str:
    """The parameter to hold first: any rule-1-3 offender before a correlated one, then the largest
    relative error (one at a time: the others may recover once it is held)."""
    return max(bad, key=lambda n: (0 if "correlated" in bad[n] else 1,
                                   se[names.index(n)] / max(abs(values[names.index(n)]), 1e-300)))


def judge_own(res, names: Sequence[str], *, rel_se_max: float, corr_max: float) -> dict[str, str]:
    """Rules 1-4 for the named parameters of a finished fit (a :class:`bpmid.fitting.FitResult`), each judged
    on its own (no refit): rule 4 flags a parameter correlated above ``corr_max`` with any other fitted
    constant. Bounds are tested in value space (tolerance 1e-6 of a finite span, else of max(|value|, 1));
    relative errors print in full. Returns {name: reason}."""
    bad = {}
    free = list(res.free_names)
    for nm in names:
        if nm not in free:
            continue
        i = free.index(nm)
        p = res.params[nm]
        se = math.sqrt(abs(res.cov[i, i])) if np.isfinite(res.cov[i, i]) else math.inf
        span = p.upper - p.lower
        tol = 1e-6 * (span if np.isfinite(span) else max(abs(p.value), 1.0))
        why = judge(se, relative_se(se, p.value), rel_se_max=rel_se_max, bound=on_bound(p.value, p.lower, p.upper, tol),
                    cap=None)
        if why:
            bad[nm] = why
        else:
            c = np.abs(np.nan_to_num(res.corr[i], nan=0.0))
            c[i] = 0.0
            if c.size and c.max() > corr_max:
                j = int(np.argmax(c))
                bad[nm] = f"correlated with {free[j]} (r = {res.corr[i, j]:+.3f})"
    return bad
