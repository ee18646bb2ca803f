"""Relaxation-test logs: stress/strain, load/extension, or a pre-reduced modulus curve.

Accepted columns (any header dialect :mod:`bpmid.io.tables` reads, units converted):

- ``time_s``, ``strain``, ``stress_mpa``: a stress-strain log (ramp and hold)
- ``time_s``, ``extension_mm``, ``load_n``: a machine log; strain and nominal stress follow from the
  specimen's gauge length and cross-section, taken from the config (``relax.specimen``) or from
  ``# gauge_length_mm: 50`` / ``# cross_section_mm2: 12`` lines in the file (they must agree when
  both are given)
- ``time_s``, ``modulus_mpa``: a relaxation-modulus curve E(t) of an (ideal) step test, for example
  pyvisco's ``t,E_relax`` / ``s,MPa``. It has no strain history, so it can only be fitted in step mode.

Checks beyond the table reader's: a test log (stress/strain or load/extension) is a tension test, so a
strain (extension) clearly below zero is refused with its line (a compression test must be logged with
compression positive, strain and stress alike); with ``gap_factor`` a time step longer than that many
median steps is a gap in the log (samples lost): read with a warning naming the line, refused only beyond
``io.max_gap_s`` (``--max-gap``), as for motion logs. Modulus curves are not gap-checked: master curves are
usually sampled evenly in log time, not in time. The same readers as for motion logs apply (CSV dialects,
encodings, Excel, MATLAB; units never guessed; ``io.units``, ``io.sheet`` and ``io.columns`` honoured when
``io_cfg`` is given).

Every error names the file and the line (or the config key).
"""
from __future__ import annotations

import dataclasses
import re
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from bpmid.errors import InputError
from bpmid.io.material_files import (_MAT_UNITS, SET_T_SPAN_C, _base_role, _mat_role, _split_unit, _unit_cell,
                                     _unit_in_name)
from bpmid.io.tables import cell_numbers, check_time, read_table

KIND = "relaxation log"

#: a strain below -NEG_STRAIN_SHARE x the largest |strain| of the log is refused (sensor noise at rest is far smaller)
NEG_STRAIN_SHARE = 0.02

#: words for each source kind (messages)
SOURCE_WORDS = {"stress-strain": "a stress/strain log", "load-extension": "a load/extension log",
                "modulus": "a modulus curve"}


@dataclasses.dataclass
class RelaxLog:
    """One relaxation test or modulus curve, in canonical units.

    Attributes
    ----------
    name : file stem
    time_s : (N,) s, strictly increasing
    strain : (N,) engineering strain, or None for a modulus curve
    stress_mpa : (N,) nominal stress (MPa), or None for a modulus curve
    modulus_mpa : (N,) relaxation modulus (MPa) for a modulus curve, else None
    source : ``"stress-strain"``, ``"load-extension"`` or ``"modulus"``
    path : the file, or None for an in-memory log
    meta : ``# key: value`` lines of the file
    first_data_line : file line of the first sample (for messages)
    reading : what the reader found and assumed (format, columns, units and where they came from)
    warnings : reader warnings (gaps, ignored columns)
    temperature : (mean, unit, column) of a test log's temperature column: the mean in C (unit ``"C"``), or as
        written (unit None) when the column states no unit of C, K or F; None without such a column
    """

    name: str
    time_s: np.ndarray
    strain: np.ndarray | None = None
    stress_mpa: np.ndarray | None = None
    modulus_mpa: np.ndarray | None = None
    source: str = "stress-strain"
    path: Path | None = None
    meta: dict = dataclasses.field(default_factory=dict)
    first_data_line: int = 2
    reading: dict = dataclasses.field(default_factory=dict)
    warnings: list = dataclasses.field(default_factory=list)
    temperature: tuple | None = None

    @property
    def is_modulus_curve(self) -> bool:
        return self.modulus_mpa is not None

    @property
    def n(self) -> int:
        return int(self.time_s.size)


