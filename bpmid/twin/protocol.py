"""Protocol files: what the test rig does, in the experimenter's terms (schema ``bpmid.protocol/1``).

A protocol is a YAML mapping. Unknown keys are refused with their dotted path (``logs[0].program[2].
triangle.rat``); so are negative rates or durations and levels outside the model's range.

Top level
---------
- ``schema``: ``bpmid.protocol/1`` (optional)
- ``kind``: ``motion`` (pressure program -> motion logs), ``reference`` (angle program -> reference
  signals ``time_s, angle_deg`` for control), ``relaxation`` (ramp-and-hold tensile tests; the block
  ``relaxation`` is :class:`bpmid.twin.relaxation_protocol.RelaxationSpec`)
- ``name``, ``description``: text for the manifest
- ``seed`` (int, default 0): the seed when ``--seed`` is not given
- ``sampling_hz`` (default 10): logging rate
- ``unit``: ``bar`` (motion, default) or ``kpa``; ``deg`` for reference signals. Every level, limit and rate in
  the programs is in this unit (rates in unit/s)
- ``pressure_reference``: ``absolute`` (default) or ``gauge``; ``atmosphere_bar`` (default 1.01325)
- ``replicates`` (default 1): every log is run this many times (files ``<name>_r<k>.csv``), each replicate with
  its own draw of the constants (``plant.variation``) and of the sensor errors
- ``logs``: a list of ``{name, start, program, replicates}``; ``start`` is the level at t = 0 (the muscle is
  relaxed there); ``program`` a list of segments, each a one-key mapping:

  - ``hold: {duration_s, level}``: stay (or jump to ``level``) for ``duration_s``
  - ``ramp: {to, rate | duration_s}``: linear change to ``to``
  - ``step: {to, hold_s, slew}``: change to ``to`` at the slew limit ``slew`` (unit/s; omitted: a jump), then
    hold for ``hold_s``
  - ``triangle: {low, high, rate, cycles}``: ramp to ``low`` at ``rate`` if not there, then ``cycles`` times
    low -> high -> low at +-``rate``
  - ``sawtooth: {low, high, period_s, cycles, fall_s}``: rise low -> high over ``period_s``, fall back over
    ``fall_s`` (default 0: a jump)
  - ``sine: {mean, amplitude, frequency_hz, cycles, slew}``: mean + amplitude sin(2 pi f t), starting at ``mean``:
    from another level it first changes to ``mean`` at the slew limit ``slew`` (unit/s; omitted: a jump, as ``step``)
  - ``repeat: {times, program}``: a sub-program run ``times`` times
- ``plant`` (motion): ``material`` (``paper_fit`` or ``paper_mat``; ``--params`` overrides), ``closure``,
  ``effects`` (the rig's own physics: ``{id: {parameter or setting: value}}``), ``variation``
  (``modulus_cv``, ``tau_cv``: replicate-to-replicate log-normal spread of the constants), ``integration``
  (``continuous``, default: the muscle runs on internal steps of at most ``max_step_s``, default 0.001 s, and is
  logged at ``sampling_hz``, so what is logged does not depend on the logging rate, as for a real muscle;
  ``log_rate``: the muscle runs at the logging rate, the discrete model a fit at that rate uses, as bpmid's twin
  did before 2026-11-28). A motion fit given with ``--params`` is run, in continuous time, as the muscle that acts as
  the fit did at its logs' step (each branch modulus times the continuous factor; the manifest says so)
- ``sensors`` (motion): see :class:`bpmid.twin.sensors.Sensors`
- ``effects`` (motion): catalogue effects to inject, ``{id: {parameter or setting: value}}`` (``--effect`` adds)
- ``blind`` (default false): the injected effects go to a separate answer, not the manifest (discovery demo):
  ``<out>_ANSWER.yaml`` beside the output folder, not in it, and the command recorded with ``--effect <hidden>``
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any, ClassVar, Literal, Mapping, Optional

import numpy as np

from bpmid.config import build_dataclass, read_yaml
from bpmid.errors import InputError
from bpmid.twin.relaxation_protocol import RelaxationSpec
from bpmid.twin.sensors import Sensors
from bpmid.units import PA_PER_BAR, PA_PER_KPA

SCHEMA = "bpmid.protocol/1"


def _key(where, k):
    """``where.k``, or ``k`` alone for a top-level key (``where`` empty: not ``.sampling_hz``)."""
    return f"{where}.{k}" if where else k


def _positive(where, path, **values):
    for k, v in values.items():
        if v is not None and not (math.isfinite(v) and v > 0):
            what = "must be positive" if math.isfinite(v) else "must be a finite positive number"
            raise InputError(f"{what}, found {v!r}", path=path, key=_key(where, k))


def _non_negative(where, path, **values):
    for k, v in values.items():
        if v is not None and not (math.isfinite(v) and v >= 0):
            what = "must not be negative" if math.isfinite(v) else "must be a finite number, not negative"
            raise InputError(f"{what}, found {v!r}", path=path, key=_key(where, k))


def _check_band(seg, where, path):
    """A segment that swings between ``low`` and ``high`` needs high above low."""
    if not seg.high > seg.low:
        raise InputError(f"high ({seg.high:g}) must be above low ({seg.low:g})", path=path, key=f"{where}.high")


# ---------------------------------------------------------------------------------------------
# program segments (levels in the protocol's unit, rates in unit/s)
# ---------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Hold:
    duration_s: float
    level: Optional[float] = None

    def validate(self, where, path):
        _non_negative(where, path, duration_s=self.duration_s)

    def levels(self):
        return {} if self.level is None else {"level": self.level}

    def pieces(self, t0, x0):
        x = x0 if self.level is None else self.level
        return [("lin", t0, t0 + self.duration_s, x, x)], t0 + self.duration_s, x


@dataclasses.dataclass(frozen=True)
class Ramp:
    to: float
    rate: Optional[float] = None
    duration_s: Optional[float] = None

    def validate(self, where, path):
        if (self.rate is None) == (self.duration_s is None):
            raise InputError("give exactly one of rate and duration_s", path=path, key=f"{where}.rate")
        _positive(where, path, rate=self.rate)
        _non_negative(where, path, duration_s=self.duration_s)

    def levels(self):
        return {"to": self.to}

    def pieces(self, t0, x0):
        d = self.duration_s if self.duration_s is not None else abs(self.to - x0) / self.rate
        return [("lin", t0, t0 + d, x0, self.to)], t0 + d, self.to


@dataclasses.dataclass(frozen=True)
class Step:
    to: float
    hold_s: float
    slew: Optional[float] = None

    def validate(self, where, path):
        _non_negative(where, path, hold_s=self.hold_s)
        _positive(where, path, slew=self.slew)

    def levels(self):
        return {"to": self.to}

    def pieces(self, t0, x0):
        out = []
        if self.slew is not None and self.to != x0:
            d = abs(self.to - x0) / self.slew
            out.append(("lin", t0, t0 + d, x0, self.to))
            t0 += d
        out.append(("lin", t0, t0 + self.hold_s, self.to, self.to))
        return out, t0 + self.hold_s, self.to


@dataclasses.dataclass(frozen=True)
class Triangle:
    low: float
    high: float
    rate: float
    cycles: int = 1

    def validate(self, where, path):
        _positive(where, path, rate=self.rate, cycles=self.cycles)
        _check_band(self, where, path)

    def levels(self):
        return {"low": self.low, "high": self.high}

    def pieces(self, t0, x0):
        out = []
        if x0 != self.low:
            d = abs(x0 - self.low) / self.rate
            out.append(("lin", t0, t0 + d, x0, self.low))
            t0 += d
        half = (self.high - self.low) / self.rate
        for _ in range(self.cycles):
            out.append(("lin", t0, t0 + half, self.low, self.high))
            out.append(("lin", t0 + half, t0 + 2 * half, self.high, self.low))
            t0 += 2 * half
        return out, t0, self.low


@dataclasses.dataclass(frozen=True)
class Sawtooth:
    low: float
    high: float
    period_s: float
    cycles: int = 1
    fall_s: float = 0.0

    def validate(self, where, path):
        _positive(where, path, period_s=self.period_s, cycles=self.cycles)
        _non_negative(where, path, fall_s=self.fall_s)
        _check_band(self, where, path)

    def levels(self):
        return {"low": self.low, "high": self.high}

    def pieces(self, t0, x0):
        out = []
        for _ in range(self.cycles):
            out.append(("lin", t0, t0 + self.period_s, self.low, self.high))
            t0 += self.period_s
            if self.fall_s > 0:
                out.append(("lin", t0, t0 + self.fall_s, self.high, self.low))
                t0 += self.fall_s
        return out, t0, (self.low if self.fall_s > 0 else self.high)


@dataclasses.dataclass(frozen=True)
class Sine:
    mean: float
    amplitude: float
    frequency_hz: float
    cycles: float = 1.0
    slew: Optional[float] = None

    def validate(self, where, path):
        _positive(where, path, frequency_hz=self.frequency_hz, cycles=self.cycles, slew=self.slew)
        _non_negative(where, path, amplitude=self.amplitude)

    def levels(self):
        return {"mean": self.mean}

    def pieces(self, t0, x0):
        out = []
        if self.slew is not None and self.mean != x0:
            d = abs(self.mean - x0) / self.slew
            out.append(("lin", t0, t0 + d, x0, self.mean))
            t0 += d
        d = self.cycles / self.frequency_hz
        end = self.mean + self.amplitude * math.sin(2 * math.pi * self.cycles)
        return out + [("sine", t0, t0 + d, self.mean, self.amplitude, self.frequency_hz)], t0 + d, end


@dataclasses.dataclass(frozen=True)
class Repeat:
    times: int
    program: tuple[Any, ...]

    def validate(self, where, path):
        _positive(where, path, times=self.times)

    def levels(self):
        return {}

    def pieces(self, t0, x0):
        out = []
        for _ in range(self.times):
            for seg in self.program:
                p, t0, x0 = seg.pieces(t0, x0)
                out.extend(p)
        return out, t0, x0


SEGMENTS: dict[str, type] = {"hold": Hold, "ramp": Ramp, "step": Step, "triangle": Triangle,
                             "sawtooth": Sawtooth, "sine": Sine, "repeat": Repeat}


def parse_program(raw, where: str, path) -> tuple:
    """A list of one-key mappings -> segment objects (``repeat`` recursively)."""
    if not isinstance(raw, (list, tuple)) or not raw:
        raise InputError("expected a non-empty list of segments", path=path, key=where)
    out = []
    for j, item in enumerate(raw):
        w = f"{where}[{j}]"
        if not isinstance(item, dict) or len(item) != 1:
            raise InputError(f"each segment is a one-key mapping ({', '.join(SEGMENTS)})", path=path, key=w)
        (kind, body), = item.items()
        if kind not in SEGMENTS:
            raise InputError(f"unknown segment type (known: {', '.join(SEGMENTS)})", path=path, key=f"{w}.{kind}")
        seg = build_dataclass(SEGMENTS[kind], body, f"{w}.{kind}", path)
        if kind == "repeat":
            seg = dataclasses.replace(seg, program=parse_program(seg.program, f"{w}.repeat.program", path))
        out.append((f"{w}.{kind}", seg))
    return tuple(out)


def _walk(program):
    """(key, segment) pairs, descending into repeats (a program stripped of its keys gives key None)."""
    for item in program:
        key, seg = item if isinstance(item, tuple) else (None, item)
        yield key, seg
        if isinstance(seg, Repeat):
            yield from _walk(seg.program)


def _strip(program):
    return tuple(dataclasses.replace(s, program=_strip(s.program)) if isinstance(s, Repeat) else s
                 for _k, s in program)


def render(program: tuple, start: float, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Sample a program at ``fs`` Hz from t = 0: times (s) and levels (the protocol's unit), shape (N,)."""
    _pieces, t_end, _x = Repeat(1, program).pieces(0.0, float(start))
    t = np.arange(int(math.floor(t_end * fs + 1e-9)) + 1) / fs
    return t, render_at(program, start, t)


