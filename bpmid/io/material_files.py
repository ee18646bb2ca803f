"""Material-test files: frequency sweeps (E', E'' or G', G''), master curves and raw sets at several temperatures,
and relaxation-modulus curves E(t) at several temperatures, as pyvisco writes them (two header rows, names then
units), as an Eplexor DMA exports them to Excel, and as instrument software writes text (TRIOS with its ``[step]``
tables, RheoCompass, Proteus, STARe: an export block above the header, units after a slash or a space or in a
bracketed units row, UTF-16). A file is routed here when its header names a frequency or a storage/loss modulus, or
a relaxation modulus beside a temperature (:func:`is_material_file`); time-domain test logs go through
:mod:`bpmid.io.relax_logs`. Units are never guessed; every error names the file and line (sheet row).
"""
from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path
from typing import Mapping

import numpy as np

from bpmid.errors import InputError
from bpmid.units import millipascal_slip

#: header name (lower case, spaces, underscores, dashes and dots removed) -> role
_MAT_NAMES = {
    "f": "f", "freq": "f", "frequency": "f", "fset": "f", "omega": "omega", "angularfrequency": "omega",
    "w": "omega", "ω": "omega",
    "estor": "storage", "e'": "storage", "estorage": "storage", "storagemodulus": "storage", "eprime": "storage",
    "eloss": "loss", "e''": "loss", "lossmodulus": "loss", "edoubleprime": "loss",
    "gstor": "storage_g", "g'": "storage_g", "gstorage": "storage_g", "shearstoragemodulus": "storage_g",
    "gloss": "loss_g", "g''": "loss_g", "shearlossmodulus": "loss_g",
    "t": "t", "time": "t", "tset": "t",
    "erelax": "relax", "e(t)": "relax", "relaxationmodulus": "relax", "modulus": "relax",
    "grelax": "relax_g", "g(t)": "relax_g",
    "temp": "T", "temperature": "T", "tround": "T",
    "set": "set", "setid": "set", "sweep": "set", "segment": "set",
}
_MAT_UNITS = {
    "f": {"hz": 1.0, "1/s": 1.0, "khz": 1e3, "mhz": 1e6, "rad/s": 1.0 / (2 * np.pi), "rad s-1": 1.0 / (2 * np.pi),
          "": 1.0},
    "omega": {"rad/s": 1.0 / (2 * np.pi), "1/s": 1.0 / (2 * np.pi), "": 1.0 / (2 * np.pi)},
    "t": {"s": 1.0, "sec": 1.0, "ms": 1e-3, "min": 60.0, "h": 3600.0, "": 1.0},
    "modulus": {"mpa": 1.0, "n/mm^2": 1.0, "n/mm2": 1.0, "kpa": 1e-3, "pa": 1e-6, "gpa": 1e3, "": 1.0},
    "T": {"c": 0.0, "°c": 0.0, "degc": 0.0, "deg c": 0.0, "celsius": 0.0, "k": -273.15, "": 0.0},  # offsets added: C = K - 273.15
    "set": {"-": 1.0, "": 1.0, "1": 1.0},
}
#: unit families a material file must state (in the header or a units row): why, and how to state it (a test
#: temperature of 70 may be C or F, one of 300 C or K; a modulus of 3 may be MPa or GPa)
_STATED = {"T": ("degrees C, kelvin and degrees F all read as plausible test temperatures",
                 "name the column '{h} (C)' or '{h} (K)' (degrees F: convert to C)"),
           "f": ("a DMA frequency may be in Hz or in rad/s, 2 pi apart",
                 "name the column '{h} (Hz)' or '{h} (rad/s)'"),
           "modulus": ("a modulus of 3 is a soft rubber in MPa and a glassy polymer in GPa",
                       "name the column '{h} (MPa)' (or Pa, kPa, GPa)")}
#: header names that say neither E nor G (read as E, with a warning)
_VAGUE_MODULUS = frozenset({"storagemodulus", "lossmodulus", "relaxationmodulus", "modulus"})
#: a modulus above this (MPa; 100 GPa) is stiffer than any polymer: refused without a stated unit, warned with one
MAX_PLAUSIBLE_MPA = 1e5
#: fewest samples of one set of raw data (bpmid.relax.tts.MIN_OVERLAP: a shift is judged on at least 3 overlapping
#: samples, and a set's smooth curve needs 3 points to be more than a line through 2)
MIN_SET_SAMPLES = 3
#: every test temperature above this (C) under a degrees C header, or below COLD_C under a kelvin one, is warned
#: about as the other unit (300 K read as 300 C; 20 C read as 20 K = -253 C): a DMA of an elastomer runs from about
#: -150 C to 200 C; a temperature below absolute zero is refused
WARM_C, COLD_C = 200.0, -150.0
#: without a Set column, a temperature step larger than this (C) from one sample to the next starts a new set
SET_T_JUMP_C = 2.0
#: without a Set column, sets are told apart by the sweep restarting and the temperature jumping (messages say so)
_SET_HINT = ("; without a Set column, a new set starts where the sweep restarts or the temperature jumps by over "
             f"{SET_T_JUMP_C:g} C: if the file holds sweeps logged in alternating directions (up, then down), add a "
             "Set column numbering them")
