"""Fit a Prony series to relaxation logs, in ramp mode or step mode.

- **ramp mode**: the measured stress of all logs, jointly, as the hereditary integral of each log's
  own strain history (:class:`~bpmid.relax.bases.RampBasis`). A finite loading ramp is accounted for.
- **step mode**: the modulus curve of each hold, E(t') = sigma(t') / eps_hold with t' the time since
  the ramp ended (:func:`hold_curve`), pooled with any modulus-curve logs, fitted as an ideal-step
  response (:class:`~bpmid.relax.bases.StepBasis`), as the paper and pyvisco do. With a ramp of
  several time constants this under-reads the relaxing moduli; it is offered so the difference shows.

Both fit moduli by NNLS and log time constants by variable projection
(:mod:`bpmid.relax.varpro`). Standard errors come from the full Jacobian in (E_inf, E_j, log tau_j)
with the effective-sample-size inflation of :mod:`bpmid.fitting` (autocorrelated residuals).
"""
from __future__ import annotations

import dataclasses
import math
import time
from typing import Sequence

import numpy as np

from bpmid import metrics
from bpmid.errors import InputError
from bpmid.fitting import (BETWEEN_TESTS_METHOD, UNCERTAINTY_METHOD, correlation, covariance_from_jacobian,
                            effective_sample_size, with_between_tests)
from bpmid.io.relax_logs import RelaxLog
from bpmid.progress import note
from bpmid.relax import varpro
from bpmid.relax._blas import single_thread_blas
from bpmid.relax.bases import RampBasis, StepBasis

#: MAPE of stress fits counts samples whose |stress| is above this share of the largest (a ramp starts at zero)
MAPE_FLOOR_SHARE = 0.05

#: a step-mode modulus curve whose largest value is more than this many times its smallest (it spans more than a decade
#: of modulus, as master curves do) has its number of terms chosen on relative residuals (E_fit - E) / E, as the
#: frequency-domain fit does: on absolute residuals the criterion sees only the glassy end and drops slow terms
RELATIVE_SPAN = 10.0


#: fewest samples a log (in step mode: its hold) must have: one term and E_inf are 3 constants, plus 2 to spare
MIN_SAMPLES = 5


@dataclasses.dataclass
class HoldCurve:
    """The step-mode reading of one log: its hold as a modulus curve.

    Attributes
    ----------
    t : (M,) time since the hold started (s), starting at 0
    modulus_mpa : (M,) sigma / eps_hold (MPa), or the log's own modulus curve
    strain_level : held strain (dimensionless), nan for a modulus-curve log
    ramp_s : duration of the loading ramp (s), 0 for a modulus-curve log
    start : index in the log of the first hold sample
    """

    t: np.ndarray
    modulus_mpa: np.ndarray
    strain_level: float
    ramp_s: float
    start: int


def hold_curve(log: RelaxLog, window_s: float | None = None) -> HoldCurve:
    """Reduce a ramp-and-hold log to the modulus curve of its hold (step mode).

    The held strain is the median strain of the last fifth of the log; the hold starts at the first
    sample whose strain is within max(0.2 % of that level, 3 robust noise deviations) of it, and the
    ramp starts at the last sample below 2 % of it.

    Parameters
    ----------
    log : a stress-strain (or load-extension) log, or a modulus curve (returned as it is)
    window_s : keep this much of the hold (s); None keeps all of it (a modulus curve is always kept whole)
    """
    if log.is_modulus_curve:  # already reduced: used whole, the window applies to holds of ramp tests
        return HoldCurve(log.time_s, log.modulus_mpa, math.nan, 0.0, 0)
    eps, t = log.strain, log.time_s
    tail = eps[int(0.8 * eps.size):]
    level = float(np.median(tail))
    if not level > 0:
        raise InputError(f"no hold found: the strain at the end of the log is {level:g} (expected a positive held "
                         "strain)", path=log.path, key="strain")
    noise = 1.4826 * float(np.median(np.abs(tail - level)))
    tol = max(0.002 * level, 3.0 * noise)
    at = np.flatnonzero(eps >= level - tol)
    start = int(at[0])
    if eps.size - start < 3:
        raise InputError("no hold found: the strain reaches its final level only in the last samples",
                         path=log.path, line=log.first_data_line + start)
    below = np.flatnonzero(eps[:start] < 0.02 * level)
    ramp_start = int(below[-1]) if below.size else 0
    th = t[start:] - t[start]
    E = log.stress_mpa[start:] / level
    if window_s is not None:
        k = th <= window_s
        th, E = th[k], E[k]
    return HoldCurve(th, E, level, float(t[start] - t[ramp_start]), start)