#: specimen keys an instrument writes above its table ('Gauge Length (mm),50', 'Area (mm^2),12'; keys folded, the
#: unit in brackets or after the value cut off) -> bpmid's key
_SPECIMEN_KEYS = {
    "gauge_length": "gauge_length_mm", "gage_length": "gauge_length_mm", "initial_gauge_length": "gauge_length_mm",
    "specimen_gauge_length": "gauge_length_mm", "gauge_length_l0": "gauge_length_mm", "l0": "gauge_length_mm",
    "area": "cross_section_mm2", "specimen_area": "cross_section_mm2", "cross_section": "cross_section_mm2",
    "cross_sectional_area": "cross_section_mm2", "cross_section_area": "cross_section_mm2",
    "initial_area": "cross_section_mm2", "a0": "cross_section_mm2", "s0": "cross_section_mm2",
}
#: the units of each specimen key -> factor to bpmid's (mm, mm^2)
_SPECIMEN_UNITS = {
    "gauge_length_mm": {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4},
    "cross_section_mm2": {"mm^2": 1.0, "mm2": 1.0, "mm²": 1.0, "cm^2": 100.0, "cm2": 100.0, "cm²": 100.0,
                          "m^2": 1e6, "m2": 1e6, "m²": 1e6, "in^2": 645.16, "in2": 645.16, "in²": 645.16},
}


def _instrument_specimen(name: str, meta: dict, meta_lines: dict, path: Path) -> tuple[float, str] | None:
    """The specimen value ``name`` (gauge_length_mm, cross_section_mm2) from an instrument's lines above the table
    (``Gauge Length (mm),50``, ``Area: 12 mm^2``), in bpmid's unit, with the line it came from (for the output's
    record); None when no such line. A line whose unit is not stated or not a length (an area) is refused, naming it
    and the form that reads: units are never guessed. Lines that disagree are refused too."""
    found = []
    for key, raw in meta.items():
        m = re.match(r"^(.*?)_*[(\[]([^)\]]*)[)\]]$", key)
        base, unit = (m.group(1), m.group(2)) if m else (key, None)
        if _SPECIMEN_KEYS.get(base.strip("_")) != name:
            continue
        value = str(raw).strip()
        v = re.match(r"^([-+]?(?:\d+[.,]?\d*|[.,]\d+)(?:[eE][-+]?\d+)?)\s*(.*)$", value)
        line = meta_lines.get(key)
        said = f"the line {line}" if line else "a line above the table"
        units = _SPECIMEN_UNITS[name]
        form = f"'# {name}: <value>'"
        words, bpmid_unit = ("gauge length", "mm") if name == "gauge_length_mm" else ("cross-section", "mm^2")
        if v is None:
            raise InputError(f"{said} states the specimen's {words} as {value!r}, not a number; write it as a "
                             f"number, or as a line {form}", path=path, line=line, key=key)
        number = float(v.group(1).replace(",", "."))
        stated = [x.strip().lower().replace(" ", "") for x in (unit, v.group(2)) if x and x.strip()]
        u = stated[0] if stated else None
        if u is None or u not in units or len(set(stated)) > 1:
            what = "states no unit" if u is None else (
                f"states it in {' and '.join(stated)}" if len(set(stated)) > 1 else
                f"states it in {u!r}, which bpmid does not read here")
            raise InputError(f"{said} gives the specimen's {words} ({value}) but {what}; units are never guessed: "
                             f"state it in {bpmid_unit} as a line {form}, or with its unit in brackets (known: "
                             f"{', '.join(units)}), or set relax.specimen.{name} in the config", path=path,
                             line=line, key=key)
        found.append((number * units[u], key, line))
    if not found:
        return None
    if len({round(v, 9) for v, _k, _l in found}) > 1:
        said = ", ".join(f"{k} = {v:g} (line {ln})" for v, k, ln in found)
        raise InputError(f"the lines above the table give the specimen's {name} twice and they disagree ({said}); "
                         f"keep one", path=path, line=found[-1][2], key=found[-1][1])
    value, key, line = found[0]
    return value, f"file line {line} ({key})" if line else f"file header ({key})"


