"""The reading flags every command that reads logs shares, declared once.

``@log_options("motion")`` (or ``"relax"``) under ``@command(...)`` adds to a command:

- ``--columns time=Zeit,pressure=Druck,angle=theta`` (bpmid quantity, optionally with its unit: ``time_ms=Zeit``)
- ``--pressure-reference absolute|gauge``, ``--pressure-unit``, ``--angle-unit`` (motion logs), ``--time-unit``
- ``--sheet NAME`` (Excel), ``--max-gap SECONDS`` (refuse longer gaps), ``--strict`` (warnings -> exit 2)

and passes the command a :class:`LogOptions` as the keyword ``logopts``; ``logopts.apply(cfg)`` returns the
config with its ``io`` section overridden by the flags (a flag wins over the config), so library code that
reads ``config.section("io")`` sees them.
"""
from __future__ import annotations

import dataclasses
import functools
import inspect
from typing import Optional

import typer

from bpmid.errors import InputError

_MOTION = ("columns", "pressure_reference", "pressure_unit", "angle_unit", "time_unit", "sheet", "max_gap", "strict")
_RELAX = ("columns", "time_unit", "sheet", "max_gap", "strict")
#: a reference angle table (bpmid control): time and angle only
_REFERENCE = ("columns", "angle_unit", "time_unit", "sheet")


def _options() -> dict[str, inspect.Parameter]:
    kw = inspect.Parameter.KEYWORD_ONLY

    def opt(name, default, annotation):
        return inspect.Parameter(name, kw, default=default, annotation=annotation)

    return {
        "columns": opt("columns", typer.Option(None, "--columns", help="Map your column names: "
                       "time=Zeit,pressure=Druck,angle=theta (a quantity, optionally with its unit: time_ms=t). "
                       "Config: io.columns."), Optional[str]),
        "pressure_reference": opt("pressure_reference", typer.Option(None, "--pressure-reference",
                                  help="absolute or gauge, for logs that do not say it (no '# pressure_reference:' "
                                  "line). Config: io.pressure_reference."), Optional[str]),
        "pressure_unit": opt("pressure_unit", typer.Option(None, "--pressure-unit", help="Unit of a pressure column "
                             "whose name states none: Pa, hPa, kPa, MPa, bar, mbar, psi (psig/psia/bar(a) carry the reference). "
                             "Config: io.units.pressure."), Optional[str]),
        "angle_unit": opt("angle_unit", typer.Option(None, "--angle-unit", help="Unit of an angle column whose name "
                          "states none: deg or rad. Config: io.units.angle."), Optional[str]),
        "time_unit": opt("time_unit", typer.Option(None, "--time-unit", help="Unit of a time column whose name "
                         "states none: s, ms, us, min, epoch_s, epoch_ms. Config: io.units.time."), Optional[str]),
        "sheet": opt("sheet", typer.Option(None, "--sheet", help="Excel sheet to read (default: the one sheet with "
                     "the needed columns). Config: io.sheet."), Optional[str]),
        "max_gap": opt("max_gap", typer.Option(None, "--max-gap", metavar="SECONDS", help="Refuse a log with a gap "
                       "between samples longer than this (default: read it, with a warning naming the line). "
                       "Config: io.max_gap_s."), Optional[float]),
        "strict": opt("strict", typer.Option(False, "--strict", help="Treat warnings (gaps, implausible fits, likely "
                      "unit or reference slips) as errors: exit 2, nothing written. Config: io.strict."), bool),
    }


