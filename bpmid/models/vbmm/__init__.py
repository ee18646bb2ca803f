"""The VBMM's one home: the viscoelasticity-based mechanistic model of a bending pneumatic muscle.

- :mod:`.model`: geometry, closure, stresses, forward and inverse; the material and its one parameter naming
  (:func:`material_params`); the ``bpmid.vbmm/1`` file (one writer :func:`vbmm_yaml_body`, one reader
  :func:`load_vbmm` / :func:`vbmm_from_mapping`) and the one start rule (:func:`starting_vbmm`)
- :mod:`.fit`: ``bpmid fit motion`` (was ``bpmid.motion_fit``)
- :mod:`.family`: the registry's ``vbmm-mat`` and ``vbmm-fit`` families (was ``bpmid.models.vbmm_family``)
- the compiled forward kernel stays in :mod:`bpmid.models._vbmm_kernels`

``from bpmid.models.vbmm import VBMM`` gives the model (importing this package does not import fitting).
"""
from bpmid.models.vbmm import model as _model

# every name of model.py (public and private, including ones added later on other branches) stays importable
# from here, as it was when the model was the module bpmid/models/vbmm.py
globals().update({k: v for k, v in vars(_model).items() if not (k.startswith("__") and k.endswith("__"))})

__all__ = ["Geometry", "Material", "VBMM", "VBMMConfig", "kinematics", "u3_from_beta", "closure_pressure",
           "load_vbmm", "vbmm_from_mapping", "starting_vbmm", "material_params", "material_yaml", "FIT_BOUNDS",
           "DISCOVERY_BOUNDS", "vbmm_yaml_body", "material_from_yaml", "geometry_from_yaml", "triangle_pressure"]
