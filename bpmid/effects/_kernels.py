"""Compiled step-by-step recursions of the catalogue effects (private; numpy API in
:mod:`bpmid.effects.catalogue`).

- :func:`play_kernel`: the play (backlash) operator of half-width r, the model term of dry friction
- :func:`lag_kernel`: a first-order lag, exact for an input that is linear between samples
  (first-order hold), with uneven sampling
- :func:`delay_kernel`: a pure dead time by linear interpolation in the input's own samples

Every kernel starts in equilibrium with the first sample (y_0 = x_0), like the VBMM's relaxed start.
"""
from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True)
def play_kernel(x, r):  # pragma: no cover - compiled
    """Play operator: y_k = min(x_k + r, max(x_k - r, y_{k-1})), y_0 = x_0. r >= 0 (same unit as x).

    With r = 0 the output is the input exactly. The output is rate-independent (it depends on the
    sequence of input values, not on their timing) and |y - x| <= r.
    """
    n = x.size
    y = np.empty(n)
    if n == 0:
        return y
    y[0] = x[0]
    for k in range(1, n):
        v = y[k - 1]
        lo = x[k] - r
        hi = x[k] + r
        if v < lo:
            v = lo
        elif v > hi:
            v = hi
        y[k] = v
    return y


@numba.njit(cache=True)
def lag_kernel(t, x, tau):  # pragma: no cover - compiled
    """First-order lag tau y' = x - y, y_0 = x_0, x linear between samples (exact discretisation).

    y_k = a y_{k-1} + (1 - a) x_{k-1} + (x_k - x_{k-1}) (1 - tau (1 - a) / dt), a = exp(-dt / tau).
    tau <= 0 returns a copy of x.
    """
    n = x.size
    y = x.copy()
    if tau <= 0.0 or n == 0:
        return y
    for k in range(1, n):
        dt = t[k] - t[k - 1]
        a = math.exp(-dt / tau)
        y[k] = a * y[k - 1] + (1.0 - a) * x[k - 1] + (x[k] - x[k - 1]) * (1.0 - tau * (1.0 - a) / dt)
    return y


@numba.njit(cache=True)
def delay_kernel(t, x, d):  # pragma: no cover - compiled
    """x(t - d) by linear interpolation between the samples; x_0 before the start. d <= 0: a copy."""
    n = x.size
    y = x.copy()
    if d <= 0.0 or n == 0:
        return y
    j = 0
    for k in range(n):
        tq = t[k] - d
        if tq <= t[0]:
            y[k] = x[0]
            continue
        while j + 1 < n and t[j + 1] < tq:
            j += 1
        if j + 1 >= n:
            y[k] = x[n - 1]
        else:
            w = (tq - t[j]) / (t[j + 1] - t[j])
            y[k] = x[j] + w * (x[j + 1] - x[j])
    return y


def play(x: np.ndarray, r: float) -> np.ndarray:
    """Play operator of half-width ``r`` on (N,) ``x`` (see :func:`play_kernel`)."""
    return play_kernel(np.ascontiguousarray(x, float), float(r))


def lag(t: np.ndarray, x: np.ndarray, tau: float) -> np.ndarray:
    """First-order lag of time constant ``tau`` (s) on (N,) ``x`` sampled at (N,) ``t`` (s)."""
    return lag_kernel(np.ascontiguousarray(t, float), np.ascontiguousarray(x, float), float(tau))


def delay(t: np.ndarray, x: np.ndarray, d: float) -> np.ndarray:
    """Dead time of ``d`` (s) on (N,) ``x`` sampled at (N,) ``t`` (s)."""
    return delay_kernel(np.ascontiguousarray(t, float), np.ascontiguousarray(x, float), float(d))
