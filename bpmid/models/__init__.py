"""Model families, by registry name. Adding a family: one new module plus one line here."""
from __future__ import annotations


from bpmid.errors import InputError
from bpmid.registry import lookup

#: registry name -> "module:Class" (imported on first use)
REGISTRY: dict[str, str] = {
    "vbmm-mat": "bpmid.models.vbmm.family:VBMMMatModel",
    "vbmm-fit": "bpmid.models.vbmm.family:VBMMFitModel",
    "gpi": "bpmid.models.gpi:GPIModel",
    "maxwell-slip": "bpmid.models.maxwell_slip:MaxwellSlipModel",
    "three-element": "bpmid.models.three_element:ThreeElementModel",
    "two-branch": "bpmid.models.two_branch:TwoBranchModel",
}


def model_class(name: str):
    """The class registered as ``name`` (InputError naming the known ones otherwise)."""
    return lookup(REGISTRY, name, what="model", key="--models")


def parse_model_list(text: str) -> list[str]:
    """``"gpi,maxwell-slip"`` -> ``["gpi", "maxwell-slip"]``, each checked against the registry."""
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise InputError("empty model list", key="--models")
    for n in names:
        if n not in REGISTRY:
            raise InputError(f"unknown model {n!r} (known: {', '.join(REGISTRY)})", key="--models")
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(f"model {dup[0]!r} is listed twice", key="--models")
    return names
