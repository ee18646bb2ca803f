"""Error metrics: pure functions of (measured, predicted) arrays of the same shape.

Units follow the inputs (degrees in, degrees out); percentages are stated in the name.
NaN samples in either array are ignored pairwise.
"""
from __future__ import annotations

import numpy as np


def _pair(y, y_hat):
    y = np.asarray(y, float).ravel()
    y_hat = np.asarray(y_hat, float).ravel()
    if y.shape != y_hat.shape:
        raise ValueError(f"shape mismatch: {y.shape} vs {y_hat.shape}")
    ok = np.isfinite(y) & np.isfinite(y_hat)
    return y[ok], y_hat[ok]


def rmse(y, y_hat) -> float:
    """Root-mean-square error, in the unit of ``y``."""
    y, y_hat = _pair(y, y_hat)
    return float(np.sqrt(np.mean((y - y_hat) ** 2))) if y.size else float("nan")


def max_abs_err(y, y_hat) -> float:
    """Largest absolute error, in the unit of ``y``."""
    y, y_hat = _pair(y, y_hat)
    return float(np.max(np.abs(y - y_hat))) if y.size else float("nan")


def mape_pct(y, y_hat, floor: float = 0.0) -> float:
    """Mean absolute percentage error (%) over samples with ``|y| > floor``."""
    y, y_hat = _pair(y, y_hat)
    ok = np.abs(y) > floor
    if not np.any(ok):
        return float("nan")
    return float(100.0 * np.mean(np.abs((y[ok] - y_hat[ok]) / y[ok])))


def r2(y, y_hat) -> float:
    """Coefficient of determination 1 - SSE/SST (dimensionless; may be negative)."""
    y, y_hat = _pair(y, y_hat)
    if y.size == 0 or _constant(y):
        return float("nan")   # no variation to explain (a constant angle): undefined, not -4e30 from rounding
    sst = np.sum((y - y.mean()) ** 2)
    return float(1.0 - np.sum((y - y_hat) ** 2) / sst)


def _constant(y: np.ndarray) -> bool:
    """True when ``y`` varies by no more than rounding of its own size (the sum of squares about the mean of a
    constant column is not exactly 0 in floating point)."""
    scale = float(np.max(np.abs(y))) if y.size else 0.0
    return float(np.ptp(y)) <= 1e-12 * max(scale, 1e-300)


def fit_pct(y, y_hat) -> float:
    """Normalised-RMSE fit (%), as in system identification: 100 (1 - ||y - y_hat|| / ||y - mean y||)."""
    y, y_hat = _pair(y, y_hat)
    if y.size == 0 or _constant(y):
        return float("nan")
    den = np.linalg.norm(y - y.mean())
    return float(100.0 * (1.0 - np.linalg.norm(y - y_hat) / den))


def summary(y, y_hat, *, unit: str = "deg") -> dict[str, float]:
    """All metrics at once; keys carry the unit (``rmse_deg``, ``mape_pct``, ``r2``, ``fit_pct``...)."""
    return {
        f"rmse_{unit}": rmse(y, y_hat),
        "mape_pct": mape_pct(y, y_hat),
        "r2": r2(y, y_hat),
        "fit_pct": fit_pct(y, y_hat),
        f"max_abs_err_{unit}": max_abs_err(y, y_hat),
    }
