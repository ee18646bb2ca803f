"""YAML configuration -> frozen dataclasses, with unknown keys rejected by their dotted path.

A config file is a mapping of *sections*. Each section is owned by the module that uses it and is a
frozen dataclass defined there; :data:`SECTIONS` maps the section name to ``"module:ClassName"`` so
this module never needs editing when a section grows a field. Every field has a default, so an
empty config (or none at all) is valid, and a config names only what it changes.

Relative paths inside a config are resolved against the config file's folder by
:func:`resolve_path`.
"""
from __future__ import annotations

import dataclasses
import hashlib
import os
import types
import typing
from pathlib import Path
from typing import Any, Mapping

import yaml

from bpmid.errors import InputError
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


def _convert(tp, value, where: str, path):
    """Convert a YAML value to the annotated type ``tp`` (best effort, with clear errors)."""
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if tp is Any:
        return value
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        errors = []
        for a in args:
            if a is type(None):
                continue
            try:
                return _convert(a, value, where, path)
            except InputError as exc:
                errors.append(exc.message)
        raise InputError(f"invalid value {value!r}: " + "; ".join(errors), path=path, key=where)
    if origin is typing.Literal:
        if value not in args:
            raise InputError(f"expected one of {list(args)}, found {value!r}", path=path, key=where)
        return value
    if _is_dataclass_type(tp):
        return build_dataclass(tp, value, where, path)
    if origin in (list, tuple):
        if not isinstance(value, (list, tuple)):
            raise InputError(f"expected a list, found {value!r}", path=path, key=where)
        inner = args[0] if args else Any
        return tuple(_convert(inner, v, f"{where}[{i}]", path) for i, v in enumerate(value))
    if origin in (dict, Mapping) or tp is dict:
        if not isinstance(value, dict):
            raise InputError(f"expected a mapping, found {value!r}", path=path, key=where)
        vt = args[1] if len(args) == 2 else Any
        return types.MappingProxyType({str(k): _convert(vt, v, f"{where}.{k}", path) for k, v in value.items()})
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise InputError(f"expected a number, found {value!r}", path=path, key=where)
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(f"expected a whole number, found {value!r}", path=path, key=where)
        return int(value)
    if tp is bool:
        if not isinstance(value, bool):
            raise InputError(f"expected true or false, found {value!r}", path=path, key=where)
        return value
    if tp is str:
        if not isinstance(value, (str, int, float)) or isinstance(value, bool):
            raise InputError(f"expected text, found {value!r}", path=path, key=where)
        return str(value)
    return value


def build_dataclass(cls: type, data: Any, where: str = "", path=None):
    """Build the frozen dataclass ``cls`` from a mapping; unknown keys are an error naming their path."""
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise InputError(f"expected a mapping, found {type(data).__name__}", path=path, key=where or None)
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = [k for k in data if k not in fields]
    if unknown:
        k = unknown[0]
        full = f"{where}.{k}" if where else str(k)
        raise InputError(f"unknown config key (known here: {', '.join(sorted(fields))})", path=path, key=full)
    kwargs = {}
    for k, v in data.items():
        full = f"{where}.{k}" if where else str(k)
        kwargs[k] = _convert(hints[k], v, full, path)
    try:
        obj = cls(**kwargs)
    except InputError:
        raise
    except (TypeError, ValueError) as exc:
        raise InputError(str(exc), path=path, key=where or None) from exc
    check = getattr(obj, "validate", None)
    if callable(check):
        check(where, path)
    return obj


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
    return Config(types.MappingProxyType(sections), path, sha256)


def read_yaml(path: str | Path, what: str = "file") -> tuple[Any, str]:
    """Parse a YAML file; errors name the file and the line. Returns (data, sha256 of the bytes).

    Parameters
    ----------
    what : words for the not-found message ("config file", "protocol file", ...)
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{what} not found", path=path)
    raw = path.read_bytes()
    try:
        data = yaml.safe_load(raw.decode("utf-8"))
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        raise InputError(f"not valid YAML: {getattr(exc, 'problem', exc)}", path=path,
                         line=None if mark is None else mark.line + 1) from exc
    except UnicodeDecodeError as exc:
        raise InputError("not a UTF-8 text file", path=path) from exc
    return data, hashlib.sha256(raw).hexdigest()


def load_config(path: str | Path | None) -> Config:
    """Load a YAML config file; ``None`` gives all defaults."""
    if path is None:
        return Config(types.MappingProxyType({}))
    data, sha = read_yaml(path, "config file")
    return parse_config(data, Path(path), sha)
