"""Closed-loop control of a bending pneumatic muscle: PI, VBMM-PI (seed 000 eq. 20) and Maxwell-slip-PI
(seed 003), simulated at the control rate on a plant (the twin: a VBMM with optional catalogue effects,
sensor noise and valve-and-volume pressure dynamics, :mod:`bpmid.pneumatics`).

The controllers (eq. 20, one command per control period, applied at the next sample)::

    P_out(k+1) = FF(beta_in(k)) + P e(k) + I sum_{i<=k} e(i),    e = beta_in - beta_measured

- ``pi``: FF = 0 (the integrator carries the whole pressure; it starts at the resting pressure)
- ``vbmm-pi``: FF = the inverse VBMM of the controller's model (eq. 18, recursive history: the exact
  O(1) form of the long-term VBMM) run incrementally on the reference
- ``ms-pi``: FF = the Maxwell-slip model written from angle to pressure (seed 003's inverse form),
  identified on open-loop data of the controller's model (a training set of pressure triangles)

Units of the paper's gains (seed 000 gives none): e in degrees (the flex sensor's reading, the unit of every
angle in the paper), P_out in bar (the pressure of eq. 20, the same unit as the inverse VBMM's output it is
added to), and the integral gain per second, as a Simulink discrete PI integrates (I Ts sum e): P = 0.04
bar/deg, I = 0.01 bar/(deg s), i.e. 0.001 bar/deg per step at 10 Hz. Reading eq. (20)'s sum literally
(0.01 bar/deg per step) is ``--ki 0.1``; on the twin that makes the PI alone track to about 1 deg RMSE,
far better than the paper's 5.1 deg, so the per-second reading is the default. Pressures are absolute, clipped to the
rig's range [p_min, p_max] with conditional integration (anti-windup); saturation and oscillation are
reported per run. Oscillation is looked for where it happens (:mod:`bpmid.control_ringing`: the error swinging back
and forth six times in a row, each swing quick and beyond the sensor's noise), not averaged over the run: at the
paper's gains on a plant without valve lag the loop rings at the Nyquist frequency for one to two seconds after
each step (P times the rubber's instantaneous gain is about 0.9), under every controller alike.
"""
from __future__ import annotations

import dataclasses
import functools
import math
import time
import zlib
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd

from bpmid import control_kernels as CK
from bpmid import control_ringing as ringing
from bpmid import metrics
from bpmid.errors import InputError
from bpmid.models.vbmm import VBMM, _CLOSURES, triangle_pressure
from bpmid.pneumatics import ValveVolumeParams
from bpmid.twin.sensors import Sensors, read_angle
from bpmid.units import PA_PER_BAR

CONTROLLERS = ("pi", "vbmm-pi", "ms-pi")
_KIND = {"pi": CK.CTRL_PI, "vbmm-pi": CK.CTRL_VBMM, "ms-pi": CK.CTRL_MS}
#: built-in references (used when datasets/control/ does not hold a file of that name)
BUILTIN_REFERENCES = ("steps", "sawtooth", "sines")


@dataclasses.dataclass(frozen=True)
class ControlConfig:
    """Config section ``control``.

    Attributes
    ----------
    kp_bar_per_deg : proportional gain P of eq. (20), bar per degree of error (paper 0.04)
    ki_bar_per_deg_s : integral gain I of eq. (20), bar per degree of error per second (paper 0.01; the
        sum of eq. 20 is taken times the control period 1/rate_hz)
    rate_hz : sampling and control rate (paper 10 Hz)
    p_min_bar_abs, p_max_bar_abs : pressure limits of the valve command, bar absolute (1.0, 2.4)
    atmosphere_bar : absolute pressure of the atmosphere (gauge = absolute - this)
    preview : feedforward on the next reference sample beta_in(k+1) instead of the paper's beta_in(k)
    controllers : controllers run by default
    sensors : the plant's angle sensor (:class:`bpmid.twin.sensors.Sensors`: white noise, drift,
        resolution; the pressure fields are not used); default 0.1 deg white noise
    seed : seed of the sensor draws
    plant_modulus_scale, plant_tau_scale : the plant's moduli and time constants times these (a plant a few
        percent off the controller's model without a second parameter file)
    pressure_dynamics : plant option: valve and muscle-volume dynamics (seed 003 eqs. 12-17)
    pneumatics : their constants (:class:`bpmid.pneumatics.ValveVolumeParams`)
    ms_elements, ms_poly_degree : size of the Maxwell-slip inverse feedforward
    ms_train_bar_abs : pressure range of the open-loop training triangles of the Maxwell-slip feedforward
    oscillation_limit_pct : a run whose command reverses (by more than 0.01 bar, or than three standard deviations
        of the change sensor noise alone makes through the P term, if larger) on more than this share of all its
        steps is reported as oscillating (a loop ringing all the time). A run is also reported as oscillating
        when it rings anywhere, for a while (:mod:`bpmid.control_ringing`: after a step, say, however quiet the
        rest of the run is); a run whose command swings between both limits (three switches within 2 s), or
        asks for a bend beyond the model's range, is reported as unstable
    """

    kp_bar_per_deg: float = 0.04
    ki_bar_per_deg_s: float = 0.01
    rate_hz: float = 10.0
    p_min_bar_abs: float = 1.0
    p_max_bar_abs: float = 2.4
    atmosphere_bar: float = 1.01325
    preview: bool = False
    controllers: tuple[str, ...] = CONTROLLERS
    sensors: Sensors = dataclasses.field(default_factory=lambda: Sensors(angle_noise_deg=0.1))
    seed: int = 0
    plant_modulus_scale: float = 1.0
    plant_tau_scale: float = 1.0
    pressure_dynamics: bool = False
    pneumatics: ValveVolumeParams = dataclasses.field(default_factory=ValveVolumeParams)
    ms_elements: int = 4
    ms_poly_degree: int = 3
    ms_train_bar_abs: tuple[float, ...] = (1.1, 2.4)
    oscillation_limit_pct: float = 50.0

    def validate(self, where="control", path=None):
        def bad(key, msg):
            raise InputError(msg, path=path, key=f"{where}.{key}")

        for key in ("kp_bar_per_deg", "ki_bar_per_deg_s", "rate_hz", "p_min_bar_abs", "p_max_bar_abs",
                    "atmosphere_bar", "plant_modulus_scale", "plant_tau_scale", "oscillation_limit_pct"):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
                bad(key, f"must be a number, found {v!r}")
        for key in ("kp_bar_per_deg", "ki_bar_per_deg_s"):
            v = getattr(self, key)
            if not (np.isfinite(v) and v >= 0):
                bad(key, f"must be finite and >= 0, found {v!r}")
        if not 0.5 <= self.rate_hz <= 10_000:   # a loop slower than 2 s a step, or faster than a valve, is a slip
            bad("rate_hz", f"must be a control rate in Hz between 0.5 and 10000, found {self.rate_hz!r}")
        if not 0 < self.p_min_bar_abs < self.p_max_bar_abs:
            bad("p_max_bar_abs", f"need 0 < p_min < p_max, found {self.p_min_bar_abs!r}, {self.p_max_bar_abs!r}")
        if not 0.1 <= self.atmosphere_bar <= 1.2:   # from high altitude to a deep mine; a value in Pa or kPa is a slip
            bad("atmosphere_bar", f"must be an ambient pressure in bar absolute (0.1-1.2, sea level 1.01325), "
                                  f"found {self.atmosphere_bar!r}")
        if not self.p_max_bar_abs <= 50.0:   # bar absolute; a value in kPa or Pa is a slip
            bad("p_max_bar_abs", f"must be a valve limit in bar absolute (at most 50), found {self.p_max_bar_abs!r}")
        if not 0 < self.oscillation_limit_pct <= 100:
            bad("oscillation_limit_pct", f"must be a share of the steps in % (0-100], found {self.oscillation_limit_pct!r}")
        for key, lo in (("ms_elements", 1), ("ms_poly_degree", 0)):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
                bad(key, f"must be an integer >= {lo}, found {v!r}")
        for c in self.controllers:
            if c not in CONTROLLERS:
                bad("controllers", f"unknown controller {c!r} (known: {', '.join(CONTROLLERS)})")
        dup = sorted({c for c in self.controllers if list(self.controllers).count(c) > 1})
        if dup:
            bad("controllers", f"controller {dup[0]} is listed twice")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            bad("seed", f"must be a non-negative integer, found {self.seed!r}")
        for key in ("plant_modulus_scale", "plant_tau_scale"):
            if not getattr(self, key) > 0:
                bad(key, f"must be positive, found {getattr(self, key)!r}")
        if len(self.ms_train_bar_abs) != 2 or not self.ms_train_bar_abs[0] < self.ms_train_bar_abs[1]:
            bad("ms_train_bar_abs", "expected [low, high] in bar absolute")
        self.pneumatics.validate(f"{where}.pneumatics", path)