def render_at(program: tuple, start: float, t: np.ndarray) -> np.ndarray:
    """A program's levels (the protocol's unit) at the times ``t`` (s from the program's start; past its end, the
    last piece's end level)."""
    pieces, _t_end, _x = Repeat(1, program).pieces(0.0, float(start))
    t = np.asarray(t, float)
    x = np.full(t.size, float(start))
    if not pieces:
        return x
    # one row per piece: kind (0 linear, 1 sine), t0, t1, a, b, f (linear: from a to b; sine: mean a, amplitude b)
    kind = np.array([0 if p[0] == "lin" else 1 for p in pieces])
    t0s = np.array([p[1] for p in pieces], float)
    t1s = np.array([p[2] for p in pieces], float)
    a = np.array([p[3] for p in pieces], float)
    b = np.array([p[4] for p in pieces], float)
    f = np.array([p[5] if p[0] != "lin" else 0.0 for p in pieces], float)
    idx = np.clip(np.searchsorted(t0s, t + 1e-9, side="right") - 1, 0, len(pieces) - 1)
    tl = np.minimum(t, t1s[idx]) - t0s[idx]
    span = t1s[idx] - t0s[idx]
    with np.errstate(invalid="ignore", divide="ignore"):
        lin = np.where(span > 0, a[idx] + (b[idx] - a[idx]) * tl / np.where(span > 0, span, 1.0), a[idx])
    sine = a[idx] + b[idx] * np.sin(2 * math.pi * f[idx] * tl)
    x[:] = np.where(kind[idx] == 0, lin, sine)
    return x


