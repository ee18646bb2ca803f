"""Motion logs: time, pressure, (optionally) bending angle.

Columns: ``time_s``, ``pressure_bar`` (or ``pressure_kpa``, ``pressure_psi``, ``Pressure (bar a)``, any header
:mod:`bpmid.io.tables` understands, in any format it reads: CSV dialects, Excel, MATLAB), ``angle_deg``. Units are
never guessed (see :mod:`bpmid.io.tables`). The pressure reference (absolute or gauge) comes from a
``# pressure_reference: absolute`` line (key and value case-insensitive), a unit that carries it (``psig``,
``bar(a)``) or the config/flag (``io.pressure_reference``, ``--pressure-reference``); when several are given they
must agree, and none at all is an error that names the three ways. Inside bpmid pressure is always gauge, in Pa.
Gaps in the time column are read with a warning (``io.max_gap_s`` refuses them).
"""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Literal, Mapping, Optional, Sequence

import numpy as np

from bpmid.errors import InputError
from bpmid.io.ambient import AMBIENT_RANGE_PA, ambient_pressure, atmosphere_line, unread_ambient_lines
from bpmid.io.tables import UNITS, check_time, read_table, split_unit

from bpmid.units import ATMOSPHERE_PA, PA_PER_BAR  # noqa: E402  (the one home of unit factors)


@dataclasses.dataclass(frozen=True)
class IOConfig:
    """Config section ``io``: how logs are read (the CLI flags ``--columns``, ``--pressure-unit``,
    ``--angle-unit``, ``--time-unit``, ``--pressure-reference``, ``--sheet``, ``--max-gap`` and ``--strict``
    override these).

    Attributes
    ----------
    columns : file header -> bpmid column name (``{"Zeit [s]": "time_s"}``, ``{"Druck": "pressure"}``)
    units : quantity -> unit for columns whose name states none (``{pressure: kPa, angle: deg, time: ms}``)
    pressure_reference : ``absolute`` or ``gauge`` for logs that do not say it themselves
    atmosphere_pa : ambient pressure used to turn absolute into gauge pressure (Pa)
    max_gap_factor : a time step longer than this many median steps is a gap: read with a warning naming the line
    max_gap_s : a time step longer than this (s) is refused (null: gaps are never refused)
    sheet : the Excel sheet to read (null: the one sheet with the needed columns)
    strict : warnings (gaps, implausible fits, likely unit or reference slips) end the command with exit 2
    min_gauge_pa : a gauge pressure below this (Pa) is refused: a muscle is not driven by vacuum, so it is
        almost always a wrong pressure reference or unit (default -5000 Pa leaves room for sensor noise at rest)
    stated_by : setting -> the flag that gave it (filled by the command line, for messages)
    """

    columns: Mapping[str, str] = dataclasses.field(default_factory=dict)
    units: Mapping[str, str] = dataclasses.field(default_factory=dict)
    pressure_reference: Optional[Literal["absolute", "gauge"]] = None
    atmosphere_pa: float = ATMOSPHERE_PA
    max_gap_factor: float = 5.0
    max_gap_s: Optional[float] = None
    sheet: Optional[str] = None
    strict: bool = False
    min_gauge_pa: float = -5000.0
    stated_by: Mapping[str, str] = dataclasses.field(default_factory=dict)

    def validate(self, where, path):
        if not self.max_gap_factor > 1.0:
            raise InputError(f"max_gap_factor must be above 1 (a multiple of the usual time step), found "
                             f"{self.max_gap_factor:g}", path=path, key=f"{where}.max_gap_factor")
        if self.max_gap_s is not None and not self.max_gap_s > 0:
            raise InputError(f"max_gap_s must be a positive number of seconds, found {self.max_gap_s:g}", path=path,
                             key=self.stated_by.get("max_gap_s", f"{where}.max_gap_s"))
        if self.min_gauge_pa > 0:
            raise InputError(f"min_gauge_pa must be 0 or below, found {self.min_gauge_pa:g} Pa", path=path,
                             key=f"{where}.min_gauge_pa")
        if not (AMBIENT_RANGE_PA[0] <= self.atmosphere_pa <= AMBIENT_RANGE_PA[1]):
            raise InputError(f"atmosphere_pa {self.atmosphere_pa:g} Pa is not an ambient pressure",
                             path=path, key=f"{where}.atmosphere_pa")
        for q, u in self.units.items():
            if q not in UNITS:
                raise InputError(f"no quantity {q!r} (known: {', '.join(sorted(UNITS))})", path=path,
                                 key=f"{where}.units.{q}")
            if split_unit(q, str(u))[0] is None:
                raise InputError(f"unknown unit {u!r} for {q} (known: {', '.join(sorted(k for k in UNITS[q] if k))})",
                                 path=path, key=self.stated_by.get(f"units.{q}", f"{where}.units.{q}"))

    def unit_sources(self) -> dict[str, str]:
        """quantity -> where its unit setting came from (a flag or ``io.units.<q>``), for messages."""
        return {q: self.stated_by.get(f"units.{q}", f"io.units.{q}") for q in self.units}


