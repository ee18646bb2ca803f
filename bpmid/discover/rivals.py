"""Rivals: explanations outside the catalogue that discovery tests against the effect it is about to name.

An effect the catalogue cannot represent still leaves a residual, and some catalogue entry usually takes part of
it up: a payload on the tip that rings after every change of the pressure rate adds delay, and a pressure lag
(one or two first-order lags: it cannot overshoot) removes much of that delay; a muscle that leaks air through an
orifice falls short of the supply pressure by an amount growing as the square root of its pressure, and an angle
offset (with the stiffness refitted) takes up most of that shortfall over a working range; rubber that softens
below the largest stretch so far (the Mullins effect) opens a loop that friction or a slower deflation partly
takes up; a pressure transducer's noise, which the muscle never saw, passes through a model driven by the logged
pressure into its angle, and a lag of a sample or two averages it away. Judged only against the other catalogue
entries, the lag, the offset or the friction would be named. A rival is a model term for such an outside
effect, refitted and scored exactly like a candidate (:func:`bpmid.discover.confirm.confirm`: the same starts,
nuisance and held-out logs);
when it explains the held-out logs better than the effect the round would name, and it needs what only it has,
nothing is named that round and the remainder is reported unexplained, with the rival's constants as a clue.

Rivals are never named: they stand for physics the catalogue lacks, so naming them would claim more than the test
shows (that the residual rings, not that it is a payload). The rule has no calibrated number:

1. the rival was tested (its refit moved) and passes the round's likelihood-ratio test on the fitting logs
   (its p below the family-wise level, uncorrected: it is one test beside the candidates, and passing it only ever
   withholds a name);
2. it fits what only it can do: :class:`PayloadInertia`'s damping ratio stays inside its range, not on the upper
   bound 0.5 (at the bound the data asked for a response that does not overshoot, which a lag represents);
   :class:`AirLeak`'s orifice constant is off its lower bound 0 (a leak at all); :class:`MullinsSoftening`'s
   softening is off its lower bound 0; :class:`PressureNoise`'s smoothing width is above 0, and the lag, refitted on
   top of the smoothing, adds nothing more (:func:`adds_beside`: the noise and a lag can both be there);
3. its held-out RMSE is below the named candidate's (for two effects named together, below the better of the two
   alone).

Every rival of :data:`RIVALS` is refitted in each round that would name something, except that one listed in
:data:`IMITATES` is asked only of the effects it can pass for (noise on the logged pressure, of a pressure lag:
a lag of a sample or two averages the pressure's noise away; no other catalogue entry smooths the pressure); the
first that takes the round withholds it.
"""
from __future__ import annotations

import math
from typing import ClassVar, Optional, Sequence

import numpy as np

from bpmid.discover.confirm import Confirmation, heldout_drop_sigma, p_words
from bpmid.effects import _kernels
from bpmid.effects.base import Effect
from bpmid.io.motion_logs import MotionLog
from bpmid.params import Param, ParamSet


