"""The effect interface: one catalogue entry = one physical effect the plain VBMM lacks.

An effect has a fixed id (the discovery spec; docs/discover.md), parameters with units, bounds and a default
(the "moderate size" the twin injects), a value that means "absent", and up to four *model terms*
that compose with the VBMM (:class:`AugmentedVBMM`):

1. ``transform_pressure``: the muscle sees a different pressure than the log (pressure_lag,
   braid_friction as a pressure dead band)
2. ``vbmm_changes``: keyword changes to the :class:`~bpmid.models.vbmm.VBMM` (an extra Prony branch,
   fall_ratio, stiffening)
3. ``modulus_scale``: a per-step scale of all moduli (thermal_softening)
4. ``transform_angle``: the sensor reads something else (angle_offset)

with the causal per-step form of 1 and 4 beside them (``causal_pressure``, ``causal_angle``), which the
closed loop (:func:`bpmid.control.causal_terms`) steps without naming any effect,

and a *signature* for screening (``signature_columns``): regressors whose projection explains the
residual when the effect is present (used by :mod:`bpmid.discover`). Adding an effect to the
catalogue is one new class plus one line in :data:`bpmid.effects.CATALOGUE`.

Units: pressure in Pa (gauge), angle in degrees, time in s.
"""
from __future__ import annotations

import abc
import copy
import dataclasses
import functools
from typing import ClassVar, Sequence

import numpy as np

from bpmid.io.motion_logs import MotionLog
from bpmid.models.vbmm import VBMM
from bpmid.params import ParamSet


class Effect(abc.ABC):
    """A catalogue effect. Constructors store settings only (e.g. the twin's variant of the physics)."""

    id: ClassVar[str] = ""
    meaning: ClassVar[str] = ""
    where_it_shows: ClassVar[str] = ""
    #: place on the signal path (logged pressure -> tubing -> friction -> rubber -> sensor): effects act in
    #: ascending order; the pressure and angle transforms do not commute, so each effect states its place
    signal_order: ClassVar[int] = 50
    #: settings (constructor arguments, ``SETTINGS``) -> their unit, for those that have one (``dead_time``: s)
    SETTING_UNITS: ClassVar[dict[str, str]] = {}

    @abc.abstractmethod
    def default_params(self) -> ParamSet:
        """Parameters (names prefixed ``<id>.``), default = the moderate size the twin injects; with bounds."""

    def null_values(self) -> dict[str, float]:
        """Parameter values at which the effect is absent (the augmented model equals the base)."""
        return {}

    # -- model terms (identity by default) ----------------------------------------------------
    def transform_pressure(self, t: np.ndarray, p: np.ndarray, params: ParamSet) -> np.ndarray:
        return p

    def vbmm_changes(self, base: VBMM, params: ParamSet) -> dict:
        return {}

    def modulus_scale(self, t: np.ndarray, params: ParamSet) -> np.ndarray | None:
        return None

    def pressure_modulus_scale(self, t: np.ndarray, p: np.ndarray, params: ParamSet) -> np.ndarray | None:
        """A per-step scale of all moduli that depends on the pressure the rubber sees (``p``, gauge Pa, after
        the pressure terms): the Mullins rival's softening below the largest pressure so far
        (:mod:`bpmid.discover.rivals`). No causal form: the closed loop refuses an effect that has one."""
        return None

    def transform_angle(self, t: np.ndarray, beta_deg: np.ndarray, params: ParamSet) -> np.ndarray:
        return beta_deg

    # -- causal per-step form (the closed loop steps the plant one sample at a time) ----------
    def causal_pressure(self, params: ParamSet) -> tuple | None:
        """The pressure term as operators stepped sample by sample, in order: ``(("delay", (d_s,)),
        ("lag", (tau_s,)), ("plays", (r_1_pa, ...)), ("frictions", (r_1_pa, mu_1, slip_1_pa, ...)))`` (see
        :data:`bpmid.control.CAUSAL_OPS`; a friction element is :func:`bpmid.effects._kernels.friction_step`,
        several are averaged like the plays); ``()`` when the
        effect leaves the pressure alone (the default when :meth:`transform_pressure` is not overridden).
        None: no causal form (the closed loop refuses the effect)."""
        return () if type(self).transform_pressure is Effect.transform_pressure else None

    def not_causal_because(self, params: ParamSet) -> str:
        """Why :meth:`causal_pressure` is None for these parameters, in words a user can act on (the closed loop
        and the C export quote it)."""
        return "its pressure term has no one-step form"

    def causal_angle(self, params: ParamSet) -> tuple[float, float] | None:
        """The sensor term per sample as ``(gain, offset_deg)``: the sensor reads ``gain * angle + offset_deg``;
        ``(1, 0)`` when :meth:`transform_angle` is not overridden. None: not affine (the closed loop refuses)."""
        return (1.0, 0.0) if type(self).transform_angle is Effect.transform_angle else None

    # -- screening signature (discover) -------------------------------------------------------
    def signature_columns(self, log: MotionLog, base_angle_deg: np.ndarray) -> np.ndarray:
        """(N, q) regressors of this effect's signature on ``log`` given the base model's prediction.
        Default: none (the effect is screened only by its refit)."""
        return np.zeros((log.n, 0))

    def describe(self, params: ParamSet, *, mark_held: bool = False) -> str:
        """``id (name = value unit, ...)``; ``mark_held``: a parameter held at its value (``fixed``: a fit's
        start or default, not estimated from the data) says so, as in a discovery verdict."""
        # a dimensionless parameter (unit "1") is printed bare: "share = 0", not "share = 0 1"
        vals = ", ".join(f"{p.name.split('.', 1)[-1]} = {p.value:.4g}" + ("" if p.unit in ("1", "") else f" {p.unit}")
                         + (_held_mark(p) if mark_held and p.fixed else "")
                         for p in params if p.name.startswith(self.id + "."))
        return f"{self.id} ({vals})"


