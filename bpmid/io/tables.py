"""Read the CSV dialects bpmid meets and bring every column to a canonical quantity and unit.

Accepted headers, all mapped to ``(quantity, unit)``:

- bpmid's own names with a unit suffix: ``time_s``, ``pressure_kpa``, ``stress_mpa``, ``load_n``
- instrument style, a unit in parentheses or brackets: ``Time (s)``, ``Load [N]``, ``Extension (mm)``
- two header rows, names then units (pyvisco): ``t,E_relax`` / ``s, MPa``
- a column map from the config (``io.columns``: file name -> bpmid name)

Leading ``# key: value`` lines are metadata (``# pressure_reference: absolute``). Values are
converted to each quantity's canonical unit (:data:`CANONICAL`); pressure keeps the unit it was
logged in as well, so outputs can echo it. Every error names the file and, where it can, the line.
"""
from __future__ import annotations

import csv
import dataclasses
import io
import re
from pathlib import Path
from typing import Mapping

import numpy as np

from bpmid.errors import InputError
from bpmid.io.atomic import note_input

#: quantity -> canonical unit
CANONICAL = {
    "time": "s", "strain": "1", "stress": "MPa", "load": "N", "extension": "mm",
    "modulus": "MPa", "pressure": "Pa", "angle": "deg",
}

#: quantity -> {unit spelling (lower case) -> factor to the canonical unit}
UNITS: dict[str, dict[str, float]] = {
    "time": {"s": 1.0, "sec": 1.0, "ms": 1e-3, "min": 60.0, "h": 3600.0},
    "strain": {"1": 1.0, "-": 1.0, "": 1.0, "mm/mm": 1.0, "m/m": 1.0, "%": 0.01, "pct": 0.01},
    "stress": {"mpa": 1.0, "n/mm^2": 1.0, "n/mm2": 1.0, "kpa": 1e-3, "pa": 1e-6, "gpa": 1e3},
    "load": {"n": 1.0, "kn": 1e3, "mn": 1e-3},
    "extension": {"mm": 1.0, "m": 1e3, "um": 1e-3, "µm": 1e-3, "cm": 10.0},
    "modulus": {"mpa": 1.0, "n/mm^2": 1.0, "n/mm2": 1.0, "kpa": 1e-3, "pa": 1e-6, "gpa": 1e3},
    "pressure": {"pa": 1.0, "kpa": 1e3, "bar": 1e5, "mbar": 1e2, "mpa": 1e6, "psi": 6894.757293168},
    "angle": {"deg": 1.0, "degree": 1.0, "degrees": 1.0, "°": 1.0, "rad": 180.0 / np.pi},
}

#: header base names (lower case, spaces/underscores folded) -> quantity
ALIASES = {
    "time": "time", "t": "time", "zeit": "time",
    "strain": "strain", "eps": "strain", "epsilon": "strain", "tensile strain": "strain",
    "stress": "stress", "sigma": "stress", "tensile stress": "stress",
    "load": "load", "force": "load",
    "extension": "extension", "elongation": "extension", "displacement": "extension",
    "crosshead": "extension",
    "modulus": "modulus", "e_relax": "modulus", "e relax": "modulus", "relaxation modulus": "modulus",
    "e": "modulus", "e(t)": "modulus",
    "pressure": "pressure", "p": "pressure",
    "angle": "angle", "beta": "angle", "bending angle": "angle",
}

_PAREN = re.compile(r"^(.*?)\s*[\(\[]\s*([^\)\]]*)\s*[\)\]]\s*$")


@dataclasses.dataclass
class Table:
    """A CSV file's columns in canonical units.

    Attributes
    ----------
    path : Path
    columns : dict quantity -> float array (canonical unit, see :data:`CANONICAL`)
    units_in_file : dict quantity -> unit as written in the file (lower case)
    headers : dict quantity -> header text as written
    meta : dict from ``# key: value`` lines
    first_data_line : 1-based line number of the first data row (for error messages)
    """

    path: Path
    columns: dict[str, np.ndarray]
    units_in_file: dict[str, str]
    headers: dict[str, str]
    meta: dict[str, str]
    first_data_line: int

    def has(self, quantity: str) -> bool:
        return quantity in self.columns

    def line_of(self, row: int) -> int:
        """File line number of data row ``row`` (0-based)."""
        return self.first_data_line + int(row)


def _norm(name: str) -> str:
    return re.sub(r"[\s_]+", " ", name.strip().lower())


def parse_header(name: str, unit_row: str | None = None) -> tuple[str | None, str | None]:
    """``'Time (s)'`` -> ``('time', 's')``; ``'pressure_kpa'`` -> ``('pressure', 'kpa')``.

    Returns (None, None) for a column bpmid does not know (it is ignored).
    """
    raw = name.strip().strip('"')
    unit = None
    m = _PAREN.match(raw)
    if m:
        raw, unit = m.group(1), m.group(2).strip().lower()
    base = _norm(raw)
    if unit_row is not None and unit is None:
        unit = unit_row.strip().lower()
    if base in ALIASES:
        return ALIASES[base], unit
    # suffix form: time_s, pressure_kpa, stress_mpa, angle_deg, load_n ...
    parts = base.rsplit(" ", 1)
    if len(parts) == 2 and _norm(parts[0]) in ALIASES:
        q = ALIASES[_norm(parts[0])]
        suf = parts[1]
        if suf in UNITS[q] or unit is None:
            return q, (suf if unit is None else unit)
    return None, None


