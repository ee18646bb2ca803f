"""The one YAML reader of bpmid: safe, bounded, and YAML 1.2 about numbers.

PyYAML's ``safe_load`` follows YAML 1.1, which reads ``5e6`` and ``1e9`` as *text* (1.1 floats need a dot
and a signed exponent); a config value ``K_inf: 5e6`` then fails far from the file. It also expands aliases
without limit: ten nested aliases of ten items each (a "billion laughs" document) are a few hundred bytes
that grow to 10^10 values when a caller walks them. This loader

- refuses a document larger than :data:`MAX_BYTES` (``BPMID_MAX_YAML_BYTES`` overrides),
- counts aliases (at most :data:`MAX_ALIASES`) and the number of values the document has once its aliases
  are expanded (at most :data:`MAX_EXPANDED_NODES`), and refuses a document beyond either before anything
  is built from it,
- reads numbers as YAML 1.2 does: ``5e6``, ``1E-3``, ``.5``, ``1.0e+6``, ``.inf`` and ``.nan`` are floats,
  and ``12:30`` is text (YAML 1.1 read it as the base-60 number 750),
- builds only plain data (mappings, lists, text, numbers, booleans, null, dates): tags such as
  ``!!python/object`` are refused (PyYAML's SafeLoader),
- refuses a mapping that gives the same key twice (PyYAML keeps the last silently).

Every refusal is an :class:`~bpmid.errors.InputError` naming the file and, where known, the line.
"""
from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

import yaml
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from bpmid.errors import InputError

# The pure-Python parser, not libyaml's: the C composer recurses on the C stack and a document nested
# 100,000 levels deep ("[[[[...") crashes the interpreter (SIGSEGV); the Python one stops at the recursion
# limit, which is reported as bad input. bpmid's YAML files are small, so speed does not matter here.
from yaml import SafeLoader as _Base

#: largest YAML document read (bytes); BPMID_MAX_YAML_BYTES overrides
MAX_BYTES = 16 * 2**20
#: most aliases (``*name``) in one document
MAX_ALIASES = 200
#: most values (mapping keys and values, list items) a document may hold once its aliases are expanded
MAX_EXPANDED_NODES = 2_000_000

#: YAML 1.2 core-schema floats (plus PyYAML's 1.1 forms with ``_`` separators, kept for old files)
_FLOAT_12 = re.compile(r"""^(?:
      [-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?(?:[eE][-+]?[0-9]+)?   # 1.5 1. 5e6 1.0e+6 (an int alone is excluded below)
    | [-+]?\.[0-9][0-9_]*(?:[eE][-+]?[0-9]+)?                  # .5 .5e3
    | [-+]?\.(?:inf|Inf|INF)
    | \.(?:nan|NaN|NAN)
    )$""", re.X)
_INT_ONLY = re.compile(r"^[-+]?[0-9][0-9_]*$")


class _FloatPattern:
    """A float resolver pattern that leaves plain integers to the int resolver."""

    def match(self, value: str):
        return None if _INT_ONLY.match(value) else _FLOAT_12.match(value)


def limit(name: str, default: int) -> int:
    """``default`` unless the environment variable ``name`` gives a positive whole number."""
    raw = os.environ.get(name)
    if raw is None or raw.strip() == "":
        return default
    try:
        value = int(float(raw))
    except ValueError:
        raise InputError(f"expected a positive whole number, found {raw!r}", key=name) from None
    if value <= 0:
        raise InputError(f"expected a positive whole number, found {raw!r}", key=name)
    return value


class StrictLoader(_Base):
    """SafeLoader with YAML 1.2 floats, no duplicate keys and an alias budget (see the module docstring)."""

    # floats and ints are resolved below (YAML 1.2 floats; no base-60 numbers such as 12:30 -> 750)
    yaml_implicit_resolvers = {k: [(tag, rx) for tag, rx in v
                                   if tag not in ("tag:yaml.org,2002:float", "tag:yaml.org,2002:int")]
                               for k, v in _Base.yaml_implicit_resolvers.items()}

    def construct_mapping(self, node, deep=False):
        if isinstance(node, MappingNode):
            seen: dict = {}
            for key_node, _v in node.value:
                if isinstance(key_node, ScalarNode):
                    key = (key_node.tag, key_node.value)
                    if key in seen:
                        raise yaml.constructor.ConstructorError(
                            None, None, f"the key {key_node.value!r} is given twice in one mapping",
                            key_node.start_mark)
                    seen[key] = True
        return super().construct_mapping(node, deep=deep)


