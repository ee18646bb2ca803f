"""Time-temperature superposition: shift factors from raw isothermal sets, WLF and polynomial shift functions.

Raw sets (one frequency sweep, or one relaxation curve, per temperature) are shifted along log frequency (log time)
onto the set at the reference temperature. A set at temperature T moves by log10(a_T): frequencies become
f a_T, times t / a_T (a_T > 1 below the reference temperature, where the material is slower).

Shift factors from the data (overlap-based): neighbouring sets are shifted pairwise, walking outward from the
reference set, each onto its already shifted inner neighbour (:func:`pair_shift`): samples that stray from their
own set's smooth curve (the first point of a sweep, taken before the temperature settled) are left out, and the
shift minimises the squared difference of log modulus where the two sets overlap, measured both ways. Sets that
share no modulus range are bridged by extrapolating their smooth curves. The storage modulus E' (or E(t)) is used:
it is monotone in frequency, where the loss modulus has peaks and, in the glassy region, instrument artefacts.

Shift functions fitted to the shift factors, each with standard errors:

- WLF: log10 a_T = -C1 (T - T_ref) / (C2 + T - T_ref)
- polynomial: log10 a_T = sum_k c_k (T - T_ref)^k, k = 0..degree (degree 4, or fewer for few temperatures)
"""
from __future__ import annotations

import dataclasses
import math
import warnings
from pathlib import Path
from typing import Sequence

import numpy as np
from scipy.optimize import least_squares, minimize_scalar

from bpmid.errors import InputError

#: modulus levels used per pair of sets
N_LEVELS = 10
#: level of the outlier test of :func:`inliers` (Bonferroni-corrected over the samples of a set)
OUTLIER_ALPHA = 0.01
#: every set keeps at least this many samples
MIN_INLIERS = 5
#: fewest overlapping samples (both ways together) a shift is judged on
MIN_OVERLAP = 3
#: a pair's shift is not determined when the scan's optimum is this many grid steps (of 400) or fewer from the edge of
#: the shifts that give an overlap
EDGE_STEPS = 2
#: ... or when its standard error exceeds this (decades)
MAX_SHIFT_SE = 0.2
#: ... or when a set is flat: its smooth curve's range over its samples below this many times its robust scatter
FLAT_SCATTER = 3.0
#: half-width (decades) of the central difference for the overlap cost's curvature
CURVATURE_STEP = 0.05
#: the WLF fit does not describe the shift factors when a constant's standard error exceeds the constant and the fit
#: misses them by more than this RMSE (decades); a WLF that runs to C2 at its bound along a straight line of shift
#: factors (Arrhenius-like over a short range) still describes them and is not warned about
WLF_MISFIT_RMSE = 0.1
#: fewest temperatures with shifts determined by the data (the WLF has 2 constants)
MIN_DETERMINED = 3
#: degree of the polynomial shift function (lowered to the number of temperatures - 2)
POLY_DEGREE = 4


@dataclasses.dataclass
class ShiftResult:
    """Shift factors and shift functions.

    Attributes
    ----------
    T_ref : reference temperature (deg C)
    T : (K,) set temperatures (deg C), in the order of the sets
    log_aT : (K,) decadic log of the shift factor of each set
    source : ``"data"`` (found from the raw sets) or ``"user"`` (given in a file)
    wlf : dict C1, C2, T_ref, se_C1, se_C2, rmse (decades), or None when the fit failed
    poly : dict degree, coefficients c0..cd (of T - T_ref, deg C), se, rmse (decades)
    pair_shifts : (K,) shift of each set relative to its inner neighbour (decades; 0 at the reference)
    from_function : (K,) True where the data do not determine the set's shift and the shift function gave it
    chained : (K,) True where the set is chained through determined links to such a set
    function : that shift function (``kind`` wlf or poly, its constants), fitted to the temperatures ``fitted_on``
    why : temperature (C) -> why the data do not determine its shift
    """

    T_ref: float
    T: np.ndarray
    log_aT: np.ndarray
    source: str
    wlf: dict | None
    poly: dict | None
    pair_shifts: np.ndarray | None = None
    from_function: np.ndarray | None = None
    chained: np.ndarray | None = None
    function: dict | None = None
    fitted_on: np.ndarray | None = None
    why: dict | None = None

    def wlf_log_aT(self, T) -> np.ndarray:
        T = np.asarray(T, float)
        if self.wlf is None:
            return np.full(T.shape, np.nan)
        return wlf(T, self.wlf["T_ref"], self.wlf["C1"], self.wlf["C2"])

    def poly_log_aT(self, T) -> np.ndarray:
        T = np.asarray(T, float)
        if self.poly is None:
            return np.full(T.shape, np.nan)
        return np.polynomial.polynomial.polyval(T - self.T_ref, self.poly["coefficients"])


def wlf(T, T_ref: float, C1: float, C2: float) -> np.ndarray:
    """log10 a_T of the WLF equation."""
    d = np.asarray(T, float) - T_ref
    return -C1 * d / (C2 + d)


