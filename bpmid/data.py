"""The shipped configs and datasets, found through the installed package (``importlib.resources``), never
through the source tree: ``bpmid run`` and the examples work from any folder after ``pip install .``.

Layout (paths relative to :func:`root`): ``configs/paper.yaml`` (the study), ``configs/compare_paper.yaml``,
``configs/datasets/*.yaml`` (protocols), ``datasets/relaxation/``, ``datasets/motion/<set>/``,
``datasets/control/``, ``datasets/discovery/``, ``datasets/reference/``. In the source tree these are the
top-level ``configs/`` and ``datasets/`` (``bpmid/_data`` links to them); an installed wheel holds copies.
"""
from __future__ import annotations

import glob as _glob
from pathlib import Path

from bpmid.errors import InputError


def root() -> Path:
    """The folder holding ``configs/`` and ``datasets/``."""
    from importlib.resources import files

    return Path(str(files("bpmid._data")))


def path(relative: str | Path) -> Path:
    """The shipped file or folder ``relative`` (``"configs/paper.yaml"``); InputError when it is not shipped."""
    p = (root() / relative).resolve()  # the real file (in a source tree: under the top-level folders)
    if not p.exists():
        raise InputError(f"not among bpmid's shipped data (under {root()})", path=str(relative))
    return p


def files(pattern: str) -> list[Path]:
    """Shipped files matching a glob relative to :func:`root` (``"datasets/motion/fitting_set/*.csv"``),
    sorted; InputError when none match."""
    head, _, rest = str(pattern).partition("/")
    base = (root() / head).resolve() if rest else root()
    found = sorted(Path(p) for p in _glob.glob(str(base / rest if rest else base / head), recursive=True))
    if not found:
        raise InputError("no shipped file matches", path=pattern)
    return found


def copy_to(target: str | Path) -> Path:
    """Copy ``configs/`` and ``datasets/`` into ``target`` (made if needed; files of the same name are replaced), so that the
    examples of ``bpmid --help``, written with paths relative to the repository, run there."""
    import shutil

    target = Path(target)
    for name in ("configs", "datasets"):
        shutil.copytree(root() / name, target / name, dirs_exist_ok=True)
    return target


__all__ = ["root", "path", "files", "copy_to"]
