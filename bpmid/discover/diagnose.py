"""Residual diagnostics of a fitted model, and the sensor-noise floor estimated from the data alone.

- :func:`noise_floor`: standard deviation of the measurement noise of the angle, from the second
  difference of the measured angle (robust: median absolute deviation, so the corners of the pressure
  profile do not count). Never from any simulator's truth.
- :func:`whiteness`: normalised autocorrelation r(tau) = R_e(tau)/R_e(0) with bounds +-2.576/sqrt(N).
- :func:`cross_correlation`: residual against the input (pressure) and its rate, Ljung's bounds.
- :func:`conditional_summaries`: residual on rising vs falling pressure, against pressure level, |rate|
  and elapsed time.

Units: degrees for angles and residuals, Pa for pressure, s for time.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from bpmid.io.motion_logs import MotionLog

_Z99 = 2.576


def noise_floor(logs: Sequence[MotionLog]) -> dict:
    """Sensor-noise standard deviation of the measured angle (deg), pooled over ``logs``.

    The second difference of the measured angle removes the signal wherever it is locally linear (ramps,
    holds) and leaves 6 sigma^2 of white noise; the median absolute deviation ignores the few samples at
    the corners of the pressure profile where the signal itself curves. Noise slower than the sampling
    (drift) is not seen: it is part of what a model may be asked to explain.

    Returns
    -------
    dict with ``sigma_deg`` (the floor) and ``per_log`` (name -> deg)
    """
    d2_all, per_log = [], {}
    for lg in logs:
        y = np.asarray(lg.angle_deg, float)
        if y.size < 8:
            continue
        d2 = y[2:] - 2 * y[1:-1] + y[:-2]
        d2_all.append(d2 - np.median(d2))
        per_log[lg.name] = float(1.4826 * np.median(np.abs(d2_all[-1])) / np.sqrt(6.0))
    if not d2_all:
        return {"sigma_deg": float("nan"), "per_log": per_log}
    d2 = np.concatenate(d2_all)
    sigma = float(1.4826 * np.median(np.abs(d2)) / np.sqrt(6.0))
    return {"sigma_deg": sigma, "per_log": per_log}


def autocorrelation(r: np.ndarray, max_lag: int) -> np.ndarray:
    r = np.asarray(r, float) - np.mean(r)
    den = float(np.dot(r, r)) or 1.0
    return np.array([float(np.dot(r[k:], r[:r.size - k])) / den for k in range(max_lag + 1)])


def whiteness(parts: Sequence[np.ndarray], max_lag: int = 20) -> dict:
    """Residual whiteness per log, pooled: share of lags 1..max_lag outside +-2.576/sqrt(N)."""
    outside, total, rho1 = 0, 0, []
    for r in parts:
        r = np.asarray(r, float)
        L = min(max_lag, r.size // 4)
        if L < 1:
            continue
        ac = autocorrelation(r, L)
        bound = _Z99 / np.sqrt(r.size)
        outside += int(np.sum(np.abs(ac[1:]) > bound))
        total += L
        rho1.append(float(ac[1]))
    frac = outside / total if total else float("nan")
    return {"lags_outside_99pct_bounds": frac, "mean_lag1_autocorrelation": float(np.mean(rho1)) if rho1 else float("nan"),
            "white": bool(total and frac <= 0.05)}


def cross_correlation(parts: Sequence[np.ndarray], inputs: Sequence[np.ndarray], max_lag: int = 10) -> dict:
    """Normalised cross-correlation of residual and an input at lags -max_lag..max_lag (input leading at
    positive lag), pooled over logs by sample-weighted mean; Ljung's bound 2.576 / sqrt(N)."""
    lags = np.arange(-max_lag, max_lag + 1)
    acc = np.zeros(lags.size)
    n_tot = 0
    for r, u in zip(parts, inputs):
        r = np.asarray(r, float) - np.mean(r)
        u = np.asarray(u, float) - np.mean(u)
        den = np.sqrt(np.dot(r, r) * np.dot(u, u)) or 1.0
        n = r.size
        for i, k in enumerate(lags):
            if abs(k) >= n:
                continue
            v = np.dot(r[k:], u[:n - k]) if k >= 0 else np.dot(r[:n + k], u[-k:])
            acc[i] += v / den * n
        n_tot += n
    cc = acc / max(n_tot, 1)
    bound = _Z99 / np.sqrt(max(n_tot, 1))
    k = int(np.argmax(np.abs(cc)))
    return {"peak": float(cc[k]), "peak_lag_samples": int(lags[k]), "bound": float(bound),
            "significant": bool(abs(cc[k]) > bound)}


def pressure_rate(log: MotionLog) -> np.ndarray:
    """dP/dt (Pa/s), central differences."""
    return np.gradient(log.pressure_pa, log.time_s)


def conditional_summaries(logs: Sequence[MotionLog], parts: Sequence[np.ndarray]) -> dict:
    """Where the residual sits: rising vs falling pressure, and its correlation with pressure level, |rate|
    and elapsed time (pooled over logs)."""
    rate = np.concatenate([pressure_rate(lg) for lg in logs])
    p = np.concatenate([lg.pressure_pa for lg in logs])
    tel = np.concatenate([lg.time_s - lg.time_s[0] for lg in logs])
    r = np.concatenate([np.asarray(x, float) for x in parts])
    scale = np.percentile(np.abs(rate), 90) if rate.size else 0.0
    moving = np.abs(rate) > 0.05 * scale if scale > 0 else np.zeros(r.size, bool)
    rising, falling = moving & (rate > 0), moving & (rate < 0)

    def corr(a, b):
        if a.size < 3 or np.std(a) == 0 or np.std(b) == 0:
            return 0.0
        return float(np.corrcoef(a, b)[0, 1])

    return {
        "mean_rising_deg": float(np.mean(r[rising])) if rising.any() else 0.0,
        "mean_falling_deg": float(np.mean(r[falling])) if falling.any() else 0.0,
        "mean_held_deg": float(np.mean(r[~moving])) if (~moving).any() else 0.0,
        "mean_deg": float(np.mean(r)) if r.size else 0.0,
        "corr_with_pressure": corr(r, p),
        "corr_with_abs_rate": corr(np.abs(r), np.abs(rate)),
        "corr_with_sign_rate": corr(r, np.sign(rate) * moving),
        "corr_with_elapsed_time": corr(r, tel),
    }


def diagnose(logs: Sequence[MotionLog], parts: Sequence[np.ndarray]) -> dict:
    """All residual diagnostics of one model on ``logs`` (residual = model - measured, deg)."""
    return {
        "rmse_deg": float(np.sqrt(np.mean(np.concatenate(parts) ** 2))),
        "whiteness": whiteness(parts),
        "cross_correlation_pressure": cross_correlation(parts, [lg.pressure_pa for lg in logs]),
        "cross_correlation_pressure_rate": cross_correlation(parts, [pressure_rate(lg) for lg in logs]),
        "conditional": conditional_summaries(logs, parts),
    }
