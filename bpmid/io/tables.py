"""Read the tables labs export and bring every column to a canonical quantity and unit.

Formats (told apart by their bytes, not only by their extension):

- text tables: comma, semicolon (with decimal commas), tab or whitespace separated; UTF-8 with or without
  BOM, UTF-16 (BOM or not), Latin-1/cp1252; LF, CRLF or CR line ends; an Excel ``sep=;`` first line
- Excel workbooks: ``.xlsx`` (openpyxl) and legacy ``.xls`` (xlrd); the sheet named by ``sheet`` or the one
  sheet whose header has the columns the log needs
- MATLAB files: v5/v7 (scipy.io) and v7.3 (HDF5, h5py); every numeric vector (also struct fields
  ``s.field`` and matrix columns ``m(:,2)``) is a column named by its variable; char variables are metadata

Column names, all mapped to ``(quantity, unit)``:

- bpmid's own names with a unit suffix: ``time_s``, ``pressure_kpa``, ``stress_mpa``, ``angle_deg``
- instrument style: ``Time (s)``, ``Load [N]``, ``p / bar``, ``Druck in kPa``
- names then a units row (pyvisco): ``t,E_relax`` / ``s, MPa``
- a column map (``io.columns`` / ``--columns``): file header -> bpmid name (``Zeit`` -> ``time`` or ``time_s``); a
  key names a header with or without the unit written beside it (``Dehnung`` names ``Dehnung [-]``); entries that
  match no column are named in the errors about missing or unreadable columns, and said to look reversed when
  their values are columns of the file

Units are never guessed. A column whose unit is stated nowhere (name, units row, a ``# pressure_unit: kPa``
line, ``io.units`` or the ``--pressure-unit``/``--angle-unit``/``--time-unit`` flags) is refused, naming the
column and the ways to state it; strain is dimensionless by its name. A unit stated twice must agree (a
``# pressure_unit:`` line and the header too; a column map that carries a unit overrides the file's). A
pressure unit may carry its reference (``psig``, ``bar(a)``, ``kPa abs``). Times may be ISO-8601 timestamps (or
Excel dates), clock times (``09:30:01.250``) or epoch times (``epoch_s``, ``epoch_ms``); all become seconds since
the first sample.

Every data row must have exactly the header's fields (a decimal comma in a comma-separated file is refused
with its line, never read by position). Leading ``# key: value`` lines are metadata; keys are
case-insensitive (``# Pressure reference: Absolute``). What the reader found and assumed is in
:attr:`Table.reading` (it goes into every output's provenance). Every error names the file and, where it
can, the line.
"""
from __future__ import annotations

import csv
import dataclasses
import io
import re
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from bpmid.errors import InputError
from bpmid.io.atomic import note_input
from bpmid.units import PRESSURE_REF_SUFFIXES, PRESSURE_UNITS, millipascal_slip, split_pressure_unit

#: quantity -> canonical unit
CANONICAL = {
    "time": "s", "strain": "1", "stress": "MPa", "load": "N", "extension": "mm",
    "modulus": "MPa", "pressure": "Pa", "angle": "deg", "ambient": "Pa",
}

#: quantity -> {unit spelling (lower case) -> factor to the canonical unit}
UNITS: dict[str, dict[str, float]] = {
    "time": {"s": 1.0, "sec": 1.0, "secs": 1.0, "second": 1.0, "seconds": 1.0, "ms": 1e-3, "msec": 1e-3,
             "us": 1e-6, "µs": 1e-6, "μs": 1e-6, "min": 60.0, "h": 3600.0, "epoch_s": 1.0, "epoch_ms": 1e-3,
             "unix_s": 1.0, "unix_ms": 1e-3, "iso8601": 1.0},
    "strain": {"1": 1.0, "-": 1.0, "": 1.0, "mm/mm": 1.0, "m/m": 1.0, "%": 0.01, "pct": 0.01},
    "stress": {"mpa": 1.0, "n/mm^2": 1.0, "n/mm2": 1.0, "n/mm²": 1.0, "kpa": 1e-3, "pa": 1e-6, "gpa": 1e3,
               "psi": 6894.757293168e-6},
    "load": {"n": 1.0, "kn": 1e3, "mn": 1e-3, "lbf": 4.4482216152605},
    "extension": {"mm": 1.0, "m": 1e3, "um": 1e-3, "µm": 1e-3, "μm": 1e-3, "cm": 10.0, "in": 25.4},
    "modulus": {"mpa": 1.0, "n/mm^2": 1.0, "n/mm2": 1.0, "n/mm²": 1.0, "kpa": 1e-3, "pa": 1e-6, "gpa": 1e3},
    "pressure": PRESSURE_UNITS,   # bpmid.units' one list (from_arrays takes the same)
    "angle": {"deg": 1.0, "degree": 1.0, "degrees": 1.0, "°": 1.0, "rad": 180.0 / np.pi, "mrad": 0.18 / np.pi,
              "gon": 0.9},
}
# the ambient (barometric) pressure logged beside an absolute pressure: the same units
UNITS["ambient"] = dict(UNITS["pressure"])

#: units that make a one-letter name (T, P) a temperature, not the time or the pressure (lower case, no spaces)
TEMPERATURE_UNITS = {"k", "kelvin", "°c", "ºc", "degc", "deg c", "c", "celsius", "°f", "degf", "f", "fahrenheit"}

#: time units that are points in time (epoch), turned into seconds since the first sample
EPOCH_UNITS = ("epoch_s", "epoch_ms", "unix_s", "unix_ms")

#: header base names (lower case, spaces/underscores folded) -> quantity
ALIASES = {
    "time": "time", "t": "time", "zeit": "time", "timestamp": "time", "time stamp": "time", "datetime": "time",
    "date time": "time", "elapsed time": "time", "elapsed": "time",
    "strain": "strain", "eps": "strain", "epsilon": "strain", "tensile strain": "strain",
    "stress": "stress", "sigma": "stress", "tensile stress": "stress",
    "load": "load", "force": "load", "kraft": "load",
    "extension": "extension", "elongation": "extension", "displacement": "extension",
    "crosshead": "extension",
    "modulus": "modulus", "e relax": "modulus", "relaxation modulus": "modulus",
    "e": "modulus", "e(t)": "modulus",
    "pressure": "pressure", "p": "pressure", "druck": "pressure", "supply pressure": "pressure",
    "angle": "angle", "beta": "angle", "bending angle": "angle", "theta": "angle", "bend angle": "angle",
    "winkel": "angle", "biegewinkel": "angle",
    # not 'air pressure': on a pneumatic rig that is as often the supply
    "ambient pressure": "ambient", "atmospheric pressure": "ambient", "barometric pressure": "ambient",
    "p amb": "ambient", "p atm": "ambient", "p ambient": "ambient", "p baro": "ambient", "umgebungsdruck": "ambient",
    # a column named only so (a temperature unit beside it makes it a temperature: 'Ambient [°C]', set aside)
    "ambient": "ambient", "barometer": "ambient", "baro": "ambient", "barometric": "ambient", "atmospheric": "ambient",
}

#: header base names whose unit 'grad' is the German for degree (elsewhere 'grad' may be the gradian: refused)
GERMAN_ANGLE = {"winkel", "biegewinkel"}

#: how a user states the unit of each quantity on the command line (others: the config's io.units)
UNIT_FLAGS = {"time": "--time-unit", "pressure": "--pressure-unit", "angle": "--angle-unit"}

#: an example unit per quantity (messages)
EXAMPLE_UNIT = {"time": "s", "pressure": "kPa", "angle": "deg", "stress": "MPa", "load": "N", "extension": "mm",
                "modulus": "MPa", "strain": "1", "ambient": "kPa"}

#: bpmid's name for each quantity in canonical unit (messages, ``--columns``)
BPMID_NAME = {"time": "time_s", "pressure": "pressure_kpa", "angle": "angle_deg", "strain": "strain",
              "stress": "stress_mpa", "load": "load_n", "extension": "extension_mm", "modulus": "modulus_mpa",
              "ambient": "ambient_pressure_kpa"}

#: words in a column name that mark it as derived from a quantity, not the quantity itself
#: (bpmid's own outputs: ``angle_pred_deg``, ``angle_ref_deg``; rigs: ``pressure_setpoint_bar``)
DERIVED_WORDS = {"pred", "predicted", "model", "sim", "simulated", "ref", "reference", "cmd", "command",
                 "setpoint", "set", "target", "residual", "error", "err", "fit", "filtered", "std", "sd",
                 "commanded", "demand", "desired", "requested", "request", "sp", "soll", "sollwert",
                 "max", "min", "mean", "avg", "average", "peak", "drop", "delta", "rate", "rms"}
#: the start of a German compound that names a setpoint (Solldruck, Sollwinkel): derived, like DERIVED_WORDS
_DERIVED_PREFIXES = ("soll",)

_PAREN = re.compile(r"^(.*?)\s*[\(\[\{]\s*([^\)\]\}]*)\s*[\)\]\}]\s*$")
_SLASH = re.compile(r"^(.*?\S)\s+(?:/|in)\s+(\S+)$")
#: a quantity and its unit with one slash and no spaces ('t/s', 'p/bar'); read only when the unit is one bpmid knows
_SLASH_TIGHT = re.compile(r"^([^/]*[^\s/])/([^\s/]+)$")
_COMMA_UNIT = re.compile(r"^(.*?\S),\s+(\S+)$")
#: words of a pressure column's name that state its reference ('Gauge pressure', 'Druck rel.', 'p abs')
_NAME_REF_WORDS = {"gauge": "gauge", "gage": "gauge", "relative": "gauge", "rel": "gauge", "relativ": "gauge",
                   "absolute": "absolute", "abs": "absolute", "absolut": "absolute"}
_REF_WORDS = PRESSURE_REF_SUFFIXES
_COMMA_NUM = re.compile(r"^[+-]?\d*,\d+(?:[eE][+-]?\d+)?$")
_DOT_NUM = re.compile(r"^[+-]?\d*\.\d+(?:[eE][+-]?\d+)?$")
_CLOCK = re.compile(r"^\s*\d{1,2}:\d{2}(?::\d{2}(?:[.,]\d+)?)?\s*$")
#: an elapsed time as minutes:seconds with a fraction (Excel's 'mm:ss.0': '01:05.3'); a fraction rules out hh:mm
#: MATLAB's default datetime text ('01-Mar-2026 10:00:00.125')
_MATLAB_DATE = re.compile(r"^\s*\d{1,2}-[A-Za-z]{3}-\d{4}(?:\s+\d{1,2}:\d{2}:\d{2}(?:\.\d+)?)?\s*$")
_MMSS = re.compile(r"^\s*(\d{1,4}):(\d{2}[.,]\d+)\s*$")
#: a dotted date (always day-first: German, Swiss, Russian instruments) and a time: 30.03.2025 01:59:40,0
_DOTTED_DATE = re.compile(r"^\s*(\d{1,2})\.(\d{1,2})\.(\d{4})[ T]+(\d{1,2}):(\d{2})(?::(\d{2})(?:[.,](\d+))?)?\s*$")
#: a date with slashes: day-first in some locales, month-first in others (03/04/2025), never guessed
_SLASH_DATE = re.compile(r"^\s*\d{1,2}/\d{1,2}/\d{2,4}\b")
#: a year-first date with slashes (2025/03/01 10:00:00.125): unambiguous, read as ISO 8601
_YMD_SLASH = re.compile(r"^\s*(\d{4})/(\d{1,2})/(\d{1,2})(?:[ T]+(.*))?\s*$")
#: a 12-hour clock time (12:59:50.000 PM, 1:05 am)
_CLOCK_12 = re.compile(r"^\s*(\d{1,2}):(\d{2})(?::(\d{2})(?:[.,](\d+))?)?\s*([AaPp])\.?\s*[Mm]\.?\s*$")
_SEP_LINE = re.compile(r'^\s*"?sep=(.)"?\s*$', re.IGNORECASE)
_META = re.compile(r"^\s*([A-Za-z][\w \-./()\[\]^]*?)\s*[:=]\s*(.*)$")
#: a metadata key standing in a cell of its own ('Pressure Reference' | 'Gauge', 'Area (mm^2)' | 12): the key of
#: :data:`_META`
_META_KEY = re.compile(r"^[A-Za-z][\w \-./()\[\]^]*$")
_MAGIC_XLSX = b"PK\x03\x04"
_MAGIC_OLE = b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1"
_MAGIC_HDF5 = b"\x89HDF\r\n\x1a\n"
_MAGIC_GZIP = b"\x1f\x8b"
_MAX_BYTES = 1 << 30


@dataclasses.dataclass
class Table:
    """A log's columns in canonical units.

    Attributes
    ----------
    path : Path
    columns : dict quantity -> float array (canonical unit, see :data:`CANONICAL`)
    units_in_file : dict quantity -> unit as stated (lower case)
    headers : dict quantity -> header text as written
    meta : dict from ``# key: value`` lines (keys lower case, spaces as underscores)
    first_data_line : 1-based line number of the first data row (for error messages)
    lines : file line (text), sheet row (Excel) or sample number (MATLAB) of each data row
    references : quantity -> pressure reference stated with the unit (``psig``, ``bar(a)``)
    reading : what was read and assumed (format, encoding, separators, column units and where they came from)
    warnings : things the user should know (gaps, ignored columns); printed and written by the commands
    where : the file as named in messages (``log.xlsx[Sheet1]``)
    """

    path: Path
    columns: dict[str, np.ndarray]
    units_in_file: dict[str, str]
    headers: dict[str, str]
    meta: dict[str, str]
    first_data_line: int
    lines: np.ndarray | None = None
    references: dict[str, str] = dataclasses.field(default_factory=dict)
    reading: dict = dataclasses.field(default_factory=dict)
    warnings: list[str] = dataclasses.field(default_factory=list)
    where: str | None = None
    #: the column-map entries that matched no column (and whether the map looks reversed), for messages
    map_note: str = ""
    #: metadata key -> the file line (sheet row) it was read from
    meta_lines: dict = dataclasses.field(default_factory=dict)
    #: quantity -> why its column could not be read, for a quantity only some readers need (the ambient pressure:
    #: an absolute log's); the column is listed as ignored, and the reader that needs it raises this
    deferred: dict = dataclasses.field(default_factory=dict)
    #: header -> (cells, unit stated in its name or the units row, or None) of each column bpmid set aside, for a
    #: reader that checks one (a relaxation log's test temperature)
    ignored_cells: dict = dataclasses.field(default_factory=dict)

    def has(self, quantity: str) -> bool:
        return quantity in self.columns

    def line_of(self, row: int) -> int:
        """File line number of data row ``row`` (0-based)."""
        if self.lines is not None and 0 <= int(row) < len(self.lines):
            return int(self.lines[int(row)])
        return self.first_data_line + int(row)

    @property
    def name(self) -> str:
        return self.where or str(self.path)


@dataclasses.dataclass
class Grid:
    """A table before its columns are understood: header, optional units row, cells column by column."""

    header: list[str]
    unit_row: list[str] | None
    cols: list[list]
    lines: list[int]
    meta: dict[str, str]
    where: str
    header_line: int
    info: dict
    #: meta key -> the line (sheet row) that stated it, for messages
    meta_lines: dict = dataclasses.field(default_factory=dict)
    #: line (sheet row) of the units row, or None
    unit_row_line: int | None = None

    @property
    def excel(self) -> bool:
        """Whether the grid is a spreadsheet's (its cells typed by Excel, not split from text)."""
        return str(self.info.get("format", "")).startswith("excel")


# ---------------------------------------------------------------------------------------------------------
# names and units
# ---------------------------------------------------------------------------------------------------------
def _norm(name: str) -> str:
    return re.sub(r"[\s_]+", " ", str(name).strip().lower()).strip()


def meta_key(key: str) -> str:
    """``'Pressure reference'`` -> ``'pressure_reference'`` (comment keys are case-insensitive)."""
    return re.sub(r"[\s\-]+", "_", str(key).strip().lower())


def _clean_unit(unit: str) -> str:
    u = str(unit).strip().strip('"').strip().lower()
    u = u.strip("()[]{} ")
    return u.replace("°c", "degc")


