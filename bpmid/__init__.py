"""bpmid: identify models of bending pneumatic muscles (BPMs).

Data flows one way: files -> logs (``bpmid.io``) -> model + parameters (``bpmid.models``)
-> simulation -> metrics (``bpmid.metrics``) -> results (``bpmid.results``) -> report.

The public API, one call per workflow, each returning a result with ``.params``, ``.summary()``, ``.plot()``,
``.save(path)`` (and ``bpmid.load(path)`` to read any file bpmid writes back)::

    import bpmid
    relax = bpmid.fit_relaxation(bpmid.data.files("datasets/relaxation/*.csv"))
    fit = bpmid.fit_motion(bpmid.data.files("datasets/motion/fitting_set/*.csv"), init=relax)
    print(fit.summary())

Everything is imported on first use (``import bpmid`` costs the standard library only).
"""
from __future__ import annotations

import importlib

__version__ = "0.1.0"

from bpmid.errors import BpmidWarning, InputError  # noqa: E402  (standard library only)

#: modules that moved, old name -> new name: ``import bpmid.motion_fit`` gives the very module object of
#: ``bpmid.models.vbmm.fit`` (so patches and isinstance checks see one module)
MOVED: dict[str, str] = {
    "bpmid.motion_fit": "bpmid.models.vbmm.fit",
    "bpmid.models.vbmm_family": "bpmid.models.vbmm.family",
}


class _MovedModuleFinder:
    """Finds the modules of :data:`MOVED` under their old names (a meta-path finder and its loader)."""

    def find_spec(self, name, path=None, target=None):
        if name not in MOVED:
            return None
        from importlib.machinery import ModuleSpec

        return ModuleSpec(name, self, origin=MOVED[name])

    def create_module(self, spec):
        return importlib.import_module(MOVED[spec.name])

    def exec_module(self, module):
        pass


if not any(isinstance(f, _MovedModuleFinder) for f in __import__("sys").meta_path):
    __import__("sys").meta_path.insert(0, _MovedModuleFinder())

#: public name -> "module:attribute" (imported on first access)
_LAZY: dict[str, str] = {
    # workflows
    "fit_relaxation": "bpmid.api:fit_relaxation",
    "fit_motion": "bpmid.api:fit_motion",
    # these five are also the modules of their science, made callable (see bpmid._callable)
    "predict": "bpmid.predict",
    "compare": "bpmid.compare",
    "discover": "bpmid.discover",
    "control": "bpmid.control",
    "export": "bpmid.export",   # the module of the exporters, callable as bpmid.api.export
    "simulate": "bpmid.api:simulate",
    "run_study": "bpmid.api:run_study",
    "load": "bpmid.results:load",
    # log readers
    "from_arrays": "bpmid.api:from_arrays",
    "read_motion_logs": "bpmid.api:read_motion_logs",
    "read_relax_logs": "bpmid.api:read_relax_logs",
    "MotionLog": "bpmid.io.motion_logs:MotionLog",
    # models and registries
    "VBMM": "bpmid.models.vbmm:VBMM",
    "Material": "bpmid.models.vbmm:Material",
    "Geometry": "bpmid.models.vbmm:Geometry",
    "load_vbmm": "bpmid.models.vbmm:load_vbmm",
    "VBMMMatModel": "bpmid.models.vbmm.family:VBMMMatModel",
    "VBMMFitModel": "bpmid.models.vbmm.family:VBMMFitModel",
    "GPIModel": "bpmid.models.gpi:GPIModel",
    "MaxwellSlipModel": "bpmid.models.maxwell_slip:MaxwellSlipModel",
    "ThreeElementModel": "bpmid.models.three_element:ThreeElementModel",
    "TwoBranchModel": "bpmid.models.two_branch:TwoBranchModel",
    "ModelFamily": "bpmid.models.base:ModelFamily",
    "REGISTRY": "bpmid.models:REGISTRY",
    "model_class": "bpmid.models:model_class",
    "CATALOGUE": "bpmid.effects:CATALOGUE",
    "get_effect": "bpmid.effects:get_effect",
    "Param": "bpmid.params:Param",
    "ParamSet": "bpmid.params:ParamSet",
    # results
    "Result": "bpmid.results:Result",
    "ParamInfo": "bpmid.results:ParamInfo",
    "RelaxationResult": "bpmid.results:RelaxationResult",
    "VBMMFitResult": "bpmid.results:VBMMFitResult",
    "PredictionResult": "bpmid.results:PredictionResult",
    "ComparisonResult": "bpmid.results:ComparisonResult",
    "DiscoveryResult": "bpmid.results:DiscoveryResult",
    "SimulationResult": "bpmid.results:SimulationResult",
    "ControlResult": "bpmid.results:ControlResult",
    "StudyResult": "bpmid.results:StudyResult",
    # configuration
    "load_config": "bpmid.config:load_config",
}
#: public subpackages/modules reachable as attributes (``bpmid.units``, ``bpmid.data``)
_SUBMODULES = ("units", "data", "results", "api", "models", "effects", "metrics")

__all__ = ["__version__", "InputError", "BpmidWarning", *_LAZY, *_SUBMODULES]


def __getattr__(name: str):
    target = _LAZY.get(name)
    if target is not None:
        module, _, attr = target.partition(":")
        value = importlib.import_module(module)
        value = getattr(value, attr) if attr else value
        globals()[name] = value  # later lookups skip this function
        return value
    if name in _SUBMODULES:
        return importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module 'bpmid' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
