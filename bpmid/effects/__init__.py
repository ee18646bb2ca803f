"""The catalogue of physical effects the plain VBMM lacks (ids fixed by ../shared/spec/DISCOVER.md).

:data:`CATALOGUE` maps each id to ``"module:Class"``; :func:`get_effect` builds one. Adding an effect
is one new class plus one line here.
"""
from __future__ import annotations

import importlib

from bpmid.errors import InputError

#: id -> "module:Class"
CATALOGUE: dict[str, str] = {
    "second_relaxation": "bpmid.effects.catalogue:SecondRelaxation",
    "braid_friction": "bpmid.effects.catalogue:BraidFriction",
    "pressure_lag": "bpmid.effects.catalogue:PressureLag",
    "asymmetric_relaxation": "bpmid.effects.catalogue:AsymmetricRelaxation",
    "strain_stiffening": "bpmid.effects.catalogue:StrainStiffening",
    "angle_offset": "bpmid.effects.catalogue:AngleOffset",
    "thermal_softening": "bpmid.effects.catalogue:ThermalSoftening",
}


def effect_class(effect_id: str):
    if effect_id not in CATALOGUE:
        raise InputError(f"unknown effect id {effect_id!r} (known: {', '.join(CATALOGUE)})", key="--effect")
    module, cls = CATALOGUE[effect_id].split(":")
    return getattr(importlib.import_module(module), cls)


def get_effect(effect_id: str, **settings):
    """An effect instance by id (settings select the twin's variant of the physics, where it has one)."""
    return effect_class(effect_id)(**settings)
