"""Prony series from frequency-domain data: storage and loss modulus fitted jointly.

A Prony series E(t) = E_inf + sum_j E_j exp(-t/tau_j) has the complex modulus

    E'(w)  = E_inf + sum_j E_j (w tau_j)^2 / (1 + (w tau_j)^2)
    E''(w) =         sum_j E_j (w tau_j)   / (1 + (w tau_j)^2),      w = 2 pi f.

Both are linear in (E_inf, E_j) for fixed tau_j, so the time-domain machinery applies unchanged: moduli by
NNLS (>= 0), log time constants by variable projection (:mod:`bpmid.relax.varpro`), the number of terms by an
information criterion or as the fewest that meet a stated error.

Residuals are relative (a master curve spans decades of modulus; absolute residuals would fit only the glassy
plateau). Two weightings (``relax.freq_weighting``):

- ``complex`` (default): the relative residual of the complex modulus, (E*_fit - E*)/|E*|, i.e. the storage and
  the loss residual both divided by |E*| = sqrt(E'^2 + E''^2). To first order this is the complex log residual
  log(E*_fit/E*) = (relative error of |E*|) + i (error of the phase angle delta), the two quantities a DMA
  instrument measures. Where tan(delta) is small the loss modulus is a small, phase-limited part of E* and weighs
  accordingly; measured master curves whose E'' is not Kramers-Kronig consistent with E' (a flat tan(delta) over a
  flat E') then do not pull the storage modulus off.
- ``component``: each modulus relative to itself, (E'_fit - E')/E' and (E''_fit - E'')/E''. Equal weight to the
  loss modulus even where it is a hundredth of E'.
"""
from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from bpmid.errors import InputError
from bpmid.fitting import UNCERTAINTY_METHOD, correlation, covariance_from_jacobian, effective_sample_size
from bpmid.progress import note
from bpmid.relax import varpro
from bpmid.relax.fit import _criterion  # one information criterion for time- and frequency-domain fits
from bpmid.relax._blas import single_thread_blas

#: fewest frequencies a curve must have (one term and E_inf are 3 constants; 2N equations)
MIN_FREQUENCIES = 3


class FreqBasis:
    """Columns of the weighted problem [w_s E' ; w_l E''] = A c, c = (E_inf, E_1, ..., E_m) (data: ``self.y``).

    Parameters
    ----------
    f : (N,) frequency (Hz)
    storage, loss : (N,) measured storage and loss modulus (> 0)
    weighting : ``"complex"`` (w_s = w_l = 1/|E*|) or ``"component"`` (w_s = 1/E', w_l = 1/E'')
    """

    n_fixed = 1

    def __init__(self, f: np.ndarray, storage: np.ndarray, loss: np.ndarray, weighting: str = "complex"):
        self.omega = 2.0 * np.pi * np.asarray(f, float)
        storage, loss = np.asarray(storage, float), np.asarray(loss, float)
        if weighting == "complex":
            self.ws = self.wl = 1.0 / np.hypot(storage, loss)
        elif weighting == "component":
            self.ws, self.wl = 1.0 / storage, 1.0 / loss
        else:
            raise InputError(f"weighting must be complex or component, found {weighting!r}",
                             key="relax.freq_weighting")
        self.y = np.concatenate([storage * self.ws, loss * self.wl])
        n = self.omega.size
        self.fixed = np.concatenate([self.ws, np.zeros(n)])[:, None]

    def columns(self, theta: np.ndarray, derivative: bool = True):
        """Returns A (2N, 1+m) and dA/dlog(tau) (2N, m) (or None)."""
        x = self.omega[:, None] * np.exp(np.asarray(theta, float))[None, :]
        d = 1.0 / (1.0 + x * x)
        s = x * x * d
        l = x * d
        A = np.hstack([self.fixed, np.vstack([s * self.ws[:, None], l * self.wl[:, None]])])
        if not derivative:
            return A, None
        ds = 2.0 * s * d             # d s / d log tau = 2 x^2 / (1 + x^2)^2
        dl = l * (1.0 - x * x) * d   # d l / d log tau = x (1 - x^2) / (1 + x^2)^2
        return A, np.vstack([ds * self.ws[:, None], dl * self.wl[:, None]])


