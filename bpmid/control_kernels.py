"""Compiled closed-loop kernels of ``bpmid control`` (private; the numpy API is :mod:`bpmid.control`).

The plant is stepped one control period at a time, because the command at step k + 1 depends on the angle
measured at step k. Per step the recursive VBMM (VBMM.md section 3: the exact O(1) recursion) solves one
scalar equation P_model(beta_k) = P_k, using the kinematics and pressure closure of
:mod:`bpmid.models._vbmm_kernels` (imported, not copied); the feedforward is the inverse VBMM evaluated
incrementally on the reference (one closed-form evaluation and one state update per step).

Model vector layout (``pack_model`` in :mod:`bpmid.control`): the VBMM is passed as
geo (5,), closure, G_inf, G (m,), tauG (m,), K_inf, K (m,), tauK (m,), fall_ratio, stiffening.
Pressures inside: Pa (absolute where named ``_abs``, gauge otherwise); angles rad; time s.
"""
from __future__ import annotations

import math

import numba
import numpy as np

from bpmid.effects._kernels import delay_step as _delay_step
from bpmid.effects._kernels import friction_step as _friction_step
from bpmid.effects._kernels import lag_step as _lag_step
from bpmid.effects._kernels import play_step as _play_step
from bpmid.models._vbmm_kernels import commit as _commit
from bpmid.models._vbmm_kernels import decay as _decay
from bpmid.models._vbmm_kernels import instantaneous as _instantaneous
from bpmid.models._vbmm_kernels import DIR_TOL, pressure_at, stretch, u3_from_beta
from bpmid.models._vbmm_kernels import recursion_const as _hist
from bpmid.models._vbmm_kernels import solve_beta as _solve_beta
from bpmid.pneumatics import muscle_volume, pressure_period, IDX_DEAD
from bpmid.units import PA_PER_BAR

CTRL_PI, CTRL_VBMM, CTRL_MS, CTRL_GIVEN = 0, 1, 2, 3  # CTRL_GIVEN: feedforward precomputed by the caller

SAT_NONE, SAT_HIGH, SAT_LOW = 0, 1, -1


class _State:  # documentation only: the state arrays every stepper carries
    """hG1, hG2, hK1, hK2 (branch states per strain), aG, aK (decays of this step), x (4,): e1, e2 of the
    previous step, 1 when the angle fell on the previous step (asymmetric relaxation; the forward step's), and the
    previous beta."""


@numba.njit(cache=True)
def _step_history(k, dt, r, Ginf, Gj, tauG, Kinf, Kj, tauK, hG1, hG2, hK1, hK2, aG, aK, x):  # pragma: no cover
    """Moduli (G0, K0) and history constants of step k."""
    if k == 0:
        return Ginf, Kinf, 0.0, 0.0, 0.0, 0.0
    G0 = _instantaneous(Ginf, Gj)
    K0 = _instantaneous(Kinf, Kj)
    _decay(aG, dt, tauG, r)
    _decay(aK, dt, tauK, r)
    return (G0, K0, _hist(Gj, aG, hG1, x[0]), _hist(Gj, aG, hG2, x[1]),
            _hist(Kj, aK, hK1, x[0]), _hist(Kj, aK, hK2, x[1]))


@numba.njit(cache=True)
def _commit_step(k, beta, geo, hG1, hG2, hK1, hK2, aG, aK, x):  # pragma: no cover
    R0, l0, nn = geo[2], geo[3], geo[4]
    u3 = u3_from_beta(beta, R0, l0, nn)
    F = stretch(u3, R0, l0, nn)
    e1 = F - 1.0
    e2 = u3 / R0
    if k > 0:
        _commit(aG, hG1, e1 - x[0])
        _commit(aG, hG2, e2 - x[1])
        _commit(aK, hK1, e1 - x[0])
        _commit(aK, hK2, e2 - x[1])
    x[0] = e1
    x[1] = e2
    return u3, F


@numba.njit(cache=True)
def inverse_step(k, dt, beta, geo, closure, Ginf, Gj, tauG, Kinf, Kj, tauK, fall, stiff,
                 hG1, hG2, hK1, hK2, aG, aK, x):  # pragma: no cover - compiled
    """One step of the incremental inverse VBMM: gauge pressure (Pa) that holds ``beta`` (rad) at step k
    given the state; commits the step. Falling angle (beta < previous) uses tau * fall."""
    r = fall if (k > 0 and beta < x[3] - DIR_TOL) else 1.0
    G0, K0, cG1, cG2, cK1, cK2 = _step_history(k, dt, r, Ginf, Gj, tauG, Kinf, Kj, tauK,
                                               hG1, hG2, hK1, hK2, aG, aK, x)
    p = pressure_at(beta, geo, closure, G0, K0, cG1, cG2, cK1, cK2, 1.0, stiff)
    _commit_step(k, beta, geo, hG1, hG2, hK1, hK2, aG, aK, x)
    x[3] = beta
    return p