# ---------------------------------------------------------------------------------------------
# references
# ---------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Reference:
    """A reference angle signal on the control grid: time_s (N,) s, angle_deg (N,) deg."""

    name: str
    time_s: np.ndarray
    angle_deg: np.ndarray
    path: Path | None = None
    #: how a file's samples were put on the control grid (None: the file was on it already), in words
    resampled: str | None = None
    #: what the reader found and assumed in the file (columns, units, dialect); {} for a built-in reference
    reading: dict = dataclasses.field(default_factory=dict)


def shipped_dir() -> Path:
    from bpmid import data

    return (data.root() / "datasets" / "control").resolve()


def builtin_reference(name: str, rate_hz: float = 10.0) -> Reference:
    """The paper's reference kinds (Fig. 18), generated: ``steps`` 45-60-75-60-45 deg held 10 s each;
    ``sawtooth`` triangles of 15 then 30 deg amplitude about 45 deg (two 20 s periods each); ``sines``
    about 45 deg, amplitude 20 deg, one period at 0.042 Hz then two at 0.083 Hz. Each starts with 5 s at
    its first value."""
    dt = 1.0 / rate_hz
    if name == "steps":
        levels = [45.0, 60.0, 75.0, 60.0, 45.0]
        t = np.arange(0.0, 5.0 + 10.0 * len(levels) - 0.5 * dt, dt)
        a = np.full(t.size, levels[0])
        for i, lv in enumerate(levels):
            a[t >= 5.0 + 10.0 * i] = lv
        return Reference(name, t, a)
    if name == "sawtooth":
        t = np.arange(0.0, 85.0 - 0.5 * dt, dt)
        tt = np.clip(t - 5.0, 0.0, None)
        amp = np.where(tt < 40.0, 15.0, 30.0)
        ph = np.mod(tt, 20.0) / 20.0
        tri = np.where(ph < 0.25, 4 * ph, np.where(ph < 0.75, 2 - 4 * ph, 4 * ph - 4))
        return Reference(name, t, 45.0 + amp * tri)
    if name == "sines":
        T1, T2 = 1 / 0.042, 2 / 0.083
        t = np.arange(0.0, 5.0 + T1 + T2, dt)
        tt = np.clip(t - 5.0, 0.0, None)
        phase = np.where(tt < T1, 2 * np.pi * 0.042 * tt, 2 * np.pi + 2 * np.pi * 0.083 * (tt - T1))
        return Reference(name, t, 45.0 + 20.0 * np.sin(phase))
    raise InputError(f"unknown reference {name!r}")


