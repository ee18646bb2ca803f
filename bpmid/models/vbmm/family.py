"""The VBMM as two model families of :data:`bpmid.models.REGISTRY` (used by ``bpmid compare``).

- ``vbmm-mat`` (:class:`VBMMMatModel`): material constants straight from a relaxation fit (G from
  ``shear``, K from ``bulk``) or the paper's VBMM-mat constants. Nothing is refitted on motion data: its
  :meth:`~VBMMMatModel.fit` only evaluates the training logs (no free parameters).
- ``vbmm-fit`` (:class:`VBMMFitModel`): the same start, refitted on the training logs by
  :func:`bpmid.models.vbmm.fit.fit_motion` (linear start in pressure space, then least squares on the angle
  error, identifiability verdicts).

Both take ``relax_fit`` (a ``bpmid.relax/1`` path, its loaded mapping, or a
:class:`~bpmid.models.vbmm.Material`; None: the config's ``motion.relax_fit`` or the paper) and ``config``
(a :class:`bpmid.config.Config`: sections ``model`` for closure/history/geometry and ``motion`` for the fit).

Units: gauge Pa in, degrees out; constants in Pa and s.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from bpmid.errors import InputError
from bpmid.fitting import FitResult, fit_least_squares
from bpmid.io.motion_logs import MotionLog
from bpmid.models.base import ModelFamily, check_fit_logs
from bpmid.models.vbmm import VBMM, VBMMConfig
from bpmid.models.vbmm.model import material_at_step
from bpmid.models.vbmm.fit import (MotionFit, MotionFitConfig, check_angle_range, check_pressure_range, fit_motion,
                              initial_material, linear_start, material_from_params, params_from_material)
from bpmid.params import ParamSet


class _VBMMBase(ModelFamily):
    """Shared settings and simulation of both VBMM families."""

    min_samples = 20
    start_from_data = False   # the start is the relaxation test's constants (or the paper's): prior knowledge

    def __init__(self, relax_fit=None, config=None):
        self.relax_fit = relax_fit
        self.config = config
        self.model_cfg: VBMMConfig = config.section("model") if config is not None else VBMMConfig()
        self.motion_cfg: MotionFitConfig = config.section("motion") if config is not None else MotionFitConfig()
        self._base_cache: VBMM | None = None

    def initial_material(self):
        base_dir = None if self.config is None else self.config.base_dir
        return initial_material(self.motion_cfg, self.relax_fit, base_dir=base_dir)

    def vbmm(self, params: ParamSet) -> VBMM:
        """The :class:`VBMM` of a parameter set (closure, history, geometry from the config)."""
        if self._base_cache is None:
            self._base_cache = VBMM.from_config(material_from_params(params), self.model_cfg)
            return self._base_cache
        return self._base_cache.replace(material=material_from_params(params))

    def simulate(self, params: ParamSet, log: MotionLog) -> np.ndarray:
        """Forward model angle (deg), shape (log.n,); InputError if a pressure is beyond the model's range."""
        return self.vbmm_for(params, log).forward_deg(log.time_s, log.pressure_pa, name=log.name, path=log.path)

    def vbmm_for(self, params: ParamSet, log: MotionLog) -> VBMM:
        """The :class:`VBMM` that runs on ``log`` (the parameter set's, whatever the log)."""
        return self.vbmm(params)

    def describe(self, params: ParamSet) -> dict:
        out = super().describe(params)
        m = self.vbmm(params)
        out.update({"closure": m.closure, "history": m.history, "window_s": m.window_s,
                    "geometry": m.geometry.to_yaml()})
        return out