@numba.njit(cache=True)
def inverse_incremental(t, beta, geo, closure, Ginf, Gj, tauG, Kinf, Kj, tauK, fall, stiff):  # pragma: no cover
    """The inverse VBMM run step by step (as the controller runs it): gauge pressure (Pa), shape (N,)."""
    m, q = Gj.size, Kj.size
    hG1, hG2, aG = np.zeros(m), np.zeros(m), np.ones(m)
    hK1, hK2, aK = np.zeros(q), np.zeros(q), np.ones(q)
    x = np.zeros(4)
    out = np.empty(t.size)
    for k in range(t.size):
        dt = t[k] - t[k - 1] if k > 0 else 0.0
        out[k] = inverse_step(k, dt, beta[k], geo, closure, Ginf, Gj, tauG, Kinf, Kj, tauK, fall, stiff,
                              hG1, hG2, hK1, hK2, aG, aK, x)
    return out


@numba.njit(cache=True)
def forward_stepped(t, p, geo, closure, Ginf, Gj, tauG, Kinf, Kj, tauK, fall, stiff, scale):  # pragma: no cover
    """The forward VBMM stepped one sample at a time by the closed-loop stepper (open-loop check)."""
    m, q = Gj.size, Kj.size
    hG1, hG2, aG = np.zeros(m), np.zeros(m), np.ones(m)
    hK1, hK2, aK = np.zeros(q), np.zeros(q), np.ones(q)
    x = np.zeros(4)
    out = np.empty(t.size)
    status = np.zeros(t.size, np.int64)
    for k in range(t.size):
        dt = t[k] - t[k - 1] if k > 0 else 0.0
        out[k], status[k] = plant_step(k, dt, p[k], geo, closure, Ginf, Gj, tauG, Kinf, Kj, tauK, fall, stiff,
                                       scale[k], hG1, hG2, hK1, hK2, aG, aK, x)
    return out, status


@numba.njit(cache=True)
def plant_step(k, dt, p, geo, closure, Ginf, Gj, tauG, Kinf, Kj, tauK, fall, stiff, sc,
               hG1, hG2, hK1, hK2, aG, aK, x):  # pragma: no cover - compiled
    """One step of the forward VBMM: beta (rad) for gauge pressure p (Pa) at step k; commits the step.
    A falling angle uses tau * fall (the asymmetric_relaxation term), decided as the open-loop kernel decides it
    (:func:`bpmid.models._vbmm_kernels.forward_kernel`): solved with the last step's direction, again with the
    other when the angle moves the other way, kept when that one is consistent."""
    falling = k > 0 and fall != 1.0 and x[2] > 0.5
    r = fall if falling else 1.0
    G0, K0, cG1, cG2, cK1, cK2 = _step_history(k, dt, r, Ginf, Gj, tauG, Kinf, Kj, tauK,
                                               hG1, hG2, hK1, hK2, aG, aK, x)
    b, st = _solve_beta(p, x[3], geo, closure, G0, K0, cG1, cG2, cK1, cK2, sc, stiff)
    if k > 0 and fall != 1.0 and (b < x[3] - DIR_TOL) != falling:
        r2 = 1.0 if falling else fall
        G0, K0, c1, c2, c3, c4 = _step_history(k, dt, r2, Ginf, Gj, tauG, Kinf, Kj, tauK,
                                               hG1, hG2, hK1, hK2, aG, aK, x)
        b2, st2 = _solve_beta(p, x[3], geo, closure, G0, K0, c1, c2, c3, c4, sc, stiff)
        if (b2 < x[3] - DIR_TOL) != falling:    # consistent: the angle turned
            b, st = b2, st2
            falling = not falling
        else:                         # neither is consistent: the first solve stands, with its decays
            _step_history(k, dt, r, Ginf, Gj, tauG, Kinf, Kj, tauK, hG1, hG2, hK1, hK2, aG, aK, x)
    _commit_step(k, b, geo, hG1, hG2, hK1, hK2, aG, aK, x)
    x[2] = 1.0 if falling else 0.0
    x[3] = b
    return b, st


OP_DELAY, OP_LAG, OP_PLAYS, OP_FRICTION = 0, 1, 2, 3


