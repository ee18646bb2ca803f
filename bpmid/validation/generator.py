"""Design, simulate and write out-of-family validation cases (see the package docstring for the API)."""
from __future__ import annotations

import dataclasses
import hashlib
import math
from pathlib import Path
from typing import Literal, Mapping, Optional, Sequence, Union

import numpy as np
import yaml

from bpmid.io import yamlsafe

from bpmid.errors import InputError
from bpmid.validation import physics
from bpmid.units import ATMOSPHERE_PA, PA_PER_BAR, PA_PER_KPA
from bpmid.units import PA_PER_PSI as PSI_PA
from bpmid.validation.forms import CATALOGUE_IDS, FORMS, OUT_OF_CATALOGUE_IDS, Form, empty_spec, merge

GENERATOR = "bpmid.validation/1"
ANSWERS_SCHEMA = "bpmid.validation-answers/1"
_PRESSURE_FACTOR = {"bar": PA_PER_BAR, "kpa": PA_PER_KPA, "psi": PSI_PA}


# ---------------------------------------------------------------------------------------------
# configuration
# ---------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class GeometrySpec:
    """A muscle geometry in the units a datasheet gives (mm, deg); ``name`` labels it in the outputs."""

    name: str
    th_mm: float
    alpha0_deg: float
    R0_mm: float
    l0_mm: float
    n: float

    def validate(self, where, path):
        for k in ("th_mm", "alpha0_deg", "R0_mm", "l0_mm", "n"):
            v = getattr(self, k)
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"must be positive, found {v!r}", path=path, key=f"{where}.{k}")
        if not self.alpha0_deg < 90:
            raise InputError(f"must be below 90 deg, found {self.alpha0_deg}", path=path, key=f"{where}.alpha0_deg")
        # the muscle's sizes as the model checks them, here under this section's own key, before any case runs
        from bpmid.models.vbmm.model import ALPHA0_MIN_DEG, GEOMETRY_MAX_M, GEOMETRY_MIN_M

        if self.alpha0_deg < ALPHA0_MIN_DEG:
            raise InputError(f"a braid angle of {self.alpha0_deg:g} deg is too small for a muscle (at least "
                             f"{ALPHA0_MIN_DEG:g} deg): radians given under a _deg key? alpha0_deg takes degrees "
                             f"({math.degrees(self.alpha0_deg):.4g} for {self.alpha0_deg:g} rad)", path=path,
                             key=f"{where}.alpha0_deg")

        for field in ("th", "R0", "l0"):
            mm = getattr(self, f"{field}_mm")
            lo, hi = GEOMETRY_MIN_M[field] * 1e3, GEOMETRY_MAX_M[field] * 1e3
            if mm < lo:
                raise InputError(f"{mm:g} mm is too small for a muscle (at least {lo:g} mm): metres given under a _mm "
                                 f"key? {field}_mm takes millimetres ({mm * 1e3:g} for {mm:g} m)", path=path,
                                 key=f"{where}.{field}_mm")
            if mm > hi:
                raise InputError(f"{mm:g} mm is too large for a muscle (at most {hi:g} mm): {field}_mm takes "
                                 f"millimetres", path=path, key=f"{where}.{field}_mm")

    def si(self) -> np.ndarray:
        """(th, alpha0, R0, l0, n) in m, rad."""
        return np.array([self.th_mm * 1e-3, math.radians(self.alpha0_deg), self.R0_mm * 1e-3, self.l0_mm * 1e-3,
                         self.n], float)

    def to_yaml(self) -> dict:
        th, a0, R0, l0, n = (float(f"{v:.12g}") for v in self.si())
        return {"th": th, "alpha0": a0, "R0": R0, "l0": l0, "n": n}


#: the values the generator accepts for each drawn quantity (a range's ends, or a rig's single value)
VALUE_RANGES = {"sampling_hz": (1.0, 2000.0), "noise_deg": (0.0, 10.0), "noise_rho": (0.0, 0.99),
                "variation": (0.0, 0.3), "size_ratio": (1.0, 50.0), "atmosphere_pa": (50e3, 120e3),
                "pressure_noise_pa": (0.0, 1e4)}

#: built-in geometries: the paper's muscle (Table I) and two others
GEOMETRIES = {
    "paper": GeometrySpec("paper", 2.0, 30.0, 16.73, 195.9, 7.43),
    "slim": GeometrySpec("slim", 1.5, 25.0, 11.0, 140.0, 5.2),
    "wide": GeometrySpec("wide", 2.6, 36.0, 22.5, 260.0, 9.6),
}