def read_reference(path: Path, rate_hz: float, name: str | None = None, io=None) -> Reference:
    """A reference table (``time_s``, ``angle_deg``; any format :func:`bpmid.io.tables.read_table` reads),
    resampled (linear) onto the control grid if needed. ``io``: the config's ``io`` section
    (:class:`~bpmid.io.motion_logs.IOConfig`: its column map, units and sheet apply, as to any log)."""
    path = Path(path)
    if not path.is_file():
        raise InputError("reference file not found", path=path)
    from bpmid.io.tables import read_table

    # the log readers (text dialects, encodings, Excel, MATLAB; units stated, never guessed; strict rows)
    kw = {} if io is None else {"column_map": io.columns, "sheet": io.sheet, "unit_sources": io.unit_sources(),
                                "units": {q: u for q, u in io.units.items() if q in ("time", "angle")}}
    table = read_table(path, required=("time", "angle"), kind="reference", **kw)
    t, a = table.columns["time"], table.columns["angle"]
    if t.size < 2:
        raise InputError("a reference needs at least two samples", path=path)
    step = np.flatnonzero(np.diff(t) <= 0)
    if step.size:
        raise InputError("time_s must increase strictly", path=path, line=table.line_of(int(step[0]) + 1),
                         key="time_s")
    if np.any(a < 0) or np.any(a > 180):
        k = int(np.flatnonzero((a < 0) | (a > 180))[0])
        raise InputError(f"angle {a[k]:g} deg is outside 0..180 deg", path=path, line=table.line_of(k), key="angle_deg")
    dt = 1.0 / rate_hz
    resampled = None
    steps = np.diff(t)
    if not np.allclose(steps, dt, rtol=1e-6, atol=1e-9):
        grid = t[0] + np.arange(int(np.floor((t[-1] - t[0]) / dt + 1e-9)) + 1) * dt
        lo, hi = float(np.min(steps)), float(np.max(steps))
        even = np.isclose(lo, hi, rtol=1e-4, atol=1e-7)   # a file's rounding of a steady step is no unevenness
        logged = (f"every {float(np.median(steps)):.4g} s ({1.0 / float(np.median(steps)):.4g} Hz)" if even
                  else f"every {lo:.4g}-{hi:.4g} s (uneven)")
        resampled = (f"logged {logged}: {t.size} samples interpolated linearly onto the {rate_hz:g} Hz control "
                     f"grid ({grid.size} samples"
                     + (f"; detail faster than {rate_hz / 2:g} Hz is not followed)" if lo < dt * (1 - 1e-6) else ")"))
        a = np.interp(grid, t, a)
        t = grid
    if 0.0 < float(np.max(a)) <= math.pi and float(np.ptp(a)) > 0.05:   # as the motion logs' radians check
        rad = (f"its angles never exceed {float(np.max(a)):.3g} deg: radians in a degree column? If so, state "
               "it (--angle-unit rad, or a column named angle_rad)")
        resampled = f"{resampled}; {rad}" if resampled else rad
    if abs(float(t[0])) > 1e-9:   # the run starts at the reference's first sample: said, with its shift
        shift = f"its time starts at {float(t[0]):.6g} s and runs from 0 here (shifted by {-float(t[0]):.6g} s)"
        resampled = f"{resampled}; {shift}" if resampled else shift
    return Reference(name or path.stem, t - t[0], a, path, resampled, dict(table.reading))


def references_reading(refs: Sequence[Reference]) -> dict:
    """Reference name -> what the reader found and assumed in its file (the ``provenance.reading`` every output that
    reads files records); the built-in references, read from no file, have none."""
    return {r.name: dict(r.reading) for r in refs if r.reading}


def load_references(spec: str, rate_hz: float = 10.0, io=None) -> list[Reference]:
    """``spec``: a comma list of CSV paths or names (a shipped reference in datasets/control/, else a
    built-in one); ``all`` = every shipped reference (the built-in ones when none is shipped). ``io``: the config's
    ``io`` section, for the user's files (:func:`read_reference`)."""
    out = []
    for item in [s.strip() for s in spec.split(",") if s.strip()]:
        p = Path(item)
        if p.suffix.lower() == ".csv" or p.is_file():
            out.append(read_reference(p, rate_hz, io=io))
            continue
        shipped = sorted(shipped_dir().glob("*.csv")) if shipped_dir().is_dir() else []
        if item == "all":
            out += [read_reference(f, rate_hz) for f in shipped] or [builtin_reference(n, rate_hz)
                                                                    for n in BUILTIN_REFERENCES]
            continue
        match = [f for f in shipped if f.stem == item]
        if match:
            out.append(read_reference(match[0], rate_hz))
        elif item in BUILTIN_REFERENCES:
            out.append(builtin_reference(item, rate_hz))
        else:
            known = [f.stem for f in shipped] + list(BUILTIN_REFERENCES) + ["all"]
            raise InputError(f"unknown reference {item!r}: not a CSV file, known names: {', '.join(known)}",
                             key="--reference")
    if not out:
        raise InputError("no reference given", key="--reference")
    return check_reference_names(out, key="--reference")


def check_reference_names(refs: list, *, key: str, path=None) -> list:
    """``refs`` when no two share a name (references are told apart by name: a file's stem), else InputError
    naming the first name given twice and ``key``."""
    names = [r.name for r in refs]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(f"reference {dup[0]} is given twice (references are told apart by name, a file's by its "
                         "file name): give it once, or rename one of two files", path=path, key=key)
    return refs


# ---------------------------------------------------------------------------------------------
# plant
# ---------------------------------------------------------------------------------------------
def pack_model(model: VBMM) -> tuple:
    """The VBMM as the kernel's argument tuple (geo, closure, G_inf, G, tauG, K_inf, K, tauK, fall, stiff)."""
    if model.history != "recursive":
        model = model.replace(history="recursive")  # the exact O(1) form (window: the same to 1e-3 deg)
    m = model.material
    return (model.geometry.vector(), _CLOSURES[model.closure], float(m.G_inf), np.asarray(m.G, float),
            np.asarray(m.tauG, float), float(m.K_inf), np.asarray(m.K, float), np.asarray(m.tau_K, float),
            float(model.fall_ratio), float(model.stiffening))


@dataclasses.dataclass(frozen=True)
class PlantTerms:
    """The plant's causal per-sample terms: what the catalogue effects become inside the loop.

    ops : ((op, values), ...) pressure terms in order (:func:`bpmid.control_kernels.pressure_chain`)
    offset_deg, gain : the angle sensor reads gain * angle + offset_deg; scale : (N,) modulus scale or None
    """

    ops: tuple = ()
    offset_deg: float = 0.0
    scale: np.ndarray | None = None
    gain: float = 1.0

    def arrays(self):
        """(ch_op (m,), ch_par (m, R), ch_cnt (m,)) for the kernel."""
        m = len(self.ops)
        width = max([len(v) for _op, v in self.ops] + [1])
        par = np.zeros((m, width))
        for i, (_op, v) in enumerate(self.ops):
            par[i, : len(v)] = v
        return (np.array([op for op, _v in self.ops], np.int64), par,
                np.array([len(v) for _op, v in self.ops], np.int64))


#: the operators an effect's causal pressure form may name (Effect.causal_pressure) -> kernel op code
CAUSAL_OPS = {"delay": CK.OP_DELAY, "lag": CK.OP_LAG, "plays": CK.OP_PLAYS, "frictions": CK.OP_FRICTION}


