"""YAML configuration -> frozen dataclasses, with unknown keys rejected by their dotted path.

A config file is a mapping of *sections*. Each section is owned by the module that uses it and is a
frozen dataclass defined there; :data:`SECTIONS` maps the section name to ``"module:ClassName"`` so
this module never needs editing when a section grows a field. Every field has a default, so an
empty config (or none at all) is valid, and a config names only what it changes.

Relative paths inside a config are resolved against the config file's folder by
:func:`resolve_path`.
"""
from __future__ import annotations

import collections.abc
import dataclasses
import hashlib
import math
import os
import types
import typing
from pathlib import Path
from typing import Any, Mapping

from bpmid.errors import InputError
from bpmid.limits import check_config_value
from bpmid.registry import lookup

#: section name -> "module:Class" (the class is a frozen dataclass with defaults for every field)
SECTIONS: dict[str, str] = {
    "io": "bpmid.io.motion_logs:IOConfig",
    "relax": "bpmid.relax:RelaxConfig",
    "model": "bpmid.models.vbmm:VBMMConfig",
    "motion": "bpmid.motion_fit:MotionFitConfig",
    "compare": "bpmid.compare:CompareConfig",
    "discover": "bpmid.discover.workflow:DiscoverConfig",
    "control": "bpmid.control:ControlConfig",
    "run": "bpmid.run:RunConfig",
}


def _section_class(name: str) -> type:
    return lookup(SECTIONS, name, what="config section")



class FrozenMap(Mapping):
    """A read-only mapping (a config's mappings and sections: no caller changes them under a run), which, unlike
    ``types.MappingProxyType``, pickles: a result that keeps its config can be sent to another process."""

    __slots__ = ("_d",)

    def __init__(self, data=()):
        object.__setattr__(self, "_d", dict(data))

    def __getitem__(self, key):
        return self._d[key]

    def __iter__(self):
        return iter(self._d)

    def __len__(self) -> int:
        return len(self._d)

    def __repr__(self) -> str:
        return f"FrozenMap({self._d!r})"

    def __reduce__(self):
        return (FrozenMap, (self._d,))


@dataclasses.dataclass(frozen=True)
class Config:
    """A loaded configuration: one dataclass instance per section, plus where it came from."""

    sections: Mapping[str, Any]
    path: Path | None = None
    sha256: str | None = None

    def section(self, name: str):
        """The section ``name`` as its dataclass (defaults when the file did not give it)."""
        if name not in SECTIONS:
            raise KeyError(name)
        if name in self.sections:
            return self.sections[name]
        return _section_class(name)()

    def __getattr__(self, name: str):
        if name in SECTIONS:
            return self.section(name)
        raise AttributeError(name)

    @property
    def base_dir(self) -> Path:
        return self.path.parent if self.path is not None else Path.cwd()

    def resolve_path(self, p: str | Path) -> Path:
        """A path from the config, relative to the config file's folder."""
        p = Path(p)
        # normpath folds "configs/../datasets" so reports and provenance show the path a person would type
        return Path(os.path.normpath(p if p.is_absolute() else (self.base_dir / p)))


def _is_dataclass_type(tp) -> bool:
    return isinstance(tp, type) and dataclasses.is_dataclass(tp)


_MAPPINGS = (dict, Mapping, collections.abc.Mapping, collections.abc.MutableMapping, typing.Dict)
_SEQUENCES = (list, tuple, collections.abc.Sequence, typing.List, typing.Tuple)