class PayloadInertia(Effect):
    """A payload on the tip whose inertia makes the measured angle ring: the sensor sees the muscle's angle through
    an underdamped second-order response ``y'' + 2 zeta w y' + w^2 y = w^2 beta`` (``w = 2 pi / period``), exact
    for an angle linear between samples (:func:`bpmid.effects._kernels.ring`). Outside the catalogue: a rival only
    (:mod:`bpmid.discover.rivals`)."""

    id = "payload_inertia"
    signal_order = 95
    meaning = "a payload whose inertia makes the angle ring after each change of the pressure rate (outside the catalogue)"
    where_it_shows = "an overshoot and a decaying oscillation after the corners of the pressure profile"
    SETTINGS: ClassVar[tuple[str, ...]] = ()
    #: the damping ratio's upper bound: a response that overshoots by at least 16 % (exp(-pi zeta / sqrt(1 -
    #: zeta^2))); a fit on this bound asked for less ringing than that, which a lag represents
    ZETA_MAX = 0.5
    #: starting values a refit tries: natural periods from a few samples at 100 Hz to 2 s, light to strong damping
    START_VALUES: ClassVar[dict] = {"period": (0.05, 0.15, 0.4, 1.0, 2.0), "zeta": (0.05, 0.15, 0.3)}

    def default_params(self) -> ParamSet:
        return ParamSet([
            Param(f"{self.id}.period", 0.4, "s", 0.0, 5.0, note="natural period of the ringing"),
            Param(f"{self.id}.zeta", 0.15, "1", 0.01, self.ZETA_MAX, note="damping ratio"),
        ])

    def null_values(self):
        return {f"{self.id}.period": 0.0}

    def transform_angle(self, t, beta_deg, params):
        period = params.value(f"{self.id}.period")
        return beta_deg if period <= 0.0 else _kernels.ring(t, beta_deg, period, params.value(f"{self.id}.zeta"))

    def causal_angle(self, params):
        return None   # not an affine sensor term: the closed loop refuses it (it is never named anyway)

    def signature_columns(self, log: MotionLog, base_angle_deg: np.ndarray) -> np.ndarray:
        # y ~ beta - (2 zeta / w) beta' - (1 - 4 zeta^2) / w^2 beta''
        d1 = np.gradient(base_angle_deg, log.time_s) if log.n > 1 else np.zeros(log.n)
        d2 = np.gradient(d1, log.time_s) if log.n > 1 else np.zeros(log.n)
        return np.column_stack([-d1, -d2])


class AirLeak(Effect):
    """A muscle that leaks air through an orifice while fed through its supply line: in steady flow the line's
    inflow, proportional to the pressure drop along it, equals the orifice's outflow, proportional to the square
    root of the muscle's gauge pressure (turbulent orifice flow), so the muscle's pressure ``p`` falls short of the
    supply ``p_s`` by ``c sqrt(p)``: ``p = p_s - c sqrt(p)``, solved exactly (``sqrt(p) = (sqrt(c^2 + 4 p_s) -
    c) / 2``). ``c`` (sqrt(Pa)) is the orifice's conductance over the line's. A linear (laminar) leak would only
    scale the pressure, which the stiffness takes up; the square root is what no catalogue entry has. Outside the
    catalogue: a rival only (:mod:`bpmid.discover.rivals`)."""

    id = "air_leak"
    signal_order = 12
    meaning = ("a muscle that leaks air through an orifice: its pressure falls short of the supply by an amount "
               "growing as the square root of the pressure (outside the catalogue)")
    where_it_shows = "an angle shortfall that grows with the pressure, steepest at low pressure"
    SETTINGS: ClassVar[tuple[str, ...]] = ()
    #: starting values a refit tries: a shortfall of about 0.3 %, 1.5 % and 6 % at 1 bar gauge
    START_VALUES: ClassVar[dict] = {"c": (1.0, 5.0, 20.0)}

    def default_params(self) -> ParamSet:
        return ParamSet([Param(f"{self.id}.c", 5.0, "Pa^0.5", 0.0, 300.0,
                               note="orifice over line conductance: shortfall c sqrt(p) (Pa)")])

    def null_values(self):
        return {f"{self.id}.c": 0.0}

    def transform_pressure(self, t, p, params):
        c = params.value(f"{self.id}.c")
        if c <= 0.0:
            return p
        p = np.asarray(p, float)
        root = 0.5 * (np.sqrt(c * c + 4.0 * np.maximum(p, 0.0)) - c)
        return np.where(p > 0.0, root * root, p)

    def signature_columns(self, log: MotionLog, base_angle_deg: np.ndarray) -> np.ndarray:
        return np.zeros((log.n, 0))


