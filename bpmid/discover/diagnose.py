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

import math
from pathlib import Path
from typing import Sequence

import numpy as np

from bpmid.io.motion_logs import MotionLog

_Z99 = 2.576


#: order of the difference operator and the spacings h the noise model is fitted to
_NOISE_ORDER = 5
_NOISE_SPACINGS = (1, 2, 3, 4)
#: largest lag-1 correlation of the sensor noise the estimator considers (slower than this is drift)
_RHO_MAX = 0.95
#: a log whose own reading exceeds the floor of the logs not at the correlation bound by more than this factor,
#: with its own correlation at the bound, is reading its signal and is left out (one sensor logs every run of a
#: rig, so its noise cannot differ tenfold; on 480 out-of-family calibration cases no log read over 7.6 times the
#: floor: coloured noise alone up to 3.5 times, at 20-100 Hz, and the cyclic logs at 10 Hz 3.5-7.6 times, a leak
#: that moved their floor by 1-3 %)
_SIGNAL_READING_OVER = 10.0
#: such a log reading over this factor is named in the caution but kept
_PINNED_READING_NOTED = 3.0
NOISE_METHOD = ("AR(1)-aware difference estimator: robust (median absolute deviation) variances of the 5th-order "
                "differences of the measured angle at spacings h = 1..4 samples, windows spanning a corner of the "
                "logged pressure left out, fitted with the AR(1) noise model Var_h = sigma^2 sum_ij w_i w_j "
                "rho^|i-j|h: sigma is the noise's marginal standard deviation (the RMSE a perfect model reaches), "
                "rho its lag-1 correlation (0 = white); a log whose own fit puts rho at its bound and reads over "
                f"{_SIGNAL_READING_OVER:g} times the floor of the logs whose fit is not at the bound is reading its "
                "signal (too fast for its sampling) and is left out")


def _diff_weights(order: int) -> np.ndarray:
    return np.array([(-1) ** k * math.comb(order, k) for k in range(order + 1)], float)


def _ar1_factor(rho: float, h: int, w: np.ndarray) -> float:
    """Variance of sum_k w_k e[k h] for unit-variance AR(1) noise with lag-1 correlation rho."""
    off = np.arange(w.size) * h
    return float(w @ (rho ** np.abs(off[:, None] - off[None, :])) @ w)


def _robust_var(x: np.ndarray) -> float:
    if x.size == 0:
        return float("nan")
    x = x - np.median(x)
    return float((1.4826 * np.median(np.abs(x))) ** 2)


def _fit_ar1(v: np.ndarray, hs: Sequence[int], w: np.ndarray) -> tuple[float, float]:
    """(sigma, rho) from robust variances ``v`` of the spaced differences (least squares in log space over a
    fine rho grid)."""
    hs = np.asarray(hs)
    ok = np.isfinite(v) & (v > 0)
    if not ok.any():
        return float("nan"), float("nan")
    if ok.sum() < 2:
        return math.sqrt(v[ok][0] / _ar1_factor(0.0, int(hs[ok][0]), w)), 0.0
    lv, hs = np.log(v[ok]), hs[ok]
    best = (math.inf, float("nan"), 0.0)
    for rho in np.linspace(0.0, _RHO_MAX, 191):
        lf = np.log([_ar1_factor(rho, int(h), w) for h in hs])
        ls2 = float(np.mean(lv - lf))
        cost = float(np.sum((lv - ls2 - lf) ** 2))
        if cost < best[0] - 1e-12:
            best = (cost, math.exp(0.5 * ls2), float(rho))
    return best[1], best[2]


def _pressure_corners(p: np.ndarray, t: np.ndarray | None = None) -> np.ndarray:
    """Samples where the logged pressure changes slope (profile corners), robust to pressure noise. With the
    times ``t`` of an unevenly sampled log, the slope change is taken in time (per median step)."""
    p = np.asarray(p, float)
    c = np.zeros(p.size, bool)
    if p.size < 3:
        return c
    if t is not None and uneven_steps(t):
        dt = np.diff(np.asarray(t, float))
        d2 = np.abs(np.diff(np.diff(p) / dt)) * float(np.median(dt))
    else:
        d2 = np.abs(np.diff(p, 2))
    s = 1.4826 * float(np.median(np.abs(d2 - np.median(d2))))
    d1 = np.abs(np.diff(p))
    moving = d1[d1 > 1e-9 * (float(np.ptp(p)) + 1e-300)]
    step = float(np.median(moving)) if moving.size else 0.0
    # a corner changes the slope by a good part of a ramp's step; rounding of the logged values does not
    c[1:-1] = d2 > max(6.0 * s, 0.1 * step, 1e-9 * (float(np.ptp(p)) + 1e-300))
    return c


#: a log whose time steps differ from their median by more than this share is unevenly sampled
_UNEVEN_STEP_SHARE = 0.01