@dataclasses.dataclass
class LogFit:
    """One log's data and fit, in the fitted quantity (stress or modulus, MPa).

    Attributes
    ----------
    name, source : the log's name and source kind
    t : (M,) s; data and fit times (the whole log in ramp mode, the hold in step mode)
    y, y_fit : (M,) MPa
    quantity : ``"stress"`` or ``"modulus"``
    hold : the log's step-mode modulus curve (for the overlay figure)
    """

    name: str
    source: str
    t: np.ndarray
    y: np.ndarray
    y_fit: np.ndarray
    quantity: str
    hold: HoldCurve

    @property
    def rmse_mpa(self) -> float:
        return metrics.rmse(self.y, self.y_fit)


@dataclasses.dataclass
class RelaxFit:
    """A fitted Prony series with everything the output file and figure need.

    Moduli in MPa, time constants in s (the YAML writer converts to Pa).

    Attributes
    ----------
    mode : ``"ramp"`` or ``"step"``
    E_inf : float; E, tau : (m,) ascending in tau
    se_E_inf : float or nan; se_E, se_tau : (m,) standard errors (nan where not determined)
    param_names : names in the order of ``corr`` (E_inf, E_1, tau_1, E_2, tau_2, ...)
    corr : (2m+1, 2m+1) correlation matrix
    n_obs, n_eff : samples fitted and effective sample size
    rmse_mpa, r2, mape_pct : metrics of the fitted quantity
    quantity : ``"stress"`` (ramp) or ``"modulus"`` (step)
    selection : one entry per candidate number of terms visited (terms, rmse_mpa, criterion)
    criterion : name of the criterion (``"BIC"`` or ``"AICc"``), or None for a fixed number of terms
    requested_terms : ``"auto"`` or the number asked for
    logs : per-log data and fit
    seconds : wall time of the fit (s)
    uncertainty_method : how the standard errors were computed
    warnings : things a reader of the constants must know (time constants outside the data's time span)
    weighting : residuals of the term criterion: ``"absolute"`` (MPa) or ``"relative"`` ((E_fit - E)/E: a step-mode
        modulus curve spanning more than ``RELATIVE_SPAN`` in modulus); the fit itself is on absolute residuals
    """

    mode: str
    E_inf: float
    E: np.ndarray
    tau: np.ndarray
    se_E_inf: float
    se_E: np.ndarray
    se_tau: np.ndarray
    param_names: list[str]
    corr: np.ndarray
    n_obs: int
    n_eff: float
    rmse_mpa: float
    r2: float
    mape_pct: float
    quantity: str
    selection: list[dict]
    criterion: str | None
    requested_terms: int | str
    logs: list[LogFit]
    seconds: float
    uncertainty_method: str = UNCERTAINTY_METHOD
    warnings: list[str] = dataclasses.field(default_factory=list)
    weighting: str = "absolute"

    @property
    def m(self) -> int:
        return int(self.E.size)

    def modulus(self, t) -> np.ndarray:
        """E(t) in MPa for (N,) times t (s)."""
        t = np.asarray(t, float)
        return self.E_inf + np.exp(-t[:, None] / self.tau[None, :]) @ self.E


def _criterion(name: str, n: int, weights: np.ndarray | None = None):
    """Information criterion (lower is better) of a refined model with 2m+1 constants; with ``weights`` on the
    weighted residuals (1/y: relative residuals)."""
    def score(sol: varpro.VPSolution) -> float:
        p = 2 * sol.m + 1
        sse = sol.sse if weights is None else float(np.sum((sol.residual * weights) ** 2))
        fit = n * math.log(max(sse, 1e-300) / n)
        if name == "aicc":
            return fit + 2 * p + (2 * p * (p + 1) / (n - p - 1) if n - p - 1 > 0 else math.inf)
        return fit + p * math.log(n)
    return score


def _label(lg: RelaxLog) -> str:
    return lg.path.name if lg.path is not None else lg.name


def _check_kinds(logs: Sequence[RelaxLog]) -> None:
    """Refuse a modulus curve fitted together with test logs.

    A modulus curve is usually a master curve (reduced time, its own reference temperature and specimen) and
    has no strain history; pooling it with the holds of ramp tests mixes two experiments into one series.
    Stress/strain and load/extension logs are the same kind (both become stress and strain).
    """
    curves = [lg for lg in logs if lg.is_modulus_curve]
    tests = [lg for lg in logs if not lg.is_modulus_curve]
    if curves and tests:
        from bpmid.io.relax_logs import SOURCE_WORDS

        a, b = tests[0], curves[0]
        raise InputError(f"logs of different kinds: {_label(a)} is {SOURCE_WORDS.get(a.source, a.source)}, "
                         f"{_label(b)} {SOURCE_WORDS['modulus']}; fit them separately", path=b.path)