class MullinsSoftening(Effect):
    """The Mullins effect: filled rubber softens once stretched, and on every later loading below the largest
    stretch so far it is softer than on the first (the softening recovers only with rest). With the muscle's
    pressure as the measure of its stretch, all moduli scale by ``1 - d erf((pm^2 - p^2) / (w pm^2))`` with ``pm``
    the largest pressure (gauge, after the pressure terms) since the start of the log (each log starts from a
    rested muscle): 1 while the pressure is at its largest so far (the first loading), less below it; ``d`` the
    largest fractional softening, ``w`` how far below the largest pressure it takes hold (a share of ``pm^2``).
    A loop from softening below the previous largest pressure looks like friction or a slower deflation, which
    the catalogue has; what only this has is its dependence on the largest pressure so far. Outside the
    catalogue: a rival only (:mod:`bpmid.discover.rivals`)."""

    id = "mullins"
    signal_order = 30
    meaning = ("the Mullins effect: rubber stretched once is softer on every later loading below the largest "
               "stretch so far (outside the catalogue)")
    where_it_shows = "a softer return and reloading below the largest pressure so far in each log"
    SETTINGS: ClassVar[tuple[str, ...]] = ()
    #: starting values a refit tries: 2 %, 8 % and 25 % softening, taking hold just below the largest pressure or
    #: over most of the range
    START_VALUES: ClassVar[dict] = {"d": (0.02, 0.08, 0.25), "w": (0.05, 0.3, 1.5)}
    #: a pressure below this share of the log's largest counts as none (a log starting at rest: no softening
    #: before the muscle was loaded)
    _PM_FLOOR = 1e-3

    def default_params(self) -> ParamSet:
        return ParamSet([
            Param(f"{self.id}.d", 0.1, "1", 0.0, 0.6, note="largest fractional softening below the largest pressure"),
            Param(f"{self.id}.w", 0.3, "1", 0.01, 5.0, log_scale=True,
                  note="how far below the largest pressure it takes hold (share of its square)"),
        ])

    def null_values(self):
        return {f"{self.id}.d": 0.0}

    def pressure_modulus_scale(self, t, p, params):
        d = params.value(f"{self.id}.d")
        if d <= 0.0:
            return None
        w = params.value(f"{self.id}.w")
        p = np.maximum(np.asarray(p, float), 0.0)
        pm = np.maximum.accumulate(p) if p.size else p
        floor = max(self._PM_FLOOR * (float(pm[-1]) if pm.size else 0.0), 1e-9)
        pm_safe = np.maximum(pm, floor)
        x = np.where(pm > floor, (pm_safe ** 2 - p ** 2) / (w * pm_safe ** 2), 0.0)   # at rest before loading: none
        return 1.0 - d * _erf(np.clip(x, 0.0, None))

    def signature_columns(self, log: MotionLog, base_angle_deg: np.ndarray) -> np.ndarray:
        return np.zeros((log.n, 0))


class PressureNoise(Effect):
    """Noise of the pressure transducer: the logged pressure carries noise the muscle never saw, and a model
    driven by the logged pressure passes that noise on to its angle. Any term that smooths the logged pressure
    takes part of it out again, and a pressure lag does so too: with the time constant of a sample or two it is a
    one-sided average of the last samples, which removes the noise and adds a delay the data need not ask for.
    This rival smooths the logged pressure with a zero-phase Gaussian kernel (standard deviation ``width``, s, in
    the log's median sample spacing): the same removal of noise with no delay, so a lag that explains nothing
    more than this is not shown to be there. Outside the catalogue: a rival only, held against a pressure lag
    (:data:`IMITATES`; :mod:`bpmid.discover.rivals`)."""

    id = "pressure_noise"
    signal_order = 5     # on the logged pressure, before any other pressure term
    meaning = ("noise on the logged pressure, which the muscle never saw: a smoothing of the logged pressure with "
               "no delay removes what the model passes on of it (outside the catalogue)")
    where_it_shows = "a residual that follows the logged pressure's sample-to-sample noise"
    SETTINGS: ClassVar[tuple[str, ...]] = ()
    #: starting values a refit tries: 1, 4 and 15 samples at 100 Hz (0.1 to 1.5 samples at 10 Hz)
    START_VALUES: ClassVar[dict] = {"width": (0.01, 0.04, 0.15)}

    def default_params(self) -> ParamSet:
        return ParamSet([Param(f"{self.id}.width", 0.02, "s", 0.0, 0.5,
                               note="standard deviation of the zero-phase Gaussian smoothing of the logged pressure")])

    def null_values(self):
        return {f"{self.id}.width": 0.0}

    def transform_pressure(self, t, p, params):
        width = params.value(f"{self.id}.width")
        p = np.asarray(p, float)
        if width <= 0.0 or p.size < 3:
            return p
        dt = float(np.median(np.diff(np.asarray(t, float))))
        if not dt > 0.0:
            return p
        from scipy.ndimage import gaussian_filter1d

        return gaussian_filter1d(p, width / dt, mode="nearest")

    def causal_pressure(self, params):
        return None   # two-sided: no step-by-step form (it is never named)

    def not_causal_because(self, params):
        return "it smooths the logged pressure in both directions of time"

    def signature_columns(self, log: MotionLog, base_angle_deg: np.ndarray) -> np.ndarray:
        return np.zeros((log.n, 0))


