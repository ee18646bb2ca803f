"""The ``bpmid`` command line: one file per command in this package, no science in here.

Every module in this package is imported, and registers its command(s) on :data:`app` or
:data:`fit_app` with :func:`bpmid.cli._app.command`, which maps errors to exit codes
(2: bad input or usage, 1: internal failure).
"""
from __future__ import annotations

import importlib
import pkgutil

from bpmid.cli._app import app, fit_app  # noqa: F401

for _mod in sorted(m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_")):
    importlib.import_module(f"{__name__}.{_mod}")


def main() -> None:
    app()