#: spellings of the two pressure references in files and flags
REFERENCE_WORDS = {"absolute": "absolute", "abs": "absolute", "a": "absolute", "gauge": "gauge", "gage": "gauge",
                   "g": "gauge", "relative": "gauge", "rel": "gauge", "overpressure": "gauge"}

#: comment keys that state the pressure reference (compared case-insensitively, spaces as underscores)
REFERENCE_KEYS = ("pressure_reference", "pressure_ref", "reference_pressure")


@dataclasses.dataclass
class MotionLog:
    """One pressure/angle run.

    Attributes
    ----------
    name : file stem (used for output names)
    time_s : (N,) s, strictly increasing
    pressure_pa : (N,) gauge pressure in Pa (what the model sees)
    angle_deg : (N,) measured bending angle in degrees, or None for a pressure-only log
    pressure_reference : "absolute" or "gauge", as logged
    pressure_unit : unit of the pressure column in the file ("bar", "kpa", "pa", ...)
    pressure_as_given : (N,) the pressure column exactly as logged (file unit, file reference)
    atmosphere_pa : ambient pressure used for the conversion
    path : source file, or None for an in-memory log
    meta : ``# key: value`` lines of the file
    reading : what the reader found and assumed (format, columns and units, reference and where it came from)
    warnings : reader warnings (gaps, ignored columns)
    lines : (N,) the file line (sheet row) of each sample, or None (an in-memory log): for messages
    """

    name: str
    time_s: np.ndarray
    pressure_pa: np.ndarray
    angle_deg: np.ndarray | None
    pressure_reference: str = "gauge"
    pressure_unit: str = "pa"
    pressure_as_given: np.ndarray | None = None
    atmosphere_pa: float = ATMOSPHERE_PA
    path: Path | None = None
    meta: dict = dataclasses.field(default_factory=dict)
    reading: dict = dataclasses.field(default_factory=dict)
    warnings: list = dataclasses.field(default_factory=list)
    lines: np.ndarray | None = None

    @property
    def n(self) -> int:
        return int(self.time_s.size)

    def line_of(self, k: int) -> int | None:
        """The file line of sample ``k``, or None when the log does not know it (in memory, or cut from another)."""
        if self.lines is None or len(self.lines) != self.n or not 0 <= int(k) < self.n:
            return None
        return int(self.lines[int(k)])

    @property
    def duration_s(self) -> float:
        return float(self.time_s[-1] - self.time_s[0])

    @property
    def dt_s(self) -> float:
        """Median sampling step (s)."""
        return float(np.median(np.diff(self.time_s)))

    @property
    def angle_rad(self) -> np.ndarray | None:
        return None if self.angle_deg is None else np.deg2rad(self.angle_deg)

    @property
    def label(self) -> str:
        return self.name

    def __repr__(self) -> str:
        """A line a person reads (the arrays are in the attributes): name, samples, span, rate, pressure range."""
        if self.n == 0:
            return f"<MotionLog {self.name!r}: no samples>"
        p = self.pressure_pa / 1e5
        ang = ("no angle" if self.angle_deg is None else
               f"angle {np.nanmin(self.angle_deg):.4g}..{np.nanmax(self.angle_deg):.4g} deg")
        rate = f", {1.0 / self.dt_s:.4g} Hz" if self.n > 1 and self.dt_s > 0 else ""
        src = f", from {self.path}" if self.path is not None else ""
        return (f"<MotionLog {self.name!r}: {self.n} samples over {self.duration_s:.4g} s{rate}, gauge pressure "
                f"{np.nanmin(p):.4g}..{np.nanmax(p):.4g} bar, {ang}{src}>")

    def with_angle(self, angle_deg: np.ndarray) -> "MotionLog":
        return dataclasses.replace(self, angle_deg=np.asarray(angle_deg, float))

    def slice(self, start: int, stop: int) -> "MotionLog":
        pg = None if self.pressure_as_given is None else self.pressure_as_given[start:stop]
        ang = None if self.angle_deg is None else self.angle_deg[start:stop]
        ln = None if self.lines is None or len(self.lines) != self.n else self.lines[start:stop]
        return dataclasses.replace(self, time_s=self.time_s[start:stop], pressure_pa=self.pressure_pa[start:stop],
                                   angle_deg=ang, pressure_as_given=pg, lines=ln)


