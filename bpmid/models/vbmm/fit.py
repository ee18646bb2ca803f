"""Fit the VBMM's material constants to pressure-angle logs (``bpmid fit motion``).

The fit follows the paper (section V.A, "VBMM-fit") and VBMM.md section 5:

1. Start values ("prior") from a relaxation fit (``bpmid fit relax``; shear moduli G from ``shear``, bulk
   moduli K from ``bulk``, time constants shared) or the paper's VBMM-mat constants.
2. A linear least-squares start in pressure space: for fixed time constants the closed-form inverse
   P(beta history) is linear in (G_inf, G_j, K_inf, K_j), so the free moduli solve a linear problem on the
   measured angles; the time constants are chosen from a short grid of scale factors around the prior.
   Moduli the pressure data cannot determine stay at their prior value.
3. Nonlinear least squares on the angle error of the forward model over all logs at once
   (:func:`bpmid.fitting.fit_least_squares`), with standard errors (effective sample size), correlations
   and an identifiability verdict per parameter. A parameter the data cannot determine is reported as
   such and held at its prior value: typically the shear moduli, which move the angle about 1000 times
   less than the bulk moduli (``sensitivity_deg`` in the output shows by how much).

Parameter names: ``G_inf``, ``K_inf``, ``G_j``, ``K_j`` (Pa) and ``tau_j`` (s), or ``tauG_j`` and ``tauK_j``
when the time constants are split (j = 1..branches).

Units: Pa and s for the constants, degrees for angles, gauge Pa for pressures.
"""
from __future__ import annotations

import dataclasses
import math
import re
import time
from pathlib import Path
from typing import Literal, Mapping, Optional, Sequence

import numpy as np

from bpmid import identifiability
from bpmid import metrics as M
from bpmid.errors import InputError
from bpmid.fitting import FitResult, fit_least_squares
from bpmid.io.motion_logs import MotionLog
from bpmid.models import _vbmm_kernels as VK
from bpmid.models.vbmm import (VBMM, Material, VBMMConfig, material_params, paper_geometry_note, sampling_note,
                               vbmm_yaml_body)
from bpmid.params import ParamSet
from bpmid.progress import note
from bpmid.relax._blas import one_blas_thread

#: paper's name for each built-in prior
PRIORS = {"paper-mat": Material.paper_mat, "paper-fit": Material.paper_fit}
#: MAPE ignores samples with |angle| at or below this (deg): near 0 deg a percentage error means nothing
MAPE_FLOOR_DEG = 1.0
_NAME = re.compile(r"^(G_inf|K_inf|(G|K|tau|tauG|tauK)_[1-9][0-9]*)$")


@dataclasses.dataclass(frozen=True)
class MotionFitConfig:
    """Config section ``motion``: how ``bpmid fit motion`` fits the VBMM.

    Attributes
    ----------
    branches : number of Prony branches; None takes the initial material's number (paper: 1)
    split_tau : separate time constants for G and K (``tauG_j``, ``tauK_j``) instead of a shared ``tau_j``
    prior : start when no relaxation fit is given: ``paper-mat`` (relaxation constants) or ``paper-fit``
    relax_fit : a ``bpmid.relax/1`` file to start from (relative to the config file); ``--init`` wins
    start : start (= prior) values by parameter name, SI (Pa, s); overrides the initial source
    fixed : parameter names held at their start value (not estimated)
    bounds : parameter name -> [lower, upper] (SI); defaults: moduli [0, inf), K_inf [1 kPa, inf),
        time constants [1 ms, 1000 s]
    linear_start : run the linear least-squares start in pressure space
    tau_grid : scale factors of the prior time constants the linear start tries (log-spaced 0.1..10; 1: none)
    check_identifiability : hold parameters the data cannot determine at their prior value
    rel_se_max : a relative standard error above this makes a parameter not identifiable
    corr_max : a correlation above this (absolute) makes the weaker of two parameters not identifiable
    max_nfev : budget of forward evaluations of the nonlinear least squares (per round)
    angle_tolerance_deg : measured angles may dip this far below 0 deg (sensor noise) before the log is refused
    """

    branches: Optional[int] = None
    split_tau: bool = False
    prior: Literal["paper-mat", "paper-fit"] = "paper-mat"
    relax_fit: Optional[str] = None
    start: Mapping[str, float] = dataclasses.field(default_factory=dict)
    fixed: tuple[str, ...] = ()
    bounds: Mapping[str, tuple[float, ...]] = dataclasses.field(default_factory=dict)
    linear_start: bool = True
    tau_grid: int = 13
    check_identifiability: bool = True
    rel_se_max: float = 0.5
    corr_max: float = 0.995
    max_nfev: int = 300
    angle_tolerance_deg: float = 2.0

    def validate(self, where="motion", path=None):
        if self.branches is not None and not 1 <= self.branches <= 8:
            raise InputError(f"branches must be 1..8, found {self.branches}", path=path, key=f"{where}.branches")
        for what, names in (("start", self.start), ("fixed", self.fixed), ("bounds", self.bounds)):
            for name in names:
                if not _NAME.match(name):
                    raise InputError(f"unknown parameter name {name!r} (G_inf, K_inf, G_j, K_j, tau_j or "
                                     "tauG_j/tauK_j)", path=path, key=f"{where}.{what}")
        for name, v in self.start.items():
            if not (np.isfinite(v) and v >= 0):
                raise InputError(f"start values must be finite and non-negative (SI), found {v!r}", path=path,
                                 key=f"{where}.start.{name}")
        for name, b in self.bounds.items():
            if len(b) != 2 or not b[0] < b[1]:
                raise InputError(f"bounds are [lower, upper] with lower < upper, found {list(b)}", path=path,
                                 key=f"{where}.bounds.{name}")
            if not b[0] >= 0:   # moduli and time constants: a negative one is no rubber, and the solve fails on it
                raise InputError(f"a lower bound of a modulus or time constant must be >= 0 (SI), found {b[0]!r}",
                                 path=path, key=f"{where}.bounds.{name}")
        if not self.tau_grid >= 1:
            raise InputError("tau_grid must be at least 1", path=path, key=f"{where}.tau_grid")
        if not self.rel_se_max > 0:
            raise InputError("rel_se_max must be positive", path=path, key=f"{where}.rel_se_max")
        if not 0 < self.corr_max <= 1:
            raise InputError("corr_max must lie in (0, 1]", path=path, key=f"{where}.corr_max")
        if not self.max_nfev >= 1:
            raise InputError("max_nfev must be at least 1", path=path, key=f"{where}.max_nfev")
        if not self.angle_tolerance_deg >= 0:
            raise InputError("angle_tolerance_deg must be >= 0", path=path, key=f"{where}.angle_tolerance_deg")