StrictLoader.add_implicit_resolver("tag:yaml.org,2002:float", _FloatPattern(), list("-+0123456789."))
StrictLoader.add_implicit_resolver(
    "tag:yaml.org,2002:int",
    re.compile(r"^(?:[-+]?0b[0-1_]+|[-+]?0o?[0-7_]+|[-+]?(?:0|[1-9][0-9_]*)|[-+]?0x[0-9a-fA-F_]+)$"),
    list("-+0123456789"))


def _expanded_size(root: Node, budget: int) -> int:
    """Number of nodes of ``root`` with every alias expanded (shared nodes counted once per use); stops
    counting once above ``budget``. Iterative with memoisation, so a deep or wide document costs its own size."""
    memo: dict[int, int] = {}
    on_stack: set[int] = set()
    stack: list[tuple[Node, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        nid = id(node)
        if nid in memo:
            continue
        if isinstance(node, ScalarNode):
            memo[nid] = 1
            continue
        children = ([c for kv in node.value for c in kv] if isinstance(node, MappingNode)
                    else list(node.value) if isinstance(node, SequenceNode) else [])
        if done:
            on_stack.discard(nid)
            memo[nid] = min(budget + 1, 1 + sum(memo.get(id(c), 1) for c in children))
            continue
        if nid in on_stack:  # a recursive alias (an anchor used inside itself): infinite once expanded
            return budget + 1
        on_stack.add(nid)
        stack.append((node, True))
        stack.extend((c, False) for c in children if id(c) not in memo)
    return memo.get(id(root), 1)


#: deepest nesting of flow collections (``[[[...`` or ``{a: {b: ...``) read; PyYAML's parser spends quadratic
#: time on such a document before its recursion limit stops it
MAX_FLOW_DEPTH = 100
_QUOTED = re.compile(r"'(?:[^'\n]|'')*'|\"(?:[^\"\\\n]|\\.)*\"")
_BRACKETS = re.compile(r"[\[\]{}]")


def _flow_depth(text: str) -> int:
    """Deepest nesting of ``[`` and ``{`` outside quoted text (comments are not told apart: a rough upper bound)."""
    depth = top = 0
    for m in _BRACKETS.finditer(_QUOTED.sub("", text)):
        if m.group() in "[{":
            depth += 1
            top = max(top, depth)
            if top > MAX_FLOW_DEPTH:
                break
        else:
            depth = max(depth - 1, 0)
    return top


def _count_aliases(text: str, loader_cls) -> int:
    n = 0
    for event in yaml.parse(text, Loader=loader_cls):
        if isinstance(event, yaml.AliasEvent):
            n += 1
    return n


def loads(text: str, *, path: str | Path | None = None) -> Any:
    """Parse one YAML document from ``text`` under the limits of this module (InputError naming ``path``)."""
    max_aliases = limit("BPMID_MAX_YAML_ALIASES", MAX_ALIASES)
    max_nodes = limit("BPMID_MAX_YAML_NODES", MAX_EXPANDED_NODES)
    if ("[" in text or "{" in text) and _flow_depth(text) > MAX_FLOW_DEPTH:
        raise InputError(f"not valid YAML: nested too deeply (more than {MAX_FLOW_DEPTH} levels of [ ] or {{ }})",
                         path=path)
    try:
        if "*" in text:  # aliases are rare: only then pay for the event walk
            n = _count_aliases(text, StrictLoader)
            if n > max_aliases:
                raise InputError(f"the document uses {n} aliases (*name), more than the {max_aliases} allowed "
                                 "(a YAML bomb grows with them; raise BPMID_MAX_YAML_ALIASES if the file is "
                                 "genuine)", path=path)
        loader = StrictLoader(text)
        try:
            node = loader.get_single_node()
            if node is None:
                return None
            if "*" in text:
                size = _expanded_size(node, max_nodes)
                if size > max_nodes:
                    raise InputError(f"the document expands to more than {max_nodes:,} values through its aliases "
                                     "(a YAML bomb; raise BPMID_MAX_YAML_NODES if the file is genuine)",
                                     path=path, line=node.start_mark.line + 1)
            return loader.construct_document(node)
        finally:
            loader.dispose()
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        if "could not determine a constructor" in str(exc) or "!!python" in str(problem):
            problem = (f"{problem} (only plain data is read: mappings, lists, text, numbers, booleans; "
                       "tags such as !!python/object are refused)")
        raise InputError(f"not valid YAML: {problem}", path=path,
                         line=None if mark is None else mark.line + 1) from exc
    except RecursionError as exc:
        raise InputError("not valid YAML: nested too deeply", path=path) from exc


def load_file(path: str | Path, what: str = "file") -> tuple[Any, bytes]:
    """Read and parse the YAML file ``path``: (data, raw bytes). InputError when it is missing, a folder,
    larger than the limit, not UTF-8 or not valid YAML (the message names the file and line).

    Parameters
    ----------
    what : words for the not-found message ("config file", "protocol file", ...)
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{what} is a folder, not a file", path=path)
    if not path.is_file():
        raise InputError(f"{what} not found", path=path)
    max_bytes = limit("BPMID_MAX_YAML_BYTES", MAX_BYTES)
    size = path.stat().st_size
    if size > max_bytes:
        raise InputError(f"{size:,} bytes is more than the {max_bytes:,} bytes a YAML {what} may have "
                         "(raise BPMID_MAX_YAML_BYTES if the file is genuine)", path=path)
    from bpmid.io.atomic import note_input

    note_input(path)
    with open(path, "rb") as fh:
        raw = fh.read(max_bytes + 1)
    if len(raw) > max_bytes:  # it grew while we looked (a pipe or a file still being written)
        raise InputError(f"more than the {max_bytes:,} bytes a YAML {what} may have", path=path)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError("not a UTF-8 text file", path=path) from exc
    return loads(text, path=path), raw


class Dumper12(yaml.SafeDumper):
    """SafeDumper that quotes every string :class:`StrictLoader` would read back as a number (``'1e5'``,
    ``'0o7'``): PyYAML's emitter knows only YAML 1.1's number forms, so without this a string such as ``1e5``
    would be written plain and come back as a float."""


Dumper12.add_implicit_resolver("tag:yaml.org,2002:float", _FloatPattern(), list("-+0123456789."))
Dumper12.add_implicit_resolver(
    "tag:yaml.org,2002:int",
    re.compile(r"^(?:[-+]?0b[0-1_]+|[-+]?0o?[0-7_]+|[-+]?(?:0|[1-9][0-9_]*)|[-+]?0x[0-9a-fA-F_]+)$"),
    list("-+0123456789"))


if hasattr(yaml, "CSafeDumper"):  # libyaml's emitter: the same text, about 3x faster on large result files
    class _CDumper12(yaml.CSafeDumper):
        """:class:`Dumper12` on libyaml's emitter (the resolvers, which decide the quoting, are the same)."""

    for _tag, _rx, _first in (("tag:yaml.org,2002:float", _FloatPattern(), list("-+0123456789.")),
                              ("tag:yaml.org,2002:int", Dumper12.yaml_implicit_resolvers["0"][-1][1],
                               list("-+0123456789"))):
        _CDumper12.add_implicit_resolver(_tag, _rx, _first)
    _FAST_DUMPER = _CDumper12
else:  # pragma: no cover - PyYAML built without libyaml
    _FAST_DUMPER = Dumper12


def dump(data: Any, **kw) -> str:
    """YAML text of plain data (``yaml.safe_dump``'s options) that :func:`loads` reads back equal."""
    return yaml.dump(data, Dumper=_FAST_DUMPER, **kw)
