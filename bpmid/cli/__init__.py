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


def _quiet_first(argv: list[str]) -> list[str]:
    """``bpmid run --quiet`` means ``bpmid --quiet run``: the flag is the root's, accepted anywhere."""
    head, sep, tail = (argv[:argv.index("--")], ["--"], argv[argv.index("--") + 1:]) if "--" in argv else (argv, [], [])
    if not any(a in ("--quiet", "-q") for a in head):
        return argv
    return ["--quiet"] + [a for a in head if a not in ("--quiet", "-q")] + sep + tail


def main() -> None:
    import sys

    app(args=_quiet_first(sys.argv[1:]), prog_name="bpmid")