def _extent(program, x0: float) -> tuple[float, float, float]:
    """(duration s, number of pieces, end level) of a program started at ``x0``, computed without building it
    (so a protocol asking for 10^8 cycles is measured, not run). ``program``: segments or (key, segment)."""
    dur = pieces = 0.0
    x = float(x0)
    for item in program:
        seg = item[1] if isinstance(item, tuple) else item
        if isinstance(seg, Hold):
            d, k, x = seg.duration_s, 1, (x if seg.level is None else seg.level)
        elif isinstance(seg, Ramp):
            d = seg.duration_s if seg.duration_s is not None else abs(seg.to - x) / seg.rate
            k, x = 1, seg.to
        elif isinstance(seg, Step):
            slew = seg.slew is not None and seg.to != x
            d = (abs(seg.to - x) / seg.slew if slew else 0.0) + seg.hold_s
            k, x = (2 if slew else 1), seg.to
        elif isinstance(seg, Triangle):
            pre = x != seg.low
            d = (abs(x - seg.low) / seg.rate if pre else 0.0) + seg.cycles * 2 * (seg.high - seg.low) / seg.rate
            k, x = (1 if pre else 0) + 2.0 * seg.cycles, seg.low
        elif isinstance(seg, Sawtooth):
            d = seg.cycles * (seg.period_s + seg.fall_s)
            k = seg.cycles * (2.0 if seg.fall_s > 0 else 1.0)
            x = seg.low if seg.fall_s > 0 else seg.high
        elif isinstance(seg, Sine):
            d, k = seg.cycles / seg.frequency_hz, 1
            x = seg.mean + seg.amplitude * math.sin(2 * math.pi * seg.cycles)
        elif isinstance(seg, Repeat):
            # the end level of a pass is either fixed by the program or its start level: passes 2.. are alike
            d1, k1, x1 = _extent(seg.program, x)
            d2, k2, x2 = _extent(seg.program, x1) if seg.times > 1 else (0.0, 0.0, x1)
            d, k, x = d1 + (seg.times - 1) * d2, k1 + (seg.times - 1) * k2, x2
        else:  # pragma: no cover - SEGMENTS lists every kind
            raise TypeError(type(seg).__name__)
        dur += d
        pieces += k
    return dur, pieces, x