def _quad(logx: np.ndarray, logy: np.ndarray) -> np.ndarray:
    """Robust quadratic (coefficients low to high) of log modulus in log x; a line for 4 points or fewer.

    Huber-weighted least squares (iteratively reweighted, scale from the median absolute residual), so that a sweep's
    first point, often taken before the temperature settled, does not bend the curve."""
    deg = 2 if logx.size > 4 else 1
    V = np.polynomial.polynomial.polyvander(logx, deg)
    w = np.ones(logx.size)
    coef = np.linalg.lstsq(V, logy, rcond=None)[0]
    for _ in range(20):
        r = logy - V @ coef
        scale = 1.4826 * np.median(np.abs(r)) + 1e-12
        u = np.abs(r) / (1.345 * scale)
        w_new = np.where(u <= 1.0, 1.0, 1.0 / np.maximum(u, 1e-300))
        sw = np.sqrt(w_new)
        new = np.linalg.lstsq(V * sw[:, None], logy * sw, rcond=None)[0]
        if np.allclose(new, coef, rtol=0, atol=1e-12) and np.allclose(w_new, w):
            break
        coef, w = new, w_new
    return coef


def _invert(coef: np.ndarray, lo: float, hi: float, levels: np.ndarray) -> np.ndarray | None:
    """log x at which the polynomial reaches each level, searched on [lo, hi] extended by the range itself on each side;
    None where the polynomial is not monotone there or misses a level."""
    span = hi - lo
    grid = np.linspace(lo - span, hi + span, 801)
    val = np.polynomial.polynomial.polyval(grid, coef)
    d = np.diff(val)
    if not (np.all(d > 0) or np.all(d < 0)):
        # keep the monotone branch that holds the data range
        mid = np.polynomial.polynomial.polyval(0.5 * (lo + hi), np.polynomial.polynomial.polyder(coef))
        sign = 1.0 if mid > 0 else -1.0
        ok = np.flatnonzero(sign * d > 0)
        inside = np.flatnonzero((grid[:-1] >= lo) & (grid[:-1] <= hi))
        if not np.all(np.isin(inside, ok)):
            return None
        # extend from the data range while monotone
        a = inside[0]
        while a > 0 and sign * d[a - 1] > 0:
            a -= 1
        b = inside[-1]
        while b < d.size - 1 and sign * d[b + 1] > 0:
            b += 1
        grid, val = grid[a:b + 2], val[a:b + 2]
    if val[0] > val[-1]:
        grid, val = grid[::-1], val[::-1]
    if levels.min() < val[0] or levels.max() > val[-1]:
        return None
    return np.interp(levels, val, grid)


def inliers(logx: np.ndarray, logy: np.ndarray, alpha: float = OUTLIER_ALPHA) -> np.ndarray:
    """Mask of the samples of one set that agree with the set's own smooth curve; the first point of a sweep taken
    before the temperature settled is the usual outlier.

    Outlier test by externally studentized residuals: each sample is compared with the least-squares quadratic (a line
    for 6 samples or fewer) of the others, in units of the others' own residual scatter and the prediction's
    leverage, t_j = r_j / (s_(j) sqrt(1 + h_j)); the sample with the largest |t_j| is dropped when it exceeds the
    Bonferroni-corrected two-sided Student-t quantile at level ``alpha``, and the test repeats. A point cannot hide
    by bending the curve towards itself, nor inflate the scale it is judged by. At least ``MIN_INLIERS`` samples are
    kept.
    """
    from scipy.stats import t as student_t

    keep = np.ones(logx.size, bool)
    while keep.sum() > MIN_INLIERS:
        idx = np.flatnonzero(keep)
        n = idx.size
        deg = 2 if n - 1 > 6 else 1
        dof = n - 1 - (deg + 1)
        if dof < 2:
            break
        tj = np.zeros(n)
        for j, i in enumerate(idx):
            others = np.delete(idx, j)
            V = np.polynomial.polynomial.polyvander(logx[others], deg)
            c, *_ = np.linalg.lstsq(V, logy[others], rcond=None)
            res = logy[others] - V @ c
            s2 = float(res @ res) / dof
            v = np.polynomial.polynomial.polyvander(np.array([logx[i]]), deg)[0]
            h = float(v @ np.linalg.pinv(V.T @ V) @ v)
            r = logy[i] - float(v @ c)
            tj[j] = abs(r) / math.sqrt(max(s2 * (1.0 + h), 1e-300))
        j = int(np.argmax(tj))
        if tj[j] <= student_t.ppf(1.0 - alpha / (2.0 * n), dof):
            break
        keep[idx[j]] = False
    return keep


def _bridge_shift(logx_ref, logy_ref, logx, logy) -> float:
    """Shift across a gap (no common modulus range): the two robust quadratics are extended and the mean log-x
    distance at modulus levels between the nearest ends is taken."""
    cr, cs = _quad(logx_ref, logy_ref), _quad(logx, logy)
    fr = np.polynomial.polynomial.polyval(logx_ref, cr)
    fs = np.polynomial.polynomial.polyval(logx, cs)
    lo, hi = max(fr.min(), fs.min()), min(fr.max(), fs.max())
    if lo >= hi:
        lo, hi = hi, lo
    levels = np.linspace(lo, hi, N_LEVELS)
    xr = _invert(cr, logx_ref.min(), logx_ref.max(), levels)
    xs = _invert(cs, logx.min(), logx.max(), levels)
    if xr is None or xs is None:
        return math.nan
    return float(np.mean(xr - xs))