def uneven_steps(t: np.ndarray) -> bool:
    """Whether a log's time steps differ from their median by more than 1 %."""
    dt = np.diff(np.asarray(t, float))
    med = float(np.median(dt)) if dt.size else 0.0
    return bool(dt.size and med > 0 and np.max(np.abs(dt - med)) > _UNEVEN_STEP_SHARE * med)


def _spaced_differences(lg: MotionLog, order: int, h: int, w: np.ndarray) -> np.ndarray:
    y = np.asarray(lg.angle_deg, float)
    span = order * h
    n = y.size - span
    if n < 1:
        return np.zeros(0)
    if uneven_steps(lg.time_s):
        # on uneven times a difference by sample index leaves the signal in (a ramp is no longer a polynomial of the
        # index): each window takes the divided-difference weights of its own times, which remove any polynomial of
        # degree < order in time, scaled to the even weights' norm so that the noise model below still holds
        t = np.asarray(lg.time_s, float)
        T = np.stack([t[k * h:k * h + n] for k in range(order + 1)], axis=1)
        diff = T[:, :, None] - T[:, None, :]
        np.einsum("ijj->ij", diff)[...] = 1.0
        ww = 1.0 / np.prod(diff, axis=2)
        ww *= (np.linalg.norm(w) / np.linalg.norm(ww, axis=1))[:, None]
        d = np.sum(ww * np.stack([y[k * h:k * h + n] for k in range(order + 1)], axis=1), axis=1)
    else:
        d = sum(w[k] * y[k * h:k * h + n] for k in range(order + 1))
    cum = np.concatenate([[0], np.cumsum(_pressure_corners(lg.pressure_pa, lg.time_s))])
    idx = np.arange(n)
    clean = (cum[idx + span + 1] - cum[idx]) == 0
    return d[clean] if clean.sum() >= 0.1 * n else d


def noise_floor(logs: Sequence[MotionLog]) -> dict:
    """Sensor-noise standard deviation of the measured angle (deg), pooled over ``logs``, right under
    coloured (AR(1)) noise as well as white noise.

    A k-th order difference with spacing h, sum_j w_j y[i + j h], removes every signal that is locally a
    polynomial of degree < k (ramps, holds, the smooth relaxation after them) and leaves
    sigma^2 sum_ij w_i w_j rho^(|i-j| h) of AR(1) noise with marginal standard deviation sigma and lag-1
    correlation rho (white noise: sum w^2 for every h). The robust variances at h = 1..4 give both sigma and
    rho; a white-noise estimator (second difference / sqrt 6) reads sigma sqrt((6 - 8 rho + 2 rho^2) / 6), i.e.
    40 % low at rho = 0.6. Windows that span a corner of the logged pressure profile (where the angle itself
    has a kink) are left out; the median absolute deviation ignores what remains of the signal. Noise slower
    than rho = 0.95 per sample is drift, part of what a model may be asked to explain. Never from any
    simulator's truth.

    Returns
    -------
    dict with ``sigma_deg`` (the floor), ``rho`` (lag-1 correlation of the noise), ``white_noise_sigma_deg``
    (the second-difference white-noise reading, for comparison), ``per_log`` (name -> deg), ``method``,
    ``left_out`` (logs whose own reading is their signal, not in the floor) and ``caution`` (sentences: logs left
    out, logs kept though they read over 3 times the others, a pooled reading at the correlation bound)
    """
    w = _diff_weights(_NOISE_ORDER)
    pooled: list[list[np.ndarray]] = [[] for _ in _NOISE_SPACINGS]
    names, own, d2_all, pinned, folders = [], [], [], [], []   # by position: two logs may share a name
    for lg in logs:
        y = np.asarray(lg.angle_deg, float)
        if y.size < 8:
            continue
        d2 = y[2:] - 2 * y[1:-1] + y[:-2]
        d2_all.append(d2 - np.median(d2))
        v = []
        for i, h in enumerate(_NOISE_SPACINGS):
            d = _spaced_differences(lg, _NOISE_ORDER, h, w)
            pooled[i].append(d)
            v.append(_robust_var(d) if d.size >= 20 else float("nan"))
        sig_log, rho_log = _fit_ar1(np.array(v), _NOISE_SPACINGS, w)
        if np.isfinite(rho_log) and rho_log >= _RHO_MAX - 1e-9:
            pinned.append(len(names))
        names.append(lg.name)
        own.append(float(sig_log))
        folders.append(Path(lg.path).parent.name if getattr(lg, "path", None) else "")
    if not d2_all:
        return {"sigma_deg": float("nan"), "rho": float("nan"), "white_noise_sigma_deg": float("nan"),
                "per_log": {}, "method": NOISE_METHOD, "left_out": [], "caution": []}
    every = set(range(len(names)))

    def pooled_fit(keep: set):
        v = np.array([_robust_var(np.concatenate([x for k, x in enumerate(p) if k in keep]))
                      if sum(x.size for k, x in enumerate(p) if k in keep) >= 20 else float("nan") for p in pooled])
        return _fit_ar1(v, _NOISE_SPACINGS, w)

    # a log whose own fit puts the correlation at its bound and reads far above the other logs' floor is measuring
    # its signal, not the sensor's noise (one sensor logs every run): left out of the pooled floor
    signal, high, rest = [], [], float("nan")
    if pinned and len(pinned) < len(names):
        rest = float(pooled_fit(every - set(pinned))[0])
        if np.isfinite(rest):
            high = [k for k in pinned if own[k] > _PINNED_READING_NOTED * rest]
            signal = [k for k in high if own[k] > _SIGNAL_READING_OVER * rest]
    white = math.sqrt(_robust_var(np.concatenate([d for k, d in enumerate(d2_all) if k not in signal])) / 6.0)
    sigma, rho = pooled_fit(every - set(signal))
    if not np.isfinite(sigma):
        sigma, rho = white, 0.0
    kept = [k for k in high if k not in signal]
    without = float(pooled_fit(every - set(high))[0]) if kept else float("nan")
    # logs that share a file name (fit/run1.csv and holdout/run1.csv) are told apart by their folder, or position
    shared = {n for n in names if names.count(n) > 1}
    names = [f"{n} ({folders[k] or f'log {k + 1}'})" if n in shared else n for k, n in enumerate(names)]
    shared = {n for n in names if names.count(n) > 1}
    names = [f"{n} #{k + 1}" if n in shared else n for k, n in enumerate(names)]
    per_log = {n: (v if np.isfinite(v) else white) for n, v in zip(names, own)}
    reading = {"rest": rest, "sigma": float(sigma), "without": without, "rho": float(rho), "n_logs": len(names)}
    return {"sigma_deg": float(sigma), "rho": float(rho), "white_noise_sigma_deg": float(white),
            "per_log": per_log, "method": NOISE_METHOD, "left_out": [names[k] for k in signal],
            "caution": _noise_caution([(names[k], own[k]) for k in signal], [(names[k], own[k]) for k in kept],
                                      [names[k] for k in pinned], reading)}