def _check_samples(lg: RelaxLog, n: int, where: str = "") -> None:
    if n < MIN_SAMPLES:
        raise InputError(f"{n} samples{where} are too few to fit a Prony series (need at least {MIN_SAMPLES}: "
                         "one term and E_inf are 3 constants)", path=lg.path)


def _span_warnings(tau: np.ndarray, lo: float, hi: float, what: str) -> list[str]:
    """Time constants the data cannot resolve: faster than the first resolved time or slower than the span.

    Such a term's modulus is not identified on its own (a fast one has decayed before the data see it, a slow one
    is indistinguishable from E_inf); the sum of the moduli on that side is what the data determine.
    """
    out = []
    for j, t in enumerate(tau):
        if t < lo:
            out.append(f"tau_{j + 1} = {t:.4g} s is shorter than {what} ({lo:.4g} s): outside the data's time span, "
                       f"so the term has mostly relaxed before the data see it and E_{j + 1} is an extrapolation")
        elif t > hi:
            out.append(f"tau_{j + 1} = {t:.4g} s is longer than the data's time span ({hi:.4g} s): E_{j + 1} and E_inf "
                       "are not separated by these data (their sum is)")
    return out


def _choose_mode(logs: Sequence[RelaxLog], mode: str | None) -> str:
    curves = [lg for lg in logs if lg.is_modulus_curve]
    if mode is None:
        return "step" if curves else "ramp"
    if mode == "ramp" and curves:
        lg = curves[0]
        raise InputError("a relaxation-modulus curve has no strain history, so it cannot be fitted in ramp mode; "
                         "use --mode step", path=lg.path, key="mode")
    if mode not in ("ramp", "step"):
        raise InputError(f"mode must be ramp or step, found {mode!r}", key="mode")
    return mode


def _error_pct(quantity: str, y: np.ndarray):
    """The error measure of ``--max-error`` (%): RMS relative error of a modulus curve; for stress (which starts at
    zero) the RMS error relative to the RMS stress."""
    if quantity == "modulus":
        yy = np.where(np.abs(y) > 0, y, np.nan)
        return lambda sol: float(100 * np.sqrt(np.nanmean((sol.residual / yy) ** 2)))
    scale = float(np.sqrt(np.mean(y ** 2))) or 1.0
    return lambda sol: float(100 * np.sqrt(np.mean(sol.residual ** 2)) / scale)