def split_unit(quantity: str, unit: str) -> tuple[str | None, str | None]:
    """A unit spelling -> (unit known to :data:`UNITS`, pressure reference it carries or None).

    ``'psig'`` -> ``('psi', 'gauge')``; ``'bar(a)'`` -> ``('bar', 'absolute')``; ``'kPa abs'`` ->
    ``('kpa', 'absolute')``; an unknown spelling -> ``(None, None)``.
    """
    u = _clean_unit(unit)
    if quantity == "angle" and u in ("°", "deg."):
        return "deg", None
    if quantity == "time" and u in ("iso", "iso8601", "iso-8601", "datetime"):
        return "iso8601", None
    if quantity == "time" and u in ("epoch", "unix", "posix", "epoch s", "unix s"):
        return "epoch_s", None
    if quantity == "time" and u in ("epoch ms", "unix ms"):
        return "epoch_ms", None
    if u in UNITS[quantity]:
        return u, None
    if quantity in ("pressure", "ambient"):
        got = split_pressure_unit(u)
        if got[0] is not None:
            return got
    return None, None


def _unit_part(name: str) -> tuple[str, str | None]:
    """``'Time (s)'`` -> ``('time', 's')``, ``'p / bar'`` -> ``('p', 'bar')``; else (name, None)."""
    raw = str(name).strip().strip('"').strip()
    m = _PAREN.match(raw)
    if m and m.group(1).strip():
        if re.fullmatch(r"[\d:,\s]+", m.group(2)) and ("," in m.group(2) or ":" in m.group(2)):
            return raw, None   # a MATLAB matrix column, data(:,1): an index, no unit
        return m.group(1), m.group(2).strip()
    m = _SLASH.match(raw)
    if m:
        return m.group(1), m.group(2).strip()
    m = _SLASH_TIGHT.match(raw)   # 't/s', 'strain/%' (DIN 1313's quantity/unit): only a unit bpmid knows after it
    if m and any(split_unit(q, m.group(2))[0] is not None for q in UNITS):
        return m.group(1), m.group(2).strip()
    m = _COMMA_UNIT.match(raw)   # 'Time, s' in a ';' or tab file: only a unit bpmid knows after the comma
    if m and any(split_unit(q, m.group(2))[0] is not None for q in UNITS):
        return m.group(1), m.group(2).strip()
    return raw, None


def parse_header(name: str, unit_row: str | None = None) -> tuple[str | None, str | None]:
    """``'Time (s)'`` -> ``('time', 's')``; ``'pressure_kpa'`` -> ``('pressure', 'kpa')``.

    The unit is ``None`` when the name states none (the caller decides whether that is allowed).
    Returns (None, None) for a column bpmid does not know.
    """
    q, unit, _ref, _derived = _parse(name, unit_row)
    return q, unit


def _parse(name: str, unit_row: str | None = None):
    """(quantity, unit or None, reference or None, derived) of a header; quantity None if unknown.

    ``unit`` is the spelling as written (lower case) when it is not one bpmid knows, so that the caller can say
    "unknown unit"."""
    raw, unit = _unit_part(name)
    said = "header"  # where the unit beside the name was written (messages): the header or the units row
    word_ref = None   # a pressure's reference written as a word of its name: 'Gauge pressure (kPa)', 'Druck rel. [bar]'
    if unit is not None and _norm(unit).rstrip(".") in _NAME_REF_WORDS:   # 'Pressure (kPa) [gauge]'
        raw2, unit2 = _unit_part(raw)
        word_ref, raw, unit = _NAME_REF_WORDS[_norm(unit).rstrip(".")], raw2, unit2
    words0 = [w.rstrip(".") for w in _norm(raw).split(" ")]
    kept = [w for w in words0 if w not in _NAME_REF_WORDS]
    # 'gauge' after the pressure word names the instrument ('Pressure gauge (bar)'): only before it a reference
    instrument = any(w in ("gauge", "gage") and k > 0 and words0[k - 1] not in _NAME_REF_WORDS
                     and ALIASES.get(words0[k - 1]) == "pressure" for k, w in enumerate(words0))
    if len(kept) < len(words0) and kept and ALIASES.get(" ".join(kept)) == "pressure" and not instrument:
        refs = {_NAME_REF_WORDS[w] for w in words0 if w in _NAME_REF_WORDS}
        if len(refs) == 1 and word_ref in (None, *refs):
            word_ref, raw = refs.pop(), " ".join(kept)
    if word_ref is not None:
        q, u, ref, derived = _parse(raw if unit is None else f"{raw} ({unit})", unit_row)
        if q != "pressure":
            return q, u, ref, derived
        if ref is not None and ref != word_ref:   # 'Gauge pressure (kPa abs)': refused as a conflict
            return q, f"conflict:{word_ref}|{ref}|header", None, False
        return q, u, word_ref, derived
    base = _norm(raw)
    if unit is None and base.replace(" ", "_") in EPOCH_UNITS:   # 'epoch_ms', 'unix_s': the name is the unit
        return "time", base.replace(" ", "_"), None, False
    if base not in ALIASES and "." in base and _norm(base.rsplit(".", 1)[1]):
        base = _norm(base.rsplit(".", 1)[1])  # a MATLAB struct field: run.t -> t
    row = unit_row.strip() if unit_row is not None and unit_row.strip() else None
    if unit is None and row is not None:
        unit, said, row = row, "units row", None
    if base in ALIASES:
        q = ALIASES[base]
        if (len(base) == 1 or q == "ambient") and unit is not None \
                and _norm(unit).replace(" ", "") in TEMPERATURE_UNITS:
            return None, None, None, False  # 'T (K)', 'Ambient [°C]': a temperature beside the log
        if q == "angle" and base in GERMAN_ANGLE and unit is not None and _clean_unit(unit) == "grad":
            unit = "deg"   # 'Winkel [Grad]': German for degree
        u, ref = _unit_ref(q, unit)
        return _against_row(q, u, ref, unit, row) + (False,)
    words = base.split(" ")
    # suffix forms: time_s, pressure_kpa, angle_deg, pressure_bar_abs, pressure_kpa_g, theta_rad
    for cut in (1, 2):
        if len(words) > cut and " ".join(words[:-cut]) in ALIASES:
            q = ALIASES[" ".join(words[:-cut])]
            suffix = " ".join(words[-cut:])
            u, ref = split_unit(q, suffix)
            if u is None and q == "angle" and " ".join(words[:-cut]) in GERMAN_ANGLE and suffix == "grad":
                u, ref = "deg", None
            if u is not None:
                if unit is not None:  # 'pressure_kpa (bar)': the name and the parentheses disagree or repeat
                    u2, ref2 = _unit_ref(q, unit)
                    if u2 not in UNITS[q] or UNITS[q][u2] != UNITS[q][u]:   # 's' and 'sec' agree
                        return q, f"conflict:{suffix}|{unit}|{said}", None, False
                return q, u, ref, False
    # derived columns: angle_pred_deg, pressure_setpoint_bar (named by a quantity plus a qualifier word)
    if len(words) >= 2 and words[0] in ALIASES and any(w in DERIVED_WORDS for w in words[1:]):
        return None, None, None, True
    if unit is None and len(words) == 2 and words[0] in ALIASES:
        # 'pressure psx': a suffix that is no unit bpmid knows
        q = ALIASES[words[0]]
        return q, words[1], None, False
    return None, None, None, False


def _against_row(q: str, u: str | None, ref: str | None, written: str | None, row: str | None):
    """(quantity, unit, reference) of a header that states its unit in brackets, checked against the units row
    under it (``row``, None when the header alone states it): a known unit there of another size (``s`` over
    ``ms``; ``s`` over ``sec`` is the same), or a reference that differs, is a conflict (never one of them silently
    dropped); the row may add the reference."""
    if row is None or u is None or u.startswith("conflict:") or u not in UNITS[q]:
        return q, u, ref
    ru, rref = split_unit(q, row)
    if ru is None:   # 'Druck (bar)' in the row under 'Pressure (kPa g)': the unit it names
        rq, rus, rrf, _d = _parse(row)
        if rq == q and rus in UNITS[q]:
            ru, rref = rus, rrf
    if ru is None:
        return q, u, ref
    if UNITS[q][ru] != UNITS[q][u] or (rref is not None and ref is not None and rref != ref):
        return q, f"conflict:{written}|{row}|units row", None
    return q, u, ref if ref is not None else rref


def _unit_ref(q: str, unit: str | None) -> tuple[str | None, str | None]:
    if unit is None:
        return None, None
    u, ref = split_unit(q, unit)
    if u is None:
        return _clean_unit(unit), None
    return u, ref


def _unit_quantities(name: str) -> list[str]:
    """Quantities whose units the name's suffix or parentheses carry (``theta_deg`` -> ``['angle']``)."""
    raw, unit = _unit_part(name)
    if unit is None:
        words = _norm(raw).split(" ")
        if len(words) < 2:
            return []
        unit = words[-1]
    return [q for q in ("pressure", "angle", "time", "stress", "load", "extension") if split_unit(q, unit)[0]
            and _clean_unit(unit) not in ("", "-", "1", "m", "in")]


def _is_number(s: Any) -> bool:
    if isinstance(s, bool):
        return False
    if isinstance(s, (int, float, np.number)):
        return True
    try:
        float(str(s).strip().replace(",", "."))
        return True
    except ValueError:
        return False


def unit_hint(q: str, header: str | None = None) -> str:
    """The ways to state the unit of quantity ``q`` (for messages)."""
    ex = EXAMPLE_UNIT.get(q, "unit")
    col = header or q
    ways = [f"in the header ({BPMID_NAME.get(q, q).split('_')[0]}_{ex.lower()} or '{col} ({ex})')",
            f"a units row under the header ({ex})"]
    if q in UNIT_FLAGS:
        ways.append(f"the flag {UNIT_FLAGS[q]} {ex} (config: io.units: {{{q}: {ex}}})")
    else:
        ways.append(f"the config (io.units: {{{q}: {ex}}}) or a line '# {q}_unit: {ex}'")
    return "; ".join(f"({i + 1}) {w}" for i, w in enumerate(ways))


# ---------------------------------------------------------------------------------------------------------
# raw grids: text, Excel, MATLAB
# ---------------------------------------------------------------------------------------------------------
def _decode(data: bytes, where: str) -> tuple[str, str]:
    """Bytes -> text and the encoding used (BOM, UTF-16 without BOM, UTF-8, else cp1252/Latin-1)."""
    if data.startswith(b"\xef\xbb\xbf"):
        enc = "utf-8-sig"
    elif data.startswith((b"\xff\xfe\x00\x00", b"\x00\x00\xfe\xff")):   # before UTF-16: its BOM starts alike
        enc = "utf-32"
    elif data.startswith((b"\xff\xfe", b"\xfe\xff")):
        enc = "utf-16"
    else:
        head = data[:4000]
        even, odd = head[0::2], head[1::2]
        if len(head) >= 4 and odd.count(0) > 0.4 * len(odd) and even.count(0) < 0.1 * len(even):
            enc = "utf-16-le"
        elif len(head) >= 4 and even.count(0) > 0.4 * len(even) and odd.count(0) < 0.1 * len(odd):
            enc = "utf-16-be"
        else:
            enc = None
    if enc is not None:
        try:
            return data.decode(enc), enc.replace("-sig", " with BOM")
        except UnicodeDecodeError:
            raise InputError(f"not a readable text table: it starts like {enc} but does not decode as such",
                             path=where) from None
    if b"\x00" in data:
        raise InputError("not a text table (binary data): bpmid reads CSV/TSV/text, Excel (.xlsx, .xls) and MATLAB "
                         "(.mat) files; export the log as one of those", path=where)
    try:
        return data.decode("utf-8"), "utf-8"
    except UnicodeDecodeError:
        pass
    try:
        return data.decode("cp1252"), "cp1252"
    except UnicodeDecodeError:
        return data.decode("latin-1"), "latin-1"


def _split_ws_header(line: str, width: int) -> list[str]:
    """A whitespace table's header: split on its spaces (``_split_ws``), or, when that does not give the rows'
    ``width`` fields and runs of two or more spaces do, on those ('Elapsed Time (s)   Pressure (bar a)')."""
    fields = _split_ws(line)
    if len(fields) != width:
        wide = [c for c in re.split(r"\s{2,}|\t", line.strip()) if c]
        if len(wide) == width:
            return wide
    return fields


def _pandas_index(header: str, rows: list[list[str]]) -> bool:
    """Whether a whitespace table's rows start with an unnamed index (pandas' ``to_string``): the header line starts
    with blanks, every row has one field more than the header has names (split on spaces, or on runs of two or
    more), and the first field counts 0, 1, 2, ... (or from 1)."""
    if not rows or len({len(r) for r in rows}) != 1 or not header[:1].isspace():
        return False   # pandas writes the index's name as blanks: its header line starts with spaces
    n = len(rows[0])
    names = {len(_split_ws(header)), len([c for c in re.split(r"\s{2,}|\t", header.strip()) if c])}
    if n - 1 not in names or n < 3:
        return False
    first = [r[0] for r in rows]
    if not all(re.fullmatch(r"\d+", x) for x in first):
        return False
    start = int(first[0])
    return start in (0, 1) and [int(x) for x in first] == list(range(start, start + len(first)))


def _split_ws(line: str) -> list[str]:
    toks = line.split()
    out: list[str] = []
    for tok in toks:  # 'Time (s)' written with spaces: a unit in brackets belongs to the name before it
        if out and tok[:1] in "([{" and not _is_number(tok):
            out[-1] += " " + tok
        else:
            out.append(tok)
    return out


def _choose_delimiter(header: str, sample: Sequence[str]) -> str | None:
    """The separator of a text table: the header's most frequent of tab ; , | (None: whitespace)."""
    counts = {d: header.count(d) for d in ("\t", ";", ",", "|")}
    best = max(counts, key=lambda d: counts[d])
    if counts[best] == 0:
        return None
    if sample and best in (",", "|"):
        # 'Time, s;Pressure, kPa': a unit after a comma inside the names (and decimal commas in the rows): a tab
        # or ';' that every row repeats as often as the header, and that splits the header into such names
        for d in ("\t", ";"):
            names = [c.strip().strip('"') for c in header.split(d) if c.strip()]
            if counts[d] and len(names) >= 2 and all(r.count(d) == counts[d] for r in sample) \
                    and any(_unit_part(c)[1] is not None and _COMMA_UNIT.match(c) for c in names):
                return d
    if best == "," and counts[";"] == 0 and counts["\t"] == 0:
        return ","
    # a tie ("a;b,c"): prefer the one the data rows repeat as often as the header
    tied = [d for d in ("\t", ";", ",", "|") if counts[d] == counts[best]]
    if len(tied) > 1 and sample:
        for d in tied:
            if all(s.count(d) == counts[d] for s in sample):
                return d
    return tied[0]


def _is_comment(line: str) -> bool:
    s = line.lstrip()
    return s.startswith("#") or s.startswith("%") or s.startswith("//")


def _meta_from_line(body: str, meta: dict, lines: dict | None = None, line: int | None = None) -> None:
    m = _META.match(body)
    if m:
        key = meta_key(m.group(1))
        if key.endswith("_units") and key[:-6] in UNITS:
            key = key[:-1]   # 'Pressure Units: psi' states the unit as 'pressure_unit' does
        meta[key] = m.group(2).strip()
        if lines is not None and line is not None:
            lines[key] = line


_LVM_END = re.compile(r"^\s*\*\*\*End_of_Header\*\*\*", re.IGNORECASE)