@numba.njit(cache=True)
def pressure_chain(k, t, x, ch_op, ch_par, ch_cnt, ch_hist, ch_y, ch_j, ch_play):  # pragma: no cover
    """The catalogue's pressure terms at step k, causally, in order: each op's output feeds the next.

    The same one-step kernels as :mod:`bpmid.effects._kernels` runs on the whole signal (imported, not
    copied: the stepped plant equals the open-loop :class:`~bpmid.effects.base.AugmentedVBMM`): OP_DELAY ch_par[i, 0] = dead time (s),
    linear interpolation in the op's own input samples; OP_LAG ch_par[i, 0] = tau (s), first-order lag
    exact for a linear input between samples; OP_PLAYS ch_par[i, :ch_cnt[i]] = half-widths (Pa), the mean
    of that many play operators; OP_FRICTION ch_par[i, :ch_cnt[i]] = (r, mu, slip) of each element in a row,
    the mean of that many friction operators (:func:`bpmid.effects._kernels.friction_step`, state: the
    friction pressure per element). All start in equilibrium with the first sample.
    """
    for i in range(ch_op.size):
        ch_hist[i, k] = x
        op = ch_op[i]
        if op == OP_DELAY:
            d = ch_par[i, 0]
            if d > 0.0 and k > 0:
                x, ch_j[i] = _delay_step(t, ch_hist[i], k, t[k] - d, ch_j[i])
            elif d > 0.0:
                x = ch_hist[i, 0]
        elif op == OP_LAG:
            tau = ch_par[i, 0]
            if tau > 0.0 and k > 0:
                x = _lag_step(ch_y[i], ch_hist[i, k - 1], x, t[k] - t[k - 1], tau)
        elif op == OP_FRICTION:
            ne = ch_cnt[i] // 3
            acc = 0.0
            for e in range(ne):
                if k == 0:
                    ch_play[i, e] = 0.0
                    v = x
                else:
                    fr = _friction_step(ch_play[i, e], ch_hist[i, k - 1], x, ch_par[i, 3 * e],
                                        ch_par[i, 3 * e + 1], ch_par[i, 3 * e + 2])
                    ch_play[i, e] = fr
                    v = x - fr
                acc += v
            x = acc / ne
        else:
            acc = 0.0
            for e in range(ch_cnt[i]):
                v = x if k == 0 else _play_step(ch_play[i, e], x, ch_par[i, e])
                ch_play[i, e] = v
                acc += v
            x = acc / ch_cnt[i]
        ch_y[i] = x
    return x


