"""Maxwell-slip model (seeds 001 and 003): elastoplastic elements in parallel plus a static polynomial.

Model (BASELINES.md), input v in ``input_unit`` (bar of gauge pressure for a muscle log):

    d_i,k = sat_{D_i}(v_k - v_{k-1} + d_i,k-1)      (stop operator; slip limit D_i = w_i / k_i)
    F_i,k = k_i d_i,k                               (saturates at +-w_i)
    y_k   = s(v_k) + sigma sum_i F_i,k,       s(v) = s0 + s1 v + ... + s_deg v^deg,   sigma = +1 or -1

Each element is a stop operator, so this is a stop-type Prandtl-Ishlinskii model; it shares the
compiled kernel :func:`bpmid.models._hysteresis_kernels.stop_bank` but stays its own family. Elements
start relaxed (d = 0).

Parameters: ``s0..s{deg}`` (output / input^j), ``k1..kn`` (output / input, >= 0) and ``D1..Dn`` (input
unit, > 0); the saturation forces w_i = k_i D_i are reported by :meth:`MaxwellSlipModel.element_table`.

**Loop orientation** (fixed parameter ``loop_sign`` = sigma, constructor ``orientation``). A stop
operator's deflection is positive while the input rises, so with k_i >= 0 and sigma = +1 the rising
branch lies *above* the falling one: the output leads the input (clockwise loop), as a friction force
against displacement does (seeds 001/003, the friction check, the inverse feedforward of
:mod:`bpmid.control`). A muscle's bending angle *lags* its pressure (rising branch below the falling
one) and needs sigma = -1; then y = s(v) - sum k_i d_i = s(v) - (sum k_i) v + sum k_i play_{D_i}(v) + const,
i.e. a classical PI model plus a static polynomial. With the wrong sign the non-negative least squares
can only answer k_i = 0 and the model collapses to its polynomial: that is why, before the option
existed, Maxwell-slip fitted the muscle's fitting set at 4.2 deg RMSE with every k_i = 0 (no hysteresis
at all). ``orientation="lead"`` (default, sigma = +1: the classical friction form), ``"lag"``
(sigma = -1: muscle angle against pressure), ``"auto"`` (the better of the two dense NNLS starts on the
training data).

**Static polynomial and extrapolation.** Once every element has slipped (input excursions larger than
2 D_max), the output follows s(v) alone plus a constant, so s carries the model outside the training
range. A quadratic fitted on the muscle's 0.19-0.59 bar gauge fitting set comes out concave (lead
orientation: s2 = -78 deg/bar^2, maximum at 0.64 bar, the angle then falls to 9 deg at 1.2 bar; lag:
s2 = -39 deg/bar^2, flat by 1.2 bar), while the muscle's static angle-pressure map is nearly linear,
slightly convex, over 0.2-1.2 bar gauge: the curvature seen in a 0.4 bar window is creep at the cycle
ends, not the static map. The shipped comparison (``configs/compare_paper.yaml``) uses ``poly_degree=1``
with ``orientation="auto"`` (it picks lag there) and ``monotone=True`` (training RMSE 1.87 deg, against 1.74 deg for the free
lag quadratic, whose extra fit comes from elements with slip limits below the pressure noise).

**Monotone fit** (``monotone=True``, needs ``poly_degree=1``). Just after a reversal every element
still deflects, so the rising-branch slope is s1 + sigma sum k_i (over the elements not yet slipped).
For sigma = -1 a free fit makes sum k_i far larger than s1 (elements with slip limits below the 0.002 bar
pressure noise and stiffnesses of several hundred deg/bar): after every reversal the predicted angle first
moves against the pressure. ``monotone=True`` solves for p = s1 + min(sigma, 0) sum k_i >= 0 instead of s1
(for sigma = +1: s1 >= 0), so the output never decreases while the input rises; s1 is reported as usual
(its standard error from the transformed covariance).

Identification (``method``):

- ``"lsq"`` (default): D_i start on a grid over the input span, k_i (>= 0) and the polynomial by one
  bounded linear least-squares (NNLS) solve; with ``refine=True`` the D_i are then refined by nonlinear
  least squares around that solve (variable projection, :func:`bpmid.varpro.fit_variable_projection`).
- ``"virgin"``: the virgin-curve method of seed 001 eq. (7). The largest rising branch that starts at
  a reversal is shrunk by 2 about its reversal point (x = (v - v_rev)/2, V = (y - y_rev)/2), n linear
  segments with breakpoints b_1 < ... < b_n are fitted to it, the segment slopes K_j are read off and
  the 2n equations  sum_{i>=j} k_i = K_j - K_end,  w_i = k_i b_i  are solved for (k_i, w_i). The seed
  extracted the hysteresis by subtracting a separately measured static force, so its last segment
  is flat (K_end = 0); here the static polynomial is still in the data, and on a branch where all
  elements have slipped the slope left is that of s, so the branch after b_n is fitted with its own
  slope K_end (exact for a linear s, an approximation for curved s). The polynomial is then fitted by
  linear least squares with the elements held. k_i and D_i from this method carry no standard error.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
from scipy.optimize import least_squares

from bpmid.errors import InputError
from bpmid.fitting import FitResult, correlation
from bpmid.io.motion_logs import MotionLog
from bpmid.models._hysteresis_kernels import direction_with_deadband, stop_bank
from bpmid.models.base import ModelFamily, check_fit_logs
from bpmid.models.gpi import check_arrays
from bpmid import identifiability
from bpmid.varpro import fit_variable_projection, solve_linear
from bpmid.params import Param, ParamSet
from bpmid.units import PA_PER_BAR

METHODS = ("lsq", "virgin")
ORIENTATIONS = ("lead", "lag", "auto")


class MaxwellSlipModel(ModelFamily):
    """Maxwell-slip hysteresis (rate-independent) plus a static polynomial.

    Parameters
    ----------
    n_elements : int
        Number n of elastoplastic elements (seed 001 used 4).
    poly_degree : int
        Degree of the static polynomial s(v) (0..3).
    method : {"lsq", "virgin"}
        Identification method (module docstring).
    refine : bool
        ``method="lsq"`` only: refine the slip limits by nonlinear least squares after the grid solve.
    orientation : {"lead", "lag", "auto"}
        Loop orientation sigma (module docstring): "lead" (+1, friction force against displacement;
        default), "lag" (-1, a muscle's angle against pressure), "auto" (decided from the data at fit time).
    monotone : bool
        Constrain the fit so that the output never decreases while the input rises (module docstring);
        needs ``poly_degree=1``.
    input_unit, output_unit : str
        Units of the generic signals (``"bar"``/``"deg"`` for muscle logs).
    """

    name = "maxwell-slip"
    label = "Maxwell-slip"
    min_samples = 40

    def __init__(self, n_elements: int = 4, poly_degree: int = 2, method: str = "lsq", refine: bool = True, *,
                 orientation: str = "lead", monotone: bool = False, input_unit: str = "bar",
                 output_unit: str = "deg"):
        if orientation not in ORIENTATIONS:
            raise InputError(f"unknown orientation {orientation!r} (known: {', '.join(ORIENTATIONS)})",
                             key="orientation")
        if method not in METHODS:
            raise InputError(f"unknown Maxwell-slip method {method!r} (known: {', '.join(METHODS)})", key="method")
        if int(n_elements) < 1:
            raise InputError(f"n_elements must be >= 1, found {n_elements}", key="n_elements")
        if not 0 <= int(poly_degree) <= 3:
            raise InputError(f"poly_degree must be 0..3, found {poly_degree}", key="poly_degree")
        self.n_elements = int(n_elements)
        self.poly_degree = int(poly_degree)
        self.method = method
        self.refine = bool(refine)
        self.orientation = orientation
        self.monotone = bool(monotone)
        if self.monotone and self.poly_degree != 1:
            raise InputError(f"monotone=True needs poly_degree=1, found {poly_degree}", key="monotone")
        self.input_unit = input_unit
        self.output_unit = output_unit

    # -- parameters -------------------------------------------------------------------------------
    @property
    def poly_names(self) -> list[str]:
        return [f"s{j}" for j in range(self.poly_degree + 1)]

    @property
    def stiffness_names(self) -> list[str]:
        return [f"k{i + 1}" for i in range(self.n_elements)]

    @property
    def slip_names(self) -> list[str]:
        return [f"D{i + 1}" for i in range(self.n_elements)]

    def _params(self, poly, k, slip, span: float, sign: float | None = None) -> ParamSet:
        iu, ou = self.input_unit, self.output_unit
        if sign is None:
            sign = -1.0 if self.orientation == "lag" else 1.0
        ps = [Param(n, float(c), ou if j == 0 else (f"{ou}/{iu}" if j == 1 else f"{ou}/{iu}^{j}"))
              for j, (n, c) in enumerate(zip(self.poly_names, poly))]
        ps += [Param(n, float(v), f"{ou}/{iu}", 0.0, np.inf) for n, v in zip(self.stiffness_names, k)]
        ps += [Param(n, float(v), iu, 1e-4 * span, 2.0 * span, log_scale=True) for n, v in zip(self.slip_names, slip)]
        ps.append(Param("loop_sign", float(sign), "1", -1.0, 1.0, fixed=True))
        return ParamSet(ps)

    def slip_grid(self, span: float) -> np.ndarray:
        """Starting slip limits (n,): quadratic spacing up to half the input span (small D resolve the
        steep start of every branch, large D its end)."""
        i = np.arange(1, self.n_elements + 1)
        return 0.5 * span * (i / self.n_elements) ** 2

    def default_params(self) -> ParamSet:
        """A plausible muscle: 0.2-1.2 bar -> roughly 10-80 deg with a few degrees of hysteresis."""
        poly = [5.0, 55.0, 5.0, 0.0][: self.poly_degree + 1]
        n = self.n_elements
        k = 40.0 / n * np.ones(n) / np.arange(1, n + 1) ** 0.5
        return self._params(poly, k, self.slip_grid(1.0), 1.0)

    def element_table(self, params: ParamSet) -> dict[str, np.ndarray]:
        """Element stiffness k (output/input), saturation w = k D (output) and slip limit D (input), each (n,)."""
        k = np.array([params.value(n) for n in self.stiffness_names])
        d = np.array([params.value(n) for n in self.slip_names])
        return {"k": k, "w": k * d, "D": d}

    # -- simulation -------------------------------------------------------------------------------
    def deflections(self, params: ParamSet, u: np.ndarray) -> np.ndarray:
        """Element deflections d (N, n) in ``input_unit`` from a relaxed start."""
        d = np.array([params.value(n) for n in self.slip_names], float)
        return stop_bank(np.ascontiguousarray(u, float), d, np.zeros_like(d))

    def design(self, params: ParamSet, u: np.ndarray) -> np.ndarray:
        """Design (N, deg + 1 + n): columns [1, v, .., v^deg, sigma d_1..sigma d_n] for (s_j, k_i)."""
        v = np.asarray(u, float)
        sign = params.value("loop_sign") if "loop_sign" in params else 1.0
        return np.column_stack([v[:, None] ** np.arange(self.poly_degree + 1), sign * self.deflections(params, v)])

    def fit_design(self, sign: float, v: np.ndarray, defl: np.ndarray) -> np.ndarray:
        """Design of the linear solve from the input v (N,) and deflections (N, q): [1, v, .., v^deg, sigma d].

        With ``monotone`` the v column multiplies p = s1 + min(sigma, 0) sum k (constrained >= 0), so each
        element column becomes sigma d_i - min(sigma, 0) v; :meth:`from_fit_coefficients` maps back.
        """
        v = np.asarray(v, float)
        el = sign * defl
        if self.monotone and sign < 0:
            el = el + v[:, None]
        return np.column_stack([v[:, None] ** np.arange(self.poly_degree + 1), el])

    def fit_nonneg(self, q: int) -> np.ndarray:
        """Which of the deg + 1 + q linear coefficients of :meth:`fit_design` are constrained >= 0."""
        out = np.arange(self.poly_degree + 1 + q) > self.poly_degree
        if self.monotone:
            out[1] = True
        return out

    def simulate_arrays(self, params: ParamSet, u: np.ndarray) -> np.ndarray:
        """Output (N,) in ``output_unit`` for the input ``u`` (N,) in ``input_unit``."""
        theta = np.array([params.value(n) for n in self.poly_names + self.stiffness_names], float)
        return self.design(params, u) @ theta

    def simulate(self, params: ParamSet, log: MotionLog) -> np.ndarray:
        """Bending angle (deg), shape (log.n,), from the gauge pressure (Pa -> bar)."""
        return self.simulate_arrays(params, log.pressure_pa / PA_PER_BAR)

    # -- identification ---------------------------------------------------------------------------
    def initial_guess_arrays(self, us: Sequence[np.ndarray], params: ParamSet,
                             ys: Sequence[np.ndarray] | None = None) -> ParamSet:
        """Slip limits from the data: one NNLS solve on a dense grid of candidate slip limits, merged to n.

        Without outputs ``ys`` the start is the n-point grid :meth:`slip_grid` over the input span.
        With them, 48 candidate elements (slip limits geometric from 1e-3 to 1/2 of the span) and the
        polynomial are solved by one NNLS; the elements the solve keeps are merged to n by
        :func:`merge_elements`. Refining from this start avoids the local minima a coarse n-point grid
        falls into (two true elements shared by one, the others shifted).
        """
        lo = min(float(np.min(u)) for u in us)
        span = max(float(np.max(u)) for u in us) - lo
        if not span > 0:
            raise InputError(f"{self.name}: the input is constant; a hysteresis model cannot be identified")
        slip = self.slip_grid(span)
        k = np.zeros(self.n_elements)
        sign = -1.0 if self.orientation == "lag" else 1.0
        if ys is not None:
            grid = np.geomspace(1e-3 * span, 0.45 * span, 48)
            v_all = np.concatenate([np.asarray(u, float) for u in us])
            defl = np.vstack([stop_bank(np.ascontiguousarray(u, float), grid, np.zeros_like(grid)) for u in us])
            y = np.concatenate(ys)
            nonneg = self.fit_nonneg(grid.size)
            signs = (1.0, -1.0) if self.orientation == "auto" else (sign,)
            best = None
            for s in signs:
                a = self.fit_design(s, v_all, defl)
                theta = solve_linear(a, y, nonneg)
                sse = float(np.sum((a @ theta - y) ** 2))
                if best is None or sse < best[0]:
                    best = (sse, s, theta)
            _sse, sign, theta = best
            slip, k = merge_elements(grid, theta[self.poly_degree + 1:], self.n_elements)
        fresh = self._params(np.zeros(self.poly_degree + 1), k, slip, span, sign)
        # fixed flags of the given set survive; the loop sign is a setting decided here, not a start value
        return ParamSet(params[p.name] if p.name in params and params[p.name].fixed and p.name != "loop_sign"
                        else p for p in fresh)

    def initial_guess(self, logs: Sequence[MotionLog], params: ParamSet) -> ParamSet:
        return self.initial_guess_arrays([lg.pressure_pa / PA_PER_BAR for lg in logs], params,
                                         [lg.angle_deg for lg in logs] if all(lg.angle_deg is not None for lg in logs)
                                         else None)

    def fit_arrays(self, us: Sequence[np.ndarray], ys: Sequence[np.ndarray], params: ParamSet | None = None,
                   **fit_kw) -> FitResult:
        """Identify from generic signals with the constructor's ``method`` (module docstring).

        Parameters
        ----------
        us, ys : sequences of (N_j,) input (``input_unit``) and output (``output_unit``) signals, each
            simulated from relaxed elements.
        params : optional start (fixed flags are kept); the slip grid follows the data range.
        """
        us = [np.asarray(u, float) for u in us]
        ys = [np.asarray(y, float) for y in ys]
        check_arrays(self, us, ys, 2 * self.n_elements + self.poly_degree + 1)
        start = self.initial_guess_arrays(us, self.default_params() if params is None else params, ys)
        fit_kw.setdefault("prior_from_data", True)   # the start is the data's, not knowledge
        if self.method == "virgin":
            start = self.virgin_curve_elements(us, ys, start)
        elif not self.refine:
            start = ParamSet(p.replace(fixed=True) if p.name in self.slip_names else p for p in start)

        def design_fn(p: ParamSet) -> np.ndarray:
            return np.vstack([self.fit_design(p.value("loop_sign"), u, self.deflections(p, u)) for u in us])

        if self.method == "virgin":
            # elements come from eq. (7); only the polynomial is left for least squares
            held = ParamSet(p.replace(fixed=True) if p.name in self.stiffness_names + self.slip_names else p
                            for p in start)
            k = np.array([start.value(n) for n in self.stiffness_names])
            y_all = np.concatenate(ys)

            def design_poly(p: ParamSet) -> np.ndarray:
                a = design_fn(p)
                return a[:, : self.poly_degree + 1]

            el = np.concatenate([self.design(start, u)[:, self.poly_degree + 1:] @ k for u in us])
            if self.monotone and start.value("loop_sign") < 0:
                # p = s1 - sum k >= 0 multiplies v: the element columns carry + v
                el = el + np.concatenate(us) * float(k.sum())
            res = fit_variable_projection(design_poly, y_all - el, held, self.poly_names,
                                          list(self.fit_nonneg(0)), segments=[u.size for u in us], **fit_kw)
            res = self.from_fit_coefficients(res)
            note = "virgin-curve method (seed 001 eq. 7): no standard error"
            out = res.params
            for n in self.stiffness_names + self.slip_names:
                out = out.replace(n, fixed=False, stderr=None, note=note)
            res.params = out
            return res

        nonneg = list(self.fit_nonneg(self.n_elements))
        res = fit_variable_projection(design_fn, np.concatenate(ys), start, self.poly_names + self.stiffness_names,
                                      nonneg, segments=[u.size for u in us], **fit_kw)
        return self.from_fit_coefficients(res)

    def from_fit_coefficients(self, res: FitResult) -> FitResult:
        """Map the fitted p of a monotone lag fit back to s1 = p + sum k (value, covariance, standard error)."""
        if not (self.monotone and res.params.value("loop_sign") < 0):
            return res
        pr = res.params
        k_sum = float(sum(pr.value(n) for n in self.stiffness_names))
        out = pr.replace("s1", value=pr.value("s1") + k_sum)
        names = list(res.free_names)
        cov = res.cov
        if "s1" in names and cov is not None and np.size(cov):
            t = np.eye(len(names))
            i = names.index("s1")
            for j, n in enumerate(names):
                if n in self.stiffness_names:
                    t[i, j] = 1.0
            cov = t @ cov @ t.T
            se = float(np.sqrt(abs(cov[i, i])))
            why = identifiability.judge(se, se / max(abs(out.value("s1")), 1e-300), rel_se_max=0.5)
            out = out.replace("s1", stderr=se if np.isfinite(se) else None, identifiable=why is None,
                              note="" if why is None else f"not identifiable: {why} (estimated, not held)")
            res.cov, res.corr = cov, correlation(cov)
        else:
            # p at its bound 0: s1 = sum k exactly at the constraint, no standard error of its own
            out = out.replace("s1", stderr=None, identifiable=None,
                              note="monotone fit: s1 = sum k (slope constraint active)")
        res.held.pop("s1", None)
        res.params = out
        return res

    def fit(self, logs: Sequence[MotionLog], params: ParamSet | None = None, **fit_kw) -> FitResult:
        """Fit on motion logs (gauge pressure -> angle), all at once; see :meth:`fit_arrays`."""
        check_fit_logs(self, logs)
        return self.fit_arrays([lg.pressure_pa / PA_PER_BAR for lg in logs], [lg.angle_deg for lg in logs],
                               params, **fit_kw)

    # -- virgin-curve method (seed 001 eq. 7) -----------------------------------------------------
    def virgin_curve_elements(self, us: Sequence[np.ndarray], ys: Sequence[np.ndarray], params: ParamSet) -> ParamSet:
        """k_i and D_i = w_i / k_i from the virgin curve of the largest full loop (seed 001 eq. 7)."""
        # sigma y = sigma s(v) + sum F_i: the elements of a lagging loop are those of the mirrored output
        sign = params.value("loop_sign") if "loop_sign" in params else 1.0
        x, v = largest_rising_branch(us, [sign * np.asarray(y, float) for y in ys])
        b, a, k_end = fit_linear_segments(x, v, self.n_elements)
        k, w = solve_eq7(a, b, k_end)
        span = max(float(np.max(u)) for u in us) - min(float(np.min(u)) for u in us)
        d = np.clip(np.where(k > 0, w / np.where(k > 0, k, 1.0), b), 1e-4 * span, 2.0 * span)
        return params.with_values({**dict(zip(self.stiffness_names, k)), **dict(zip(self.slip_names, d))})

    def describe(self, params: ParamSet) -> dict:
        out = super().describe(params)
        tab = self.element_table(params)
        out["elements"] = {"k": tab["k"].tolist(), "w": tab["w"].tolist(), "D": tab["D"].tolist(),
                           "units": {"k": f"{self.output_unit}/{self.input_unit}", "w": self.output_unit,
                                     "D": self.input_unit}}
        out["settings"] = {"n_elements": self.n_elements, "poly_degree": self.poly_degree, "method": self.method,
                           "refine": self.refine, "orientation": self.orientation, "monotone": self.monotone,
                           "input_unit": self.input_unit, "output_unit": self.output_unit}
        return out


def largest_rising_branch(us: Sequence[np.ndarray], ys: Sequence[np.ndarray], *, noise_frac: float = 0.01):
    """The virgin curve (x, V) from the widest full-loop rising branch that starts at an interior reversal.

    A rising branch runs from a local minimum of the input to the next maximum; its usable width is the
    smaller of the rise and the fall before the minimum (only a fall at least as wide as the rise has
    slipped every element that the rise uses). The input may jitter by ``noise_frac`` of its span.
    The branch is shrunk by 2 about the reversal point: x = (v - v_rev)/2, V = (y - y_rev)/2.

    Returns
    -------
    x, V : (M,) float, x >= 0 increasing (input unit), V (output unit)
    """
    best = None
    for u, y in zip(us, ys):
        span = float(np.ptp(u))
        tol = noise_frac * span
        # reversal points by a dead-band walk (vectorised sign changes would chatter on noise)
        direction = direction_with_deadband(np.ascontiguousarray(u, float), tol)
        flips = np.flatnonzero(np.diff(direction) != 0) + 1
        for j, f in enumerate(flips):
            if direction[f] < 0:
                continue
            # the dead band detects the reversal late: the reversal is the extremum just before
            prev = flips[j - 1] if j > 0 else 0
            i0 = prev + int(np.argmin(u[prev:f + 1]))
            if i0 == 0:
                continue  # the log's first sample is not a reversal (elements relaxed, not slipped)
            end = flips[j + 1] if j + 1 < flips.size else u.size
            i1 = i0 + int(np.argmax(u[i0:end]))
            # a branch of a full loop: the fall before the reversal must be at least as wide as the rise,
            # otherwise some elements had not slipped back when the rise began
            pre = flips[j - 2] if j > 1 else 0
            fall = float(np.max(u[pre:i0 + 1]) - u[i0])
            width = min(float(u[i1] - u[i0]), fall)
            if best is None or width > best[0]:
                best = (width, u[i0:i1 + 1], y[i0:i1 + 1])
    if best is None or best[0] <= 0:
        raise InputError("maxwell-slip (virgin-curve method): the data hold no rising branch that starts at a "
                         "reversal; record at least one full loop (rise, fall, rise)")
    _w, ub, yb = best
    x = 0.5 * (ub - ub[0])
    order = np.argsort(x, kind="stable")
    return x[order], 0.5 * (yb - yb[0])[order]


def fit_linear_segments(x: np.ndarray, v: np.ndarray, n: int):
    """n continuous linear segments through the origin plus a final one: breakpoints by least squares.

    V(x) = K_end x + sum_i k_i min(x, b_i) is continuous piecewise linear with breakpoints b_i and
    decreasing slopes; for fixed b it is linear in (K_end, k_i >= 0). The breakpoints are fitted by
    nonlinear least squares on their log-gaps (ordered, positive) around that solve.

    Returns
    -------
    b : (n,) breakpoints (input unit); a : (n,) V at the breakpoints (output unit); k_end : final slope
    """
    xmax = float(x.max())

    def basis(gaps):
        b = np.cumsum(np.exp(gaps))
        return b, np.column_stack([x] + [np.minimum(x, bi) for bi in b])

    def resid(gaps):
        _b, a = basis(gaps)
        return a @ solve_linear(a, v, np.array([False] + [True] * n)) - v

    # start: NNLS over a dense grid of breakpoints, merged to n (a coarse start falls into local minima)
    # below the branch end: a breakpoint at its end would duplicate the final-slope column
    grid = np.geomspace(1e-3 * xmax, 0.9 * xmax, 48)
    dense = np.column_stack([x] + [np.minimum(x, g) for g in grid])
    theta = solve_linear(dense, v, np.arange(grid.size + 1) > 0)
    b0, _k0 = merge_elements(grid, theta[1:], n)
    b0 = np.minimum(np.sort(b0), xmax)
    g0 = np.log(np.maximum(np.diff(np.concatenate([[0.0], b0])), 1e-6 * xmax))
    lo, hi = np.full(n, np.log(1e-6 * xmax)), np.full(n, np.log(xmax))
    sol = least_squares(resid, np.clip(g0, lo + 1e-9, hi - 1e-9), bounds=(lo, hi))
    b, a_mat = basis(sol.x)
    theta = solve_linear(a_mat, v, np.array([False] + [True] * n))
    k_end, k = theta[0], theta[1:]
    a = np.array([k_end * bj + np.sum(k * np.minimum(bj, b)) for bj in b])
    return b, a, float(k_end)


def solve_eq7(a: np.ndarray, b: np.ndarray, k_end: float = 0.0):
    """Seed 001 eq. (7): the 2n equations for (k_i, w_i) from segment end points (b_j, a_j).

    Segment slopes K_j = (a_j - a_{j-1}) / (b_j - b_{j-1}) (a_0 = b_0 = 0);
    sum_{i >= j} k_i = K_j - k_end for j = 1..n and w_i = k_i b_i.

    Returns
    -------
    k, w : (n,) element stiffnesses (output/input) and saturation values (output)
    """
    n = a.size
    aa = np.concatenate([[0.0], a])
    bb = np.concatenate([[0.0], b])
    slopes = np.diff(aa) / np.diff(bb)
    m = np.zeros((2 * n, 2 * n))
    rhs = np.zeros(2 * n)
    for j in range(n):
        m[j, j:n] = 1.0
        rhs[j] = slopes[j] - k_end
        m[n + j, j] = -b[j]
        m[n + j, n + j] = 1.0
    sol = np.linalg.solve(m, rhs)
    return sol[:n], sol[n:]


def merge_elements(grid: np.ndarray, k: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Reduce grid elements (slip limits ``grid`` (G,), stiffnesses ``k`` (G,) >= 0) to n elements.

    Neighbouring kept elements (in log slip limit) are merged pairwise, closest first, into one of
    stiffness k_a + k_b at the stiffness-weighted geometric mean slip limit, until n remain. With fewer
    than n kept, the rest are filled with unused grid points (stiffness 0) spread over the grid.

    Returns
    -------
    slip, k : (n,) sorted by slip limit
    """
    keep = k > 1e-12 * max(float(k.max(initial=0.0)), 1e-300)
    d = list(np.log(grid[keep]))
    kk = list(k[keep])
    while len(d) > n:
        j = int(np.argmin(np.diff(d)))
        tot = kk[j] + kk[j + 1]
        d[j] = (kk[j] * d[j] + kk[j + 1] * d[j + 1]) / tot
        kk[j] = tot
        del d[j + 1], kk[j + 1]
    slip = list(np.exp(d))
    if len(slip) < n:
        unused = [g for g in grid[::-1] if not np.any(np.isclose(g, slip))]
        pick = np.linspace(0, len(unused) - 1, n - len(slip)).round().astype(int)
        slip += [unused[i] for i in pick]
        kk += [0.0] * len(pick)
    order = np.argsort(slip)
    return np.asarray(slip)[order], np.asarray(kk)[order]
