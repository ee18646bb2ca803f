"""Named, bounded, unit-tagged parameters (in the spirit of lmfit's ``Parameter``).

A :class:`ParamSet` is an ordered collection of :class:`Param`. Fitting code works on the vector of
*free* parameters (:meth:`ParamSet.free_vector` / :meth:`ParamSet.with_free_vector`); everything else
(serialisation, reports) sees names, values, units and standard errors.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Iterable, Iterator

import numpy as np

from bpmid.errors import InputError


@dataclasses.dataclass(frozen=True)
class Param:
    """One model constant.

    Attributes
    ----------
    name : str
    value : float
        In ``unit``.
    unit : str
        SI unit string, e.g. ``"Pa"``, ``"s"``, ``"rad"``, ``"1"`` for dimensionless.
    lower, upper : float
        Bounds (may be infinite).
    fixed : bool
        Held at ``value`` during a fit.
    stderr : float or None
        Standard error after a fit (None: not estimated or not identifiable).
    log_scale : bool
        Fit on log(value) (positive scale parameters such as time constants).
    identifiable : bool or None
        Verdict after a fit (None: not judged).
    note : str
        Free text for the verdict.
    """

    name: str
    value: float
    unit: str = "1"
    lower: float = -math.inf
    upper: float = math.inf
    fixed: bool = False
    stderr: float | None = None
    log_scale: bool = False
    identifiable: bool | None = None
    note: str = ""

    def replace(self, **kw) -> "Param":
        return dataclasses.replace(self, **kw)

    def to_yaml(self) -> dict:
        """``{value, stderr, unit}`` as CLI.md fixes it (plus extras only when set)."""
        out = {"value": float(self.value),
               "stderr": None if self.stderr is None or not np.isfinite(self.stderr) else float(self.stderr),
               "unit": self.unit}
        if self.fixed:
            out["fixed"] = True
        if self.identifiable is not None:
            out["identifiable"] = bool(self.identifiable)
        if self.note:
            out["note"] = self.note
        return out


class ParamSet:
    """Ordered, immutable-by-convention collection of :class:`Param` (replace returns a new set)."""

    def __init__(self, params: Iterable[Param]):
        self._params: dict[str, Param] = {}
        for p in params:
            if p.name in self._params:
                raise ValueError(f"duplicate parameter {p.name}")
            self._params[p.name] = p

    # -- mapping-like -------------------------------------------------------------------------
    def __getitem__(self, name: str) -> Param:
        return self._params[name]

    def __contains__(self, name: str) -> bool:
        return name in self._params

    def __iter__(self) -> Iterator[Param]:
        return iter(self._params.values())

    def __len__(self) -> int:
        return len(self._params)

    def names(self) -> list[str]:
        return list(self._params)

    def value(self, name: str) -> float:
        return self._params[name].value

    def values(self) -> dict[str, float]:
        return {k: p.value for k, p in self._params.items()}

    def __repr__(self) -> str:
        inner = ", ".join(f"{p.name}={p.value:.6g} {p.unit}" for p in self)
        return f"ParamSet({inner})"

    # -- functional updates -------------------------------------------------------------------
    def replace(self, name: str, **kw) -> "ParamSet":
        if name not in self._params:
            raise KeyError(name)
        return ParamSet(p.replace(**kw) if p.name == name else p for p in self)

    def with_values(self, values: dict[str, float]) -> "ParamSet":
        unknown = set(values) - set(self._params)
        if unknown:
            raise KeyError(sorted(unknown)[0])
        return ParamSet(p.replace(value=float(values[p.name])) if p.name in values else p for p in self)

    def added(self, params: Iterable[Param]) -> "ParamSet":
        return ParamSet(list(self) + list(params))

    # -- free-parameter vector (what optimisers see) ------------------------------------------
    def free(self) -> list[Param]:
        return [p for p in self if not p.fixed]

    def free_names(self) -> list[str]:
        return [p.name for p in self.free()]

    def free_vector(self) -> np.ndarray:
        """Free parameters in optimiser space (log for ``log_scale``)."""
        return np.array([math.log(p.value) if p.log_scale else p.value for p in self.free()], float)

    def free_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = [], []
        for p in self.free():
            if p.log_scale:
                lo.append(math.log(p.lower) if p.lower > 0 else -np.inf)
                hi.append(math.log(p.upper) if np.isfinite(p.upper) else np.inf)
            else:
                lo.append(p.lower)
                hi.append(p.upper)
        return np.array(lo, float), np.array(hi, float)

    def with_free_vector(self, x: np.ndarray) -> "ParamSet":
        names = self.free_names()
        if len(x) != len(names):
            raise ValueError("vector length does not match the free parameters")
        vals = {}
        for n, xi in zip(names, x):
            vals[n] = math.exp(xi) if self._params[n].log_scale else float(xi)
        return self.with_values(vals)

    # -- serialisation ------------------------------------------------------------------------
    def to_yaml(self) -> dict:
        return {p.name: p.to_yaml() for p in self}

    def update_from_yaml(self, data: dict, *, path=None, where: str = "") -> "ParamSet":
        """Take values (and stderr) from a ``{name: {value, stderr, unit}}`` mapping; units must match."""
        out = self
        for name, entry in data.items():
            key = f"{where}.{name}" if where else name
            if name not in self._params:
                raise InputError(f"unknown parameter (known: {', '.join(self._params)})", path=path, key=key)
            value, stderr, unit = parse_param_entry(entry, path=path, key=key)
            want = self._params[name].unit
            if unit is not None and unit != want:
                raise InputError(f"unit {unit!r} where {want!r} is expected", path=path, key=key)
            out = out.replace(name, value=value, stderr=stderr)
        return out


#: the keys of a parameter entry in a results file (what :meth:`Param.to_yaml` writes)
PARAM_ENTRY_KEYS = ("value", "stderr", "unit", "fixed", "identifiable", "note")


def parse_param_entry(entry, *, path=None, key: str = "") -> tuple[float, float | None, str | None]:
    """Read ``{value, stderr, unit}`` (or a bare number) from a results file.

    Returns
    -------
    value, stderr, unit : float, float or None, str or None
    """
    if isinstance(entry, (int, float)) and not isinstance(entry, bool):
        return float(entry), None, None
    if not isinstance(entry, dict) or "value" not in entry:
        raise InputError("expected a parameter mapping {value, stderr, unit}", path=path, key=key)
    for k in entry:
        if k not in PARAM_ENTRY_KEYS:
            raise InputError(f"unknown key in a parameter entry (known: {', '.join(PARAM_ENTRY_KEYS)})", path=path,
                             key=f"{key}.{k}")
    v = entry["value"]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
        raise InputError(f"value must be a finite number, found {v!r}", path=path, key=f"{key}.value")
    se = entry.get("stderr")
    if se is not None and (isinstance(se, bool) or not isinstance(se, (int, float)) or not se >= 0):
        raise InputError(f"stderr must be a non-negative number or null, found {se!r}", path=path,
                         key=f"{key}.stderr")
    for k, want in (("fixed", bool), ("identifiable", bool), ("note", str)):
        if entry.get(k) is not None and not isinstance(entry[k], want):
            raise InputError(f"{k} must be {'true or false' if want is bool else 'text'}, found {entry[k]!r}",
                             path=path, key=f"{key}.{k}")
    unit = entry.get("unit")
    if unit is not None and not isinstance(unit, str):
        raise InputError(f"unit must be text, found {unit!r}", path=path, key=f"{key}.unit")
    return float(v), None if se is None else float(se), unit
