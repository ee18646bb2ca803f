"""Compiled step-by-step recursions of the baseline models (numba, ``cache=True``).

Only the recursions live here; envelopes, dead-time shifts, designs and fits are vectorised numpy in
the model modules. Every kernel takes and returns float64 numpy arrays and is generic in its input
signal (pressure in bar for the muscle, displacement in mm for the friction check): units are the
caller's.

- :func:`play_bank`: a bank of generalized play operators (GPI; classical PI for identity envelopes)
- :func:`stop_bank`: a bank of stop operators = Maxwell-slip elastoplastic elements (element deflections)
- :func:`first_order_ramp`: exact exponential stepping of ``b dy/dt + k y = f`` with k, b constant over each
  step and the equilibrium f/k linear over it (first-order hold: the three-element model; the dead time is
  applied to the input before the call)
- :func:`direction_with_deadband`: rising/falling flag of a noisy input with a dead band (two-branch and
  three-element models switch on it)
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def play_bank(gamma_l, gamma_r, r, z_init):  # pragma: no cover - compiled
    """Generalized play operators ``z_k = max(gamma_l_k - r, min(gamma_r_k + r, z_{k-1}))``.

    Parameters
    ----------
    gamma_l, gamma_r : (N,) float
        Rising (gamma_l) and falling (gamma_r) envelopes evaluated at the input samples, in envelope
        units (the input's unit for the classical PI, where both equal the input).
    r : (m,) float
        Thresholds (envelope units), >= 0.
    z_init : (m,) float
        Operator states before the first sample.

    Returns
    -------
    z : (N, m) float
        Operator outputs (envelope units).
    """
    n = gamma_l.shape[0]
    m = r.shape[0]
    out = np.empty((n, m))
    z = z_init.copy()
    for k in range(n):
        gl = gamma_l[k]
        gr = gamma_r[k]
        for i in range(m):
            zi = z[i]
            hi = gr + r[i]
            if zi > hi:
                zi = hi
            lo = gl - r[i]
            if zi < lo:  # max() applied last, as in the definition
                zi = lo
            z[i] = zi
            out[k, i] = zi
    return out


@njit(cache=True)
def stop_bank(u, slip, d_init):  # pragma: no cover - compiled
    """Maxwell-slip elements (stop operators): ``d_k = sat_D(u_k - u_{k-1} + d_{k-1})``.

    Element i is a spring of stiffness k_i in series with a slip block that holds up to the force
    w_i = k_i D_i; its deflection d_i follows the input increment until |d_i| reaches the slip limit
    D_i, then the block slides. The element force is ``k_i * d_i`` (saturates at +-w_i).

    Parameters
    ----------
    u : (N,) float
        Input (any unit; the first sample is taken as the previous one, no jump at k = 0).
    slip : (n,) float
        Slip limits D_i (input unit), >= 0.
    d_init : (n,) float
        Deflections before the first sample (input unit), |d_init| <= D.

    Returns
    -------
    d : (N, n) float
        Element deflections (input unit).
    """
    n = u.shape[0]
    m = slip.shape[0]
    out = np.empty((n, m))
    d = d_init.copy()
    prev = u[0] if n > 0 else 0.0
    for k in range(n):
        du = u[k] - prev
        prev = u[k]
        for i in range(m):
            x = d[i] + du
            lim = slip[i]
            if x > lim:
                x = lim
            elif x < -lim:
                x = -lim
            d[i] = x
            out[k, i] = x
    return out


@njit(cache=True)
def first_order_ramp(y_eq, x, y0):  # pragma: no cover - compiled
    """Exact step of ``T dy/dt + y = e(t)`` with e linear from ``y_eq[k-1]`` to ``y_eq[k]`` over the step and
    T constant over it: ``y_k = y_eq_k + (y_{k-1} - y_eq_{k-1}) a - (y_eq_k - y_eq_{k-1}) (1 - a) / x`` with
    x = dt / T and a = exp(-x). Holding e at the step's end sample instead (``y_k = y_eq_k + (y_{k-1} - y_eq_k) a``)
    advances a sampled input by half a sample on average, which a fitted dead time then absorbs (+dt/2). Stable for any
    dt; x = 0 (no time passes) keeps y.

    Parameters
    ----------
    y_eq : (N,) equilibrium f/k at each sample (output unit)
    x : (N,) dt_k / T_k >= 0 of the step ending at sample k (``x[0]`` is not used)
    y0 : output at the first sample
    """
    n = y_eq.shape[0]
    y = np.empty(n)
    if n == 0:
        return y
    y[0] = y0
    prev = y0
    for k in range(1, n):
        xk = x[k]
        a = np.exp(-xk)
        g = -np.expm1(-xk) / xk if xk > 1e-12 else 1.0 - 0.5 * xk
        prev = y_eq[k] + (prev - y_eq[k - 1]) * a - (y_eq[k] - y_eq[k - 1]) * g
        y[k] = prev
    return y


@njit(cache=True)
def direction_with_deadband(u, tol):  # pragma: no cover - compiled
    """+1 while the input rises, -1 while it falls; a reversal counts once u has left the last extremum by tol.

    Sensor noise smaller than ``tol`` therefore does not flip a branch (a plain sign of the difference
    would chatter on every noisy hold).

    Parameters
    ----------
    u : (N,) float
    tol : float
        Dead band, in the unit of u (>= 0).

    Returns
    -------
    direction : (N,) float, +1.0 or -1.0 (starts rising)
    """
    n = u.shape[0]
    out = np.empty(n)
    if n == 0:
        return out
    direction = 1.0
    ext = u[0]
    for k in range(n):
        x = u[k]
        if direction > 0:
            if x > ext:
                ext = x
            elif x < ext - tol:
                direction = -1.0
                ext = x
        else:
            if x < ext:
                ext = x
            elif x > ext + tol:
                direction = 1.0
                ext = x
        out[k] = direction
    return out