@dataclasses.dataclass(frozen=True)
class GeneratorConfig:
    """Section ``generator`` of a sweep config: what cases to make. Ranges are ``[low, high]`` (drawn uniformly
    per case); lists are choices (drawn per case). A rig calibrates on its own noise by giving one value.

    Attributes
    ----------
    n_cases : number of cases
    mix : share of each kind: single (one catalogue effect), null, pair (two catalogue effects),
        out_of_catalogue (payload inertia, Mullins, air leak)
    effects : catalogue ids used for single and pair cases
    out_of_catalogue : out-of-catalogue ids used
    geometries : built-in names (paper, slim, wide) or mappings {name, th_mm, alpha0_deg, R0_mm, l0_mm, n}
    sampling_hz : sampling rates (Hz) to choose from
    pressure_units : bar, kpa, psi
    pressure_references : absolute, gauge
    time_units : s, ms
    header_styles : bpmid (``time_s,pressure_bar,angle_deg``) or instrument (``Time (ms),Pressure (psi),Angle (deg)``)
    atmosphere_pa : range of the ambient pressure (Pa) the absolute logs refer to (stated in each case.yaml)
    noise_deg : range of the sensor noise standard deviation (deg)
    noise_rho : range of the AR(1) lag-1 correlation of the noise from one sample to the next (0 = white), as
        measured on a rig's logs at its own rate
    white_share : share of cases with white noise whatever noise_rho says
    pressure_noise_pa : range of the pressure transducer's white noise standard deviation (Pa) on the logged
        pressure; the muscle sees the pressure without it ([0, 0], the default: a noise-free pressure log, as every
        draw before it existed)
    variation : range of the log-to-log variation of the constants (relative standard deviation, 0.05 = 5 %)
    size_ratio : range of the held-out RMSE of the true base model over the noise (1.5: just detectable)
    duration_scale : multiplies the number of cycles and the hold times of every protocol (1 = paper-sized)
    integration : ``continuous`` (sub-steps <= ``max_step_s``, a muscle in continuous time) or ``log_rate``
        (one step per log sample, the discretisation of VBMM.md)
    max_step_s : largest internal step (s) for continuous integration
    """

    n_cases: int = 24
    mix: Mapping[str, float] = dataclasses.field(default_factory=lambda: {
        "single": 0.5, "null": 0.2, "pair": 0.15, "out_of_catalogue": 0.15})
    effects: tuple[str, ...] = CATALOGUE_IDS
    out_of_catalogue: tuple[str, ...] = OUT_OF_CATALOGUE_IDS
    geometries: tuple[Union[str, GeometrySpec], ...] = ("paper", "slim", "wide")
    sampling_hz: tuple[float, ...] = (10.0, 20.0, 50.0, 100.0)
    pressure_units: tuple[Literal["bar", "kpa", "psi"], ...] = ("bar", "kpa", "psi")
    pressure_references: tuple[Literal["absolute", "gauge"], ...] = ("absolute", "gauge")
    time_units: tuple[Literal["s", "ms"], ...] = ("s", "ms")
    header_styles: tuple[Literal["bpmid", "instrument"], ...] = ("bpmid", "instrument")
    atmosphere_pa: tuple[float, float] = (ATMOSPHERE_PA, ATMOSPHERE_PA)
    noise_deg: tuple[float, float] = (0.1, 0.3)
    noise_rho: tuple[float, float] = (0.0, 0.8)
    white_share: float = 0.4
    pressure_noise_pa: tuple[float, float] = (0.0, 0.0)
    variation: tuple[float, float] = (0.0, 0.05)
    size_ratio: tuple[float, float] = (1.5, 4.0)
    duration_scale: float = 1.0
    integration: Literal["continuous", "log_rate"] = "continuous"
    max_step_s: float = 0.002

    def __post_init__(self):  # plain containers, so cases pickle (Dask ships them to workers)
        # YAML reads a bare ``null:`` key as None: that is the null kind here
        object.__setattr__(self, "mix", {("null" if k is None or k == "None" else str(k)): float(v)
                                         for k, v in dict(self.mix).items()})

    def validate(self, where, path):
        kinds = ("single", "null", "pair", "out_of_catalogue")
        for k, v in self.mix.items():
            if k not in kinds:
                raise InputError(f"unknown case kind (known: {', '.join(kinds)})", path=path, key=f"{where}.mix.{k}")
            if not (isinstance(v, (int, float)) and v >= 0):
                raise InputError(f"must be a share >= 0, found {v!r}", path=path, key=f"{where}.mix.{k}")
        if not sum(self.mix.values()) > 0:
            raise InputError("the shares must not all be 0", path=path, key=f"{where}.mix")
        if self.n_cases < 1:
            raise InputError(f"must be at least 1, found {self.n_cases}", path=path, key=f"{where}.n_cases")
        for e in self.effects:
            if e not in CATALOGUE_IDS:
                raise InputError(f"unknown catalogue id {e!r} (known: {', '.join(CATALOGUE_IDS)})", path=path,
                                 key=f"{where}.effects")
        if self.mix.get("pair", 0) > 0 and len(self.effects) < 2:
            raise InputError("pairs need at least two effects", path=path, key=f"{where}.effects")
        for e in self.out_of_catalogue:
            if e not in OUT_OF_CATALOGUE_IDS:
                raise InputError(f"unknown out-of-catalogue effect {e!r} (known: {', '.join(OUT_OF_CATALOGUE_IDS)})",
                                 path=path, key=f"{where}.out_of_catalogue")
        for i, g in enumerate(self.geometries):
            if isinstance(g, str) and g not in GEOMETRIES:
                raise InputError(f"unknown geometry {g!r} (built in: {', '.join(GEOMETRIES)}; or give a mapping "
                                 "name, th_mm, alpha0_deg, R0_mm, l0_mm, n)", path=path, key=f"{where}.geometries[{i}]")
        for name in ("geometries", "sampling_hz", "pressure_units", "pressure_references", "time_units",
                     "header_styles", "effects"):
            if not getattr(self, name):
                raise InputError("must not be empty", path=path, key=f"{where}.{name}")
        lo, hi = VALUE_RANGES["sampling_hz"]
        for f in self.sampling_hz:
            if not lo <= f <= hi:
                raise InputError(f"sampling rate {f} Hz is outside {lo:g}-{hi:g} Hz", path=path,
                                 key=f"{where}.sampling_hz")
        for name in ("noise_deg", "noise_rho", "variation", "size_ratio", "atmosphere_pa", "pressure_noise_pa"):
            lo_ok, hi_ok = VALUE_RANGES[name]
            rng = getattr(self, name)
            if len(rng) != 2 or not (lo_ok <= rng[0] <= rng[1] <= hi_ok):
                raise InputError(f"expected [low, high] within [{lo_ok:g}, {hi_ok:g}], found {list(rng)}", path=path,
                                 key=f"{where}.{name}")
        if self.noise_deg[0] <= 0:
            raise InputError("sensor noise must be above 0 deg (discovery needs raw measurements)", path=path,
                             key=f"{where}.noise_deg")
        if self.size_ratio[0] <= 1.0:
            raise InputError("size ratios are held-out RMSE / noise and must be above 1", path=path,
                             key=f"{where}.size_ratio")
        if not 0 <= self.white_share <= 1:
            raise InputError(f"must be between 0 and 1, found {self.white_share}", path=path,
                             key=f"{where}.white_share")
        if not 0.02 <= self.duration_scale <= 10:
            raise InputError(f"must be within 0.02-10, found {self.duration_scale}", path=path,
                             key=f"{where}.duration_scale")
        if not 1e-4 <= self.max_step_s <= 0.1:
            raise InputError(f"must be within 1e-4 - 0.1 s, found {self.max_step_s}", path=path,
                             key=f"{where}.max_step_s")

    def geometry_specs(self) -> list[GeometrySpec]:
        return [GEOMETRIES[g] if isinstance(g, str) else g for g in self.geometries]

    def to_yaml(self) -> dict:
        d = dataclasses.asdict(self)
        d["mix"] = dict(self.mix)
        d["geometries"] = [g if isinstance(g, str) else dataclasses.asdict(g) for g in self.geometries]
        if not self.pressure_noise_pa[1] > 0:   # absent: the configs (and fingerprints) of draws before it
            del d["pressure_noise_pa"]
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in d.items()}