# ---------------------------------------------------------------------------------------------
# initial material: relaxation fit or the paper
# ---------------------------------------------------------------------------------------------
def material_from_relax(source, path=None) -> Material:
    """The VBMM material of a relaxation fit (``bpmid.relax/1``): G from ``shear``, K from ``bulk``.

    Parameters
    ----------
    source : path of the YAML file, or its already-loaded mapping
    path : the file's name for messages when ``source`` is a mapping

    Returns
    -------
    Material (Pa, s); time constants shared when shear and bulk terms agree, split otherwise
    """
    from bpmid.relax.result import load_relax_fit, relax_fit_from_mapping

    # one reader for relaxation fits (units converted, mode and Poisson's ratio checked, shear and bulk
    # checked against prony and poisson_ratio), whoever asks for one
    if isinstance(source, (str, Path)):
        try:
            rf = load_relax_fit(source)
        except InputError as exc:
            if exc.key != "schema":
                raise
            from bpmid.io.results import what_to_give

            # _not_a_relax_fit says what --init takes in its own words (and what to do with a motion fit)
            raise InputError(exc.message.removesuffix("; " + what_to_give(("bpmid.relax/",)))
                             + _not_a_relax_fit(Path(source)), path=exc.path, line=exc.line, key=exc.key) from None
        path = Path(source)
    elif isinstance(source, Mapping):
        rf = relax_fit_from_mapping(dict(source), None if path is None else Path(path))
    else:
        raise TypeError(f"relax fit must be a path or a mapping, not {type(source).__name__}")
    if not rf.K_inf > 0:
        raise InputError("bulk.K_inf must be positive", path=path, key="bulk.K_inf")
    from bpmid.models.vbmm import MAX_BRANCHES

    if len(rf.tau) > MAX_BRANCHES:  # a resource limit: every term becomes a branch of every simulated step
        raise InputError(f"{len(rf.tau)} Prony terms, more than the {MAX_BRANCHES} a relaxation fit can have",
                         path=path, key="prony")
    try:
        return Material(float(rf.G_inf), float(rf.K_inf), tuple(map(float, rf.G)), tuple(map(float, rf.K)),
                        tuple(map(float, rf.tau)), None)
    except InputError as exc:
        raise InputError(exc.message, path=path, key=exc.key) from None


def _not_a_relax_fit(path: Path) -> str:
    """What to do with a file given where a relaxation fit is expected (``--init``, ``motion.relax_fit``): what it
    takes, and, for a motion fit (``bpmid.vbmm/1``), how to predict with it or start a motion fit from its constants
    (a config's ``motion.start``, with its values written out)."""
    from bpmid.config import read_yaml
    from bpmid.models.vbmm import material_params
    from bpmid.models.vbmm.model import Geometry, geometry_from_yaml, material_from_yaml

    out = ("; --init (and motion.relax_fit) takes a relaxation fit, the file bpmid fit relax writes (schema "
           "bpmid.relax/1)")
    try:
        data, _sha = read_yaml(path)
        schema = str(data.get("schema", "")) if isinstance(data, dict) else ""
    except InputError:
        return out
    if not schema.startswith("bpmid.vbmm/"):
        return out + (f"; this file is a {schema.split('/')[0].removeprefix('bpmid.')} result" if schema.startswith(
            "bpmid.") else "")
    out += (f"; this file is a motion fit (what bpmid fit motion writes): to predict with it, bpmid predict LOG "
            f"--params {path}; to start a new motion fit from its constants, drop --init and give them as start "
            f"values in a config (--config)")
    try:
        mat = material_from_yaml(data, path)
        geo = geometry_from_yaml(data.get("geometry"), path) if "geometry" in data else Geometry()
    except InputError:
        return out + ": motion: {start: {G_inf: ..., K_inf: ..., G_1: ..., K_1: ..., tau_1: ...}} (Pa, s)"
    start = ", ".join(f"{p.name}: {p.value:.6g}" for p in material_params(mat))
    extra = (f", branches: {mat.n_branches}" if mat.n_branches != 1 else "") + (", split_tau: true" if mat.split
                                                                               else "")
    out += f": motion: {{start: {{{start}}}{extra}}} (Pa, s)"
    if geo != Geometry():
        out += (f", with its geometry as model: {{geometry: {{th: {geo.th:.6g}, alpha0: {geo.alpha0:.6g}, "
                f"R0: {geo.R0:.6g}, l0: {geo.l0:.6g}, n: {geo.n:.6g}}}}}")
    return out


