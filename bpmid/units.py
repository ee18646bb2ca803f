"""Unit constants and conversions: the one home of every factor bpmid uses at its boundaries.

Inside, bpmid works in SI (Pa gauge, s, rad or deg for angles as named). Values cross the boundary (files,
the command line, the public API) with their unit stated; this module turns them into SI and back.
Import cost: none beyond the standard library.
"""
from __future__ import annotations

import re

#: Pa in one bar
PA_PER_BAR = 1e5
#: Pa in one kPa, one MPa, one mbar, one psi
PA_PER_KPA = 1e3
PA_PER_MPA = 1e6
PA_PER_MBAR = 1e2
PA_PER_PSI = 6894.757293168
#: standard atmosphere (Pa): the default ambient pressure turning absolute into gauge pressure
ATMOSPHERE_PA = 101325.0

#: pressure unit name (lower case) -> Pa per unit: the one list every reader of a pressure unit takes (a log's
#: header, ``--pressure-unit``, ``io.units``, :func:`bpmid.from_arrays`)
PRESSURE_UNITS: dict[str, float] = {"pa": 1.0, "hpa": 1e2, "kpa": PA_PER_KPA, "bar": PA_PER_BAR,
                                    "mbar": PA_PER_MBAR, "mpa": PA_PER_MPA, "psi": PA_PER_PSI}
#: pressure references a value can be given in
PRESSURE_REFERENCES = ("gauge", "absolute")
#: a reference written after a pressure unit (``psig``, ``bar(a)``, ``kPa abs``) -> the reference
PRESSURE_REF_SUFFIXES = {"a": "absolute", "abs": "absolute", "absolute": "absolute", "g": "gauge", "gauge": "gauge",
                         "gage": "gauge", "rel": "gauge", "relative": "gauge"}
#: a pressure unit with the reference it may carry, written without spaces, brackets, points or dashes
PRESSURE_UNIT_REF = re.compile(r"^(" + "|".join(sorted(PRESSURE_UNITS, key=len, reverse=True)) + r")("
                               + "|".join(sorted(PRESSURE_REF_SUFFIXES, key=len, reverse=True)) + r")?$")


def split_pressure_unit(unit) -> tuple[str | None, str | None]:
    """A pressure unit as written -> (key of :data:`PRESSURE_UNITS`, reference it carries or None); (None, None)
    for a spelling that is no pressure unit. ``'psig'`` -> ``('psi', 'gauge')``, ``'bar(a)'`` -> ``('bar',
    'absolute')``, ``'kPa abs'`` -> ``('kpa', 'absolute')``, ``'hPa'`` -> ``('hpa', None)``."""
    m = PRESSURE_UNIT_REF.match(re.sub(r"[\s()\[\]._\-]+", "", str(unit).strip().lower()))
    if m is None:
        return None, None
    return m.group(1), (PRESSURE_REF_SUFFIXES[m.group(2)] if m.group(2) else None)
#: angle unit -> degrees per unit
ANGLE_UNITS: dict[str, float] = {"deg": 1.0, "rad": 57.29577951308232}
#: time unit -> seconds per unit
TIME_UNITS: dict[str, float] = {"s": 1.0, "ms": 1e-3, "min": 60.0}
#: a modulus's unit in a parameter file (lower case) -> Pa
MODULUS_UNITS: dict[str, float] = {"pa": 1.0, "kpa": PA_PER_KPA, "mpa": PA_PER_MPA, "gpa": 1e9}


#: ``mPa`` as written: the millipascal, which no log of a muscle or a rubber is in; bpmid reads units without regard
#: to case (``stress_mpa`` is the megapascal), so this one spelling is refused rather than read as ``MPa``
_MILLIPASCAL = re.compile(r"(?<![A-Za-z])mPa(?![A-Za-z])")


def millipascal_slip(text) -> str | None:
    """A message when ``text`` (a header cell, a units-row cell or a stated unit) writes ``mPa``, else None.

    ``mPa`` is the millipascal (1e-3 Pa); read without regard to case it would be taken for the megapascal (1e6 Pa),
    a factor of 1e9. bpmid never guesses which was meant.
    """
    if text is None or not _MILLIPASCAL.search(str(text)):
        return None
    said = "'mPa' is" if str(text).strip() == "mPa" else f"{str(text).strip()!r} states 'mPa',"
    return (f"{said} the millipascal (1e-3 Pa), a factor of 1e9 from MPa (the megapascal); "
            f"bpmid does not guess which is meant: write MPa (or N/mm^2) if the values are megapascals, or give them "
            f"in Pa, kPa or bar")


def pa_per(unit: str, *, what: str = "pressure_unit") -> float:
    """Pa per ``unit`` (``"bar"``, ``"kPa"``, ``"Pa"``, ``"MPa"``, ``"mbar"``, ``"psi"``; case-insensitive).

    Raises
    ------
    bpmid.errors.InputError
        For an unknown unit (naming the known ones) or a missing one.
    """
    from bpmid.errors import InputError

    if unit is None:
        raise InputError(f"no pressure unit given: state it ({', '.join(PRESSURE_UNITS)})", key=what)
    if (slip := millipascal_slip(unit)) is not None:
        raise InputError(slip, key=what)
    key = str(unit).strip().lower()
    if key not in PRESSURE_UNITS:
        raise InputError(f"unknown pressure unit {unit!r} (known: {', '.join(PRESSURE_UNITS)})", key=what)
    return PRESSURE_UNITS[key]


def to_gauge_pa(values, unit: str, reference: str, *, atmosphere_pa: float = ATMOSPHERE_PA):
    """Pressure values in ``unit`` and ``reference`` (``"gauge"`` or ``"absolute"``) -> gauge Pa (numpy array)."""
    import numpy as np

    from bpmid.errors import InputError

    if reference not in PRESSURE_REFERENCES:
        raise InputError(f"pressure reference must be gauge or absolute, found {reference!r}", key="reference")
    pa = np.asarray(values, float) * pa_per(unit)
    return pa - atmosphere_pa if reference == "absolute" else pa


__all__ = ["PA_PER_BAR", "PA_PER_KPA", "PA_PER_MPA", "PA_PER_MBAR", "PA_PER_PSI", "ATMOSPHERE_PA",
           "PRESSURE_UNITS", "PRESSURE_REFERENCES", "ANGLE_UNITS", "TIME_UNITS", "millipascal_slip", "pa_per",
           "split_pressure_unit",
           "to_gauge_pa"]
