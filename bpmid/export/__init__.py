"""``bpmid export``: a fitted model in another tool's format, dispatched by target (``--to``).

- ``c``: dependency-free C99 of a ``bpmid.vbmm/1`` fit (or, with ``model``, of the vbmm-fit, vbmm-mat or
  Maxwell-slip model in a ``bpmid.compare/1`` file, or the MS-PI feedforward of a ``bpmid.control/1`` file):
  :mod:`bpmid.export.c`
- ``abaqus``, ``ansys``, ``comsol``: material cards of a ``bpmid.relax/1`` fit (:mod:`bpmid.export.fea`)
"""
from __future__ import annotations

from pathlib import Path

from bpmid.errors import InputError

#: target -> the schemas of the fit files it takes
TARGETS: dict[str, tuple[str, ...]] = {"c": ("bpmid.vbmm/", "bpmid.compare/", "bpmid.control/"),
                                       "abaqus": ("bpmid.relax/",), "ansys": ("bpmid.relax/",),
                                       "comsol": ("bpmid.relax/",)}


def export(fit_path: str | Path, to: str, out_dir: str | Path, *, model: str | None = None,
           command: str | None = None) -> list[Path]:
    """Write ``fit_path`` in format ``to`` into ``out_dir`` (whole or not at all); returns the files written.

    The fit file's schema must suit the target (``bpmid.vbmm/1`` for C, or a compare/control file with
    ``model="maxwell-slip"``; ``bpmid.relax/1`` for the FEA formats); otherwise InputError naming ``schema``.
    """
    from bpmid.io.results import read_result

    to = str(to).strip().lower()   # --to Abaqus is abaqus
    if to not in TARGETS:
        raise InputError(f"unknown target {to!r} (known: {', '.join(TARGETS)})", key="--to")
    fit_path = Path(fit_path)
    schemas = TARGETS[to]
    if to == "c":
        if model is None or model == "vbmm":
            schemas = ("bpmid.vbmm/",)
        elif model in ("vbmm-fit", "vbmm-mat"):
            schemas = ("bpmid.compare/",)
        elif model == "maxwell-slip":
            schemas = ("bpmid.compare/", "bpmid.control/")
        else:
            raise InputError(f"unknown model {model!r} for --to c (known: vbmm, vbmm-fit, vbmm-mat, maxwell-slip)",
                             key="--model")
    _say_what_fits(fit_path, to, model, schemas)
    read_result(fit_path, schemas)
    if to == "c":
        from bpmid.export.c import export_c

        return export_c(fit_path, out_dir, model or "vbmm", command=command)
    if model is not None:
        raise InputError(f"--model {model} applies to --to c only", key="--model")
    from bpmid.export.fea import export_fea  # the material-fits helper's module, loaded only for FEA targets

    return export_fea(fit_path, to, Path(out_dir))


#: what each kind of bpmid file is, and what to export instead (for a file the target does not take)
_KIND_WORDS = {
    "bpmid.vbmm/": ("a motion fit (bpmid fit motion, or discover's model.yaml)", "export it with --to c"),
    "bpmid.compare/": ("a comparison", "export one of its models with --to c --model vbmm-fit, vbmm-mat or "
                                       "maxwell-slip"),
    "bpmid.control/": ("a control result", "export its MS-PI feedforward with --to c --model maxwell-slip"),
    "bpmid.relax/": ("a material fit (bpmid fit relax)", "export it with --to abaqus, ansys or comsol"),
    "bpmid.discovery/": ("discover's verdict", "export the fit beside it instead, discover/model.yaml, with --to c"),
    "bpmid.run/": ("a study's record", "export one of its fits instead: relax_fit.yaml (--to abaqus, ansys or "
                                       "comsol), vbmm_fit.yaml (--to c) or compare/compare.yaml (--to c --model ...)"),
}


def _say_what_fits(fit_path: Path, to: str, model: str | None, schemas: tuple[str, ...]) -> None:
    """Refuse a fit file the target (and model) does not take, saying what the file is and what to do with it;
    silent for a file it takes (read_result then checks it whole)."""
    from bpmid.config import read_yaml

    data, _sha = read_yaml(fit_path)
    schema = str(data.get("schema", "")) if isinstance(data, dict) else ""
    if not schema or schema.startswith(schemas):
        return
    kind = next((k for k in _KIND_WORDS if schema.startswith(k)), None)
    asked = f"--to {to}" + (f" --model {model}" if model else "")
    wants = " or ".join(x.rstrip("/") + "/1" for x in schemas)
    if kind is None:
        raise InputError(f"a {schema} file: {asked} takes a {wants} file", path=fit_path, key="schema")
    what, how = _KIND_WORDS[kind]
    if to == "c" and kind == "bpmid.vbmm/" and model not in (None, "vbmm"):   # the right target, a wrong --model
        raise InputError(f"a {schema} file is {what}: --model {model} takes a comparison or control result; export "
                         "this one with --to c alone (or --model vbmm)", path=fit_path, key="--model")
    if to == "c" and model in (None, "vbmm") and kind in ("bpmid.compare/", "bpmid.control/"):
        raise InputError(f"a {schema} file is {what}: {how} "
                         f"(--to c without --model, or with --model vbmm, takes a bpmid.vbmm/1 motion fit)",
                         path=fit_path, key="schema")
    raise InputError(f"a {schema} file is {what}; {asked} takes a {wants} file: {how}", path=fit_path, key="schema")


__all__ = ["export", "TARGETS"]