def initial_material(cfg: MotionFitConfig, init=None, *, base_dir: Path | None = None) -> tuple[Material, str]:
    """The start material and a description of where it came from.

    Parameters
    ----------
    cfg : the ``motion`` section
    init : a relaxation fit (path, loaded mapping or :class:`Material`); None uses ``cfg.relax_fit`` or
        ``cfg.prior``
    base_dir : folder that ``cfg.relax_fit`` is relative to
    """
    if init is None and cfg.relax_fit is not None:
        p = Path(cfg.relax_fit)
        init = p if p.is_absolute() or base_dir is None else base_dir / p
    if init is None:
        mat, source = PRIORS[cfg.prior](), f"{cfg.prior} (paper, section V.A)"
    elif isinstance(init, Material):
        mat, source = init, "material given in code"
    elif isinstance(init, (str, Path)):
        mat, source = material_from_relax(init), f"relaxation fit {init}"
    else:
        mat, source = material_from_relax(init), "relaxation fit (mapping)"
    return _adapt_branches(mat, cfg), source


#: default bounds of a time constant (s)
TAU_BOUNDS = (1e-3, 1e3)


def _slower(tau: float) -> float:
    """The time constant of an added, slower branch: 10x ``tau``, but inside the default bounds (between ``tau``
    and the upper bound, geometrically, once 10x would leave them)."""
    hi = TAU_BOUNDS[1]
    return 10.0 * tau if 10.0 * tau <= 0.5 * hi else math.sqrt(min(tau, 0.99 * hi) * hi)


def _adapt_branches(mat: Material, cfg: MotionFitConfig) -> Material:
    """Match the branch count and tau sharing the config asks for."""
    m = mat.n_branches
    want = m if cfg.branches is None else cfg.branches
    if want < m:
        raise InputError(f"the initial material has {m} Prony branches and motion.branches asks for {want}; "
                         "fit the relaxation test with fewer terms or raise motion.branches", key="motion.branches")
    G, Kk, tG, tK = list(mat.G), list(mat.K), list(mat.tauG), list(mat.tau_K)
    while len(G) < want:
        # a new, slower branch: 10x the last time constant, 30 % of its moduli (or of the long-term ones)
        G.append(0.3 * (G[-1] if G else mat.G_inf))
        Kk.append(0.3 * (Kk[-1] if Kk else mat.K_inf))
        tG.append(_slower(tG[-1]) if tG else 0.4)
        tK.append(_slower(tK[-1]) if tK else 0.4)
    split = cfg.split_tau or mat.split
    if mat.split and not cfg.split_tau:
        raise InputError("the initial material has separate time constants for G and K; set motion.split_tau: true",
                         key="motion.split_tau")
    return Material(mat.G_inf, mat.K_inf, tuple(G), tuple(Kk), tuple(tG), tuple(tK) if split else None)


# ---------------------------------------------------------------------------------------------
# material <-> parameters
# ---------------------------------------------------------------------------------------------
def params_from_material(mat: Material, cfg: MotionFitConfig | None = None, *, all_fixed: bool = False) -> ParamSet:
    """The ParamSet of a material (names as in the module docstring), with the config's start values,
    fixed flags and bounds applied."""
    cfg = cfg or MotionFitConfig()
    params = material_params(mat)
    for what, names in (("start", cfg.start), ("fixed", cfg.fixed), ("bounds", cfg.bounds)):
        for name in names:
            if name not in params:
                raise InputError(f"no parameter {name!r} in this model (it has {', '.join(params.names())})",
                                 key=f"motion.{what}.{name}")
    for name, v in cfg.start.items():
        params = params.replace(name, value=float(v))
    for name, (lo, hi) in cfg.bounds.items():
        params = params.replace(name, lower=float(lo), upper=float(hi))
    for p in params:
        if not p.lower <= p.value <= p.upper:
            # name the key the user wrote (bounds or start); else the start came from the initial material
            key = (f"motion.bounds.{p.name}" if p.name in cfg.bounds else f"motion.start.{p.name}"
                   if p.name in cfg.start else None)
            raise InputError(f"start value {p.value:g} {p.unit} of {p.name} lies outside its bounds "
                             f"[{p.lower:g}, {p.upper:g}]" + ("" if key else
                             " (the start comes from the initial material: set motion.start." + p.name
                             + " or motion.bounds." + p.name + ")"), key=key)
        if p.log_scale and p.value <= 0:
            raise InputError("a time constant must be positive", key=f"motion.start.{p.name}")
    for name in cfg.fixed:
        params = params.replace(name, fixed=True)
    if all_fixed:
        for name in params.names():
            params = params.replace(name, fixed=True)
    return params