@dataclasses.dataclass
class PairShift:
    """The shift of one set onto its neighbour and whether the data determine it.

    Attributes
    ----------
    d : shift (decades of x): logx + d overlays the reference set
    determined : False when the data do not fix d (see :func:`pair_shift_info`)
    why : the reason when not determined ('' else)
    se : standard error of d from the overlap cost's curvature and residual level (decades; nan when not found)
    method : ``"overlap"`` (scan of the overlap cost) or ``"bridge"`` (extrapolated smooth curves)
    """

    d: float
    determined: bool = True
    why: str = ""
    se: float = math.nan
    method: str = "overlap"


def flat_set(logx: np.ndarray, logy: np.ndarray) -> bool:
    """A set whose smooth curve (:func:`_quad`) changes over its samples by less than ``FLAT_SCATTER`` times its robust
    residual scatter: noise, not a slope, would set its shift."""
    if logx.size < 3:
        return True
    c, scatter = _curve(logx, logy)
    fit = np.polynomial.polynomial.polyval(logx, c)
    return float(fit.max() - fit.min()) < FLAT_SCATTER * scatter


def _curve(logx: np.ndarray, logy: np.ndarray) -> tuple[np.ndarray, float]:
    """A set's smooth curve (:func:`_quad` coefficients) and its robust residual scatter (decades)."""
    c = _quad(logx, logy)
    r = logy - np.polynomial.polynomial.polyval(logx, c)
    return c, 1.4826 * float(np.median(np.abs(r)))


def shift_se(xr, yr, xs, ys, d: float) -> float:
    """Standard error (decades) of the shift d that overlays the set (xs, ys) on (xr, yr): a horizontal shift is
    read through the curves' slope, so its error is the scatter of the two sets' log moduli, averaged over the
    samples that inform it, over that slope: sqrt(s_r^2 / n_r + s_s^2 / n_s) / |dlogE/dlogx|. The samples are those
    of each set within the other's shifted range (at least the 3 nearest to it, for a bridged pair) and the slope
    is the smooth curves' mean slope there. Honest where the curvature of an interpolated noisy overlap cost is not:
    a flat stretch (a glassy or rubbery plateau) gives a large error however small the cost's noise."""
    cr, s_r = _curve(xr, yr)
    cs, s_s = _curve(xs, ys)
    xx = xs + d

    def near(x, lo, hi):
        k = (x >= lo) & (x <= hi)
        if k.sum() >= 3:
            return k
        idx = np.argsort(np.minimum(np.abs(x - lo), np.abs(x - hi)))[:3]
        k = np.zeros(x.size, bool)
        k[idx] = True
        return k

    kr = near(xr, xx.min(), xx.max())
    ks = near(xx, xr.min(), xr.max())
    dr = np.polynomial.polynomial.polyval(xr[kr], np.polynomial.polynomial.polyder(cr))
    ds = np.polynomial.polynomial.polyval(xs[ks], np.polynomial.polynomial.polyder(cs))
    slope = abs(float(np.mean(np.concatenate([dr, ds]))))
    noise = math.sqrt(s_r ** 2 / max(int(kr.sum()), 1) + s_s ** 2 / max(int(ks.sum()), 1))
    return noise / slope if slope > 0 else math.inf


def pair_shift(logx_ref: np.ndarray, logy_ref: np.ndarray, logx: np.ndarray, logy: np.ndarray) -> float:
    """Shift d (decades of x) that moves the set (logx, logy) onto the reference set: logx + d overlays logx_ref
    (:func:`pair_shift_info` without the verdict)."""
    return pair_shift_info(logx_ref, logy_ref, logx, logy).d