def _labview_header(lines: list[str], where: str, meta: dict, meta_lines: dict,
                    channels: dict | None = None) -> tuple[int, str | None]:
    """A LabVIEW measurement file (``.lvm``): its file header and its segment header (``key<sep>value`` lines,
    each ending at ``***End_of_Header***``) read as metadata. Returns (index of the line after them, the file's
    separator), or (0, None) when ``lines`` are no LabVIEW measurement file. ``channels`` receives the lines
    with one value per channel (y_unit_label, x0, delta_x: lists)."""
    first = next((ln.strip().lstrip("\ufeff") for ln in lines if ln.strip()), "")
    if not first.lower().startswith("labview measurement"):
        return 0, None
    ends = [k for k, ln in enumerate(lines) if _LVM_END.match(ln)]
    if not ends:
        raise InputError("a LabVIEW measurement file without its '***End_of_Header***' line: export it again",
                         path=where)
    if len(ends) > 2:
        raise InputError(f"a LabVIEW measurement file with {len(ends) - 1} segments, each with its own header: "
                         "export one segment per file (or one header only)", path=where, line=ends[2] + 1)
    sep = "," if any(re.match(r"^\s*Separator[\t,]\s*Comma", ln, re.IGNORECASE) for ln in lines[:ends[0]]) \
        else "\t"
    for k in range(ends[-1]):
        cells = [c.strip() for c in lines[k].split(sep)]
        if len(cells) >= 2 and cells[1] and re.match(r"^[A-Za-z][\w ]*$", cells[0]):
            _meta_from_line(f"{cells[0]}: {cells[1]}", meta, meta_lines, k + 1)
            if channels is not None and cells[0].lower() in ("y_unit_label", "delta_x", "x0"):   # per channel
                vals = list(cells[1:])
                while vals and not vals[-1]:   # only the trailing empties: a channel without a unit keeps its place
                    vals.pop()
                channels[cells[0].lower()] = vals
    return ends[-1] + 1, sep


def _labview_columns(header: list[str], body: list, meta: dict, sep: str, ch: dict) -> tuple[list[str], list]:
    """A LabVIEW file's channel units (Y_Unit_Label) written into its column names ('Pressure' over 'bar' reads
    as 'Pressure (bar)'), and, without an x column (X_Columns No), its time made from X0 + k Delta_X."""
    has_x = bool(header) and header[0].lower() in ("x_value", "time (s)")
    units = list(ch.get("y_unit_label") or [])
    named = []
    for k, h in enumerate(header):   # the channels' units in order, skipping every x column (X_Columns Multi)
        if (k == 0 and has_x) or h.lower() in ("x_value", "comment") or not h:
            named.append(h)
            continue
        u = units.pop(0) if units else ""
        named.append(f"{h} ({u})" if u and _unit_part(h)[1] is None else h)
    header = named
    if not has_x and meta.get("x_columns", "").lower() == "no" and ch.get("delta_x"):
        try:
            x0, dx = float((ch.get("x0") or ["0"])[0].replace(",", ".")), float(ch["delta_x"][0].replace(",", "."))
        except ValueError:
            return header, body
        if meta.get("x_dimension", "time").lower().startswith("time") and dx > 0:
            header = ["time (s)"] + header
            comma = meta.get("decimal_separator", ".").strip() == ","   # the time written as the file writes numbers
            body = [(ln, f"{repr(x0 + k * dx).replace('.', ',') if comma else repr(x0 + k * dx)}{sep}{text}")
                    for k, (ln, text) in enumerate(body)]
    return header, body


def _text_grid(data: bytes, where: str, map_keys: frozenset | set = frozenset()) -> Grid:
    body_bytes = data.rstrip(b"\x00")
    nul_tail = len(data) - len(body_bytes)
    if nul_tail and b"\x00" not in body_bytes:
        data = body_bytes   # a logger that lost power leaves its file padded with NUL bytes: the text before them
    else:
        nul_tail = 0
    text, enc = _decode(data, where)
    lines = re.split(r"\r\n|\r|\n", text)
    meta: dict[str, str] = {}
    meta_lines: dict[str, int] = {}
    lvm_channels: dict[str, list[str]] = {}
    i, delim_hint = _labview_header(lines, where, meta, meta_lines, lvm_channels)
    labview = i > 0
    last_comment = None
    while i < len(lines):
        s = lines[i].strip().lstrip("\ufeff")
        if not s:
            i += 1
            continue
        m = _SEP_LINE.match(s)
        if m:
            delim_hint = m.group(1)
            i += 1
            continue
        if _is_comment(s):
            _meta_from_line(s.lstrip("#%/ ").strip(), meta, meta_lines, i + 1)
            last_comment = i
            i += 1
            continue
        h = _find_header(lines, i, delim_hint, map_keys=map_keys)
        if h > i:
            # title or 'key: value' lines above the header (instrument exports): metadata
            table_delim = delim_hint if delim_hint is not None else _choose_delimiter(
                lines[h], [ln for ln in lines[h + 1:h + 4] if ln.strip()])
            for k, ln in enumerate(lines[i:h], start=i + 1):
                t = ln.strip()
                if not t or _EMPTY_ROW.match(t):
                    continue
                if _is_comment(t):   # a "# key: value" line among the metadata lines: read as at the top
                    _meta_from_line(t.lstrip("#%/ ").strip(), meta, meta_lines, k)
                    continue
                pair = [c.strip() for c in _fields(t, table_delim) if c.strip()] if table_delim else []
                if _META.match(t):
                    _meta_from_line(t, meta, meta_lines, k)
                elif len(pair) == 2 and _META_KEY.match(pair[0]):
                    # 'Pressure Reference;Gauge': a key and its value in two cells of the table's separator
                    _meta_from_line(f"{pair[0]}: {pair[1]}", meta, meta_lines, k)
                elif len(pair) == 3 and _META_KEY.match(pair[0]) and _is_number(pair[1].replace(",", ".")) \
                        and _is_unit(pair[2]):
                    # 'Ambient pressure,98.2,kPa': a key, its value and the value's unit
                    _meta_from_line(f"{pair[0]}: {pair[1]} {pair[2]}", meta, meta_lines, k)
                else:
                    meta.setdefault("title", t)
            i = h
        break
    if i >= len(lines):
        raise InputError("empty log: no header row (expected column names such as time_s)", path=where)
    header_line = i + 1
    header_text = lines[i].lstrip("\ufeff")
    first_body = i + 1
    if last_comment is not None and all(not lines[k].strip() for k in range(last_comment + 1, i)):
        # numpy's savetxt: '# time_s pressure_kpa angle_deg' right above the numbers is the header
        named = lines[last_comment].strip().lstrip("#%/").strip()
        d0 = delim_hint if delim_hint is not None else _choose_delimiter(named, [header_text])
        cells, row = _fields(named, d0), _fields(header_text, d0)
        if all(_is_number(c) for c in row if c.strip()) and len(cells) == len(row) >= 2 and _known_names(cells) >= 2:
            header_line, header_text, first_body = last_comment + 1, named, i
    body = [(k + 1, ln) for k, ln in enumerate(lines[first_body:], start=first_body)
            if ln.strip() and not _is_comment(ln) and not _EMPTY_ROW.match(ln)]
    delim = delim_hint if delim_hint is not None else _choose_delimiter(header_text, [ln for _, ln in body[:5]])
    if delim is None:
        split = _split_ws
        info_delim = "whitespace"
    else:
        def split(line: str, _d=delim) -> list[str]:
            if '"' not in line:
                return line.split(_d)
            try:
                return next(csv.reader([line], delimiter=_d))
            except (csv.Error, StopIteration):
                return line.split(_d)
        info_delim = {"\t": "tab", ",": "comma", ";": "semicolon", "|": "pipe"}.get(delim, repr(delim))
    index_col = delim is None and _pandas_index(header_text, [split(ln) for _, ln in body[:50]])
    if index_col:   # pandas' to_string: an unnamed index column before the named ones
        width_ws = len(split(body[0][1])) - 1
        single = _split_ws(header_text)
        header_cells = single if len(single) == width_ws else [c for c in re.split(r"\s{2,}|\t", header_text.strip())
                                                                 if c]
        split = (lambda line, _s=split: _s(line)[1:])
    else:
        header_cells = split(header_text) if delim is not None or not body else \
            _split_ws_header(header_text, len(split(body[0][1])))
    header = [h.strip().strip('"').strip() for h in header_cells]
    width_rows = len(split(body[0][1])) if body else len(header)
    while len(header) > 1 and not header[-1] and len(header) > width_rows:
        header.pop()   # 'time_s,pressure_kpa,angle_deg,' over rows of three: a separator at the end of the header
    if labview:
        # LabVIEW's x column is the time when its X_Dimension says so (in s); its 'Comment' column is often left
        # off the rows
        if header and header[0].lower() == "x_value" and meta.get("x_dimension", "").lower().startswith("time"):
            header[0] = "time (s)"
        if header and header[-1].lower() == "comment" and body and len(split(body[0][1])) == len(header) - 1:
            header = header[:-1]
        header, body = _labview_columns(header, body, meta, delim or "\t", lvm_channels)
    nxt = next(((k + 1, ln) for k, ln in enumerate(lines[i + 1:], start=i + 1) if ln.strip()), None)
    if nxt is not None and nxt[1].lstrip().startswith("%") and (not body or body[0][0] > nxt[0]):
        cells = [c.strip() for c in split(nxt[1])]
        if len(cells) == len(header) and _units_row(cells):
            body.insert(0, nxt)   # a units row under the header that starts with '%' (strain in %): not a comment
    if not any(header):
        raise InputError("the header row is empty", path=where, line=header_line)
    if all(_is_number(h) for h in header if h):
        raise InputError("the log has no header row (expected column names such as time_s, pressure_kpa, "
                         "angle_deg): add a first line naming the columns with their units, in the file's own "
                         "separator (time_s,pressure_kpa,angle_deg); --columns maps names, not positions",
                         path=where, line=header_line)
    rows: list[list[str]] = []
    row_lines: list[int] = []
    for ln_no, ln in body:
        cells = [c.strip() for c in split(ln)]
        if len(cells) > len(header) and not any(cells[len(header):]):
            cells = cells[:len(header)]   # a separator at the end of each row
        if len(cells) != len(header):
            hint = ""
            if delim == "," and any(_COMMA_NUM.match(f"{a},{b}") for a, b in zip(cells, cells[1:])):
                hint = ("; a decimal comma in a comma-separated file? Export with a point as the decimal "
                        "separator, or separate the columns with ';'")
            elif len(cells) > len(header):
                hint = "; a decimal comma or a separator inside a cell? Quote such cells or export again"
            raise InputError(f"row has {len(cells)} fields, the header has {len(header)}{hint}", path=where,
                             line=ln_no)
        rows.append(cells)
        row_lines.append(ln_no)
    unit_row = unit_row_line = None
    info_rows: list = []
    rows, row_lines = _drop_name_rows(rows, row_lines, info_rows)
    if rows and not any(_is_number(c) for c in rows[0] if c) and any(rows[0]) and not _looks_like_time(rows[0]) \
            and not _numbers_with_units(rows[0]):
        unit_row, unit_row_line = rows[0], row_lines[0]
        rows, row_lines = rows[1:], row_lines[1:]
    # decimal separator: a comma only where the columns are not comma-separated, and never mixed with points
    decimal = "."
    grouped_cols: list[str] = []
    if delim != "," and any("," in ln for _, ln in body):
        first_comma = next(((r, c) for r, row in enumerate(rows) for c in row
                            if _COMMA_NUM.match(c) or _GROUPED_COMMA.match(c)), None)
        if first_comma is not None:
            decimal = ","
            dot = next(((r, c, j) for r, row in enumerate(rows) for j, c in enumerate(row)
                        if "." in c and _DOT_NUM.match(c)), None)
            if dot is not None:
                hint = "export the log with one decimal separator"
                if _THOUSANDS.match(dot[1]):   # '18.775' among decimal commas: a thousands separator, or a decimal?
                    hint = (f"if the point in {dot[1]!r} is a thousands separator ({dot[1].replace('.', '')}), export "
                            f"the log without thousands separators (in Excel: Format Cells > Number, untick 'Use "
                            f"1000 Separator'), or with every value's decimals written out ({dot[1]},0); if it is a "
                            f"decimal point, export the log with one decimal separator")
                raise InputError(f"mixed decimal separators: {first_comma[1]!r} (line {row_lines[first_comma[0]]}) "
                                 f"and {dot[1]!r}; {hint}", path=where, line=row_lines[dot[0]],
                                 key=header[dot[2]] if dot[2] < len(header) else None)
            # '18.775,0': a point between groups of three digits before a decimal comma is a thousands separator
            # (18775.0), read so when every cell of its column that holds a point is written so
            rows, grouped_cols = _thousands_with_decimal_comma(header, rows, row_lines, where)
            # only the cells that are numbers with a decimal comma: any other cell is quoted as written when refused
            rows = [[c.replace(",", ".") if _COMMA_NUM.match(c.strip()) else c for c in row] for row in rows]
    cols = [list(c) for c in zip(*rows)] if rows else [[] for _ in header]
    if delim != "," and decimal == ".":
        _refuse_thousands_points(header, cols, row_lines, where)
    info = {"format": "text", "encoding": enc, "delimiter": info_delim, "decimal": "comma" if decimal == "," else
            "point"}
    if grouped_cols:
        info["thousands_separator"] = f"point, before a decimal comma ({', '.join(repr(h) for h in grouped_cols)})"
    if info_rows:
        info["name_rows_skipped"] = info_rows
    if index_col:
        info["index_column"] = "an unnamed first column counting the rows (pandas' index): not read"
    if nul_tail:
        info["nul_bytes_at_end"] = nul_tail
    return Grid(header, unit_row, cols, row_lines, meta, where, header_line, info, meta_lines, unit_row_line)


#: a whole number written with points between groups of three digits (German, Swiss: 1.008 for 1008)
_THOUSANDS = re.compile(r"^[-+]?[1-9]\d{0,2}(?:\.\d{3})+$")
_WHOLE = re.compile(r"^[-+]?\d+$")
#: a number with a point between groups of three digits and a decimal comma (German, Swiss: 18.775,0 for 18775.0)
_GROUPED_COMMA = re.compile(r"^[-+]?[1-9]\d{0,2}(?:\.\d{3})+,\d+$")
#: the English form: commas between groups of three digits, then a decimal point (18,775.0)
_THOUSANDS_DOT_DECIMAL = re.compile(r"^[-+]?[1-9]\d{0,2}(?:,\d{3})+\.\d+$")


def _thousands_with_decimal_comma(header: list[str], rows: list[list[str]], row_lines: list[int],
                                  where: str) -> tuple[list[list[str]], list[str]]:
    """Read the thousands separators of a file with decimal commas: a column whose every cell with a point in it is
    written ``18.775,0`` (points between groups of three digits, then a decimal comma) has its points dropped
    (``18775,0``, then read with its decimal comma); the point can be nothing else there. A column that holds such a
    cell and another with a point written otherwise (``18.75,0``, ``18.775``) is refused, naming both. Returns the
    rows and the headers of the columns so read."""
    width = max((len(r) for r in rows), default=0)
    grouped: list[int] = []
    for j in range(width):
        cells = [(r, row[j].strip()) for r, row in enumerate(rows) if j < len(row)]
        first = next(((r, c) for r, c in cells if _GROUPED_COMMA.match(c)), None)
        if first is None:
            continue
        other = next(((r, c) for r, c in cells if "." in c and not _GROUPED_COMMA.match(c)), None)
        name = header[j] if j < len(header) else f"column {j + 1}"
        if other is not None:
            raise InputError(f"column {name!r}: {first[1]!r} (line {row_lines[first[0]]}) reads as a point between "
                             f"thousands and a decimal comma ({first[1].replace('.', '').replace(',', '.')}), but "
                             f"{other[1]!r} is written otherwise and bpmid does not guess; export the log without "
                             f"thousands separators (in Excel: Format Cells > Number, untick 'Use 1000 Separator')",
                             path=where, line=row_lines[other[0]], key=name)
        grouped.append(j)
    if not grouped:
        return rows, []
    out = [[c.replace(".", "") if j in grouped and _GROUPED_COMMA.match(c.strip()) else c
            for j, c in enumerate(row)] for row in rows]
    return out, [header[j] if j < len(header) else f"column {j + 1}" for j in grouped]


def _refuse_thousands_points(header: list[str], cols: list[list], row_lines: list[int], where: str) -> None:
    """Refuse a column of whole numbers some of which carry a point before exactly three digits (``991`` above
    ``1.008``) in a file not separated by commas: the point is a thousands separator there as often as a decimal
    point, a factor of 1000 apart, and bpmid does not guess. A column with any other decimal (``1.5``) or with every
    whole number written with decimals (``991.000``) is a decimal column and read as such."""
    for j, col in enumerate(cols):
        cells = [str(c).strip() for c in col if str(c).strip()]
        grouped = next((k for k, c in enumerate(col) if _THOUSANDS.match(str(c).strip())), None)
        if grouped is None or not any(_WHOLE.match(c) for c in cells):
            continue
        if all(_WHOLE.match(c) or _THOUSANDS.match(c) for c in cells):
            whole = next(c for c in cells if _WHOLE.match(c))
            g = str(col[grouped]).strip()
            name = header[j] if j < len(header) else f"column {j + 1}"
            raise InputError(f"column {name!r} holds whole numbers ({whole!r}) and {g!r}: is the point a thousands "
                             f"separator ({g.replace('.', '')}) or a decimal point ({g})? They are 1000 times apart "
                             f"and bpmid does not guess; export the log without thousands separators (or with every "
                             f"value's decimals written out)", path=where,
                             line=row_lines[grouped] if grouped < len(row_lines) else None, key=name)


