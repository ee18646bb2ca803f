"""``bpmid shipped``: where the shipped configs and datasets are, and a copy of them to work in
(the library: :mod:`bpmid.data`)."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from bpmid.cli._app import app, command


@command(app, "shipped", epilog="Example:  bpmid shipped --copy work  then  cd work  and run the examples of "
                                "bpmid COMMAND --help (they name configs/... and datasets/... relative to it)")
def shipped(copy: Optional[Path] = typer.Option(None, "--copy", help="Copy configs/ and datasets/ into this "
                                                "folder (made if needed).")):
    """Print the folder holding bpmid's shipped configs/ and datasets/ (installed with the package); with
    --copy, copy them into a folder of your own."""
    from bpmid import data

    if copy is None:
        typer.echo(str(data.path("configs").parent))
        return
    if copy.exists() and not copy.is_dir():
        from bpmid.errors import InputError

        raise InputError("--copy needs a folder, found a file", path=copy, key="--copy")
    data.copy_to(copy)
    typer.echo(f"copied configs/ and datasets/ to {copy}")