def generator_config(data: Mapping | None = None, path=None, where: str = "generator") -> GeneratorConfig:
    """A :class:`GeneratorConfig` from a mapping (unknown keys -> InputError naming the key)."""
    from bpmid.config import build_dataclass
    return build_dataclass(GeneratorConfig, dict(data or {}), where, path)


# ---------------------------------------------------------------------------------------------
# the case
# ---------------------------------------------------------------------------------------------
def split_of(case_id: str) -> str:
    """``calibration`` or ``heldout``, from a hash of the case id alone (stable, independent of the sweep)."""
    h = int(hashlib.sha256(case_id.encode("utf-8")).hexdigest()[:8], 16)
    return "heldout" if h % 2 else "calibration"


@dataclasses.dataclass(frozen=True)
class EffectChoice:
    """One hidden effect of a case: id, physical form, shape constants, and the target size ratio."""

    effect: str
    form: str
    shape: Mapping[str, object]
    size_ratio: float

    def form_obj(self) -> Form:
        return next(f for f in FORMS[self.effect] if f.name == self.form)


@dataclasses.dataclass(frozen=True)
class Case:
    """One validation case, designed (not yet simulated: :func:`realize` does that, deterministically).

    Attributes
    ----------
    id : unique name (``<prefix>-<index>``); the split follows from it (:func:`split_of`)
    index, seed : position in the sweep and the seed of everything random in this case
    kind : single, null, pair or out_of_catalogue
    effects : the hidden effects (empty for a null)
    geometry : the muscle
    material : truth constants {G_inf, K_inf, G, K, tau} (Pa, s)
    start : the starting constants written to init.yaml (G as the truth, K and tau off)
    fs_hz, pressure_unit, pressure_reference, atmosphere_pa, time_unit, header_style : how the logs look
    noise_deg, noise_rho : sensor noise (standard deviation, AR(1) lag-1 correlation at the log rate)
    variation : log-to-log relative standard deviation of the constants
    pressure_noise_pa : the pressure transducer's white noise (Pa) on the logged pressure (0: none)
    p_lo_pa, p_hi_pa : gauge pressure range of the protocols (from the geometry: about 12-70 deg at rest)
    config : the generator config it was made from (for the labels)
    """

    id: str
    index: int
    seed: int
    kind: str
    effects: tuple[EffectChoice, ...]
    geometry: GeometrySpec
    material: Mapping[str, object]
    start: Mapping[str, object]
    fs_hz: float
    pressure_unit: str
    pressure_reference: str
    atmosphere_pa: float
    time_unit: str
    header_style: str
    noise_deg: float
    noise_rho: float
    variation: float
    p_lo_pa: float
    p_hi_pa: float
    config: GeneratorConfig
    pressure_noise_pa: float = 0.0

    @property
    def split(self) -> str:
        return split_of(self.id)

    @property
    def truth_label(self) -> str:
        """The row of the confusion matrix: ``none``, the catalogue id, ``pair`` or ``out_of_catalogue``."""
        if self.kind == "null":
            return "none"
        if self.kind == "single":
            return self.effects[0].effect
        return self.kind

    @property
    def truth(self) -> dict:
        """What was hidden (designed values; :func:`realize` adds the sized parameters)."""
        return {"kind": self.kind, "label": self.truth_label,
                "catalogue_ids": [e.effect for e in self.effects if e.effect in CATALOGUE_IDS],
                "effects": [{"id": e.effect, "form": e.form, "in_catalogue": e.effect in CATALOGUE_IDS,
                             "target_size_ratio": round(e.size_ratio, 4),
                             "shape": {k: v for k, v in e.shape.items()}} for e in self.effects]}


