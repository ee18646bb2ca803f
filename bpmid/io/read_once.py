"""Files read once per ``bpmid run``: a log read again the same way is parsed once.

``bpmid run`` reads and checks every input before its first stage (so a bad file stops it before anything is
written), and each stage then reads its inputs again with the reader it shares with the single commands. Inside
:func:`reading_once` a reader that goes through :func:`read_once` parses a file once: the same file (its resolved
path, size and modification time unchanged) read with the same options is handed out again as a deep copy, so no
caller sees another's changes. Outside the block (every single command, the library) nothing is kept.
"""
from __future__ import annotations

import contextlib
import copy
from pathlib import Path
from typing import Callable, TypeVar

T = TypeVar("T")

#: (reader, file, size, modification time, options) -> what the reader returned; None outside reading_once
_MEMO: dict | None = None


@contextlib.contextmanager
def reading_once():
    """Parse each file once inside this block (nested blocks share the outermost one's memory)."""
    global _MEMO
    outer = _MEMO
    if outer is None:
        _MEMO = {}
    try:
        yield
    finally:
        _MEMO = outer


def read_once(reader: str, path: str | Path, options: tuple, read: Callable[[], T]) -> T:
    """``read()`` (the parse of ``path`` by ``reader`` with ``options``, a tuple of reprs), or a deep copy of its
    earlier result inside :func:`reading_once`. A read that fails is not kept (the next one fails the same way)."""
    memo = _MEMO
    if memo is None:
        return read()
    try:
        p = Path(path)
        st = p.stat()
        key = (reader, str(p.resolve()), st.st_size, st.st_mtime_ns, options)
    except OSError:  # missing or unreadable: the reader says so
        return read()
    if key not in memo:
        value = read()
        memo[key] = copy.deepcopy(value)
        return value
    return copy.deepcopy(memo[key])