def _is_number(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False


def read_table(path: str | Path, *, column_map: Mapping[str, str] | None = None,
               required: tuple[str, ...] = (), kind: str = "log") -> Table:
    """Read a CSV log into a :class:`Table`.

    Parameters
    ----------
    path : the file
    column_map : file header -> bpmid name (``{"Zeit": "time_s"}``), from the config
    required : quantities that must be present (checked here so the message names them)
    kind : words for messages ("relaxation log", "motion log")
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("file not found", path=path)
    note_input(path)  # the command that reads it must not replace it (bpmid.io.atomic)
    try:
        text = path.read_text("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError("not a UTF-8 text file", path=path) from exc
    lines = text.splitlines()
    meta: dict[str, str] = {}
    i = 0
    while i < len(lines) and (lines[i].lstrip().startswith("#") or not lines[i].strip()):
        body = lines[i].lstrip().lstrip("#").strip()
        if ":" in body:
            k, v = body.split(":", 1)
            meta[k.strip().lower()] = v.strip()
        i += 1
    if i >= len(lines):
        raise InputError(f"empty {kind}: no header row", path=path)
    dialect_delim = "\t" if "\t" in lines[i] and "," not in lines[i] else (";" if ";" in lines[i] and "," not in lines[i] else ",")
    rows = list(csv.reader(io.StringIO("\n".join(lines[i:])), delimiter=dialect_delim))
    header = [h.strip() for h in rows[0]]
    header_line = i + 1
    if header and all(_is_number(h) for h in header if h):
        raise InputError(f"{kind} has no header row (expected column names such as time_s)", path=path,
                         line=header_line)
    data_rows = rows[1:]
    unit_row = None
    if data_rows and data_rows[0] and not any(_is_number(c) for c in data_rows[0] if c.strip()):
        unit_row = [c.strip() for c in data_rows[0]]
        data_rows = data_rows[1:]
    first_data_line = header_line + (2 if unit_row is not None else 1)
    cmap = {str(k).strip(): str(v) for k, v in (column_map or {}).items()}
    index: dict[str, tuple[int, str, str]] = {}
    for j, h in enumerate(header):
        name = cmap.get(h, h)
        q, unit = parse_header(name, unit_row[j] if unit_row is not None and j < len(unit_row) else None)
        if q is None:
            continue
        if q in index:
            raise InputError(f"two columns give {q}: {header[index[q][0]]!r} and {h!r}", path=path,
                             line=header_line, key=h)
        if unit is None:
            unit = CANONICAL[q].lower()
        if unit not in UNITS[q]:
            raise InputError(f"unknown unit {unit!r} for {q} (known: {', '.join(sorted(k for k in UNITS[q] if k))})",
                             path=path, line=header_line, key=h)
        index[q] = (j, unit, h)
    missing = [q for q in required if q not in index]
    if missing:
        found = ", ".join(repr(h) for h in header)
        raise InputError(f"missing column for {missing[0]} (found columns: {found})", path=path,
                         line=header_line, key=missing[0])
    data_rows = [r for r in data_rows if any(c.strip() for c in r)]
    if not data_rows:
        raise InputError(f"empty {kind}: a header but no data rows", path=path, line=header_line)
    columns, units, headers = {}, {}, {}
    for q, (j, unit, h) in index.items():
        vals = np.empty(len(data_rows))
        for r, row in enumerate(data_rows):
            cell = row[j].strip() if j < len(row) else ""
            try:
                v = float(cell)
            except ValueError:
                raise InputError(f"column {h!r}: {cell!r} is not a number", path=path,
                                 line=first_data_line + r) from None
            if not np.isfinite(v):
                raise InputError(f"column {h!r}: {cell!r} (NaN or infinite values are not allowed)",
                                 path=path, line=first_data_line + r)
            vals[r] = v
        columns[q] = vals * UNITS[q][unit]
        units[q] = unit
        headers[q] = h
    return Table(path, columns, units, headers, meta, first_data_line)


def check_time(table: Table, *, kind: str = "log", gap_factor: float | None = None) -> np.ndarray:
    """The time column, checked to rise strictly (and, optionally, to have no gaps).

    Parameters
    ----------
    gap_factor : a step longer than this many times the median step is a gap (None: no gap check)
    """
    t = table.columns["time"]
    if t.size < 2:
        raise InputError(f"{kind} needs at least two samples, found {t.size}", path=table.path)
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        r = int(bad[0]) + 1
        what = "repeats" if dt[bad[0]] == 0 else "goes backwards"
        raise InputError(f"time {what} ({t[r - 1]:g} s then {t[r]:g} s); time must increase",
                         path=table.path, line=table.line_of(r))
    if gap_factor is not None:
        med = float(np.median(dt))
        gaps = np.flatnonzero(dt > gap_factor * med)
        if gaps.size:
            r = int(gaps[0]) + 1
            raise InputError(f"gap in the log: {dt[gaps[0]]:g} s between samples where the usual step is {med:g} s",
                             path=table.path, line=table.line_of(r))
    return t