def pair_shift_info(logx_ref: np.ndarray, logy_ref: np.ndarray, logx: np.ndarray, logy: np.ndarray) -> PairShift:
    """Shift d (decades of x) that moves the set (logx, logy) onto the reference set, and whether the data determine it.

    Each set's outliers are dropped (:func:`inliers`); d minimises the mean squared difference of log modulus over the
    overlap, measured both ways (the set interpolated at the reference's samples and the reference at the set's,
    linear in log-log): a global scan of every d that gives an overlap, then a bounded refinement. Sets whose moduli
    do not overlap at any shift are bridged by extrapolating their smooth curves (:func:`_bridge_shift`).

    Not determined (``determined`` False, ``why`` says which):

    - the sets share no modulus range and the bridge fails (the scan then only finds the least bad partial overlap);
    - the scan's optimum lies within ``EDGE_STEPS`` grid steps of the edge of the shifts that give an overlap;
    - the standard error of d, sqrt(cost_min / (n k)) for a cost ~ cost_min + k (d - d0)^2 over n overlapping samples,
      exceeds ``MAX_SHIFT_SE`` decades;
    - either set is flat (:func:`flat_set`).
    """
    o = np.argsort(logx_ref)
    xr, yr = logx_ref[o], logy_ref[o]
    o = np.argsort(logx)
    xs, ys = logx[o], logy[o]
    mr, ms = inliers(xr, yr), inliers(xs, ys)
    xr, yr, xs, ys = xr[mr], yr[mr], xs[ms], ys[ms]
    lo, hi = xr.min() - xs.max(), xr.max() - xs.min()
    flat = [w for w, (x_, y_) in (("the reference", (xr, yr)), ("the other", (xs, ys))) if flat_set(x_, y_)]
    flat_why = (f"{' and '.join(flat)} set {'is' if len(flat) == 1 else 'are'} flat (the modulus changes less than "
                f"{FLAT_SCATTER:g} times its scatter)") if flat else ""

    def overlap(d):
        xx = xs + d
        k1 = (xx >= xr[0]) & (xx <= xr[-1])
        k2 = (xr >= xx[0]) & (xr <= xx[-1])
        return xx, k1, k2, int(k1.sum() + k2.sum())

    def cost(d):
        xx, k1, k2, n = overlap(d)
        if n < MIN_OVERLAP:
            return math.inf
        r1 = np.interp(xx[k1], xr, yr) - ys[k1]
        r2 = np.interp(xr[k2], xx, ys) - yr[k2]
        return float((r1 @ r1 + r2 @ r2) / n)

    grid = np.linspace(lo, hi, 401)
    costs = np.array([cost(d) for d in grid])
    shared = _levels_overlap(yr, ys)
    if not np.isfinite(costs).any() or not shared:
        d = _bridge_shift(xr, yr, xs, ys)
        if math.isfinite(d):
            why = [flat_why] if flat_why else []
            se = shift_se(xr, yr, xs, ys, d)
            if not se <= MAX_SHIFT_SE:
                why.append(f"its standard error is {se:.2g} decades (the modulus barely changes where the two "
                           "sets' extrapolated curves meet)")
            return PairShift(d, not why, "; ".join(why), se, "bridge")
    if not np.isfinite(costs).any():
        raise InputError("two neighbouring sets cannot be overlaid (too few samples in common at any shift)")
    ib = int(np.nanargmin(costs))
    b = grid[ib]
    step = grid[1] - grid[0]
    with warnings.catch_warnings():   # a flat cost (noise-free data) makes Brent's parabola 0/0: harmless, it
        warnings.simplefilter("ignore", RuntimeWarning)   # falls back to golden-section steps
        res = minimize_scalar(cost, bounds=(b - step, b + step), method="bounded")
    d = float(res.x) if res.fun <= costs.min() else float(b)
    why = []
    if not shared:
        why.append("the two sets share no modulus range and their smooth curves cannot be extrapolated to meet")
    feas = np.flatnonzero(np.isfinite(costs))
    if ib - feas[0] <= EDGE_STEPS or feas[-1] - ib <= EDGE_STEPS:
        why.append("the best overlay lies at the edge of the shifts that give any overlap")
    c0 = cost(d)
    h = max(CURVATURE_STEP, 2 * step)
    cp, cm = cost(d + h), cost(d - h)
    se_cost = math.nan
    if math.isfinite(cp) and math.isfinite(cm):
        k = (cp + cm - 2.0 * c0) / (2.0 * h * h)
        n = overlap(d)[3]
        se_cost = math.sqrt(max(c0, 0.0) / (n * k)) if k > 0 else math.inf
    # the slope-based error (the scatter over the slope) is the honest one on noisy data; the cost's curvature
    # catches a cost that does not rise away from its optimum at all
    se = max(shift_se(xr, yr, xs, ys, d), se_cost if math.isfinite(se_cost) else 0.0) \
        if not (math.isinf(se_cost)) else math.inf
    if se > MAX_SHIFT_SE:
        why.append(f"its standard error is {se:.2g} decades (the modulus barely changes over the overlap)")
    if flat_why:
        why.append(flat_why)
    return PairShift(d, not why, "; ".join(why), se)


def _levels_overlap(yr: np.ndarray, ys: np.ndarray) -> bool:
    """The two sets share a range of modulus (else no shift can overlay them; their shift is an extrapolation)."""
    return max(yr.min(), ys.min()) < min(yr.max(), ys.max())


def overlap_rms(logx_a: np.ndarray, logy_a: np.ndarray, logx_b: np.ndarray, logy_b: np.ndarray) -> tuple[float, int]:
    """How well two (already shifted) sets superpose: RMS difference of log modulus (decades) where their log-x ranges
    overlap, measured both ways (each set interpolated linearly in log-log at the other's samples), and the number of
    samples it is taken over; (nan, 0) without overlap. The quality measure the shift factors of a master curve are
    judged by (every sample counts, outliers included)."""
    oa, ob = np.argsort(logx_a), np.argsort(logx_b)
    xa, ya, xb, yb = logx_a[oa], logy_a[oa], logx_b[ob], logy_b[ob]
    k1 = (xb >= xa[0]) & (xb <= xa[-1])
    k2 = (xa >= xb[0]) & (xa <= xb[-1])
    r = np.concatenate([np.interp(xb[k1], xa, ya) - yb[k1], np.interp(xa[k2], xb, yb) - ya[k2]])
    if r.size == 0:
        return math.nan, 0
    return float(np.sqrt(np.mean(r ** 2))), int(r.size)