def complex_modulus(f, E_inf: float, E, tau) -> tuple[np.ndarray, np.ndarray]:
    """E'(f) and E''(f) (units of the moduli) of a Prony series for (N,) frequencies f (Hz)."""
    x = 2.0 * np.pi * np.asarray(f, float)[:, None] * np.asarray(tau, float)[None, :]
    d = 1.0 / (1.0 + x * x)
    E = np.asarray(E, float)
    return E_inf + (x * x * d) @ E, (x * d) @ E


def rms_rel_pct(y, y_fit) -> float:
    """RMS of the relative error (%), (y_fit - y) / y."""
    y = np.asarray(y, float)
    return float(100.0 * np.sqrt(np.mean(((np.asarray(y_fit, float) - y) / y) ** 2)))


@dataclasses.dataclass
class FreqFit:
    """A Prony series fitted to storage and loss modulus (MPa, s).

    Attributes
    ----------
    modulus : ``"E"`` or ``"G"``: which modulus the data (and these constants) are
    E_inf, E, tau : constants (MPa, MPa, s), tau ascending
    se_E_inf, se_E, se_tau : standard errors (nan where not determined)
    param_names, corr : names (E_inf, E_1, tau_1, ...) and correlation matrix
    f, storage, loss : the fitted data (Hz, MPa, MPa; a master curve at the reference temperature for raw sets)
    storage_fit, loss_fit : the model at f
    rms_rel_storage_pct, rms_rel_loss_pct : RMS relative error of each modulus (%), each relative to itself
    error_pct : the fitted error measure (%): for the complex weighting the RMS of |E*_fit - E*| / |E*|
    selection : one entry per candidate number of terms (terms, error_pct, rms_rel_storage_pct, rms_rel_loss_pct,
        criterion)
    criterion : ``"BIC"``/``"AICc"`` for auto, ``"max-error"`` for --max-error, else None
    requested_terms : ``"auto"`` or the number asked for
    max_error_pct : the stated error for the term minimisation, or None
    n_obs, n_eff : equations fitted (2 per frequency) and effective sample size
    seconds : wall time (s)
    warnings : things a reader must know
    """

    modulus: str
    E_inf: float
    E: np.ndarray
    tau: np.ndarray
    se_E_inf: float
    se_E: np.ndarray
    se_tau: np.ndarray
    param_names: list
    corr: np.ndarray
    f: np.ndarray
    storage: np.ndarray
    loss: np.ndarray
    storage_fit: np.ndarray
    loss_fit: np.ndarray
    rms_rel_storage_pct: float
    rms_rel_loss_pct: float
    error_pct: float
    selection: list
    criterion: str | None
    requested_terms: int | str
    max_error_pct: float | None
    n_obs: int
    n_eff: float
    seconds: float
    uncertainty_method: str = UNCERTAINTY_METHOD
    warnings: list = dataclasses.field(default_factory=list)
    mode: str = "frequency"
    weighting: str = "complex"

    @property
    def m(self) -> int:
        return int(self.E.size)

    @property
    def E0(self) -> float:
        """Instantaneous modulus E_inf + sum E_j (MPa)."""
        return float(self.E_inf + self.E.sum())

    def modulus_t(self, t) -> np.ndarray:
        """E(t) (MPa) for (N,) times t (s)."""
        t = np.asarray(t, float)
        return self.E_inf + np.exp(-t[:, None] / self.tau[None, :]) @ self.E

    def complex(self, f) -> tuple[np.ndarray, np.ndarray]:
        return complex_modulus(f, self.E_inf, self.E, self.tau)


def _rel_errors(basis: FreqBasis, sol: varpro.VPSolution) -> tuple[float, float]:
    """RMS relative error (%) of E' and of E'' (each relative to itself, whatever the weighting)."""
    n = basis.omega.size
    r = sol.residual
    return (float(100 * np.sqrt(np.mean((r[:n] / (basis.y[:n])) ** 2))),
            float(100 * np.sqrt(np.mean((r[n:] / (basis.y[n:])) ** 2))))