#: a set whose temperatures span more than this (C) is not one isothermal sweep: refused
SET_T_SPAN_C = 5.0
#: role -> unit family
_ROLE_UNIT = {"f": "f", "omega": "omega", "t": "t", "storage": "modulus", "loss": "modulus", "storage_g": "modulus",
              "loss_g": "modulus", "relax": "modulus", "relax_g": "modulus", "T": "T", "set": "set"}


def _mat_key(name: str) -> str:
    return re.sub(r"[\s_\-\.]+", "", name.strip().strip('"').lower())


def _split_unit(name: str) -> tuple[str, str | None]:
    m = re.match(r"^(.*?)\s*[\(\[]\s*([^\)\]]*)\s*[\)\]]\s*$", name.strip())
    return (m.group(1), m.group(2).strip().lower()) if m else (name.strip(), None)


def _base_role(base: str) -> str | None:
    if base.strip().strip('"') == "T":  # upper-case T is temperature, lower-case t is time (pyvisco's headers)
        return "T"
    return _MAT_NAMES.get(_mat_key(base))


def _mat_role(name: str) -> tuple[str | None, str | None]:
    """``'E_stor'`` -> ``('storage', None)``; ``'Frequency (Hz)'`` -> ``('f', 'hz')``; ``'T'`` -> ``('T', None)``;
    instruments' ``'Freq./Hz'`` and ``"E'/MPa"`` (Netzsch) or ``'Temperature °C'`` (Mettler) -> the role and unit."""
    base, unit = _split_unit(name)
    role = _base_role(base)
    if role is not None:
        return role, unit
    parts = base.strip().lower().rsplit("_", 1)  # suffix style: f_hz, e_stor_mpa, t_s, temperature_c
    if len(parts) == 2 and _mat_key(parts[0]) in _MAT_NAMES:
        role = _MAT_NAMES[_mat_key(parts[0])]
        if parts[1] in _MAT_UNITS[_ROLE_UNIT[role]]:
            return role, parts[1] if unit is None else unit
    if unit is None:  # a unit after a slash or a space: only a known name with a known unit of its kind
        for left, right in _name_tails(base):
            role = (_base_role(left) or _modulus_symbol(left)) if left else None
            if role is not None and right.strip() and right.strip().lower() in _MAT_UNITS[_ROLE_UNIT[role]]:
                return role, right.strip().lower()
    role = _modulus_symbol(base)
    return (role, unit) if role is not None else (None, None)


def _modulus_symbol(name: str) -> str | None:
    """A long name that ends in a modulus symbol: ``"Storage modulus E'"`` -> ``'storage'`` (a modulus only: a
    last word 'temperature' or 'time' may be a setpoint's or a step's)."""
    words = name.strip().split()
    if len(words) < 2:
        return None
    key = _mat_key(words[-1])
    return _MAT_NAMES[key] if key in _MODULUS_SYMBOLS else None


def material_role(name: str) -> tuple[str | None, str | None]:
    """The role a material file's column name gives (``'f'``, ``'storage'``, ``'T'`` ...) and the unit it states."""
    return _mat_role(name)


def _name_tails(name: str) -> list[tuple[str, str]]:
    """(name, unit) splits where instruments write a unit after a name: at the first slash (``Freq./Hz``,
    ``Frequency/rad/s``) and at the last space (``Temperature °C``)."""
    out = []
    if "/" in name:
        out.append(tuple(name.split("/", 1)))
    if " " in name.strip():
        out.append(tuple(name.strip().rsplit(" ", 1)))
    return out


def _unit_in_name(name: str, fam: str, also: frozenset = frozenset()) -> str | None:
    """The unit a column's own name states, for a column the map gives another name: in parentheses or brackets,
    or after a slash or the last space when it is a unit of ``fam`` (or in ``also``): ``'Temp. sample °C'`` ->
    ``'°c'``."""
    unit = _split_unit(name)[1]
    if unit is not None:
        return unit
    for _, tail in _name_tails(name):
        if tail.strip() and (tail.strip().lower() in _MAT_UNITS[fam] or tail.strip().lower() in also):
            return tail.strip().lower()
    return None


def is_material_file(path: str | Path, column_map: Mapping[str, str] | None = None, sheet: str | None = None) -> bool:
    """True for a CSV or Excel file whose header names a frequency or storage/loss column, or a relaxation-modulus
    curve with a temperature column (time-domain test logs are left to :func:`read_relax_log`). ``column_map``
    (file header -> bpmid name) and ``sheet`` as :func:`read_material_file` takes them."""
    path = Path(path)
    cmap = {str(k).strip(): str(v) for k, v in (column_map or {}).items()}
    try:  # the header alone: a material file's own errors (rows, units) are raised by read_material_file
        if path.suffix.lower() in (".xls", ".xlsx"):
            header = _xls_rows(path, cmap, sheet=sheet)[0]
        else:
            header = _csv_rows(path, cmap, header_only=True)[0]
    except InputError:
        return False
    roles = {_mat_role(cmap.get(h, h))[0] for h in header}
    if roles & {"f", "omega", "storage", "loss", "storage_g", "loss_g"}:
        return True
    # relaxation curves at several temperatures (t, E_relax, T[, Set]); a test log with a temperature column is not
    return "T" in roles and bool(roles & {"relax", "relax_g"})


def _is_num(s) -> bool:
    if isinstance(s, (int, float)) and not isinstance(s, bool):
        return True
    try:
        float(str(s))
        return True
    except ValueError:
        return False