@dataclasses.dataclass
class ShiftSearch:
    """Shift factors found from the data, and which of them the data do not determine.

    Attributes
    ----------
    log_aT, pair : (K,) as :func:`find_shift_factors` returns them
    info : (K,) :class:`PairShift` of each set onto its inner neighbour (None for the reference set)
    from_function : (K,) True where the set's shift is the shift function's value (an undetermined link)
    chained : (K,) True where the set is chained by determined links to a set taken from the shift function
    function : the shift function used for them (``{"kind": "wlf", ...}`` or ``{"kind": "poly", ...}``), or None
    fitted_on : temperatures (C) the shift function was fitted to (those connected to the reference set through
        determined links), or None
    """

    log_aT: np.ndarray
    pair: np.ndarray
    info: list
    from_function: np.ndarray
    chained: np.ndarray
    function: dict | None = None
    fitted_on: np.ndarray | None = None


def find_shift_factors(T: Sequence[float], logx: Sequence[np.ndarray], logy: Sequence[np.ndarray], T_ref: float,
                       *, domain: str = "freq", where: Sequence | None = None) -> tuple[np.ndarray, np.ndarray]:
    """log10 a_T of every set from the data (see the module docstring and :func:`search_shift_factors`).

    Returns
    -------
    (log_aT, pair_shift) each (K,)
    """
    s = search_shift_factors(T, logx, logy, T_ref, domain=domain, where=where)
    return s.log_aT, s.pair


def search_shift_factors(T: Sequence[float], logx: Sequence[np.ndarray], logy: Sequence[np.ndarray], T_ref: float,
                         *, domain: str = "freq", where: Sequence | None = None) -> ShiftSearch:
    """log10 a_T of every set from the data, and which shifts the data do not determine.

    Neighbouring sets are shifted pairwise, walking outward from the reference set (:func:`pair_shift_info`). When
    every link is determined by the data, that is the answer. Otherwise the WLF equation (:func:`fit_wlf`; a
    polynomial when it does not fit) is fitted to the sets connected to the reference set through determined links
    (at least ``MIN_DETERMINED`` temperatures), each set at an undetermined link takes the shift function's value,
    and the chain continues from there through determined links. Fewer determined temperatures are refused.

    Parameters
    ----------
    T : (K,) set temperatures (deg C); T_ref must be one of them (within 0.5 C)
    logx, logy : per set, log10 frequency (Hz) or time (s), and log10 modulus
    domain : ``"freq"`` (reduced frequency f a_T) or ``"time"`` (reduced time t / a_T)
    where : per set, (file, line of its first sample) for error messages
    """
    T = np.asarray(T, float)
    order = np.argsort(T, kind="stable")
    k_ref = int(np.argmin(np.abs(T - T_ref)))
    sign = 1.0 if domain == "freq" else -1.0
    log_aT = np.zeros(T.size)
    pair = np.zeros(T.size)
    info: list = [None] * T.size
    pos = int(np.flatnonzero(order == k_ref)[0])
    for direction in (-1, 1):
        prev = order[pos]
        j = pos + direction
        while 0 <= j < order.size:
            cur = order[j]
            ref_x = logx[prev] + sign * log_aT[prev]
            try:
                info[cur] = pair_shift_info(ref_x, logy[prev], logx[cur], logy[cur])  # reduced log x = log x + d
            except InputError as exc:
                path, line = where[cur] if where is not None else (None, None)
                raise InputError(f"the sets at {T[prev]:g} C and {T[cur]:g} C cannot be overlaid: {exc.message}",
                                 path=path, line=line) from None
            log_aT[cur] = sign * info[cur].d
            pair[cur] = log_aT[cur] - log_aT[prev]
            # a colder set is slower (log a_T larger), a warmer one faster: a shift the other way is noise
            if info[cur].determined and pair[cur] * (-direction) <= 0.0 and T[cur] != T[prev]:
                info[cur] = dataclasses.replace(info[cur], determined=False,
                                                why=f"its shift goes the wrong way ({pair[cur]:+.2g} decades against "
                                                    f"the {T[prev]:g} C set: a {'colder' if direction < 0 else 'warmer'} "
                                                    f"set must be {'slower' if direction < 0 else 'faster'})")
            prev = cur
            j += direction
    none = np.zeros(T.size, bool)
    if all(p is None or p.determined for p in info):
        return ShiftSearch(log_aT, pair, info, none, none.copy())
    # every determined link (pair of neighbours), wherever it sits: the shift function is fitted to their increments
    links = []   # (colder-or-warmer set, its inner neighbour, increment of log a_T, its standard error)
    for direction in (-1, 1):
        prev = order[pos]
        for jj in range(pos + direction, -1 if direction < 0 else order.size, direction):
            cur = order[jj]
            if info[cur].determined:
                links.append((cur, prev, pair[cur], info[cur].se))
            prev = cur
    used = sorted({k for a, b, _d, _s in links for k in (a, b)}, key=lambda k: T[k])
    bad = [k for k in order if info[k] is not None and not info[k].determined]
    words = "; ".join(f"{T[k]:g} C: {info[k].why}" for k in bad[:3]) + (" ..." if len(bad) > 3 else "")
    if len(links) < MIN_DETERMINED - 1:
        path, line = where[bad[0]] if where is not None else (None, None)
        raise InputError(f"the data determine the shift between only {len(links)} pair(s) of neighbouring sets (at "
                         f"least {MIN_DETERMINED - 1} are needed to fit a shift function to the rest): not determined "
                         f"at {', '.join(format(T[k], 'g') for k in bad)} C ({words}); measure wider sweeps "
                         "(neighbouring temperatures must share a range of modulus over which it changes) or give "
                         "the shift factors with --shift FILE", path=path, line=line, key="--shift")
    fn = fit_wlf_increments(T, links, T_ref)
    if fn is not None:
        fn = {"kind": "wlf", **fn}
        f_of = lambda t: float(wlf(t, fn["T_ref"], fn["C1"], fn["C2"]))  # noqa: E731
    else:
        fn = {"kind": "poly", **fit_poly_increments(T, links, T_ref)}
        f_of = lambda t: float(np.polynomial.polynomial.polyval(t - T_ref, fn["coefficients"]))  # noqa: E731
    connected = np.array(used, int)
    new = log_aT.copy()
    from_fn, chained = none.copy(), none.copy()
    for direction in (-1, 1):
        prev = order[pos]
        j = pos + direction
        while 0 <= j < order.size:
            cur = order[j]
            if info[cur].determined:
                new[cur] = new[prev] + pair[cur]
                chained[cur] = from_fn[prev] or chained[prev]
            else:   # the shift function's step across the link the data do not fix
                new[cur] = new[prev] + f_of(T[cur]) - f_of(T[prev])
                from_fn[cur] = True
            prev = cur
            j += direction
    pair_new = pair.copy()
    for direction in (-1, 1):  # pair shifts of the final factors
        for j in range(pos + direction, -1 if direction < 0 else order.size, direction):
            pair_new[order[j]] = new[order[j]] - new[order[j - direction]]
    return ShiftSearch(new, pair_new, info, from_fn, chained, fn, T[connected])


