"""Motion logs: time, pressure, (optionally) bending angle.

Columns: ``time_s``, ``pressure_bar`` (or ``pressure_kpa``, ``pressure_pa``, or any header
:mod:`bpmid.io.tables` understands), ``angle_deg``. The pressure reference (absolute or gauge) comes
from a ``# pressure_reference: absolute`` line or the config (``io.pressure_reference``); the file's
line wins when both are given and agree, and a disagreement is an error. Inside bpmid pressure is
always gauge, in Pa.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Literal, Mapping, Optional, Sequence

import numpy as np

from bpmid.errors import InputError
from bpmid.io.tables import UNITS, check_time, read_table

ATMOSPHERE_PA = 101325.0


@dataclasses.dataclass(frozen=True)
class IOConfig:
    """Config section ``io``: how logs are read.

    Attributes
    ----------
    columns : file header -> bpmid column name (``{"Zeit [s]": "time_s"}``)
    pressure_reference : ``absolute`` or ``gauge`` for logs without a ``# pressure_reference:`` line
    atmosphere_pa : ambient pressure used to turn absolute into gauge pressure (Pa)
    max_gap_factor : a time step longer than this many median steps is refused as a gap
    min_gauge_pa : a gauge pressure below this (Pa) is refused: a muscle is not driven by vacuum, so it is
        almost always a wrong pressure reference or unit (default -5000 Pa leaves room for sensor noise at rest)
    """

    columns: Mapping[str, str] = dataclasses.field(default_factory=dict)
    pressure_reference: Optional[Literal["absolute", "gauge"]] = None
    atmosphere_pa: float = ATMOSPHERE_PA
    max_gap_factor: float = 5.0
    min_gauge_pa: float = -5000.0

    def validate(self, where, path):
        if not self.max_gap_factor > 1.0:
            raise InputError(f"max_gap_factor must be above 1 (a multiple of the usual time step), found "
                             f"{self.max_gap_factor:g}", path=path, key=f"{where}.max_gap_factor")
        if self.min_gauge_pa > 0:
            raise InputError(f"min_gauge_pa must be 0 or below, found {self.min_gauge_pa:g} Pa", path=path,
                             key=f"{where}.min_gauge_pa")
        if not (50e3 <= self.atmosphere_pa <= 120e3):
            raise InputError(f"atmosphere_pa {self.atmosphere_pa:g} Pa is not an ambient pressure",
                             path=path, key=f"{where}.atmosphere_pa")


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

    @property
    def n(self) -> int:
        return int(self.time_s.size)

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

    def with_angle(self, angle_deg: np.ndarray) -> "MotionLog":
        return dataclasses.replace(self, angle_deg=np.asarray(angle_deg, float))

    def slice(self, start: int, stop: int) -> "MotionLog":
        pg = None if self.pressure_as_given is None else self.pressure_as_given[start:stop]
        ang = None if self.angle_deg is None else self.angle_deg[start:stop]
        return dataclasses.replace(self, time_s=self.time_s[start:stop], pressure_pa=self.pressure_pa[start:stop],
                                   angle_deg=ang, pressure_as_given=pg)


def from_arrays(name: str, time_s, pressure_pa_gauge, angle_deg=None, **kw) -> MotionLog:
    """An in-memory log from arrays (gauge pressure in Pa, angle in degrees)."""
    t = np.asarray(time_s, float)
    p = np.asarray(pressure_pa_gauge, float)
    a = None if angle_deg is None else np.asarray(angle_deg, float)
    return MotionLog(name=name, time_s=t, pressure_pa=p, angle_deg=a, pressure_as_given=p.copy(), **kw)


def read_motion_log(path: str | Path, io_cfg: IOConfig | None = None, *, require_angle: bool = False) -> MotionLog:
    """Read one motion log (see module docstring). Errors name the file and line."""
    io_cfg = io_cfg or IOConfig()
    path = Path(path)
    required = ("time", "pressure") + (("angle",) if require_angle else ())
    table = read_table(path, column_map=io_cfg.columns, required=required, kind="motion log")
    t = check_time(table, kind="motion log", gap_factor=io_cfg.max_gap_factor)
    ref_file = table.meta.get("pressure_reference")
    ref_cfg = io_cfg.pressure_reference
    if ref_file is not None:
        ref_file = ref_file.strip().lower()
        if ref_file not in ("absolute", "gauge"):
            raise InputError(f"pressure_reference must be absolute or gauge, found {ref_file!r}", path=path,
                             key="pressure_reference")
        if ref_cfg is not None and ref_cfg != ref_file:
            raise InputError(f"the file says pressure_reference: {ref_file}, the config io.pressure_reference says "
                             f"{ref_cfg}", path=path, key="pressure_reference")
    ref = ref_file or ref_cfg
    if ref is None:
        raise InputError("pressure reference unknown: add a line '# pressure_reference: absolute' (or gauge) "
                         "to the file, or set io.pressure_reference in the config", path=path)
    unit = table.units_in_file["pressure"]
    p_pa = table.columns["pressure"]
    given = p_pa / UNITS["pressure"][unit]
    gauge = p_pa - io_cfg.atmosphere_pa if ref == "absolute" else p_pa
    low = np.flatnonzero(gauge < io_cfg.min_gauge_pa)
    if low.size:
        k = int(low[0])
        raise InputError(f"pressure {given[k]:g} {unit} ({ref}) is {-gauge[k] / 1e5:.3g} bar below atmosphere; a "
                         f"muscle is not driven by vacuum: check the pressure reference (# pressure_reference: "
                         f"absolute or gauge) and the unit of the column {table.headers['pressure']!r}",
                         path=path, line=table.line_of(k))
    angle = table.columns.get("angle")
    return MotionLog(name=path.stem, time_s=t, pressure_pa=gauge, angle_deg=angle, pressure_reference=ref,
                     pressure_unit=unit, pressure_as_given=given, atmosphere_pa=io_cfg.atmosphere_pa,
                     path=path, meta=dict(table.meta))


def read_motion_logs(paths: Sequence[str | Path], io_cfg: IOConfig | None = None, *,
                     require_angle: bool = False) -> list[MotionLog]:
    if not paths:
        raise InputError("no motion logs given")
    logs = [read_motion_log(p, io_cfg, require_angle=require_angle) for p in paths]
    names = [lg.name for lg in logs]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise InputError(f"two logs share the file name {sorted(dup)[0]!r}; outputs are named by it")
    return logs


def is_synthetic(logs: Sequence[MotionLog]) -> bool:
    """True when every log says it is synthetic (a ``# synthetic: true`` line, or a ``# source:``/``# generator:``
    line naming bpmid's twin) or lives under a ``datasets`` folder of bpmid's shipped data (not ``reference``)."""
    def one(lg: MotionLog) -> bool:
        meta = {str(k).strip().lower(): str(v).strip().lower() for k, v in (lg.meta or {}).items()}
        if "synthetic" in meta:  # "# synthetic: true (bpmid digital twin; not a measurement)"
            words = meta["synthetic"].replace("(", " ").split()
            return bool(words) and words[0] in ("true", "yes", "1")
        if any(("twin" in meta.get(k, "") or "synthetic" in meta.get(k, "")) for k in ("source", "generator")):
            return True
        return lg.path is not None and "datasets" in Path(lg.path).parts and "reference" not in Path(lg.path).parts
    return bool(logs) and all(one(lg) for lg in logs)


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
    head = [f"# pressure_reference: {reference}"]
    for k, v in (comments or {}).items():
        head.append(f"# {k}: {v}")
    df = motion_frame(log, unit=unit, reference=reference, decimals=decimals)
    body = df.to_csv(index=False, lineterminator="\n")
    return write_text(path, "\n".join(head) + "\n" + body)