def from_arrays(name: str, time_s, pressure_pa_gauge, angle_deg=None, **kw) -> MotionLog:
    """An in-memory log from arrays (gauge pressure in Pa, angle in degrees)."""
    t = np.asarray(time_s, float)
    p = np.asarray(pressure_pa_gauge, float)
    a = None if angle_deg is None else np.asarray(angle_deg, float)
    return MotionLog(name=name, time_s=t, pressure_pa=p, angle_deg=a, pressure_as_given=p.copy(), **kw)


def _reference(table, io_cfg: IOConfig, path: Path) -> tuple[str, str]:
    """The pressure reference and where it was stated; every statement must agree, none is an error."""
    stated = []
    for k in REFERENCE_KEYS:
        if k in table.meta:
            v = str(table.meta[k]).strip().lower().split()
            word = REFERENCE_WORDS.get(v[0] if v else "")
            if word is None:
                raise InputError(f"pressure reference must be absolute or gauge, found {table.meta[k]!r}",
                                 path=table.name, key=k)
            ln = table.meta_lines.get(k)   # the file's line: its key may read 'Pressure Reference', not this
            stated.append((word, f"line {ln} ({k}: {table.meta[k]})" if ln else f"the line '# {k}: {table.meta[k]}'"))
    if "pressure" in table.references:
        stated.append((table.references["pressure"], f"the unit of {table.headers['pressure']!r}"))
    if io_cfg.pressure_reference is not None:
        src = io_cfg.stated_by.get("pressure_reference", "io.pressure_reference (config)")
        stated.append((io_cfg.pressure_reference, src))
    words = {w for w, _ in stated}
    if len(words) > 1:
        a = next(s for s in stated if s[0] == stated[0][0])
        b = next(s for s in stated if s[0] != stated[0][0])
        raise InputError(f"the pressure reference is stated twice and disagrees: {a[1]} says {a[0]}, {b[1]} says "
                         f"{b[0]}; drop or correct one", path=table.name, key="pressure_reference")
    if not stated:
        raise InputError("pressure reference unknown (bpmid never guesses it): state it with (1) a line "
                         "'# pressure_reference: gauge' (or absolute) above the column names, (2) the flag "
                         "--pressure-reference gauge|absolute (config io.pressure_reference), or (3) a unit that "
                         "carries it (pressure_psig, 'Pressure (bar a)')", path=table.name, key="pressure_reference")
    return stated[0]


def read_motion_log(path: str | Path, io_cfg: IOConfig | None = None, *, require_angle: bool = False) -> MotionLog:
    """Read one motion log (see module docstring). Errors name the file and line."""
    from bpmid.io.read_once import read_once

    io_cfg = io_cfg or IOConfig()
    path = Path(path)
    return read_once("motion log", path, (repr(io_cfg), require_angle),
                     lambda: _read_motion_log(path, io_cfg, require_angle))