def _fields(line: str, delim: str | None) -> list[str]:
    if delim is None:
        return _split_ws(line)
    try:
        return next(csv.reader([line], delimiter=delim))
    except (csv.Error, StopIteration):
        return line.split(delim)


def _find_header(lines: list[str], start: int, delim_hint: str | None, look: int = 200,
                 map_keys: frozenset | set = frozenset()) -> int:
    """The header's index: the first line (from ``start``, within ``look`` lines) whose next lines have its number
    of fields, at least two, with a number among them, and whose next line holds a number, is a units row, or names
    fewer quantities bpmid knows than it does (a description or channel row under a header; a key and its value
    padded to the table's width, 'Operator,J. Doe,', above the header names none, and the line below it, the
    header or another such row, as many or more). ``start`` when none does (its errors are then reported)."""
    cand = [k for k in range(start, min(len(lines), start + look)) if lines[k].strip() and not _is_comment(lines[k])
            and not _EMPTY_ROW.match(lines[k])]
    for n, k in enumerate(cand):
        nxt = [lines[j] for j in cand[n + 1:n + 4]]
        if not nxt:
            break
        delim = delim_hint if delim_hint is not None else _choose_delimiter(lines[k], nxt)
        if delim is None and (_META.match(lines[k].strip()) or _rows_delimited(nxt)):
            # a line split on its spaces ('Operator: John Smith', 'Pressure Reference: Gauge') above lines that
            # share a tab, ';' or '|': a 'key: value' line, never the header of a table split otherwise
            continue
        head = _fields(lines[k], delim)
        if delim is None and nxt:
            head = _split_ws_header(lines[k], len(_split_ws(nxt[0])))
        width = len(head)
        if width < 2 or any(_is_number(c) for c in head if c.strip()) or _looks_like_time(head):
            continue  # a header names its columns: no numbers, no timestamps
        filled = [c for c in head if c.strip()]
        if len(filled) <= 2 and len(filled) < width and not _known_names(filled) \
                and not _names_mapped(filled, map_keys):
            continue  # 'Operator,J. Doe,': a key and its value padded to the table's width
        if not _known_names(head) and not _names_mapped(head, map_keys) and any(
                _known_names(_fields(lines[j], delim_hint if delim_hint is not None else _choose_delimiter(lines[j], [])))
                >= 2 for j in cand[n + 1:n + 40]):
            continue  # 'Sample ID,S-03' above 'Time,Extension,Load': metadata rows, the header is further down
        rows = [_fields(ln, delim) for ln in nxt]
        if all(len(r) == width for r in rows) and any(_is_number(c) for r in rows for c in r if c.strip()) \
                and (any(_is_number(c) for c in rows[0] if c.strip()) or _units_row(rows[0])
                     or _known_names(rows[0]) < _known_names(head) or _units_stated(head) >= 1
                     or _names_mapped(head, map_keys)):
            return k
    return start


def _names_mapped(cells, map_keys) -> bool:
    """Whether a row names a column the user's column map names (the map's keys, folded): then it is the header."""
    return bool(map_keys) and any(c is not None and str(c).strip() and (
        _norm(str(c)) in map_keys or _norm(_unit_part(str(c))[0]) in map_keys) for c in cells)


def _drop_name_rows(rows: list, lines: list, skipped: list) -> tuple[list, list]:
    """Rows right under the header that name quantities again, with no unit anywhere (a second language, variable
    names, a description: 'Zeit;Druck;Winkel', 'elapsed time, chamber pressure, ...'): not a units row, skipped
    (their lines in ``skipped``). A row with a unit in it (a units row, or 'Zeit;Druck (bar);Winkel') is never
    skipped: it is read as the units row and checked against the header."""
    while rows and not any(_is_number(c) for c in rows[0] if str(c).strip()) \
            and not _looks_like_time([str(c) for c in rows[0]]) \
            and not any(_is_unit(str(c)) for c in rows[0] if c is not None and str(c).strip()) \
            and not _units_stated([str(c) for c in rows[0] if c is not None]) \
            and _known_names([str(c) for c in rows[0] if c is not None]) >= 1:
        skipped.append(lines[0])
        rows, lines = rows[1:], lines[1:]
    return rows, lines


def _units_stated(cells: Sequence[str]) -> int:
    """How many of ``cells`` state a unit beside a quantity's name (``Time (s)``, ``pressure_kpa``)."""
    parsed = [_parse(str(c)) for c in cells if str(c).strip()]
    return sum(1 for q, unit, _ref, _derived in parsed if q is not None and unit)


def _known_names(cells: Sequence[str]) -> int:
    """How many of ``cells`` name a quantity bpmid knows (``Time (s)``, ``pressure_kpa``, ``Winkel``): a header's
    row names more of them than a key and its value above it, a description or channel row under it fewer."""
    return sum(1 for c in cells if str(c).strip() and _parse(str(c))[0] is not None)


#: units of a raw transducer signal, not of any quantity bpmid reads ('Pressure (V)')
_SIGNAL_UNITS = {"v", "mv", "ma", "counts", "cts", "digits", "lsb", "adc", "raw", "volt", "volts", "bits"}

#: pressure units bpmid does not read (lower case) -> Pa per unit, for the message that says how to convert them:
#: relabelling such a column as kPa without converting its numbers would give a wrong pressure
_UNREAD_PRESSURE_UNITS = {"inh2o": 249.08891, "inwc": 249.08891, "in h2o": 249.08891, "cmh2o": 98.0665,
                          "mmh2o": 9.80665, "mh2o": 9806.65, "torr": 133.322368, "mmhg": 133.322368,
                          "inhg": 3386.389, "atm": 101325.0, "kgf/cm2": 98066.5, "kgf/cm²": 98066.5,
                          "kg/cm2": 98066.5, "kg/cm²": 98066.5, "ksi": 6894757.293168, "n/m2": 1.0, "n/m²": 1.0,
                          "mpsi": 6.894757293168, "fth2o": 2989.06692, "n/mm2": 1e6, "n/mm²": 1e6,
                          "n/cm2": 1e4, "n/cm²": 1e4}


def _unread_pressure_unit(unit: str) -> str | None:
    """The key of :data:`_UNREAD_PRESSURE_UNITS` a stated unit spells (``mm Hg``, ``in. H2O``, ``kgf/cm^2``,
    ``Torr abs``, ``mmHg g``), or None."""
    u = re.sub(r"[\s.^]", "", str(unit).lower())
    if u in _UNREAD_PRESSURE_UNITS:
        return u
    for ref in ("absolute", "gauge", "gage", "abs", "rel", "a", "g"):
        if u.endswith(ref) and u[:-len(ref)] in _UNREAD_PRESSURE_UNITS:
            return u[:-len(ref)]
    return None

#: a line of separators only (a spreadsheet's empty row: ',,', ';;'): a blank line
_EMPTY_ROW = re.compile(r"^[\s,;|]*$")

#: unit spellings of a units row besides those of :data:`UNITS` (channels a log keeps beside its own)
_OTHER_UNITS = {"v", "mv", "ma", "a", "hz", "%", "-", "1", "n", "w", "rpm", "l/min", "slpm", "sccm"}


def _is_unit(c: str) -> bool:
    """Whether a cell is a unit spelling (of a quantity bpmid reads, a temperature or a common channel)."""
    u = _clean_unit(c)
    return (u in _OTHER_UNITS or _norm(u).replace(" ", "") in TEMPERATURE_UNITS
            or any(split_unit(q, c)[0] is not None for q in UNITS))


def _numbers_with_units(cells: Sequence) -> bool:
    """Whether most filled cells of a row start with a number ('0.00 s', '1.1998 bar'): data with a unit written in
    each cell, not a units row (refused then as numbers, with that said)."""
    filled = [str(c).strip() for c in cells if str(c).strip()]
    return bool(filled) and sum(bool(re.match(r"^[+-]?(?:\d+\.?\d*|\.\d+)", c)) for c in filled) * 2 > len(filled)


def _units_row(cells: Sequence[str]) -> bool:
    """Whether a row under a candidate header reads as units: at least half its filled cells a unit spelling."""
    filled = [c for c in cells if str(c).strip()]
    if _numbers_with_units(filled):
        return False   # '0.00 s', '1.1998 bar': numbers with a unit in each cell, data, not a units row
    return bool(filled) and sum(_is_unit(c) for c in filled) * 2 >= len(filled)


def _rows_delimited(rows: Sequence[str]) -> bool:
    """Whether every one of ``rows`` holds the same tab, ';' or '|' (a comma is not asked: it may be a decimal
    comma in a table split on spaces)."""
    return bool(rows) and any(all(d in r for r in rows) for d in ("\t", ";", "|"))


def _looks_like_time(row: Sequence[str]) -> bool:
    return any(re.match(r"^\d{4}-\d{2}-\d{2}", str(c)) or _CLOCK.match(str(c)) for c in row)


def _sheet_grid(rows: list[list], where: str, info: dict, map_keys: frozenset | set = frozenset()) -> Grid:
    """A grid from spreadsheet rows (values: str, float, int, datetime, None); row numbers are 1-based."""
    meta: dict[str, str] = {}
    meta_lines: dict[str, int] = {}
    k = 0
    while k < len(rows):
        vals = [v for v in rows[k] if v is not None and str(v).strip() != ""]
        if not vals:
            k += 1
            continue
        if len(vals) == 1 and isinstance(vals[0], str):
            # one text cell above the header: a comment, a 'key: value' line or a title (a log has two columns
            # at least, so it is never the header)
            body = vals[0].lstrip("#% ").strip()
            if _META.match(body):
                _meta_from_line(body, meta, meta_lines, k + 1)
            else:
                meta.setdefault("title", body)
            k += 1
            continue
        if all(isinstance(v, str) and _is_comment(v) for v in vals):
            k += 1
            continue
        if len(vals) == 2 and isinstance(vals[0], str) and _META_KEY.match(vals[0].strip()):
            # a key and its value in two cells ('Pressure Reference' | 'Gauge') among such rows above a header of
            # more columns (a two-column log's header is followed by two-cell rows only)
            counts = (sum(1 for v in r if v is not None and str(v).strip() != "") for r in rows[k + 1:])
            wider = next((c for c in counts if c not in (0, 1, 2)), 0)
            if wider > 2:
                _meta_from_line(f"{vals[0].strip()}: {str(vals[1]).strip()}", meta, meta_lines, k + 1)
                k += 1
                continue
        if len(vals) == 3 and isinstance(vals[0], str) and _META_KEY.match(vals[0].strip()) \
                and _is_number(vals[1]) and isinstance(vals[2], str) and _is_unit(vals[2]):
            # 'Ambient pressure' | 98.2 | 'kPa': a key, its value and the value's unit
            _meta_from_line(f"{vals[0].strip()}: {vals[1]} {vals[2].strip()}", meta, meta_lines, k + 1)
            k += 1
            continue
        if _known_names([str(v) for v in vals]) == 0 and not _names_mapped(vals, map_keys):
            # a row of several cells that names no quantity (nor a column the user mapped), some rows above one that
            # names two or more
            # ('Test' | 'Run 3' | '2024-05-01' over 'Time (s)' | 'Pressure (kPa)' | ...): metadata, not the header
            if any(_known_names([str(v) for v in r if v is not None]) >= 2 for r in rows[k + 1:k + 12]):
                if isinstance(vals[0], str) and _META_KEY.match(vals[0].strip()):
                    rest = " ".join(str(v).strip() for v in vals[1:])
                    _meta_from_line(f"{vals[0].strip()}: {rest}", meta, meta_lines, k + 1)
                else:
                    meta.setdefault("title", " ".join(str(v).strip() for v in vals))
                k += 1
                continue
        break
    if k >= len(rows):
        raise InputError("empty sheet: no header row", path=where)
    hdr = list(rows[k])
    while hdr and (hdr[-1] is None or str(hdr[-1]).strip() == ""):
        hdr.pop()
    header = ["" if h is None else str(h).strip() for h in hdr]
    header_line = k + 1
    if all(_is_number(h) for h in hdr if h is not None and str(h).strip()):
        raise InputError("the sheet has no header row (expected column names such as time_s)", path=where,
                         line=header_line)
    width = len(header)
    data, lines = [], []
    for r in range(k + 1, len(rows)):
        row = list(rows[r])
        if all(v is None or str(v).strip() == "" for v in row):
            continue
        if isinstance(row[0], str) and _is_comment(row[0]) and all(v is None for v in row[1:]):
            continue
        extra = [v for v in row[width:] if v is not None and str(v).strip() != ""]
        if extra:
            raise InputError(f"row has a value beyond the header's {width} columns ({extra[0]!r})", path=where,
                             line=r + 1)
        row = (row + [None] * width)[:width]
        data.append(["" if v is None else (v.strip() if isinstance(v, str) else v) for v in row])
        lines.append(r + 1)
    unit_row = unit_row_line = None
    info_rows: list = []
    data, lines = _drop_name_rows(data, lines, info_rows)
    if info_rows:
        info["name_rows_skipped"] = info_rows
    if data and all(isinstance(v, str) for v in data[0]) and not any(_is_number(v) for v in data[0] if v) \
            and any(data[0]) and not _looks_like_time(data[0]) and not _numbers_with_units(data[0]):
        unit_row, unit_row_line = [str(v) for v in data[0]], lines[0]
        data, lines = data[1:], lines[1:]
    cols = [list(c) for c in zip(*data)] if data else [[] for _ in header]
    return Grid(header, unit_row, cols, lines, meta, where, header_line, info, meta_lines, unit_row_line)


def _xlsx_sheets(path: Path, data: bytes) -> dict[str, list[list]]:
    try:
        import openpyxl
    except ImportError:
        raise InputError("reading .xlsx needs openpyxl (a bpmid dependency): pip install openpyxl",
                         path=path) from None
    try:
        wb = openpyxl.load_workbook(io.BytesIO(data), read_only=True, data_only=True)
        try:
            return {ws.title: [list(r) for r in ws.iter_rows(values_only=True)] for ws in wb.worksheets}
        finally:
            wb.close()
    except InputError:
        raise
    except Exception as exc:  # a broken zip or workbook: the library's words, as bad input
        raise InputError(f"not a readable Excel workbook ({type(exc).__name__}: {exc})", path=path) from None


def _xls_sheets(path: Path, data: bytes) -> dict[str, list[list]]:
    try:
        import xlrd
    except ImportError:
        raise InputError("reading legacy .xls needs xlrd (a bpmid dependency): pip install xlrd",
                         path=path) from None
    try:
        book = xlrd.open_workbook(file_contents=data)
        out = {}
        for sh in book.sheets():
            rows = []
            for r in range(sh.nrows):
                row = []
                for c in range(sh.ncols):
                    cell = sh.cell(r, c)
                    if cell.ctype == xlrd.XL_CELL_DATE:
                        row.append(xlrd.xldate.xldate_as_datetime(cell.value, book.datemode))
                    elif cell.ctype in (xlrd.XL_CELL_EMPTY, xlrd.XL_CELL_BLANK):
                        row.append(None)
                    elif cell.ctype == xlrd.XL_CELL_ERROR:
                        row.append("#ERROR")
                    else:
                        row.append(cell.value)
                rows.append(row)
            out[sh.name] = rows
        return out
    except InputError:
        raise
    except Exception as exc:
        raise InputError(f"not a readable .xls workbook ({type(exc).__name__}: {exc})", path=path) from None