def shift_warnings(sh: "ShiftResult") -> list[str]:
    """The warning ``fit relax`` gives (and ``--strict`` refuses) when shift factors came from the shift function."""
    if sh.from_function is None or not np.any(sh.from_function):
        return []
    o = np.argsort(sh.T)
    ff = [format(t + 0.0, "g") for t in sh.T[o][sh.from_function[o]]]  # + 0.0: no "-0"
    ch = [format(t + 0.0, "g") for t in sh.T[o][sh.chained[o]]] if sh.chained is not None else []
    fit_on = sh.fitted_on if sh.fitted_on is not None else np.zeros(0)
    kind = "WLF" if (sh.function or {}).get("kind") == "wlf" else "polynomial"
    why = [(t, w) for t, w in sorted((sh.why or {}).items()) if w]
    reason = why[0][1] if len(why) == 1 else "; ".join(f"{t + 0.0:g} C: {w}" for t, w in why)
    return [f"the data do not determine the shift factors at {', '.join(ff)} C ({reason}): they are the {kind} shift "
            f"function's values, fitted to the steps of log a_T across the links between neighbouring sets that the "
            f"data determine (sets at {fit_on.min():g} ... {fit_on.max():g} C)"
            + (f"; the sets at {', '.join(ch)} C are chained to them" if ch else "")
            + ". Wider sweeps (overlapping modulus ranges) or --shift FILE give them from data"]


def wlf_warnings(sh: "ShiftResult") -> list[str]:
    """The warning ``fit relax`` gives (and ``--strict`` refuses) when the WLF fit does not describe the shift
    factors: its constants are not determined (a standard error above the constant) and it misses the factors by
    more than :data:`WLF_MISFIT_RMSE`. Seen when one file's frequency or temperature unit is not what it states (a
    set 2 pi or 273 off), which the FEA cards would carry as C1, C2."""
    w = sh.wlf
    if w is None:
        return []
    def num(k):   # a shift given in a file may carry no standard errors: nothing to judge then
        v = w.get(k)
        return float(v) if isinstance(v, (int, float)) else float("nan")

    c1, c2, se1, se2, rmse = (num(k) for k in ("C1", "C2", "se_C1", "se_C2", "rmse"))
    if not all(np.isfinite(v) for v in (c1, c2, rmse)):
        return []
    undetermined = not (np.isfinite(se1) and np.isfinite(se2)) or se1 > abs(c1) or se2 > abs(c2)
    if not undetermined or not rmse > WLF_MISFIT_RMSE:
        return []
    return [f"the WLF shift function does not describe these shift factors: C1 = {c1:.4g} +- {se1:.2g}, "
            f"C2 = {c2:.4g} +- {se2:.2g} C (standard errors larger than the constants), RMSE {rmse:.2g} decades. "
            "One set off by a constant shift breaks the curve: check that every file's frequency (Hz or rad/s) and "
            "temperature (C or K) are what its header states (the result's data.units_in_file lists them) and look "
            "at the shift factors against temperature in the figure; the FEA cards `bpmid export` writes take "
            "these C1, C2"]


