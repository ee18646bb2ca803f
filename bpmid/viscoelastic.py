"""Prony kernels, hereditary operators and elastic-constant conversion.

A Prony (generalized-Maxwell) kernel is M(t) = M_inf + sum_j M_j exp(-t / tau_j). Its hereditary
operator on a strain sequence x_0..x_k sampled at t_0..t_k is (VBMM.md eq. 5)

    M-hat[x]_k = M_inf x_0 + sum_{i=1..k} M(t_k - t_i) (x_i - x_{i-1})

evaluated three ways (all required, all equal where they should be):

- :func:`hereditary_recursive`: the exact recursion h_j,k = exp(-dt_k/tau_j) h_j,k-1 + (x_k - x_k-1),
  M-hat = M_inf x_k + sum_j M_j h_j,k. O(branches) per step, any sampling.
- :func:`hereditary_full`: the sum as written, O(k) per step.
- :func:`hereditary_window`: eq. (19), increments older than T_win lumped as M(t_k - t_s)(x_s - x_0).

Units are whatever the caller uses consistently (moduli in Pa or MPa, time in s).
"""
from __future__ import annotations

import numpy as np

from bpmid._jit import lazy_njit
from bpmid.errors import InputError


# ---------------------------------------------------------------------------------------------
# elastic constants
# ---------------------------------------------------------------------------------------------
def check_poisson(nu: float, *, key: str = "poisson_ratio", path=None) -> float:
    """Poisson's ratio must lie in (-1, 0.5): at 0.5 the bulk modulus is infinite."""
    nu = float(nu)
    if not np.isfinite(nu) or nu >= 0.5 or nu <= -1.0:
        raise InputError(f"Poisson's ratio must be below 0.5 (and above -1), found {nu:g}; "
                         "at 0.5 the bulk modulus K = E/(3(1-2 nu)) is infinite", key=key, path=path)
    return nu


def E_to_G(E, nu: float):
    """Shear modulus G = E / (2 (1 + nu)), same unit as E."""
    check_poisson(nu)
    return np.asarray(E, float) / (2.0 * (1.0 + nu)) if np.ndim(E) else float(E) / (2.0 * (1.0 + nu))


def E_to_K(E, nu: float):
    """Bulk modulus K = E / (3 (1 - 2 nu)), same unit as E."""
    check_poisson(nu)
    return np.asarray(E, float) / (3.0 * (1.0 - 2.0 * nu)) if np.ndim(E) else float(E) / (3.0 * (1.0 - 2.0 * nu))


# ---------------------------------------------------------------------------------------------
# kernels
# ---------------------------------------------------------------------------------------------
def prony(t, M_inf: float, M, tau):
    """M(t) = M_inf + sum_j M_j exp(-t/tau_j).

    Parameters
    ----------
    t : (N,) times (s), t >= 0
    M_inf : long-term modulus
    M, tau : (m,) branch moduli and time constants (s)

    Returns
    -------
    (N,) modulus, unit of M_inf
    """
    t = np.asarray(t, float)
    M = np.atleast_1d(np.asarray(M, float))
    tau = np.atleast_1d(np.asarray(tau, float))
    if M.size == 0:
        return np.full_like(t, float(M_inf))
    return M_inf + np.exp(-t[:, None] / tau[None, :]) @ M


# ---------------------------------------------------------------------------------------------
# hereditary states (the recursion), compiled; even sampling takes exp(-dt/tau) once per branch
# ---------------------------------------------------------------------------------------------
@lazy_njit(cache=True)
def _states_kernel(t, x, tau, ramp):  # pragma: no cover - compiled
    # ramp: each increment scaled by its interval's (tau/dt)(1 - exp(-dt/tau)), the strain moving linearly between
    # samples; else the increment applied at its sample time
    n = t.size
    m = tau.size
    h = np.zeros((n, m))
    for k in range(1, n):
        dt = t[k] - t[k - 1]
        dx = x[k] - x[k - 1]
        for j in range(m):
            r = dt / tau[j]
            b = 1.0
            if ramp:
                b = -np.expm1(-r) / r if r > 1e-8 else 1.0 - 0.5 * r
            h[k, j] = np.exp(-r) * h[k - 1, j] + b * dx
    return h


def ramp_states(t, x, tau) -> np.ndarray:
    """The branch states for a strain that moves linearly between samples (a crosshead ramp): the recursion of
    :func:`hereditary_states` with each increment scaled by its own interval's (tau/dt)(1 - exp(-dt/tau)), exact on
    uneven sampling too. Shapes as :func:`hereditary_states`."""
    t = np.ascontiguousarray(t, float)
    x = np.ascontiguousarray(x, float)
    tau = np.ascontiguousarray(np.atleast_1d(tau), float)
    if tau.size == 0:
        return np.zeros((t.size, 0))
    return _states_kernel(t, x, tau, True)


