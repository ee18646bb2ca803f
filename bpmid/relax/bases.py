"""Design matrices of the two relaxation fits (see :mod:`bpmid.relax.varpro` for the protocol).

- :class:`StepBasis`, step mode: a modulus curve E(t) = E_inf + sum_j E_j exp(-t/tau_j) (the paper's
  and pyvisco's ideal-step reading of a relaxation test).
- :class:`RampBasis`, ramp mode: the measured stress of every log through the hereditary integral of
  that log's own strain history, sigma_k = E_inf eps_k + sum_j E_j b_j h_j,k, with the branch states
  h_j from :func:`bpmid.viscoelastic.hereditary_states`.

The recursion there applies each strain increment at its sample time. For a strain that moves
linearly between samples (a crosshead ramp) the exact response of a branch is the same recursion with
every increment scaled by b_j = (tau_j/dt)(1 - exp(-dt/tau_j)); on evenly sampled logs that is a
constant factor per branch, applied here as a column scale; on unevenly sampled logs (fast during the
ramp, slow in the hold) each interval takes its own factor inside the recursion
(:func:`bpmid.viscoelastic.ramp_states`; one factor from the median step read E_1 57 % high on a log
at 100 Hz in a 1 s ramp and 2 Hz in the hold). Without it the fitted E_j of a tau = 0.4 s branch logged
at 50 Hz come out 2.5 % low.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from bpmid.viscoelastic import hereditary_states, is_uniform, ramp_states

#: exp(-x) for x above this is set to 0 (avoids subnormal numbers, which slow LAPACK down a lot)
_EXP_CUT = 40.0
#: relative step in log tau of the central difference for the ramp-mode derivative columns
_DLOG = 1e-4


def _exp_columns(t: np.ndarray, tau: np.ndarray):
    ratio = t[:, None] / tau[None, :]
    X = np.where(ratio < _EXP_CUT, np.exp(-np.minimum(ratio, _EXP_CUT)), 0.0)
    return X, ratio


class StepBasis:
    """Columns [1, exp(-t/tau_1), ..., exp(-t/tau_m)] for pooled modulus curves.

    Parameters
    ----------
    t : (N,) time since the step of each sample (s); curves are simply concatenated
    """

    n_fixed = 1

    def __init__(self, t: np.ndarray):
        self.t = np.asarray(t, float)

    def columns(self, theta: np.ndarray, derivative: bool = True):
        """Returns A (N, 1+m) and dA/dlog(tau) (N, m) (or None)."""
        tau = np.exp(np.asarray(theta, float))
        X, ratio = _exp_columns(self.t, tau)
        A = np.hstack([np.ones((self.t.size, 1)), X])
        return A, (X * ratio if derivative else None)


def branch_scale(tau: np.ndarray, dt: float) -> np.ndarray:
    """b = (tau/dt)(1 - exp(-dt/tau)): first-order-hold correction of a step-form branch state."""
    x = dt / np.asarray(tau, float)
    return np.where(x > 1e-8, -np.expm1(-x) / np.maximum(x, 1e-300), 1.0 - 0.5 * x)


class RampBasis:
    """Columns [eps, b_1 h_1, ..., b_m h_m] of all logs stacked (ramp mode).

    Parameters
    ----------
    times, strains : sequences of (N_i,) arrays, one pair per log (s, dimensionless)
    """

    n_fixed = 1

    def __init__(self, times: Sequence[np.ndarray], strains: Sequence[np.ndarray]):
        self.times = [np.asarray(t, float) for t in times]
        self.strains = [np.asarray(e, float) for e in strains]
        self.uniform = [is_uniform(t) for t in self.times]
        self.eps = np.concatenate(self.strains)

    def _states(self, tau: np.ndarray) -> np.ndarray:
        parts = []
        for t, e, even in zip(self.times, self.strains, self.uniform):
            if even and t.size > 1:  # one factor per branch: a column scale on the fast even-step filter
                parts.append(hereditary_states(t, e, tau) * branch_scale(tau, float(t[1] - t[0]))[None, :])
            else:
                parts.append(ramp_states(t, e, tau))
        return np.vstack(parts)

    def columns(self, theta: np.ndarray, derivative: bool = True):
        """Returns A (N, 1+m) and dA/dlog(tau) (N, m) (central difference) or None."""
        theta = np.asarray(theta, float)
        H = self._states(np.exp(theta))
        A = np.hstack([self.eps[:, None], H])
        if not derivative:
            return A, None
        dA = (self._states(np.exp(theta + _DLOG)) - self._states(np.exp(theta - _DLOG))) / (2 * _DLOG)
        return A, dA