def _specimen_value(name: str, cfg_value: float | None, meta: dict, path: Path, *, meta_lines: dict | None = None,
                    source: dict | None = None, required: bool = True) -> float | None:
    """The specimen's ``name``: from the config, a ``# name:`` line, or an instrument's line above the table
    (:func:`_instrument_specimen`, its lines in ``meta_lines``); the file's and the config's must agree. Where it came
    from goes into ``source[name]`` when given. Not ``required`` (a file whose strain and stress are read): None when
    nothing states it, an instrument's line it cannot read included."""
    file_value = meta.get(name)
    said = "file header"
    if file_value is not None:
        try:
            file_value = float(file_value)
        except ValueError:
            raise InputError(f"'# {name}:' must be a number, found {file_value!r}", path=path, key=name) from None
    else:
        try:
            got = _instrument_specimen(name, meta, meta_lines or {}, path)
        except InputError:
            if cfg_value is None and required:
                raise
            got = None   # the config states it, or it is not needed: a line it cannot read is no reason to refuse
        if got is not None:
            file_value, said = got
    if file_value is not None and not (np.isfinite(file_value) and file_value > 0):
        raise InputError(f"'# {name}:' must be positive, found {file_value:g}", path=path, key=name)
    if cfg_value is not None and file_value is not None and not np.isclose(cfg_value, file_value, rtol=1e-9):
        raise InputError(f"the file says {name} = {file_value:g}, the config relax.specimen.{name} says "
                         f"{cfg_value:g}", path=path, key=name)
    value = cfg_value if cfg_value is not None else file_value
    if value is None and not required:
        return None
    if value is None:
        raise InputError(f"a load/extension log needs the specimen's {name}: set relax.specimen.{name} in the "
                         f"config or add a line '# {name}: <value>' to the file", path=path,
                         key=f"relax.specimen.{name}")
    if source is not None:
        source[name] = "config relax.specimen" if cfg_value is not None else said
    return float(value)


#: a file's strain and stress agree with its extension and load over the stated specimen within this share
#: (the machine's rounding of its columns is far below it; a wrongly entered specimen is far above)
PAIRS_AGREE_SHARE = 0.01


def _implied(num: np.ndarray, den: np.ndarray) -> float:
    """The median of num / den where den is at least a fifth of its peak (the ramp's top and the hold)."""
    peak = float(np.max(np.abs(den))) if den.size else 0.0
    k = np.abs(den) >= 0.2 * peak if peak > 0 else np.zeros(den.size, bool)
    return float(np.median(num[k] / den[k])) if k.any() else float("nan")


def _check_both_pairs(table, path: Path, gauge_length_mm, cross_section_mm2) -> dict:
    """A file with strain and stress and also extension and load: the strain and stress are read (the machine's
    own), and where the specimen is stated (config or file) the two pairs must agree over it, else the file is
    refused (one of them rests on a wrongly entered specimen, and which one is the user's to say). Returns what the
    reading records of the check."""
    strain, stress = table.columns["strain"], table.columns["stress"]
    ext, load = table.columns["extension"], table.columns["load"]
    L_implied = _implied(ext, strain)          # mm: the gauge length the machine's strain was computed with
    A_implied = _implied(load, stress)         # mm^2: N / MPa
    given, came = {}, {}
    for name, cfg_value in (("gauge_length_mm", gauge_length_mm), ("cross_section_mm2", cross_section_mm2)):
        value = _specimen_value(name, cfg_value, table.meta, path, meta_lines=table.meta_lines, source=came,
                                required=False)
        if value is not None:
            given[name] = value
    heads = {q: table.headers.get(q, q) for q in ("strain", "stress", "extension", "load")}
    record = {"columns": [heads["extension"], heads["load"]], "used": False,
              "implied_specimen": {"gauge_length_mm": round(L_implied, 6), "cross_section_mm2": round(A_implied, 6)}}
    if not given:
        record["note"] = ("strain and stress read; extension and load not used (no specimen stated to check them "
                          "against)")
        return record
    bad = []
    for name, implied, what in (("gauge_length_mm", L_implied, f"{heads['extension']!r} / {heads['strain']!r}"),
                                ("cross_section_mm2", A_implied, f"{heads['load']!r} / {heads['stress']!r}")):
        if name in given and np.isfinite(implied) and abs(implied / given[name] - 1.0) > PAIRS_AGREE_SHARE:
            bad.append(f"{what} gives {name} = {implied:.4g}, the specimen says {given[name]:g}")
    if bad:
        where = "; ".join(dict.fromkeys(came.values()))   # where the specimen came from: the config, the file's lines
        raise InputError("the file has both strain/stress and extension/load columns, and they disagree: "
                         + "; ".join(bad) + f" ({where}). One pair rests on a wrongly entered specimen: correct the "
                         "specimen to the one tested, or delete the wrong pair's columns from the file",
                         path=path, key=heads["strain"])
    record["note"] = (f"strain and stress read; extension and load agree with them over the stated specimen within "
                      f"{PAIRS_AGREE_SHARE:.0%}")
    return record