def _read_motion_log(path: Path, io_cfg: IOConfig, require_angle: bool) -> MotionLog:
    required = ("time", "pressure") + (("angle",) if require_angle else ())
    table = read_table(path, column_map=io_cfg.columns, required=required, optional=("angle", "ambient"),
                       kind="motion log",
                       units=io_cfg.units, unit_sources=io_cfg.unit_sources(), sheet=io_cfg.sheet)
    t = check_time(table, kind="motion log", gap_factor=io_cfg.max_gap_factor, max_gap_s=io_cfg.max_gap_s)
    ref, ref_from = _reference(table, io_cfg, path)
    unit = table.units_in_file["pressure"]
    p_pa = table.columns["pressure"]
    given = p_pa / UNITS["pressure"][unit]
    from bpmid.config import stated_keys

    # a config that writes out atmosphere_pa states it, even at the standard atmosphere's value
    said = io_cfg.stated_by.get("atmosphere_pa") or (
        "io.atmosphere_pa (config)" if "atmosphere_pa" in stated_keys(io_cfg) else None)
    atm, atm_from = ambient_pressure(table, io_cfg.atmosphere_pa, said) \
        if ref == "absolute" else (io_cfg.atmosphere_pa, None)
    gauge = p_pa - atm if ref == "absolute" else p_pa
    low = np.flatnonzero(gauge < io_cfg.min_gauge_pa)
    if low.size:
        k = int(low[0])
        import types

        from bpmid.io.plausibility import reference_fix, unit_fix

        h = table.headers["pressure"]
        view = types.SimpleNamespace(reading=table.reading, meta=table.meta)   # what the hints read of a log
        unit_from = str(((table.reading.get("columns") or {}).get("pressure") or {}).get("unit_from") or "")
        # a flag is refused where the file itself states the unit or the reference: then the hint is the column map
        stated_in_file = unit_from in ("header", "units row") or unit_from.startswith("'#")
        unit_how = unit_fix(view, "pressure", "bar" if unit.lower() != "bar" else "kpa") if stated_in_file \
            else "--pressure-unit"
        ref_how = reference_fix(view, "absolute" if ref == "gauge" else "gauge")
        raise InputError(f"pressure {given[k]:g} {unit} ({ref}, from {ref_from}) is {-gauge[k] / PA_PER_BAR:.3g} bar below "
                         f"atmosphere; a muscle is not driven by vacuum: check the pressure reference ({ref_how}) "
                         f"and the unit of the column {h!r} ({unit_how})", path=table.name, line=table.line_of(k))
    angle = table.columns.get("angle")
    reading = dict(table.reading)
    reading["pressure_reference"] = {"reference": ref, "from": ref_from}
    atm_mean = float(np.mean(atm))
    if ref == "absolute":
        reading["pressure_reference"]["atmosphere_pa"] = atm_mean
        reading["pressure_reference"]["atmosphere_from"] = atm_from   # a column, a line, the config or assumed
    warnings = list(table.warnings)
    if ref == "absolute" and atm_from.startswith("io.atmosphere_pa"):
        warnings += unread_ambient_lines(table, io_cfg.atmosphere_pa)
    return MotionLog(name=path.stem, time_s=t, pressure_pa=gauge, angle_deg=angle, pressure_reference=ref,
                     pressure_unit=unit, pressure_as_given=given, atmosphere_pa=atm_mean,
                     path=path, meta=dict(table.meta), reading=reading, warnings=warnings,
                     lines=None if table.lines is None else np.asarray(table.lines, int))


def read_motion_logs(paths: Sequence[str | Path], io_cfg: IOConfig | None = None, *,
                     require_angle: bool = False) -> list[MotionLog]:
    if not paths:
        raise InputError("no motion logs given")
    logs = [read_motion_log(p, io_cfg, require_angle=require_angle) for p in paths]
    check_distinct_names(logs)
    return logs