def _mat_vectors(path: Path, data: bytes, kind: str) -> tuple[dict[str, np.ndarray], dict[str, str], str]:
    """Numeric vectors (name -> 1-D array) and char variables (metadata) of a MATLAB file."""
    vectors: dict[str, np.ndarray] = {}
    meta: dict[str, str] = {}

    def add(name: str, val) -> None:
        if isinstance(val, str):
            meta[meta_key(name)] = val.strip()
            return
        if isinstance(val, dict):
            for k, v in val.items():
                add(f"{name}.{k}", v)
            return
        arr = np.asarray(val)
        if arr.dtype.kind in "U S":
            if arr.size == 1:
                meta[meta_key(name)] = str(arr.reshape(-1)[0]).strip()
            return
        if arr.dtype.kind not in "fiub" or arr.size < 1:
            return
        arr = np.squeeze(arr)
        if arr.ndim == 1:
            vectors[name] = arr.astype(float)
        elif arr.ndim == 2:
            n = max(arr.shape)
            if arr.shape[0] != n:
                arr = arr.T
            for j in range(arr.shape[1]):
                vectors[f"{name}(:,{j + 1})"] = arr[:, j].astype(float)

    if data[512:520] == _MAGIC_HDF5 or data.startswith(_MAGIC_HDF5):
        try:
            import h5py
        except ImportError:
            raise InputError("reading MATLAB v7.3 files needs h5py: pip install 'bpmid[formats]' (or pip install "
                             "h5py)", path=path) from None
        try:
            with h5py.File(io.BytesIO(data), "r") as f:
                def visit(name, obj):
                    if not isinstance(obj, h5py.Dataset) or name.startswith("#"):
                        return
                    cls = obj.attrs.get("MATLAB_class", b"")
                    cls = cls.decode() if isinstance(cls, bytes) else str(cls)
                    val = obj[()]
                    if cls == "char":
                        add(name.replace("/", "."), "".join(chr(int(c)) for c in np.ravel(val, order="F")))
                    elif np.ndim(val) >= 1:
                        add(name.replace("/", "."), np.asarray(val).T)
                f.visititems(visit)
        except InputError:
            raise
        except Exception as exc:
            raise InputError(f"not a readable MATLAB v7.3 (HDF5) file ({type(exc).__name__}: {exc})",
                             path=path) from None
        return vectors, meta, "matlab v7.3 (HDF5, h5py)"
    try:
        import scipy.io
    except ImportError:  # pragma: no cover - scipy is a core dependency
        raise InputError("reading .mat needs scipy", path=path) from None
    try:
        mat = scipy.io.loadmat(io.BytesIO(data), squeeze_me=True, simplify_cells=True)
    except Exception as exc:
        raise InputError(f"not a readable MATLAB file ({type(exc).__name__}: {exc})", path=path) from None
    for k, v in mat.items():
        if not k.startswith("__"):
            add(k, v)
    return vectors, meta, "matlab v5 (scipy.io)"


def _mat_grid(path: Path, data: bytes, kind: str) -> Grid:
    vectors, meta, fmt = _mat_vectors(path, data, kind)
    if not vectors:
        raise InputError(f"no numeric vectors in this MATLAB file (a {kind} needs time, pressure, ... as "
                         f"variables; MATLAB table or timeseries objects cannot be read: save plain vectors, e.g. "
                         f"s = table2struct(T, 'ToScalar', true); save('log.mat', '-struct', 's'))", path=path)
    header = list(vectors)
    cols = [list(v) for v in vectors.values()]
    n = max(len(c) for c in cols)
    return Grid(header, None, cols, list(range(1, n + 1)), meta, str(path), 0,
                {"format": fmt, "rows": "sample numbers (1-based) stand for lines in messages"})


def _file_kind(path: Path, data: bytes) -> str:
    """By the bytes first, the extension second: a workbook saved as .csv is read as one, and a text table saved as
    .xls (as LabVIEW and many loggers write TSV) as text; an HTML table saved as .xls is refused, saying so."""
    suffix = path.suffix.lower()
    if data.startswith(_MAGIC_XLSX) and (suffix not in (".csv", ".txt", ".tsv", ".dat")
                                         or b"[Content_Types].xml" in data[:4096] or b"xl/" in data[:4096]):
        return "xlsx"
    if data.startswith(_MAGIC_OLE):
        return "xls"
    if suffix in (".xls", ".xlsx", ".xlsm"):
        head = data[:2048].lstrip(b"\xef\xbb\xbf \t\r\n").lower()
        if head.startswith((b"<html", b"<!doctype html", b"<table", b"<?xml")) or b"<table" in head:
            raise InputError(f"an HTML or XML table saved with the extension {suffix}, not an Excel workbook: open it "
                             "in Excel (or LibreOffice) and save it as .xlsx or CSV, then read that", path=path)
        if b"\x00" not in data[:4096] or data.startswith((b"\xff\xfe", b"\xfe\xff")):
            return "text"   # a text table named as a workbook (UTF-16 with its BOM too)
    if data.startswith(b"MATLAB") or data[512:520] == _MAGIC_HDF5 or data.startswith(_MAGIC_HDF5):
        return "mat"
    if suffix == ".mat":
        return "mat"
    if suffix in (".xlsx", ".xlsm"):
        return "xlsx"
    if suffix == ".xls":
        return "xls"
    return "text"


# ---------------------------------------------------------------------------------------------------------
# columns
# ---------------------------------------------------------------------------------------------------------
def _column_map(column_map: Mapping[str, str] | None) -> dict[str, tuple[str, str]]:
    """file header (folded) -> (the key as written, bpmid name)."""
    return {_norm(k): (str(k), str(v)) for k, v in (column_map or {}).items()}


def _map_key_of(h: str, cmap: Mapping[str, tuple[str, str]], exact: set) -> str | None:
    """The column-map key (folded) that names header ``h``: the header itself, or its name without the unit
    written beside it (``Dehnung`` names ``Dehnung [-]``, as the header parser reads the name and the unit) when no
    header of the file is that name exactly."""
    k = _norm(h)
    if k in cmap:
        return k
    raw, unit = _unit_part(h)
    if unit is not None:
        base = _norm(raw)
        if base in cmap and base not in exact:
            return base
    return None


def _map_note(grid: Grid, cmap: Mapping[str, tuple[str, str]], used: set) -> str:
    """Column-map entries that match no column of the file, for the messages of a missing or unreadable column;
    entries whose value is a column of the file and whose key a bpmid name look reversed, and are said so."""
    unmatched = [k for k in cmap if k not in used]
    if not unmatched:
        return ""
    exact = {_norm(h) for h in grid.header if h}

    def is_column(v: str) -> bool:
        return _norm(v) in exact or any(_unit_part(h)[1] is not None and _norm(_unit_part(h)[0]) == _norm(v)
                                        for h in grid.header if h)

    def bpmid_like(k: str) -> bool:
        words = _norm(k).split(" ")
        return _parse(k)[0] is not None or words[0] in ALIASES or words[0] in BPMID_NAME

    # a key that is no column but one of the file's names nearly ('angle_imu' for 'angle_imu_deg'): the map's
    # direction is right (its value a bpmid name), the column misnamed; never said to look reversed then
    near = {k: like for k in unmatched if (like := _like_column(cmap[k][0], grid.header, exclude=cmap[k][1]))
            and _parse(cmap[k][1])[0] is not None}
    rev = [cmap[k] for k in unmatched if k not in near and is_column(cmap[k][1]) and bpmid_like(cmap[k][0])]
    other = [cmap[k][0] for k in unmatched if cmap[k] not in rev and k not in near]
    note = ""
    for k, like in near.items():
        key, value = cmap[k]
        note += (f"; the column map names {key!r}, not a column of this file, which has {like!r}: to take that column "
                 f"as {value}, {columns_arg(f'{value}={like}')} (config io.columns: {{'{like}': {value}}}); "
                 f"--columns takes bpmid's name, then the file's column")
    if rev:
        pairs = ", ".join(f"{k}: {v}" for k, v in rev)
        right = ", ".join(f"{v}: {k}" for k, v in rev)
        flag = columns_arg(",".join(f"{k}={v}" for k, v in rev))
        note += (f"; the column map's entries {{{pairs}}} match no column, but their values are columns of this "
                 f"file: the map looks reversed. io.columns maps file column -> quantity (io.columns: {{{right}}}), "
                 f"the opposite of --columns, which takes quantity=column ({flag})")
    if other:
        note += f"; the column map names {', '.join(repr(k) for k in other)}, not a column of this file"
    return note


def _like_column(name: str, header: Sequence[str], exclude: str | None = None) -> str | None:
    """The file's column that ``name`` nearly names, or None: the column's name without the unit written after it
    (``angle_imu`` for ``angle_imu_deg`` or ``Angle IMU (deg)``), a name it starts ('angle_imu' for
    'angle_imu_2'), or one spelled almost alike; never ``exclude`` (folded) nor ``name`` itself."""
    import difflib

    n = _norm(name)
    skip = {n} | ({_norm(exclude)} if exclude is not None else set())
    cands = [h for h in header if h and _norm(h) not in skip]
    for h in cands:
        raw, unit = _unit_part(h)
        words = _norm(raw).split(" ")
        if unit is not None and _norm(raw) == n:
            return h
        if len(words) > 1 and " ".join(words[:-1]) == n and any(split_unit(q, words[-1])[0] for q in UNITS):
            return h
    starts = [h for h in cands if _norm(h).startswith(n + " ")]
    if len(starts) == 1:
        return starts[0]
    close = difflib.get_close_matches(n, [_norm(h) for h in cands], n=1, cutoff=0.85)
    return next((h for h in cands if close and _norm(h) == close[0]), None)


def _resolve(grid: Grid, cmap: dict[str, tuple[str, str]], units: Mapping[str, str], unit_sources: Mapping[str, str],
             wanted: Sequence[str]) -> tuple[dict, list, list]:
    """quantity -> list of (column index, unit, header, unit_from, reference); derived and unknown columns."""
    found: dict[str, list] = {}
    ignored, unknown = [], []
    used_keys = set()
    mapped_js: set[int] = set()
    exact = {_norm(h) for h in grid.header if h}
    for j, h in enumerate(grid.header):
        if not h:
            continue
        ur = grid.unit_row[j] if grid.unit_row is not None and j < len(grid.unit_row) else None
        key = _map_key_of(h, cmap, exact)
        mapped = cmap[key][1] if key is not None else None
        if mapped is not None:
            used_keys.add(key)
            q, unit, ref, derived = _parse(mapped, None)
            if q is None:
                raise InputError(f"the column map sends {h!r} to {mapped!r}, which is no bpmid column (known: "
                                 f"{', '.join(sorted(set(ALIASES.values())))}, optionally with a unit: time_s, "
                                 f"pressure_kpa)", path=grid.where, key=h)
            if unit is None:
                _raw, unit_h = _unit_part(h)
                words = _norm(_raw).split(" ")
                if unit_h is None and len(words) > 1 and split_unit(q, words[-1])[0] is not None:
                    unit_h = words[-1]  # tilt_deg mapped to angle: the unit is the name's suffix
                if unit_h is None and ur:
                    unit_h = ur
                if unit_h is not None:
                    unit, ref = _unit_ref(q, unit_h)
                    unit_from = "header" if ur is None or _unit_part(h)[1] is not None else "units row"
                else:
                    unit_from = None
            else:
                unit_from = "column map"
                _raw, named = _unit_part(h)
                unit_h = named if named is not None else (ur or None)
                hu, href = _unit_ref(q, unit_h) if unit_h is not None else (None, None)
                if hu is not None and hu in UNITS[q] and (UNITS[q][hu] != UNITS[q].get(unit)
                                                           or (ref is not None and href is not None and ref != href)):
                    said = "its name says" if named is not None else "the units row under it says"
                    raise InputError(f"the column map sends {h!r} to {mapped!r}, but {said} {unit_h}: a unit stated "
                                     f"twice must agree; map it to {q} alone (the file's unit is read) or correct the "
                                     f"map", path=grid.where, line=grid.header_line or None, key=h)
                if ref is None and href is not None and hu is not None:
                    ref = href   # 'Pressure (kPa g)' mapped to pressure_kpa: the name's reference still holds
        else:
            q, unit, ref, derived = _parse(h, ur)
            if q is None:
                (ignored if derived else unknown).append(h)
                continue
            unit_from = None if unit is None else ("header" if _parse(h, None)[1] is not None else "units row")
        if mapped is not None and q == "pressure" and ref is None:
            # a reference the mapped column's name states still holds (a map that states one corrects the name)
            ref = _parse(h, None)[2] if _parse(h, None)[0] == "pressure" else None
        found.setdefault(q, []).append([j, unit, h, unit_from, ref])
        if mapped is not None:
            mapped_js.add(j)
    # a raw signal beside the calibrated column of the same quantity ('Pressure (V)' beside 'Pressure (kPa)'): set
    # aside; alone, it is refused with what to do (_unknown_unit_hint)
    for q, ents in found.items():
        raw_sig = [e for e in ents if e[1] in _SIGNAL_UNITS and e[0] not in mapped_js]
        if raw_sig and len(raw_sig) < len(ents):
            ignored.extend(e[2] for e in raw_sig)
            found[q] = [e for e in ents if e not in raw_sig]
    # a quantity the user mapped a column to is that column: others bpmid would take by their names are set aside
    for q, ents in found.items():
        if any(e[0] in mapped_js for e in ents) and not all(e[0] in mapped_js for e in ents):
            ignored.extend(e[2] for e in ents if e[0] not in mapped_js)
            found[q] = [e for e in ents if e[0] in mapped_js]
    grid.info["mapped_quantities"] = sorted({q for q, ents in found.items() if any(e[0] in mapped_js for e in ents)})
    # map entries for columns this file does not have are fine (one map serves files with different headers);
    # they are named when a needed column is then missing
    grid.info["unmatched_map"] = [cmap[k][0] for k in cmap if k not in used_keys]
    grid.info["map_note"] = _map_note(grid, cmap, used_keys)
    return found, ignored, unknown


def _to_24h(m) -> str:
    """'12:59:50.000 PM' -> '12:59:50.000'; '12:05 AM' -> '00:05'."""
    hh, mm, ss, frac, ap = m.groups()
    h = int(hh) % 12 + (12 if ap.lower() == "p" else 0)
    return f"{h:02d}:{mm}" + (f":{ss}" if ss else "") + (f".{frac}" if frac else "")


def _ymd_iso(m) -> str:
    """'2025/03/01 10:00:00.5' -> '2025-03-01T10:00:00.5' (a 12-hour time after it made 24-hour)."""
    y, mo, d, rest = m.groups()
    rest = (rest or "").strip()
    if rest and _CLOCK_12.match(rest):
        rest = _to_24h(_CLOCK_12.match(rest))
    return f"{y}-{int(mo):02d}-{int(d):02d}" + (f"T{rest}" if rest else "")


