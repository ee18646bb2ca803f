"""The catalogue of physical effects the plain VBMM lacks (ids fixed by the project's discovery spec; docs/discover.md).

:data:`CATALOGUE` maps each id to ``"module:Class"``; :func:`get_effect` builds one. Adding an effect
is one new class plus one line here.
"""
from __future__ import annotations


from bpmid.registry import lookup

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
    """The class of catalogue effect ``effect_id`` (InputError naming the known ids otherwise)."""
    return lookup(CATALOGUE, effect_id, what="effect id", key="--effect")


def get_effect(effect_id: str, **settings):
    """An effect instance by id (settings select the twin's variant of the physics, where it has one)."""
    return effect_class(effect_id)(**settings)
