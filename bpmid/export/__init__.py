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
    if to == "c" and (model is None or model == "vbmm"):
        # say what a file of another kind needs, rather than only that it is not a motion fit
        from bpmid.config import read_yaml

        data, _sha = read_yaml(fit_path)
        schema = str(data.get("schema", "")) if isinstance(data, dict) else ""
        if schema.startswith(("bpmid.compare/", "bpmid.control/")):
            which = "vbmm-fit, vbmm-mat or maxwell-slip" if schema.startswith("bpmid.compare/") else "maxwell-slip"
            raise InputError(f"a {schema} file: say which of its models to export with --model ({which}); "
                             "--to c without --model takes a bpmid.vbmm/1 fit (bpmid fit motion, bpmid discover)",
                             path=fit_path, key="schema")
        if schema.startswith("bpmid.relax/"):
            raise InputError(f"a {schema} file is a material fit: export it with --to abaqus, ansys or comsol; "
                             "--to c takes a motion fit (bpmid.vbmm/1)", path=fit_path, key="schema")
    read_result(fit_path, schemas)
    if to == "c":
        from bpmid.export.c import export_c

        return export_c(fit_path, out_dir, model or "vbmm", command=command)
    if model is not None:
        raise InputError(f"--model {model} applies to --to c only", key="--model")
    from bpmid.export.fea import export_fea  # the material-fits helper's module, loaded only for FEA targets

    return export_fea(fit_path, to, Path(out_dir))


__all__ = ["export", "TARGETS"]
