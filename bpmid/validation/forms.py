"""The physical forms of each effect, as functions of one strength ``s`` (0 = absent, 1 = nominal).

Every catalogue id has at least two forms written from physics, none in the form of the catalogue's model term
(bpmid.effects is not imported here). Three effects are outside the catalogue: payload inertia that rings, the
Mullins effect and an air leak. A form returns a partial physics spec (see :func:`empty_spec`) that
:mod:`bpmid.validation.generator` merges and hands to :mod:`bpmid.validation.physics`.

``draw(rng)`` picks the form's free shape constants (time constants, exponents) once per case; the strength is
then set by the generator so that the effect raises the held-out RMSE of the true base model to a target multiple
of the sensor noise.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Callable

import numpy as np

#: catalogue ids (DISCOVER.md); the generator names its truth with these
CATALOGUE_IDS = ("second_relaxation", "braid_friction", "pressure_lag", "asymmetric_relaxation",
                 "strain_stiffening", "angle_offset", "thermal_softening")
#: effects no catalogue entry represents
OUT_OF_CATALOGUE_IDS = ("payload_inertia", "mullins", "air_leak")


def empty_spec() -> dict:
    """The physics of a muscle without any effect."""
    return {"pressure": {"kind": "none"}, "extra_branches": [], "fall_ratio": 1.0,
            "friction": {"kind": "none", "par": []}, "stiffening": {"kind": "none", "C": 0.0, "k": 0.0},
            "thermal": {"kind": "none"}, "mullins": {"rinv": 0.0, "m": 1.0}, "inertia": {"f_n_hz": 0.0, "zeta": 0.0},
            "offset": {"deg": 0.0, "per_log_sd": 0.0}}


@dataclasses.dataclass(frozen=True)
class Form:
    """One physical form of an effect.

    Attributes
    ----------
    effect : catalogue id or out-of-catalogue id
    name : the form's name (``dahl``, ``cascade``, ...)
    description : one line of physics
    draw : rng -> shape constants (dict), drawn once per case
    spec : (s, shape) -> partial physics spec
    s_max : largest strength the sizing may use (keeps the physics sane)
    """

    effect: str
    name: str
    description: str
    draw: Callable[[np.random.Generator], dict]
    spec: Callable[[float, dict], dict]
    s_max: float = 20.0


def _u(rng, lo, hi):
    return float(rng.uniform(lo, hi))


def _friction_spec(kind: str, par: list) -> dict:
    return {"friction": {"kind": kind, "par": [float(v) for v in par]}}


def _dahl(s, sh):
    Fc = 8e3 * s  # Pa, axial friction stress at full slip
    return _friction_spec("dahl", [Fc / sh["slip_strain"], max(Fc, 1e-9)])


def _bouc_wen(s, sh):
    z_max = sh["slip_strain"]  # z saturates at A / (b + g) (strain units)
    share = sh["b_share"]  # b / (b + g): the loop's shape between "hardening" and "softening" reversal
    return _friction_spec("bouc_wen", [8e3 * s / z_max, 1.0, share / z_max, (1.0 - share) / z_max])


def _jenkins(n_el):
    def spec(s, sh):
        f = np.asarray(sh["limits"][:n_el]) * 8e3 * s
        k = f / np.asarray(sh["slips"][:n_el])
        return _friction_spec("jenkins", list(k) + list(f))
    return spec


def _jenkins_draw(n_el):
    def draw(rng):
        w = rng.dirichlet(np.ones(n_el) * 3)
        slips = np.sort(rng.uniform(0.0005, 0.012, n_el))
        return {"limits": [float(v) for v in w], "slips": [float(v) for v in slips]}
    return draw


FORMS: dict[str, list[Form]] = {
    "braid_friction": [
        Form("braid_friction", "dahl", "Dahl friction dF/de = sigma0 (1 - F/Fc sgn de) on the axial stress",
             lambda r: {"slip_strain": _u(r, 0.001, 0.006)}, _dahl),
        Form("braid_friction", "bouc_wen", "Bouc-Wen hysteretic stress alpha z, dz/de = A - (b sgn(z de) + g)|z|",
             lambda r: {"slip_strain": _u(r, 0.001, 0.006), "b_share": _u(r, 0.3, 0.7)}, _bouc_wen),
        Form("braid_friction", "jenkins4", "four Jenkins (spring + slider) elements in parallel on the axial stress",
             _jenkins_draw(4), _jenkins(4)),
        Form("braid_friction", "jenkins2", "two Jenkins (spring + slider) elements in parallel on the axial stress",
             _jenkins_draw(2), _jenkins(2)),
    ],
    "pressure_lag": [
        Form("pressure_lag", "cascade", "two cascaded first-order lags between the logged and the internal pressure",
             lambda r: {"tau1": _u(r, 0.05, 0.15), "ratio": _u(r, 0.3, 1.0)},
             lambda s, sh: {"pressure": {"kind": "cascade", "tau1": sh["tau1"] * s,
                                         "tau2": max(sh["tau1"] * sh["ratio"] * s, 1e-6)}}, s_max=10.0),
        Form("pressure_lag", "delay_lag", "a transport delay (tubing) followed by a first-order lag (muscle volume)",
             lambda r: {"delay": _u(r, 0.03, 0.1), "tau": _u(r, 0.02, 0.1)},
             lambda s, sh: {"pressure": {"kind": "delay_lag", "delay": sh["delay"] * s, "tau": sh["tau"] * s}},
             s_max=10.0),
    ],
    "second_relaxation": [
        Form("second_relaxation", "one_slow", "one slow Prony branch of the rubber (seconds to tens of seconds)",
             lambda r: {"tau": _u(r, 3.0, 20.0)},
             lambda s, sh: {"extra_branches": [{"share": 0.25 * s, "tau": sh["tau"]}]}, s_max=8.0),
        Form("second_relaxation", "two_slow", "two slow Prony branches of the rubber",
             lambda r: {"tau_a": _u(r, 2.5, 6.0), "tau_b": _u(r, 12.0, 40.0)},
             lambda s, sh: {"extra_branches": [{"share": 0.15 * s, "tau": sh["tau_a"]},
                                               {"share": 0.15 * s, "tau": sh["tau_b"]}]}, s_max=8.0),
    ],
    "asymmetric_relaxation": [
        Form("asymmetric_relaxation", "slow_deflation", "branches relax slower while the axial strain falls",
             lambda r: {"ratio": _u(r, 2.0, 4.0)},
             lambda s, sh: {"fall_ratio": float(math.exp(s * math.log(sh["ratio"])))}, s_max=3.0),
        Form("asymmetric_relaxation", "fast_deflation", "branches relax faster while the axial strain falls",
             lambda r: {"ratio": _u(r, 0.25, 0.5)},
             lambda s, sh: {"fall_ratio": float(math.exp(s * math.log(sh["ratio"])))}, s_max=3.0),
    ],
    "strain_stiffening": [
        Form("strain_stiffening", "exponential", "fibre recruitment: axial stress C (exp(k e1) - 1 - k e1)",
             lambda r: {"k": _u(r, 15.0, 35.0)},
             lambda s, sh: {"stiffening": {"kind": "exponential", "k": sh["k"],
                                           "C": 25e3 * s / (math.exp(0.1 * sh["k"]) - 1 - 0.1 * sh["k"])}}),
        Form("strain_stiffening", "polynomial", "cubic hyperelastic axial stress C e1^3",
             lambda r: {},
             lambda s, sh: {"stiffening": {"kind": "polynomial", "C": 25e6 * s, "k": 0.0}}),
    ],
    "thermal_softening": [
        Form("thermal_softening", "exponential", "moduli soften as 1 - a (1 - exp(-t/T)) over each run",
             lambda r: {"T": _u(r, 40.0, 200.0)},
             lambda s, sh: {"thermal": {"kind": "exponential", "a": min(0.06 * s, 0.5), "T": sh["T"]}}, s_max=8.0),
        Form("thermal_softening", "linear", "moduli soften linearly in elapsed time, 1 - b t",
             lambda r: {},
             lambda s, sh: {"thermal": {"kind": "linear", "b": 0.06 * s / 200.0}}, s_max=8.0),
    ],
    "angle_offset": [
        Form("angle_offset", "constant", "the angle sensor reads a constant zero offset",
             lambda r: {"sign": float(r.choice([-1.0, 1.0]))},
             lambda s, sh: {"offset": {"deg": sh["sign"] * s, "per_log_sd": 0.0}}, s_max=30.0),
        Form("angle_offset", "remounted", "a zero offset that shifts slightly each time the sensor is remounted",
             lambda r: {"sign": float(r.choice([-1.0, 1.0]))},
             lambda s, sh: {"offset": {"deg": sh["sign"] * s, "per_log_sd": 0.05 * s}}, s_max=30.0),
    ],
    # ---- outside the catalogue
    "payload_inertia": [
        Form("payload_inertia", "ringing", "a payload on the tip: P(beta) + m beta'' + c beta' = p, zeta 0.05",
             lambda r: {"zeta": _u(r, 0.03, 0.08)},
             lambda s, sh: {"inertia": {"f_n_hz": 4.0 / math.sqrt(max(s, 1e-12)), "zeta": sh["zeta"]}}, s_max=40.0),
        Form("payload_inertia", "damped", "a payload on the tip with moderate damping, zeta 0.1-0.2",
             lambda r: {"zeta": _u(r, 0.1, 0.2)},
             lambda s, sh: {"inertia": {"f_n_hz": 4.0 / math.sqrt(max(s, 1e-12)), "zeta": sh["zeta"]}}, s_max=40.0),
    ],
    "mullins": [
        Form("mullins", "ogden_roxburgh", "Mullins softening eta = 1 - (1/r) erf((e_max^2 - e1^2)/m) of the rubber",
             lambda r: {"m": _u(r, 0.001, 0.004)},
             lambda s, sh: {"mullins": {"rinv": min(0.15 * s, 0.9), "m": sh["m"]}}, s_max=6.0),
    ],
    "air_leak": [
        Form("air_leak", "orifice", "muscle fed through a line, leaking to ambient through an orifice ~ sqrt(p)",
             lambda r: {"tau_in": _u(r, 0.005, 0.02)},
             lambda s, sh: {"pressure": {"kind": "leak", "tau_in": sh["tau_in"], "k_leak": 6.0 * s / sh["tau_in"]}},
             s_max=20.0),
    ],
}


def forms_of(effect: str) -> list[Form]:
    if effect not in FORMS:
        raise KeyError(effect)
    return FORMS[effect]


def merge(specs: list[dict]) -> dict:
    """One physics spec from the empty one and the effects' partial specs (branches are concatenated)."""
    out = empty_spec()
    for sp in specs:
        for k, v in sp.items():
            if k == "extra_branches":
                out[k] = list(out[k]) + list(v)
            else:
                out[k] = v
    return out