@dataclasses.dataclass(frozen=True)
class LogOptions:
    """The reading flags as given (None: not given)."""

    columns: Optional[str] = None
    pressure_reference: Optional[str] = None
    pressure_unit: Optional[str] = None
    angle_unit: Optional[str] = None
    time_unit: Optional[str] = None
    sheet: Optional[str] = None
    max_gap: Optional[float] = None
    strict: bool = False

    def column_map(self) -> dict[str, str]:
        """``--columns time=Zeit,pressure=Druck`` -> ``{"Zeit": "time", "Druck": "pressure"}``."""
        if self.columns is None:
            return {}
        from bpmid.io.material_files import material_role
        from bpmid.io.tables import parse_header

        out: dict[str, str] = {}
        for item in _split_pairs(self.columns):
            if not item.strip():
                continue
            name, sep, header = item.partition("=")
            name, header = name.strip(), header.strip()
            if not sep or not name or not header:
                raise InputError(f"--columns takes quantity=column pairs separated by commas "
                                 f"(time=Zeit,pressure=Druck), found {item.strip()!r}", key="--columns")
            q, _unit = parse_header(name)
            if q is None and material_role(name)[0] is None:
                raise InputError(f"--columns: {name!r} is no bpmid quantity (time, pressure, angle, strain, stress, "
                                 f"load, extension, modulus; optionally with a unit: time_ms; in material files also "
                                 f"f, omega, E_stor, E_loss, G_stor, G_loss, E_relax, T, Set)", key="--columns")
            if header in out:
                raise InputError(f"--columns names the column {header!r} twice", key="--columns")
            out[header] = name
        return out

    def apply(self, cfg):
        """``cfg`` with its ``io`` section overridden by the flags (validated; a bad flag names itself)."""
        from bpmid.io.motion_logs import IOConfig

        io_cfg: IOConfig = cfg.section("io")
        stated = dict(io_cfg.stated_by)
        changes: dict = {}
        cmap = self.column_map()
        if cmap:
            merged = dict(io_cfg.columns)
            merged.update(cmap)
            changes["columns"] = merged
        units = dict(io_cfg.units)
        for q, v, flag in (("pressure", self.pressure_unit, "--pressure-unit"), ("angle", self.angle_unit,
                                                                                  "--angle-unit"),
                           ("time", self.time_unit, "--time-unit")):
            if v is not None:
                units[q] = v
                stated[f"units.{q}"] = flag
        if units != dict(io_cfg.units):
            changes["units"] = units
        if self.pressure_reference is not None:
            ref = self.pressure_reference.strip().lower()
            ref = {"abs": "absolute", "gage": "gauge"}.get(ref, ref)
            if ref not in ("absolute", "gauge"):
                raise InputError(f"--pressure-reference takes absolute or gauge, found {self.pressure_reference!r}",
                                 key="--pressure-reference")
            changes["pressure_reference"] = ref
            stated["pressure_reference"] = "--pressure-reference"
        if self.sheet is not None:
            changes["sheet"] = self.sheet
        if self.max_gap is not None:
            changes["max_gap_s"] = float(self.max_gap)
            stated["max_gap_s"] = "--max-gap"
        if self.strict:
            changes["strict"] = True
            stated["strict"] = "--strict"
        if not changes:
            return cfg
        changes["stated_by"] = stated
        new_io = dataclasses.replace(io_cfg, **changes)
        from bpmid.config import stated_keys

        # the keys the config file wrote stay stated (replace() makes a new object without them)
        object.__setattr__(new_io, "_stated", stated_keys(io_cfg) | frozenset(k for k in changes if k != "stated_by"))
        new_io.validate("io", None)
        return dataclasses.replace(cfg, sections={**dict(cfg.sections), "io": new_io})


def log_options(kind: str = "motion"):
    """Decorator: add the reading flags of ``kind`` (``motion``, ``relax`` or ``reference``) to a command; the
    command receives them as ``logopts`` (a :class:`LogOptions`). Put it under ``@command(...)``."""
    names = {"motion": _MOTION, "relax": _RELAX, "reference": _REFERENCE}[kind]

    def deco(fn):
        sig = inspect.signature(fn)
        params = [p for p in sig.parameters.values() if p.name != "logopts"]
        all_opts = _options()
        extra = [all_opts[n] for n in names]

        @functools.wraps(fn)
        def wrapper(*args, **kwargs):
            given = {n: kwargs.pop(n) for n in names if n in kwargs}
            return fn(*args, logopts=LogOptions(**given), **kwargs)

        wrapper.__signature__ = sig.replace(parameters=params + extra)
        return wrapper

    return deco


def _split_pairs(text: str) -> list[str]:
    """``--columns`` split at its commas, but not at one inside brackets: a MATLAB matrix column ``data(:,1)`` or a
    header ``Force (N, filtered)`` is one column name."""
    out, depth, cur = [], 0, []
    for ch in text:
        if ch in "([{":
            depth += 1
        elif ch in ")]}" and depth:
            depth -= 1
        if ch == "," and depth == 0:
            out.append("".join(cur))
            cur = []
        else:
            cur.append(ch)
    out.append("".join(cur))
    if depth:   # an unbalanced '(' would join the rest into one column name silently
        raise InputError(f"--columns: a bracket is opened and not closed in {text!r}; give each column as "
                         "quantity=column, with its brackets closed", key="--columns")
    return out