def _erf(x: np.ndarray) -> np.ndarray:
    from scipy.special import erf

    return erf(x)


#: the rivals a round that names something is checked against, in the order they are asked
RIVALS: tuple[type[Effect], ...] = (PayloadInertia, AirLeak, MullinsSoftening, PressureNoise)
#: a rival held only against the catalogue effects it can be mistaken for (by id); the others against every effect.
#: Such a rival is a nuisance that can stand beside the effect: before it takes the round, the effect is refitted on
#: top of it (:func:`adds_beside`)
IMITATES: dict[str, tuple[str, ...]] = {PressureNoise.id: ("pressure_lag",)}


def adds_beside(beside: Confirmation, rival: Confirmation, alpha: float, floor: float, drop_min: float) -> bool:
    """Whether an effect refitted on top of the fit of a rival of :data:`IMITATES` (``beside``) still adds what the
    rival cannot: tested, its likelihood-ratio p below ``alpha`` (uncorrected, as the rival's own test), and a
    held-out drop below the rival alone (``sqrt(rival^2 - beside^2)``, in noise floors of ``floor`` deg) of at least
    ``drop_min`` (discovery asks the drop the gate asks of that effect on the path to the noise floor). Noise on the
    logged pressure and a pressure lag can both be there: a short lag beside heavy noise is half smoothing, and the
    smoothing alone can edge the lag out although the data still ask for its delay on top of it (a 10 ms lag at
    100 Hz beside 300 Pa: p 1e-105, a drop of 0.24 noise floors; a lag beside the smoothing of pure noise: p 3e-9
    and 2e-5, drops of 0.07). Discovery stores the answer on the rival (``effect_beside_adds``), and
    :func:`own_shape` reads it: a rival that leaves the effect something to add does not take the round."""
    return bool(beside.tested and math.isfinite(beside.lr_p) and beside.lr_p < alpha
                and heldout_drop_sigma(rival.heldout_rmse_after, beside.heldout_rmse_after, floor) >= drop_min)


def held_against(rival_id: str, named: Sequence[str]) -> bool:
    """Whether the rival ``rival_id`` is asked of a round that would name ``named`` (effect ids; two for a pair):
    :data:`IMITATES` limits a rival to the effects it can pass for, the others are asked of every name."""
    only = IMITATES.get(rival_id)
    return only is None or any(n in only for n in named)


#: the first rival (kept for callers that know one)
RIVAL: type[Effect] = PayloadInertia

#: how close to the damping ratio's upper bound counts as on it (relative)
_BOUND_TOL = 0.02


def own_shape(c: Confirmation) -> bool:
    """Condition 2: the rival's fit needs what only it has (for :class:`PayloadInertia`: damping inside its range,
    off the upper bound; for :class:`AirLeak`: a leak at all, its constant above 0)."""
    if c.effect_id == PayloadInertia.id:
        z = c.state.params.value(f"{PayloadInertia.id}.zeta")
        period = c.state.params.value(f"{PayloadInertia.id}.period")
        return bool(period > 0.0 and z < PayloadInertia.ZETA_MAX * (1.0 - _BOUND_TOL))
    if c.effect_id == AirLeak.id:
        return bool(c.state.params.value(f"{AirLeak.id}.c") > 0.0)
    if c.effect_id == MullinsSoftening.id:
        return bool(c.state.params.value(f"{MullinsSoftening.id}.d") > 0.0)
    if c.effect_id == PressureNoise.id:
        return bool(c.state.params.value(f"{PressureNoise.id}.width") > 0.0) and not c.effect_beside_adds
    return True