def _parse_times(values: list, where: str, header: str, lines: list[int]) -> tuple[np.ndarray, str]:
    """ISO-8601 strings or datetimes -> seconds since the first, and the first as ISO text."""
    import datetime as _dt

    import pandas as pd

    if values and all(isinstance(v, _dt.timedelta) for v in values):  # Excel durations ('[h]:mm:ss.000' cells)
        secs = np.array([v.total_seconds() for v in values], dtype=float)
        return secs - secs[0], f"elapsed time {values[0]} (an Excel duration)"
    texts = []
    for v in values:
        if isinstance(v, (_dt.datetime, _dt.time)):
            texts.append(v.isoformat())
        else:
            texts.append(str(v).strip())
    if texts and all(_CLOCK_12.match(x) for x in texts):   # 12-hour clock times: to 24-hour ones
        texts = [_to_24h(_CLOCK_12.match(x)) for x in texts]
    if texts and all(_YMD_SLASH.match(x) for x in texts):   # 2025/03/01 10:00:00: year first, read as ISO
        texts = [_ymd_iso(_YMD_SLASH.match(x)) for x in texts]
    if texts and all(_MMSS.match(x) for x in texts):  # elapsed minutes:seconds.f (Excel's mm:ss.0)
        parts = [_MMSS.match(x) for x in texts]
        secs = np.array([60.0 * float(m.group(1)) + float(m.group(2).replace(",", ".")) for m in parts])
        return secs - secs[0], f"elapsed time {texts[0]} (minutes:seconds)"
    if texts and all(_CLOCK.match(x) for x in texts):  # clock times of one day: 09:30:01.250
        td = pd.to_timedelta(pd.Series([x.replace(",", ".") for x in texts]), errors="coerce")
        bad = np.flatnonzero(td.isna().to_numpy())
        if bad.size:
            k = int(bad[0])
            raise InputError(f"column {header!r}: {texts[k]!r} is not a clock time (hh:mm:ss.fff)", path=where,
                             line=lines[k] if k < len(lines) else None)
        secs = td.dt.total_seconds().to_numpy(dtype=float)
        # a clock that passes midnight starts the day again: a step back of more than half a day is the next day
        secs = secs + 86400.0 * np.concatenate([[0], np.cumsum(np.diff(secs) < -43200.0)])
        return secs - secs[0], f"clock time {texts[0]}"
    shown = list(texts)   # quoted as written in messages
    if texts and _SLASH_DATE.match(texts[0]):
        raise InputError(f"column {header!r}: {texts[0]!r} is a date with slashes, day-first in some locales and "
                         f"month-first in others, and bpmid does not guess which; export the time as elapsed seconds "
                         f"(time_s) or as ISO 8601 (2025-04-03T12:59:40.0)", path=where,
                         line=lines[0] if lines else None)
    if texts and all(_DOTTED_DATE.match(x) for x in texts):   # day.month.year: read as ISO 8601
        texts = []
        for x in shown:
            d, mo, y, hh, mm, ss, frac = _DOTTED_DATE.match(x).groups()
            texts.append(f"{y}-{int(mo):02d}-{int(d):02d}T{int(hh):02d}:{mm}:{ss or '00'}"
                         + (f".{frac}" if frac else ""))
    try:
        if texts and all(_MATLAB_DATE.match(x) for x in texts):
            fmt = "%d-%b-%Y %H:%M:%S.%f" if "." in texts[0] else ("%d-%b-%Y %H:%M:%S" if ":" in texts[0] else
                                                                   "%d-%b-%Y")
            ts = pd.to_datetime(pd.Series(texts), format=fmt, utc=True, errors="coerce")
        else:
            ts = pd.to_datetime(pd.Series(texts), format="ISO8601", utc=True, errors="coerce")
    except (ValueError, TypeError):
        ts = pd.to_datetime(pd.Series(texts), utc=True, errors="coerce")
    bad = np.flatnonzero(ts.isna().to_numpy())
    if bad.size:
        k = int(bad[0])
        raise InputError(f"column {header!r}: {shown[k]!r} is neither a number nor a date and time bpmid reads "
                         f"(ISO 8601, 2024-05-01T12:00:00.125, or day.month.year 01.05.2024 12:00:00,125)",
                         path=where, line=lines[k] if k < len(lines) else None)
    secs = (ts - ts.iloc[0]).dt.total_seconds().to_numpy(dtype=float)
    return secs, ts.iloc[0].isoformat()


def _numbers(values: list, where: str, header: str, lines: list[int], excel: bool = False) -> np.ndarray:
    if not any(type(v) is bool for v in values):  # Excel TRUE/FALSE cells are not numbers
        # the fast path: every cell a number (numpy parses the strings); NaN, inf, empty: the loop below names the line
        try:
            out = np.array(values, dtype=float)
            if out.ndim == 1 and np.all(np.isfinite(out)):
                return out
        except (ValueError, TypeError, OverflowError):
            pass
    out = np.empty(len(values))
    for r, v in enumerate(values):
        if isinstance(v, bool) or v is None:
            v = "" if v is None else str(v)
        if isinstance(v, (int, float, np.number)):
            x = float(v)
        else:
            cell = str(v).strip()
            try:
                x = float(cell)
            except ValueError:
                what = "an empty cell" if not cell else f"{cell!r} is not a number"
                if _GROUPED_COMMA.match(cell) or _THOUSANDS_DOT_DECIMAL.match(cell):
                    # '18.775,0' (German) or '18,775.0' (English): a thousands separator beside the decimal one
                    what += ("; a thousands separator beside the decimal separator"
                             + (": format the column's cells as numbers in the spreadsheet" if excel else
                                ": export the log without thousands separators (in Excel: Format Cells > Number, "
                                "untick 'Use 1000 Separator')"
                                + (", or separate the columns with ';'" if _GROUPED_COMMA.match(cell) else "")))
                elif _COMMA_NUM.match(cell) and excel:
                    what += ("; a number stored as text with a decimal comma: format the column's cells as numbers "
                             "in the spreadsheet (or export it as a ';'-separated text file)")
                elif _COMMA_NUM.match(cell):
                    what += ("; a decimal comma in a comma-separated file (the cell is quoted)? Export with a point "
                             "as the decimal separator, or separate the columns with ';'")
                elif cell.lstrip("\ufeff").strip('"') == str(header).strip().strip('"'):
                    what += ("; the header again: two logs joined into one file? Split the file where the header "
                             "repeats, one log per file")
                else:
                    num = re.match(r"^\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(\S+)\s*$", cell)
                    if num:   # '1.1998 bar', '0.00 s': a unit written in every cell
                        what += (f"; a unit written in each cell ({num.group(2)!r} after the number): export the "
                                 "numbers alone, with the unit in the header (e.g. 'Pressure (bar)')")
                raise InputError(f"column {header!r}: {what}", path=where,
                                 line=lines[r] if r < len(lines) else None) from None
        if not np.isfinite(x):
            raise InputError(f"column {header!r}: {v!r} (NaN or infinite values are not allowed)", path=where,
                             line=lines[r] if r < len(lines) else None)
        out[r] = x
    return out


def read_table(path: str | Path, *, column_map: Mapping[str, str] | None = None,
               required: tuple[str, ...] = (), optional: tuple[str, ...] = (), kind: str = "log",
               units: Mapping[str, str] | None = None, unit_sources: Mapping[str, str] | None = None,
               sheet: str | None = None) -> Table:
    """Read a log (text, Excel or MATLAB) into a :class:`Table`.

    Parameters
    ----------
    path : the file
    column_map : file header (or MATLAB variable) -> bpmid name (``{"Zeit": "time_s"}``, ``{"Druck": "pressure"}``)
    required : quantities that must be present (checked here so the message names them)
    optional : quantities the caller uses when present (an unknown column whose unit says it could be one of
        these is refused rather than ignored: ``tilt_deg`` when there is no angle column)
    kind : words for messages ("relaxation log", "motion log")
    units : quantity -> unit for columns whose name states none (flags or config ``io.units``)
    unit_sources : quantity -> where ``units`` came from, for messages (``--pressure-unit``)
    sheet : Excel sheet name (default: the one sheet with the required columns)
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("file not found", path=path)
    note_input(path)  # the command that reads it must not replace it (bpmid.io.atomic)
    try:
        size = path.stat().st_size
        if size > _MAX_BYTES:
            raise InputError(f"file of {size / 2 ** 30:.1f} GiB is larger than bpmid reads (1 GiB)", path=path)
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read the file ({exc.strerror or exc})", path=path) from None
    if not data.strip():
        raise InputError(f"empty {kind}: the file has no content", path=path)
    if data.startswith(_MAGIC_GZIP):
        raise InputError("a gzip-compressed file, not a table: decompress it first (gunzip, or 7-Zip on Windows) "
                         "and give bpmid the file inside", path=path)
    fkind = _file_kind(path, data)
    units = {str(k): str(v) for k, v in (units or {}).items()}
    unit_sources = dict(unit_sources or {})
    cmap = _column_map(column_map)
    if fkind in ("xlsx", "xls"):
        sheets = _xlsx_sheets(path, data) if fkind == "xlsx" else _xls_sheets(path, data)
        info = {"format": "excel .xlsx (openpyxl)" if fkind == "xlsx" else "excel .xls (xlrd)"}
        if sheet is not None:
            if sheet not in sheets:
                raise InputError(f"no sheet {sheet!r} (sheets: {', '.join(repr(s) for s in sheets)})", path=path,
                                 key="--sheet")
            names = [sheet]
        else:
            names = list(sheets)
        candidates, errors = [], []
        for name in names:
            where = f"{path}[{name}]"
            try:
                grid = _sheet_grid(sheets[name], where, dict(info, sheet=name), set(cmap))
                table = _build(path, grid, cmap, units, unit_sources, required, optional, kind)
            except InputError as exc:
                if len(names) == 1:
                    raise
                errors.append((name, exc))
                continue
            candidates.append(table)
        if not candidates:
            detail = "; ".join(f"{n!r}: {e.message}" for n, e in errors)
            raise InputError(f"no sheet holds a {kind} ({detail}); name the sheet with --sheet NAME", path=path)
        if len(candidates) > 1:
            names_txt = ", ".join(repr(t.reading["sheet"]) for t in candidates)
            raise InputError(f"several sheets hold a {kind} ({names_txt}); "
                             f"choose one with --sheet NAME (config io.sheet)", path=path, key="--sheet")
        return candidates[0]
    # a sheet name means nothing for a text or MATLAB file: not an error (one --sheet serves a batch of files)
    if fkind == "mat":
        return _build(path, _mat_grid(path, data, kind), cmap, units, unit_sources, required, optional, kind)
    try:
        grid = _text_grid(data, str(path), set(cmap))
        return _build(path, grid, cmap, units, unit_sources, required, optional, kind)
    except InputError as exc:
        if exc.line is not None and exc.line == _unended_last_line(data):
            # a file copied while the logger was still writing it: say so, not only what the last row lacks
            exc.message += ("; this is the file's last line and it has no line end: the file looks cut off "
                            "(copied or read while it was still being written); take a complete copy, or delete "
                            "that line")
            exc.args = (exc.format(),)
        raise


def _unended_last_line(data: bytes) -> int | None:
    """The (1-based) number of a text file's last line when no line end follows it, else None."""
    try:
        text, _ = _decode(data.rstrip(b"\x00"), "")
    except InputError:
        return None
    if not text.strip() or text.endswith(("\n", "\r")):
        return None
    return len(re.split(r"\r\n|\r|\n", text))


def _build(path: Path, grid: Grid, cmap, units, unit_sources, required, optional, kind) -> Table:
    where = grid.where
    hline = grid.header_line or None
    found, ignored, unknown = _resolve(grid, cmap, units, unit_sources, tuple(required) + tuple(optional))
    meta = dict(grid.meta)
    wanted = tuple(required) + tuple(q for q in optional if q not in required)
    # a column that could be a wanted quantity by its unit but whose name bpmid does not know: refuse, never ignore
    for q in wanted:
        if q in found:
            continue
        cands = [h for h in unknown if q in _unit_quantities(h)]
        if cands:
            h = cands[0]
            note = grid.info.get("map_note", "")
            own = split_unit(q, _unit_part(h)[1] or "")[0]   # the name bpmid would give it, in its own unit
            words = _norm(_unit_part(h)[0]).split(" ")
            for cut in (2, 1):   # a unit in the name's last words ('t_ms', 'zeit ms'): never offer seconds for it
                if own is None and len(words) >= cut:
                    own = split_unit(q, " ".join(words[-cut:]))[0]
            rename = _column_name(q, own) if own else BPMID_NAME[q]
            article = "an" if q[0] in "aeiou" else "a"
            if len(cands) > 1:   # say every candidate: the user picks the muscle's
                note = f"; {', '.join(repr(c) for c in cands[1:])} also {'has' if len(cands) == 2 else 'have'} " \
                       f"{article} {q} unit: map the one that is the muscle's" + note
            raise InputError(f"missing column for {q}: no name bpmid knows, but {h!r} has {article} {q} unit: map it "
                             f"with {columns_arg(f'{q}={h}')} (config io.columns: {{'{h}': {q}}}), or rename it "
                             f"{rename}{note}", path=where, line=hline, key=h)
    missing = [q for q in required if q not in found]
    if missing:
        cols = ", ".join(repr(h) for h in grid.header)
        q = missing[0]
        note = grid.info.get("map_note", "")
        raise InputError(f"missing column for {q} (found columns: {cols}); name it {BPMID_NAME[q]} or map it with "
                         f"--columns {q}=<your column> (config io.columns){note}", path=where, line=hline, key=q)
    _refuse_millipascal(grid, found, units, unit_sources, meta)
    lines = list(grid.lines)
    n_rows = max((len(grid.cols[e[0]]) for ents in found.values() for e in ents), default=0)
    if grid.info.get("format", "").startswith("matlab"):
        lens = {e[2]: len(grid.cols[e[0]]) for ents in found.values() for e in ents}
        if len(set(lens.values())) > 1:
            desc = ", ".join(f"{h} ({n})" for h, n in lens.items())
            raise InputError(f"the variables bpmid uses differ in length: {desc}; map the right ones with --columns",
                             path=where)
    if n_rows == 0 and found:
        raise InputError(f"empty {kind}: a header but no data rows", path=where, line=hline)
    # the ambient pressure matters only to an absolute pressure: a column of it that cannot be read is set aside
    # here, and its error raised by the reader that needs it (bpmid.io.ambient.ambient_pressure)
    deferred: dict[str, InputError] = {}
    pre_warns = _set_aside_bare_t(found, ignored, where)
    unstated = [(q, ents[0][2]) for q, ents in found.items()
                if ents[0][1] is None and q not in units and f"{q}_unit" not in meta and q not in ("strain", "ambient")
                and not (q == "time" and _time_is_text(grid.cols[ents[0][0]]))]
    if len(unstated) > 1:  # say every missing unit at once, not one per run
        cols_txt = ", ".join(f"{h!r} ({q})" for q, h in unstated)
        flags = " ".join(f"{UNIT_FLAGS[q]} {EXAMPLE_UNIT[q]}" for q, _h in unstated if q in UNIT_FLAGS)
        raise InputError(f"the units of the columns {cols_txt} are stated nowhere and bpmid never guesses one; state "
                         f"them (1) in the header ({', '.join(BPMID_NAME[q] for q, _h in unstated)} or "
                         f"'{unstated[0][1]} ({EXAMPLE_UNIT[unstated[0][0]]})'), (2) in a units row under the header, "
                         f"or (3) with the flags {flags or '(none)'} (config io.units){grid.info.get('map_note', '')}",
                         path=where, line=hline, key=unstated[0][1])
    columns, units_in_file, headers, refs, col_info = {}, {}, {}, {}, {}
    for q, ents in found.items():
        if q == "ambient":
            try:
                _one_quantity(grid, q, ents, units, unit_sources, meta, lines, ignored, columns, units_in_file,
                              headers, refs, col_info)
            except InputError as err:
                deferred[q] = err
                ignored.extend(e[2] for e in ents)
            continue
        _one_quantity(grid, q, ents, units, unit_sources, meta, lines, ignored, columns, units_in_file, headers,
                      refs, col_info)
    rival_warns = _check_rivals(grid, columns, headers, units_in_file, unknown, ignored, lines)
    unnamed = _unnamed_numbers(grid, n_rows)
    if unnamed:
        ignored.extend(h for h, _ in unnamed)
        pre_warns = pre_warns + [f"{where}: {h} has no name in the header but holds numbers{u}; it was not read: give "
                                 "it a name in the header (a merged or blank header cell?), and if it is the muscle's "
                                 "pressure or angle, one that says so (pressure_bar, angle_deg) or map that name with "
                                 "--columns" for h, u in unnamed]
    first = lines[0] if lines else (grid.header_line + 1)
    reading = {k: v for k, v in grid.info.items() if k not in ("map_note", "mapped_quantities", "date_warning")
               and (k != "unmatched_map" or v)}
    reading["columns"] = col_info
    if ignored or unknown:
        reading["ignored_columns"] = list(ignored) + list(unknown)
    if grid.info.get("date_warning"):
        pre_warns = pre_warns + [grid.info.pop("date_warning")]
    if "looks reversed" in grid.info.get("map_note", ""):   # said on a good read too, not only in errors
        note = grid.info["map_note"].lstrip("; ").split("; the column map names")[0]
        pre_warns = pre_warns + [f"{where}: {note}; the map was not applied"]
    for note in grid.info.get("map_note", "").split("; the column map names ")[1:]:
        if "not a column of this file, which has" in note:   # a key that nearly names a column: said too
            pre_warns = pre_warns + [f"{where}: the column map names {note}; that entry was not applied"]
    warns = pre_warns + rival_warns + ([f"the file ends in {grid.info['nul_bytes_at_end']} NUL bytes (a logger that lost power?): "
                            f"read the rows before them; check that its last row (line {lines[n_rows - 1]}) is "
                            f"complete"] if grid.info.get("nul_bytes_at_end") and n_rows else [])
    set_aside = set(ignored) | set(unknown)
    cells = {h: (list(grid.cols[j][:n_rows]), (_unit_part(h)[1] or (grid.unit_row[j].strip() if grid.unit_row
                                                                    and j < len(grid.unit_row) else "") or None))
             for j, h in enumerate(grid.header) if h in set_aside and j < len(grid.cols)}
    table = Table(path, columns, units_in_file, headers, meta, first, np.asarray(lines[:n_rows], int), refs,
                  reading, warns, where, grid.info.get("map_note", ""), dict(grid.meta_lines or {}), deferred, cells)
    return table