def _check_tension(values: np.ndarray, table, path: Path, what: str, unit: str) -> None:
    """Refuse a test log whose strain (or extension) goes clearly below zero, naming the first such line."""
    peak = float(np.max(np.abs(values))) if values.size else 0.0
    bad = np.flatnonzero(values < -NEG_STRAIN_SHARE * peak) if peak > 0 else np.zeros(0, int)
    if bad.size:
        i = int(bad[0])
        raise InputError(f"negative {what} {values[i]:g}{unit}: a relaxation test is a tension test, so {what} must be "
                         f">= 0 (log a compression test with compression positive, in {what} and stress alike)",
                         path=path, line=table.line_of(i), key=table.headers.get(
                             "strain" if what == "strain" else "extension"))




def _table_options(column_map, io_cfg) -> tuple[dict, str | None]:
    """read_table keywords from the relax column map and the io section (the relax map wins per header), and the
    header the map names as the test temperature (``T=Chamber (°C)``: set aside by the table reader, where a ``T``
    would be read as time, and checked by :func:`check_one_temperature`)."""
    cmap = dict(io_cfg.columns) if io_cfg is not None else {}
    cmap.update(column_map or {})
    temp = next((h for h, v in cmap.items() if _base_role(_split_unit(str(v))[0]) == "T"), None)
    cmap = {h: v for h, v in cmap.items() if h != temp}
    if io_cfg is None:
        return {"column_map": cmap}, temp
    return ({"column_map": cmap, "units": io_cfg.units, "unit_sources": io_cfg.unit_sources(), "sheet": io_cfg.sheet},
            temp)


def read_relax_log(path: str | Path, *, column_map: Mapping[str, str] | None = None,
                   gauge_length_mm: float | None = None, cross_section_mm2: float | None = None,
                   gap_factor: float | None = None, io_cfg=None) -> RelaxLog:
    """Read one relaxation log (see the module docstring).

    Parameters
    ----------
    path : the CSV file
    column_map : file header -> bpmid name, from the config (``relax.columns``)
    gauge_length_mm, cross_section_mm2 : specimen geometry for load/extension logs (mm, mm^2)
    gap_factor : a time step longer than this many median steps of a test log is refused as a gap (None: not
        checked; ``bpmid fit relax`` passes ``relax.max_gap_factor``, default ``io.max_gap_factor``)
    io_cfg : the config section ``io`` (:class:`bpmid.io.motion_logs.IOConfig`): units, sheet, column map and
        ``max_gap_s`` stated there or by the command-line flags
    """
    from bpmid.io.read_once import read_once

    path = Path(path)
    return read_once("relaxation log", path, (repr(column_map), gauge_length_mm, cross_section_mm2, gap_factor,
                                              repr(io_cfg)),
                     lambda: _read_relax_log(path, column_map, gauge_length_mm, cross_section_mm2, gap_factor, io_cfg))


