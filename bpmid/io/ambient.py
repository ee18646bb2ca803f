"""The ambient pressure an absolute pressure log is turned into gauge with: from a column of the log, a line of the
file, or ``io.atmosphere_pa``; never guessed, and a statement bpmid cannot read is said, not passed over.

- a column: ``Ambient pressure (kPa)``, ``Barometric pressure (hPa)``, ``p_amb`` (the reader's quantity ``ambient``,
  subtracted sample by sample);
- a line (metadata keys, spaces as underscores, lower case), optionally with a unit in the key:
  ``atmosphere_pa: 84000``, ``Ambient pressure: 840 mbar``, ``Ambient pressure [kPa]: 98.2``, ``Luftdruck: 986 hPa``;
- keys that may state something else (``Ambient: 21 C``, ``Atmosphere: air, 45 %RH``, ``Room pressure: +5 Pa``) are
  read only as a pressure an ambient pressure can have, 50-120 kPa;
- ``Air pressure`` may be the ambient pressure or the supply: a line in that range is refused with the question;
- a line under a key that mentions the ambient pressure in a spelling not read here is reported as a warning.
"""
from __future__ import annotations

import re
from typing import Optional

import numpy as np

from bpmid.errors import InputError
from bpmid.io.tables import UNITS, split_unit
from bpmid.units import ATMOSPHERE_PA

#: the ambient pressures a lab can have (Pa): a stated value outside is a unit slip or not the ambient pressure
AMBIENT_RANGE_PA = (50e3, 120e3)

#: keys that state the ambient pressure (the longest matched first), optionally with a unit suffix; not
#: 'air_pressure', which on a pneumatic rig is as often the supply
_KEYS = ("atmosphere", "atmospheric_pressure", "ambient_pressure", "barometric_pressure", "umgebungsdruck", "luftdruck",
         "ambient", "barometer", "barometer_reading", "p_amb", "p_atm", "p_ambient", "p_baro", "atm", "room_pressure",
         "lab_pressure")
_KEY = re.compile(r"^(" + "|".join(sorted(_KEYS, key=len, reverse=True)) + r")(?:_?[\(\[]?([a-z]+)[\)\]]?)?$")
#: keys that may state something else: read only as a pressure in AMBIENT_RANGE_PA, else left alone
_SOFT = {"atmosphere", "ambient", "barometer", "barometer_reading", "atm", "room_pressure", "lab_pressure", "luftdruck"}
#: keys that may be the ambient pressure or the supply: asked when their value could be an ambient pressure
_AMBIGUOUS = re.compile(r"^(?:air_pressure)(?:_?[\(\[]?[a-z]+[\)\]]?)?$")
#: a key that mentions the ambient pressure, in any spelling (for the warning)
_WORDS = re.compile(r"atmos|ambient|umgebung|baro|luftdruck|p_?amb|p_?atm|(?:^|_)atm(?:$|_|\.)|room_pressure|"
                    r"lab_pressure", re.IGNORECASE)
#: a value that reads as a pressure: a number with a pressure unit (bpmid's or another), or a bare number
_PRESSURE_VALUE = re.compile(r"^[^A-Za-z]*\d[^A-Za-z]*$|\d\s*(?:pa|hpa|kpa|mpa|mbar|bar|psi|inhg|mmhg|torr|atm)\b",
                             re.IGNORECASE)
#: a number and its unit ('840 mbar', '98,2', '1013(hPa)')
_VALUE_UNIT = re.compile(r"^\s*([+-]?(?:\d+[.,]?\d*|[.,]\d+)(?:[eE][+-]?\d+)?)\s*\(?([A-Za-z]*)\)?\s*$")


def _in_range(pa) -> bool:
    return AMBIENT_RANGE_PA[0] <= pa <= AMBIENT_RANGE_PA[1]


def _value_pa(value: str, key_unit: Optional[str]) -> tuple[bool, Optional[float]]:
    """(whether ``value`` is a number with at most a unit, the value in Pa or None when no pressure unit is given in
    the value or by the key)."""
    vm = _VALUE_UNIT.match(str(value))
    if vm is None:
        return False, None
    unit = vm.group(2) or key_unit
    u = split_unit("pressure", unit)[0] if unit else None
    return True, (float(vm.group(1).replace(",", ".")) * UNITS["pressure"][u] if u else None)