def material_from_params(params: ParamSet) -> Material:
    """Inverse of :func:`params_from_material`."""
    v = params.values()
    m = 0
    while f"G_{m + 1}" in v:
        m += 1
    split = m > 0 and "tauG_1" in v
    G = tuple(v[f"G_{i}"] for i in range(1, m + 1))
    Kk = tuple(v[f"K_{i}"] for i in range(1, m + 1))
    if split:
        tG = tuple(v[f"tauG_{i}"] for i in range(1, m + 1))
        tK = tuple(v[f"tauK_{i}"] for i in range(1, m + 1))
    else:
        tG = tuple(v[f"tau_{i}"] for i in range(1, m + 1))
        tK = None
    return Material(v["G_inf"], v["K_inf"], G, Kk, tG, tK)


def _is_modulus(name: str) -> bool:
    return not name.startswith("tau")


# ---------------------------------------------------------------------------------------------
# input checks
# ---------------------------------------------------------------------------------------------
def check_pressure_range(log: MotionLog) -> None:
    """Refuse pressures below vacuum (an absolute log read as gauge, or a unit mix-up)."""
    p = np.asarray(log.pressure_pa, float)
    if not np.all(np.isfinite(p)):
        k = int(np.flatnonzero(~np.isfinite(p))[0])
        raise InputError(f"pressure is not a number at t = {log.time_s[k]:g} s", path=log.path or log.name)
    low = np.flatnonzero(p < -log.atmosphere_pa)
    if low.size:
        k = int(low[0])
        raise InputError(f"pressure {p[k]:.6g} Pa gauge at t = {log.time_s[k]:g} s is below vacuum "
                         f"(check the unit and the pressure reference)", path=log.path or log.name)


def check_angle_range(log: MotionLog, tolerance_deg: float = 2.0) -> None:
    """Refuse measured angles the model cannot produce: below 0 deg (beyond sensor noise) or above 720 deg."""
    a = log.angle_deg
    if a is None:
        raise InputError("a training log needs an angle_deg column", path=log.path or log.name)
    if not np.all(np.isfinite(a)):
        k = int(np.flatnonzero(~np.isfinite(a))[0])
        raise InputError(f"angle is not a number at t = {log.time_s[k]:g} s", path=log.path or log.name)
    hi = math.degrees(VK.BETA_MAX)
    bad = np.flatnonzero((a < -tolerance_deg) | (a > hi))
    if bad.size:
        k = int(bad[0])
        raise InputError(f"angle {a[k]:g} deg at t = {log.time_s[k]:g} s is outside the model's range "
                         f"(0..{hi:.0f} deg; the muscle does not bend backwards)", path=log.path or log.name)


# ---------------------------------------------------------------------------------------------
# linear start in pressure space
# ---------------------------------------------------------------------------------------------
def _unit_columns(logs: Sequence[MotionLog], mat: Material, names: Sequence[str], base: VBMM) -> np.ndarray:
    """(N_total, len(names)) pressure (Pa) per unit of each modulus along the measured angle histories."""
    cols = []
    for name in names:
        G = [0.0] * mat.n_branches
        Kk = [0.0] * mat.n_branches
        Gi = Ki = 0.0
        if name == "G_inf":
            Gi = 1.0
        elif name == "K_inf":
            Ki = 1.0
        else:
            kind, j = name.split("_")
            (G if kind == "G" else Kk)[int(j) - 1] = 1.0
        unit = Material(Gi, Ki, tuple(G), tuple(Kk), mat.tauG, mat.tauK)
        vb = base.replace(material=unit, history="recursive")
        cols.append(np.concatenate([vb.inverse(lg.time_s, np.clip(lg.angle_rad, 0.0, VK.BETA_MAX)) for lg in logs]))
    return np.column_stack(cols) if cols else np.zeros((sum(lg.n for lg in logs), 0))


def _linear_solve(A: np.ndarray, y: np.ndarray, prior: np.ndarray, names: list[str], rel_se_max: float,
                  corr_max: float):
    """Least squares for the moduli, holding at the prior those the pressure data cannot determine.

    Returns values (len(names),), sse, held {name: reason}.
    """
    held: dict[str, str] = {}
    free = list(range(len(names)))
    val = prior.copy()
    while True:
        fixed = [i for i in range(len(names)) if i not in free]
        r0 = y - (A[:, fixed] @ prior[fixed] if fixed else 0.0)
        if not free:
            return val, float(r0 @ r0), held
        scale = np.where(prior[free] > 0, prior[free], 1.0)
        As = A[:, free] * scale
        z, *_ = np.linalg.lstsq(As, r0, rcond=None)
        res = r0 - As @ z
        dof = max(A.shape[0] - len(free), 1)
        s2 = float(res @ res) / dof
        try:
            cov = s2 * np.linalg.pinv(As.T @ As)
        except np.linalg.LinAlgError:  # pragma: no cover
            cov = np.full((len(free), len(free)), np.inf)
        se = np.sqrt(np.abs(np.diag(cov)))
        rel = se / np.maximum(np.abs(z), 1e-300)
        d = np.sqrt(np.abs(np.diag(cov)))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = np.nan_to_num(cov / np.outer(d, d)) - np.eye(len(free))
        bad = {}
        for k, i in enumerate(free):
            if z[k] < 0:
                bad[i] = (0, f"negative in the pressure-space solve ({z[k] * scale[k]:.3g} Pa)", rel[k])
            elif rel[k] > rel_se_max:
                bad[i] = (1, f"relative standard error {rel[k]:.0%} in the pressure-space solve", rel[k])
        pair = identifiability.strongest_pair(np.abs(corr), rel, corr_max) if not bad and len(free) > 1 else None
        if pair:
            k, other, a, b = pair
            bad[free[k]] = (2, f"correlated with {names[free[other]]} in the pressure-space "
                               f"solve (r = {corr[a, b]:+.4f})", rel[k])
        if not bad:
            val = prior.copy()
            val[free] = z * scale
            return val, float(res @ res), held
        worst = max(bad, key=lambda i: (bad[i][0] == 0, bad[i][2]))
        held[names[worst]] = bad[worst][1]
        free.remove(worst)