def cell_numbers(cells) -> np.ndarray:
    """The cells that read as numbers (a decimal comma too), in order; the others left out (a column set aside
    is looked at, never refused for its text)."""
    vals = []
    for c in cells:
        try:
            vals.append(float(str(c).strip().replace(",", ".")))
        except ValueError:
            continue
    return np.asarray(vals, float)


def _unnamed_numbers(grid: Grid, n_rows: int) -> list[tuple[str, str]]:
    """Columns with an empty header cell whose rows hold numbers (most of them), as ('column N', ' (units row:
    X)'): set aside, they must not go unsaid (a merged header cell over the muscle's pressure). A row index
    (0..n-1 or 1..n, as pandas writes it) is not one."""
    out = []
    for j, h in enumerate(grid.header):
        if h or j >= len(grid.cols):
            continue
        cells = list(grid.cols[j][:n_rows])
        v = cell_numbers(cells)
        if not cells or v.size < 0.5 * len(cells):
            continue
        if j == 0 and v.size == len(cells) and np.all(v == np.round(v)) and np.all(np.diff(v) > 0):
            # a row index in the first column (pandas writes one; after a filter or a decimation it no longer
            # runs 0..n-1): whole numbers, rising
            continue
        ur = grid.unit_row[j].strip() if grid.unit_row is not None and j < len(grid.unit_row) and \
            str(grid.unit_row[j]).strip() else ""
        out.append((f"column {j + 1}", f" (units row: {ur})" if ur else ""))
    return out


#: a date alone in a form read without guessing: ISO (2025-03-01), year first with slashes, day.month.year
_UNAMBIGUOUS_DATE = re.compile(r"^(?:\d{4}-\d{1,2}-\d{1,2}|\d{4}/\d{1,2}/\d{1,2}|\d{1,2}\.\d{1,2}\.\d{4}|\d{1,2}-[A-Za-z]{3}-\d{4})$")

#: header names of a column that gives the date beside a column of clock times
_DATE_NAMES = {"date", "datum", "day", "fecha", "date local", "local date"}


def _with_date_column(grid: Grid, j: int, vals: list) -> tuple[list, str | None]:
    """Clock times (column ``j``) beside a date column (``Date``, ``Datum``): the two joined ('2025-03-01
    10:00:00.050'), so that a log running past a day (or two) keeps its time; before, the date was set aside and a
    jump of days vanished. Other time columns as they are."""
    texts = [str(v).strip() for v in vals]
    if not texts or not all(_CLOCK.match(x) or _CLOCK_12.match(x) for x in texts):
        return vals, None
    for k, h in enumerate(grid.header):
        if k == j or not h or _norm(_unit_part(h)[0]) not in _DATE_NAMES or k >= len(grid.cols):
            continue
        dates = [str(c).strip().split(" ")[0].split("T")[0] for c in grid.cols[k][:len(texts)]]
        # only a date bpmid reads without guessing (ISO, year first with slashes, day.month.year); another form
        # (03/01/2025, 'Sat 01 Mar') is set aside as before: a date is never guessed
        if len(dates) == len(texts) and all(_UNAMBIGUOUS_DATE.match(d) for d in dates):
            clock = [_to_24h(_CLOCK_12.match(x)) if _CLOCK_12.match(x) else x for x in texts]
            return [f"{d} {x}" for d, x in zip(dates, clock)], h
        changes = [r for r in range(1, len(dates)) if dates[r] != dates[r - 1]]
        if changes and not all(d.isdigit() for d in dates):   # a date that changes but is not read: said (a
            # numeric day counter is no date form at all)
            r = changes[0]
            grid.info["date_warning"] = (
                f"{grid.where}: the column {h!r} changes from {dates[r - 1]!r} to {dates[r]!r} (line "
                f"{grid.lines[r] if r < len(grid.lines) else '?'}) but is written in a form bpmid does not read "
                "without guessing (day or month first?); the time is taken from the clock alone, so a jump of days "
                "is not seen: write the dates as ISO 8601 (2025-03-01)")
    return vals, None


def _set_aside_bare_t(found: dict, ignored: list, where) -> list[str]:
    """A bare upper-case ``T`` column beside another time column is set aside, not read as a second time: ``T`` is
    as often a temperature (material tests write it so), and the other column states the time. Returns the
    warning that says so (never in silence)."""
    ents = found.get("time") or []
    bare = [e for e in ents if str(e[2]).strip().strip('"') == "T" and e[1] is None]
    rest = [e for e in ents if e not in bare]
    if not bare or not rest:
        return []
    found["time"] = rest
    ignored.extend(e[2] for e in bare)
    return [f"{where}: took {rest[0][2]!r} as the time and set aside the column 'T' beside it (a temperature?); if "
            f"'T' is the time, take it with {columns_arg('time=T')} and state its unit"]


def _refuse_millipascal(grid: Grid, found: dict, units: Mapping[str, str], unit_sources: Mapping[str, str],
                        meta: Mapping[str, str]) -> None:
    """Refuse a column bpmid uses whose unit is written ``mPa`` (header, units row, flag or ``# q_unit:`` line):
    read without regard to case it would be the megapascal, 1e9 times the millipascal it says."""
    for q, ents in found.items():
        for j, _unit, h, *_ in ents:
            row = grid.unit_row[j] if grid.unit_row is not None and j < len(grid.unit_row) else None
            for text, line, key in ((h, grid.header_line or None, h), (row, grid.unit_row_line, h),
                                    (units.get(q), None, unit_sources.get(q, f"io.units.{q}")),
                                    (meta.get(f"{q}_unit"), grid.meta_lines.get(f"{q}_unit"), f"{q}_unit")):
                if (slip := millipascal_slip(text)) is not None:
                    raise InputError(f"the {q} column's unit: {slip}", path=grid.where, line=line, key=key)


#: the quantities a log may hold a second column of under another name ('Chamber pressure' beside 'Supply pressure')
_RIVAL_QUANTITIES = ("pressure", "angle")
#: the German word a compound name of the quantity ends with (Kammerdruck, Biegewinkel)
_GERMAN_WORD = {"pressure": "druck", "angle": "winkel"}
#: words that make a second column the muscle's own measurement ('Chamber pressure', 'Pressure sensor'): beside any
#: other column of the quantity, bpmid asks which to use; without them, bpmid's plain name is the log's
_MEASURED_WORDS = {"chamber", "muscle", "measured", "actual", "sensor", "internal", "inner", "bladder", "actuator",
                   "bpm", "ist", "kammer", "muskel", "gemessen", "real", "true"}
_MEASURED_PREFIXES = ("kammer", "muskel", "ist")
#: words that name another channel of the rig, never the muscle's own (a supply, a tank, a second segment)
_OTHER_CHANNEL_WORDS = {"line", "source", "dp", "diff", "differential", "orifice", "flow"}
_OTHER_CHANNEL_PREFIXES = ("supply", "tank", "vac", "pilot", "reservoir", "regulator", "inlet", "compressor",
                           "versorg", "vordruck", "seg", "tip", "base", "accumulator", "main", "upstream")
#: names that may be the ambient pressure or the supply: always asked
_AMBIGUOUS_AIR = re.compile(r"luftdruck|air[\s_]*pressure", re.IGNORECASE)
#: words of a name that are units or references, not qualifiers ('pressure kpa g')
_UNIT_WORDS = {"s", "ms", "pa", "kpa", "hpa", "mpa", "bar", "mbar", "psi", "psig", "psia", "barg", "bara", "deg",
               "rad", "g", "a", "abs", "gauge", "absolute", "degrees", "degree"}


def _one_quantity(grid: Grid, q: str, ents: list, units, unit_sources, meta, lines, ignored, columns,
                  units_in_file, headers, refs, col_info) -> None:
    """Read the column(s) of one quantity into ``columns`` (canonical unit) with its unit, header, reference and
    how it was read (several columns of it must agree)."""
    where = grid.where
    hline = grid.header_line or None
    arrays = []
    for ent in ents:
        j, unit, h, unit_from, ref = ent
        vals = grid.cols[j]
        stated = units.get(q)
        stated_u, stated_ref = (split_unit(q, stated) if stated is not None else (None, None))
        src = unit_sources.get(q, f"io.units.{q}")
        if stated is not None and stated_u is None:
            raise InputError(f"unknown unit {stated!r} for {q} (known: {', '.join(_known(q))})", key=src)
        meta_unit = meta.get(f"{q}_unit")
        if unit is not None and unit.startswith("conflict:"):
            u1, u2, said = unit[len("conflict:"):].split("|", 2)
            if said == "units row":
                row = grid.unit_row_line
                raise InputError(f"the name of column {h!r} says {u1} and the units row under the header "
                                 f"says {u2}; make them agree: correct the "
                                 f"units row, or if the values are in {u2}, rename the column "
                                 f"{_column_name(q, split_unit(q, u2)[0] or u2.lower())}", path=where,
                                 line=row or hline, key=h)
            _raw, written = _unit_part(h)
            part = f"its brackets say {u2}" if _PAREN.match(str(h).strip().strip('"').strip()) else \
                f"the unit written after the name says {written}"
            raise InputError(f"the name of column {h!r} says {u1} and {part}; make them agree", path=where,
                             line=hline, key=h)
        if unit is not None and unit not in UNITS[q] and split_unit(q, unit)[0] is None and unit_from == "column map":
            raise InputError(f"unknown unit {unit!r} for {q} (known: {', '.join(_known(q))})"
                             f"{_mapped_unit_hint(grid, q, h, unit)}", path=where, line=hline, key=h)
        if unit is not None and unit not in UNITS[q] and split_unit(q, unit)[0] is None:
            in_row = unit_from == "units row"
            raise InputError(f"unknown unit {unit!r} for {q} (known: {', '.join(_known(q))})"
                             f"{_unknown_unit_hint(q, h, unit, unit_from)}{grid.info.get('map_note', '')}",
                             path=where,
                             line=(grid.unit_row_line or hline) if in_row else hline, key=h)
        if unit is not None and stated_u is not None and stated_u != unit:
            raise InputError(f"the file says the unit of {h!r} is {unit}, {src} says {stated}; drop one or make "
                             f"them agree", path=where, line=hline, key=h)
        if meta_unit is not None and unit is not None and unit_from in ("header", "units row"):
            ref = _check_meta_unit(grid, q, h, unit, ref, unit_from, meta_unit)
        if unit is None and stated_u is not None and meta_unit is not None:
            # the file's '# <q>_unit:' line and a flag (or io.units) both state the unit: they must agree too
            mu, mref = split_unit(q, meta_unit)
            if mu is not None and (mu != stated_u or (mref is not None and stated_ref is not None
                                                      and mref != stated_ref)):
                raise InputError(f"the line '# {q}_unit: {meta_unit}' says {q} is in {meta_unit}, {src} says "
                                 f"{stated}; a unit stated twice must agree: drop {src} (the file states it) "
                                 f"or correct the line", path=where, line=grid.meta_lines.get(f"{q}_unit"),
                                 key=h)
        if unit is None and stated_u is not None:   # a reference the name states ('p_abs') stays
            if stated_ref is not None and ref is not None and stated_ref != ref:
                raise InputError(f"the name of column {h!r} says {ref}, {src} says {stated} ({stated_ref}); a "
                                 "reference stated twice must agree", path=where, line=hline, key=h)
            unit, ref, unit_from = stated_u, stated_ref if stated_ref is not None else ref, src
        if unit is None and meta_unit is not None:
            mu, mref = split_unit(q, meta_unit)
            if mu is None:
                raise InputError(f"unknown unit {meta_unit!r} for {q} (known: {', '.join(_known(q))})",
                                 path=where, key=f"{q}_unit")
            unit, ref, unit_from = mu, mref if mref is not None else ref, f"'# {q}_unit:' line"
        is_time_text = q == "time" and _time_is_text(vals)
        if unit is None and q == "strain":
            unit, unit_from = "1", "dimensionless by its name"
        if unit is None and is_time_text:
            unit, unit_from = "iso8601", "timestamps"
        if unit is None:
            own_q, own_u = _parse(h)[:2]
            if own_q is not None and own_q != q and own_u is not None and split_unit(own_q, own_u)[0] is not None:
                # a column map that takes another quantity's column ('angle=force_N'): its name states a unit, of
                # that quantity; never advise stating an angle unit for a force
                written = str(h)[-len(own_u):] if str(h).lower().endswith(own_u) else own_u
                raise InputError(f"column {h!r} is taken as {q} by the column map, but its name says {written}, a "
                                 f"unit of {own_q}, not of {q}: map {q} to the file's {q} column; if {h!r} really "
                                 f"holds the {q}, state its unit: {unit_hint(q, h)}"
                                 f"{grid.info.get('map_note', '')}", path=where, line=hline, key=h)
            what = "" if _norm(h) == q else f" ({q})"
            raise InputError(f"the unit of column {h!r}{what} is stated nowhere and bpmid never guesses one; "
                             f"state it: {unit_hint(q, h)}{grid.info.get('map_note', '')}", path=where,
                             line=hline, key=h)
        if is_time_text:
            vals, date_col = _with_date_column(grid, j, vals)
            arr, origin = _parse_times(vals, where, h if date_col is None else f"{date_col} + {h}", lines)
            col_info_extra = {"time_origin": origin, "timestamps": "ISO-8601 or clock times, seconds since the "
                                                                   "first"}
            if date_col is not None:
                col_info_extra["date_from"] = date_col
            unit = "iso8601"
        else:
            raw = _numbers(vals, where, h, lines, excel=grid.excel)
            with np.errstate(over="ignore"):
                arr = raw * UNITS[q][unit]
            bad = np.flatnonzero(~np.isfinite(arr))
            if bad.size:   # finite as written, beyond a float in SI (1e308 kPa): name the cell, not numpy
                k = int(bad[0])
                raise InputError(f"column {h!r}: {vals[k]!r} {unit} is too large to be {'an' if q[0] in 'aeiou' else 'a'} {q} "
                                 f"(beyond a float in SI units)", path=where, line=lines[k] if k < len(lines) else None, key=h)
            col_info_extra = {}
            if unit in EPOCH_UNITS:
                import datetime as _dt
                origin = _dt.datetime.fromtimestamp(float(arr[0]), _dt.timezone.utc).isoformat() \
                    if abs(arr[0]) < 1e11 else f"{arr[0]:.6f} s"
                arr = arr - arr[0]
                col_info_extra = {"time_origin": origin, "timestamps": f"epoch ({unit}), seconds since the first"}
        arrays.append((arr, unit, h, unit_from, ref, col_info_extra))
    if q == "pressure" and len(arrays) > 1:
        # one channel logged absolute and gauge ('Pressure abs (bar)' beside 'Pressure rel (bar)'): equal but for a
        # steady offset of about one atmosphere; the gauge one is read (it needs no ambient pressure)
        gauge = [a for a in arrays if a[4] == "gauge"]
        absol = [a for a in arrays if a[4] == "absolute"]
        if gauge and absol and gauge[0][0].shape == absol[0][0].shape and gauge[0][0].size:
            d = absol[0][0] - gauge[0][0]
            if 0.5e5 <= float(np.median(d)) <= 1.1e5 and float(np.ptp(d)) <= max(2e-3 * float(np.ptp(gauge[0][0])),
                                                                                 0.01 * float(np.median(d))):
                ignored.append(absol[0][2])
                arrays = [gauge[0]] + [a for a in arrays if a is not gauge[0] and a is not absol[0]]
    arr, unit, h, unit_from, ref, extra = arrays[0]
    for arr2, _u2, h2, *_rest in arrays[1:]:
        # one channel written twice, in two units each rounded as exports round (a psi copy to 0.01, a bar copy to
        # 0.001): equal within 0.2 % of the channel's range
        if arr2.shape != arr.shape or not (np.allclose(arr2, arr, rtol=1e-5, atol=1e-9 * max(1.0, float(np.max(
                np.abs(arr))) if arr.size else 1.0)) or (arr.size and float(np.max(np.abs(arr2 - arr)))
                                                         <= 2e-3 * float(np.ptp(arr)))):
            if str(h).strip() == str(h2).strip():   # a map by name cannot pick one of two equal names
                raise InputError(f"two columns share the name {h!r} and give different {q}s: rename one in the header "
                                 "(two runs side by side? give each its own file or sheet), then map the one to use "
                                 f"with --columns {q}=<its name>", path=where, line=hline, key=h2)
            raise InputError(f"two columns give {q}: {h!r} and {h2!r}, and they disagree; map the one to use with "
                             f"--columns {q}=<column>", path=where, line=hline, key=h2)
        ignored.append(h2)
    columns[q] = arr
    units_in_file[q] = unit
    headers[q] = h
    if ref is not None:
        refs[q] = ref
    col_info[q] = {"column": h, "unit": unit, "unit_from": unit_from, **({"reference": ref} if ref else {}),
                   **extra}

