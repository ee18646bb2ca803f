"""The viscoelasticity-based mechanistic model (VBMM) of a bending pneumatic muscle, as the project's model spec
(VBMM.md; docs/model.md) makes it precise.

- Kinematics from one scalar u3 (radial displacement, m): :func:`kinematics`, :func:`u3_from_beta`.
- Stresses from Prony kernels for G and K (any number of branches, time constants shared or split),
  lambda-hat = K-hat - 2/3 G-hat, eps3 = 0.
- Pressure closures: ``"paper"`` (eq. 18 implemented literally in SI, the default) and ``"consistent"``.
- Forward model beta(P) (:meth:`VBMM.forward`, compiled per-step solve) and inverse model P(beta)
  (:meth:`VBMM.inverse`, closed form, vectorised), in three history modes: ``recursive`` (exact, O(1)
  per step, default), ``window`` (eq. 19) and ``full`` (eq. 5 as written).

Deviations from the paper, on purpose (see README): BL is taken as sqrt(l0^2 + 4 pi^2 n^2 R0^2) so that
beta = 0 <=> u3 = 0 (VBMM.md section 1); pressures are gauge inside the model.

Units: SI inside (m, Pa, s, rad). Results files carry the units of every constant.
"""
from __future__ import annotations

import dataclasses
import functools
import math
from pathlib import Path
from typing import Literal, Optional, Sequence

import numpy as np

from bpmid.errors import InputError
from bpmid.models import _vbmm_kernels as K
from bpmid.units import PA_PER_MPA
from bpmid.viscoelastic import hereditary_full, hereditary_recursive, hereditary_window

MPa = PA_PER_MPA


# ---------------------------------------------------------------------------------------------
# geometry and material
# ---------------------------------------------------------------------------------------------
#: the sizes a muscle can have (m): a wall of 0.02-50 mm, a radius of 0.1-500 mm, a length of 2-5000 mm; outside
#: them a length was given in the other unit (metres under a _mm key, or millimetres as metres)
GEOMETRY_MIN_M = {"th": 2e-5, "R0": 1e-4, "l0": 2e-3}
GEOMETRY_MAX_M = {"th": 0.05, "R0": 0.5, "l0": 5.0}
#: the smallest braid angle a muscle has (deg): below it, radians were given under a _deg key
ALPHA0_MIN_DEG = 1.0


class PressureAboveRange(InputError):
    """A pressure the model cannot bend to (beyond 4 pi rad): ``sample`` is its index in the log, so that a caller
    holding the log can name the file's line and a likely unit slip (:func:`bpmid.predict.predict`)."""

    def __init__(self, message: str, *, sample: int, **kw):
        self.sample = int(sample)
        super().__init__(message, **kw)


@dataclasses.dataclass(frozen=True)
class Geometry:
    """Muscle geometry (paper Table I), SI: th, R0, l0 in m; alpha0 in rad; n turns (1).

    Attributes
    ----------
    th : wall thickness of the elastic tube (m)
    alpha0 : initial helix angle of the braid thread from the circumferential direction (rad)
    R0 : initial inner radius (m)
    l0 : initial length = length of the inextensible suture (m)
    n : turns of one braid thread around the tube (1)
    """

    th: float = 2.0e-3
    alpha0: float = math.radians(30.0)
    R0: float = 16.73e-3
    l0: float = 195.9e-3
    n: float = 7.43

    #: config keys that state their unit, as a datasheet gives them (``th_mm: 2.0``, ``alpha0_deg: 30``): key ->
    #: (field, factor to SI). A field given both ways is refused.
    UNIT_KEYS = {"th_mm": ("th", 1e-3), "th_m": ("th", 1.0), "alpha0_deg": ("alpha0", math.pi / 180.0),
                 "alpha0_rad": ("alpha0", 1.0), "R0_mm": ("R0", 1e-3), "R0_m": ("R0", 1.0),
                 "l0_mm": ("l0", 1e-3), "l0_m": ("l0", 1.0)}
    #: a key a user brings from another section's geometry, with what to do
    UNKNOWN_KEY_HINTS = {"name": "a name labels a muscle in a sweep's rig.geometry; the model's geometry has none: "
                                 "remove it"}

    def validate(self, where="geometry", path=None):
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if not (np.isfinite(v) and v > 0):
                raise InputError(f"geometry must be positive and finite, found {v!r}", path=path, key=f"{where}.{f.name}")
        if any(getattr(self, k) > GEOMETRY_MAX_M[k] for k in GEOMETRY_MAX_M):
            raise InputError("geometry is in metres (th, R0, l0); the values look like millimetres: give them as "
                             "th_mm, R0_mm, l0_mm (and alpha0_deg) to state mm and deg", path=path, key=where)
        if not self.alpha0 < math.pi / 2:
            deg = (f": degrees given under alpha0? alpha0 takes radians ({math.radians(self.alpha0):.4g}), "
                   f"alpha0_deg degrees (alpha0_deg: {self.alpha0:g})" if self.alpha0 < 90 else "")
            raise InputError(f"alpha0 is in rad and must be below pi/2, found {self.alpha0:g}{deg}", path=path,
                             key=f"{where}.alpha0")
        if math.degrees(self.alpha0) < ALPHA0_MIN_DEG:
            raise InputError(f"a braid angle of {math.degrees(self.alpha0):.4g} deg is too small for a muscle (at least "
                             f"{ALPHA0_MIN_DEG:g} deg): radians given under alpha0_deg? alpha0 takes radians, "
                             f"alpha0_deg degrees", path=path, key=f"{where}.alpha0")
        if any(getattr(self, k) < GEOMETRY_MIN_M[k] for k in GEOMETRY_MIN_M):
            raise InputError(f"geometry too small for a muscle (th {self.th * 1e3:.4g} mm, R0 {self.R0 * 1e3:.4g} mm, "
                             f"l0 {self.l0 * 1e3:.4g} mm): metres given under the _mm keys? th_mm, R0_mm and l0_mm "
                             f"take millimetres (R0_mm: 16.73), th, R0 and l0 take metres (R0: 0.01673)",
                             path=path, key=where)

    def vector(self) -> np.ndarray:
        return np.array([self.th, self.alpha0, self.R0, self.l0, self.n], float)

    def to_yaml(self) -> dict:
        return {"th": self.th, "alpha0": self.alpha0, "R0": self.R0, "l0": self.l0, "n": self.n}