#: most program pieces (ramps, holds, half cycles) in one log
MAX_PIECES = 1_000_000


def _check_size(proto: "Protocol", path) -> None:
    """Refuse, before anything is rendered, a protocol whose logs are too large (:mod:`bpmid.limits`)."""
    from bpmid.limits import check_file_count, check_samples

    counts: dict[str, float] = {}
    if proto.kind == "relaxation":
        spec = proto.relaxation
        check_file_count(len(spec.crosshead_mm_per_min) * len(spec.strain_levels), path=path,
                         key="relaxation.strain_levels", what="relaxation tests")
        for r in spec.crosshead_mm_per_min:
            for e in spec.strain_levels:
                ramp_s = e * spec.gauge_length_mm / (r / 60.0)
                counts[f"relax_{r:g}mmmin_{e:g}"] = (spec.pre_s + ramp_s + spec.hold_s) * spec.logging_hz + 1
        check_samples(counts, path=path, key="relaxation.logging_hz", what="test",
                      hint="lower relaxation.logging_hz, hold_s or the number of rates and strain levels")
        return
    check_file_count(sum(float(s.replicates or proto.replicates) for s in proto.logs), path=path, key="logs")
    for i, spec in enumerate(proto.logs):
        start = spec.start if spec.start is not None else _first_level(spec.program)
        dur, pieces, _x = _extent(spec.program, start)
        if pieces > MAX_PIECES:
            from bpmid.limits import human_bytes

            raise InputError(f"log {spec.name!r} would have {pieces:.3g} program pieces (ramps, holds, half cycles), "
                             f"more than {MAX_PIECES:,} (estimated {human_bytes(pieces * 200.0)} of memory before a "
                             "single sample); lower its cycles or repeat times", path=path, key=f"logs[{i}].program")
        n = dur * proto.sampling_hz + 1
        reps = spec.replicates or proto.replicates
        for k in range(min(reps, 2)):  # every replicate is the same size: two stand for all in the total
            counts[spec.name if reps == 1 else f"{spec.name}_r{k + 1}"] = n
        if reps > 2:
            counts[f"{spec.name} (replicates 3..{reps})"] = n * (reps - 2)
        check_samples({spec.name: n}, path=path, key=f"logs[{i}]",
                      hint=f"lower sampling_hz ({proto.sampling_hz:g} Hz) or this log's duration "
                           f"({dur:.4g} s: cycles, repeat times, hold durations)")
        every = proto.plant.substeps(proto.sampling_hz)
        if every > 1:   # the muscle's own grid, finer than the log's
            check_samples({f"{spec.name} (the muscle's internal steps)": (n - 1) * every + 1}, path=path,
                          key="plant.max_step_s",
                          hint=f"the muscle runs {every} internal steps per log sample (plant.max_step_s "
                               f"{proto.plant.max_step_s:g} s); raise plant.max_step_s, set plant.integration: "
                               f"log_rate, or shorten the log ({dur:.4g} s)")
    check_samples(counts, path=path, key="logs", hint="lower sampling_hz, durations, cycles or replicates",
                  total_only=True)