# ---------------------------------------------------------------------------------------------
# protocols (normalised pressure u in [0, 1] -> p_lo + u (p_hi - p_lo)); rates in u per s
# ---------------------------------------------------------------------------------------------
def _tri(hi, rate, cycles, hold=0.0):
    seg = []
    for _ in range(cycles):
        seg += [(hi, rate)] + ([(hi, -hold)] if hold else []) + [(0.0, rate)] + ([(0.0, -hold)] if hold else [])
    return seg


def _protocols(scale: float) -> list[tuple[str, str, list]]:
    """(name, role, segments) in recording order; held-out runs are interleaved with the fitting runs."""
    c = lambda n: max(1, int(round(n * scale)))  # noqa: E731
    h = lambda s: max(0.5, s * min(scale, 1.0) if scale < 1 else s)  # noqa: E731
    return [
        ("fit_cyclic", "fit", _tri(0.4, 0.2, c(8))),
        ("fit_va_mid", "fit", _tri(0.6, 0.2, c(4), hold=2.0)),
        ("ho_mixed", "holdout", [(0.6, 0.2), (0.6, -h(10.0)), (0.2, 0.3), (0.9, 0.15), (0.0, 0.25), (0.0, -h(5.0)),
                                 (0.8, 0.2), (0.8, -h(8.0)), (0.1, 0.2)]),
        ("fit_va_high", "fit", _tri(1.0, 0.2, c(3), hold=2.0)),
        ("fit_vr_slow", "fit", _tri(0.8, 0.114, c(3))),
        ("fit_vr_fast", "fit", _tri(0.8, 0.267, c(6))),
        ("ho_vr", "holdout", _tri(0.8, 0.16, c(4))),
        ("fit_hold", "fit", [(0.8, 0.4), (0.8, -h(20.0)), (0.0, 0.4), (0.0, -h(10.0)), (0.6, 0.4), (0.6, -h(15.0))]),
        ("ho_va", "holdout", _tri(0.8, 0.2, c(4), hold=2.0)),
        ("fit_long", "fit", _tri(0.6, 0.2, c(40))),
        ("ho_long", "holdout", _tri(0.8, 0.2, c(25))),
    ]


def _profile(segments, dt):
    """Times (s) and u for piecewise-linear segments: (target, rate) ramps, (level, -seconds) holds."""
    knots_t, knots_u = [0.0], [0.0]
    for target, how in segments:
        if how < 0:
            knots_t.append(knots_t[-1] - how)
            knots_u.append(knots_u[-1])
        else:
            knots_t.append(knots_t[-1] + abs(target - knots_u[-1]) / how)
            knots_u.append(target)
    n = int(math.floor(knots_t[-1] / dt + 1e-9)) + 1
    t = np.arange(n) * dt
    return t, np.interp(t, knots_t, knots_u)


# ---------------------------------------------------------------------------------------------
# design
# ---------------------------------------------------------------------------------------------
PAPER_MATERIAL = {"G_inf": 0.00905e6, "K_inf": 6.434e6, "G": [0.0183e6], "K": [13.645e6], "tau": [0.213]}


def _pressure_range(geo: np.ndarray, mat: Mapping) -> tuple[float, float]:
    """Gauge pressures (Pa) holding about 12 and 70 deg in relaxed equilibrium."""
    lo, hi = physics.equilibrium_pressure(np.radians([12.0, 70.0]), geo, mat["G_inf"], mat["K_inf"])
    return float(lo), float(hi)


def _choice(rng, seq):
    return seq[int(rng.integers(len(seq)))]


def _kinds(cfg: GeneratorConfig, rng) -> list[str]:
    """Case kinds in proportion to ``mix`` (largest remainder), in a seeded random order."""
    names = [k for k in ("single", "null", "pair", "out_of_catalogue") if cfg.mix.get(k, 0) > 0]
    w = np.array([float(cfg.mix[k]) for k in names])
    raw = w / w.sum() * cfg.n_cases
    cnt = np.floor(raw).astype(int)
    for i in np.argsort(-(raw - cnt))[: cfg.n_cases - cnt.sum()]:
        cnt[i] += 1
    kinds = [k for k, n in zip(names, cnt) for _ in range(n)]
    rng.shuffle(kinds)
    return kinds