def fit_relaxation(logs: Sequence[RelaxLog], *, terms: int | str = "auto", mode: str | None = None,
                   config=None, max_error_pct: float | None = None) -> RelaxFit:
    """Fit one Prony series to all logs jointly.

    Parameters
    ----------
    logs : relaxation logs (:func:`bpmid.io.relax_logs.read_relax_logs`)
    terms : number of Prony terms, or ``"auto"`` (information criterion over 1..config.max_terms)
    mode : ``"ramp"``, ``"step"`` or None (ramp unless a log is a modulus curve)
    config : :class:`bpmid.relax.RelaxConfig` (grid, criterion, hold window); None for defaults
    max_error_pct : if given, the fewest terms (up to ``config.max_terms``) whose error (:func:`_error_pct`) is at most
        this (%), instead of ``terms``

    Returns
    -------
    RelaxFit
    """
    from bpmid.relax import RelaxConfig

    cfg = config or RelaxConfig()
    if not logs:
        raise InputError("no relaxation logs given")
    _check_kinds(logs)
    mode = _choose_mode(logs, mode)
    if terms != "auto":
        if isinstance(terms, bool) or not isinstance(terms, (int, np.integer)) or not 1 <= int(terms) <= 200:
            raise InputError(f"terms must be a whole number from 1 to 200 or auto, found {terms!r}", key="terms")
        terms = int(terms)
    t0 = time.perf_counter()
    if mode == "step":
        holds = [hold_curve(lg, cfg.hold_window_s) for lg in logs]
    else:  # ramp mode needs no hold; the hold curve is only drawn (a log without one draws nothing)
        holds = []
        for lg in logs:
            try:
                holds.append(hold_curve(lg))
            except InputError:
                holds.append(HoldCurve(np.zeros(0), np.zeros(0), math.nan, math.nan, 0))
    for lg, h in zip(logs, holds):
        if mode == "ramp":
            _check_samples(lg, lg.n)
        elif lg.is_modulus_curve:
            _check_samples(lg, h.t.size)
        else:
            _check_samples(lg, h.t.size, " in the hold" + ("" if cfg.hold_window_s is None else
                                                          f" (its first relax.hold_window_s = {cfg.hold_window_s:g} s)"))
    if mode == "ramp":
        times = [lg.time_s for lg in logs]
        basis = RampBasis(times, [lg.strain for lg in logs])
        y = np.concatenate([lg.stress_mpa for lg in logs])
        dts = [float(np.min(np.diff(t))) for t in times]
        lo, hi = min(dts), max(float(t[-1] - t[0]) for t in times)
        span_lo_what = "the shortest sampling step"
        quantity = "stress"
        seg_t = times
    else:
        seg_t = [h.t for h in holds]
        tt = np.concatenate(seg_t)
        basis = StepBasis(tt)
        y = np.concatenate([h.modulus_mpa for h in holds])
        pos = tt[tt > 0]
        if pos.size == 0:
            raise InputError("step mode needs samples after the step (t > 0)", path=logs[0].path)
        lo, hi = float(pos.min()), float(tt.max())
        span_lo_what = "the first time after the step"
        quantity = "modulus"
    segments = [t.size for t in seg_t]
    n = y.size
    # the criterion's residuals: relative for a modulus curve spanning more than a decade, else absolute
    relative = (quantity == "modulus" and float(np.min(y)) > 0
                and float(np.max(y)) > RELATIVE_SPAN * float(np.min(y)))
    bounds = (math.log(lo / cfg.tau_span_factor), math.log(hi * cfg.tau_span_factor))
    if max_error_pct is not None and not (np.isfinite(max_error_pct) and max_error_pct > 0):
        raise InputError(f"--max-error must be a positive percentage, found {max_error_pct!r}", key="--max-error")
    crit = None if terms != "auto" or max_error_pct is not None else cfg.criterion
    m_min, m_max = (1, cfg.max_terms) if terms == "auto" or max_error_pct is not None else (terms, terms)
    if n < 2 * m_max + 3:
        m_max = max((n - 3) // 2, 1)
        if terms != "auto" and max_error_pct is None and terms > m_max:
            raise InputError(f"{terms} terms need at least {2 * terms + 3} samples, the logs have {n}", key="terms")
        m_min = min(m_min, m_max)
    score = _criterion(crit, n, 1.0 / y if relative else None) if crit else None
    note(f"fitting {n} samples of {len(logs)} log(s) in {mode} mode, terms {terms}")
    with single_thread_blas():
        path = varpro.model_path(basis, y, bounds, per_decade=cfg.grid_per_decade, m_min=m_min, m_max=m_max,
                                 score=score, patience=cfg.patience)
        if not path:
            names = ", ".join(_label(lg) for lg in logs)
            if terms == "auto":
                cut = [_label(lg) for lg, h in zip(logs, holds) if mode == "ramp" and h.t.size and h.start == 0]
                why = (f": {', '.join(cut)} start(s) at the hold, with no loading ramp in the log, which ramp mode "
                       f"models; fit them with --mode step (the hold's modulus curve)" if cut else
                       f": the {quantity} does not relax in them")
                raise InputError(f"{names}: no relaxing term fits these data (the fitted moduli of every decaying "
                                 f"term are zero){why}", key="mode" if cut else None)
            raise InputError(f"{names}: no Prony series with {terms} live term(s) fits these data (NNLS sets the "
                             "extra moduli to zero); ask for fewer terms", key="terms")
        err_of = _error_pct(quantity, y)
        extra_warn = []
        if max_error_pct is not None:
            errs = {m: err_of(path[m]) for m in path}
            ok = [m for m in sorted(path) if errs[m] <= max_error_pct]
            chosen = ok[0] if ok else fewest_near_best(errs)
            if not ok:
                extra_warn.append(f"none of the candidates tried ({tried_terms(path, m_max)}) meets --max-error "
                                  f"{max_error_pct:g} %: the smallest error, {errs[chosen]:.3g} %, is reached with "
                                  f"{chosen} term(s) ({unmet_advice(path, m_max)})")
        elif score:
            chosen = min(path, key=lambda m: score(path[m]))
            extra_warn += at_the_cap(chosen, m_max, cfg.max_terms, crit, f"{n} samples")
        else:
            chosen = terms if terms in path else max(path)
        sol = path[chosen]
        A, dA = basis.columns(sol.theta, True)
        nf = basis.n_fixed
        c = sol.coef
        J = np.hstack([A, dA * c[nf:]])          # model derivative in (E_inf, E_1..E_m, log tau_1..log tau_m)
        r = sol.residual
        n_eff = effective_sample_size(r, segments)
        cov = covariance_from_jacobian(J, r, n_eff)
        cov, between = with_between_tests(cov, J, r, segments)   # the spread from test to test counts too
    tau = np.exp(sol.theta)
    m = tau.size
    scale = np.concatenate([np.ones(1 + m), tau])   # log tau -> tau
    cov = cov * np.outer(scale, scale)
    # reorder to E_inf, E_1, tau_1, E_2, tau_2, ...
    order = [0] + [i for j in range(m) for i in (1 + j, 1 + m + j)]
    cov = cov[np.ix_(order, order)]
    names = ["E_inf"] + [f"{k}_{j + 1}" for j in range(m) for k in ("E", "tau")]
    se = np.sqrt(np.abs(np.diag(cov)))
    se[~np.isfinite(se)] = np.nan
    y_fit = y - r
    floor = MAPE_FLOOR_SHARE * float(np.max(np.abs(y))) if quantity == "stress" else 0.0
    per_log, start = [], 0
    for lg, h, k in zip(logs, holds, segments):
        sl = slice(start, start + k)
        t_fit = lg.time_s if mode == "ramp" else h.t
        per_log.append(LogFit(lg.name, lg.source, t_fit, y[sl], y_fit[sl], quantity, h))
        start += k
    selection = [{"terms": int(k), "rmse_mpa": math.sqrt(s.sse / n), "criterion": (score(s) if score else None),
                  "error_pct": err_of(s)} for k, s in sorted(path.items())]
    warn = extra_warn + _span_warnings(tau, lo, hi, span_lo_what)
    return RelaxFit(
        mode=mode, E_inf=float(c[0]), E=c[nf:].astype(float), tau=tau, se_E_inf=float(se[0]),
        se_E=se[1::2].copy(), se_tau=se[2::2].copy(), param_names=names, corr=correlation(cov),
        n_obs=int(n), n_eff=float(n_eff), rmse_mpa=metrics.rmse(y, y_fit), r2=metrics.r2(y, y_fit),
        mape_pct=metrics.mape_pct(y, y_fit, floor=floor), quantity=quantity, selection=selection,
        criterion=({"bic": "BIC", "aicc": "AICc"}.get(crit) if crit else
                   ("max-error" if max_error_pct is not None else None)),
        requested_terms=terms if max_error_pct is None else "max-error",
        logs=per_log, seconds=time.perf_counter() - t0, warnings=warn,
        weighting="relative" if relative else "absolute",
        uncertainty_method=BETWEEN_TESTS_METHOD if between else UNCERTAINTY_METHOD)


def at_the_cap(chosen: int, m_max: int, max_terms: int, crit: str, data: str) -> list[str]:
    """A warning when the information criterion chose the most terms it was allowed to try: it may have wanted more,
    and the cap, not the data, set the count (``data``: what limits the terms, in words)."""
    if chosen < m_max:
        return []
    name = {"bic": "BIC", "aicc": "AICc"}.get(crit, str(crit))
    if m_max >= max_terms:
        return [f"{name} chose {chosen} term(s), the most relax.max_terms = {max_terms} lets it try: more terms may fit "
                f"better, so the cap, not the data, set the count; raise relax.max_terms in a --config to let it look "
                f"further"]
    return [f"{name} chose {chosen} term(s), the most the {data} allow (a series of m terms needs 2 m + 3 values): "
            f"more data (a wider or denser range) would let it look further"]


def fewest_near_best(errors: dict) -> int:
    """The fewest terms whose error (%) is within 0.1 % (relative) of the smallest: more terms that do not lower
    the error are not chosen."""
    best = min(errors.values())
    return min(m for m, e in errors.items() if e <= best * (1.0 + 1e-3))


def unmet_advice(path: dict, m_max: int) -> str:
    """What to do when no candidate meets the stated error."""
    return ("state a larger error: more terms added nothing here" if max(path) < m_max
            else "raise relax.max_terms or state a larger error")


def tried_terms(path: dict, m_max: int) -> str:
    """The term counts a model path tried, in words (it stops early when another term adds nothing)."""
    lo, hi = min(path), max(path)
    span = f"{lo} term" if lo == hi else f"{lo}-{hi} terms"
    return span + ("" if hi >= m_max else f"; the path stopped there, another term adding nothing, before "
                                          f"relax.max_terms = {m_max}")
