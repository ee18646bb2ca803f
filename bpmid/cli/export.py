"""``bpmid export``: a fitted model in another tool's format (library: :mod:`bpmid.export`)."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from bpmid.cli._app import app, check_outputs, command, existing_files


@command(app, "export", epilog=(
    "Examples: bpmid export VBMM.yaml --to c --out vbmm_c/   (then: cc -std=c99 -O2 vbmm_c/*.c -lm -o vbmm; "
    "./vbmm < time_s,pressure_gauge_pa lines);   "
    "bpmid export out/paper/compare/compare.yaml --to c --model maxwell-slip --out ms_c/;   "
    "bpmid export relax_fit.yaml --to abaqus --out fea/"))
def export_command(
    fit: Path = typer.Argument(..., metavar="FIT.yaml", help="A fit file: bpmid.vbmm/1 (--to c), bpmid.compare/1 or "
                                                            "bpmid.control/1 (--to c --model maxwell-slip), "
                                                            "bpmid.relax/1 (--to abaqus|ansys|comsol)."),
    to: str = typer.Option(..., "--to", help="Target: c (C99 for a controller: bpmid_model.h, bpmid_model.c, main.c), "
                                             "abaqus, ansys or comsol (material cards of a relaxation fit)."),
    out: Path = typer.Option(..., "--out", help="Output folder (written whole or not at all)."),
    model: Optional[str] = typer.Option(None, "--model", help="For --to c: vbmm (default for a bpmid.vbmm/1 file); "
                                                              "vbmm-fit or vbmm-mat (that model of a compare result); "
                                                              "maxwell-slip (the Maxwell-slip model of a compare "
                                                              "result, or the MS-PI feedforward of a control result)."),
):
    """Write a fitted model for another tool: dependency-free C for a real-time controller, or FEA material cards."""
    from bpmid.errors import InputError
    from bpmid.export import TARGETS, export

    if Path(fit).is_dir():
        from bpmid.export import refuse_folder

        refuse_folder(Path(fit), key=None, what="the fit")
    existing_files([fit], "fit")
    to = to.strip().lower()   # --to Abaqus is abaqus
    if to not in TARGETS:
        raise InputError(f"unknown target {to!r} (known: {', '.join(TARGETS)})", key="--to")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError("--out must be a folder, found a file", path=out, key="--out")
    if to == "c":
        from bpmid.export.c import FILES

        check_outputs([out / f for f in FILES], [fit])
    others = sorted(q.name for q in out.iterdir()) if out.is_dir() else []
    written = export(fit, to, out, model=model)
    others = [n for n in others if n not in {q.name for q in written}]
    if others:   # never in silence: the folder had more in it, left as it was
        typer.echo(f"note: {out} already held {len(others)} other file{'s' if len(others) != 1 else ''} "
                   f"({', '.join(others[:4])}{', ...' if len(others) > 4 else ''}), left as they were; give an empty "
                   "or new folder to keep the export on its own", err=True)
    typer.echo(f"wrote {len(written)} file{'s' if len(written) != 1 else ''} to {out}: {', '.join(p.name for p in written)}")
    if to == "c":
        typer.echo(f"build: cc -std=c99 -O2 {out}/bpmid_model.c {out}/main.c -lm -o bpmid_model")