def _decimal_comma(cell: str) -> str:
    """``'1,5e-05'`` -> ``'1.5e-05'`` when the cell then reads as a number; any other cell unchanged."""
    if "," in cell and not _is_num(cell):
        alt = cell.replace(",", ".")
        if _is_num(alt):
            return alt
    return cell


def _delimiter(head: str) -> str:
    return "\t" if "\t" in head and "," not in head else (";" if ";" in head and "," not in head else ",")


def _unit_cell(cell) -> str:
    """A units row's cell: ``'[1/s]'`` or ``'(MPa)'`` (Anton Paar, Netzsch) -> ``'1/s'``, ``'MPa'``."""
    c = str(cell).strip()
    m = re.fullmatch(r"[\[\(]\s*(.*?)\s*[\]\)]", c)
    return m.group(1) if m else c


#: modulus symbols a long column name may end in ("Storage modulus E'"); plain words (modulus) are not symbols
_MODULUS_SYMBOLS = frozenset({"e'", "e''", "g'", "g''", "estor", "eloss", "gstor", "gloss", "erelax", "grelax", "e(t)",
                              "g(t)"})
#: a material file's header names one of each
_AXIS_ROLES = frozenset({"f", "omega", "t"})
_MODULUS_ROLES = frozenset({"storage", "loss", "storage_g", "loss_g", "relax", "relax_g"})
#: how far below the first line a header is looked for (an instrument's export block: sample, geometry, step names)
_HEADER_SEARCH_LINES = 80


def _header_roles(cells, column_map: Mapping[str, str] | None = None) -> set:
    cmap = column_map or {}
    return {_mat_role(str(cmap.get(str(c).strip(), c)))[0] for c in cells if str(c).strip()} - {None}


def _is_header(cells, column_map=None) -> bool:
    """A material table's header names an axis (frequency or time) and a modulus."""
    roles = _header_roles(cells, column_map)
    return bool(roles & _AXIS_ROLES) and bool(roles & _MODULUS_ROLES)


def _material_header_line(lines: list[str], start: int,
                          column_map: Mapping[str, str] | None = None) -> int | None:
    """The line of a material file's header: the first line from ``start`` naming an axis and a modulus, with
    numbers within the next three lines (instrument software writes sample, geometry, parameter and step lines
    above it: TRIOS, RheoCompass, Proteus, whose header line starts '##'); None when no line qualifies."""
    import csv

    for k in range(start, min(len(lines), start + _HEADER_SEARCH_LINES)):
        text = lines[k].strip()
        if not text or (text.startswith("#") and not text.startswith("##")):
            continue
        text = text.lstrip("#")
        cells = next(csv.reader([text], delimiter=_delimiter(text)), [])
        if not _is_header(cells, column_map):
            continue
        below = [ln for ln in lines[k + 1:k + 6] if ln.strip() and not ln.lstrip().startswith("#")][:3]
        if any(sum(_is_num(_decimal_comma(c.strip())) for c in next(csv.reader([ln], delimiter=_delimiter(text)),
                                                                        [])) >= 2 for ln in below):
            return k
    return None


def _decode(raw: bytes) -> str:
    """Text of a material file: UTF-8 (with or without BOM), UTF-16 (with its byte-order mark, or without one when
    every other byte is NUL, as some instrument software saves text), else Latin-1 (decodes every byte)."""
    if raw.startswith((b"\xff\xfe", b"\xfe\xff")):
        return raw.decode("utf-16")
    head = raw[:4000]
    if len(head) >= 4 and head.count(b"\x00") > 0.3 * len(head):
        even, odd = head[0::2].count(b"\x00"), head[1::2].count(b"\x00")
        try:
            return raw.decode("utf-16-le" if odd > even else "utf-16-be")
        except UnicodeDecodeError:
            pass
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        return raw.decode("latin-1")