def causal_terms(aug, t: np.ndarray) -> tuple[VBMM, PlantTerms]:
    """Split an :class:`~bpmid.effects.base.AugmentedVBMM` into its VBMM (structural changes applied:
    extra branch, fall_ratio, stiffening) and the per-sample terms the loop steps causally, as each effect
    declares them: its pressure operators (:meth:`~bpmid.effects.base.Effect.causal_pressure`), its sensor
    gain and offset (:meth:`~bpmid.effects.base.Effect.causal_angle`) and its modulus scale (a function of time
    only). No effect is named here; an effect whose pressure or angle term has no causal form is refused."""
    from bpmid.effects.base import Effect

    ops, gain, offset, scale = [], 1.0, 0.0, None
    p = aug.params
    for e in aug.effects:
        terms = e.causal_pressure(p)
        if terms is None:
            raise InputError(f"effect {e.id} changes the pressure in a way the closed loop cannot step: "
                             f"{e.not_causal_because(p)}", key=e.id)
        for name, values in terms:
            if name not in CAUSAL_OPS:
                raise InputError(f"effect {e.id} asks for an unknown causal operator {name!r} (known: "
                                 f"{', '.join(CAUSAL_OPS)})", key=e.id)
            ops.append((CAUSAL_OPS[name], [float(v) for v in values]))
        affine = e.causal_angle(p)
        if affine is None:
            raise InputError(f"effect {e.id} changes the angle in a way the closed loop cannot step", key=e.id)
        g, o = affine  # applied after the effects before it: y = g (gain beta + offset) + o
        gain, offset = g * gain, g * offset + o
        if type(e).pressure_modulus_scale is not Effect.pressure_modulus_scale:
            raise InputError(f"effect {e.id} softens the rubber with the pressure history in a way the closed loop "
                             "cannot step", key=e.id)
        s = e.modulus_scale(np.asarray(t, float), p)
        if s is not None:
            scale = s if scale is None else scale * s
    return aug.model(), PlantTerms(tuple(ops), offset, scale, gain)


