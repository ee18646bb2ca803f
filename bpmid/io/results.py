"""Result files: YAML with ``schema`` and ``provenance`` blocks, written atomically.

Every output says what made it: bpmid version, the command line, sha256 of each input file and of
the config, creation time (UTC; ``SOURCE_DATE_EPOCH`` pins it for reproducible builds), and the seed
where one was used.
"""
from __future__ import annotations

import contextlib
import contextvars
import datetime as _dt
import hashlib
import math
import os
import shlex
import sys
from pathlib import Path
from typing import Any, Iterable, Iterator

import numpy as np
import yaml

from bpmid import __version__
from bpmid.errors import InputError
from bpmid.io.atomic import write_text


def sha256_file(path: str | Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def command_line() -> str:
    """The command as the user typed it (``bpmid ...``)."""
    argv = list(sys.argv)
    if argv:
        argv[0] = "bpmid" if Path(argv[0]).name in ("bpmid", "__main__.py", "bpmid.exe") else Path(argv[0]).name
    return " ".join(shlex.quote(a) for a in argv)


#: (run id, command) of the ``bpmid run`` whose stages are being written, else None (:func:`run_stamp`)
_RUN: contextvars.ContextVar[tuple[str, str] | None] = contextvars.ContextVar("bpmid_run", default=None)


def new_run_id() -> str:
    """A fresh id for one ``bpmid run`` (random: two runs of the same config get different ids)."""
    import secrets

    return secrets.token_hex(8)


@contextlib.contextmanager
def run_stamp(run_id: str, command: str) -> Iterator[None]:
    """While inside, every provenance block (:func:`provenance`) says it was written by the run ``run_id``
    (key ``run_id``) and records ``command`` unless told another: every file of a ``bpmid run`` (run.yaml and
    each stage's files, whichever library function writes them, in forked stage processes too) carries the same
    id, so ``bpmid report`` can tell a stage file some other command wrote into the folder afterwards."""
    token = _RUN.set((str(run_id), str(command)))
    try:
        yield
    finally:
        _RUN.reset(token)


def provenance(inputs: Iterable[str | Path] = (), *, config=None, seed: int | None = None,
               command: str | None = None, timestamp: bool = True, extra: dict | None = None) -> dict:
    """The provenance block.

    Parameters
    ----------
    inputs : paths of the input files (hashed with sha256)
    config : a :class:`bpmid.config.Config` or a path, or None
    seed : the seed of every random draw, when one was used
    command : override the recorded command line (default: the running ``bpmid run``'s, else ``sys.argv``)
    timestamp : include the creation time (False for byte-reproducible files)

    Inside :func:`run_stamp` the block also holds ``run_id``.
    """
    run = _RUN.get()
    block: dict[str, Any] = {"bpmid_version": __version__,
                             "command": command or (run[1] if run else None) or command_line()}
    if run is not None:
        block["run_id"] = run[0]
    block["inputs"] = {str(p): sha256_file(p) for p in inputs}
    if config is not None:
        cpath = getattr(config, "path", config)
        csha = getattr(config, "sha256", None)
        if cpath is not None:
            block["config"] = {"path": str(cpath), "sha256": csha or sha256_file(cpath)}
    if timestamp:
        epoch = os.environ.get("SOURCE_DATE_EPOCH")
        now = (_dt.datetime.fromtimestamp(int(epoch), _dt.timezone.utc) if epoch
               else _dt.datetime.now(_dt.timezone.utc))
        block["created"] = now.replace(microsecond=0).isoformat()
    if seed is not None:
        block["seed"] = int(seed)
    if extra:
        block.update(extra)
    return block


def _plain(obj):
    """numpy scalars/arrays and tuples -> plain YAML types."""
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind in "biu" or (obj.dtype.kind == "f" and np.isfinite(obj).all()):
            return obj.tolist()  # already plain Python numbers (nested lists for 2-D), nothing to replace
        return [_plain(v) for v in obj.tolist()]
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None if math.isnan(obj) else obj
    if isinstance(obj, Path):
        return str(obj)
    return obj


def dump_yaml(data: dict) -> str:
    from bpmid.io.yamlsafe import dump

    return dump(_plain(data), sort_keys=False, allow_unicode=True, width=110)


def write_result(path: str | Path, schema: str, body: dict, prov: dict) -> Path:
    """Write ``{schema, <body...>, provenance}`` atomically as YAML."""
    data = {"schema": schema}
    data.update(body)
    data["provenance"] = prov
    return write_text(path, dump_yaml(data))


#: the one version of every ``bpmid.<kind>`` result schema this bpmid reads
SCHEMA_VERSION = "1"

#: the command that writes each kind of result file a reader may ask for (said when it is given another file)
_WRITTEN_BY = {
    "bpmid.vbmm/": "a motion fit (bpmid fit motion LOG... --out VBMM.yaml, or bpmid discover's DIR/model.yaml)",
    "bpmid.relax/": "a relaxation fit (bpmid fit relax LOG... --out relax_fit.yaml)",
    "bpmid.compare/": "a comparison (bpmid compare ... --out DIR writes DIR/compare.yaml)",
    "bpmid.control/": "a control result (bpmid control ... --out DIR writes DIR/control.yaml)",
}

#: how the first lines of a file bpmid export wrote begin (C: "generated by bpmid <version> from FIT", the FEA cards:
#: "bpmid <version> export of FIT"), with the fit file it was made from
_EXPORT_MARK = r"(?:[Gg]enerated by bpmid \S+ from|bpmid \S+ export of)\s+([^\s,()]+)"


def what_to_give(prefixes: tuple[str, ...]) -> str:
    """What to give instead of a file that is not the result asked for: the kinds asked, with what writes each."""
    words = [_WRITTEN_BY[p] for p in prefixes if p in _WRITTEN_BY]
    if not words:
        return ("give a YAML file a bpmid command wrote (a fit file, or the .yaml in an output folder: predict.yaml, "
                "compare.yaml, control.yaml, discovery.yaml ...)")
    return "give " + "; or ".join(words)


def _made_by_export(path: Path) -> InputError | None:
    """The error for a file bpmid export wrote (C code, an FEA card) given where a result is read, naming the fit
    file it was made from; None for any other file."""
    import re

    from bpmid.io.atomic import file_head

    made = re.search(_EXPORT_MARK, file_head(path))
    if not made:
        return None
    return InputError("a file bpmid export wrote (C code or an FEA material card), which bpmid does not read back: "
                      f"give the fit file it was made from, {made.group(1)}, named at its top", path=path)


def _not_a_result(path: Path, data, expected: str, prefixes: tuple[str, ...]) -> InputError:
    """The error for a file that parses but is not a mapping (a log, an empty file, a list, a COMSOL card): what it
    reads as and what to give instead."""
    made = _made_by_export(path)
    if made is not None:
        return made
    if data is None:
        found = "the file is empty"
    elif isinstance(data, str):
        found = ("it reads as plain text, as a log or a table does (a log is fitted first: bpmid fit motion or "
                 "bpmid fit relax)")
    else:
        found = f"it reads as a YAML {'list' if isinstance(data, list) else type(data).__name__}"
    return InputError(f"not a bpmid result file: expected a YAML mapping with the key schema ({expected}), but {found}; "
                      f"{what_to_give(prefixes)}", path=path)


def _unreadable_result(path: Path, exc: InputError, prefixes: tuple[str, ...]) -> InputError:
    """``exc`` (the file is not text, or not YAML) with what the file is when bpmid export wrote it, and what to
    give instead."""
    made = _made_by_export(path)
    if made is not None:
        return made
    edited = ("if it is a result file edited by hand, mend that line or write it again with the command that made "
              "it; otherwise " if exc.message.startswith("not valid YAML") else "")
    return InputError(f"{exc.message}; {edited}{what_to_give(prefixes)}", path=exc.path, line=exc.line, key=exc.key)


def read_result(path: str | Path, schema_prefix: str | tuple[str, ...]) -> dict:
    """Read a result YAML and check its schema (``bpmid.vbmm/`` etc., or a tuple of such prefixes when
    several kinds are accepted).

    Only version 1 exists for every kind: ``bpmid.vbmm/2`` is refused (naming the key ``schema``), as is
    anything that is not ``bpmid.<kind>/1``.
    """
    from bpmid.config import read_yaml

    path = Path(path)
    prefixes = (schema_prefix,) if isinstance(schema_prefix, str) else tuple(schema_prefix)
    expected = " or ".join(f"{p}{SCHEMA_VERSION}" if p.endswith("/") else f"{p}<kind>/{SCHEMA_VERSION}"
                           for p in prefixes)
    try:
        data, _sha = read_yaml(path)
    except InputError as exc:
        if exc.message.startswith(("not a UTF-8 text file", "not valid YAML")):
            raise _unreadable_result(path, exc, prefixes) from None
        raise
    if not isinstance(data, dict):
        raise _not_a_result(path, data, expected, prefixes)
    schema = data.get("schema")
    if schema is None:
        raise InputError(f"missing key (expected schema {expected})", path=path, key="schema")
    if not isinstance(schema, str) or not schema.startswith(prefixes):
        raise InputError(f"wrong kind of file: schema {schema!r}, expected {expected}; {what_to_give(prefixes)}",
                         path=path, key="schema")
    kind, sep, version = schema.rpartition("/")
    if not sep or not kind.startswith("bpmid.") or "/" in kind or len(kind) <= len("bpmid."):
        raise InputError(f"malformed schema {schema!r}, expected {expected}", path=path, key="schema")
    if version != SCHEMA_VERSION:
        raise InputError(f"unsupported schema version {schema!r}: this bpmid reads {kind}/{SCHEMA_VERSION} only",
                         path=path, key="schema")
    return data


def require(data: dict, dotted: str, path=None):
    """``data['a']['b']`` for ``'a.b'``, or an InputError naming the missing key."""
    cur = data
    for part in dotted.split("."):
        if not isinstance(cur, dict) or part not in cur:
            # what to do: a file bpmid wrote has every key it reads; one edited by hand or cut short lost it
            raise InputError(f"missing key {dotted!r}: the file was edited or cut short (a file bpmid writes has it); "
                             "add it, restore it from the original, or write the file again with the command that "
                             "made it", path=path, key=dotted)
        cur = cur[part]
    return cur