def _read_relax_log(path: Path, column_map, gauge_length_mm, cross_section_mm2, gap_factor, io_cfg) -> RelaxLog:
    opts, temp_column = _table_options(column_map, io_cfg)
    table = read_table(path, kind=KIND, optional=("time",), **opts)
    if table.has("modulus"):
        need = ("time", "modulus")
    elif table.has("strain") and table.has("stress"):
        need = ("time", "strain", "stress")
    elif table.has("load") and table.has("extension"):   # a lone machine strain (or stress) beside them is unused
        need = ("time", "extension", "load")
    elif table.has("strain") or table.has("stress"):
        need = ("time", "strain", "stress")
    elif table.has("load") or table.has("extension"):
        need = ("time", "extension", "load")
    else:
        found = ", ".join(repr(h) for h in table.headers.values()) or "none bpmid knows"
        raise InputError("no relaxation columns: expected time_s with strain and stress_mpa, or extension_mm and "
                         f"load_n, or modulus_mpa (recognised columns: {found}){table.map_note}", path=path,
                         line=max(table.first_data_line - 1, 1))
    if any(not table.has(q) for q in need):
        table = read_table(path, required=need, kind=KIND, **opts)  # raises, naming the column
    t = check_time(table, kind=KIND, gap_factor=None if need[1] == "modulus" else gap_factor,
                   max_gap_s=None if io_cfg is None or need[1] == "modulus" else io_cfg.max_gap_s)
    temperature = _test_temperature(table, path, temp_column)   # first: it may add a warning
    common = dict(name=path.stem, time_s=t, path=path, meta=dict(table.meta), first_data_line=table.first_data_line,
                  reading=dict(table.reading), warnings=list(table.warnings), temperature=temperature)
    if need[1] == "modulus":
        E = table.columns["modulus"]
        bad = np.flatnonzero(E < 0)
        if bad.size:
            raise InputError(f"negative relaxation modulus {E[bad[0]]:g} MPa (a modulus curve must be >= 0)",
                             path=path, line=table.line_of(int(bad[0])))
        return RelaxLog(modulus_mpa=E, source="modulus", **common)
    if need[1] == "strain":
        _check_tension(table.columns["strain"], table, path, "strain", "")
        if table.has("load") and table.has("extension"):
            common["reading"]["load_extension"] = _check_both_pairs(table, path, gauge_length_mm, cross_section_mm2)
        return RelaxLog(strain=table.columns["strain"], stress_mpa=table.columns["stress"], source="stress-strain",
                        **common)
    _check_tension(table.columns["extension"], table, path, "extension", " mm")
    came: dict = {}
    L0 = _specimen_value("gauge_length_mm", gauge_length_mm, table.meta, path, meta_lines=table.meta_lines,
                         source=came)
    A0 = _specimen_value("cross_section_mm2", cross_section_mm2, table.meta, path, meta_lines=table.meta_lines,
                         source=came)
    # what turned load and extension into stress and strain, and where it came from (the output records it)
    common["reading"]["specimen"] = {"gauge_length_mm": L0, "cross_section_mm2": A0, "from": came}
    return RelaxLog(strain=table.columns["extension"] / L0, stress_mpa=table.columns["load"] / A0,
                    source="load-extension", **common)


_F_UNITS = frozenset({"f", "°f", "degf", "deg f", "fahrenheit"})


def _f_to_c(v: float) -> float:
    """Degrees F to C, for comparing the test temperatures of logs only (material files refuse F)."""
    return (v - 32.0) * 5.0 / 9.0


#: temperature columns of the machine, not of the specimen (a motor's, the oil's, the room's): never the test's
_NOT_THE_SPECIMEN = re.compile(r"motor|oil|drive|electronic|cpu|board|room|amplifier|coolant", re.IGNORECASE)


def _temperature_values(table, chosen: str | None = None) -> tuple[np.ndarray, str | None, str] | None:
    """(values, unit, header) of a log's test-temperature column: the one the column map names, else a set-aside
    column whose name is a temperature (``Temperature (°C)``, ``T [K]``, ``Chamber temp (°F)``). The values are in C
    for C, K and F, and as written (unit None) for a column whose unit is not stated or not known."""
    chosen = chosen if chosen in table.ignored_cells else None  # a map for other files names a column not here
    for h, (cells, unit) in table.ignored_cells.items():
        role, named = _mat_role(h)
        if h != chosen and (chosen is not None or (role != "T" and "temp" not in h.lower())
                            or _NOT_THE_SPECIMEN.search(h)):
            continue
        unit = _unit_cell(named or _unit_in_name(h, "T", also=_F_UNITS) or unit or "").strip().lower()
        vals = cell_numbers(cells)
        vals = vals[np.isfinite(vals)]
        if not vals.size:
            continue
        if unit in _MAT_UNITS["T"] and unit:
            return vals + _MAT_UNITS["T"][unit], "C", h
        if unit in _F_UNITS:
            return _f_to_c(vals), "C", h
        return vals, None, h
    return None


