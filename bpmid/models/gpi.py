"""Generalized Prandtl-Ishlinskii (GPI) model: a weighted bank of generalized play operators.

Model (BASELINES.md; Al Janaideh, Rakheja, Su 2009/2011), with the input v in ``input_unit``
(bar of gauge pressure for a muscle log):

    z_i,k = max(gamma_l(v_k) - r_i, min(gamma_r(v_k) + r_i, z_i,k-1))      i = 1..m
    y_k   = p0 v_k + c + sigma sum_i w_i z_i,k,          w_i >= 0,  sigma = +1 or -1

``gamma_l`` (rising branch) and ``gamma_r`` (falling branch) are increasing envelopes:

- ``envelope="tanh"``: gamma(v) = amp tanh(slope v + shift) (+ offset for gamma_r only: a common offset
  of both envelopes shifts every z_i alike and is absorbed by c, so gamma_l carries none);
- ``envelope="linear"``: gamma_l(v) = v, gamma_r(v) = slope v + offset (gamma_l fixes the scale);
- ``envelope="identity"``: gamma_l = gamma_r = v, the classical PI model (no envelope parameters).

The loop orientation sigma (fixed parameter ``loop_sign``) is +1 when the output lags the input
(anticlockwise loop in the input-output plane, the usual PI case and the muscle's angle under
pressure) and -1 when it leads (clockwise, e.g. a friction force against displacement); with
non-negative weights one sign cannot make the other loop. ``orientation="auto"`` picks it from the
data by the better of the two starting solves.

Identification (variable projection): thresholds on a grid over half the input span of the training
data (fixed; ``threshold_grid="uniform"``: r_i = (i/m) h, ``"quadratic"``: r_i = (i/m)^2 h, finer near
the reversals where dry friction switches); for given envelopes the output is linear in (p0, c, w_i), solved by bounded linear least
squares (w_i >= 0); the envelope parameters are fitted by the shared nonlinear least-squares driver
around that inner solve. :func:`bpmid.varpro.fit_variable_projection` (used by Maxwell-slip too) turns the result
into an ordinary :class:`bpmid.fitting.FitResult` with standard errors from the joint Jacobian.

The model is rate-independent: it cannot show creep (that is the point of the comparison).

**Extrapolation** (the comparison fits on 0.19-0.59 bar gauge and tests up to 1.19 bar). Once every
operator moves with the input, the rising branch follows p0 v + sum w_i gamma_l(v), so the envelopes
carry the model outside the training range. Tanh envelopes fitted on a narrow range are essentially a
free curvature there: on the muscle's fitting set they come out in their convex part and the angle
shoots up to about 150 deg at 1.2 bar gauge (the muscle bends about 75 deg), while they improve the
training RMSE only from 1.74 to 1.59 deg over linear envelopes with three more parameters.
``envelope="linear"`` extrapolates linearly, which matches the muscle's nearly linear static map; it is
the setting of the shipped comparison (``configs/compare_paper.yaml``).

``monotone=True`` constrains p0 >= 0 (besides w_i >= 0). With sigma = +1 and increasing envelopes the
output then never falls while the input rises: a fit left free puts p0 < 0 on the muscle data
(-20 deg/bar), so that just after every reversal from falling to rising the predicted angle first keeps
falling (the operators have not started to move yet) - a trace of the rig's pressure lag that a
rate-independent model can only mimic this way, and at slow rates it is wrong. The shipped comparison
uses ``monotone: true`` (the cost on the fitting set is given in the config comment).

Every method works on a generic input signal (``*_arrays``): the friction check of
:mod:`bpmid.external.friction` feeds displacement in mm and fits force in N.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from bpmid.errors import InputError
from bpmid.fitting import FitResult
from bpmid.io.motion_logs import MotionLog
from bpmid.models._hysteresis_kernels import play_bank
from bpmid.models.base import ModelFamily, check_fit_logs
from bpmid.params import Param, ParamSet
# Pa per bar: muscle logs carry gauge pressure in Pa, the baselines work in bar (well-conditioned)
from bpmid.units import PA_PER_BAR
# variable projection has one home (bpmid.varpro); the names stay importable from here
from bpmid.varpro import fit_variable_projection, solve_linear  # noqa: F401

ENVELOPES = ("tanh", "linear", "identity")
ORIENTATIONS = ("auto", "lag", "lead")
GRIDS = ("uniform", "quadratic")


def check_arrays(model: ModelFamily, us: Sequence[np.ndarray], ys: Sequence[np.ndarray], n_params: int) -> None:
    """Refuse signal pairs a model cannot be identified from (shapes, NaNs, too few samples)."""
    if not us or len(us) != len(ys):
        raise InputError(f"{model.name}: need as many output signals as input signals (got {len(us)} and {len(ys)})")
    total = 0
    for u, y in zip(us, ys):
        if u.shape != y.shape or u.ndim != 1:
            raise InputError(f"{model.name}: input and output must be 1-D of equal length, found {u.shape} and {y.shape}")
        if not (np.all(np.isfinite(u)) and np.all(np.isfinite(y))):
            raise InputError(f"{model.name}: the signals contain NaN or inf")
        total += u.size
    need = max(model.min_samples, 3 * n_params)
    if total < need:
        raise InputError(f"{model.name}: {total} samples are too few to identify the model "
                         f"({n_params} parameters; needs at least {need})")


# --------------------------------------------------------------------------------------------------
# envelopes
# --------------------------------------------------------------------------------------------------
def envelopes(params: ParamSet, v: np.ndarray, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """Rising and falling envelopes (gamma_l, gamma_r) at the inputs ``v`` (N,), in envelope units."""
    if kind == "identity":
        return v, v
    if kind == "linear":
        return v, params.value("gr_slope") * v + params.value("gr_offset")
    gl = params.value("gl_amp") * np.tanh(params.value("gl_slope") * v + params.value("gl_shift"))
    gr = (params.value("gr_amp") * np.tanh(params.value("gr_slope") * v + params.value("gr_shift"))
          + params.value("gr_offset"))
    return gl, gr


class GPIModel(ModelFamily):
    """Generalized Prandtl-Ishlinskii model (rate-independent hysteresis, no creep).

    Parameters
    ----------
    n_operators : int
        Number m of play operators (thresholds on a grid over the input range).
    envelope : {"tanh", "linear", "identity"}
        Envelope family; "identity" is the classical PI model.
    orientation : {"auto", "lag", "lead"}
        Loop orientation (module docstring); "auto" decides from the data at fit time.
    threshold_grid : {"uniform", "quadratic"}
        Spacing of the thresholds over half the input span.
    monotone : bool
        Constrain p0 >= 0: with sigma = +1 (lag) the output then never decreases while the input rises
        (module docstring). Default False (p0 free, as in the literature).
    input_unit, output_unit : str
        Units of the generic signals (``"bar"``/``"deg"`` for muscle logs, whose Pa are divided by PA_PER_BAR).
    """

    name = "gpi"
    label = "GPI"
    min_samples = 40

    def __init__(self, n_operators: int = 10, envelope: str = "tanh", *, orientation: str = "auto",
                 threshold_grid: str = "uniform", monotone: bool = False, input_unit: str = "bar",
                 output_unit: str = "deg"):
        if envelope not in ENVELOPES:
            raise InputError(f"unknown GPI envelope {envelope!r} (known: {', '.join(ENVELOPES)})", key="envelope")
        if orientation not in ORIENTATIONS:
            raise InputError(f"unknown orientation {orientation!r} (known: {', '.join(ORIENTATIONS)})",
                             key="orientation")
        if threshold_grid not in GRIDS:
            raise InputError(f"unknown threshold grid {threshold_grid!r} (known: {', '.join(GRIDS)})",
                             key="threshold_grid")
        self.orientation = orientation
        self.threshold_grid = threshold_grid
        self.monotone = bool(monotone)
        if int(n_operators) < 1:
            raise InputError(f"n_operators must be >= 1, found {n_operators}", key="n_operators")
        self.n_operators = int(n_operators)
        self.envelope = envelope
        self.input_unit = input_unit
        self.output_unit = output_unit

    # -- parameters -------------------------------------------------------------------------------
    @property
    def weight_names(self) -> list[str]:
        return [f"w{i + 1}" for i in range(self.n_operators)]

    @property
    def threshold_names(self) -> list[str]:
        return [f"r{i + 1}" for i in range(self.n_operators)]

    @property
    def linear_names(self) -> list[str]:
        return ["p0", "c"] + self.weight_names

    def _envelope_params(self, center: float, half_span: float) -> list[Param]:
        iu = self.input_unit
        if self.envelope == "identity":
            return []
        if self.envelope == "linear":
            return [Param("gr_slope", 1.0, "1", 0.05, 20.0),
                    Param("gr_offset", 0.0, iu, -10 * half_span, 10 * half_span)]
        # argument of tanh spans about +-0.5 over the input range: nearly linear start, room to saturate
        slope = 0.5 / half_span
        amp = half_span / np.tanh(0.5)
        out = []
        for side in ("gl", "gr"):
            out += [Param(f"{side}_amp", amp, iu, 1e-3 * half_span, 1e3 * half_span),
                    Param(f"{side}_slope", slope, f"1/{iu}", 1e-3 / half_span, 50.0 / half_span),
                    Param(f"{side}_shift", -slope * center, "1", -20.0, 20.0)]
        out.append(Param("gr_offset", 0.0, iu, -10 * half_span, 10 * half_span))
        return out

    def thresholds(self, half_span: float) -> np.ndarray:
        """Threshold grid (m,) over ``half_span`` (input unit)."""
        frac = np.arange(1, self.n_operators + 1) / self.n_operators
        return half_span * (frac if self.threshold_grid == "uniform" else frac ** 2)

    def _params_for_range(self, lo: float, hi: float, weights: np.ndarray, p0: float, c: float,
                          sign: float = 1.0) -> ParamSet:
        iu, ou = self.input_unit, self.output_unit
        center, half = 0.5 * (lo + hi), max(0.5 * (hi - lo), 1e-12)
        ps = [Param("p0", p0, f"{ou}/{iu}"), Param("c", c, ou)]
        ps += [Param(n, float(w), f"{ou}/{iu}", 0.0, np.inf) for n, w in zip(self.weight_names, weights)]
        ps += [Param(n, float(r), iu, 0.0, np.inf, fixed=True) for n, r in zip(self.threshold_names,
                                                                                self.thresholds(half))]
        ps.append(Param("loop_sign", sign, "1", -1.0, 1.0, fixed=True))
        return ParamSet(ps + self._envelope_params(center, half))

    def default_params(self) -> ParamSet:
        """Start for a muscle log (0.2-1.2 bar gauge, 10-80 deg): decreasing weights, mild tanh envelopes."""
        m = self.n_operators
        weights = 60.0 / m * np.exp(-np.arange(m) / max(m / 3.0, 1.0))
        return self._params_for_range(0.2, 1.2, weights, p0=40.0, c=25.0,
                                      sign=-1.0 if self.orientation == "lead" else 1.0)

    # -- simulation -------------------------------------------------------------------------------
    def operator_outputs(self, params: ParamSet, u: np.ndarray) -> np.ndarray:
        """Play operator outputs z (N, m) for the input ``u`` (N,) in ``input_unit``.

        The operators start at the mid-point of the envelopes at the first sample (0 for the
        classical PI started at u = 0), i.e. relaxed.
        """
        v = np.ascontiguousarray(u, float)
        gl, gr = envelopes(params, v, self.envelope)
        r = np.array([params.value(n) for n in self.threshold_names], float)
        z0 = np.full(r.size, 0.5 * (gl[0] + gr[0]) if v.size else 0.0)
        return play_bank(np.ascontiguousarray(gl, float), np.ascontiguousarray(gr, float), r, z0)

    def design(self, params: ParamSet, u: np.ndarray) -> np.ndarray:
        """Design matrix (N, m + 2) with columns [v, 1, sigma z_1..sigma z_m] for the linear coefficients (p0, c, w)."""
        v = np.asarray(u, float)
        return np.column_stack([v, np.ones_like(v), params.value("loop_sign") * self.operator_outputs(params, v)])

    def simulate_arrays(self, params: ParamSet, u: np.ndarray) -> np.ndarray:
        """Output (N,) in ``output_unit`` for the input ``u`` (N,) in ``input_unit``."""
        theta = np.array([params.value(n) for n in self.linear_names], float)
        return self.design(params, u) @ theta

    def simulate(self, params: ParamSet, log: MotionLog) -> np.ndarray:
        """Bending angle (deg), shape (log.n,), from the gauge pressure (Pa -> bar)."""
        return self.simulate_arrays(params, log.pressure_pa / PA_PER_BAR)

    # -- identification ---------------------------------------------------------------------------
    def initial_guess_arrays(self, us: Sequence[np.ndarray], params: ParamSet,
                             ys: Sequence[np.ndarray] | None = None) -> ParamSet:
        """Thresholds and envelope start from the input range; with ``orientation="auto"`` and outputs
        ``ys`` given, the loop sign whose NNLS solve fits better (the linear coefficients themselves are
        solved inside the fit)."""
        lo = min(float(np.min(u)) for u in us)
        hi = max(float(np.max(u)) for u in us)
        if not hi > lo:
            raise InputError(f"{self.name}: the input is constant; a hysteresis model cannot be identified")
        sign = -1.0 if self.orientation == "lead" else 1.0
        fresh = self._params_for_range(lo, hi, np.zeros(self.n_operators), 0.0, 0.0, sign)
        if self.orientation == "auto" and ys is not None:
            y = np.concatenate(ys)
            nonneg = np.arange(self.n_operators + 2) >= 2
            nonneg[0] = self.monotone
            sse = {}
            for s in (1.0, -1.0):
                a = np.vstack([self.design(fresh.replace("loop_sign", value=s), u) for u in us])
                sse[s] = float(np.sum((a @ solve_linear(a, y, nonneg) - y) ** 2))
            fresh = fresh.replace("loop_sign", value=min(sse, key=sse.get))
        keep = {p.name: p for p in params}
        # settings of the given set survive (fixed flags), the data-dependent grid is recomputed
        out = []
        for p in fresh:
            q = keep.get(p.name)
            out.append(p if q is None or not q.fixed or p.name in self.threshold_names + ["loop_sign"] else q)
        return ParamSet(out)

    def initial_guess(self, logs: Sequence[MotionLog], params: ParamSet) -> ParamSet:
        ys = [lg.angle_deg for lg in logs] if all(lg.angle_deg is not None for lg in logs) else None
        return self.initial_guess_arrays([lg.pressure_pa / PA_PER_BAR for lg in logs], params, ys)

    def fit_arrays(self, us: Sequence[np.ndarray], ys: Sequence[np.ndarray], params: ParamSet | None = None,
                   **fit_kw) -> FitResult:
        """Variable projection fit on generic signals (see module docstring).

        Parameters
        ----------
        us, ys : sequences of (N_j,) input (``input_unit``) and output (``output_unit``) signals; each
            pair is simulated from a relaxed start.
        params : optional start (settings such as fixed flags); thresholds follow the data range.
        """
        us = [np.asarray(u, float) for u in us]
        ys = [np.asarray(y, float) for y in ys]
        check_arrays(self, us, ys, 2 * self.n_operators + 2)
        start = self.initial_guess_arrays(us, self.default_params() if params is None else params, ys)

        def design_fn(p: ParamSet) -> np.ndarray:
            return np.vstack([self.design(p, u) for u in us])

        nonneg = [self.monotone, False] + [True] * self.n_operators
        # each outer evaluation is a full simulation plus a BVLS solve: bound the cost on long real logs
        fit_kw.setdefault("max_nfev", 60 * (len(start.free()) - self.n_operators - 2 + 1))
        fit_kw.setdefault("prior_from_data", True)   # the start is the data's, not knowledge
        return fit_variable_projection(design_fn, np.concatenate(ys), start, self.linear_names, nonneg,
                                       segments=[u.size for u in us], **fit_kw)

    def fit(self, logs: Sequence[MotionLog], params: ParamSet | None = None, **fit_kw) -> FitResult:
        """Fit on motion logs (gauge pressure -> angle), all at once; see :meth:`fit_arrays`."""
        check_fit_logs(self, logs)
        return self.fit_arrays([lg.pressure_pa / PA_PER_BAR for lg in logs], [lg.angle_deg for lg in logs],
                               params, **fit_kw)

    def describe(self, params: ParamSet) -> dict:
        out = super().describe(params)
        out["settings"] = {"n_operators": self.n_operators, "envelope": self.envelope,
                           "orientation": self.orientation, "threshold_grid": self.threshold_grid,
                           "monotone": self.monotone,
                           "input_unit": self.input_unit, "output_unit": self.output_unit}
        return out