def _logs_reading(logs: Sequence[tuple[str, float]], rest: float) -> str:
    return ", ".join(f"{n} reads {v:.3g} deg ({v / rest:.0f} times)" for n, v in logs)


def _noise_caution(signal: Sequence[tuple[str, float]], high: Sequence[tuple[str, float]], pinned: Sequence[str],
                   r: dict) -> list[str]:
    """What to distrust in a noise reading, in sentences. The AR(1) fit puts the correlation at its bound when the
    differences' variance grows with the spacing faster than noise can: slow noise, or signal leaking into them (a
    smooth pressure profile, e.g. a sine, too fast for the sampling: a few tens of samples per period), which reads
    high. ``signal``: (name, own reading) of the logs left out; ``high``: of those kept though they read over
    :data:`_PINNED_READING_NOTED` times the floor of the logs whose correlation is below the bound (``r["rest"]``);
    ``pinned``: every log at the bound; ``r``: the pooled reading (``sigma``, ``rho``), the floor without ``high``
    (``without``) and the number of logs."""
    out, bound = [], f"noise correlation below the {_RHO_MAX} bound"
    if signal:
        out.append(f"{_logs_reading(signal, r['rest'])} the {r['rest']:.3g} deg floor of the logs with their {bound}: "
                   f"over {_SIGNAL_READING_OVER:g} times, that is the signal changing too fast for the sampling, not "
                   f"noise. Left out; the floor ({r['sigma']:.3g} deg) rests on the other "
                   f"{r['n_logs'] - len(signal)} log(s)")
    if high:
        out.append(f"{_logs_reading(high, r['rest'])} the {r['rest']:.3g} deg floor of the logs with their {bound}, "
                   f"with their own correlation at the bound: signal in the differences, or slow noise. Kept; the "
                   f"floor is {r['sigma']:.3g} deg with them and {r['without']:.3g} deg without them")
    if np.isfinite(r["rho"]) and r["rho"] >= _RHO_MAX - 1e-9:
        who = (f" (every log's own reading is at the bound too: {', '.join(pinned)})"
               if pinned and len(pinned) == r["n_logs"] else "")
        out.append(f"the pooled reading put the noise's lag-1 correlation at its {_RHO_MAX} bound{who}: either the "
                   "noise is that slow (drift) or the signal leaked into the differences, and the floor may read "
                   "high (discovery caps it at the base fit's RMSE on the fitting logs when that is lower). Log "
                   "faster than the pressure changes (at least ~50 samples per cycle) or add holds and ramps")
    return out


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