class VBMMMatModel(_VBMMBase):
    """VBMM with relaxation-test constants, not refitted on motion data.

    Parameters
    ----------
    relax_fit : path / mapping of a ``bpmid.relax/1`` fit, or a Material; None: ``motion.relax_fit`` of the
        config or the paper's VBMM-mat constants
    config : :class:`bpmid.config.Config` or None

    Examples
    --------
    >>> m = VBMMMatModel()                      # doctest: +SKIP
    >>> res = m.fit(train_logs)                 # evaluates only; res.params are all fixed
    >>> angle_deg = m.simulate(res.params, test_log)
    """

    name = "vbmm-mat"
    label = "VBMM-mat."

    def __init__(self, relax_fit=None, config=None, at_log_step: bool = False):
        super().__init__(relax_fit, config)
        if not isinstance(at_log_step, bool):
            raise InputError(f"must be true or false, found {at_log_step!r}", key="at_log_step")
        self.at_log_step = at_log_step

    def default_params(self) -> ParamSet:
        mat, _source = self.initial_material()
        return params_from_material(mat, self.motion_cfg, all_fixed=True)

    def vbmm_for(self, params: ParamSet, log: MotionLog) -> VBMM:
        """With ``at_log_step`` the relaxation test's constants, a material in continuous time, run as that material
        in the sum sampled at the log's (median) step: each branch modulus divided by
        :func:`~bpmid.models.vbmm.model.continuous_factor` of the step and its time constant (exact for a strain
        linear between samples; docs/model.md)."""
        model = self.vbmm(params)
        if self.at_log_step and log.n > 1:
            model = model.replace(material=material_at_step(model.material, float(np.median(np.diff(log.time_s)))))
        return model

    def describe(self, params: ParamSet) -> dict:
        out = super().describe(params)
        out["at_log_step"] = self.at_log_step
        if self.at_log_step:
            out["at_log_step_note"] = ("the relaxation constants hold in continuous time; each log runs them in the "
                                       "sum sampled at its own step, each branch modulus divided by (dt/tau) / "
                                       "(1 - exp(-dt/tau))")
        return out

    def fit(self, logs: Sequence[MotionLog], params: ParamSet | None = None, **fit_kw) -> FitResult:
        """No refit: the residual of the relaxation constants on ``logs`` (every parameter fixed)."""
        check_fit_logs(self, logs)
        for lg in logs:
            check_angle_range(lg, self.motion_cfg.angle_tolerance_deg)
            check_pressure_range(lg)
        params = self.default_params() if params is None else params
        for name in params.names():
            params = params.replace(name, fixed=True)
        return fit_least_squares(lambda p: self.residual(p, logs), params, segments=[lg.n for lg in logs])


class VBMMFitModel(_VBMMBase):
    """VBMM refitted on motion data (the paper's VBMM-fit), by :func:`bpmid.models.vbmm.fit.fit_motion`.

    Parameters
    ----------
    relax_fit, config : as :class:`VBMMMatModel`; free/fixed/bounded parameters come from ``motion``

    Attributes
    ----------
    result : the :class:`~bpmid.models.vbmm.fit.MotionFit` of the last :meth:`fit` (metrics, verdicts), or None

    Examples
    --------
    >>> m = VBMMFitModel(relax_fit="relax.yaml")   # doctest: +SKIP
    >>> res = m.fit(train_logs)                    # res.params: fitted, stderr, identifiable flags
    >>> angle_deg = m.simulate(res.params, test_log)
    """

    name = "vbmm-fit"
    label = "VBMM-fit"

    def __init__(self, relax_fit=None, config=None):
        super().__init__(relax_fit, config)
        self.result: MotionFit | None = None

    def default_params(self) -> ParamSet:
        mat, _source = self.initial_material()
        return params_from_material(mat, self.motion_cfg)

    def initial_guess(self, logs: Sequence[MotionLog], params: ParamSet) -> ParamSet:
        base = VBMM.from_config(material_from_params(params), self.model_cfg)
        return linear_start(logs, params, base, self.motion_cfg)[0]

    def fit(self, logs: Sequence[MotionLog], params: ParamSet | None = None, **fit_kw) -> FitResult:
        """Refit on ``logs`` (all at once); ``fit_kw`` is accepted for interface compatibility and ignored
        (the thresholds come from the config section ``motion``)."""
        check_fit_logs(self, logs)
        if params is None:
            self.result = fit_motion(logs, config=self.config, init=self.relax_fit)
        else:
            self.result = fit_motion(logs, config=self.config, params=params)
        return self.result.fit


__all__ = ["VBMMMatModel", "VBMMFitModel"]