def ambient_pressure(table, configured_pa: float, stated_by: Optional[str] = None) -> tuple[float | np.ndarray, str]:
    """The ambient pressure (Pa; an array when the log has a column of it) and where it came from, for an absolute
    log read into ``table`` (:class:`bpmid.io.tables.Table`). ``configured_pa`` is ``io.atmosphere_pa``; it counts as
    a statement when a flag gave it (``stated_by``) or it differs from the standard atmosphere. Every statement
    must agree within 0.1 kPa; a value outside 50-120 kPa, or a number without a pressure unit under a key that
    only states the ambient pressure, is refused with its line."""
    cfg_src = stated_by or ("io.atmosphere_pa (config)" if configured_pa != ATMOSPHERE_PA else None)
    if "ambient" in table.deferred:
        raise table.deferred["ambient"]   # the log's ambient-pressure column, needed now, cannot be read
    found: list[tuple[float | np.ndarray, str, Optional[int]]] = []
    if "ambient" in table.columns:
        found.append((np.asarray(table.columns["ambient"], float), f"the column {table.headers['ambient']!r}", None))
    for k, v in table.meta.items():
        m = _KEY.match(k)
        if not m or (m.group(2) and split_unit("pressure", m.group(2))[0] is None) or not re.search(r"\d", str(v)):
            continue   # another key ('atmosphere_type'), or no number ('atmosphere: nitrogen')
        line = table.meta_lines.get(k)
        is_number, pa = _value_pa(v, m.group(2))
        if m.group(1) in _SOFT and (pa is None or not _in_range(pa)):
            continue   # 'Ambient: 21 C', 'Room pressure: +5 Pa': not the ambient pressure as such (warned below)
        if pa is None:
            raise InputError(f"the line '{k}: {v}' states the ambient pressure, but bpmid cannot read it as a number "
                             f"with a pressure unit ({', '.join(sorted(UNITS['pressure']))}); write it so, as in "
                             f"'atmosphere_pa: 101325' or 'ambient_pressure: 1013 mbar'", path=table.name, line=line,
                             key=k)
        found.append((pa, f"line {line} ({k}: {v})" if line else f"the line '{k}: {v}'", line))
    for val, src, line in found:
        arr = np.atleast_1d(val)
        bad = np.flatnonzero(~((arr >= AMBIENT_RANGE_PA[0]) & (arr <= AMBIENT_RANGE_PA[1])))
        if bad.size:
            k = int(bad[0])
            raise InputError(f"{src} gives an ambient pressure of {arr[k]:g} Pa, which is not an ambient pressure "
                             f"(50-120 kPa): check its unit", path=table.name,
                             line=line if line is not None else table.line_of(k), key="atmosphere_pa")
    if cfg_src is not None:
        found.append((configured_pa, cfg_src, None))
    if not found:
        for k, v in table.meta.items():
            pa = _value_pa(v, None)[1] if _AMBIGUOUS.match(k) else None
            if pa is not None and _in_range(pa):   # 'Air pressure: 0.98 bar'; '6 bar' is the supply's
                raise InputError(f"the line '{k}: {v}' may be the ambient pressure or the supply, and this absolute "
                                 f"log needs the ambient pressure: if it is the ambient pressure, write the line "
                                 f"'ambient_pressure: {v}'; if not, give the ambient pressure with io.atmosphere_pa "
                                 f"(Pa) in the config", path=table.name, line=table.meta_lines.get(k), key=k)
        return configured_pa, "io.atmosphere_pa (the standard atmosphere; set it for your lab)"
    first, first_src, _ = found[0]
    for val, src, _ in found[1:]:
        if np.max(np.abs(np.asarray(first, float) - np.asarray(val, float))) > 100.0:
            raise InputError(f"the ambient pressure is stated twice and disagrees: {first_src} gives "
                             f"{np.mean(first):.6g} Pa, {src} gives {np.mean(val):.6g} Pa; drop or correct one",
                             path=table.name, key="atmosphere_pa")
    return first, first_src


def unread_ambient_lines(table, used_pa: float) -> list[str]:
    """A warning for the first line that reads like a pressure under a key mentioning the ambient pressure, when the
    log was turned into gauge with ``used_pa`` (io.atmosphere_pa) because no statement was read."""
    unread = [k for k, v in table.meta.items() if _WORDS.search(k) and _PRESSURE_VALUE.search(str(v))]
    if not unread:
        return []
    k = unread[0]
    ln = table.meta_lines.get(k)
    return [f"{table.name}{f':{ln}' if ln else ''}: the line '{k}: {table.meta[k]}' may state the ambient pressure, "
            f"which bpmid does not read in that form: the absolute pressure was turned into gauge with {used_pa:g} Pa; "
            f"if the line is the ambient pressure, write it 'ambient_pressure: 98.2 kPa' (its value and unit) or set "
            f"io.atmosphere_pa"]


def atmosphere_line(log) -> str:
    """``'# atmosphere_pa: 98500\\n'`` for an absolute log (:class:`bpmid.io.motion_logs.MotionLog`) read against
    another ambient pressure than the standard one, so that a file written from it reads back the same; else ``''``."""
    if log.pressure_reference != "absolute" or abs(float(log.atmosphere_pa) - ATMOSPHERE_PA) < 1e-9:
        return ""
    return f"# atmosphere_pa: {float(log.atmosphere_pa):.10g}\n"