def _test_temperature(table, path: Path, chosen: str | None = None) -> tuple[float, str | None, str] | None:
    """(mean, unit, header) of a log's test-temperature column (:func:`_temperature_values`); refused when the
    temperature moves by more than :data:`SET_T_SPAN_C` during the test (between its 1st and 99th percentiles, so
    that a glitch of a sample or two does not count): the test is then not at one temperature."""
    got = _temperature_values(table, chosen)
    if got is None:
        return None
    vals, unit, h = got
    # a rolling median over a few samples first: a glitch or an open thermocouple for a moment is no change
    w = int(min(max(5, vals.size // 50), 101)) | 1
    if vals.size < w:
        smooth = vals
    else:
        from scipy.ndimage import median_filter

        smooth = median_filter(vals, size=w, mode="nearest")
    lo, hi = np.percentile(smooth, [1.0, 99.0])
    mid = float(np.median(vals))
    away = np.abs(smooth - mid) > SET_T_SPAN_C
    edge = max(1, vals.size // 10)
    if hi - lo > SET_T_SPAN_C and away.mean() < 0.1 and \
            abs(float(np.median(vals[:edge])) - float(np.median(vals[-edge:]))) <= SET_T_SPAN_C:
        # a brief excursion that comes back (an open thermocouple for a moment): said, read at the log's level
        k = int(np.flatnonzero(away)[0])
        c = " C" if unit == "C" else ""
        table.warnings.append(f"{path.name}: the temperature in column {h!r} leaves {mid:.3g}{c} for "
                              f"{int(away.sum())} of {vals.size} samples (to {float(vals[k]):.4g}{c} at sample {k}) "
                              "and comes back: a sensor fault? The log is read at its steady temperature")
        return float(np.median(vals)), unit, h
    if hi - lo > SET_T_SPAN_C:
        c = " C" if unit == "C" else ""
        how = "" if unit == "C" else " (a column without a unit of C, K or F is read as written)"
        raise InputError(f"the temperature in column {h!r} moves from {lo:.3g}{c} to {hi:.3g}{c} during the test, "
                         f"more than {SET_T_SPAN_C:g} C{how}: a ramp-and-hold fit takes each log at one temperature; "
                         "cut the log to the part at one temperature, or fit a master curve from relaxation modulus "
                         "curves (t, E_relax, T) or frequency sweeps with their temperatures", path=path, key=h)
    return float(np.mean(vals)), unit, h


def check_one_temperature(logs: Sequence[RelaxLog]) -> None:
    """Refuse test logs whose temperature columns differ by more than :data:`SET_T_SPAN_C`: a ramp-and-hold fit
    pools its logs as one material at one temperature (time-temperature superposition is for modulus curves).
    Columns without a unit bpmid reads are compared as written."""
    temps = [(lg, lg.temperature) for lg in logs if lg.temperature is not None]
    if len(temps) < 2:
        return
    known = all(u == "C" for _, (_, u, _) in temps)
    vals = [(lg, T) for lg, (T, _, _) in temps]
    lo, hi = min(vals, key=lambda p: p[1]), max(vals, key=lambda p: p[1])
    if hi[1] - lo[1] > SET_T_SPAN_C:
        said = ", ".join(f"{lg.path.name if lg.path else lg.name} {T:.3g}{' C' if u == 'C' else ''} ({h!r})"
                         for lg, (T, u, h) in temps)
        how = "" if known else " (a column without a unit of C, K or F is compared as written)"
        raise InputError(f"the logs were tested at different temperatures ({said}){how}: a ramp-and-hold fit pools "
                         "its logs as one material at one temperature, so fit each temperature on its own; for a "
                         "master curve, give relaxation modulus curves (t, E_relax, T) or frequency sweeps with their "
                         "temperatures", path=hi[0].path, key="T")


def read_relax_logs(paths: Sequence[str | Path], *, column_map: Mapping[str, str] | None = None,
                    gauge_length_mm: float | None = None, cross_section_mm2: float | None = None,
                    gap_factor: float | None = None, io_cfg=None) -> list[RelaxLog]:
    """Read several relaxation logs (same options for each)."""
    if not paths:
        raise InputError("no relaxation logs given")
    logs = [read_relax_log(p, column_map=column_map, gauge_length_mm=gauge_length_mm,
                           cross_section_mm2=cross_section_mm2, gap_factor=gap_factor, io_cfg=io_cfg) for p in paths]
    check_one_temperature(logs)
    return logs