def linear_start(logs: Sequence[MotionLog], params: ParamSet, base: VBMM, cfg: MotionFitConfig) -> tuple[ParamSet, dict]:
    """Start values from the linear least squares in pressure space (VBMM.md section 5).

    For each candidate scaling of the free time constants the free moduli solve a linear problem
    P_measured = sum_m theta_m P_m(beta_measured); the candidate with the smallest pressure residual wins.
    Moduli the pressure data cannot determine (relative standard error, correlation, sign) stay at the prior.

    Returns
    -------
    params : the start values (fixed flags unchanged)
    report : pressure-space RMSE (Pa) before and after, chosen tau factor, moduli held at the prior
    """
    y = np.concatenate([lg.pressure_pa for lg in logs])
    mod_names = [n for n in params.free_names() if _is_modulus(n)]
    tau_names = [n for n in params.free_names() if not _is_modulus(n)]
    if not mod_names:
        return params, {"used": False, "reason": "no free moduli"}
    factors = np.logspace(-1, 1, cfg.tau_grid) if (tau_names and cfg.tau_grid > 1) else np.array([1.0])
    all_mods = [n for n in params.names() if _is_modulus(n)]
    prior_all = np.array([params.value(n) for n in all_mods])
    free_idx = [all_mods.index(n) for n in mod_names]
    fixed_idx = [i for i in range(len(all_mods)) if i not in free_idx]
    best = None
    rmse_prior = None
    for f in factors:
        trial = params
        for n in tau_names:
            p = params[n]
            trial = trial.replace(n, value=float(np.clip(p.value * f, p.lower, p.upper)))
        mat = material_from_params(trial)
        A = _unit_columns(logs, mat, all_mods, base)
        yy = y - (A[:, fixed_idx] @ prior_all[fixed_idx] if fixed_idx else 0.0)
        if abs(f - 1.0) < 1e-12:
            r = yy - A[:, free_idx] @ prior_all[free_idx]
            rmse_prior = float(np.sqrt(np.mean(r**2)))
        vals, sse, held = _linear_solve(A[:, free_idx], yy, prior_all[free_idx], mod_names, cfg.rel_se_max,
                                        cfg.corr_max)
        if best is None or sse < best[0]:
            best = (sse, f, trial, vals, held)
    sse, f, trial, vals, held = best
    out = trial.with_values({n: float(v) for n, v in zip(mod_names, vals)})
    return out, {"used": True, "tau_factor": float(f), "pressure_rmse_pa_prior": rmse_prior,
                 "pressure_rmse_pa": math.sqrt(sse / y.size), "held_at_prior": held}


# ---------------------------------------------------------------------------------------------
# the fit
# ---------------------------------------------------------------------------------------------
def simulate_deg(model: VBMM, log: MotionLog) -> np.ndarray:
    """Forward model angle (deg), shape (log.n,); a pressure beyond the 4 pi range gives 720 deg."""
    return np.degrees(model.forward_full(log.time_s, log.pressure_pa)["beta"])


