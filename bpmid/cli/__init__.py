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
    """The console script: the command, then :func:`_exit`."""
    import sys

    try:
        app(args=_quiet_first(sys.argv[1:]), prog_name="bpmid")
        code = 0
    except SystemExit as e:
        code = e.code
    _exit(code)


def _exit(code) -> None:
    """End the process with ``code`` (as ``SystemExit`` would) without the interpreter's teardown.

    Tearing down the modules a command has loaded (numba's compiled code, llvmlite, matplotlib, scipy) took 0.5-0.6 s
    after ``bpmid run`` (measured from the command's return to the shell's prompt), a twentieth of the run. Every
    file a command writes is closed (and renamed into place) before it returns, so nothing is lost: the ``atexit``
    handlers still run (temporary folders, logging), the standard streams are flushed, and the usual exit is used
    when a non-daemon thread is still running (the interpreter would wait for it) or ``BPMID_SLOW_EXIT`` is set.
    Only the console script ends this way; a command called in-process (tests, ``CliRunner``) never does.
    """
    import atexit
    import os
    import sys
    import threading

    if code is None:
        code = 0
    elif not isinstance(code, int):  # SystemExit("message"): printed to stderr, exit status 1
        print(code, file=sys.stderr)
        code = 1
    if os.environ.get("BPMID_SLOW_EXIT") or any(t.is_alive() and not t.daemon for t in threading.enumerate()
                                                if t is not threading.main_thread()):
        raise SystemExit(code)
    try:
        atexit._run_exitfuncs()
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError, AttributeError):  # closed or replaced by the caller
                pass
        os._exit(code)
