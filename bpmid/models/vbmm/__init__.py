"""The VBMM's one home: the viscoelasticity-based mechanistic model of a bending pneumatic muscle.

- :mod:`.model`: geometry, closure, stresses, forward and inverse; the material and its one parameter naming
  (:func:`material_params`); the ``bpmid.vbmm/1`` file (one writer :func:`vbmm_yaml_body`, one reader
  :func:`load_vbmm` / :func:`vbmm_from_mapping`) and the one start rule (:func:`starting_vbmm`)
- :mod:`.fit`: ``bpmid fit motion`` (was ``bpmid.motion_fit``)
- :mod:`.family`: the registry's ``vbmm-mat`` and ``vbmm-fit`` families (was ``bpmid.models.vbmm_family``)
- the compiled forward kernel stays in :mod:`bpmid.models._vbmm_kernels`

``from bpmid.models.vbmm import VBMM`` gives the model (importing this package does not import fitting).
"""
from bpmid.models.vbmm.model import (  # noqa: F401
    DISCOVERY_BOUNDS, FIT_BOUNDS, MPa, VBMM, Geometry, Material, VBMMConfig, _BRANCH_KEYS, _CLOSURES,
    _MATERIAL_KEYS, _MODES, closure_pressure, geometry_from_yaml, kinematics, load_vbmm, material_from_yaml,
    material_params, material_yaml, starting_vbmm, triangle_pressure, u3_from_beta, vbmm_from_mapping,
    vbmm_yaml_body,
)
from bpmid.models.vbmm.model import K  # noqa: F401  (the compiled kernels, as model.py names them)

__all__ = ["Geometry", "Material", "VBMM", "VBMMConfig", "kinematics", "u3_from_beta", "closure_pressure",
           "load_vbmm", "vbmm_from_mapping", "starting_vbmm", "material_params", "material_yaml", "FIT_BOUNDS",
           "DISCOVERY_BOUNDS", "vbmm_yaml_body", "material_from_yaml", "geometry_from_yaml", "triangle_pressure"]