@dataclasses.dataclass
class MotionFit:
    """Result of :func:`fit_motion`.

    Attributes
    ----------
    model : the fitted VBMM (closure, history and geometry of the config)
    fit : the least-squares result (parameters with stderr and verdicts, correlations, residual)
    prior : the start values before the linear start (what non-identifiable parameters are held at)
    source : where the prior came from
    linear : report of the linear start
    logs : the training logs
    predictions : name -> (N,) fitted angle (deg)
    metrics : pooled metrics over all logs (rmse_deg, mape_pct, r2, fit_pct, max_abs_err_deg)
    per_log : name -> metrics of that log
    sensitivity_deg : name -> RMS change of the angle (deg) over the logs for a +10 % change of the parameter
    seconds : wall time of the fit
    """

    model: VBMM
    fit: FitResult
    prior: ParamSet
    source: str
    linear: dict
    logs: list
    predictions: dict
    metrics: dict
    per_log: dict
    sensitivity_deg: dict
    seconds: float

    def verdicts(self) -> dict[str, str]:
        """Per parameter: ``estimated``, ``fixed (config)`` or ``not identifiable: <why>; held at prior``."""
        out = {}
        for p in self.fit.params:
            if p.name in self.fit.held:
                out[p.name] = f"not identifiable: {self.fit.held[p.name]}; held at prior value {p.value:.6g} {p.unit}"
            elif p.name in self.fit.free_names and p.identifiable is False:   # estimated, not held (its note)
                out[p.name] = p.note or "not identifiable; estimated, not held"
            elif p.name in self.fit.free_names:
                out[p.name] = "estimated"
            else:
                out[p.name] = f"fixed by config at {p.value:.6g} {p.unit}"
        return out

    def yaml_body(self) -> dict:
        """Everything of the ``bpmid.vbmm/1`` file but schema and provenance."""
        params = self.fit.params
        unc = self.fit.uncertainty_yaml()
        unc["standard_errors"] = {p.name: (None if p.stderr is None else float(p.stderr)) for p in params}
        unc["relative_standard_errors"] = {
            p.name: (None if p.stderr is None or p.value == 0 else round(float(p.stderr / abs(p.value)), 6))
            for p in params}
        unc["identifiability"] = self.verdicts()
        unc["sensitivity_deg_per_10pct"] = {k: round(float(v), 6) for k, v in self.sensitivity_deg.items()}
        unc["thresholds"] = {"rel_se_max": self._cfg.rel_se_max, "corr_max": self._cfg.corr_max}
        body = vbmm_yaml_body(self.model, params=params)
        body["model"]["time_constants"] = "split" if self.model.material.split else "shared"
        return {
            **body,
            "metrics": {**{k: float(v) for k, v in self.metrics.items()}, "n_samples": int(sum(lg.n for lg in self.logs)),
                        "mape_floor_deg": MAPE_FLOOR_DEG,
                        "per_log": {k: {kk: float(vv) for kk, vv in v.items()} for k, v in self.per_log.items()}},
            "fit": {"initial": self.source,
                    "prior": {p.name: float(p.value) for p in self.prior},
                    "linear_start": self.linear,
                    "objective": "angle error (deg) of the forward model, all logs at once",
                    "logs": [{"name": lg.name, "samples": lg.n, "duration_s": round(lg.duration_s, 6),
                              # the median sampling step: the step these constants hold for (the C export says it)
                              "step_s": round(lg.dt_s, 9) if lg.n > 1 else None,
                              # the gauge pressures the constants were fitted on (predict says when it goes beyond)
                              "pressure_gauge_pa": [float(np.min(lg.pressure_pa)), float(np.max(lg.pressure_pa))]}
                             for lg in self.logs],
                    "seconds": round(self.seconds, 3)},
            "uncertainty": unc,
            # the geometry the constants belong to, when it is the paper's (also what a run without one gets):
            # recorded with them, not a warning (the paper's muscle is a muscle too)
            # and the sampling step they hold for, when it is not small against the shortest time constant
            **({"notes": notes} if (notes := [n for n in (paper_geometry_note(self.model.geometry),
                                                          sampling_note(self.model.material, self.logs)) if n])
               else {}),
        }

    _cfg: MotionFitConfig = dataclasses.field(default_factory=MotionFitConfig, repr=False)


def log_metrics(y, y_hat) -> dict:
    """Metrics of one log or pooled (deg, %, 1)."""
    out = M.summary(y, y_hat)
    out["mape_pct"] = M.mape_pct(y, y_hat, floor=MAPE_FLOOR_DEG)
    return out


@one_blas_thread  # a sequence of small solves: one BLAS thread (bpmid.relax._blas is the one place that sets it)
def fit_motion(logs: Sequence[MotionLog], *, config=None, init=None, params: ParamSet | None = None) -> MotionFit:
    """Fit the VBMM to motion logs (all at once) and report uncertainties and identifiability.

    Parameters
    ----------
    logs : training logs with ``angle_deg`` (gauge pressure in Pa inside)
    config : a :class:`bpmid.config.Config` (sections ``model`` and ``motion``), or None for defaults
    init : relaxation fit (path, mapping or Material); None uses ``motion.relax_fit`` or ``motion.prior``
    params : a complete ParamSet to start from instead (skips ``init``)

    Returns
    -------
    MotionFit
    """
    t0 = time.perf_counter()
    vcfg: VBMMConfig = config.section("model") if config is not None else VBMMConfig()
    mcfg: MotionFitConfig = config.section("motion") if config is not None else MotionFitConfig()
    logs = list(logs)
    if not logs:
        raise InputError("no training logs")
    for lg in logs:
        check_angle_range(lg, mcfg.angle_tolerance_deg)
        check_pressure_range(lg)
    total = sum(lg.n for lg in logs)
    if total < 20:
        raise InputError(f"{total} samples are too few to fit the VBMM (needs at least 20)",
                         path=logs[0].path if len(logs) == 1 else None)
    if params is None:
        mat, source = initial_material(mcfg, init, base_dir=None if config is None else config.base_dir)
        prior = params_from_material(mat, mcfg)
    else:
        prior, source = params, "parameters given in code"
    base = VBMM.from_config(material_from_params(prior), vcfg)

    start, linear = prior, {"used": False}
    if mcfg.linear_start:
        note("linear start in pressure space")
        start, linear = linear_start(logs, prior, base, mcfg)

    def residual(p: ParamSet) -> np.ndarray:
        model = base.replace(material=material_from_params(p))
        return np.concatenate([simulate_deg(model, lg) - lg.angle_deg for lg in logs])

    start, linear["multi_start"] = _best_start(residual, start, prior)
    note(f"least squares on the angle error of {len(logs)} logs ({total} samples)")
    kw = dict(segments=[lg.n for lg in logs], check_identifiability=mcfg.check_identifiability,
              rel_se_max=mcfg.rel_se_max, corr_max=mcfg.corr_max, max_nfev=mcfg.max_nfev)
    res = _fit_holding_at_prior(residual, start, prior, **kw)
    res = _unless_holds_rejected(residual, start, res, linear, kw,
                                 np.concatenate([lg.angle_deg for lg in logs]))
    linear["least_squares"] = {"converged": bool(res.success), "message": str(res.message),
                               "evaluations": int(res.nfev)}
    if not res.success:
        note(f"warning: the least-squares fit did not converge ({res.message}); the constants are where it stopped")
    model = base.replace(material=material_from_params(res.params))

    preds, per_log = {}, {}
    for lg in logs:
        out = model.forward_full(lg.time_s, lg.pressure_pa)
        if np.any(out["status"] == VK.STATUS_ABOVE_RANGE):
            k = int(np.flatnonzero(out["status"] == VK.STATUS_ABOVE_RANGE)[0])
            raise InputError(f"pressure {lg.pressure_pa[k]:.6g} Pa gauge at t = {lg.time_s[k]:g} s is above the "
                             "range of the fitted model (it would bend the muscle beyond 720 deg)",
                             path=lg.path or lg.name)
        preds[lg.name] = np.degrees(out["beta"])
        per_log[lg.name] = log_metrics(lg.angle_deg, preds[lg.name])
    y = np.concatenate([lg.angle_deg for lg in logs])
    yh = np.concatenate([preds[lg.name] for lg in logs])
    from bpmid.fitting import check_explained

    check_explained(y, yh, quantity="angle", unit="deg", paths=[lg.path or lg.name for lg in logs],
                    hint="fit on logs whose pressure program moves the muscle (ramps, steps, cycles) and check "
                         "the pressure and angle columns and their units")
    sens = sensitivity(model, logs, res.params, yh)
    return MotionFit(model, res, prior, source, linear, logs, preds, log_metrics(y, yh), per_log, sens,
                     time.perf_counter() - t0, mcfg)