def _csv_rows(path: Path, column_map: Mapping[str, str] | None = None, *,
              header_only: bool = False) -> tuple[list[str], list[str] | None, list[tuple[int, list[str]]], int]:
    """Header, unit row (or None), data rows with their file line numbers, header line (CSV/TSV/semicolon; in a
    semicolon- or tab-separated file a numeric cell with a decimal comma, 1,5e-05, reads as 1.5e-05).
    ``header_only``: the header and units row only (routing a file: nothing below them is checked)."""
    if not path.is_file():
        raise InputError("file not found", path=path)
    lines = _decode(path.read_bytes()).splitlines()
    i = 0
    while i < len(lines) and (lines[i].lstrip().startswith("#") or not lines[i].strip()):
        i += 1
    found = _material_header_line(lines, 0, column_map)  # from the top: a '##' line may be the header (Proteus)
    i = found if found is not None else i
    if i >= len(lines):
        raise InputError("empty file: no header row", path=path)
    head = lines[i].lstrip()
    head = head.lstrip("#") if head.startswith("##") else head  # Proteus writes its header as '##Temp./°C;...'
    delim = _delimiter(head)
    import csv
    import io as _io

    parsed = list(csv.reader(_io.StringIO("\n".join([head] + lines[i + 1:])), delimiter=delim))
    header = [h.strip().lstrip("\ufeff") for h in parsed[0]]
    rows = [(i + 1 + k, r) for k, r in enumerate(parsed) if k > 0]
    if delim != ",":  # a decimal comma (1,5e-05) where the delimiter leaves the comma free
        rows = [(ln, [_decimal_comma(c) for c in r]) for ln, r in rows]
    rows = [(ln, r) for ln, r in rows if any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    units = None
    if rows and rows[0][1] and _units_like(rows[0][1]):
        units = [_unit_cell(c) for c in rows[0][1]]
        rows = rows[1:]
    if header_only:
        return header, units, [], i + 1
    return header, units, _drop_repeated_tables(rows, header, units, path), i + 1


def _units_like(cells) -> bool:
    """A units row: no numbers, except a Set column's dimensionless '1' beside two or more units."""
    cells = [str(c).strip() for c in cells if str(c).strip()]
    nums = [c for c in cells if _is_num(c)]
    return not nums or (all(c == "1" for c in nums) and len(cells) - len(nums) >= 2)


def _data_like(cells) -> bool:
    return sum(_is_num(str(c).strip()) for c in cells if str(c).strip()) >= 2


#: two frequencies (times) of a master curve, or two moduli, this close (relative) are the same number written to
#: other digits (1584.893192461108 and 1584.8931924611134 in pyvisco's curve; 13 digits in a re-export)
REPEAT_RTOL = 1e-9


def _drop_repeated_tables(rows, header, units, path: Path):
    """The data rows of a file that repeats its table once per step (TRIOS: ``[step]``, the step's name, the header
    and units again, then its data): a run of rows that are not data is dropped when it repeats the header, and
    its units row must repeat the first. Any other row that is not data stays (its cells are refused by line)."""
    want = [h for h in header if h]
    out, k = [], 0
    while k < len(rows):
        if _data_like(rows[k][1]):
            out.append(rows[k])
            k += 1
            continue
        j = k
        while j < len(rows) and not _data_like(rows[j][1]):
            j += 1
        block = rows[k:j]
        heads = [n for n, (_, r) in enumerate(block) if [c.strip() for c in r if c.strip()] == want]
        if not heads:
            out.extend(block)
        else:
            after = block[heads[-1] + 1:]
            if units is not None and after:
                again = [_unit_cell(c) for c in after[0][1]]
                if [u.lower() for u in again if u] != [u.lower() for u in units if u]:
                    raise InputError(f"the table repeated at line {block[heads[-1]][0]} states the units "
                                     f"{', '.join(u for u in again if u)}, the first table "
                                     f"{', '.join(u for u in units if u)}: give each column one unit", path=path,
                                     line=after[0][0])
        k = j
    return out


def _xls_rows(path: Path, column_map: Mapping[str, str] | None = None, *,
              sheet: str | None = None) -> tuple[list[str], list[str] | None, list[tuple[int, list]], int, str]:
    """The same from an Excel workbook: the first sheet (or ``sheet``) with a header row naming a frequency or
    time column and a modulus (an Eplexor export: sheet ``Exported Data``, names in row 1, units in row 2; title
    rows above the header are skipped). Lines are sheet rows (1-based)."""
    if path.suffix.lower() == ".xlsx":
        try:
            import openpyxl
        except ImportError as exc:  # pragma: no cover - openpyxl is a dependency of pandas' Excel support here
            raise InputError("reading .xlsx needs openpyxl (pip install openpyxl)", path=path) from exc
        try:
            wb = openpyxl.load_workbook(path, read_only=True, data_only=True)
        except Exception as exc:
            raise InputError(f"cannot read this Excel workbook ({exc})", path=path) from None
        sheets = [(ws.title, [["" if c is None else c for c in r] for r in ws.iter_rows(values_only=True)])
                  for ws in wb.worksheets]
    else:
        try:
            import xlrd
        except ImportError as exc:  # pragma: no cover
            raise InputError("reading .xls needs xlrd (pip install xlrd)", path=path) from exc
        try:
            wb = xlrd.open_workbook(str(path))
        except Exception as exc:
            raise InputError(f"cannot read this Excel workbook ({exc})", path=path) from None
        sheets = [(s.name, [s.row_values(r) for r in range(s.nrows)]) for s in wb.sheets()]
    if sheet is not None:
        names = [n for n, _ in sheets]
        if sheet not in names:
            raise InputError(f"no sheet {sheet!r} (sheets: {', '.join(repr(n) for n in names)})", path=path,
                             key="--sheet")
        sheets = [(n, r) for n, r in sheets if n == sheet]
    for name, rows in sheets:
        # the header: the first row naming an axis and a modulus (title rows above it are the sheet's notes)
        top = next((k for k, r in enumerate(rows[:_HEADER_SEARCH_LINES]) if _is_header(r, column_map)), None)
        if top is None:
            continue
        header = [str(h).strip() for h in rows[top]]
        data = [(k + 1, r) for k, r in enumerate(rows) if k > top]
        data = [(ln, r) for ln, r in data if any(str(c).strip() for c in r)]
        units = None
        if data and _units_like(data[0][1]):
            units = [_unit_cell(c) for c in data[0][1]]
            data = data[1:]
        return header, units, data, top + 1, name
    where = f"sheet {sheet!r} has no" if sheet is not None else "no sheet with a"
    raise InputError(f"{where} header row naming a frequency (f, Hz) or time (t, s) column beside a modulus "
                     "(E', E'', E_relax or G ...)", path=path, key="--sheet" if sheet is not None else None)


@dataclasses.dataclass
class MaterialData:
    """Frequency-domain moduli (storage and loss) or time-domain relaxation moduli, possibly at several temperatures.

    Attributes
    ----------
    name : file stem
    path : the file
    domain : ``"freq"`` (E'(f), E''(f)) or ``"time"`` (E(t))
    modulus : ``"E"`` (tensile) or ``"G"`` (shear)
    x : (N,) frequency (Hz) or time (s), > 0
    storage : (N,) storage modulus E' (MPa), or the relaxation modulus E(t) in the time domain
    loss : (N,) loss modulus E'' (MPa), or None in the time domain
    temperature_c : (N,) test temperature (deg C) or None (a master curve)
    set_id : (N,) integer set of each sample (one isothermal sweep each) or None
    lines : (N,) file line (CSV) or sheet row (Excel) of each sample
    sheet : sheet name of an Excel source, else None
    units_in_file : role -> the unit the file states ('' where it states none)
    warnings : implausible values under a stated unit (``fit relax`` prints them; ``--strict`` refuses them)
    """

    name: str
    path: Path | None
    domain: str
    modulus: str
    x: np.ndarray
    storage: np.ndarray
    loss: np.ndarray | None
    temperature_c: np.ndarray | None = None
    set_id: np.ndarray | None = None
    lines: np.ndarray | None = None
    sheet: str | None = None
    units_in_file: dict = dataclasses.field(default_factory=dict)
    warnings: list = dataclasses.field(default_factory=list)

    @property
    def n(self) -> int:
        return int(self.x.size)

    @property
    def is_raw(self) -> bool:
        """More than one isothermal set: needs time-temperature superposition."""
        return self.set_id is not None and np.unique(self.set_id).size > 1

    def where(self, i: int) -> int:
        return int(self.lines[i]) if self.lines is not None else i + 1

    def sets(self) -> list[tuple[float, np.ndarray]]:
        """[(set temperature in deg C, indices of its samples), ...] in the file's order of sets.

        The set temperature is the mean measured temperature of the set, rounded to a whole degree (as pyvisco does).
        """
        if self.set_id is None:
            T = float(np.round(np.mean(self.temperature_c))) + 0.0 if self.temperature_c is not None else math.nan
            return [(T, np.arange(self.n))]
        out = []
        _, first = np.unique(self.set_id, return_index=True)
        for s in self.set_id[np.sort(first)]:
            idx = np.flatnonzero(self.set_id == s)
            out.append((float(np.round(np.mean(self.temperature_c[idx]))) + 0.0, idx))  # + 0.0: never -0
        return out


def _temperature_jumps(T: np.ndarray) -> np.ndarray:
    """(N-1,) True where the temperature steps by more than :data:`SET_T_JUMP_C` from one sample to the next and
    stays there: a single sample off and back (a thermocouple's glitch) starts no set."""
    jump = np.abs(np.diff(T)) > SET_T_JUMP_C
    if T.size >= 3:
        back = np.abs(T[2:] - T[:-2]) <= SET_T_JUMP_C   # sample k off, k - 1 and k + 1 agree
        spike = jump[:-1] & jump[1:] & back
        jump[:-1] &= ~spike
        jump[1:] &= ~spike
    return jump


def read_material_file(path: str | Path, *, column_map: Mapping[str, str] | None = None,
                       sheet: str | None = None) -> MaterialData:
    """Read frequency-domain moduli or raw relaxation sets at several temperatures (CSV or Excel).

    Columns (names in the first header row, units in a second row or in parentheses):
    ``f`` (Hz; or ``omega`` in rad/s) with ``E_stor``/``E'`` and ``E_loss``/``E''`` (or ``G_...``); or ``t`` (s)
    with ``E_relax`` (or ``G_relax``) and a temperature column; optional ``T`` (C or K) and ``Set``. Sets are taken
    from the ``Set`` column, else from the frequency (time) restarting low, as an instrument logs consecutive
    sweeps. Every error names the file and line (sheet row).
    """
    path = Path(path)
    cmap = {str(k).strip(): str(v) for k, v in (column_map or {}).items()}
    if path.suffix.lower() in (".xls", ".xlsx"):
        header, units, rows, header_line, sheet = _xls_rows(path, cmap, sheet=sheet)
    else:
        header, units, rows, header_line = _csv_rows(path, cmap)
        sheet = None
    index: dict[str, tuple[int, str]] = {}
    roles = [_mat_role(cmap.get(h, h)) for h in header]
    # a role the column map gives is that column's alone: another column whose own name says the same is set aside
    # (a furnace 'Temperature (°C)' beside the mapped 'Sample temperature (°C)')
    mapped = {r for h, (r, _) in zip(header, roles) if h in cmap and r is not None}
    on_freq = bool({r for r, _ in roles} & {"f", "omega"})
    set_aside = []
    for j, h in enumerate(header):
        role, unit = roles[j]
        if role is None or (role in mapped and h not in cmap):
            if role is not None:
                set_aside.append(h)
            continue
        if role == "t" and on_freq:  # a frequency file's elapsed test time (Eplexor, RheoCompass): not used
            continue
        for text, line in ((h, header_line), (units[j] if units is not None and j < len(units) else None,
                                              header_line + 1)):
            if (slip := millipascal_slip(text)) is not None:
                raise InputError(f"the unit of column {h!r}: {slip}", path=path, line=line, key=h)
        fam = _ROLE_UNIT[role]
        # every place that states this column's unit must agree: the column map's name, the header, the units row
        stated = []
        if unit is not None:
            stated.append((unit, "the column map (--columns, config columns)" if h in cmap else "its name", header_line))
        if h in cmap and (hunit := _unit_in_name(h, fam)) is not None:
            stated.append((hunit, "its name", header_line))
        if units is not None and j < len(units) and units[j].strip():
            stated.append((units[j].strip().lower(), "the units row under the header", header_line + 1))
        if fam == "f" and any(u.replace(" ", "") == "mhz" for u, _, _ in stated):
            said = next(w for u, w, _ in stated if u.replace(" ", "") == "mhz")
            raise InputError(f"column {h!r}: {said} says mHz or MHz: millihertz and megahertz are 1e9 apart and "
                             "read alike once case is lost; give the frequency in Hz", path=path,
                             line=next(ln for u, _, ln in stated if u.replace(" ", "") == "mhz"), key=h)
        for (u1, w1, _), (u2, w2, l2) in zip(stated, stated[1:]):
            same = u1 == u2 or (u1 in _MAT_UNITS[fam] and u2 in _MAT_UNITS[fam]
                                and _MAT_UNITS[fam][u1] == _MAT_UNITS[fam][u2])
            if not same:
                raise InputError(f"column {h!r}: {w1} says {u1!r} and {w2} says {u2!r}; a column has one unit: "
                                 "correct the one that is wrong", path=path, line=l2, key=h)
        unit = (stated[0][0] if stated else "").strip()
        if unit not in _MAT_UNITS[fam]:
            raise InputError(f"unknown unit {unit!r} for column {h!r} (known: "
                             f"{', '.join(sorted(u for u in _MAT_UNITS[fam] if u))})", path=path,
                             line=header_line + (1 if units is not None else 0), key=h)
        if role in index:
            raise InputError(f"two columns give {role}: {header[index[role][0]]!r} and {h!r}; choose one with "
                             f"--columns {role}=<column> (config io.columns)", path=path, line=header_line, key=h)
        index[role] = (j, unit)
    has = index.__contains__
    freq = has("f") or has("omega")
    kinds = {"E": [r for r in ("storage", "loss", "relax") if has(r)],
             "G": [r for r in ("storage_g", "loss_g", "relax_g") if has(r)]}
    if kinds["E"] and kinds["G"]:
        raise InputError("both tensile (E) and shear (G) moduli in one file; give one kind per file", path=path,
                         line=header_line)
    modulus = "G" if kinds["G"] else "E"
    sfx = "_g" if modulus == "G" else ""
    found = ", ".join(repr(h) for h in header)
    if freq:  # a time column beside a frequency is the instrument's elapsed test time (Eplexor): not used
        domain = "freq"
        for r in ("storage", "loss"):
            if not has(r + sfx):
                # a loss factor is not a modulus: say which column it is and how to get the loss modulus from it
                tand = [h for h in header if r == "loss" and re.search(r"tan\s*[_(\s]*(delta|d\b|δ)|loss\s*factor",
                                                                        str(h), re.IGNORECASE)]
                hint = (f"; {tand[0]!r} is the loss factor tan(delta) = {modulus}''/{modulus}', not a modulus: add a "
                        f"column {modulus}'' = {modulus}' tan(delta), in the unit of {modulus}'") if tand else ""
                raise InputError(f"frequency-domain data need storage and loss moduli ({modulus}_stor and "
                                 f"{modulus}_loss, or {modulus}' and {modulus}''); found columns {found}{hint}",
                                 path=path, line=header_line, key=f"{modulus}_{r[:4]}")
    elif has("t"):
        domain = "time"
        if not has("relax" + sfx):
            raise InputError(f"time-domain data need a relaxation modulus column ({modulus}_relax); found columns "
                             f"{found}", path=path, line=header_line, key=f"{modulus}_relax")
    else:
        raise InputError(f"no frequency (f, Hz) or time (t, s) column; found columns {found}: name the axis 'f (Hz)' "
                         "or 't (s)', or map it with --columns f=<your column> (or t=...; config io.columns)",
                         path=path, line=header_line)
    if has("set") and not has("T"):
        raise InputError("a raw set without temperatures: the file has a Set column but no temperature column T "
                         "(C); add the test temperature of every row", path=path, line=header_line, key="T")

    warnings: list[str] = []
    if has("T"):  # another column that names a temperature: which one is the sample's is the user's to say
        other = [h for j, h in enumerate(header) if j != index["T"][0] and "temp" in h.lower()]
        if other:
            warnings.append(f"{path.name}: the temperature is read from {header[index['T'][0]]!r}; "
                            f"{', '.join(repr(h) for h in other)} set aside (if that is the sample's temperature, "
                            f"map it with --columns T=<column>)")
    # a name that says neither E nor G ("Storage Modulus", as rheometers and DMA software both write it)
    vague = [header[index[r][0]] for r in ("storage", "loss", "relax") if has(r)
             and _mat_key(_split_unit(cmap.get(header[index[r][0]], header[index[r][0]]))[0]) in _VAGUE_MODULUS]
    if vague:
        warnings.append(f"{path.name}: the column(s) {', '.join(repr(v) for v in vague)} say neither E (tensile) nor G "
                        "(shear): read as tensile E (a DMA in tension or bending); a rheometer's or a shear DMA's "
                        "storage modulus is G: if so, name the columns G' and G'' (or G_stor, G_loss)")

    def where(i: int) -> str:   # the file and line of data row i, for a warning
        return f"{path.name}:{int(rows[i][0])}" if path is not None else f"line {int(rows[i][0])}"

    def column(role: str) -> np.ndarray:
        j, unit = index[role]
        fam = _ROLE_UNIT[role]
        canonical_f = fam == "f" and _split_unit(cmap.get(header[j], header[j]))[0].strip() == "f"  # documented: Hz
        if unit == "" and fam in _STATED and not canonical_f:  # C, K or F; MPa or GPa; Hz or rad/s: never guessed
            raise InputError(f"column {header[j]!r} states no unit, and bpmid does not guess one "
                             f"({_STATED[fam][0]}): {_STATED[fam][1].format(h=header[j])}, or add a units row "
                             f"under the header", path=path, line=header_line, key=header[j])
        vals = np.empty(len(rows))
        for r, (ln, row) in enumerate(rows):
            cell = row[j] if j < len(row) else ""
            try:
                v = float(cell if not isinstance(cell, str) else cell.strip())
            except ValueError:
                first = str(row[0]).strip() if row else ""
                if re.fullmatch(r"\[.*\]", first):  # an export's next section ('[step]', '[Summary]', '[Interval]')
                    raise InputError(f"line {ln} starts a section {first!r} that does not repeat the table's header "
                                     "(the same columns in the same order): bpmid reads one table per file; export "
                                     "every step with the same columns, or cut the file where the data end",
                                     path=path, line=ln) from None
                raise InputError(f"column {header[j]!r}: {cell!r} is not a number", path=path, line=ln) from None
            if not np.isfinite(v):
                raise InputError(f"column {header[j]!r}: {cell!r} (NaN or infinite values are not allowed)", path=path,
                                 line=ln)
            vals[r] = v
        if fam == "T":
            c = vals + _MAT_UNITS["T"][unit]  # K -> C: T - 273.15; C unchanged
            in_row = units is not None and j < len(units) and bool(units[j].strip())

            def fix(u):   # where the file states the unit: the units row under the header, or the column's name
                return (f"write {u} in the units row under the header for column {header[j]!r}" if in_row else
                        f"name the column '{_split_unit(header[j])[0].strip()} ({u})'")
            if c.size and float(c.min()) < -273.15:
                i = int(np.flatnonzero(c < -273.15)[0])   # the first such line
                raise InputError(f"column {header[j]!r}: {vals[i]:g} {unit or 'C'} is below absolute zero: check the "
                                 "unit (degrees C under a kelvin header?)", path=path, line=int(rows[i][0]))
            if c.size and unit != "k" and float(c.min()) > WARM_C:
                i = int(np.argmin(c))
                warnings.append(f"{where(i)}: column {header[j]!r} is {c.min():.4g} to {c.max():.4g} C, every sample above "
                                f"{WARM_C:g} C, hotter than an elastomer's test range: kelvin under a degrees C header? "
                                f"(0 C is 273.15 K; if these are kelvin, {fix('K')})")
            elif c.size and unit == "k" and float(c.max()) < COLD_C:
                i = int(np.argmax(c))
                warnings.append(f"{where(i)}: column {header[j]!r} is {vals.min():g} to {vals.max():g} K "
                                f"({c.min():.4g} to {c.max():.4g} C), every sample below {COLD_C:g} C: degrees C under "
                                f"a kelvin header? (if so, {fix('C')})")
            return c
        out = vals * _MAT_UNITS[fam][unit]
        if fam == "modulus" and out.size and float(out.max()) > MAX_PLAUSIBLE_MPA:
            i = int(np.argmax(out))
            warnings.append(f"{where(i)}: column {header[j]!r} reaches {out[i]:.4g} MPa ({vals[i]:g} {unit}), above "
                            f"{MAX_PLAUSIBLE_MPA:g} MPa (100 GPa), stiffer than any polymer: check the unit "
                            f"({unit!r} stated)")
        return out

    if not rows:
        raise InputError("a header but no data rows", path=path, line=header_line)
    lines = np.array([ln for ln, _ in rows], int)
    x = column("f") if has("f") else (column("omega") if has("omega") else column("t"))
    what = "frequency" if freq else "time"
    bad = np.flatnonzero(~(x > 0))
    if bad.size:
        raise InputError(f"non-positive {what} {x[bad[0]]:g} {'Hz' if freq else 's'}: {what}s must be > 0 (a "
                         "log-spaced axis)", path=path, line=int(lines[bad[0]]))
    if freq:
        stor, loss = column("storage" + sfx), column("loss" + sfx)
        names = (f"storage modulus {modulus}'", f"loss modulus {modulus}''")
        mods = (stor, loss)
    else:
        stor, loss = column("relax" + sfx), None
        names, mods = (f"relaxation modulus {modulus}(t)",), (stor,)
    for nm, v in zip(names, mods):
        bad = np.flatnonzero(~(v > 0))
        if bad.size:
            raise InputError(f"non-positive {nm} {v[bad[0]]:g} MPa: moduli must be > 0 (the fit weighs residuals "
                             "relative to the data)", path=path, line=int(lines[bad[0]]))
    T = column("T") if has("T") else None
    if T is not None:
        bad = np.flatnonzero(T < -273.15)
        if bad.size:
            raise InputError(f"temperature {T[bad[0]]:g} C is below absolute zero", path=path,
                             line=int(lines[bad[0]]))
    if has("set"):
        sid = column("set")
        if np.any(sid != np.round(sid)):
            i = int(np.flatnonzero(sid != np.round(sid))[0])
            raise InputError(f"Set must be a whole number, found {sid[i]:g}", path=path, line=int(lines[i]))
        sid = sid.astype(int)
    elif T is not None:
        # consecutive sweeps: a new set starts where the sweep direction restarts (the dominant direction is the sign
        # of the median step: an instrument sweeping high to low restarts where the frequency jumps back up) or
        # where the temperature jumps from one sample to the next (a sweep continued at another temperature)
        step = np.diff(x)
        direction = -1.0 if step.size and float(np.median(step)) < 0 else 1.0
        sid = np.concatenate([[0], np.cumsum((direction * step < 0) | _temperature_jumps(T))]).astype(int)
    else:
        sid = None
        step = np.diff(x)
        unit_word = "Hz" if freq else "s"
        if np.all(step <= 0) or np.all(step >= 0):  # monotone: a repeated value is a repeated measurement
            # a row repeated whole (within rounding) is a copy, refused; the same frequency with other moduli is two
            # measurements (a master curve joined from parts that overlap, as pyvisco's are), both fitted, whether
            # its file wrote the two frequencies apart in their last digit or, re-exported, as one number
            same = np.flatnonzero(np.abs(step) <= REPEAT_RTOL * np.abs(x[1:]))
            for i in (int(k) for k in same):
                if all(np.isclose(m[i], m[i + 1], rtol=REPEAT_RTOL, atol=0.0) for m in (stor, loss) if m is not None):
                    raise InputError(f"line {int(lines[i + 1])} repeats line {int(lines[i])} ({what} {x[i]:g} "
                                     f"{unit_word}, the same moduli): a copied row; drop it", path=path,
                                     line=int(lines[i + 1]))
            if step.size and np.all(step <= 0) and np.any(step < 0):  # logged high to low, as many instruments do
                o = np.arange(x.size)[::-1]
                x, stor, lines = x[o], stor[o], lines[o]
                loss = None if loss is None else loss[o]
        else:
            i = int(np.flatnonzero(step * np.sign(np.median(step) or 1.0) <= 0)[0]) + 1
            raise InputError(f"the {what} falls back ({x[i - 1]:g} then {x[i]:g}): several sweeps in one file are raw "
                             "sets, which need a temperature column T (C) to be shifted into a master curve (map yours with "
                             "--columns T=<column>); or, for "
                             "one master curve joined from parts that overlap, remove the rows the parts repeat",
                             path=path, line=int(lines[i]), key="T")
    out = MaterialData(path.stem, path, domain, modulus, x, stor, loss, T, sid, lines, sheet,
                       {r: u for r, (_, u) in index.items()}, warnings)
    if sid is not None:
        sets = out.sets()
        for Tset, idx in sets:
            if len(sets) > 1 and idx.size < MIN_SET_SAMPLES:
                raise InputError(f"the set at {Tset:g} C (from line {int(lines[idx[0]])}) has {idx.size} sample(s): a "
                                 f"set needs at least {MIN_SET_SAMPLES} to be overlaid on its neighbours (shift factors "
                                 f"are judged on at least {MIN_SET_SAMPLES} overlapping samples); drop it or measure "
                                 f"more {'frequencies' if freq else 'times'}{_SET_HINT if not has('set') else ''}",
                                 path=path, line=int(lines[idx[0]]))
            Tspan = float(np.ptp(T[idx]))
            if Tspan > SET_T_SPAN_C:
                raise InputError(f"the set from line {int(lines[idx[0]])} to line {int(lines[idx[-1]])} spans "
                                 f"{T[idx].min():.4g} to {T[idx].max():.4g} C: a set is one isothermal sweep (within "
                                 f"{SET_T_SPAN_C:g} C), and a sweep across temperatures cannot be shifted as one; "
                                 "number the sweeps in a Set column, or fit a temperature sweep at one frequency with "
                                 "another tool", path=path, line=int(lines[idx[0]]), key=header[index["T"][0]])
            xs = x[idx]
            if np.unique(xs).size < xs.size:
                o = np.argsort(xs, kind="stable")
                first = int(np.flatnonzero(np.diff(xs[o]) == 0)[0])
                j, k = idx[o[first]], idx[o[first + 1]]
                unit_word = "Hz" if freq else "s"
                if all(np.isclose(m[j], m[k], rtol=REPEAT_RTOL, atol=0.0) for m in (stor, loss) if m is not None):
                    raise InputError(f"line {int(lines[k])} repeats line {int(lines[j])} (the set at {Tset:g} C, {what} "
                                     f"{x[k]:g} {unit_word}, the same moduli): a copied row; drop it", path=path,
                                     line=int(lines[k]))
                hint = "" if has("set") else _SET_HINT
                raise InputError(f"the set at {Tset:g} C repeats the {what} {x[k]:g} {unit_word}{hint}", path=path,
                                 line=int(lines[k]))
    return out