@numba.njit(cache=True)
def closed_loop(t, ref, kind, kp, ki, p_lo, p_hi, atm, p_start, preview,
                # controller's model (VBMM feedforward)
                c_geo, c_closure, c_Ginf, c_Gj, c_tauG, c_Kinf, c_Kj, c_tauK, c_fall, c_stiff,
                # Maxwell-slip inverse feedforward (angle deg -> gauge bar)
                ms_poly, ms_k, ms_D,
                # CTRL_GIVEN: feedforward gauge pressure (Pa) per reference sample, computed causally by the caller
                ff_given,
                # plant
                geo, closure, Ginf, Gj, tauG, Kinf, Kj, tauK, fall, stiff, scale,
                ch_op, ch_par, ch_cnt, gain, offset_deg, noise_deg, quant_deg, pneu, pneu_prm):  # pragma: no cover - compiled
    """Simulate the loop. ``ref`` (N,) rad; gains kp (Pa / deg), ki (Pa / deg per step);
    limits and p_start in Pa abs. Controller kinds: CTRL_PI, CTRL_VBMM, CTRL_MS.

    Step k: the plant's pressure is the command u_k (saturated; through the valve-and-volume dynamics when
    ``pneu``), then the catalogue's pressure terms (:func:`pressure_chain`), the VBMM step, the angle
    sensor's gain and offset (``gain`` 1 and ``offset_deg`` 0: none), the sensor error ``noise_deg`` (white noise and drift, drawn beforehand) and the quantisation
    ``quant_deg`` give the measurement y_k; the controller forms e_k = r_k - y_k
    and the command of the next step (eq. 20):

        u_{k+1} = clip(FF(r_{k + preview}) + kp e_k + I_k, p_lo, p_hi),   I_k = I_{k-1} + ki e_k

    with conditional integration (anti-windup): I is frozen on steps where the unclipped command is beyond
    a limit and e_k pushes further out. The PI alone starts with I = p_start (bumpless start at rest).

    Returns
    -------
    u (N,) command Pa abs (applied at k), p_muscle (N,) Pa abs, p_eff (N,) gauge Pa seen by the rubber,
    beta (N,) rad (true), y (N,) deg (measured), ff (N,) Pa abs (feedforward of the command u_k),
    sat (N,) int (SAT_* of u_k), status (N,) int (solve status)
    """
    n = t.size
    u = np.empty(n)
    pm = np.empty(n)
    pe = np.empty(n)
    beta = np.empty(n)
    y = np.empty(n)
    ff_out = np.zeros(n)
    sat = np.zeros(n, np.int64)
    status = np.zeros(n, np.int64)
    # plant state
    m, q = Gj.size, Kj.size
    hG1, hG2, aG = np.zeros(m), np.zeros(m), np.ones(m)
    hK1, hK2, aK = np.zeros(q), np.zeros(q), np.ones(q)
    x = np.zeros(4)
    # feedforward state
    cm, cq = c_Gj.size, c_Kj.size
    fG1, fG2, faG = np.zeros(cm), np.zeros(cm), np.ones(cm)
    fK1, fK2, faK = np.zeros(cq), np.zeros(cq), np.ones(cq)
    fx = np.zeros(4)
    ms_d = np.zeros(ms_D.size)
    ms_prev = 0.0
    # pressure terms' state
    ch_hist = np.zeros((ch_op.size, n))
    ch_y = np.zeros(ch_op.size)
    ch_j = np.zeros(ch_op.size, np.int64)
    ch_play = np.zeros(ch_par.shape)
    V_prev = 0.0
    dV = 0.0
    integ = p_start if kind == CTRL_PI else 0.0
    u[0] = p_start
    ff_out[0] = p_start
    fj = np.int64(0)  # next reference sample the feedforward has not seen (typed int64: a literal 0 had numba
    # compile inverse_step and its callees a second time, for Literal[int](0): 0.7 of the 12.8 s first compile)
    ffv = 0.0
    for k in range(n):
        dt = t[k] - t[k - 1] if k > 0 else 0.0
        # --- plant pressure
        if pneu and k > 0:
            pm[k] = pressure_period(pm[k - 1], u[k], V_prev + pneu_prm[IDX_DEAD], dV, dt, pneu_prm)
        else:
            pm[k] = u[k]
        pg = pm[k] - atm
        pe[k] = pressure_chain(k, t, pg, ch_op, ch_par, ch_cnt, ch_hist, ch_y, ch_j, ch_play)
        b, st = plant_step(k, dt, pe[k], geo, closure, Ginf, Gj, tauG, Kinf, Kj, tauK, fall, stiff, scale[k],
                           hG1, hG2, hK1, hK2, aG, aK, x)
        beta[k] = b
        status[k] = st
        yk = gain * math.degrees(b) + offset_deg + noise_deg[k]
        y[k] = yk if quant_deg <= 0.0 else round(yk / quant_deg) * quant_deg
        if pneu:
            V = muscle_volume(u3_from_beta(b, geo[2], geo[3], geo[4]),
                              stretch(u3_from_beta(b, geo[2], geo[3], geo[4]), geo[2], geo[3], geo[4]),
                              geo[2], geo[3])
            dV = (V - V_prev) / dt if k > 0 else 0.0
            V_prev = V
        if k == n - 1:
            break
        # --- controller: command for step k + 1
        e = math.degrees(ref[k]) - y[k]
        j = k + 1 if preview else k
        # the feedforward advances along the reference one sample at a time, from sample 0
        while fj <= j:
            if kind == CTRL_VBMM:
                dtf = t[fj] - t[fj - 1] if fj > 0 else 0.0
                ffv = atm + inverse_step(fj, dtf, ref[fj], c_geo, c_closure, c_Ginf, c_Gj, c_tauG, c_Kinf, c_Kj,
                                         c_tauK, c_fall, c_stiff, fG1, fG2, fK1, fK2, faG, faK, fx)
            elif kind == CTRL_MS:
                bd = math.degrees(ref[fj])
                du = bd - ms_prev if fj > 0 else 0.0
                ms_prev = bd
                v = 0.0
                for i in range(ms_poly.size):
                    v += ms_poly[i] * bd ** i
                for i in range(ms_D.size):
                    di = ms_d[i] + du
                    if di > ms_D[i]:
                        di = ms_D[i]
                    elif di < -ms_D[i]:
                        di = -ms_D[i]
                    ms_d[i] = di
                    v += ms_k[i] * di
                ffv = atm + v * PA_PER_BAR
            elif kind == CTRL_GIVEN:
                ffv = atm + ff_given[fj]
            else:
                ffv = 0.0
            fj += 1
        ffk = ffv
        trial = integ + ki * e
        cmd = ffk + kp * e + trial
        if not ((cmd > p_hi and e > 0.0) or (cmd < p_lo and e < 0.0)):
            integ = trial
        cmd = ffk + kp * e + integ
        if cmd > p_hi:
            cmd = p_hi
            sat[k + 1] = SAT_HIGH
        elif cmd < p_lo:
            cmd = p_lo
            sat[k + 1] = SAT_LOW
        u[k + 1] = cmd
        ff_out[k + 1] = ffk
    return u, pm, pe, beta, y, ff_out, sat, status
