"""Compiled step-by-step recursions of the catalogue effects (private; numpy API in
:mod:`bpmid.effects.catalogue`).

- :func:`play_kernel`: the play (backlash) operator of half-width r, the model term of dry friction
- :func:`lag_kernel`: a first-order lag, exact for an input that is linear between samples
  (first-order hold), with uneven sampling
- :func:`flow_lag_kernel`: a lag whose time constant grows as the square root of the difference it closes (an
  orifice's flow-limited fill); whole-signal only (the closed loop and the C export refuse it), exact when linear
- :func:`delay_kernel`: a pure dead time by linear interpolation in the input's own samples
- :func:`friction_kernel`: pressure-dependent dry friction with an elastic stick (a generalised play: the
  band grows with the pressure, the friction builds up over a slip pressure); the play is its special case

Every kernel starts in equilibrium with the first sample (y_0 = x_0), like the VBMM's relaxed start.
Each runs the one-step form (:func:`play_step`, :func:`lag_step`, :func:`delay_step`) that the closed
loop's causal chain (:func:`bpmid.control_kernels.pressure_chain`) runs too.
"""
from __future__ import annotations

import math

import numba
import numpy as np


# --------------------------------------------------------------------------------------------------
# one step of each operator: the whole-signal kernels below and the closed loop's causal chain
# (bpmid.control_kernels.pressure_chain) both run these, so the two cannot drift apart
# --------------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def play_step(v, x, r):  # pragma: no cover - compiled
    """One play-operator step: the previous output ``v`` clamped to [x - r, x + r]."""
    lo = x - r
    hi = x + r
    if v < lo:
        v = lo
    elif v > hi:
        v = hi
    return v


@numba.njit(cache=True)
def lag_step(y_prev, x_prev, x, dt, tau):  # pragma: no cover - compiled
    """One first-order-lag step over ``dt`` (s) for an input linear from ``x_prev`` to ``x``; tau > 0 (s)."""
    a = math.exp(-dt / tau)
    return a * y_prev + (1.0 - a) * x_prev + (x - x_prev) * (1.0 - tau * (1.0 - a) / dt)


@numba.njit(cache=True)
def delay_step(t, x, last, tq, j):  # pragma: no cover - compiled
    """``x`` at time ``tq`` by linear interpolation in its samples ``x[0..last]`` at ``t[0..last]``
    (x[0] before the start, x[last] beyond it). ``j`` is where the search starts (the query times of a
    dead time only move forward); returns (value, j advanced)."""
    if tq <= t[0]:
        return x[0], j
    while j + 1 <= last and t[j + 1] < tq:
        j += 1
    if j + 1 > last:
        return x[last], j
    w = (tq - t[j]) / (t[j + 1] - t[j])
    return x[j] + w * (x[j + 1] - x[j]), j


@numba.njit(cache=True)
def friction_step(f, x_prev, x, r, mu, slip):  # pragma: no cover - compiled
    """One step of the friction pressure ``f`` (Pa): ``f + (x - x_prev) w / (w + slip)`` clamped to [-w, w],
    w = r + mu max(x, 0) the sliding level (Pa) at the new input; the muscle sees ``x - f``."""
    w = r + mu * (x if x > 0.0 else 0.0)
    den = w + slip
    if den > 0.0:
        f = f + (x - x_prev) * (w / den)
    if f > w:
        f = w
    elif f < -w:
        f = -w
    return f


@numba.njit(cache=True)
def friction_kernel(x, r, mu, slip):  # pragma: no cover - compiled
    """Dry friction on the pressure: y_k = x_k - f_k (see :func:`friction_step`), f_0 = 0 (unloaded).

    - ``r`` (Pa, >= 0): the part of the sliding level that does not depend on the pressure;
    - ``mu`` (1, 0 <= mu < 1): the part proportional to the gauge pressure (the braid-bladder contact force
      grows with the pressure: Coulomb friction with a pressure-made normal force), w = r + mu max(x, 0);
    - ``slip`` (Pa, >= 0): elastic stick (pre-sliding): while it sticks, the friction takes up w / (w + slip)
      of a pressure change (all of it when slip = 0), so it reaches its sliding level after a pressure change
      of about 2 (w + slip) from the other sliding direction (a Jenkins spring-and-slider element; a rounded,
      Dahl-like loop when spread over elements).

    With mu = slip = 0 this is the play operator of half-width r (:func:`play_kernel`) in exact arithmetic.
    Rate-independent; |y - x| <= w; y is non-decreasing in a rising input and non-increasing in a falling one
    (while it sticks y moves by slip / (w + slip) of the input change, while it slides by 1 -+ mu of it).
    """
    n = x.size
    y = np.empty(n)
    if n == 0:
        return y
    y[0] = x[0]
    f = 0.0
    for k in range(1, n):
        f = friction_step(f, x[k - 1], x[k], r, mu, slip)
        y[k] = x[k] - f
    return y


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
        y[k] = play_step(y[k - 1], x[k], r)
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
        y[k] = lag_step(y[k - 1], x[k - 1], x[k], t[k] - t[k - 1], tau)
    return y