#: a fit whose holds leave less than this share of the angle's variance explained is no fit of the logs
HELD_R2_MIN = 0.5


def _unless_holds_rejected(residual, start: ParamSet, res: FitResult, linear: dict, kw: dict,
                           y: np.ndarray) -> FitResult:
    """``res``, unless holding its not-identifiable constants at the relaxation test's values left it no fit of the
    logs (R^2 below :data:`HELD_R2_MIN`) and far worse than its own start (a likelihood ratio above
    :func:`bpmid.fitting.hold_rejected`: the fitting driver's own rule): then the relaxation constants and these logs
    disagree (a second Prony term the logs see otherwise, another material, a unit slip; one fit went to 17 deg
    from a 1.3 deg start and was refused as explaining nothing). The constants are then estimated where the data
    put them, each marked not identifiable, and ``linear['holds_rejected']`` says so (a warning of the fit). A
    hold that only costs some accuracy (a one-log fit) stays: the relaxation values are the better constants."""
    from bpmid.fitting import fit_least_squares, hold_rejected

    sse_start = (linear.get("multi_start") or {}).get("sse_chosen_deg2")
    sse_res = float(res.residual @ res.residual)
    sst = float(np.sum((y - np.mean(y)) ** 2)) if y.size else 0.0
    if not (kw.get("check_identifiability") and res.held and sse_start and sst > 0
            and sse_res > (1.0 - HELD_R2_MIN) * sst
            and hold_rejected(res.residual, (sse_start, res.n_eff, res.residual.size))):
        return res
    free = fit_least_squares(residual, start, **{**kw, "check_identifiability": False})
    sse_free = float(free.residual @ free.residual)
    if not sse_free < sse_res:
        return res
    n = max(res.residual.size, 1)
    linear["holds_rejected"] = {"rmse_held_deg": math.sqrt(sse_res / n), "rmse_free_deg": math.sqrt(sse_free / n),
                                "held": {k: str(v) for k, v in res.held.items()}}
    params = free.params
    for name, why in res.held.items():
        if name in params.names() and not params[name].fixed:
            params = params.replace(name, identifiable=False,
                                    note=f"not identifiable: {why}; estimated, not held (the logs reject its "
                                         f"relaxation value: the fit's warnings say how much)")
    return dataclasses.replace(free, params=params)


#: scale factors of the moduli and of the time constants the multi-start scores around the start
_START_MODULUS_SCALES = (0.35, 0.6, 1.0, 1.7, 3.0)
_START_TAU_SCALES = (0.3, 1.0, 3.0)


def _best_start(residual, start: ParamSet, prior: ParamSet) -> tuple[ParamSet, dict]:
    """Multi-start: the start (linear start or prior), the prior, and the start with every free modulus and time
    constant scaled (:data:`_START_MODULUS_SCALES` x :data:`_START_TAU_SCALES`), each scored by one evaluation of
    the angle error; the lowest wins. A poor start (a stiffness off by a factor of 2) then no longer leaves the
    local optimiser at its starting values."""
    def sse(p):
        try:
            r = np.asarray(residual(p), float)
        except (InputError, ValueError, FloatingPointError, RuntimeError):
            return math.inf
        return float(r @ r) if np.all(np.isfinite(r)) else math.inf

    cands = [("start", start), ("prior", prior)]
    for sm in _START_MODULUS_SCALES:
        for st in _START_TAU_SCALES:
            if sm == 1.0 and st == 1.0:
                continue
            vals = {}
            for p in start.free():
                f = st if p.name.startswith("tau") else sm
                vals[p.name] = min(max(p.value * f, p.lower), p.upper)
            cands.append((f"moduli x {sm:g}, time constants x {st:g}", start.with_values(vals)))
    scored = [(sse(p), how, p) for how, p in cands]
    best = min(scored, key=lambda x: x[0])
    return best[2], {"starts_scored": len(scored), "chosen": best[1],
                     "sse_chosen_deg2": float(best[0]) if math.isfinite(best[0]) else None,
                     "sse_given_start_deg2": float(scored[0][0]) if math.isfinite(scored[0][0]) else None}