def make_cases(config: GeneratorConfig | Mapping | None = None, seed: int = 0, *, prefix: str = "oof") -> list[Case]:
    """Design ``config.n_cases`` cases, deterministically from ``seed``.

    Single-effect cases cycle through the effects (and each effect's forms) so every id and form appears;
    everything else (geometry, rate, units, noise, variation, size) is drawn from the config's choices.
    """
    cfg = config if isinstance(config, GeneratorConfig) else generator_config(config)
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 12]))
    kinds = _kinds(cfg, rng)
    geos = cfg.geometry_specs()
    single_order = [e for e in cfg.effects]
    pairs = [(a, b) for i, a in enumerate(cfg.effects) for b in cfg.effects[i + 1:]]
    pairs = [pairs[j] for j in rng.permutation(len(pairs))]  # every pair once before any repeats
    counters = {"single": 0, "pair": 0, "out_of_catalogue": 0}
    cases = []
    for i, kind in enumerate(kinds):
        cseed = int(np.random.SeedSequence([int(seed), i]).generate_state(1)[0])
        r = np.random.default_rng(cseed)
        k = counters.get(kind, 0)
        counters[kind] = k + 1
        if kind == "single":
            ids = [single_order[k % len(single_order)]]
        elif kind == "pair":
            ids = list(pairs[k % len(pairs)])
        elif kind == "out_of_catalogue":
            ids = [cfg.out_of_catalogue[k % len(cfg.out_of_catalogue)]] if cfg.out_of_catalogue else []
            if not ids:
                kind, ids = "null", []
        else:
            ids = []
        effects = []
        for j, eid in enumerate(ids):
            forms = FORMS[eid]
            # cycle forms by how often this id appeared, so every form is used
            form = forms[(k // max(len(single_order), 1) + j) % len(forms)] if kind == "single" else _choice(r, forms)
            effects.append(EffectChoice(eid, form.name, form.draw(r), float(r.uniform(*cfg.size_ratio))))
        geo = geos[int(r.integers(len(geos)))]
        f = lambda lo, hi: float(r.uniform(lo, hi))  # noqa: E731
        mat = {"G_inf": PAPER_MATERIAL["G_inf"], "K_inf": PAPER_MATERIAL["K_inf"] * f(0.8, 1.25),
               "G": [PAPER_MATERIAL["G"][0]], "K": [PAPER_MATERIAL["K"][0] * f(0.8, 1.25)],
               "tau": [PAPER_MATERIAL["tau"][0] * f(0.6, 1.6)]}
        start = {"G_inf": mat["G_inf"], "K_inf": mat["K_inf"] * f(1.0, 1.1), "G": list(mat["G"]),
                 "K": [mat["K"][0] * f(0.95, 1.05)], "tau": [mat["tau"][0] * f(1.4, 2.0)]}
        fs = float(_choice(r, cfg.sampling_hz))
        rho = 0.0 if r.uniform() < cfg.white_share else f(*cfg.noise_rho)
        lo, hi = _pressure_range(geo.si(), mat)
        cases.append(Case(
            id=f"{prefix}-{i:04d}", index=i, seed=cseed, kind=kind, effects=tuple(effects), geometry=geo,
            material=mat, start=start, fs_hz=fs, pressure_unit=str(_choice(r, cfg.pressure_units)),
            pressure_reference=str(_choice(r, cfg.pressure_references)), atmosphere_pa=f(*cfg.atmosphere_pa),
            time_unit=str(_choice(r, cfg.time_units)), header_style=str(_choice(r, cfg.header_styles)),
            noise_deg=f(*cfg.noise_deg), noise_rho=float(rho),
            variation=f(*cfg.variation), p_lo_pa=lo, p_hi_pa=hi, config=cfg,
            # drawn only when asked for, so that the draws before it make the same cases
            pressure_noise_pa=f(*cfg.pressure_noise_pa) if cfg.pressure_noise_pa[1] > 0 else 0.0))
    return cases


# ---------------------------------------------------------------------------------------------
# simulation
# ---------------------------------------------------------------------------------------------
@dataclasses.dataclass
class Log:
    """One simulated run: name, role (fit or holdout), log times (s), logged gauge pressure (Pa), noise-free
    true angle (deg) and measured angle (deg)."""

    name: str
    role: str
    time_s: np.ndarray
    pressure_pa: np.ndarray
    angle_true_deg: np.ndarray
    angle_deg: np.ndarray


@dataclasses.dataclass
class CaseData:
    """A realised case: its logs and the truth with the sized effect parameters."""

    case: Case
    logs: list[Log]
    truth: dict

    def role(self, role: str) -> list[Log]:
        return [lg for lg in self.logs if lg.role == role]


def _variation_factors(case: Case, n_logs: int, rng) -> list[dict]:
    """Per log, a multiplicative factor on each constant (K_inf, K_j, G_inf, G_j, tau_j), clipped at 2.5 sd."""
    out = []
    for _ in range(n_logs):
        z = np.clip(rng.normal(size=5), -2.5, 2.5) * case.variation
        out.append({"K_inf": 1 + z[0], "K": 1 + z[1], "G_inf": 1 + z[2], "G": 1 + z[3], "tau": 1 + z[4]})
    return out


def _simulate_logs(case: Case, spec: dict, protos, var, offsets) -> list[np.ndarray]:
    """Noise-free angle (deg) of every run in recording order for the physics ``spec``."""
    geo = case.geometry.si()
    cfg = case.config
    dt_log = 1.0 / case.fs_hz
    sub = 1 if cfg.integration == "log_rate" else max(1, int(math.ceil(dt_log / cfg.max_step_s - 1e-9)))
    m = case.material
    emax = 0.0
    out = []
    fr = spec["friction"]
    fr_kind = physics.FRICTION_KINDS[fr["kind"]]
    fr_par = np.asarray(fr["par"] or [0.0], float)
    n_fr = {0: 0, 1: 1, 2: 1, 3: len(fr["par"]) // 2}[fr_kind]
    st = spec["stiffening"]
    mu = spec["mullins"]
    ine = spec["inertia"]
    for (name, role, seg), fac, off in zip(protos, var, offsets):
        t, u = _profile(seg, dt_log)
        p_log = case.p_lo_pa + u * (case.p_hi_pa - case.p_lo_pa)
        tf = np.arange((t.size - 1) * sub + 1) * (dt_log / sub)
        pf = np.interp(tf, t, p_log)
        pf = physics.pressure_path(tf, pf, **spec["pressure"])
        th = spec["thermal"]
        if th["kind"] == "exponential":
            soft = 1.0 - th["a"] * (1.0 - np.exp(-tf / th["T"]))
        elif th["kind"] == "linear":
            soft = np.maximum(1.0 - th["b"] * tf, 0.3)
        else:
            soft = np.ones_like(tf)
        G1 = [g * fac["G"] for g in m["G"]]
        K1 = [k * fac["K"] for k in m["K"]]
        tau = [tt * fac["tau"] for tt in m["tau"]]
        for br in spec["extra_branches"]:  # slow branches as a share of the long-term moduli
            G1.append(br["share"] * m["G_inf"] * fac["G_inf"])
            K1.append(br["share"] * m["K_inf"] * fac["K_inf"])
            tau.append(br["tau"] * fac["tau"])
        Ginf, Kinf = m["G_inf"] * fac["G_inf"], m["K_inf"] * fac["K_inf"]
        mass = damp = 0.0
        if ine["f_n_hz"] > 0:
            # effective stiffness dP/dbeta of the instantaneous (all-branch) moduli at mid range
            Gi, Ki = Ginf + sum(G1), Kinf + sum(K1)
            b0, b1 = math.radians(40.0), math.radians(41.0)
            pp = physics.equilibrium_pressure(np.array([b0, b1]), geo, Gi, Ki)
            k_eff = float(pp[1] - pp[0]) / (b1 - b0)
            wn = 2 * math.pi * ine["f_n_hz"]
            mass = k_eff / wn**2
            damp = 2 * ine["zeta"] * math.sqrt(k_eff * mass)
        beta, emax = physics.simulate_fine(
            tf, pf, soft, geo, Ginf, Kinf, np.asarray(G1, float), np.asarray(K1, float), np.asarray(tau, float),
            float(spec["fall_ratio"]), fr_kind, fr_par, n_fr, physics.STIFFENING_KINDS[st["kind"]], float(st["C"]),
            float(st["k"]), float(mu["rinv"]), float(mu["m"]), emax, mass, damp)
        out.append(np.degrees(beta[::sub]) + off)
    return out


def simulate_spec(case: Case, spec: dict | None = None, protocols: Sequence | None = None, *,
                  variation: bool = False) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Noise-free runs of ``case``'s muscle with the physics ``spec`` (default: no effect): a list of (time s,
    logged gauge pressure Pa, angle deg), one per protocol (default: the case's protocols; or a list of
    ``(name, role, segments)`` in normalised pressure, see :func:`_protocols`). For checks and plots."""
    spec = spec or empty_spec()
    protos = list(protocols) if protocols is not None else _protocols(case.config.duration_scale)
    rng = np.random.default_rng(case.seed)
    var = (_variation_factors(case, len(protos), rng) if variation else
           [{"K_inf": 1.0, "K": 1.0, "G_inf": 1.0, "G": 1.0, "tau": 1.0}] * len(protos))
    angles = _simulate_logs(case, spec, protos, var, _offsets(spec, len(protos), rng))
    out = []
    for (name, role, seg), ang in zip(protos, angles):
        t, u = _profile(seg, 1.0 / case.fs_hz)
        out.append((t, case.p_lo_pa + u * (case.p_hi_pa - case.p_lo_pa), ang))
    return out


def _offsets(spec: dict, n: int, rng) -> list[float]:
    o = spec["offset"]
    z = rng.normal(size=n)
    return [float(o["deg"] + o["per_log_sd"] * zi) for zi in z]


def _heldout_rms(a: list[np.ndarray], b: list[np.ndarray], roles) -> float:
    d = np.concatenate([x - y for x, y, r in zip(a, b, roles) if r == "holdout"])
    return float(np.sqrt(np.mean(d**2)))


def _size(case: Case, choice: EffectChoice, protos, var, base_ho: list[np.ndarray], roles,
          rng_state) -> tuple[float, float]:
    """Strength s so that the held-out RMS difference from the true base model is noise * sqrt(ratio^2 - 1),
    i.e. the true base model's held-out RMSE on the noisy logs is ``ratio`` times the noise. Returns (s, achieved
    ratio). Secant on log s, a few simulations."""
    form = choice.form_obj()
    target = case.noise_deg * math.sqrt(choice.size_ratio**2 - 1.0)

    def rms(s):
        spec = merge([form.spec(s, dict(choice.shape))])
        offs = _offsets(spec, len(protos), np.random.default_rng(rng_state))
        sim = _simulate_logs(case, spec, protos, var, offs)
        return _heldout_rms(sim, base_ho, roles)

    s = 1.0
    r = rms(s)
    hist = [(s, r)]
    for _ in range(8):
        if r <= 0:
            s_new = min(s * 4, form.s_max)
        elif len(hist) >= 2 and hist[-1][1] > 0 and hist[-2][1] > 0 and hist[-1][0] != hist[-2][0] \
                and abs(math.log(hist[-1][1] / hist[-2][1])) > 1e-6:
            (s1, r1), (s2, r2) = hist[-2], hist[-1]
            slope = math.log(r2 / r1) / math.log(s2 / s1)
            slope = min(max(slope, 0.3), 3.0)
            s_new = s2 * (target / r2) ** (1.0 / slope)
        else:
            s_new = s * (target / r)
        s_new = float(min(max(s_new, 1e-4), form.s_max))
        if s_new == s:
            break
        s = s_new
        r = rms(s)
        hist.append((s, r))
        if abs(r / target - 1.0) < 0.03:
            break
    s, r = min(hist, key=lambda x: abs(math.log(max(x[1], 1e-12) / target)))
    achieved = math.sqrt(1.0 + (r / case.noise_deg) ** 2)
    return s, achieved


def realize(case: Case) -> CaseData:
    """Simulate a case (deterministic from ``case.seed``): size each effect, then the noisy logs."""
    rng = np.random.default_rng(case.seed)
    protos = _protocols(case.config.duration_scale)
    roles = [p[1] for p in protos]
    var = _variation_factors(case, len(protos), rng)
    offset_seed = int(rng.integers(2**31))
    base = _simulate_logs(case, empty_spec(), protos, var, [0.0] * len(protos))
    specs, sized = [], []
    for ch in case.effects:
        s, achieved = _size(case, ch, protos, var, base, roles, offset_seed)
        sp = ch.form_obj().spec(s, dict(ch.shape))
        specs.append(sp)
        sized.append({"id": ch.effect, "form": ch.form, "strength": round(s, 6), "physics": _plain(sp),
                      "achieved_size_ratio": round(achieved, 4)})
    spec = merge(specs)
    offs = _offsets(spec, len(protos), np.random.default_rng(offset_seed))
    clean = _simulate_logs(case, spec, protos, var, offs) if case.effects else base
    logs = []
    # the transducer's noise from a stream of its own: the same angles (and angle noise) with or without it
    prng = np.random.default_rng((case.seed, 7)) if case.pressure_noise_pa > 0 else None
    for (name, role, seg), ang in zip(protos, clean):
        t, u = _profile(seg, 1.0 / case.fs_hz)
        p = case.p_lo_pa + u * (case.p_hi_pa - case.p_lo_pa)
        e = _ar1(rng, t.size, case.noise_deg, case.noise_rho)
        if case.pressure_noise_pa > 0:   # the transducer's noise is in the log, not in what the muscle saw
            p = p + prng.normal(0.0, case.pressure_noise_pa, t.size)
        logs.append(Log(name, role, t, p, ang, ang + e))
    ho_true = _heldout_rms(clean, base, roles)
    truth = dict(case.truth)
    truth["effects"] = [dict(a, **b) for a, b in zip(truth["effects"], sized)]
    truth["heldout_rmse_true_base_deg"] = round(math.sqrt(ho_true**2 + case.noise_deg**2), 5)
    truth["heldout_size_ratio"] = round(math.sqrt(1.0 + (ho_true / case.noise_deg) ** 2), 4)
    truth["noise"] = {"sigma_deg": round(case.noise_deg, 5), "ar1_rho": round(case.noise_rho, 4),
                      "colour": "white" if case.noise_rho == 0 else "AR(1)"}
    truth["log_to_log_variation"] = round(case.variation, 5)
    if case.pressure_noise_pa > 0:
        truth["pressure_noise_pa"] = round(case.pressure_noise_pa, 3)
    truth["material"] = _plain(case.material)
    truth["per_log_factors"] = {p[0]: {k: round(float(v), 5) for k, v in f.items()} for p, f in zip(protos, var)}
    return CaseData(case, logs, truth)


def _ar1(rng, n: int, sigma: float, rho: float) -> np.ndarray:
    """Stationary AR(1) Gaussian noise, standard deviation ``sigma``, lag-1 correlation ``rho``."""
    from scipy.signal import lfilter
    w = rng.normal(0.0, sigma * math.sqrt(1.0 - rho**2), n)
    if rho == 0:
        return rng.normal(0.0, sigma, n) if n else w
    e0 = rng.normal(0.0, sigma)
    out, _ = lfilter([1.0], [1.0, -rho], w, zi=[rho * e0])
    return out


def _plain(x):
    """YAML-safe plain types."""
    if isinstance(x, Mapping):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return float(x)
    if isinstance(x, (np.integer, int)) and not isinstance(x, bool):
        return int(x)
    return x


# ---------------------------------------------------------------------------------------------
# writing a case as a user would have recorded it
# ---------------------------------------------------------------------------------------------
def config_digest(cfg: GeneratorConfig) -> str:
    """A short fingerprint of a generator config (the full config is in the answers files)."""
    return hashlib.sha256(yaml.safe_dump(cfg.to_yaml(), sort_keys=True).encode("utf-8")).hexdigest()[:16]


def _label(case: Case) -> dict:
    return {"synthetic": "true (bpmid.validation out-of-family generator; not a measurement)",
            "generator": f"{GENERATOR} (independent physics, not bpmid's effect terms)",
            "generator_config": f"sha256:{config_digest(case.config)}",
            "case": case.id, "seed": str(case.seed)}


def _csv(case: Case, lg: Log) -> str:
    unit = case.pressure_unit
    p = lg.pressure_pa + (case.atmosphere_pa if case.pressure_reference == "absolute" else 0.0)
    p = p / _PRESSURE_FACTOR[unit]
    tt = lg.time_s * (1e3 if case.time_unit == "ms" else 1.0)
    if case.header_style == "instrument":
        header = f"Time ({case.time_unit}),Pressure ({unit}),Angle (deg)"
    else:
        header = f"time_{case.time_unit},pressure_{unit},angle_deg"
    pdec = {"bar": 6, "kpa": 4, "psi": 5}[unit]
    tdec = 3 if case.time_unit == "ms" else 6
    lines = [f"# pressure_reference: {case.pressure_reference}"]
    lines += [f"# {k}: {v}" for k, v in _label(case).items()]
    lines.append(header)
    lines += [f"{a:.{tdec}f},{b:.{pdec}f},{c:.5f}" for a, b, c in zip(tt, p, lg.angle_deg)]
    return "\n".join(lines) + "\n"


def case_config_yaml(case: Case) -> str:
    """``case.yaml``: a bpmid config (sections io and model) with the muscle's geometry, plus labels as comments."""
    body = {"io": {"atmosphere_pa": round(case.atmosphere_pa, 1)},
            "model": {"closure": "paper", "geometry": case.geometry.to_yaml()}}
    head = [f"# synthetic validation case {case.id} ({GENERATOR}, seed {case.seed}, generator config "
            f"sha256:{config_digest(case.config)}); not a measurement",
            f"# geometry: {case.geometry.name} (th {case.geometry.th_mm} mm, alpha0 {case.geometry.alpha0_deg} deg, "
            f"R0 {case.geometry.R0_mm} mm, l0 {case.geometry.l0_mm} mm, n {case.geometry.n})",
            f"# sampling {case.fs_hz:g} Hz; pressure {case.pressure_unit} {case.pressure_reference}; time in "
            f"{case.time_unit}",
            "# run: bpmid discover fit/*.csv --holdout holdout/*.csv --init init.yaml --config case.yaml --out OUT",
            "# the hidden truth is not in this folder (answers/<split>.yaml of the sweep output)"]
    return "\n".join(head) + "\n" + yamlsafe.dump(body, sort_keys=False)


def init_yaml(case: Case) -> str:
    """``init.yaml``: starting constants (bpmid.vbmm/1), as a relaxation test would give them (G right, K and tau
    off); geometry and closure as in case.yaml."""
    s = case.start

    def par(v, unit):
        return {"value": float(v), "stderr": None, "unit": unit}
    body = {"schema": "bpmid.vbmm/1", "geometry": case.geometry.to_yaml(), "closure": "paper",
            "material": {"G_inf": par(s["G_inf"], "Pa"), "K_inf": par(s["K_inf"], "Pa"),
                         "branches": [{"G": par(g, "Pa"), "K": par(k, "Pa"), "tau": par(t, "s")}
                                      for g, k, t in zip(s["G"], s["K"], s["tau"])]},
            "provenance": {"generator": GENERATOR, "synthetic": True, "case": case.id, "seed": case.seed,
                           "note": "starting constants for a synthetic validation case (not a fit)"}}
    return yamlsafe.dump(body, sort_keys=False)


def write_case(case: Case | CaseData, out_dir: str | Path) -> dict:
    """Write the case folder ``out_dir/<case.id>``: ``fit/*.csv``, ``holdout/*.csv``, ``case.yaml`` (config),
    ``init.yaml`` (starting constants). The truth is NOT written here; the returned answer entry goes to
    :func:`write_answers`, in a separate place. Files are written atomically."""
    from bpmid.io.atomic import write_text
    data = case if isinstance(case, CaseData) else realize(case)
    c = data.case
    d = Path(out_dir) / c.id
    for lg in data.logs:
        write_text(d / ("fit" if lg.role == "fit" else "holdout") / f"{lg.name}.csv", _csv(c, lg))
    write_text(d / "init.yaml", init_yaml(c))
    write_text(d / "case.yaml", case_config_yaml(c))
    return answer_entry(data)


def answer_entry(data: CaseData) -> dict:
    c = data.case
    return {"id": c.id, "split": c.split, "seed": c.seed, "truth": _plain(data.truth),
            "geometry": c.geometry.name, "sampling_hz": c.fs_hz,
            "pressure": f"{c.pressure_unit} {c.pressure_reference}",
            "time_unit": c.time_unit}


def write_answers(entries: Sequence[dict], path: str | Path, *, config: GeneratorConfig | None = None,
                  seed: Optional[int] = None) -> Path:
    """The answers of one split (a separate file, never beside the logs)."""
    from bpmid.io.atomic import write_text
    body = {"schema": ANSWERS_SCHEMA, "generator": GENERATOR, "synthetic": True, "seed": seed,
            "config": None if config is None else config.to_yaml(),
            "config_sha256": None if config is None else config_digest(config),
            "cases": {e["id"]: {k: v for k, v in e.items() if k != "id"}
                      for e in sorted(entries, key=lambda e: e["id"])}}
    return write_text(path, yamlsafe.dump(_plain(body), sort_keys=False))


def case_paths(case_dir: str | Path) -> dict:
    """Paths of a written case: fit logs, held-out logs, config and init file."""
    d = Path(case_dir)
    return {"fit": sorted((d / "fit").glob("*.csv")), "holdout": sorted((d / "holdout").glob("*.csv")),
            "config": d / "case.yaml", "init": d / "init.yaml"}