@dataclasses.dataclass(frozen=True)
class Plant:
    """The simulated muscle: a VBMM, catalogue effects (``effects`` with their ``effect_params``), the
    angle sensor, and optionally the valve-and-volume pressure dynamics."""

    model: VBMM
    effects: tuple = ()
    effect_params: object = None
    sensors: Sensors = dataclasses.field(default_factory=Sensors)
    pressure_dynamics: bool = False
    pneumatics: ValveVolumeParams = dataclasses.field(default_factory=ValveVolumeParams)

    def augmented(self):
        from bpmid.effects.base import AugmentedVBMM
        from bpmid.params import ParamSet

        return AugmentedVBMM(self.model, tuple(self.effects), self.effect_params or ParamSet([]))

    def terms(self, t: np.ndarray) -> tuple[VBMM, PlantTerms]:
        if not self.effects:
            return self.model, PlantTerms()
        return causal_terms(self.augmented(), t)

    def sensor_error(self, t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Additive sensor error (deg, (N,)): drift and white noise (quantisation acts in the loop)."""
        return read_angle(np.asarray(t, float), np.zeros(len(t)), dataclasses.replace(self.sensors, angle_resolution_deg=0.0),
                          rng)


def build_plant(model: VBMM, effect_args: Sequence[str] = (), cfg: "ControlConfig | None" = None) -> Plant:
    """The plant from ``--plant-effect ID[:key=value,...]`` texts (the twin's parser and catalogue), in the
    twin's signal-path order, with the config's sensors and pressure dynamics."""
    from bpmid.params import ParamSet
    from bpmid.twin.simulate import build_effect, parse_effect_arg, signal_path_key

    cfg = cfg or ControlConfig()
    chain = [build_effect(*parse_effect_arg(text), where="--plant-effect") for text in effect_args]
    ids = [e.id for e, _p in chain]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        raise InputError(f"effect {dup[0]} is given twice", key="--plant-effect")
    chain.sort(key=signal_path_key)
    return Plant(model, tuple(e for e, _p in chain), ParamSet([p for _e, ps in chain for p in ps]), cfg.sensors,
                 cfg.pressure_dynamics, cfg.pneumatics)


def scaled_plant_model(model: VBMM, modulus_scale: float = 1.0, tau_scale: float = 1.0) -> VBMM:
    """The model with all moduli and time constants scaled (a plant a few percent off)."""
    m = model.material.scaled(modulus_scale)
    m = dataclasses.replace(m, tauG=tuple(v * tau_scale for v in m.tauG),
                            tauK=None if m.tauK is None else tuple(v * tau_scale for v in m.tauK))
    return model.replace(material=m)


# ---------------------------------------------------------------------------------------------
# Maxwell-slip inverse feedforward (seed 003)
# ---------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class MSFeedforward:
    """Pressure (bar gauge) as Maxwell-slip function of the angle (deg): s(beta) + sum k_i d_i(beta).

    poly (deg + 1,) bar/deg^j; k (n,) bar/deg; D (n,) deg; train_rmse_bar on its training data."""

    poly: np.ndarray
    k: np.ndarray
    D: np.ndarray
    train_rmse_bar: float

    def pressure_bar(self, beta_deg: np.ndarray) -> np.ndarray:
        from bpmid.models._hysteresis_kernels import stop_bank

        b = np.ascontiguousarray(beta_deg, float)
        d = stop_bank(b, self.D, np.zeros_like(self.D))
        return (b[:, None] ** np.arange(self.poly.size)) @ self.poly + d @ self.k


def fit_ms_feedforward(model: VBMM, cfg: ControlConfig) -> MSFeedforward:
    """Identify the inverse Maxwell-slip feedforward on open-loop data of the controller's model: the
    VBMM driven by triangles of growing amplitude (+-0.2 bar/s, as experiment 1a) over ``ms_train_bar_abs``."""
    from bpmid.models.maxwell_slip import MaxwellSlipModel

    lo, hi = cfg.ms_train_bar_abs
    dt = 1.0 / cfg.rate_hz
    parts = []
    for top in np.linspace(lo + 0.4 * (hi - lo), hi, 3):
        tt = np.arange(0.0, 2 * (top - lo) / 0.2, dt)
        parts.append(triangle_pressure(tt, lo, top, 0.2))
    p_abs = np.concatenate(parts)
    t = np.arange(p_abs.size) * dt
    p_gauge_bar = p_abs - cfg.atmosphere_bar
    beta = model.replace(history="recursive").forward_deg(t, p_gauge_bar * PA_PER_BAR)
    ms = MaxwellSlipModel(cfg.ms_elements, cfg.ms_poly_degree, input_unit="deg", output_unit="bar")
    res = ms.fit_arrays([beta], [p_gauge_bar])
    pr = res.params
    ff = MSFeedforward(np.array([pr.value(n) for n in ms.poly_names]), np.array([pr.value(n) for n in ms.stiffness_names]),
                       np.array([pr.value(n) for n in ms.slip_names]), 0.0)
    rms = float(np.sqrt(np.mean((ff.pressure_bar(beta) - p_gauge_bar) ** 2)))
    return dataclasses.replace(ff, train_rmse_bar=rms)


# ---------------------------------------------------------------------------------------------
# the loop
# ---------------------------------------------------------------------------------------------
#: the smallest command change (bar) that counts toward a reversal of the command (the oscillation verdict)
REVERSAL_MIN_BAR = 0.01


@dataclasses.dataclass
class Run:
    """One closed-loop run: signals (N,) and its verdicts."""

    controller: str
    reference: str
    time_s: np.ndarray
    reference_deg: np.ndarray
    angle_deg: np.ndarray  # measured
    true_angle_deg: np.ndarray
    command_bar_abs: np.ndarray
    muscle_bar_abs: np.ndarray
    feedforward_bar_abs: np.ndarray
    saturated: np.ndarray  # +1 high, -1 low, 0 inside
    status: np.ndarray
    wall_s: float = 0.0
    #: a command change counts toward a reversal above this (bar): 0.01 bar, or three standard deviations of the
    #: change the P term makes from sensor noise alone (kp sqrt(2) sigma; white noise and quantisation), if larger
    reversal_min_bar: float = REVERSAL_MIN_BAR
    #: the dead band (deg) of the error's turning points in the ringing check
    #: (:func:`bpmid.control_ringing.swing_band_deg`)
    ringing_band_deg: float = ringing.RINGING_MIN_SWING_DEG

    @property
    def error_deg(self) -> np.ndarray:
        return self.reference_deg - self.angle_deg

    @functools.cached_property
    def ringing(self) -> list:
        """The episodes in which the error swings back and forth (:mod:`bpmid.control_ringing`), in time order: of
        the true angle, what the muscle did (as the RMSE), with a band a reading of the angle can tell from noise."""
        return ringing.episodes(self.time_s, self.reference_deg, self.true_angle_deg, self.ringing_band_deg)

    def metrics(self, cfg: ControlConfig) -> dict:
        du = np.diff(self.command_bar_abs)
        thr = self.reversal_min_bar
        rev = (du[1:] * du[:-1] < 0) & (np.abs(du[1:]) > thr) & (np.abs(du[:-1]) > thr)
        osc_pct = 100.0 * float(np.mean(rev)) if rev.size else 0.0
        sat_pct = 100.0 * float(np.mean(self.saturated != 0))
        out_of_range = bool(np.any(self.status == 1))
        at = np.flatnonzero(self.saturated != 0)
        sw = at[1:][self.saturated[at[1:]] != self.saturated[at[:-1]]]  # steps where the command switches limits
        # bang-bang: three switches between the limits within 2 s (a reference jump gives one)
        win = int(round(2.0 * cfg.rate_hz))
        bang = int(np.sum(sw[2:] - sw[:-2] <= win)) if sw.size >= 3 else 0
        flags = []
        if out_of_range or bang >= 3:
            flags.append("unstable")
        # ringing found where it happens (after a step, a jump), or a command reversing on most steps of the run
        if self.ringing or osc_pct > cfg.oscillation_limit_pct:
            flags.append("oscillating")
        if sat_pct > 0:
            flags.append("saturated")
        return {
            "rmse_deg": metrics.rmse(self.reference_deg, self.true_angle_deg),
            "max_abs_err_deg": metrics.max_abs_err(self.reference_deg, self.true_angle_deg),
            "rmse_measured_deg": metrics.rmse(self.reference_deg, self.angle_deg),
            "saturated_pct": sat_pct,
            "saturated_high_steps": int(np.sum(self.saturated > 0)),
            "saturated_low_steps": int(np.sum(self.saturated < 0)),
            "reversal_pct": osc_pct,
            **ringing.summary(self.ringing),
            "limit_switches": bang,
            "status": ",".join(flags) if flags else "ok",
            "us_per_step": 1e6 * self.wall_s / max(self.time_s.size, 1),
        }


def simulate_loop(controller: str, ref: Reference, model: VBMM, plant: Plant, cfg: ControlConfig, *,
                  ms_ff: MSFeedforward | None = None, kp: float | None = None, ki: float | None = None,
                  noise: np.ndarray | None = None, feedforward=None) -> Run:
    """Run ``controller`` on ``plant`` tracking ``ref``; ``model`` is the controller's VBMM.

    ``feedforward``: optional callable ``(t_s, angle_deg) -> gauge pressure (Pa)`` that replaces the
    controller's own feedforward (e.g. exported C code loaded with ctypes); it is called once per reference
    sample, in time order, as the loop would call it."""
    if controller not in _KIND:
        raise InputError(f"unknown controller {controller!r} (known: {', '.join(CONTROLLERS)})", key="--controller")
    kp = cfg.kp_bar_per_deg if kp is None else kp
    ki = cfg.ki_bar_per_deg_s if ki is None else ki
    t = np.ascontiguousarray(ref.time_s, float)
    n = t.size
    ref_rad = np.radians(np.ascontiguousarray(ref.angle_deg, float))
    atm = cfg.atmosphere_bar * PA_PER_BAR
    lo, hi = cfg.p_min_bar_abs * PA_PER_BAR, cfg.p_max_bar_abs * PA_PER_BAR
    # at rest at the start: the controller model's relaxed pressure for the first reference sample
    p_start = float(np.clip(atm + model.equilibrium_pressure(ref_rad[0])[0], lo, hi))
    pmodel, terms = plant.terms(t)
    if noise is None:
        noise = plant.sensor_error(t, np.random.default_rng(cfg.seed))
    scale = np.ones(n) if terms.scale is None else np.ascontiguousarray(terms.scale, float)
    if ms_ff is None:
        ms_ff = MSFeedforward(np.zeros(1), np.zeros(0), np.zeros(0), 0.0)
        if controller == "ms-pi":
            ms_ff = fit_ms_feedforward(model, cfg)
    kind, ff_given = _KIND[controller], np.zeros(0)
    if feedforward is not None and controller != "pi":
        kind = CK.CTRL_GIVEN
        ff_given = np.array([feedforward(float(tk), float(ak)) for tk, ak in zip(t, ref.angle_deg)], float)
    t0 = time.perf_counter()
    u, pm, pe, beta, y, ff, sat, status = CK.closed_loop(
        t, ref_rad, kind, kp * PA_PER_BAR, ki * PA_PER_BAR / cfg.rate_hz, lo, hi, atm, p_start, bool(cfg.preview),
        *pack_model(model), ms_ff.poly, ms_ff.k, ms_ff.D, ff_given,
        *pack_model(pmodel), scale, *terms.arrays(), float(terms.gain), float(terms.offset_deg),
        np.ascontiguousarray(noise, float), float(plant.sensors.angle_resolution_deg), bool(plant.pressure_dynamics),
        plant.pneumatics.vector(atm))
    wall = time.perf_counter() - t0
    sn = plant.sensors
    sigma = math.sqrt(sn.angle_noise_deg ** 2 + sn.angle_resolution_deg ** 2 / 12.0)
    thr = max(REVERSAL_MIN_BAR, 3.0 * kp * math.sqrt(2.0) * sigma)
    return Run(controller, ref.name, t, np.asarray(ref.angle_deg, float), y, np.degrees(beta), u / PA_PER_BAR,
               pm / PA_PER_BAR, ff / PA_PER_BAR, sat, status, wall, thr, ringing.swing_band_deg(sigma))


@dataclasses.dataclass
class ControlResult:
    runs: list[Run]
    table: pd.DataFrame  # summary rows
    feedforward_cost: dict
    ms_feedforward: MSFeedforward | None
    warnings: list[str]
    references: list[Reference] = dataclasses.field(default_factory=list)


def summary_table(runs: Sequence[Run], cfg: ControlConfig) -> pd.DataFrame:
    """One row per (controller, reference) plus ``ALL`` (pooled over references); reduction_pct = RMSE
    reduction against ``pi`` on the same reference (NaN when pi was not run)."""
    rows = []
    for r in runs:
        rows.append({"controller": r.controller, "reference": r.reference, **r.metrics(cfg)})
    for c in dict.fromkeys(r.controller for r in runs):
        mine = [r for r in runs if r.controller == c]
        ref = np.concatenate([r.reference_deg for r in mine])
        ang = np.concatenate([r.true_angle_deg for r in mine])
        sat = np.concatenate([r.saturated for r in mine])
        st = sorted({f for r in mine for f in r.metrics(cfg)["status"].split(",") if f != "ok"})
        eps = [ep for r in mine for ep in r.ringing]
        rings = {**ringing.summary(eps), "ringing_from_s": float("nan")}   # times of different references
        rows.append({"controller": c, "reference": "ALL", "rmse_deg": metrics.rmse(ref, ang),
                     "max_abs_err_deg": metrics.max_abs_err(ref, ang),
                     "rmse_measured_deg": metrics.rmse(ref, np.concatenate([r.angle_deg for r in mine])),
                     "saturated_pct": 100.0 * float(np.mean(sat != 0)),
                     "saturated_high_steps": int(np.sum(sat > 0)), "saturated_low_steps": int(np.sum(sat < 0)),
                     "reversal_pct": float(np.mean([r.metrics(cfg)["reversal_pct"] for r in mine])),
                     **rings,
                     "status": ",".join(st) if st else "ok",
                     "us_per_step": float(np.mean([r.metrics(cfg)["us_per_step"] for r in mine]))})
    df = pd.DataFrame(rows)
    base = df[df.controller == "pi"].set_index("reference")["rmse_deg"]
    df["reduction_pct"] = [100.0 * (1.0 - row.rmse_deg / base[row.reference]) if row.reference in base.index
                           else float("nan") for row in df.itertuples()]
    cols = ["controller", "reference", "rmse_deg", "max_abs_err_deg", "reduction_pct", "rmse_measured_deg",
            "saturated_pct", "saturated_high_steps", "saturated_low_steps", "reversal_pct", "ringing_episodes",
            "ringing_s", "ringing_longest_s", "ringing_from_s", "ringing_swing_deg", "ringing_period_s", "status",
            "us_per_step"]
    return df[cols]


def ringing_words(eps: Sequence, rate_hz: float) -> str:
    """A run's ringing in words: how many episodes, how long in all, the longest (where, how large, how fast)."""
    longest = max(eps, key=lambda ep: (ep.duration_s, ep.largest_swing_deg))
    nyq = abs(longest.period_s - 2.0 / rate_hz) < 0.5 / rate_hz
    many = (f" in {len(eps)} episodes, {sum(ep.duration_s for ep in eps):.2g} s in all; the longest"
            if len(eps) > 1 else "")
    largest = max(ep.largest_swing_deg for ep in eps)
    return (f"the error swings back and forth{many} " + longest.words()
            + (f" (the {rate_hz / 2:g} Hz Nyquist frequency of the {rate_hz:g} Hz loop)" if nyq else "")
            # summary.csv's ringing_swing_deg is the largest of any episode: said when it is not the longest's
            + (f"; the largest swing back in any episode {largest:.3g} deg peak to peak"
               if largest > longest.largest_swing_deg * 1.005 else ""))


def ringing_comparison(table: pd.DataFrame) -> str | None:
    """What ringing does to the reductions against ``pi``, said when any controller rings: time ringing per
    controller over all references, and each reference where one of pi and a compared controller rings and the other
    does not (there the reduction holds the difference). How much of each RMSE the ringing is depends on how it is
    taken out (leaving out its seconds also leaves out PI's slow lag after each step), so no number is made up here:
    ``benchmarks/bench_control.py`` takes the 5 Hz part out of every error and says what is left."""
    if "pi" not in set(table.controller) or not (table["ringing_episodes"] > 0).any():
        return None
    pooled = table[table.reference == "ALL"].set_index("controller")
    if len(pooled) < 2:
        return None
    secs = ", ".join(f"{c} {row.ringing_s:.2g} s" for c, row in pooled.iterrows())
    per = table[table.reference != "ALL"].set_index(["controller", "reference"])["ringing_episodes"]
    uneven = []
    for ref in dict.fromkeys(table.reference[table.reference != "ALL"]):
        pi_rings = per.get(("pi", ref), 0) > 0
        for c in pooled.index:
            if c != "pi" and (c, ref) in per.index and (per[(c, ref)] > 0) != pi_rings:
                uneven.append(f"on {ref} pi rings and {c} does not (part of its reduction there is pi's ringing)"
                              if pi_rings else f"on {ref} {c} rings and pi does not (its RMSE there holds its ringing)")
    both = ("every controller rings" if (pooled["ringing_episodes"] > 0).all() else "some controllers ring")
    return (f"ringing and the reductions against pi: {both} (over all references: {secs}); the P term closes the "
            "same loop under each controller and a feedforward does not damp it, so every RMSE, pi's too, holds "
            "ringing" + ("; " + "; ".join(uneven) if uneven else ""))


def feedforward_cost(model: VBMM, n_steps: int = 200_000, repeats: int = 3, period_s: float = 0.1) -> dict:
    """Measured cost of the feedforward per control step (us): the incremental inverse VBMM kernel the loop
    runs, and the vectorised :meth:`VBMM.inverse` per sample; against the control period."""
    dt = 0.1
    t = np.arange(n_steps) * dt
    beta = np.radians(45.0 + 20.0 * np.sin(2 * np.pi * 0.083 * t))
    args = pack_model(model)
    CK.inverse_incremental(t[:10], beta[:10], *args)  # compile / load the cache
    best_k = min(_timed(lambda: CK.inverse_incremental(t, beta, *args)) for _ in range(repeats))
    m = 20_000
    rec = model.replace(history="recursive")
    best_v = min(_timed(lambda: rec.inverse(t[:m], beta[:m])) for _ in range(repeats))
    us_k = 1e6 * best_k / n_steps
    return {"incremental_kernel_us_per_step": us_k, "vectorised_inverse_us_per_sample": 1e6 * best_v / m,
            "control_period_us": 1e6 * period_s, "share_of_period_pct": 100.0 * us_k / (1e6 * period_s),
            "n_steps": n_steps}


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def run_control(model: VBMM, plant: Plant, references: Sequence[Reference], cfg: ControlConfig, *,
                controllers: Sequence[str] | None = None, kp: float | None = None, ki: float | None = None,
                measure_cost: bool = True) -> ControlResult:
    """Every controller on every reference; the summary table; warnings for saturated or unstable runs."""
    controllers = list(controllers or cfg.controllers)
    for c in controllers:
        if c not in _KIND:
            raise InputError(f"unknown controller {c!r} (known: {', '.join(CONTROLLERS)})", key="--controller")
    dup = sorted({c for c in controllers if controllers.count(c) > 1})
    if dup:
        raise InputError(f"controller {dup[0]} is listed twice", key="--controller")
    ms_ff = fit_ms_feedforward(model, cfg) if "ms-pi" in controllers else None
    if references:  # load the compiled kernels before anything is timed
        r0 = references[0]
        simulate_loop("vbmm-pi", Reference("warm-up", r0.time_s[:5], r0.angle_deg[:5]), model, plant, cfg, kp=kp, ki=ki)
    runs = []
    for ref in references:
        # drawn from the seed and the reference's name, not its place in the list: a reference gives the same
        # numbers alone or among others
        noise = plant.sensor_error(ref.time_s, np.random.default_rng([cfg.seed, zlib.crc32(ref.name.encode("utf-8"))]))
        for c in controllers:  # the same noise for every controller on a reference
            runs.append(simulate_loop(c, ref, model, plant, cfg, ms_ff=ms_ff, kp=kp, ki=ki, noise=noise))
    table = summary_table(runs, cfg)
    warnings = []
    by_name = {(r.controller, r.reference): r for r in runs}
    for row in table.itertuples():
        if row.reference != "ALL" and row.status != "ok":
            said = []
            eps = by_name[(row.controller, row.reference)].ringing
            if eps:
                said.append(ringing_words(eps, cfg.rate_hz))
            said.append(f"command at a pressure limit on {row.saturated_pct:.1f} % of the steps: "
                        f"{row.saturated_high_steps} high, {row.saturated_low_steps} low")
            said.append(f"command reversals {row.reversal_pct:.0f} % of all steps"
                        + (f", more than the {cfg.oscillation_limit_pct:g} % limit"
                           if row.reversal_pct > cfg.oscillation_limit_pct else ""))
            warnings.append(f"{row.controller} on {row.reference}: {row.status} ({'; '.join(said)})")
    note = ringing_comparison(table)
    if note:
        warnings.append(note)
    # a reference beyond what the plant can bend to at the top pressure: no controller can follow it
    reach = float(np.degrees(plant.model.equilibrium_angle(
        np.array([(cfg.p_max_bar_abs - cfg.atmosphere_bar) * PA_PER_BAR]))[0])) if hasattr(plant, "model") else None
    if reach is not None and np.isfinite(reach):
        for ref in references:
            top = float(np.max(ref.angle_deg))
            if top > reach:
                warnings.append(f"reference {ref.name} asks up to {top:.4g} deg; the plant bends at most about "
                                f"{reach:.4g} deg at the top pressure {cfg.p_max_bar_abs:g} bar abs (relaxed, long "
                                "term): no controller can follow it there, and its scores say more about the "
                                "limit than the controller")
    cost = feedforward_cost(model, period_s=1.0 / cfg.rate_hz) if measure_cost else {}
    return ControlResult(runs, table, cost, ms_ff, warnings, list(references))


def control_yaml_body(result: ControlResult, cfg: ControlConfig, *, model: VBMM, plant: Plant) -> dict:
    """The body of ``control.yaml`` (schema ``bpmid.control/1``): gains, limits, feedforward, models, summary."""
    from bpmid.models.vbmm import vbmm_yaml_body

    body = {
        "gains": {"kp": {"value": cfg.kp_bar_per_deg, "unit": "bar/deg"},
                  "ki": {"value": cfg.ki_bar_per_deg_s, "unit": "bar/(deg s)",
                         "per_step": cfg.ki_bar_per_deg_s / cfg.rate_hz},
                  "acts_on": "error in deg (reference - measured angle) -> command pressure in bar absolute"},
        "rate_hz": cfg.rate_hz,
        "pressure_limits_bar_abs": [cfg.p_min_bar_abs, cfg.p_max_bar_abs],
        "anti_windup": "conditional integration (integrator frozen while the command is clipped and the error "
                       "pushes further out)",
        "feedforward": {"vbmm-pi": "inverse VBMM (eq. 18) of the controller's model, recursive history, stepped "
                                   "incrementally on the reference",
                        "preview": cfg.preview, "cost": result.feedforward_cost},
        "controller_model": vbmm_yaml_body(model),
        "plant": {"model": vbmm_yaml_body(plant.model),
                  "modulus_scale": cfg.plant_modulus_scale, "tau_scale": cfg.plant_tau_scale,
                  "effects": [e.describe(plant.effect_params) for e in plant.effects],
                  "sensors": dataclasses.asdict(plant.sensors),
                  "pressure_dynamics": plant.pressure_dynamics,
                  "pneumatics": dataclasses.asdict(plant.pneumatics) if plant.pressure_dynamics else None},
        "references": [{"name": ref.name, "source": str(ref.path) if ref.path is not None else "built in",
                        "samples": int(ref.time_s.size), "duration_s": float(ref.time_s[-1]),
                        "resampled": ref.resampled} for ref in result.references],
        "summary": result.table.to_dict(orient="records"),
        "ringing": {
            "rule": (f"the error (reference - true angle) swings back and forth {ringing.RINGING_MIN_SWINGS} times "
                     f"or more in a row, each swing at most {ringing.RINGING_MAX_HALF_PERIOD_S:g} s and larger than "
                     f"band_deg peak to peak, the reference not turning and the angle moving at least as far as the "
                     "reference over each"),
            "band_deg": {f"{r.controller} on {r.reference}": r.ringing_band_deg for r in result.runs},
            "episodes": [{"controller": r.controller, "reference": r.reference, **dataclasses.asdict(ep),
                          "duration_s": ep.duration_s} for r in result.runs for ep in r.ringing],
        },
        "warnings": result.warnings,
    }
    if result.ms_feedforward is not None:
        ms = result.ms_feedforward
        body["ms_feedforward"] = {"poly_bar_per_deg_j": ms.poly, "k_bar_per_deg": ms.k, "D_deg": ms.D,
                                  "train_rmse_bar": ms.train_rmse_bar}
    return body


def write_control(result: ControlResult, out_dir: str | Path, cfg: ControlConfig, prov: dict, *,
                  model: VBMM, plant: Plant, figure: bool = True) -> list[Path]:
    """Write DIR/summary.csv, DIR/control.yaml (schema bpmid.control/1), DIR/traces/<reference>.csv and
    DIR/fig18.png, all at once (nothing half-written on failure)."""
    from bpmid.io.atomic import staged_dir
    from bpmid.io.results import write_result

    out_dir = Path(out_dir)
    written = []
    with staged_dir(out_dir) as tmp:
        result.table.to_csv(tmp / "summary.csv", index=False, float_format="%.6g")
        written.append(out_dir / "summary.csv")
        (tmp / "traces").mkdir()
        for name in dict.fromkeys(r.reference for r in result.runs):
            mine = [r for r in result.runs if r.reference == name]
            cols = {"time_s": mine[0].time_s, "reference_deg": mine[0].reference_deg}
            for r in mine:
                cols[f"angle_deg_{r.controller}"] = r.angle_deg
                cols[f"true_angle_deg_{r.controller}"] = r.true_angle_deg
                cols[f"command_bar_abs_{r.controller}"] = r.command_bar_abs
                cols[f"muscle_bar_abs_{r.controller}"] = r.muscle_bar_abs
                if _KIND.get(r.controller) != CK.CTRL_PI:  # plain PI has no feedforward (not a column of zeros)
                    cols[f"feedforward_bar_abs_{r.controller}"] = r.feedforward_bar_abs
            safe = "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in name)
            pd.DataFrame(cols).to_csv(tmp / "traces" / f"{safe}.csv", index=False, float_format="%.6f")
            written.append(out_dir / "traces" / f"{safe}.csv")
        body = control_yaml_body(result, cfg, model=model, plant=plant)
        write_result(tmp / "control.yaml", "bpmid.control/1", body, prov)
        written.append(out_dir / "control.yaml")
        if figure:
            from bpmid.plots.common import save_figure
            from bpmid.plots.control import fig18

            fig = save_figure(fig18(result.runs, limits_bar=(cfg.p_min_bar_abs, cfg.p_max_bar_abs),
                                    atmosphere_bar=cfg.atmosphere_bar), tmp / "fig18.png")
            written.append(out_dir / fig.name)
    _drop_stale(Path(out_dir), written)
    return written


def _drop_stale(out_dir: Path, written: Sequence[Path]) -> None:
    """A control run into a folder an earlier one wrote: its figure and traces that this run did not write are
    removed (a report read the earlier figure beside this run's numbers; traces of references not run now stayed
    beside the new ones). Only bpmid control's own file names; nothing else in the folder is touched."""
    keep = {Path(p).resolve() for p in written}
    old = [out_dir / f"fig18.{ext}" for ext in ("png", "svg", "pdf")] + sorted((out_dir / "traces").glob("*.csv"))
    for f in old:
        if f.is_file() and f.resolve() not in keep:
            f.unlink()


__all__ = ["ControlConfig", "write_control", "control_yaml_body", "build_plant", "causal_terms", "Reference", "Plant", "PlantTerms", "MSFeedforward", "Run", "ControlResult",
           "builtin_reference", "read_reference", "load_references", "fit_ms_feedforward", "simulate_loop",
           "run_control", "summary_table", "feedforward_cost", "scaled_plant_model", "CONTROLLERS"]

# ``bpmid.control(...)`` is the public workflow (bpmid.api.control); this module stays importable as before
from bpmid._callable import make_callable as _make_callable  # noqa: E402

_make_callable(__name__, "bpmid.api:control")