def check_distinct_names(logs: Sequence[MotionLog], key: str | None = None) -> None:
    """Refuse (InputError naming the files) logs that share a file name: outputs are named by it."""
    names = [lg.name for lg in logs]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        where = [str(lg.path) if lg.path is not None else "(in memory)" for lg in logs if lg.name == dup[0]]
        raise InputError(f"two logs share the file name {dup[0]!r} ({' and '.join(where)}); outputs are named by "
                         "it: rename or copy one of them under another name", key=key)


def is_synthetic(logs: Sequence[MotionLog]) -> bool:
    """True when every log says it is synthetic (a ``# synthetic: true`` line, or a ``# source:``/``# generator:``
    line naming bpmid's twin) or lives in bpmid's own shipped ``datasets`` folder (not ``reference``)."""
    def one(lg: MotionLog) -> bool:
        said = _header_says_synthetic((lg.meta or {}).items())
        return said if said is not None else lg.path is not None and _in_shipped_datasets(lg.path)
    return bool(logs) and all(one(lg) for lg in logs)


def synthetic_line(log: MotionLog) -> str:
    """``'# synthetic: true (...)\n'`` for a file bpmid writes from a synthetic log (a prediction keeps its input's
    label, so the output is never taken for a measurement); ``''`` for a measured one."""
    if not is_synthetic([log]):
        return ""
    said = str((log.meta or {}).get("synthetic", "")).strip()
    source = f" {log.path.name}" if log.path is not None else ""
    return f"# synthetic: true (the input log{source} says: {said or 'made by bpmid twin'})\n"


#: the stamp on a figure drawn from the twin's logs
TWIN_NOTE = "synthetic data (bpmid digital twin)"


def synthetic_note(logs: Sequence[MotionLog]) -> str | None:
    """The stamp of a figure drawn from ``logs``: None when none is synthetic; ``synthetic data (bpmid digital
    twin)`` when every one is the twin's; ``synthetic data (the logs' own headers say so)`` when every one is
    synthetic and some come from another generator; ``partly synthetic: k of n logs`` when they are mixed (a figure
    of measured and synthetic logs is neither)."""
    logs = list(logs)
    flags = [is_synthetic([lg]) for lg in logs]
    if not any(flags):
        return None
    if not all(flags):
        return f"partly synthetic: {sum(flags)} of {len(flags)} logs"

    def twin(lg: MotionLog) -> bool:   # the twin's own words (bpmid simulate writes them), not any 'twin'
        meta = " ".join(f"{k} {v}" for k, v in (lg.meta or {}).items()).lower()
        return any(w in meta for w in TWIN_WORDS) or (lg.path is not None and _in_shipped_datasets(lg.path))
    return TWIN_NOTE if all(twin(lg) for lg in logs) else "synthetic data (the logs' own headers say so)"


#: words only the twin writes in a file's header (bpmid simulate); 'twin' alone is anyone's
TWIN_WORDS = ("bpmid digital twin", "bpmid simulate")


def header_lines(path: str | Path) -> list[str] | None:
    """The '#' lines among a file's first 40 lines; None when it cannot be read."""
    try:
        with open(path, encoding="utf-8", errors="replace") as fh:
            return [ln for ln in (fh.readline() for _ in range(40)) if ln.lstrip().startswith("#")]
    except OSError:
        return None


def file_is_twin(path: str | Path) -> bool | None:
    """A synthetic file the twin made (its own words, or bpmid's shipped datasets folder): True; another
    generator's: False; a file that cannot be read: None (not known)."""
    if _in_shipped_datasets(path):
        return True
    head = header_lines(path)
    return None if head is None else any(w in " ".join(head).lower() for w in TWIN_WORDS)


def stamp_for_files(paths) -> str | None:
    """The figure stamp of data files: None when none is synthetic, the twin's words when every one is the twin's,
    'partly synthetic: k of n' for a mix, else the logs' own. One rule with :func:`synthetic_note`."""
    paths = list(paths)
    syn = [p for p in paths if file_is_synthetic(p)]
    if not syn:
        return None
    if len(syn) < len(paths):
        return f"partly synthetic: {len(syn)} of {len(paths)} logs"
    return TWIN_NOTE if all(file_is_twin(p) for p in syn) else "synthetic data (the logs' own headers say so)"