def fit_wlf(T: np.ndarray, log_aT: np.ndarray, T_ref: float) -> dict | None:
    """WLF constants C1 (decades), C2 (C) with standard errors, by least squares; None when it does not fit
    (fewer than 3 temperatures or a pole inside the temperature range)."""
    T = np.asarray(T, float)
    y = np.asarray(log_aT, float)
    if T.size < 3:
        return None
    d = T - T_ref
    return _fit_wlf_core(T, np.full(T.size, float(T_ref)), y, np.ones(T.size), T_ref, lo2=-d.min() + 1e-3,
                         c2_floor=-d.min() + 1.0)


def fit_wlf_increments(T: np.ndarray, links, T_ref: float) -> dict | None:
    """WLF constants fitted to the increments of log a_T across determined links (``(k, k_inner, increment, se)``):
    f(T_k) - f(T_inner) = increment, weighted by 1 / se^2 (se at least 0.02 decades), with f(T_ref) = 0. Uses every
    link the data fix, wherever it lies, so that a gap between determined stretches does not leave the function to
    a few temperatures near the reference. None when it does not fit."""
    T = np.asarray(T, float)
    a = np.array([T[k] for k, _i, _d, _s in links])
    b = np.array([T[i] for _k, i, _d, _s in links])
    y = np.array([d for _k, _i, d, _s in links])
    w = 1.0 / np.maximum(np.array([s if np.isfinite(s) else 0.1 for *_r, s in links]), 0.02)
    if y.size < 2:
        return None
    lo2 = -(min(a.min(), b.min()) - T_ref) + 1e-3
    out = _fit_wlf_core(a, b, y, w, T_ref, lo2=lo2, c2_floor=lo2 + 1.0)
    return None if out is None else {**out, "fitted_to": "increments across links"}


def _fit_wlf_core(a, b, y, w, T_ref: float, *, lo2: float, c2_floor: float) -> dict | None:
    """Weighted least squares of w (f(a) - f(b) - y) over the WLF constants, from several C2 starts (C1 solved
    linearly for each); the constants with standard errors and the unweighted RMSE (decades). ``f(T_ref) = 0``:
    an absolute fit is b = T_ref."""
    best = None
    for C2 in (30.0, 51.6, 100.0, 200.0, 500.0):
        C2 = max(C2, c2_floor)

        def res(p):
            return w * (wlf(a, T_ref, p[0], p[1]) - wlf(b, T_ref, p[0], p[1]) - y)

        g = (wlf(a, T_ref, 1.0, C2) - wlf(b, T_ref, 1.0, C2)) * w
        C1 = float(np.sum(g * w * y) / max(float(g @ g), 1e-300))
        try:
            sol = least_squares(res, [C1, C2], bounds=([-np.inf, lo2], [np.inf, 1e5]), method="trf")
        except ValueError:
            continue
        if best is None or sol.cost < best.cost:
            best = sol
    if best is None:
        return None
    r = best.fun / w
    dof = max(y.size - 2, 1)
    try:
        cov = np.linalg.inv(best.jac.T @ best.jac) * float(best.fun @ best.fun) / dof
        se = np.sqrt(np.abs(np.diag(cov)))
    except np.linalg.LinAlgError:
        se = np.array([np.nan, np.nan])
    return {"C1": float(best.x[0]), "C2": float(best.x[1]), "T_ref": float(T_ref), "se_C1": float(se[0]),
            "se_C2": float(se[1]), "rmse": float(np.sqrt(np.mean(r ** 2)))}


def fit_poly_increments(T: np.ndarray, links, T_ref: float, degree: int = 2) -> dict:
    """A polynomial in (T - T_ref) without constant term fitted to the increments across determined links."""
    T = np.asarray(T, float)
    a = np.array([T[k] for k, _i, _d, _s in links]) - T_ref
    b = np.array([T[i] for _k, i, _d, _s in links]) - T_ref
    y = np.array([d for _k, _i, d, _s in links])
    deg = max(1, min(degree, y.size - 1))
    V = np.column_stack([a ** m - b ** m for m in range(1, deg + 1)])
    c, *_ = np.linalg.lstsq(V, y, rcond=None)
    r = y - V @ c
    return {"degree": int(deg), "variable": "T - T_ref (C)", "coefficients": [0.0] + [float(v) for v in c],
            "se": [0.0] + [math.nan] * deg, "rmse": float(np.sqrt(np.mean(r ** 2))) if r.size else 0.0}


def fit_poly(T: np.ndarray, log_aT: np.ndarray, T_ref: float, degree: int = POLY_DEGREE) -> dict | None:
    """Polynomial in (T - T_ref) by least squares, with standard errors of its coefficients."""
    T = np.asarray(T, float)
    y = np.asarray(log_aT, float)
    deg = min(degree, T.size - 2)
    if deg < 1:
        return None
    scale = float(np.max(np.abs(T - T_ref))) or 1.0
    V = np.polynomial.polynomial.polyvander((T - T_ref) / scale, deg)  # scaled: a well-conditioned basis
    q, rr = np.linalg.qr(V)
    cs = np.linalg.solve(rr, q.T @ y)
    r = y - V @ cs
    dof = max(T.size - deg - 1, 1)
    s2 = float(r @ r) / dof
    rinv = np.linalg.inv(rr)
    se_s = np.sqrt(np.abs(np.diag(rinv @ rinv.T) * s2))
    powers = scale ** -np.arange(deg + 1.0)
    coef, se = cs * powers, se_s * powers
    return {"degree": int(deg), "variable": "T - T_ref (C)", "coefficients": [float(c) for c in coef],
            "se": [float(s) for s in se], "rmse": float(np.sqrt(np.mean(r ** 2)))}