def _held_mark(p) -> str:
    """How a verdict marks a parameter held at its value: one the data did not determine (its refit ran it onto a
    bound or left it undetermined, then held it) says so; one held from the start (a default, a config's hold) is
    "held, not fitted"."""
    return " (held: the data did not determine it)" if str(p.note).startswith("not identifiable") else \
        " (held, not fitted)"


@dataclasses.dataclass(frozen=True)
class AugmentedVBMM:
    """The VBMM plus effects, each with its parameters. With no effects it is the VBMM itself.

    Attributes
    ----------
    base : the VBMM
    effects : the effects in the order they act
    params : one ParamSet holding every effect's parameters (names ``<id>.<name>``)
    """

    base: VBMM
    effects: tuple[Effect, ...] = ()
    params: ParamSet = dataclasses.field(default_factory=lambda: ParamSet([]))

    def model(self) -> VBMM:
        """The VBMM with the effects' structural changes applied (made once per instance: the instance is frozen,
        and a fit simulates every log with it)."""
        return self._model

    @functools.cached_property
    def _model(self) -> VBMM:
        m = self.base
        for e in self.effects:
            changes = e.vbmm_changes(m, self.params)
            if changes:
                m = m.replace(**changes)
        return m

    def simulate_deg(self, t: np.ndarray, p_gauge_pa: np.ndarray, *, name: str = "log", path=None) -> np.ndarray:
        """Angle (deg) for a gauge-pressure history (Pa)."""
        t = np.asarray(t, float)
        p = np.asarray(p_gauge_pa, float)
        for e in self.effects:
            p = e.transform_pressure(t, p, self.params)
        scale = None
        for e in self.effects:
            for s in (e.modulus_scale(t, self.params), e.pressure_modulus_scale(t, p, self.params)):
                if s is not None:
                    scale = s if scale is None else scale * s
        beta = np.degrees(self.model().forward(t, p, scale=scale, name=name, path=path))
        for e in self.effects:
            beta = e.transform_angle(t, beta, self.params)
        return beta

    def simulate_log(self, log: MotionLog) -> np.ndarray:
        return self.simulate_deg(log.time_s, log.pressure_pa, name=log.name, path=log.path)


def signal_path_order(effect: Effect) -> int:
    """Sort key that puts effects in the order they act on the signal (:attr:`Effect.signal_order`)."""
    return effect.signal_order


def effect_params(effects: Sequence[Effect]) -> ParamSet:
    """The default parameters of several effects in one set."""
    out: list = []
    for e in effects:
        out.extend(e.default_params())
    return ParamSet(out)


def held(effect: Effect, values: dict[str, float]) -> Effect:
    """A copy of ``effect`` whose parameters named in ``values`` (``<id>.<name>``) are held at those values
    (fixed: a refit does not move them, and they count as no new parameter). Names of other effects are
    ignored; a name of this effect that it does not have, or a value outside its bounds, is a ValueError."""
    own = {k: float(v) for k, v in values.items() if k.split(".", 1)[0] == effect.id}
    if not own:
        return effect
    names = {p.name: p for p in effect.default_params()}
    for k, v in own.items():
        if k not in names:
            raise ValueError(f"{effect.id} has no parameter {k.split('.', 1)[1]!r} (it has: "
                             f"{', '.join(n.split('.', 1)[1] for n in names)})")
        if not names[k].lower <= v <= names[k].upper:
            raise ValueError(f"{k} = {v:g} is outside its bounds [{names[k].lower:g}, {names[k].upper:g}]")
    cls = type(effect)

    def default_params(self, _own=own, _base=cls.default_params) -> ParamSet:
        ps = _base(self)
        for k, v in _own.items():
            ps = ps.replace(k, value=v, fixed=True)
        return ps

    sub = type(cls.__name__, (cls,), {"default_params": default_params, "__module__": cls.__module__,
                                      "__qualname__": cls.__qualname__, "__doc__": cls.__doc__})
    out = copy.copy(effect)
    out.__class__ = sub
    return out
