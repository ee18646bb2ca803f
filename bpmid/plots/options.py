"""The figure format of every figure written from now on (``--figures png|svg|pdf``). Light: no matplotlib
import, so that CLI modules can declare the option without loading the plotting stack."""
from __future__ import annotations

import contextlib
from pathlib import Path

FORMATS = ("png", "svg", "pdf")
FIGURES_HELP = ("Figure format: png (default), svg (vector; inlined in report.html) or pdf (vector; report.html "
                "embeds PNG twins of the figures the report draws and names the other PDFs).")

_format: str | None = None


def set_figure_format(fmt: str | None) -> None:
    """Format of every figure written from now on: 'png', 'svg' or 'pdf' (None: by the path's suffix)."""
    global _format
    if fmt is not None and fmt not in FORMATS:
        from bpmid.errors import InputError

        raise InputError(f"unknown figure format {fmt!r} (choose one of {', '.join(FORMATS)})", key="--figures")
    _format = fmt


@contextlib.contextmanager
def figure_format_kept():
    """Whatever format a command chooses (``--figures``) is put back when it ends: a command run in-process
    (a test, a notebook driving the CLI) leaves no format behind for the next call."""
    old = _format
    try:
        yield
    finally:
        set_figure_format(old)


def figure_format() -> str:
    return _format or "png"


@contextlib.contextmanager
def figure_format_as(fmt: str | None):
    old = _format
    set_figure_format(fmt)
    try:
        yield
    finally:
        set_figure_format(old)


#: file suffixes a figure can be written as (matplotlib's vector and raster formats a paper takes)
FIGURE_SUFFIXES = (".png", ".pdf", ".svg", ".svgz", ".eps", ".ps", ".jpg", ".jpeg", ".tif", ".tiff", ".webp")


def figure_path(path: str | Path) -> Path:
    """``path`` with the suffix of the chosen figure format."""
    path = Path(path)
    if _format is not None and path.suffix.lower() in {".png", ".svg", ".pdf"}:
        return path.with_suffix("." + _format)
    return path



def figures_option():
    """The ``--figures png|svg|pdf`` option every command that draws takes."""
    import typer

    return typer.Option(None, "--figures", metavar="png|svg|pdf", help=FIGURES_HELP)