@dataclasses.dataclass(frozen=True)
class Material:
    """Prony constants of the VBMM (Pa, s).

    G(t) = G_inf + sum_j G_j exp(-t/tauG_j), K(t) = K_inf + sum_j K_j exp(-t/tauK_j).
    ``tauK`` None means shared time constants (tauK = tauG), the paper's choice.
    """

    G_inf: float
    K_inf: float
    G: tuple[float, ...] = ()
    K: tuple[float, ...] = ()
    tauG: tuple[float, ...] = ()
    tauK: Optional[tuple[float, ...]] = None

    def __post_init__(self):
        object.__setattr__(self, "G", tuple(float(v) for v in self.G))
        object.__setattr__(self, "K", tuple(float(v) for v in self.K))
        object.__setattr__(self, "tauG", tuple(float(v) for v in self.tauG))
        if self.tauK is not None:
            object.__setattr__(self, "tauK", tuple(float(v) for v in self.tauK))
        if not (len(self.G) == len(self.K) == len(self.tauG)):
            raise InputError("material branches need the same number of G, K and tau values", key="material.branches")
        if self.tauK is not None and len(self.tauK) != len(self.K):
            raise InputError("material: one tauK per branch", key="material.branches")
        for name, vals in (("G_inf", [self.G_inf]), ("K_inf", [self.K_inf]), ("G", self.G), ("K", self.K)):
            if any((not np.isfinite(v)) or v < 0 for v in vals):
                raise InputError(f"moduli must be finite and non-negative, found {name} = {vals}", key=f"material.{name}")
        for v in self.tauG + (self.tauK or ()):
            if not (np.isfinite(v) and v > 0):
                raise InputError(f"time constants must be positive, found {v!r} s", key="material.branches")

    @property
    def n_branches(self) -> int:
        return len(self.G)

    @property
    def split(self) -> bool:
        return self.tauK is not None

    @property
    def tau_K(self) -> tuple[float, ...]:
        return self.tauG if self.tauK is None else self.tauK

    @property
    def time_constants(self) -> tuple[float, ...]:
        """Every positive time constant (s), of G and of K when split: what the sampling step is judged against."""
        return tuple(t for t in self.tauG + (self.tauK or ()) if t > 0)

    @functools.cached_property
    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(G, tauG, K, tau_K) as float arrays, made once (the instance is frozen; a fit runs the forward model
        with one material on every log). The kernels only read them (left writeable: numba compiles read-only
        arrays as another type)."""
        return tuple(np.asarray(v, float) for v in (self.G, self.tauG, self.K, self.tau_K))

    @classmethod
    def paper_fit(cls) -> "Material":
        """VBMM-fit constants of the paper (section V.A): refit on motion data."""
        return cls(0.00905 * MPa, 6.434 * MPa, (0.0183 * MPa,), (13.645 * MPa,), (0.213,))

    @classmethod
    def paper_mat(cls) -> "Material":
        """VBMM-mat. constants of the paper: straight from the relaxation test."""
        return cls(0.00905 * MPa, 6.753 * MPa, (0.0183 * MPa,), (13.639 * MPa,), (0.399,))

    def scaled(self, factor: float) -> "Material":
        """All moduli times ``factor`` (time constants unchanged)."""
        return dataclasses.replace(self, G_inf=self.G_inf * factor, K_inf=self.K_inf * factor,
                                   G=tuple(v * factor for v in self.G), K=tuple(v * factor for v in self.K))

    def to_yaml(self, stderr: dict | None = None) -> dict:
        """``material`` block of ``bpmid.vbmm/1`` (param mappings in Pa and s); ``stderr`` by parameter name."""
        ps = material_params(self)
        for name, s in (stderr or {}).items():
            if name in ps:
                ps = ps.replace(name, stderr=None if s is None or not np.isfinite(s) else float(s))
        return material_yaml(ps)


# ---------------------------------------------------------------------------------------------
# the one naming of the material constants, and the one writer of the ``material`` block
# ---------------------------------------------------------------------------------------------
#: bounds of each kind of constant for ``bpmid fit motion``: (lower, upper) in Pa or s
FIT_BOUNDS: dict = {"G_inf": (0.0, math.inf), "K_inf": (1e3, math.inf), "G": (0.0, math.inf),
                    "K": (0.0, math.inf), "tau": (1e-3, 1e3)}
#: the constants discovery refits (G is held: it barely moves the angle next to K) and their bounds:
#: ("x", f[, floor]) is [v / f, v f] around the start value v (raised to ``floor`` first), else (lower, upper)
DISCOVERY_BOUNDS: dict = {"K_inf": ("x", 20.0), "K": ("x", 50.0, 1e3), "tau": (0.01, 100.0)}


def material_params(mat: "Material", *, prefix: str = "", bounds: dict | None = None):
    """The VBMM's material constants as a :class:`~bpmid.params.ParamSet`, in the one naming every workflow
    uses: ``G_inf``, ``K_inf``, ``G_<j>``, ``K_<j>`` (Pa) and ``tau_<j>`` (s), or ``tauG_<j>`` and ``tauK_<j>``
    when the time constants are split (j = 1..branches), each name preceded by ``prefix``.

    Parameters
    ----------
    bounds : kind (``G_inf``, ``K_inf``, ``G``, ``K``, ``tau``) -> bounds (see :data:`FIT_BOUNDS`, the default,
        and :data:`DISCOVERY_BOUNDS`); kinds not named are left out. With ``tau`` but no ``tauG``/``tauK`` on a
        split material, ``tau_<j>`` stands for the bulk time constant.
    """
    from bpmid.params import Param, ParamSet

    bounds = FIT_BOUNDS if bounds is None else bounds

    def par(kind: str, name: str, value: float, unit: str, log: bool = False):
        b = bounds[kind]
        if b[0] == "x":
            v = max(value, b[2]) if len(b) > 2 else value
            return Param(prefix + name, v, unit, lower=v / b[1], upper=v * b[1], log_scale=True)
        return Param(prefix + name, value, unit, float(b[0]), float(b[1]), log_scale=log)

    ps = [par(k, k, getattr(mat, k), "Pa") for k in ("G_inf", "K_inf") if k in bounds]
    for j in range(mat.n_branches):
        i = j + 1
        ps += [par(k, f"{k}_{i}", getattr(mat, k)[j], "Pa") for k in ("G", "K") if k in bounds]
        if "tau" in bounds:
            if not mat.split:
                ps.append(par("tau", f"tau_{i}", mat.tauG[j], "s", True))
            elif "tauG" in bounds or "tauK" in bounds or bounds is FIT_BOUNDS:
                ps += [par("tau", f"tauG_{i}", mat.tauG[j], "s", True), par("tau", f"tauK_{i}", mat.tauK[j], "s", True)]
            else:
                ps.append(par("tau", f"tau_{i}", mat.tau_K[j], "s", True))
    return ParamSet(ps)


def material_yaml(params) -> dict:
    """The ``material`` block of a ``bpmid.vbmm/1`` file from parameters in the naming of
    :func:`material_params` (each entry ``{value, stderr, unit}`` plus any verdict the parameter carries)."""
    branches = []
    j = 1
    while f"G_{j}" in params:
        b = {"G": params[f"G_{j}"].to_yaml(), "K": params[f"K_{j}"].to_yaml()}
        if f"tauG_{j}" in params:
            b["tauG"] = params[f"tauG_{j}"].to_yaml()
            b["tauK"] = params[f"tauK_{j}"].to_yaml()
        else:
            b["tau"] = params[f"tau_{j}"].to_yaml()
        branches.append(b)
        j += 1
    return {"G_inf": params["G_inf"].to_yaml(), "K_inf": params["K_inf"].to_yaml(), "branches": branches}


@dataclasses.dataclass(frozen=True)
class VBMMConfig:
    """Config section ``model``: how the VBMM is evaluated.

    Attributes
    ----------
    closure : "paper" (eq. 18 literally, SI) or "consistent"
    history : "recursive" (exact, default), "window" (eq. 19) or "full" (eq. 5)
    window_s : sliding-window length T_win (s), used by history = window
    geometry : muscle geometry in SI (m, rad)
    """

    closure: Literal["paper", "consistent"] = "paper"
    history: Literal["recursive", "window", "full"] = "recursive"
    window_s: float = 20.0
    geometry: Geometry = dataclasses.field(default_factory=Geometry)

    def validate(self, where, path):
        if not self.window_s > 0:
            raise InputError(f"window length must be positive, found {self.window_s:g} s", path=path,
                             key=f"{where}.window_s")
        self.geometry.validate(f"{where}.geometry", path)


_MODES = {"recursive": 0, "window": 1, "full": 2}
_CLOSURES = {"paper": 0, "consistent": 1}


# ---------------------------------------------------------------------------------------------
# kinematics (vectorised)
# ---------------------------------------------------------------------------------------------
def u3_from_beta(beta, geo: Geometry = Geometry()):
    """Radial displacement u3 (m) for bending angle beta (rad): eq. (18), first line."""
    beta = np.asarray(beta, float)
    pn2 = 4.0 * math.pi**2 * geo.n**2
    D = geo.l0**2 + pn2 * geo.R0**2
    E = pn2**2 * geo.R0**2
    return -2.0 * geo.R0 + (2.0 * np.sqrt(D * beta**2 + E) - 2.0 * geo.l0 * beta) / (beta**2 + pn2)


def kinematics(u3, geo: Geometry = Geometry()) -> dict:
    """Everything that follows from u3 (m): F, eps1, eps2, beta (rad), R (m), cos(alpha)."""
    u3 = np.asarray(u3, float)
    A = -math.pi**2 * geo.n**2 / geo.l0**2
    B = -4.0 * math.pi**2 * geo.n**2 * geo.R0 / geo.l0**2
    F = np.sqrt(1.0 + A * u3**2 + B * u3)
    eps1 = F - 1.0
    eps2 = u3 / geo.R0
    beta = 2.0 * (F - 1.0) * geo.l0 / (2.0 * geo.R0 + u3)
    return {"F": F, "eps1": eps1, "eps2": eps2, "beta": beta, "R": geo.R0 + 0.5 * u3,
            "cos_alpha": math.cos(geo.alpha0) * (1.0 + eps2)}


def closure_pressure(u3, sigma1, sigma2, geo: Geometry = Geometry(), closure: str = "paper"):
    """Gauge pressure (Pa) from u3 (m) and the stresses (Pa) by the chosen closure."""
    kin = kinematics(u3, geo)
    F, R = kin["F"], kin["R"]
    if closure == "paper":
        gb = geo.l0 * math.cos(geo.alpha0) * (1.0 + np.asarray(u3) / geo.R0)
        return geo.th / R * (sigma2 + (sigma2 * gb + sigma1 * (F - 1.0)) / (1.0 - 2.0 * gb * F))
    if closure == "consistent":
        return geo.th / R * (sigma2 + sigma1 * (F - 1.0) / (1.0 - kin["cos_alpha"]))
    raise InputError(f"unknown closure {closure!r} (paper or consistent)", key="model.closure")


# ---------------------------------------------------------------------------------------------
# the model
# ---------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class VBMM:
    """A VBMM with fixed constants; evaluate with :meth:`forward` and :meth:`inverse`.

    Attributes
    ----------
    material : Prony constants (Pa, s)
    geometry : SI geometry
    closure : "paper" or "consistent"
    history : "recursive", "window" or "full"
    window_s : T_win (s) for history = "window"
    fall_ratio : time constants are multiplied by this on steps where the angle falls (1 = symmetric;
        the asymmetric_relaxation effect; recursive history only)
    stiffening : strain-stiffening coefficient c, moduli scale by (1 + c eps1^2) (0 = linear; the
        strain_stiffening effect)
    """

    material: Material = dataclasses.field(default_factory=Material.paper_fit)
    geometry: Geometry = dataclasses.field(default_factory=Geometry)
    closure: str = "paper"
    history: str = "recursive"
    window_s: float = 20.0
    fall_ratio: float = 1.0
    stiffening: float = 0.0

    def __post_init__(self):
        if self.closure not in _CLOSURES:
            raise InputError(f"unknown closure {self.closure!r} (paper or consistent)", key="model.closure")
        if self.history not in _MODES:
            raise InputError(f"unknown history mode {self.history!r} (recursive, window or full)", key="model.history")
        if self.fall_ratio != 1.0 and self.history != "recursive":
            raise InputError("asymmetric relaxation (fall_ratio != 1) needs history = recursive", key="model.history")
        # a geometry in mm by mistake, or a negative one, computed silently before (a constant 4 pi rad)
        self.geometry.validate("model.geometry")
        bad = _negative_bend_pressure(self.geometry, self.closure)
        if bad is not None:
            g = self.geometry
            raise InputError(
                f"this geometry (th {g.th * 1e3:.4g} mm, R0 {g.R0 * 1e3:.4g} mm, l0 {g.l0 * 1e3:.4g} mm, n {g.n:.4g}, "
                f"alpha0 {math.degrees(g.alpha0):.4g} deg) needs a negative pressure to hold a bend of {math.degrees(bad[0]):.3g} deg, "
                f"whatever the rubber: the VBMM cannot describe such a muscle, and every "
                f"prediction would sit at its 4 pi rad limit. Check the geometry: the radius R0 against the braid (its "
                f"length l0 and turns n: a small R0, or few turns over a long l0), or a decimal slip such as 1.673e-3 m "
                f"for 1.673e-2 m", key="model.geometry")

    @classmethod
    def from_config(cls, material: Material, cfg: VBMMConfig | None = None, **kw) -> "VBMM":
        cfg = cfg or VBMMConfig()
        return cls(material=material, geometry=cfg.geometry, closure=cfg.closure, history=cfg.history,
                   window_s=cfg.window_s, **kw)

    def replace(self, **kw) -> "VBMM":
        return dataclasses.replace(self, **kw)

    # -- forward ------------------------------------------------------------------------------
    def forward_full(self, t, p_gauge_pa, *, scale=None, name: str = "log"):
        """Forward model with every internal signal.

        Parameters
        ----------
        t : (N,) s, strictly increasing
        p_gauge_pa : (N,) gauge pressure, Pa
        scale : (N,) per-step modulus scale (thermal softening), default ones

        Returns
        -------
        dict with beta (rad), eps1, eps2, status (N,)
        """
        t = np.ascontiguousarray(t, float)
        p = np.ascontiguousarray(p_gauge_pa, float)
        if t.shape != p.shape or t.ndim != 1:
            raise ValueError("t and p must be 1-D arrays of equal length")
        _check_samples(t, p, name, "p_gauge_pa")
        sc = np.ones_like(t) if scale is None else np.ascontiguousarray(scale, float)
        if scale is not None and (sc.shape != t.shape or not np.all(np.isfinite(sc) & (sc > 0))):
            bad = int(np.flatnonzero(~(np.isfinite(sc) & (sc > 0)))[0]) if sc.shape == t.shape else 0
            raise InputError(f"{name}: the modulus scale must be one positive finite number per sample (sample "
                             f"{bad}: {float(sc.ravel()[bad]) if sc.size else float('nan')!r})", key="scale")
        G, tauG, Kb, tauK = self.material.arrays
        beta, e1, e2, status = K.forward_kernel(
            t, p, self.geometry.vector(), _CLOSURES[self.closure],
            float(self.material.G_inf), G, tauG, float(self.material.K_inf), Kb, tauK,
            _MODES[self.history], float(self.window_s), float(self.fall_ratio), float(self.stiffening), sc)
        return {"beta": beta, "eps1": e1, "eps2": e2, "status": status}

    def forward(self, t, p_gauge_pa, *, scale=None, name: str = "log", path=None) -> np.ndarray:
        """Bending angle beta (rad), shape (N,), for times ``t`` (s, strictly increasing) and gauge pressures (Pa).
        Pressures needing beta > 4 pi are refused (InputError naming the log and the time), as are times that do
        not rise and values that are not finite (naming the first)."""
        out = self.forward_full(t, p_gauge_pa, scale=scale, name=name)
        if not out["status"].any():   # every sample solved (STATUS_OK is 0): the usual case, one pass
            return out["beta"]
        bad = np.flatnonzero(out["status"] == K.STATUS_ABOVE_RANGE)
        if bad.size:
            k = int(bad[0])
            raise PressureAboveRange(f"{name}: pressure {p_gauge_pa[k]:.6g} Pa gauge at t = {t[k]:g} s is above the "
                                     f"model's range (it would bend the muscle beyond 4 pi rad)", path=path, sample=k)
        if np.any(out["status"] == K.STATUS_NO_CONVERGENCE):
            # the bracketed solve converges wherever the pressure rises with the angle: a model whose does not
            # (a geometry far from any muscle's, such as n = 1e6 turns) is the input's fault, said as such
            k = int(np.flatnonzero(out["status"] == K.STATUS_NO_CONVERGENCE)[0])
            g = self.geometry
            raise InputError(f"{name}: the model found no angle for {p_gauge_pa[k]:.6g} Pa gauge at t = {t[k]:g} s "
                             f"(its pressure does not rise steadily with the bend): check the geometry (th "
                             f"{g.th * 1e3:.4g} mm, R0 {g.R0 * 1e3:.4g} mm, l0 {g.l0 * 1e3:.4g} mm, n {g.n:.4g}, "
                             f"alpha0 {math.degrees(g.alpha0):.4g} deg) and the moduli", path=path)
        return out["beta"]

    def forward_deg(self, t, p_gauge_pa, **kw) -> np.ndarray:
        """Bending angle (deg), shape (N,), for times ``t`` (s, strictly increasing) and gauge pressures (Pa):
        :meth:`forward` in degrees."""
        return np.degrees(self.forward(t, p_gauge_pa, **kw))

    # -- inverse ------------------------------------------------------------------------------
    def _operator(self, t, x, M_inf, M, tau, direction=None):
        if self.history == "recursive":
            if self.fall_ratio != 1.0 and direction is not None:
                return M_inf * x + _asymmetric_states(t, x, np.asarray(tau), self.fall_ratio, direction) @ np.asarray(M)
            return hereditary_recursive(t, x, M_inf, M, tau)
        if self.history == "window":
            return hereditary_window(t, x, M_inf, M, tau, self.window_s)
        return hereditary_full(t, x, M_inf, M, tau)

    def stresses(self, t, beta, *, scale=None, direction=None) -> dict:
        """sigma1, sigma2 (Pa) and the strains along an angle history beta (rad)."""
        t = np.asarray(t, float)
        beta = np.asarray(beta, float)
        u3 = u3_from_beta(beta, self.geometry)
        kin = kinematics(u3, self.geometry)
        e1, e2 = kin["eps1"], kin["eps2"]
        m = self.material
        g1 = self._operator(t, e1, m.G_inf, m.G, m.tauG, direction)
        g2 = self._operator(t, e2, m.G_inf, m.G, m.tauG, direction)
        k1 = self._operator(t, e1, m.K_inf, m.K, m.tau_K, direction)
        k2 = self._operator(t, e2, m.K_inf, m.K, m.tau_K, direction)
        lam = k1 + k2 - (2.0 / 3.0) * (g1 + g2)
        s = (1.0 + self.stiffening * e1**2) * (1.0 if scale is None else np.asarray(scale, float))
        return {"u3": u3, "eps1": e1, "eps2": e2, "sigma1": s * (2.0 * g1 + lam), "sigma2": s * (2.0 * g2 + lam)}

    def inverse(self, t, beta_rad, *, scale=None, direction=None) -> np.ndarray:
        """Gauge pressure (Pa), shape (N,), that produces the angle history ``beta_rad`` (rad) at times ``t`` (s,
        strictly increasing; closed form).

        ``direction`` (N,) of +1/-1 marks rising/falling steps for asymmetric relaxation (default: the
        sign of the angle change).
        """
        beta_rad = np.asarray(beta_rad, float)
        t = np.asarray(t, float)
        if t.shape == beta_rad.shape and t.ndim == 1:
            _check_samples(t, beta_rad, "log", "beta_rad")
        if direction is None and self.fall_ratio != 1.0:
            direction = np.sign(np.diff(beta_rad, prepend=beta_rad[0]))
        st = self.stresses(t, beta_rad, scale=scale, direction=direction)
        return closure_pressure(st["u3"], st["sigma1"], st["sigma2"], self.geometry, self.closure)

    def equilibrium_pressure(self, beta_rad) -> np.ndarray:
        """Relaxed-equilibrium gauge pressure (Pa) for a held angle (long-term moduli only)."""
        return relaxed_pressure(np.atleast_1d(np.asarray(beta_rad, float)), self.geometry, self.closure,
                                self.material.G_inf, self.material.K_inf, self.stiffening)

    def equilibrium_angle(self, p_gauge_pa) -> np.ndarray:
        """Relaxed-equilibrium angle (rad) for held gauge pressures (Pa), by the same compiled solve."""
        p = np.atleast_1d(np.asarray(p_gauge_pa, float))
        relaxed = self.replace(material=Material(self.material.G_inf, self.material.K_inf), history="recursive",
                               fall_ratio=1.0)
        # each pressure on its own: a one-sample log is the relaxed equilibrium (h = 0)
        return np.array([relaxed.forward(np.zeros(1), np.array([pk]))[0] for pk in p])


def relaxed_pressure(beta: np.ndarray, geometry: "Geometry", closure: str, G_inf: float, K_inf: float,
                     stiffening: float = 0.0) -> np.ndarray:
    """Gauge pressure (Pa) that holds the bends ``beta`` (rad) with long-term moduli only (relaxed equilibrium)."""
    u3 = u3_from_beta(beta, geometry)
    kin = kinematics(u3, geometry)
    e1, e2 = kin["eps1"], kin["eps2"]
    lam = (K_inf - 2.0 / 3.0 * G_inf) * (e1 + e2)
    s = 1.0 + stiffening * e1**2
    return closure_pressure(u3, s * (2 * G_inf * e1 + lam), s * (2 * G_inf * e2 + lam), geometry, closure)


@functools.lru_cache(maxsize=512)
def _negative_bend_pressure(geometry: "Geometry", closure: str):
    """(beta, P) of the first test angle (rad) at which a relaxed, nearly incompressible rubber (K = 1000 G, the
    pressure in units of G) needs a pressure that is not positive to hold the bend, else None.

    Some geometries (a radius small against the braid's length and turns: with the paper's l0 and n, R0 6 mm and
    below, either closure; the wall thickness only scales the pressure) need a negative pressure at every angle,
    and the forward solve then runs to its 4 pi rad bracket for any pressure. A property of the geometry, not of the fitted constants (a fit may try a compressible rubber on the way).
    Cached: a fit makes many models of one geometry."""
    beta = np.array([0.5, 2.0])   # not a tiny bend: near 0 the pressure is near 0, of either sign by rounding
    with np.errstate(all="ignore"):   # an absurd geometry divides by zero here: it is refused, not warned about
        p = relaxed_pressure(beta, geometry, closure, 1.0, 1000.0)
    bad = np.flatnonzero(~(p > 0))
    return None if not bad.size else (float(beta[bad[0]]), float(p[bad[0]]))


def _check_samples(t: np.ndarray, x: np.ndarray, name: str, what: str) -> None:
    """Times that rise strictly and values that are finite, or an InputError naming the first sample that is not
    (a NaN pressure stopped the solve with 'did not converge'; a NaN angle gave NaN pressures; falling times ran)."""
    # the common case (every sample fine) in three reductions: a fit checks every log at every evaluation
    if np.isfinite(t).all() and np.isfinite(x).all() and (t.size < 2 or bool((t[1:] > t[:-1]).all())):
        return
    bad = np.flatnonzero(~np.isfinite(t) | ~np.isfinite(x))
    if bad.size:
        k = int(bad[0])
        raise InputError(f"{name}: sample {k} is not finite (t = {float(t[k])!r} s, {what} = {float(x[k])!r})", key=what)
    if t.size > 1:
        down = np.flatnonzero(np.diff(t) <= 0.0)
        if down.size:
            k = int(down[0]) + 1
            raise InputError(f"{name}: time must rise strictly: sample {k} at t = {t[k]:.9g} s after "
                             f"{t[k - 1]:.9g} s", key="t")


def _asymmetric_states(t, x, tau, ratio, direction):
    """Branch states with tau multiplied by ``ratio`` on falling steps (direction < 0)."""
    t = np.asarray(t, float)
    x = np.asarray(x, float)
    dt = np.diff(t, prepend=t[0])
    dx = np.diff(x, prepend=x[0])
    falling = np.asarray(direction) < 0
    h = np.zeros((t.size, tau.size))
    for j, tj in enumerate(tau):
        a = np.exp(-dt / np.where(falling, tj * ratio, tj))
        # h_k = a_k h_{k-1} + dx_k: a linear recursion with varying coefficient
        hj = 0.0
        col = h[:, j]
        for k in range(1, t.size):
            hj = a[k] * hj + dx[k]
            col[k] = hj
    return h


# ---------------------------------------------------------------------------------------------
# parameter files (schema bpmid.vbmm/1)
# ---------------------------------------------------------------------------------------------
_MATERIAL_KEYS = ("G_inf", "K_inf", "branches")
#: most Prony branches a parameter file may give (relax.terms allows up to 200)
MAX_BRANCHES = 200
_BRANCH_KEYS = ("G", "K", "tau", "tauG", "tauK")


#: the smallest K_inf + sum K (Pa) a fit file may hold: the paper's muscle has 2e7 Pa, the softest silicone tubes
#: some 1e5; below this the moduli were typed in another unit (MPa under 'unit: Pa')
MIN_PLAUSIBLE_K_PA = 1e3
#: the largest modulus (Pa) a fit file may hold: a rubber's bulk modulus is some 2e9 Pa, the VBMM's apparent moduli
#: 1e4-1e8; above this a value was given in another unit than the file says (a value in Pa under 'unit: MPa')
MAX_PLAUSIBLE_MODULUS_PA = 1e10


def material_from_yaml(data: dict, path=None) -> Material:
    """Read the ``material`` block of a ``bpmid.vbmm/1`` file (values in Pa and s)."""
    from bpmid.params import parse_param_entry
    from bpmid.io.results import require

    from bpmid.units import MODULUS_UNITS, TIME_UNITS

    def val(entry, key, unit):
        # a modulus in kPa/MPa/GPa, a time in ms/min is converted, as a relaxation file's is
        v, _se, u = parse_param_entry(entry, path=path, key=key)
        factor = 1.0
        if u is not None and u != unit:
            table = MODULUS_UNITS if unit == "Pa" else TIME_UNITS
            factor = table.get(str(u).strip().lower()) if unit == "Pa" else table.get(str(u).strip())
            if factor is None:
                raise InputError(f"unit {u!r} where {unit!r} is expected (or "
                                 f"{', '.join(k for k in table if k != unit.lower())})", path=path, key=key)
        if unit == "Pa" and v * factor > MAX_PLAUSIBLE_MODULUS_PA:
            # a value in Pa under 'unit: MPa' (converted, it is a million times too stiff): refused, never run
            raise InputError(f"{v:g} {u or unit} is {v * factor:.4g} Pa, above {MAX_PLAUSIBLE_MODULUS_PA:g} Pa: stiffer "
                             "than any rubber (a value in Pa under a unit of MPa or kPa?); the moduli are read in the "
                             "unit the file gives", path=path, key=key)
        return v * factor

    mat = require(data, "material", path)
    if not isinstance(mat, dict):
        raise InputError("material must be a mapping G_inf, K_inf, branches", path=path, key="material")
    for k in mat:
        if k not in _MATERIAL_KEYS:
            raise InputError(f"unknown material key (known: {', '.join(_MATERIAL_KEYS)})", path=path,
                             key=f"material.{k}")
    G_inf = val(require(data, "material.G_inf", path), "material.G_inf", "Pa")
    K_inf = val(require(data, "material.K_inf", path), "material.K_inf", "Pa")
    branches = mat.get("branches", [])
    if not isinstance(branches, list):
        raise InputError("material.branches must be a list of {G, K, tau}", path=path, key="material.branches")
    if len(branches) > MAX_BRANCHES:  # a resource limit: every branch is a state of every simulated step
        raise InputError(f"{len(branches)} Prony branches, more than the {MAX_BRANCHES} a relaxation fit can have",
                         path=path, key="material.branches")
    G, Kk, tG, tK, split = [], [], [], [], False
    for j, b in enumerate(branches):
        key = f"material.branches[{j}]"
        if not isinstance(b, dict):
            raise InputError("expected a mapping {G, K, tau}", path=path, key=key)
        for k in b:
            if k not in _BRANCH_KEYS:
                raise InputError(f"unknown branch key (known: {', '.join(_BRANCH_KEYS)})", path=path,
                                 key=f"{key}.{k}")
        for req in ("G", "K"):
            if req not in b:
                raise InputError("missing key", path=path, key=f"{key}.{req}")
        G.append(val(b["G"], f"{key}.G", "Pa"))
        Kk.append(val(b["K"], f"{key}.K", "Pa"))
        if "tau" in b and ("tauG" in b or "tauK" in b):   # one of them would be dropped silently
            raise InputError("give tau (one time constant for G and K), or tauG and tauK, not both", path=path,
                             key=f"{key}.{'tauK' if 'tauK' in b else 'tauG'}")
        if "tau" in b:
            tG.append(val(b["tau"], f"{key}.tau", "s"))
            tK.append(tG[-1])
        elif "tauG" in b and "tauK" in b:
            split = True
            tG.append(val(b["tauG"], f"{key}.tauG", "s"))
            tK.append(val(b["tauK"], f"{key}.tauK", "s"))
        else:
            raise InputError("missing key (tau, or tauG and tauK)", path=path, key=f"{key}.tau")
    k_total = (K_inf if np.isfinite(K_inf) else 0.0) + sum(k for k in Kk if np.isfinite(k))
    if 0.0 <= k_total < MIN_PLAUSIBLE_K_PA:
        # a modulus typed in MPa under 'unit: Pa' makes a muscle that bends fully at a few Pa: every log would
        # then be refused as beyond the model's range, blamed on the log; name the fit file's key instead
        raise InputError(f"K_inf plus the branches' K is {k_total:.4g} Pa, below {MIN_PLAUSIBLE_K_PA:g} Pa: no rubber "
                         f"tube is that soft; the moduli of a bpmid.vbmm/1 file are in Pa (6.434e6, not 6.434 MPa)",
                         path=path, key="material.K_inf")
    try:
        return Material(G_inf, K_inf, tuple(G), tuple(Kk), tuple(tG), tuple(tK) if split else None)
    except InputError as exc:
        raise InputError(exc.message, path=path, key=exc.key) from None


def geometry_from_yaml(data: dict | None, path=None) -> Geometry:
    """Read the ``geometry`` block of a ``bpmid.vbmm/1`` file: all of th, alpha0, R0, l0, n (SI) must be there."""
    if not isinstance(data, dict):
        raise InputError("geometry must be a mapping th, alpha0, R0, l0, n (SI)", path=path, key="geometry")
    known = {f.name for f in dataclasses.fields(Geometry)}
    for k in data:
        if k not in known:
            raise InputError(f"unknown geometry key (known: {', '.join(sorted(known))})", path=path, key=f"geometry.{k}")
    for f in dataclasses.fields(Geometry):
        if f.name not in data:
            raise InputError("missing key (geometry needs th, alpha0, R0, l0, n in SI)", path=path,
                             key=f"geometry.{f.name}")
    vals = {}
    for k, v in data.items():
        if isinstance(v, dict):
            v = v.get("value")
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise InputError(f"expected a number in SI units, found {v!r}", path=path, key=f"geometry.{k}")
        vals[k] = float(v)
    geo = Geometry(**vals)
    geo.validate("geometry", path)
    return geo


def _check_model_block(block, path) -> None:
    """The file's ``model`` block records how it was fitted (not used to evaluate it); a wrong one is refused
    by its key all the same, so a hand-edited ``history: bogus`` is not silently ignored."""
    if block is None:
        return
    if not isinstance(block, dict):
        raise InputError("expected a mapping {history, window_s, time_constants}", path=path, key="model")
    known = {"history": tuple(_MODES), "time_constants": ("split", "shared"), "closure": tuple(_CLOSURES)}
    for k, v in block.items():
        if k in known:
            if v not in known[k]:
                raise InputError(f"expected one of {list(known[k])}, found {v!r}", path=path, key=f"model.{k}")
        elif k == "window_s":
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0:
                raise InputError(f"expected a positive number of seconds, found {v!r}", path=path, key="model.window_s")
        else:
            raise InputError(f"unknown key (known: {', '.join(sorted([*known, 'window_s']))})", path=path,
                             key=f"model.{k}")


#: a history window at least this many times the longest time constant drops under e^-5 (0.7 %) of any branch's memory
WINDOW_TAUS_ENOUGH = 5.0


def fitted_history_note(block, model: "VBMM", *, runs_as: str | None = None, window_remedy: bool = True) -> str | None:
    """What to tell the user when a fit made with a short history window (its file's ``model`` block:
    ``history: window``, ``window_s``) is run with another history: the constants were fitted to a model that
    forgets the past after the window, so the exact history gives other angles. None when it does not matter
    (no window, or a window of at least :data:`WINDOW_TAUS_ENOUGH` times the longest time constant, or the same
    window). ``runs_as`` names what runs it (default: the model's own history)."""
    if not isinstance(block, dict) or block.get("history") != "window":
        return None
    w = block.get("window_s", 20.0)
    if not isinstance(w, (int, float)) or isinstance(w, bool):
        return None
    mat = model.material
    taus = [float(t) for t in (*mat.tauG, *mat.tau_K) if t > 0]
    tmax = max(taus) if taus else 0.0
    how = runs_as or (f"a {model.window_s:g} s window" if model.history == "window" else f"the {model.history} history")
    if model.history == "window" and runs_as is None and abs(model.window_s - w) <= 1e-9 * max(w, 1.0):
        return None
    if w >= WINDOW_TAUS_ENOUGH * tmax:
        return None
    return (f"these constants were fitted with a {w:g} s history window (model.history: window, window_s: {w:g}), "
            f"shorter than {WINDOW_TAUS_ENOUGH:g} times the longest time constant ({tmax:.3g} s): run with {how}, "
            f"the model forgets less of the past and its angles differ from the fit's; refit with model.history: "
            f"recursive (exact)" + (f", or evaluate with the fit's window (a config with model: {{history: window, "
                                    f"window_s: {w:g}}})" if window_remedy else ""))


def load_vbmm(path: str | Path, cfg: VBMMConfig | None = None) -> VBMM:
    """A :class:`VBMM` from a ``bpmid.vbmm/1`` file (``--params``). Keys of CLI.md suffice, and are required:
    ``geometry`` and ``closure`` are constants of the fitted model, never taken from a default.

    ``history`` and ``window_s`` are evaluation settings, not constants: they come from the config
    section ``model`` (the file's own ``model`` block only records how it was fitted)."""
    from bpmid.io.results import read_result

    path = Path(path)
    return vbmm_from_mapping(read_result(path, "bpmid.vbmm/"), path, cfg)


def vbmm_from_mapping(data: dict, path=None, cfg: VBMMConfig | None = None) -> VBMM:
    """A :class:`VBMM` from the mapping of a ``bpmid.vbmm/1`` file (see :func:`load_vbmm`); ``path`` names the
    file in messages."""
    from bpmid.io.results import require

    cfg = cfg or VBMMConfig()
    geometry = geometry_from_yaml(require(data, "geometry", path), path)
    _check_model_block(data.get("model"), path)
    closure = require(data, "closure", path)
    material = material_from_yaml(data, path)
    if not isinstance(closure, str) or closure not in _CLOSURES:
        raise InputError(f"unknown closure {closure!r} (paper or consistent)", path=path, key="closure")
    try:
        model = VBMM(material=material, geometry=geometry, closure=closure, history=cfg.history, window_s=cfg.window_s)
    except InputError as exc:
        if exc.key != "model.geometry":
            raise
        raise InputError(exc.message, path=path, key="geometry") from None   # the file's own block
    return with_config(model, cfg, f"the fit {path}" if path is not None else "the given fit")


def stated_differences(model: VBMM, cfg: VBMMConfig | None) -> list[str]:
    """Which of ``geometry`` and ``closure`` a config's section ``model`` states (even at the paper's values) and
    ``model`` has otherwise (a geometry within 1e-6 relative is the same muscle)."""
    from bpmid.config import stated_keys

    stated = stated_keys(cfg) if cfg is not None else frozenset()
    out = []
    if "geometry" in stated and not np.allclose(cfg.geometry.vector(), model.geometry.vector(), rtol=1e-6, atol=0.0):
        out.append("geometry")
    if "closure" in stated and cfg.closure != model.closure:
        out.append("closure")
    return out


def with_config(model: VBMM, cfg: VBMMConfig | None, where: str = "the given model") -> VBMM:
    """``model`` under a config's section ``model``: a geometry or closure the config states (even at the
    paper's values) must be the model's own, else InputError (fitted constants belong to the muscle and closure
    they were fitted with; one of the two must not be silently ignored); a history mode or window it states is
    applied (evaluation settings)."""
    from bpmid.config import stated_keys

    if cfg is None:
        return model
    stated = stated_keys(cfg)

    def words(g) -> str:
        return (f"th {g.th * 1e3:.9g} mm, alpha0 {math.degrees(g.alpha0):.9g} deg, R0 {g.R0 * 1e3:.9g} mm, "
                f"l0 {g.l0 * 1e3:.9g} mm, n {g.n:.9g}")

    differ = stated_differences(model, cfg)
    if "geometry" in differ:
        raise InputError(f"the config's model.geometry ({words(cfg.geometry)}) differs from {where}'s "
                         f"({words(model.geometry)}); fitted constants belong to the muscle they were fitted on: "
                         f"use a fit of this muscle, or remove model.geometry from the config", key="model.geometry")
    if "closure" in differ:
        raise InputError(f"the config's model.closure ({cfg.closure}) differs from {where}'s ({model.closure}); the "
                         f"closure is part of the fitted model: remove model.closure from the config or refit with it",
                         key="model.closure")
    if stated & {"history", "window_s"}:
        model = model.replace(history=cfg.history if "history" in stated else model.history,
                              window_s=cfg.window_s if "window_s" in stated else model.window_s)
    return model


def starting_vbmm(init=None, cfg: VBMMConfig | None = None) -> tuple[VBMM, str, Path | None]:
    """The one rule for "the VBMM to start from": a fitted VBMM (``bpmid.vbmm/1``), a relaxation fit
    (``bpmid.relax/1``, the material's Prony constants), either as a path or a loaded result, else the paper's
    VBMM-fit constants. Geometry and closure of a vbmm file are its own; history settings from ``cfg``.

    Returns
    -------
    (model, where it came from in words, the input file or None)
    """
    from bpmid.io.results import read_result

    cfg = cfg or VBMMConfig()
    if init is None:
        return VBMM.from_config(Material.paper_fit(), cfg), "paper VBMM-fit constants", None
    schema = getattr(init, "schema", None)
    if schema is not None and hasattr(init, "to_dict"):  # a loaded or computed bpmid result
        data, path = init.to_dict(), getattr(init, "source", None)
    else:
        path = Path(init)
        data = read_result(path, ("bpmid.vbmm/", "bpmid.relax/"))
    schema = str(data.get("schema"))
    if schema.startswith("bpmid.vbmm/"):
        # a start: its constants are refitted, so a geometry or closure the config states is the muscle being
        # fitted and wins over the file's (said in the words), where a prediction would refuse the difference
        model = vbmm_from_mapping(data, path, None).replace(history=cfg.history, window_s=cfg.window_s)
        where = f"{path or 'given VBMM'} (motion fit)"
        taken = stated_differences(model, cfg)
        if taken:
            model = model.replace(**{k: getattr(cfg, k) for k in taken})
            where += (f"; its constants only as the start: the {' and '.join(taken)} from the config, which differ "
                      f"from the fit's")
        return model, where, path
    if schema.startswith("bpmid.relax/"):
        from bpmid.models.vbmm.fit import material_from_relax

        return (VBMM.from_config(material_from_relax(data, path), cfg), f"{path or 'given fit'} (relaxation fit)",
                path)
    raise InputError(f"needs a bpmid.vbmm/1 or bpmid.relax/1 file, found schema {schema!r}", path=path, key="schema")


#: the hereditary sum (VBMM.md eq. 5) takes each strain step as a jump at its sample; against a history that moves
#: smoothly between samples its error grows as the step over the shortest time constant, about dt / (2 tau) of the
#: moduli of that branch (a helper's known-truth review: K_1 19 % low at 10 Hz with tau 0.21 s, 4 % at 50 Hz). Above
#: this share a fit says its constants hold for its sampling step
SAMPLING_NOTE_SHARE = 0.05


def sampling_note(material: Material, logs) -> str | None:
    """A sentence for a fit whose logs' sampling step is not small against its shortest time constant; None
    otherwise. Recorded with the constants (``notes``), not a warning: the model is the discrete sum the spec
    defines, and its constants are right for the rate it runs at."""
    import numpy as np

    steps = [float(np.median(np.diff(np.asarray(lg.time_s, float)))) for lg in logs if np.size(lg.time_s) > 1]
    taus = material.time_constants
    if not steps or not taus:
        return None
    dt, tau = float(np.median(steps)), min(taus)
    lo, hi = min(steps), max(steps)
    if hi > 1.5 * lo and hi / (2.0 * tau) > SAMPLING_NOTE_SHARE:
        # logs at several rates: their median step (0.1 and 0.005 s gave "0.0525 s (19 Hz)") is no log's step
        return (f"sampling: the logs step {lo:.3g} to {hi:.3g} s ({1.0 / hi:.3g} to {1.0 / lo:.3g} Hz), not one step, "
                f"against a shortest time constant of {tau:.3g} s; the model's hereditary sum takes each pressure step "
                f"as a jump at its sample, so constants hold for one step, and these were fitted on several: at "
                f"{1.0 / hi:.3g} Hz that branch's moduli act some {100.0 * (hi - lo) / (2.0 * tau):.0f} % apart from at "
                f"{1.0 / lo:.3g} Hz. Fit on logs taken at the rate the model will run at (bpmid predict, the C export, "
                f"a controller)")
    share = dt / (2.0 * tau)
    if share <= SAMPLING_NOTE_SHARE:
        return None
    return (f"sampling: the logs step {dt:.3g} s ({1.0 / dt:.3g} Hz) against a shortest time constant of {tau:.3g} s; "
            f"the model's hereditary sum takes each pressure step as a jump at its sample, so these constants hold for "
            f"this step: run the model at it (bpmid predict, the C export, a controller), and expect a fit to logs of "
            f"the same muscle taken much faster to read that branch's moduli some {100.0 * share:.0f} % apart "
            f"(below {100.0 * SAMPLING_NOTE_SHARE:g} % from {1.0 / (2.0 * tau * SAMPLING_NOTE_SHARE):.3g} Hz). A "
            f"material in continuous time that acts the same (what a relaxation test measures) has that branch's "
            f"moduli {continuous_factor(dt, tau):.3g} times these ((dt/tau) / (1 - exp(-dt/tau)), exact for strains "
            f"linear between samples)")


def _branches_scaled(material: "Material", dt: float, power: int) -> "Material":
    tau_k = material.tauG if material.tauK is None else material.tauK
    return dataclasses.replace(
        material, G=tuple(g * continuous_factor(dt, t) ** power for g, t in zip(material.G, material.tauG)),
        K=tuple(k * continuous_factor(dt, t) ** power for k, t in zip(material.K, tau_k)))


def material_at_step(material: "Material", dt: float) -> "Material":
    """``material`` (a material in continuous time: a relaxation test's constants) as the sum sampled every ``dt`` s
    needs it to act the same: each branch modulus divided by :func:`continuous_factor` (dt, its tau)."""
    return _branches_scaled(material, dt, -1)


def material_from_step(material: "Material", dt: float) -> "Material":
    """The material in continuous time that acts as ``material`` does in the sum sampled every ``dt`` s (a motion
    fit's constants at its logs' step): each branch modulus times :func:`continuous_factor` (dt, its tau)."""
    return _branches_scaled(material, dt, 1)


def continuous_factor(dt: float, tau: float) -> float:
    """By how much a Prony branch's modulus in continuous time exceeds the one the sampled hereditary sum (VBMM.md
    section 3, step ``dt``) needs for the same response: (dt/tau) / (1 - exp(-dt/tau)). With the strain linear between
    samples the branch's exact state is h (1 - e) tau / dt, h the sum's state and e = exp(-dt/tau), so a fit of the
    sum reads the branch's modulus smaller by that factor (1.25 at dt/tau = 0.47); 1 as dt/tau -> 0."""
    x = dt / tau
    return x / -math.expm1(-x) if x > 0 else 1.0


def paper_geometry_note(geometry: Geometry) -> str | None:
    """A sentence for the user when ``geometry`` is the paper's muscle, which is also what a run without any
    geometry gets (a different muscle fitted with it gives wrong constants and may name wrong effects); None
    otherwise."""
    if geometry != Geometry():
        return None
    g = geometry
    return (f"muscle geometry: the paper's (th {g.th * 1e3:g} mm, alpha0 {math.degrees(g.alpha0):g} deg, "
            f"R0 {g.R0 * 1e3:g} mm, l0 {g.l0 * 1e3:g} mm, n {g.n:g}), used when none is given; for another muscle "
            "give its geometry in a config (model: {geometry: {th_mm: ..., alpha0_deg: ..., R0_mm: ..., l0_mm: "
            "..., n: ...}}) with --config")


def vbmm_yaml_body(model: VBMM, stderr: dict | None = None, *, params=None) -> dict:
    """The model part of a ``bpmid.vbmm/1`` file (geometry, closure, material, history settings): the one
    writer of the format, read back by :func:`vbmm_from_mapping`. ``params`` (the naming of
    :func:`material_params`, e.g. a fit's result with standard errors and verdicts) replaces the material's own
    values in the ``material`` block."""
    return {"geometry": model.geometry.to_yaml(), "closure": model.closure,
            "material": model.material.to_yaml(stderr) if params is None else material_yaml(params),
            "model": {"history": model.history, "window_s": model.window_s}}


def triangle_pressure(t: np.ndarray, p_lo: float, p_hi: float, rate: float) -> np.ndarray:
    """A symmetric triangle wave between p_lo and p_hi at +-rate (units of p per s), starting at p_lo."""
    period = 2.0 * (p_hi - p_lo) / rate
    ph = np.mod(np.asarray(t, float), period)
    up = ph < period / 2
    return np.where(up, p_lo + rate * ph, p_hi - rate * (ph - period / 2))


__all__: Sequence[str] = ["Geometry", "Material", "VBMM", "VBMMConfig", "kinematics", "u3_from_beta",
                          "closure_pressure", "load_vbmm", "vbmm_from_mapping", "with_config", "starting_vbmm", "material_params",
                          "material_yaml", "FIT_BOUNDS", "DISCOVERY_BOUNDS", "vbmm_yaml_body", "material_from_yaml"]