def _check_rivals(grid: Grid, columns: dict, headers: dict, units_in_file: dict, unknown: list, ignored: list,
                  lines: list) -> list[str]:
    """A column bpmid took by its name for the pressure or the angle, beside another whose unit is one of that
    quantity (in its brackets, the units row or its name's last words) and whose values differ. Returns warnings.

    - Asked (refused, with both ``--columns`` to choose): when the other is named as the muscle's own measurement
      ('Chamber pressure', 'Pressure sensor', 'Kammerdruck'), may be the supply or the ambient pressure ('Air
      pressure', 'Luftdruck'), or the name bpmid took is itself qualified ('Supply pressure'); and whenever the
      column bpmid took barely moves beside the other (a supply or a setpoint held while the muscle's pressure runs).
    - Otherwise bpmid's plain name ('pressure_kpa', 'Pressure (kPa)') is the log's; the other ('p_supply_kpa',
      'angle_imu_deg', 'pmuscle_kpa') is set aside, listed as ignored, and named in a warning with the ``--columns``
      that would take it instead: never in silence.
    Columns named as derived (setpoint, command, max, ...) are no rivals; equal values are one channel logged twice."""
    warns: list[str] = []
    mapped = set(grid.info.get("mapped_quantities", ()))
    for q in _RIVAL_QUANTITIES:
        if q not in columns or q in mapped:
            continue
        words_q = {w for w, qq in ALIASES.items() if qq == q and " " not in w}
        for h2 in list(unknown):
            if h2 not in grid.header:
                continue
            j = grid.header.index(h2)
            raw, unit = _unit_part(h2)
            words = _norm(raw).split(" ")
            row = grid.unit_row[j] if grid.unit_row is not None and j < len(grid.unit_row) else None
            u = split_unit(q, unit)[0] if unit is not None else None
            if unit is None and row is not None and str(row).strip():
                u = split_unit(q, str(row))[0]   # the unit in the units row under the header
            for cut in (2, 1):   # a unit in the name's last words: chamber_pressure_bar_g, p_supply_kpa
                if u is None and unit is None and len(words) > cut and split_unit(q, " ".join(words[-cut:]))[0]:
                    u, words = split_unit(q, " ".join(words[-cut:]))[0], words[:-cut]
            if u is None or set(words) & DERIVED_WORDS or any(w.startswith(_DERIVED_PREFIXES) for w in words):
                continue
            try:
                vals = _numbers(grid.cols[j], grid.where, h2, lines, excel=grid.excel) * UNITS[q][u]
            except InputError:
                continue
            a = columns[q]
            if vals.shape != a.shape:
                continue
            d = np.abs(vals - a)
            d = d[np.isfinite(d)]
            scale = float(np.nanmax(np.abs(a))) if a.size else 1.0
            unknown.remove(h2)
            ignored.append(h2)
            if d.size == 0 or float(np.max(d)) <= 1e-3 * max(scale, 1e-12):
                continue   # one channel logged twice
            h = headers[q]
            named = bool(set(words) & words_q) or any(w.endswith(_GERMAN_WORD[q]) for w in words)
            measured = bool(set(words) & _MEASURED_WORDS) or any(w.startswith(_MEASURED_PREFIXES) for w in words)
            chosen_words = set(_norm(_unit_part(h)[0]).split(" "))
            qualified = bool(chosen_words - words_q - _UNIT_WORDS)
            # the one taken barely moves beside the other, which is not named as another channel of the rig (a
            # creep test holds the muscle while the supply or a tank moves)
            still = float(np.ptp(a)) < 0.2 * float(np.ptp(vals)) and not (
                set(words) & _OTHER_CHANNEL_WORDS or any(w.startswith(_OTHER_CHANNEL_PREFIXES) for w in words))
            if (named and (measured or qualified)) or _AMBIGUOUS_AIR.search(h2) or still:
                why = ("the one taken by its name barely moves beside the other (a supply or a setpoint?)" if still
                       else "one is often the supply or the setpoint")
                raise InputError(f"two columns could be the {q}: {h!r}, by its name, and {h2!r}, by its unit, and "
                                 f"their values differ (by up to {float(np.max(d)):.4g} {CANONICAL[q]}); {why}, so "
                                 f"bpmid does not choose: name the measured {q} with {columns_arg(f'{q}={h2}')} or "
                                 f"{columns_arg(f'{q}={h}')} (config io.columns: {{'<column>': {q}}})",
                                 path=grid.where, line=grid.header_line or None, key=h2)
            warns.append(f"{grid.where}: took {h!r} as the {q} (bpmid's name for it) and set aside {h2!r}, whose values "
                         f"differ by up to {float(np.max(d)):.4g} {CANONICAL[q]}; if {h2!r} is the muscle's, take it "
                         f"with {columns_arg(f'{q}={h2}')}")
    return warns


def _column_name(q: str, unit: str) -> str:
    """bpmid's name for a column of ``q`` in ``unit`` (``time_ms``; ``'stress (n/mm^2)'`` for a unit with signs)."""
    return f"{q}_{unit}" if re.fullmatch(r"[a-z0-9]+", unit) else f"'{q} ({unit})'"


def _check_meta_unit(grid: Grid, q: str, h: str, unit: str, ref: str | None, unit_from: str,
                     meta_unit: str) -> str | None:
    """A ``# <q>_unit:`` line beside a unit the header (or units row) states: it must agree (a unit stated twice
    must agree; the line is not silently ignored). Returns the pressure reference (the line may add one)."""
    line = grid.meta_lines.get(f"{q}_unit")
    said = f"the line '# {q}_unit: {meta_unit}'"
    mu, mref = split_unit(q, meta_unit)
    if mu is None:
        raise InputError(f"unknown unit {meta_unit!r} for {q} in {said} (known: {', '.join(_known(q))}); the column "
                         f"{h!r} already states its unit ({unit}), so the line can be deleted", path=grid.where,
                         line=line, key=f"{q}_unit")
    if unit_from == "units row":
        src = f"the units row under the header (line {grid.unit_row_line})" if grid.unit_row_line else \
            "the units row under the header"
        fix = f"correct the units row (or map the column with its unit: {columns_arg(f'{_column_name(q, mu)}={h}')})"
    else:
        src = f"the header {h!r}"
        fix = (f"rename the column {_column_name(q, mu)} (or map it with its unit: --columns "
               f"{_column_name(q, mu)}={h})")
    if mu != unit:
        raise InputError(f"{said} says {q} is in {meta_unit}, but {src} says {unit}; a unit stated twice must agree: if "
                         f"the values are in {unit}, delete or correct the line; if they are in {meta_unit}, {fix}",
                         path=grid.where, line=line, key=h)
    if mref is not None and ref is not None and mref != ref:
        raise InputError(f"{said} says the pressure is {mref}, but {src} says {ref} ({h!r}); make them agree",
                         path=grid.where, line=line, key=h)
    return ref if ref is not None else mref


def columns_arg(pairs: str) -> str:
    """``--columns`` with its value, quoted for a shell when the value has spaces or brackets (messages)."""
    return f"--columns {pairs}" if re.fullmatch(r"[\w.,=+-]+", pairs) else f"--columns '{pairs}'"


def _unknown_unit_hint(q: str, h: str, unit: str, unit_from: str | None) -> str:
    """What to do about a column whose stated unit bpmid does not know (``p_abs``: 'abs' is a reference)."""
    ex = EXAMPLE_UNIT[q]
    ref = _REF_WORDS.get(unit) if q == "pressure" else None
    out = ""
    if ref is not None:
        out += (f"; {unit!r} reads as the pressure reference ({ref}), which a name carries only after a unit "
                f"(pressure_{ex.lower()}_{unit})")
    if unit in _SIGNAL_UNITS:
        return (f"; {unit!r} is a raw signal, not {'an' if q[0] in 'aeiou' else 'a'} {q}: log the calibrated {q} "
                f"(in {EXAMPLE_UNIT[q]}, say), or convert the signal with its sensor's calibration first")
    if q == "angle" and unit == "grad":
        out += ("; 'grad' is the degree in German but the gradian (400 to a turn) in English, so bpmid does not "
                "read it either way: write deg or gon")
    unread = _unread_pressure_unit(unit) if q in ("pressure", "ambient") else None
    if unread is not None:
        kpa = _UNREAD_PRESSURE_UNITS[unread] / 1e3
        return (f"; bpmid does not read {unit!r}: convert the column to kPa first (1 {unit} = {kpa:.6g} kPa; "
                f"multiply the values by {kpa:.6g}) and name it {BPMID_NAME[q]}, or to another unit it reads. "
                f"Do not only rename or map the column: its numbers would then be read as kPa")
    name = f"pressure_{ex.lower()}_{unit}" if ref is not None else BPMID_NAME[q]
    mapped = f"{columns_arg(f'{name}={h}')} (config io.columns: {{'{h}': {name}}})"
    if q in UNIT_FLAGS or q == "ambient":
        # only right when the stated unit is a slip for the example's: say so, never suggest a relabel alone
        mapped += f", only if the values are in fact in {ex} (otherwise convert them to a unit bpmid reads first)"
    if unit_from == "units row":
        out += f"; state the unit the column is logged in: correct the units row, or map the column: {mapped}"
    else:
        out += f"; state the unit the column is logged in: rename the column ({name}) or map it: {mapped}"
    if q in UNIT_FLAGS and unit_from == "header" and _unit_part(h)[1] is None:
        # a name suffix: mapped to the bare quantity, the suffix is no longer read as its unit and the flag applies
        out += f", or {columns_arg(f'{q}={h}')} with {UNIT_FLAGS[q]} {ex}"
        if ref is not None:
            out += f" (and --pressure-reference {ref} unless the file states the reference)"
    return out


def _mapped_unit_hint(grid: Grid, q: str, h: str, unit: str) -> str:
    """What to do when the column map sends column ``h`` to a name whose part after the quantity is no unit
    (``--columns angle_imu=angle_deg``: 'angle_imu' read as the angle in 'imu'): say how the map is read and give a
    map that differs from the one written (never ``h`` to itself when its own name already reads)."""
    mapped = f"{q}_{unit}"
    out = (f": the column map sends the column {h!r} to {mapped!r}, and bpmid reads the part after the quantity as "
           f"its unit. --columns takes bpmid's name ({q}, or with a unit: {BPMID_NAME[q]}) on the left of '=' and "
           f"the file's column on the right")
    like = _like_column(mapped, grid.header, exclude=h)
    if like is not None:   # the map written the other way round ('angle_imu' for the column 'angle_imu_deg')
        return out + (f"; to take the column {like!r} as the {q}: {columns_arg(f'{q}={like}')} (config io.columns: "
                      f"{{'{like}': {q}}})")
    own_q, own_u, _r, _d = _parse(h)
    if own_q == q and own_u is not None and own_u in UNITS[q]:
        return out + f"; the column {h!r} reads as the {q} by its own name: drop the entry"
    return out + (f"; to take {h!r} as the {q}: {columns_arg(f'{BPMID_NAME[q]}={h}')} if its values are in "
                  f"{EXAMPLE_UNIT[q]} (or {q}_<unit> with the unit they are in)")


def _known(q: str) -> list[str]:
    return sorted(k for k in UNITS[q] if k)


def _time_is_text(vals: list) -> bool:
    import datetime as _dt

    for v in vals[:5]:
        if isinstance(v, (_dt.datetime, _dt.time, _dt.timedelta)):
            return True
        if isinstance(v, str) and (_CLOCK.match(v) or _MMSS.match(v) or _CLOCK_12.match(v) or _YMD_SLASH.match(v)):
            return True
        if isinstance(v, str) and v.strip() and not _is_number(v) and (
                re.match(r"^\s*\d{4}-\d{2}-\d{2}", v) or _MATLAB_DATE.match(v) or _DOTTED_DATE.match(v)
                or _SLASH_DATE.match(v)):
            return True
    return False


def check_time(table: Table, *, kind: str = "log", gap_factor: float | None = None,
               max_gap_s: float | None = None) -> np.ndarray:
    """The time column, checked to rise strictly; gaps are warned about (or refused beyond ``max_gap_s``).

    Parameters
    ----------
    gap_factor : a step longer than this many times the median step is a gap: the log is still read (the
        hereditary recursion is exact for any step), with a warning naming the line and what is assumed
        across the gap (None: gaps are not looked for)
    max_gap_s : a step longer than this (s) is refused (``--max-gap`` / ``io.max_gap_s``; None: never)
    """
    t = table.columns["time"]
    if t.size < 2:
        raise InputError(f"{kind} needs at least two samples, found {t.size}", path=table.name)
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        r = int(bad[0]) + 1
        what = "repeats" if dt[bad[0]] == 0 else "goes backwards"
        hint = ""
        if dt[bad[0]] == 0:
            pos = dt[dt > 0]
            res = float(np.min(pos)) if pos.size else 0.0
            if (dt == 0).sum() > 0.1 * dt.size and pos.size and np.allclose(pos / res, np.round(pos / res)):
                # many repeats, the other steps whole multiples of one: the column is written coarser than it is
                # sampled (mm:ss.0 at 20 Hz)
                hint = (f"; {int((dt == 0).sum())} of {dt.size} steps repeat and the rest are multiples of {res:g} s: "
                        "the time column is written coarser than the log is sampled; export it with more decimals")
            else:
                hint = "; a sample written twice? Drop one of the two rows"
        raise InputError(f"time {what} ({t[r - 1]:g} s then {t[r]:g} s); time must increase{hint}",
                         path=table.name, line=table.line_of(r))
    if max_gap_s is not None:
        over = np.flatnonzero(dt > max_gap_s)
        if over.size:
            r = int(over[0]) + 1
            raise InputError(f"gap of {dt[over[0]]:g} s between samples, longer than --max-gap {max_gap_s:g} s "
                             f"(io.max_gap_s); raise or drop that setting to read the log", path=table.name,
                             line=table.line_of(r))
    if gap_factor is not None:
        med = float(np.median(dt))
        gaps = np.flatnonzero(dt > gap_factor * med)
        if gaps.size:
            r = int(gaps[0]) + 1
            longest = int(gaps[np.argmax(dt[gaps])]) + 1
            more = "" if gaps.size == 1 else (f" ({gaps.size} gaps; the longest {dt[longest - 1]:g} s at line "
                                              f"{table.line_of(longest)})")
            table.warnings.append(
                f"{table.name}:{table.line_of(r)}: gap of {dt[gaps[0]]:g} s between samples where the usual step "
                f"is {med:g} s{more}; read anyway: across a gap the input is taken to hold its last sample and "
                f"change in one step at the next (the hereditary recursion is exact for that input). Refuse such "
                f"logs with --max-gap SECONDS (io.max_gap_s)")
            table.reading["gaps"] = {"count": int(gaps.size), "first_line": table.line_of(r),
                                     "longest_s": float(dt[longest - 1]),
                                     "assumed": "input held at its last sample across the gap, stepping at the next"}
    return t