# ---------------------------------------------------------------------------------------------
# the protocol
# ---------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class LogSpec:
    """One log (or ``replicates`` of it): a program started relaxed at ``start``."""

    name: str
    program: tuple[Any, ...]
    start: Optional[float] = None
    replicates: Optional[int] = None

    def validate(self, where, path):
        _positive(where, path, replicates=self.replicates)
        if not self.name or any(c in self.name for c in "/\\ "):
            raise InputError(f"a log name is a file stem without spaces or slashes, found {self.name!r}",
                             path=path, key=f"{where}.name")


@dataclasses.dataclass(frozen=True)
class Variation:
    """Replicate-to-replicate spread of the constants: each replicate's moduli are multiplied by
    exp(modulus_cv z1) and its time constants by exp(tau_cv z2), z standard normal from the seed."""

    modulus_cv: float = 0.0
    tau_cv: float = 0.0

    def validate(self, where, path):
        _non_negative(where, path, modulus_cv=self.modulus_cv, tau_cv=self.tau_cv)
        for k in ("modulus_cv", "tau_cv"):
            if getattr(self, k) > 0.5:
                raise InputError(f"a spread above 0.5 is not a replicate of one muscle, found {getattr(self, k)}",
                                 path=path, key=f"{where}.{k}")


_GEOMETRY_HINT = ("another muscle's geometry and constants come from a fit file: bpmid simulate PROTOCOL --params "
                  "FIT.yaml (a bpmid.vbmm/1 file as bpmid fit motion writes it; its geometry block sets the muscle)")


