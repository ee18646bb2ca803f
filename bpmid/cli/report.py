"""``bpmid report``: the study report from a run folder (the work is in :mod:`bpmid.report`)."""
from __future__ import annotations

from pathlib import Path

import typer

from bpmid.cli._app import app, command

EPILOG = "Example:  bpmid run --out out/paper  then  bpmid report out/paper   (opens as out/paper/report.html)"


@command(app, "report", epilog=EPILOG)
def report(
    out_dir: Path = typer.Argument(..., metavar="DIR", help="A folder written by bpmid run (or by bpmid compare "
                                   "and friends): relax_fit.yaml, vbmm_fit.yaml, compare/, history_modes.*, "
                                   "discover/."),
):
    """Write DIR/report.html (one self-contained file: figures embedded, no scripts, no external links) and
    DIR/report.md (figures as files next to it)."""
    from bpmid.report import write_report

    page, md = write_report(out_dir)
    typer.echo(f"wrote {page} and {md}")