def _fit_holding_at_prior(residual, start: ParamSet, prior: ParamSet, *, prior_z: float = 3.0, **kw) -> FitResult:
    """:func:`fit_least_squares` from ``start``; a parameter found not identifiable is held at its value in
    ``prior`` (the linear start may have moved it) and the others are refit.

    Besides the driver's verdict (relative standard error, bound, correlation) a parameter is not identifiable
    when its standard error exceeds ``rel_se_max`` times its prior value *and* the fit did not move it
    significantly (less than ``prior_z`` standard errors) from the prior: the data neither resolve it at the
    size it is expected to have nor contradict that size. A relative error judged at the fitted value alone
    misses a parameter that noise pushed 100 times above its prior (its standard error is absolute, and
    large values make it look small).
    """
    from bpmid.fitting import correlated_with

    held_all: dict[str, str] = {}
    links: dict[str, dict[str, float]] = {}
    current = start
    check = kw.get("check_identifiability", True)
    rel_max = kw.get("rel_se_max", 0.5)
    for _ in range(2 * len(start) + 2):
        res = fit_least_squares(residual, current, held_links=links, **kw)
        held_all.update(res.held)
        links.update(res.conditional)
        moved = [n for n in res.held if res.params[n].value != prior[n].value]
        weak = {}
        if check:
            for n in res.free_names:
                p, pr = res.params[n], prior[n].value
                if p.stderr is None or pr == 0 or p.fixed:
                    continue
                if p.stderr > rel_max * abs(pr) and abs(p.value - pr) < prior_z * p.stderr:
                    weak[n] = (p.stderr / abs(pr),
                               f"standard error {p.stderr / abs(pr):.0%} of its prior value and no significant "
                               f"departure from it ({abs(p.value - pr) / p.stderr:.1f} standard errors)")
        if not moved and not weak:
            break
        if weak:
            worst = max(weak, key=lambda n: weak[n][0])
            held_all[worst] = weak[worst][1]
            links[worst] = correlated_with(res.free_names, res.corr, worst)
        current = res.params
        for n in held_all:
            current = current.replace(n, value=prior[n].value, fixed=True, stderr=None)
    params = res.params
    for n, why in held_all.items():
        params = params.replace(n, value=prior[n].value, fixed=True, stderr=None, identifiable=False,
                                note=f"not identifiable: {why}; held at prior value")
    return dataclasses.replace(res, params=params, held=held_all, conditional=links)


def sensitivity(model: VBMM, logs: Sequence[MotionLog], params: ParamSet, base_deg: np.ndarray,
                rel_step: float = 0.1) -> dict[str, float]:
    """RMS change of the predicted angle (deg) over all logs for a ``rel_step`` relative change of each parameter."""
    out = {}
    for p in params:
        if p.value == 0:
            out[p.name] = 0.0
            continue
        pp = params.replace(p.name, value=p.value * (1.0 + rel_step))
        m2 = model.replace(material=material_from_params(pp))
        yh = np.concatenate([simulate_deg(m2, lg) for lg in logs])
        out[p.name] = float(np.sqrt(np.mean((yh - base_deg) ** 2)))
    return out


SCHEMA = "bpmid.vbmm/1"


def write_motion_fit(out: str | Path, result: MotionFit, prov: dict, *, figure: str | Path | None = None,
                     synthetic: "bool | str | None" = False) -> list[Path]:
    """Write the ``bpmid.vbmm/1`` YAML (and the figure when ``figure`` is a path), all or nothing.

    The figure is rendered before anything is written; if the YAML cannot be written the figure is removed.
    """
    import io

    from bpmid.io.atomic import write_bytes
    from bpmid.io.results import dump_yaml

    out = Path(out)
    if out.is_dir():
        raise InputError("--out must be a file name (VBMM.yaml), found a folder", path=out)
    data = {"schema": SCHEMA}
    data.update(result.yaml_body())
    if "warnings" in prov:  # plausibility warnings (bpmid.io.plausibility), also kept in the provenance
        data["warnings"] = list(prov["warnings"])
    data["provenance"] = prov
    text = dump_yaml(data)
    png = None
    if figure is not None:
        import matplotlib.pyplot as plt

        from bpmid.plots.motion import motion_fit_figure

        fig = motion_fit_figure(result.logs, result.predictions, title=f"VBMM fit ({result.model.closure} closure, "
                                f"{result.model.history} history): RMSE {result.metrics['rmse_deg']:.3g}°",
                                synthetic=synthetic)
        buf = io.BytesIO()
        try:
            fig.savefig(buf, dpi=110, format=Path(figure).suffix.lstrip(".") or "png")
        finally:
            plt.close(fig)
        png = buf.getvalue()
    written = []
    if png is not None:
        written.append(write_bytes(figure, png))
    try:
        written.insert(0, write_bytes(out, text.encode("utf-8")))
    except BaseException:
        for p in written:
            p.unlink(missing_ok=True)
        raise
    return written


__all__ = ["MotionFitConfig", "MotionFit", "fit_motion", "linear_start", "initial_material", "material_from_relax",
           "params_from_material", "material_from_params", "check_angle_range", "check_pressure_range",
           "simulate_deg", "log_metrics", "PRIORS", "SCHEMA", "write_motion_fit"]