def _in_shipped_datasets(path: str | Path) -> bool:
    """True for a file inside bpmid's own shipped ``datasets`` folder (:mod:`bpmid.data`), not ``reference``
    (measured data of others). A user's folder that happens to be called ``datasets`` says nothing."""
    from bpmid import data

    try:
        shipped = (data.root() / "datasets").resolve()
        rel = Path(path).resolve().relative_to(shipped)
    except (ValueError, OSError):
        return False
    return not rel.parts or rel.parts[0] != "reference"


def file_is_synthetic(path: str | Path) -> bool:
    """The rule of :func:`is_synthetic` for any data file bpmid reads (a relaxation log, a material file): a
    ``# synthetic: true`` line or a ``# source:``/``# generator:`` line naming bpmid's twin among its first comment
    lines, else a file in bpmid's own shipped ``datasets`` folder (not ``reference``)."""
    path = Path(path)
    pairs = []
    for line in header_lines(path) or []:
        key, sep, val = line.strip().lstrip("#").strip().partition(":")
        if sep:
            pairs.append((key, val))
    said = _header_says_synthetic(pairs)
    return said if said is not None else _in_shipped_datasets(path)


def _header_says_synthetic(pairs) -> bool | None:
    """The one rule on a file's ``# key: value`` lines: ``synthetic: true|false`` decides; else a ``source`` or
    ``generator`` naming bpmid's twin, ``synthetic`` or ``bpmid simulate`` says synthetic; else None (not said)."""
    meta = [(str(k).strip().lower(), str(v).strip().lower()) for k, v in pairs]
    for key, val in meta:
        if key == "synthetic":   # "# synthetic: true (bpmid digital twin; not a measurement)"
            words = val.replace("(", " ").split()
            return bool(words) and words[0] in ("true", "yes", "1")
    for key, val in meta:
        if key in ("source", "generator") and ("twin" in val or "synthetic" in val or "bpmid simulate" in val):
            return True
    return None


def pressure_column_name(unit: str) -> str:
    """bpmid's column name for a pressure in ``unit`` (``pressure_bar``, ``pressure_kpa``, ``pressure_pa``)."""
    return f"pressure_{unit.lower()}"


def motion_frame(log: MotionLog, *, angle_deg: np.ndarray | None = None, unit: str = "bar",
                 reference: str | None = None, decimals: int = 6) -> pd.DataFrame:
    """A log as a DataFrame in the motion-log format (pressure in ``unit`` and ``reference``)."""
    reference = reference or log.pressure_reference
    p = log.pressure_pa + (log.atmosphere_pa if reference == "absolute" else 0.0)
    import pandas as pd  # here, not at the top: reading logs and configs must not import pandas (0.3 s)

    df = pd.DataFrame({"time_s": np.round(log.time_s, decimals),
                       pressure_column_name(unit): np.round(p / UNITS["pressure"][unit.lower()], decimals)})
    ang = log.angle_deg if angle_deg is None else angle_deg
    if ang is not None:
        df["angle_deg"] = np.round(np.asarray(ang, float), decimals)
    return df


def write_motion_log(path: str | Path, log: MotionLog, *, unit: str = "bar", reference: str | None = None,
                     comments: Mapping[str, str] | None = None, decimals: int = 6) -> Path:
    """Write a motion log atomically, with its ``# pressure_reference:`` line and any other comments."""
    from bpmid.io.atomic import write_text

    reference = reference or log.pressure_reference
    atm = atmosphere_line(log) if reference == "absolute" else ""
    head = [f"# pressure_reference: {reference}"] + ([atm.rstrip("\n")] if atm else [])
    for k, v in (comments or {}).items():
        head.append(f"# {k}: {v}")
    df = motion_frame(log, unit=unit, reference=reference, decimals=decimals)
    body = df.to_csv(index=False, lineterminator="\n")
    return write_text(path, "\n".join(head) + "\n" + body)
