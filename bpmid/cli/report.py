"""``bpmid report``: the study report from a run folder (the work is in :mod:`bpmid.report`)."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from bpmid.cli._app import app, command

EPILOG = ("Example:  bpmid run --out out/paper  then  bpmid report out/paper --figures svg   (opens as "
          "out/paper/report.html)")


@command(app, "report", epilog=EPILOG)
def report(
    out_dir: Path = typer.Argument(..., metavar="DIR", help="A folder written by bpmid run (or by bpmid compare "
                                   "and friends): relax_fit.yaml, vbmm_fit.yaml, compare/, history_modes.*, "
                                   "discover/, control/."),
    figures: Optional[str] = typer.Option(None, "--figures", metavar="png|svg|pdf", help="Format of the figures "
                                          "the report draws (svg: vector figures inlined in the HTML; pdf: PDF "
                                          "files, PNG twins embedded). Default png."),
):
    """Write DIR/report.html (one self-contained file: figures embedded, no scripts, no external links) and
    DIR/report.md (figures as files next to it). Missing or partial stage files are named and the rest is
    built (exit 0 with a warning); stages left over from an earlier run, or rewritten by another command after
    the run, are marked stale."""
    from bpmid.plots.common import set_figure_format
    from bpmid.report import report_study

    set_figure_format(figures)
    res = report_study(out_dir, figures=figures)
    for w in res.warnings():
        typer.echo(f"warning: {w}", err=True)
    typer.echo(f"wrote {res.html} and {res.markdown}")
