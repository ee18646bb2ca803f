"""Errors meant for people.

:class:`InputError` is bad input or usage (the CLI exits with code 2). It names what is at fault:
the file, and where known the line or the config key, what was expected and what was found.
Anything else escaping a command is an internal failure (exit code 1).
"""
from __future__ import annotations

import contextlib
import contextvars
import re
import warnings as _warnings
from pathlib import Path
from typing import Iterable


#: set while a command runs: the command prints the warnings itself (``warning: ...`` on stderr), once; and its
#: errors name its flags (outside a command, the reading flags are also named by their config keys)
_IN_COMMAND = contextvars.ContextVar("bpmid_in_command", default=False)

#: the reading flags a log's error may name -> the config key a library caller sets instead
_FLAG_KEYS = {"--columns": "io.columns ({'<header in the file>': '<bpmid name>'})",
              "--pressure-unit": "io.units.pressure", "--time-unit": "io.units.time",
              "--angle-unit": "io.units.angle", "--pressure-reference": "io.pressure_reference",
              "--sheet": "io.sheet", "--max-gap": "io.max_gap_s", "--strict": "io.strict"}
_FLAG_NOTE = "from Python, pass these in config={'io': {...}}"
#: set while a command without the reading flags runs (bpmid run): its errors name the config keys instead
_NO_READING_FLAGS = contextvars.ContextVar("bpmid_no_reading_flags", default=False)
_RUN_NOTE = "bpmid run takes no reading flags: set them in the study config's io section"


#: command-line options that are arguments of the library's calls under another name (bpmid.compare(models=...))
_ARG_KEYS = {"--models": "models", "--reference": "reference", "--controllers": "controllers", "--train": "train",
             "--test": "test", "--relax": "relax", "--holdout": "holdout", "--params": "params", "--init": "init",
             "--to": "to", "--model": "model"}


def _library_words(message: str, note: str = _FLAG_NOTE) -> str:
    """``message`` with the config key of each reading flag it names, for a caller outside the command line (or
    inside a command that has no such flags: ``note`` says where they go)."""
    named = [f"{flag} is {key}" for flag, key in _FLAG_KEYS.items()
             if re.search(re.escape(flag) + r"(?![\w-])", message)]
    if not named or note in message:
        return message
    return f"{message} ({note}: {'; '.join(named)})"


@contextlib.contextmanager
def reading_flags_absent():
    """A command that takes no reading flags (``bpmid run``, whose study config's ``io`` section reads every
    log) runs inside this: the errors of what it reads name the config keys beside the flags they mention."""
    token = _NO_READING_FLAGS.set(True)
    try:
        yield
    finally:
        _NO_READING_FLAGS.reset(token)


class InputError(Exception):
    """Bad input: a file, line or key a user can fix.

    Parameters
    ----------
    message : str
        What is wrong, in plain words (what was expected, what was found).
    path : str or Path, optional
        The file at fault.
    line : int, optional
        1-based line number in that file.
    key : str, optional
        Dotted config/parameter key or column name at fault.
    """

    def __init__(self, message: str, *, path: str | Path | None = None,
                 line: int | None = None, key: str | None = None):
        in_command = _IN_COMMAND.get()
        no_flags = in_command and _NO_READING_FLAGS.get()
        if no_flags:
            message = _library_words(message, _RUN_NOTE)
        elif not in_command:
            message = _library_words(message)
        self.message = message
        self.path = None if path is None else str(path)
        self.line = line
        # outside a command, an option that is an argument of the library's call is named as that argument; in a
        # command without the reading flags, a reading flag is named as its config key
        if no_flags and key in _FLAG_KEYS:
            key = _FLAG_KEYS[key].split(" ")[0]
        self.key = key if in_command or key not in _ARG_KEYS else _ARG_KEYS[key]
        super().__init__(self.format())

    def format(self) -> str:
        where = []
        if self.path:
            where.append(self.path + (f":{self.line}" if self.line else ""))
        elif self.line:
            where.append(f"line {self.line}")
        if self.key:
            where.append(f"key '{self.key}'")
        prefix = ", ".join(where)
        return f"{prefix}: {self.message}" if prefix else self.message


class ConvergenceError(InputError):
    """A fit or solve that did not converge on the given data (reported as bad input, exit 2)."""


def interrupted(exc: BaseException | None) -> bool:
    """True when a KeyboardInterrupt stands anywhere in ``exc``'s chain of causes (Ctrl-C inside a compiled
    kernel surfaces as nested SystemErrors "returned a result with an exception set")."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


class BpmidWarning(UserWarning):
    """What a result's ``warnings`` hold (a likely unit slip, a poor fit, a constant at a bound), said to a library
    caller through Python's warnings too: a script that prints only ``.params`` still sees them."""


@contextlib.contextmanager
def command_prints_warnings():
    """The CLI's commands run inside this: the library calls they make do not also raise Python warnings."""
    token = _IN_COMMAND.set(True)
    try:
        yield
    finally:
        _IN_COMMAND.reset(token)


def warn_caller(messages: Iterable[str], *, stacklevel: int | None = None) -> None:
    """Each message as a :class:`BpmidWarning` to the library's caller (not inside a CLI command), attributed to
    the caller's own line: the first frame outside the bpmid package (a fixed ``stacklevel`` named a line inside
    bpmid when a call went through a wrapper, and location filters missed it)."""
    if _IN_COMMAND.get():
        return
    if stacklevel is None:
        import os
        import sys

        root = os.path.dirname(os.path.abspath(__file__)) + os.sep
        f, stacklevel = sys._getframe(0), 1
        while f is not None and os.path.abspath(f.f_code.co_filename).startswith(root):
            f, stacklevel = f.f_back, stacklevel + 1
    for m in messages:
        _warnings.warn(str(m), BpmidWarning, stacklevel=stacklevel)