@dataclasses.dataclass(frozen=True)
class PlantSpec:
    """The muscle on the rig: VBMM constants (unless ``--params``), the rig's own effects, variation."""

    material: Literal["paper_fit", "paper_mat"] = "paper_fit"
    closure: Literal["paper", "consistent"] = "paper"
    effects: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    variation: Variation = dataclasses.field(default_factory=Variation)
    #: ``continuous``: the muscle runs on internal steps of at most ``max_step_s`` between log samples and is
    #: logged at ``sampling_hz``, as a real muscle is (what it logs does not depend on the logging rate);
    #: ``log_rate``: the muscle runs at the logging rate itself (the model a fit at that rate uses; the twin's way
    #: until 2026-11-28)
    integration: Literal["continuous", "log_rate"] = "continuous"
    max_step_s: float = 0.001

    #: what to do instead of an unknown key a user is likely to try (named in the error)
    UNKNOWN_KEY_HINTS: ClassVar[dict] = {k: _GEOMETRY_HINT for k in ("geometry", "model", "params")}

    def validate(self, where, path):
        from bpmid.config import stated_keys

        if self.integration == "log_rate" and "max_step_s" in stated_keys(self):
            raise InputError("max_step_s sets the internal step of integration: continuous, and integration is "
                             "log_rate (the muscle runs at the logging rate): remove max_step_s, or set "
                             "integration: continuous", path=path, key=f"{where}.max_step_s")
        if not 1e-4 <= self.max_step_s <= 0.1:
            raise InputError(f"the largest internal step is 1e-4 to 0.1 s, found {self.max_step_s} (the muscle's "
                             "integration error falls with it: 0.001 s stays under 0.01 deg on the paper's muscle)",
                             path=path, key=f"{where}.max_step_s")

    def substeps(self, sampling_hz: float) -> int:
        """Internal steps per log sample (1 for ``log_rate``)."""
        if self.integration == "log_rate":
            return 1
        return max(1, int(math.ceil(1.0 / (sampling_hz * self.max_step_s) - 1e-9)))