def _shown(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _convert(tp, value, where: str, path):
    """Convert a YAML value to the annotated type ``tp``; an InputError naming the dotted key ``where`` when the
    value does not have that type. Works inside mappings and lists at any depth (``motion.start.K_inf``,
    ``compare.test_sets.a[2]``).

    Numbers: a float field takes any finite or infinite number but not NaN; a whole-number field also takes a
    float with no fractional part (``1e3``: YAML 1.2 reads it as a float). Text fields take text only."""
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if tp is Any:
        return value
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        given = [a for a in args if a is not type(None)]
        if len(given) == 1 and value is not None:   # Optional[X]: X's own error, with its own key
            return _convert(given[0], value, where, path)
        errors = []
        for a in args:
            if a is type(None):
                continue
            try:
                return _convert(a, value, where, path)
            except InputError as exc:
                errors.append(exc.message)
        if value is None:
            raise InputError("a value is needed here (found nothing)", path=path, key=where)
        raise InputError(f"invalid value {_shown(value)}: " + "; or ".join(dict.fromkeys(errors)), path=path,
                         key=where)
    if origin is typing.Literal:
        if isinstance(value, bool) or value not in args or type(value) not in {type(a) for a in args}:
            raise InputError(f"expected one of {list(args)}, found {_shown(value)}", path=path, key=where)
        return value
    if _is_dataclass_type(tp):
        return build_dataclass(tp, value, where, path)
    if origin in _SEQUENCES or tp in (list, tuple):
        if not isinstance(value, (list, tuple)):
            one = f'["{value}"]' if isinstance(value, str) else f"[{value}]"
            raise InputError(f"expected a list, found {_shown(value)}"
                             + ("" if isinstance(value, dict) else f": write it as a list, {_shown(one)}"),
                             path=path, key=where)
        if origin is tuple and args and args[-1] is not Ellipsis:  # a fixed-length tuple
            if len(value) != len(args):
                raise InputError(f"expected a list of {len(args)} values, found {len(value)}", path=path, key=where)
            return tuple(_convert(a, v, f"{where}[{i}]", path) for i, (a, v) in enumerate(zip(args, value)))
        inner = args[0] if args else Any
        return tuple(_convert(inner, v, f"{where}[{i}]", path) for i, v in enumerate(value))
    if origin in _MAPPINGS or tp in (dict, Mapping):
        if not isinstance(value, dict):
            raise InputError(f"expected a mapping, found {_shown(value)}"
                             + (": give each entry a name, " + ("{set_name: [paths], ...}" if where.endswith("test_sets")
                                                                  else "{name: value, ...}")
                                if isinstance(value, (list, tuple)) else ""), path=path, key=where)
        kt = args[0] if len(args) == 2 else Any
        vt = args[1] if len(args) == 2 else Any
        out = {}
        for k, v in value.items():
            if kt is str and not isinstance(k, (str, int, float)) or isinstance(k, bool) or k is None:
                raise InputError(f"a key here is a name, found {_shown(k)}", path=path, key=f"{where}.{k}")
            out[str(k)] = _convert(vt, v, f"{where}.{k}", path)
        return FrozenMap(out)
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InputError(f"expected a number, found {_shown(value)}", path=path, key=where)
        if isinstance(value, float) and math.isnan(value):
            raise InputError("expected a number, found .nan (not a number)", path=path, key=where)
        return float(value)
    if tp is int:
        if isinstance(value, float) and math.isfinite(value) and value.is_integer():
            value = int(value)  # 1e3 is a float in YAML 1.2
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"expected a whole number, found {_shown(value)}", path=path, key=where)
        return int(value)
    if tp is bool:
        if not isinstance(value, bool):
            raise InputError(f"expected true or false, found {_shown(value)}", path=path, key=where)
        return value
    if tp is str:
        if not isinstance(value, str):
            raise InputError(f"expected text, found {_shown(value)} (quote it if it is meant as text)", path=path,
                             key=where)
        return value
    if isinstance(tp, type) and tp not in (object,):
        if not isinstance(value, tp):
            raise InputError(f"expected {tp.__name__}, found {_shown(value)}", path=path, key=where)
    return value


