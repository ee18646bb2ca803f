"""Pressure dynamics of the valve and the muscle volume (seed 003, eqs. 12-17), a plant option of
``bpmid control``.

The controller commands a pressure; a proportional pressure valve (the paper's rig: Festo VPPE, a
pressure regulator fed from the compressor) fills or vents the muscle through an orifice, and the muscle
pressure follows with the dynamics of a polytropic gas in a changing volume:

- polytropic law (eq. 12): P V^c / m^c = const; with PV = mRT (eq. 13) its total differential gives the
  building-up pressure (eq. 14)::

      dP/dt = c / V * (mdot R T - P dV/dt)

- the volume follows the bending state (eq. 15 for the seed's contracting muscle; here from the VBMM
  kinematics): a tube of mean radius R = R0 + u3/2 and centre-line length F l0, V = pi R^2 F l0
- mass flow through a non-ideal nozzle (eqs. 16a/16b, ISO 6358), short form eq. (17)::

      mdot = C rho0 Pu sqrt(T0 / T1) psi(Pd / Pu)
      psi(r) = 1                                   r <= b  (sonic, choked flow)
      psi(r) = sqrt(1 - ((r - b) / (1 - b))^2)     r >  b  (subsonic flow)

  charging: Pu = Ps (supply), Pd = P; venting: Pu = P, Pd = P0 (atmosphere)
- the valve's internal pressure regulator sets the spool opening x in [-1, 1] in proportion to the
  pressure error: x = clip((P_cmd - P) / band, -1, 1); x > 0 charges with conductance x C, x < 0 vents
  with |x| C. A small ``band`` is a stiff regulator (the muscle pressure reaches the command within a
  few milliseconds when the flow is large); a small ``C`` makes filling flow-limited (slew-rate limited in
  the sonic regime, exponential-like in the subsonic end).

Integration: explicit Euler with ``substeps`` sub-steps per control period (0.5 ms at 10 Hz and 200
sub-steps; the regulator's stiffness c R T C rho0 Ps / (V band) must stay below 2 / sub-step). Within one
control period the volume rate is the previous period's (the angle is only known at the samples): causal.

All pressures are absolute, Pa; volumes m^3; C in m^3 / (s Pa) (1 l/(s bar) = 1e-8 m^3/(s Pa)).
"""
from __future__ import annotations

import dataclasses
import math

import numba
import numpy as np

from bpmid.errors import InputError
from bpmid.units import PA_PER_BAR

R_AIR = 287.05  # J / (kg K), specific gas constant of air
RHO0 = 1.185  # kg / m^3, air density at the ISO 8778 standard reference atmosphere
T0 = 293.15  # K, standard reference temperature

#: indices into the parameter vector the compiled code takes
IDX_SUPPLY, IDX_ATM, IDX_C, IDX_B, IDX_POLY, IDX_T, IDX_BAND, IDX_SUB, IDX_DEAD = range(9)


@dataclasses.dataclass(frozen=True)
class ValveVolumeParams:
    """Constants of the valve and muscle-volume model (config ``control.pneumatics``).

    Attributes
    ----------
    supply_bar_abs : supply pressure Ps upstream of the valve, bar absolute (3.0)
    conductance_l_per_s_bar : sonic conductance C of the fully open valve, l/(s bar) (0.3; a small
        proportional valve; 1 l/(s bar) = 1e-8 m^3/(s Pa))
    critical_ratio : critical pressure ratio b of eq. (16) (0.3; 0.528 is an ideal nozzle)
    polytropic_exponent : c of eq. (12), between 1 (isothermal) and 1.4 (adiabatic) (1.2)
    temperature_k : air temperature in the muscle and of the supply, T = T1, K (293.15)
    band_bar : proportional band of the valve's pressure regulator, bar (0.05)
    substeps : Euler sub-steps per control period (200)
    dead_volume_ml : volume of tubing and fittings added to the muscle volume, ml (20)
    """

    supply_bar_abs: float = 3.0
    conductance_l_per_s_bar: float = 0.3
    critical_ratio: float = 0.3
    polytropic_exponent: float = 1.2
    temperature_k: float = 293.15
    band_bar: float = 0.05
    substeps: int = 200
    dead_volume_ml: float = 20.0

    def validate(self, where="control.pneumatics", path=None):
        checks = {
            "supply_bar_abs": self.supply_bar_abs > 1.0,
            "conductance_l_per_s_bar": self.conductance_l_per_s_bar > 0,
            "critical_ratio": 0.0 <= self.critical_ratio < 1.0,
            "polytropic_exponent": 1.0 <= self.polytropic_exponent <= 1.4,
            "temperature_k": self.temperature_k > 0,
            "band_bar": self.band_bar > 0,
            "substeps": self.substeps >= 1,
            "dead_volume_ml": self.dead_volume_ml >= 0,
        }
        for key, ok in checks.items():
            if not ok:
                raise InputError(f"out of range: {getattr(self, key)!r} (see bpmid.pneumatics.ValveVolumeParams)",
                                 path=path, key=f"{where}.{key}")

    def vector(self, atm_pa: float) -> np.ndarray:
        """The parameter vector of the compiled code (SI)."""
        return np.array([self.supply_bar_abs * PA_PER_BAR, atm_pa, self.conductance_l_per_s_bar * 1e-8,
                         self.critical_ratio, self.polytropic_exponent, self.temperature_k, self.band_bar * PA_PER_BAR,
                         float(self.substeps), self.dead_volume_ml * 1e-6])