@dataclasses.dataclass(frozen=True)
class Protocol:
    kind: Literal["motion", "reference", "relaxation"]
    name: str = "protocol"
    description: str = ""
    schema: str = SCHEMA
    seed: int = 0
    sampling_hz: float = 10.0
    unit: Literal["bar", "kpa", "deg"] = "bar"
    pressure_reference: Literal["absolute", "gauge"] = "absolute"
    atmosphere_bar: float = 1.01325
    replicates: int = 1
    logs: tuple[LogSpec, ...] = ()
    plant: PlantSpec = dataclasses.field(default_factory=PlantSpec)
    sensors: Sensors = dataclasses.field(default_factory=Sensors)
    effects: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    blind: bool = False
    relaxation: Optional[RelaxationSpec] = None
    path: Optional[str] = None
    sha256: Optional[str] = None

    UNKNOWN_KEY_HINTS: ClassVar[dict] = {k: _GEOMETRY_HINT for k in ("geometry", "model", "params")}
    #: filled in by load_protocol (the file's own path and hash), not keys of a protocol file
    INTERNAL_FIELDS: ClassVar[tuple] = ("path", "sha256")

    def validate(self, where, path):
        if self.schema != SCHEMA:
            raise InputError(f"expected {SCHEMA}, found {self.schema!r}", path=path, key="schema")
        _positive("", path, sampling_hz=self.sampling_hz, replicates=self.replicates)
        if self.seed < 0:
            raise InputError(f"a seed is a non-negative whole number, found {self.seed}", path=path, key="seed")
        if not (0.5 <= self.atmosphere_bar <= 1.2):
            raise InputError(f"not an ambient pressure: {self.atmosphere_bar} bar", path=path, key="atmosphere_bar")
        if self.kind == "reference" and self.unit != "deg":
            raise InputError("reference signals are angles: unit must be deg", path=path, key="unit")
        if (self.kind == "relaxation") != (self.relaxation is not None):
            raise InputError("a relaxation protocol needs the block relaxation (and only it has one)", path=path,
                             key="relaxation")
        if self.kind == "motion" and self.unit == "deg":
            raise InputError("motion programs are pressures: unit bar or kpa", path=path, key="unit")

    # -- units -------------------------------------------------------------------------------
    @property
    def unit_pa(self) -> float:
        return {"bar": PA_PER_BAR, "kpa": PA_PER_KPA, "deg": 1.0}[self.unit]

    def to_gauge_pa(self, level):
        """A program level (the protocol's unit and reference) as gauge Pa."""
        pa = np.asarray(level, float) * self.unit_pa
        return pa - self.atmosphere_bar * PA_PER_BAR if self.pressure_reference == "absolute" else pa

    def runs(self):
        """(file stem, log spec, replicate index) for every log file this protocol writes."""
        for spec in self.logs:
            n = spec.replicates or self.replicates
            for k in range(n):
                yield (spec.name if n == 1 else f"{spec.name}_r{k + 1}"), spec, k

    def render(self, spec: LogSpec):
        start = spec.start if spec.start is not None else _first_level(spec.program)
        return render(spec.program, start, self.sampling_hz)


def _first_level(program) -> float:
    for _k, seg in _walk(program):
        lv = seg.levels()
        if lv:
            return float(next(iter(lv.values())))
    return 0.0


def load_protocol(path: str | Path, *, max_gauge_pa: float | None = None) -> Protocol:
    """Read and check a protocol file (errors name the file and the key)."""
    path = Path(path)
    data, sha = read_yaml(path, "protocol file")
    if not isinstance(data, dict):
        raise InputError("a protocol file is a YAML mapping", path=path)
    if "kind" not in data:
        schema = str(data.get("schema") or "")
        if schema.startswith("bpmid.") and not schema.startswith("bpmid.protocol/"):
            raise InputError(f"this is a {schema} result, not a protocol: bpmid simulate takes a protocol file "
                             "(schema bpmid.protocol/1, kind: motion, reference or relaxation; see "
                             "datasets/README.md); a fitted VBMM goes to --params", path=path, key="schema")
        raise InputError("missing key (motion, reference or relaxation)", path=path, key="kind")
    proto = build_dataclass(Protocol, data, "", path)
    logs = []
    for i, spec in enumerate(proto.logs):
        logs.append(dataclasses.replace(spec, program=parse_program(spec.program, f"logs[{i}].program", path)))
    proto = dataclasses.replace(proto, logs=tuple(logs), path=str(path), sha256=sha)
    _check_size(proto, path)  # before anything is rendered (bpmid.limits)
    if proto.kind in ("motion", "reference") and not proto.logs:
        raise InputError("a motion or reference protocol needs at least one log", path=path, key="logs")
    _check_nyquist(proto, path)
    names = [n for n, _s, _k in proto.runs()]
    from collections import Counter

    dup = sorted(n for n, c in Counter(names).items() if c > 1)
    if dup:
        raise InputError(f"two logs would share the file name {dup[0]!r}", path=path, key="logs")
    if proto.kind == "motion":
        _check_levels(proto, path, max_gauge_pa)
    if proto.kind == "reference":
        _check_angles(proto, path)
    # the segment keys were only needed for the messages above
    return dataclasses.replace(proto, logs=tuple(dataclasses.replace(s, program=_strip(s.program)) for s in proto.logs))