@lazy_njit(cache=True)
def _uniform_states_kernel(dx, a):  # pragma: no cover - compiled
    n = dx.size
    m = a.size
    h = np.empty((n, m))
    for j in range(m):
        acc = 0.0
        for k in range(n):
            acc = a[j] * acc + dx[k]
            h[k, j] = acc
    return h


def is_uniform(t: np.ndarray) -> bool:
    if t.size < 3:
        return True
    dt = np.diff(t)
    return bool(np.max(np.abs(dt - dt[0])) <= 1e-9 * max(abs(dt[0]), 1e-300))


def hereditary_states(t, x, tau) -> np.ndarray:
    """The branch states h_j,k of the exact recursion.

    Parameters
    ----------
    t : (N,) strictly increasing times (s)
    x : (N,) strain sequence
    tau : (m,) time constants (s)

    Returns
    -------
    (N, m) array; h[0] = 0 (relaxed start)
    """
    t = np.ascontiguousarray(t, float)
    x = np.ascontiguousarray(x, float)
    tau = np.ascontiguousarray(np.atleast_1d(tau), float)
    if tau.size == 0:
        return np.zeros((t.size, 0))
    if is_uniform(t) and t.size > 1:
        # each branch is the first-order filter h_k = a h_{k-1} + dx_k, a = exp(-dt/tau)
        # (what scipy.signal.lfilter([1], [1, -a], dx) computes, bit for bit, without importing scipy.signal)
        dx = np.diff(x, prepend=x[0])
        return _uniform_states_kernel(dx, np.exp(-(t[1] - t[0]) / tau))
    return _states_kernel(t, x, tau, False)


def hereditary_recursive(t, x, M_inf: float, M, tau) -> np.ndarray:
    """M-hat[x] by the exact recursion (O(branches) per step). Shapes as :func:`hereditary_states`."""
    M = np.atleast_1d(np.asarray(M, float))
    h = hereditary_states(t, x, tau)
    return M_inf * np.asarray(x, float) + (h @ M if M.size else 0.0)


@lazy_njit(cache=True)
def _full_kernel(t, x, M_inf, M, tau, window):  # pragma: no cover - compiled
    n = t.size
    out = np.empty(n)
    s = 0  # first index inside the window (window <= 0: no window, full history)
    for k in range(n):
        acc = M_inf * x[0]
        start = 1
        if window > 0.0:
            # ages within rounding of T_win count as T_win: the lumped point is then t_s = t_k - T_win exactly
            while s < k and t[k] - t[s] >= window * (1.0 - 1e-9):
                s += 1
            # s is the first sample within the window; s-1 the last one outside it (the lumped point)
            if s > 1:
                ls = s - 1
                age = t[k] - t[ls]
                mk = M_inf
                for j in range(M.size):
                    mk += M[j] * np.exp(-age / tau[j])
                acc += mk * (x[ls] - x[0])
                start = ls + 1
        for i in range(start, k + 1):
            age = t[k] - t[i]
            mk = M_inf
            for j in range(M.size):
                # exp(-745 or less) is at most the smallest subnormal: skipping it leaves the sum bit-identical
                # and avoids exp's slow subnormal range (full history stays linear in the log's length)
                a = age / tau[j]
                if a <= 745.0:
                    mk += M[j] * np.exp(-a)
            acc += mk * (x[i] - x[i - 1])
        out[k] = acc
    return out


def hereditary_full(t, x, M_inf: float, M, tau) -> np.ndarray:
    """M-hat[x] as the full sum of eq. (5) (O(k) per step)."""
    return _full_kernel(np.ascontiguousarray(t, float), np.ascontiguousarray(x, float), float(M_inf),
                        np.ascontiguousarray(np.atleast_1d(M), float),
                        np.ascontiguousarray(np.atleast_1d(tau), float), -1.0)


def hereditary_window(t, x, M_inf: float, M, tau, window_s: float) -> np.ndarray:
    """M-hat[x] with the sliding window of eq. (19): increments older than ``window_s`` are lumped.

    The lumped point s is the last sample at least ``window_s`` old (to rounding: on a regular grid it is
    t_s = t_k - T_win exactly); its increments since t_0 act through the kernel at their window age,
    M(t_k - t_s) (x_s - x_0).
    """
    if not window_s > 0:
        raise InputError(f"window length must be positive, found {window_s:g} s", key="model.window_s")
    return _full_kernel(np.ascontiguousarray(t, float), np.ascontiguousarray(x, float), float(M_inf),
                        np.ascontiguousarray(np.atleast_1d(M), float),
                        np.ascontiguousarray(np.atleast_1d(tau), float), float(window_s))