def build_dataclass(cls: type, data: Any, where: str = "", path=None):
    """Build the frozen dataclass ``cls`` from a mapping; unknown keys are an error naming their path."""
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise InputError(f"expected a mapping, found {type(data).__name__}", path=path, key=where or None)
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    aliases = getattr(cls, "UNIT_KEYS", None) or {}
    if aliases:
        data = _unit_keys(data, aliases, where, path)
    internal = set(getattr(cls, "INTERNAL_FIELDS", None) or ())   # set by bpmid, never read from a file
    unknown = [k for k in data if k not in fields or k in internal]
    if unknown:
        k = unknown[0]
        full = f"{where}.{k}" if where else str(k)
        hint = (getattr(cls, "UNKNOWN_KEY_HINTS", None) or {}).get(str(k))
        known = sorted([*(f for f in fields if f not in internal), *aliases])
        raise InputError(f"unknown config key (known here: {', '.join(known)})"
                         + (f"; {hint}" if hint else ""), path=path, key=full)
    kwargs = {}
    for k, v in data.items():
        full = f"{where}.{k}" if where else str(k)
        kwargs[k] = _convert(hints[k], v, full, path)
        check_config_value(full, kwargs[k], path=path)  # stated resource limits (bpmid.limits)
    missing = [f.name for f in dataclasses.fields(cls) if f.init and f.name not in data
               and f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING]
    if missing:   # named as a key, not as Python's 'missing 1 required positional argument'
        m = missing[0]
        raise InputError(f"missing key {m!r} (required here{', with ' + ', '.join(map(repr, missing[1:])) if missing[1:] else ''})",
                         path=path, key=f"{where}.{m}" if where else m)
    try:
        obj = cls(**kwargs)
    except InputError:
        raise
    except (TypeError, ValueError) as exc:
        raise InputError(str(exc), path=path, key=where or None) from exc
    try:   # which keys the file gave (a value equal to the default is still a statement): stated_keys()
        object.__setattr__(obj, "_stated", frozenset(str(k) for k in data))
    except (AttributeError, TypeError):   # pragma: no cover - a class with slots
        pass
    check = getattr(obj, "validate", None)
    if callable(check):
        check(where, path)
    return obj


def stated_keys(obj) -> frozenset:
    """The keys a config file gave for the section ``obj`` (built by :func:`build_dataclass`); empty for
    defaults. A setting the user wrote out, even at its default value, must not be silently overridden."""
    return getattr(obj, "_stated", frozenset())


def _unit_keys(data: dict, aliases: dict, where: str, path) -> dict:
    """``data`` with keys that state their unit (a class's ``UNIT_KEYS``: ``th_mm`` -> ``th`` times 1e-3) turned
    into the field in SI; a field given twice (``th`` and ``th_mm``) or a non-number is refused, naming the key."""
    out, given = {}, {}
    for k, v in data.items():
        if k not in aliases:
            out[k] = v
            continue
        field, factor = aliases[k]
        full = f"{where}.{k}" if where else str(k)
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise InputError(f"expected a number, found {v!r}", path=path, key=full)
        if field in data or field in given:
            other = given.get(field, field)
            raise InputError(f"{field} is given twice ({other} and {k}): keep one", path=path, key=full)
        given[field] = k
        out[field] = float(v) * factor
    return out


def parse_config(data: Any, path: Path | None = None, sha256: str | None = None) -> Config:
    """Build a :class:`Config` from an already-loaded YAML mapping."""
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise InputError("a config file must be a mapping of sections", path=path)
    sections = {}
    for name, value in data.items():
        if name not in SECTIONS:
            raise InputError(f"unknown config section (known: {', '.join(SECTIONS)})", path=path, key=str(name))
        sections[name] = build_dataclass(_section_class(name), value, name, path)
    return Config(FrozenMap(sections), path, sha256)


def read_yaml(path: str | Path, what: str = "file") -> tuple[Any, str]:
    """Parse a YAML file with bpmid's strict loader (:mod:`bpmid.io.yamlsafe`: bounded size and aliases, YAML 1.2
    numbers, plain data only); errors name the file and the line. Returns (data, sha256 of the bytes).

    Parameters
    ----------
    what : words for the not-found message ("config file", "protocol file", ...)
    """
    from bpmid.io.yamlsafe import load_file

    data, raw = load_file(path, what)
    return data, hashlib.sha256(raw).hexdigest()


def load_config(path: str | Path | None) -> Config:
    """Load a YAML config file; ``None`` gives all defaults."""
    if path is None:
        return Config(FrozenMap({}))
    data, sha = read_yaml(path, "config file")
    return parse_config(data, Path(path), sha)