#: sub-steps per sample of the flow-limited lag (its time constant is frozen over each; the update is exact for a
#: frozen one, so any step is stable)
FLOW_LAG_SUBSTEPS = 8


@numba.njit(cache=True)
def flow_lag_kernel(t, x, tau, sat):  # pragma: no cover - compiled
    """A lag whose time constant grows with the pressure difference across the valve, as an orifice's flow grows
    only as its square root: ``tau sqrt(1 + sat |x - y|) y' = x - y``, ``sat`` (1/Pa) >= 0; y_0 = x_0, x linear
    between samples, :data:`FLOW_LAG_SUBSTEPS` sub-steps per sample with the time constant frozen over each.
    ``sat = 0`` is the first-order lag (:func:`lag_kernel`, exact); tau <= 0 returns a copy of x."""
    n = x.size
    y = x.copy()
    if tau <= 0.0 or n == 0:
        return y
    if sat <= 0.0:
        return lag_kernel(t, x, tau)
    v = x[0]
    m = FLOW_LAG_SUBSTEPS
    for k in range(1, n):
        h = (t[k] - t[k - 1]) / m
        for i in range(m):
            xi = x[k - 1] + (x[k] - x[k - 1]) * (i + 0.5) / m
            e = xi - v
            v = xi - e * math.exp(-h / (tau * math.sqrt(1.0 + sat * abs(e))))
        y[k] = v
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
        y[k], j = delay_step(t, x, n - 1, t[k] - d, j)
    return y


def play(x: np.ndarray, r: float) -> np.ndarray:
    """Play operator of half-width ``r`` on (N,) ``x`` (see :func:`play_kernel`)."""
    return play_kernel(np.ascontiguousarray(x, float), float(r))


def friction(x: np.ndarray, r: float, mu: float = 0.0, slip: float = 0.0) -> np.ndarray:
    """Pressure seen through dry friction (see :func:`friction_kernel`) on (N,) ``x`` (Pa)."""
    return friction_kernel(np.ascontiguousarray(x, float), float(r), float(mu), float(slip))


def lag(t: np.ndarray, x: np.ndarray, tau: float) -> np.ndarray:
    """First-order lag of time constant ``tau`` (s) on (N,) ``x`` sampled at (N,) ``t`` (s)."""
    return lag_kernel(np.ascontiguousarray(t, float), np.ascontiguousarray(x, float), float(tau))


def flow_lag(t: np.ndarray, x: np.ndarray, tau: float, sat: float) -> np.ndarray:
    """Flow-limited lag (see :func:`flow_lag_kernel`): ``tau`` (s), ``sat`` (1/Pa) on (N,) ``x`` at (N,) ``t`` (s)."""
    return flow_lag_kernel(np.ascontiguousarray(t, float), np.ascontiguousarray(x, float), float(tau), float(sat))


def delay(t: np.ndarray, x: np.ndarray, d: float) -> np.ndarray:
    """Dead time of ``d`` (s) on (N,) ``x`` sampled at (N,) ``t`` (s)."""
    return delay_kernel(np.ascontiguousarray(t, float), np.ascontiguousarray(x, float), float(d))


@numba.njit(cache=True)
def ring_step(y, v, x_prev, x, dt, period, zeta):  # pragma: no cover - compiled
    """One step of the underdamped second-order filter y'' + 2 zeta w y' + w^2 y = w^2 x (w = 2 pi / period,
    0 < zeta < 1), exact for an input linear between samples: with x = x_prev + s (t - t_prev) the particular
    solution is x - 2 zeta s / w, and the rest rings freely. Returns (y, y')."""
    w = 2.0 * math.pi / period
    s = (x - x_prev) / dt if dt > 0.0 else 0.0
    sig = zeta * w
    wd = w * math.sqrt(1.0 - zeta * zeta)
    e0 = y - (x_prev - 2.0 * zeta * s / w)
    e1 = v - s
    ex = math.exp(-sig * dt)
    c = math.cos(wd * dt)
    sn = math.sin(wd * dt)
    f0 = ex * (e0 * c + (e1 + sig * e0) / wd * sn)
    f1 = ex * (e1 * c - (w * w * e0 + sig * e1) / wd * sn)
    return x - 2.0 * zeta * s / w + f0, s + f1


@numba.njit(cache=True)
def ring_kernel(t, x, period, zeta):  # pragma: no cover - compiled
    """The underdamped second-order filter of :func:`ring_step` over a signal, starting at rest (y_0 = x_0,
    y'_0 = 0). period <= 0 returns a copy of x."""
    n = x.size
    y = x.copy()
    if period <= 0.0 or n == 0:
        return y
    v = 0.0
    for k in range(1, n):
        y[k], v = ring_step(y[k - 1], v, x[k - 1], x[k], t[k] - t[k - 1], period, zeta)
    return y


def ring(t: np.ndarray, x: np.ndarray, period: float, zeta: float) -> np.ndarray:
    """Underdamped second-order response of natural ``period`` (s) and damping ratio ``zeta`` (0 < zeta < 1) to
    (N,) ``x`` sampled at (N,) ``t`` (s) (see :func:`ring_kernel`)."""
    return ring_kernel(np.ascontiguousarray(t, float), np.ascontiguousarray(x, float), float(period), float(zeta))