def takes_the_round(tested: bool, needs_own_shape: bool, lr_p: float, after: float, named_after: float,
                    alpha: float) -> bool:
    """The rule (the three conditions of the module docstring) on a rival's numbers: tested, its likelihood-ratio
    p below ``alpha``, its own shape needed, and its held-out RMSE ``after`` below the named effect's
    ``named_after`` (the same unit). Discovery applies it to a refit (:func:`beats`), the calibration to the
    recorded numbers (:func:`bpmid.discover.calibrate.rival_withholds`)."""
    return bool(tested and math.isfinite(lr_p) and lr_p < alpha and needs_own_shape
                and math.isfinite(after) and after < named_after)


def beats(c: Confirmation, named_after_deg: float, alpha: float) -> bool:
    """Whether the rival ``c`` takes the round from an effect that leaves ``named_after_deg`` of held-out RMSE."""
    return takes_the_round(c.tested, own_shape(c), c.lr_p, c.heldout_rmse_after, named_after_deg, alpha)


def rival_constants(c: Confirmation) -> dict:
    """The rival's fitted constants by short name (for the report)."""
    return {n.split(".", 1)[1]: float(c.state.params.value(n)) for n in c.effect_params}


def rival_words(c: Confirmation, named: str, named_after_deg: float, floor: float) -> str:
    """Why nothing was named: the rival and its numbers beside the candidate it beat."""
    k = rival_constants(c)
    if c.effect_id == PayloadInertia.id:
        what = (f"a response that rings with a natural period of {k.get('period', math.nan):.3g} s and a damping "
                f"ratio of {k.get('zeta', math.nan):.2f}")
        eg, cannot = "e.g. a payload's inertia", "no catalogue entry can ring"
    elif c.effect_id == AirLeak.id:
        short = k.get("c", math.nan) * math.sqrt(1e5)
        what = (f"a pressure shortfall growing as the square root of the pressure ({short:.3g} Pa at 1 bar gauge, "
                f"c = {k.get('c', math.nan):.3g} Pa^0.5)")
        eg, cannot = "e.g. an air leak through an orifice", "no catalogue entry falls short as the square root"
    elif c.effect_id == MullinsSoftening.id:
        what = (f"rubber {100 * k.get('d', math.nan):.3g} % softer below the largest pressure so far in each log "
                f"(w = {k.get('w', math.nan):.3g})")
        eg, cannot = "e.g. the Mullins effect", "no catalogue entry remembers the largest pressure"
    elif c.effect_id == PressureNoise.id:
        what = ("noise on the logged pressure (a zero-phase Gaussian smoothing of it, no delay, standard deviation "
                f"{k.get('width', math.nan):.3g} s)")
        b = c.effect_beside
        eg, cannot = ("e.g. the pressure transducer's own noise, which the muscle never saw",
                      "a lag smooths the logged pressure too, but adds a delay the data did not ask for"
                      + ("" if b is None else
                         f": refitted on top of the smoothing, {b.effect_id} leaves a held-out RMSE of "
                         f"{b.heldout_rmse_after:.4g} deg, likelihood-ratio p {p_words(b.lr_p)}"))
    else:
        what, eg, cannot = c.effect_id, "", "no catalogue entry represents it"
    return (f"withheld: the residual is explained better by {what} ({c.effect_id}: outside the catalogue"
            f"{', ' + eg if eg else ''}): held-out RMSE {c.heldout_rmse_after:.4g} deg against "
            f"{named_after_deg:.4g} deg with {named} ({c.heldout_rmse_after / floor:.3f} vs "
            f"{named_after_deg / floor:.3f} noise floors), likelihood-ratio p "
            f"{p_words(c.lr_p)}; {cannot}, so {named} would only imitate it and "
            "nothing is named this round")


def check_rival(c: Optional[Confirmation], named: str, named_after_deg: float, alpha: float,
                floor: float) -> Optional[str]:
    """The reason to withhold ``named`` (None: the rival does not take the round)."""
    if c is None or not beats(c, named_after_deg, alpha):
        return None
    return rival_words(c, named, named_after_deg, floor)