def _levels_of(i: int, spec) -> list[tuple[str, float]]:
    """(key, level) of every level log ``i``'s program reaches (its start, each segment's levels, a sine's two
    extremes), in the protocol's unit: what the range checks look at."""
    out = [(f"logs[{i}].start", spec.start)] if spec.start is not None else []
    for key, seg in _walk(spec.program):
        if isinstance(seg, Sine):
            out += [(f"{key}.mean", seg.mean - seg.amplitude), (f"{key}.amplitude", seg.mean + seg.amplitude)]
        else:
            out += [(f"{key}.{k}", v) for k, v in seg.levels().items()]
    return out


def _check_nyquist(proto: Protocol, path) -> None:
    """A sine at or above half the sampling rate would be logged (and, for a motion log, run through the plant) as
    another, slower sine: refused naming the segment's key, not aliased without a word."""
    nyquist = proto.sampling_hz / 2.0
    for spec in proto.logs:
        start = spec.start if spec.start is not None else _first_level(spec.program)
        if _extent(spec.program, start)[0] * proto.sampling_hz < 1.0:   # under two samples: refused as too short
            continue
        for key, seg in _walk(spec.program):
            cycle = {Sawtooth: lambda g: g.period_s + g.fall_s,
                     Triangle: lambda g: 2.0 * (g.high - g.low) / g.rate}.get(type(seg))
            if cycle is not None and cycle(seg) * nyquist <= 1.0 + 1e-9:   # fewer than two samples a cycle
                kind = type(seg).__name__.lower()
                raise InputError(f"a {kind} cycle of {cycle(seg):.3g} s spans at most two samples at sampling_hz "
                                 f"{proto.sampling_hz:g}: the log would hold another, slower signal (aliasing); "
                                 f"raise sampling_hz above {2.0 / cycle(seg):.3g} Hz (some 10 samples a cycle, "
                                 f"{10.0 / cycle(seg):.3g} Hz, to draw it) or slow the {kind}", path=path,
                                 key=f"{key}.{'period_s' if kind == 'sawtooth' else 'rate'}")
            if isinstance(seg, Sine) and seg.frequency_hz >= nyquist:
                raise InputError(f"{seg.frequency_hz:g} Hz is at or above half the sampling rate ({nyquist:g} Hz at "
                                 f"sampling_hz {proto.sampling_hz:g}): the log would hold another, slower sine "
                                 f"(aliasing); raise sampling_hz above {2 * seg.frequency_hz:g} Hz (some 10 samples "
                                 f"a cycle, {10 * seg.frequency_hz:g} Hz, to draw it) or lower frequency_hz",
                                 path=path, key=f"{key}.frequency_hz")


def _check_angles(proto: Protocol, path) -> None:
    """A reference's angles within 0..180 deg, the range bpmid control takes (a reference it would refuse later
    is refused here, naming the segment's key)."""
    for i, spec in enumerate(proto.logs):
        for key, angle in _levels_of(i, spec):
            if not 0.0 <= float(angle) <= 180.0:
                raise InputError(f"angle {angle:g} deg is outside 0..180 deg, the range a reference takes (bpmid "
                                 "control refuses it)", path=path, key=key)


def _check_levels(proto: Protocol, path, max_gauge_pa):
    """Pressures must stay in the model's range: at or above atmosphere, below ``max_gauge_pa``."""
    for i, spec in enumerate(proto.logs):
        for key, level in _levels_of(i, spec):
            g = float(proto.to_gauge_pa(level))
            if g < -1e-9:
                raise InputError(f"pressure {level:g} {proto.unit} ({proto.pressure_reference}) is below atmosphere: "
                                 f"outside the model's range (the VBMM takes gauge pressure >= 0)", path=path, key=key)
            if max_gauge_pa is not None and g > max_gauge_pa:
                top = max_gauge_pa / proto.unit_pa + (proto.atmosphere_bar * PA_PER_BAR / proto.unit_pa
                                                       if proto.pressure_reference == "absolute" else 0.0)
                raise InputError(f"pressure {level:g} {proto.unit} ({proto.pressure_reference}) is above the model's "
                                 f"range (at most {top:.3g} {proto.unit}: beyond it the muscle would bend past the "
                                 f"model's limit)", path=path, key=key)