def _fit_error(basis: FreqBasis, sol: varpro.VPSolution) -> float:
    """The fitted error measure (%): RMS over frequencies of the weighted residual's length, per frequency
    sqrt(r_s^2 + r_l^2) -- for the ``complex`` weighting |E*_fit - E*| / |E*|."""
    n = basis.omega.size
    return float(100 * np.sqrt(np.sum(sol.residual ** 2) / n))


def check_curve(f, storage, loss, where=None) -> None:
    """Refuse non-positive or non-finite frequencies or moduli and repeated frequencies (messages name ``where``)."""
    for name, v in (("frequency", f), ("storage modulus", storage), ("loss modulus", loss)):
        v = np.asarray(v, float)
        bad = np.flatnonzero(~(np.isfinite(v) & (v > 0)))
        if bad.size:
            raise InputError(f"{name} must be positive and finite, found {v[bad[0]]:g} at sample {bad[0] + 1}",
                             path=where)


def fit_frequency(f, storage, loss, *, modulus: str = "E", terms: int | str = "auto",
                  max_error_pct: float | None = None, config=None, path=None) -> FreqFit:
    """Fit one Prony series to storage and loss modulus jointly.

    Parameters
    ----------
    f : (N,) frequency (Hz), > 0; storage, loss : (N,) moduli (MPa), > 0
    modulus : ``"E"`` or ``"G"`` (labels only)
    terms : number of terms, or ``"auto"`` (``config.criterion`` over 1..``config.max_terms``)
    max_error_pct : if given, the fewest terms (up to ``config.max_terms``) whose fitted error (:func:`_fit_error`:
        the RMS relative error of the complex modulus, %) is at most this -- pyvisco's term minimisation with a
        stated error; overrides ``terms``
    config : :class:`bpmid.relax.RelaxConfig` (grid density, span factor, criterion, patience, max_terms)
    path : the data file (messages)
    """
    from bpmid.relax import RelaxConfig

    cfg = config or RelaxConfig()
    f = np.asarray(f, float)
    storage = np.asarray(storage, float)
    loss = np.asarray(loss, float)
    check_curve(f, storage, loss, path)
    order = np.argsort(f, kind="stable")
    f, storage, loss = f[order], storage[order], loss[order]
    n = f.size
    if n < MIN_FREQUENCIES:
        raise InputError(f"{n} frequencies are too few to fit a Prony series (need at least {MIN_FREQUENCIES})",
                         path=path)
    if max_error_pct is not None and not (np.isfinite(max_error_pct) and max_error_pct > 0):
        raise InputError(f"--max-error must be a positive percentage, found {max_error_pct!r}", key="--max-error")
    if terms != "auto":
        if isinstance(terms, bool) or not isinstance(terms, (int, np.integer)) or not 1 <= int(terms) <= 200:
            raise InputError(f"terms must be a whole number from 1 to 200 or auto, found {terms!r}", key="terms")
        terms = int(terms)
    t0 = time.perf_counter()
    weighting = getattr(cfg, "freq_weighting", "complex")
    basis = FreqBasis(f, storage, loss, weighting)
    y = basis.y
    tau_lo, tau_hi = 1.0 / (2 * np.pi * f.max()), 1.0 / (2 * np.pi * f.min())
    bounds = (math.log(tau_lo / cfg.tau_span_factor), math.log(tau_hi * cfg.tau_span_factor))
    N = 2 * n
    m_cap = max((N - 3) // 2, 1)
    if max_error_pct is not None:
        m_min, m_max, score, crit = 1, min(cfg.max_terms, m_cap), None, "max-error"
    elif terms == "auto":
        m_min, m_max, score, crit = 1, min(cfg.max_terms, m_cap), _criterion(cfg.criterion, N), cfg.criterion
    else:
        if terms > m_cap:
            raise InputError(f"{terms} terms need at least {(2 * terms + 3 + 1) // 2} frequencies, the data have {n}",
                             key="terms")
        m_min = m_max = terms
        score, crit = None, None
    note(f"fitting storage and loss modulus at {n} frequencies, terms "
         f"{'max-error ' + format(max_error_pct, 'g') + ' %' if max_error_pct is not None else terms}")
    with single_thread_blas():
        path_sols = varpro.model_path(basis, y, bounds, per_decade=cfg.grid_per_decade, m_min=m_min, m_max=m_max,
                                      score=score, patience=cfg.patience)
        if not path_sols:
            raise InputError("no relaxing term fits these data (every fitted modulus is zero)", path=path)
        errs = {m: _rel_errors(basis, s) for m, s in path_sols.items()}
        total = {m: _fit_error(basis, s) for m, s in path_sols.items()}
        warn = []
        if max_error_pct is not None:
            ok = [m for m in sorted(path_sols) if total[m] <= max_error_pct]
            if ok:
                chosen = ok[0]
            else:
                from bpmid.relax.fit import fewest_near_best, tried_terms, unmet_advice

                chosen = fewest_near_best(total)
                warn.append(f"none of the candidates tried ({tried_terms(path_sols, m_max)}) meets --max-error "
                            f"{max_error_pct:g} %: the smallest error, {total[chosen]:.3g} %, is reached with "
                            f"{chosen} term(s) ({unmet_advice(path_sols, m_max)})")
        elif score is not None:
            from bpmid.relax.fit import at_the_cap

            chosen = min(path_sols, key=lambda m: score(path_sols[m]))
            warn += at_the_cap(chosen, m_max, cfg.max_terms, crit, f"{N} values ({n} frequencies, storage and loss)")
        else:
            chosen = terms if terms in path_sols else max(path_sols)
        sol = path_sols[chosen]
        A, dA = basis.columns(sol.theta, True)
        c = sol.coef
        J = np.hstack([A, dA * c[1:]])
        r = sol.residual
        n_eff = effective_sample_size(r, [n, n])
        cov = covariance_from_jacobian(J, r, n_eff)
    tau = np.exp(sol.theta)
    m = tau.size
    scale = np.concatenate([np.ones(1 + m), tau])
    cov = cov * np.outer(scale, scale)
    order = [0] + [i for j in range(m) for i in (1 + j, 1 + m + j)]
    cov = cov[np.ix_(order, order)]
    se = np.sqrt(np.abs(np.diag(cov)))
    se[~np.isfinite(se)] = np.nan
    names = ["E_inf"] + [f"{k}_{j + 1}" for j in range(m) for k in ("E", "tau")]
    s_fit, l_fit = complex_modulus(f, c[0], c[1:], tau)
    for j, t in enumerate(tau):
        if t < tau_lo:
            warn.append(f"tau_{j + 1} = {t:.4g} s is shorter than 1/(2 pi f_max) = {tau_lo:.4g} s: outside the data's "
                        "frequency window, E_{j} is an extrapolation".replace("{j}", str(j + 1)))
        elif t > tau_hi:
            warn.append(f"tau_{j + 1} = {t:.4g} s is longer than 1/(2 pi f_min) = {tau_hi:.4g} s: E_{j + 1} and E_inf "
                        "are not separated by these data (their sum is)")
    sc = _criterion(cfg.criterion, N)
    selection = [{"terms": int(k), "error_pct": total[k], "rms_rel_storage_pct": errs[k][0],
                  "rms_rel_loss_pct": errs[k][1],
                  "criterion": float(sc(s)) if crit not in (None, "max-error") else None}
                 for k, s in sorted(path_sols.items())]
    return FreqFit(
        modulus=modulus, E_inf=float(c[0]), E=c[1:].astype(float), tau=tau, se_E_inf=float(se[0]),
        se_E=se[1::2].copy(), se_tau=se[2::2].copy(), param_names=names, corr=correlation(cov), f=f, storage=storage,
        loss=loss, storage_fit=s_fit, loss_fit=l_fit, rms_rel_storage_pct=rms_rel_pct(storage, s_fit),
        rms_rel_loss_pct=rms_rel_pct(loss, l_fit), error_pct=total[chosen], selection=selection,
        criterion={"bic": "BIC", "aicc": "AICc"}.get(crit, crit) if crit else None,
        requested_terms=terms if max_error_pct is None else "max-error", max_error_pct=max_error_pct, n_obs=N,
        n_eff=float(n_eff), seconds=time.perf_counter() - t0, warnings=warn, weighting=weighting)