def read_shift_file(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """User shift factors: a CSV with columns T (C) and log_aT (pyvisco's ``T, log_aT`` / ``C, -`` format works).

    Returns (T, log_aT); errors name the file and line.
    """
    from bpmid.io.material_files import _csv_rows, _is_num, _split_unit

    path = Path(path)
    header, units, rows, hline = _csv_rows(path)
    parts = [_split_unit(h) for h in header]   # 'T (K)' -> ('T', 'k')
    names = [b.strip().lower().replace(" ", "") for b, _u in parts]
    try:
        jt = next(j for j, h in enumerate(names) if h in ("t", "temp", "temperature"))
        ja = next(j for j, h in enumerate(names) if h in ("log_at", "logat", "log10_at", "log10(at)", "log(at)"))
    except StopIteration:
        raise InputError(f"a shift-factor file needs columns T (C) and log_aT; found {header}", path=path,
                         line=hline) from None
    row_unit = units[jt].strip().lower() if units is not None and jt < len(units) and units[jt].strip() else None
    unit = parts[jt][1] if parts[jt][1] is not None else row_unit
    if unit is None:   # C, K or F: never guessed (as the material files' temperature column)
        raise InputError(f"column {header[jt]!r} states no unit: name it 'T (C)' or 'T (K)', or add a units row "
                         f"under the header (pyvisco's 'C, -'); degrees F: convert to C", path=path, line=hline,
                         key=header[jt])
    offset = {"c": 0.0, "°c": 0.0, "degc": 0.0, "k": -273.15}.get(unit)
    if offset is None:
        raise InputError(f"unknown temperature unit {unit!r} (C or K)", path=path,
                         line=hline + (1 if parts[jt][1] is None else 0), key=header[jt])
    T, a = [], []
    for ln, r in rows:
        for j in (jt, ja):
            if j >= len(r) or not _is_num(r[j]) or not np.isfinite(float(r[j])):
                raise InputError(f"column {header[j]!r}: {r[j] if j < len(r) else ''!r} is not a number", path=path,
                                 line=ln)
        T.append(float(r[jt]) + offset)
        a.append(float(r[ja]))
    if not T:
        raise InputError("no shift factors in the file", path=path, line=hline)
    return np.array(T), np.array(a)


def shift_from_user(T_sets: np.ndarray, T_user: np.ndarray, a_user: np.ndarray, T_ref: float, path) -> np.ndarray:
    """The user's log_aT at each set temperature (within 0.5 C), re-referenced to T_ref (log_aT(T_ref) = 0)."""
    out = np.empty(T_sets.size)
    for i, t in enumerate(T_sets):
        k = np.flatnonzero(np.abs(T_user - t) <= 0.5)
        if k.size == 0:
            raise InputError(f"no shift factor for the set at {t:g} C (the file gives "
                             f"{', '.join(format(v, 'g') for v in T_user)} C)", path=path, key="T")
        out[i] = a_user[k[0]]
    k = np.flatnonzero(np.abs(T_user - T_ref) <= 0.5)
    ref = a_user[k[0]] if k.size else float(np.interp(T_ref, np.sort(T_user), a_user[np.argsort(T_user)]))
    return out - ref


def shift_result(T: np.ndarray, log_aT: np.ndarray, T_ref: float, source: str, pair=None,
                 search: ShiftSearch | None = None) -> ShiftResult:
    out = ShiftResult(float(T_ref), np.asarray(T, float), np.asarray(log_aT, float), source,
                      fit_wlf(T, log_aT, T_ref), fit_poly(T, log_aT, T_ref), pair)
    if search is not None and np.any(search.from_function):
        out.from_function, out.chained = search.from_function.copy(), search.chained.copy()
        out.function, out.fitted_on = search.function, search.fitted_on
        out.why = {float(t): p.why for t, p in zip(out.T, search.info) if p is not None and not p.determined}
    return out


def shift_body(sh: ShiftResult) -> dict:
    """The ``shift`` block of the result YAML."""
    def clean(d):
        if d is None:
            return None
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}

    order = np.argsort(sh.T)
    body = {
        "T_ref": sh.T_ref, "T_unit": "C", "source": sh.source,
        "convention": "f_reduced = f * a_T, t_reduced = t / a_T; log_aT is log10",
        "log_aT": {format(float(t), "g"): float(a) for t, a in zip(sh.T[order], sh.log_aT[order])},
        "wlf": clean(sh.wlf), "poly": clean(sh.poly),
    }
    if sh.from_function is not None and np.any(sh.from_function):
        body["not_determined_by_data"] = {
            "from_shift_function": [float(t) + 0.0 for t in sh.T[order][sh.from_function[order]]],
            "chained_to_them": [float(t) + 0.0 for t in sh.T[order][sh.chained[order]]],
            "function": clean(sh.function), "fitted_on": [float(t) + 0.0 for t in np.sort(sh.fitted_on)],
            "why": {format(t + 0.0, "g"): w for t, w in sorted(sh.why.items())}}
    return body