@numba.njit(cache=True)
def flow_function(r, b):  # pragma: no cover - compiled
    """psi(Pd/Pu) of eq. (17): 1 when choked (r <= b), the subsonic ellipse above, 0 for r >= 1."""
    if r <= b:
        return 1.0
    if r >= 1.0:
        return 0.0
    x = (r - b) / (1.0 - b)
    return math.sqrt(1.0 - x * x)


@numba.njit(cache=True)
def mass_flow(pu, pd, C, b, T1):  # pragma: no cover - compiled
    """Mass flow (kg/s) from pu to pd (Pa abs) through conductance C (m^3/(s Pa)), eqs. (16a/b)."""
    if pu <= 0.0:
        return 0.0
    return C * RHO0 * pu * math.sqrt(T0 / T1) * flow_function(pd / pu, b)


@numba.njit(cache=True)
def valve_flow(p, p_cmd, prm):  # pragma: no cover - compiled
    """Net mass flow into the muscle (kg/s) at muscle pressure p for command p_cmd (Pa abs)."""
    x = (p_cmd - p) / prm[IDX_BAND]
    if x > 1.0:
        x = 1.0
    elif x < -1.0:
        x = -1.0
    C, b, T1 = prm[IDX_C], prm[IDX_B], prm[IDX_T]
    if x > 0.0:
        return x * mass_flow(prm[IDX_SUPPLY], p, C, b, T1)
    if x < 0.0:
        return x * mass_flow(p, prm[IDX_ATM], C, b, T1)
    return 0.0


@numba.njit(cache=True)
def pressure_period(p0, p_cmd, V, dVdt, dt, prm):  # pragma: no cover - compiled
    """Muscle pressure (Pa abs) after one control period ``dt`` of eq. (14) from ``p0``, command ``p_cmd``,
    volume ``V`` (m^3, muscle + dead volume) changing at ``dVdt`` (m^3/s)."""
    n = int(prm[IDX_SUB])
    h = dt / n
    c, T = prm[IDX_POLY], prm[IDX_T]
    p = p0
    for _ in range(n):
        q = valve_flow(p, p_cmd, prm)
        p = p + h * c / V * (q * R_AIR * T - p * dVdt)
        # the flow stops where the pressures meet (psi -> 0 with infinite slope there: no Euler overshoot)
        if q > 0.0 and p > prm[IDX_SUPPLY]:
            p = prm[IDX_SUPPLY]
        elif q < 0.0 and p < prm[IDX_ATM]:
            p = prm[IDX_ATM]
        if p < 1.0:
            p = 1.0
    return p


@numba.njit(cache=True)
def muscle_volume(u3, F, R0, l0):  # pragma: no cover - compiled
    """Volume (m^3) of the tube: mean radius R0 + u3/2, centre-line length F l0."""
    R = R0 + 0.5 * u3
    return math.pi * R * R * F * l0


@numba.njit(cache=True)
def _fill_kernel(t, p_cmd, V, p0, prm):  # pragma: no cover - compiled
    n = t.size
    out = np.empty(n)
    out[0] = p0
    for k in range(1, n):
        out[k] = pressure_period(out[k - 1], p_cmd[k], V, 0.0, t[k] - t[k - 1], prm)
    return out


def fill(t, p_cmd_bar_abs, *, volume_ml: float = 192.0, p0_bar_abs: float = 1.01325,
         params: ValveVolumeParams | None = None, atm_bar: float = 1.01325) -> np.ndarray:
    """Muscle pressure (bar abs), shape (N,), for a command history at times ``t`` (s) into a fixed volume.

    A numpy entry point for checks and plots; ``bpmid control`` couples the same compiled step to the
    VBMM's volume.
    """
    prm = (params or ValveVolumeParams()).vector(atm_bar * PA_PER_BAR)
    prm[IDX_DEAD] = 0.0
    t = np.ascontiguousarray(t, float)
    cmd = np.ascontiguousarray(p_cmd_bar_abs, float) * PA_PER_BAR
    return _fill_kernel(t, cmd, volume_ml * 1e-6, p0_bar_abs * PA_PER_BAR, prm) / PA_PER_BAR


__all__ = ["ValveVolumeParams", "fill", "flow_function", "mass_flow", "pressure_period", "muscle_volume"]
