"""The interface every model family implements (pressure in, bending angle out).

A family declares its default parameters (names, units, bounds) and how to simulate a log; it may
offer a cheap data-driven initial guess. Fitting, metrics, results and plots are shared code that
works for every registered family (:func:`ModelFamily.fit` uses :func:`bpmid.fitting.fit_least_squares`).
Constructors store settings only. Adding a family is one new file plus one line in
:data:`bpmid.models.REGISTRY`.
"""
from __future__ import annotations

import abc
from typing import ClassVar, Sequence

import numpy as np

from bpmid.errors import InputError
from bpmid.fitting import FitResult, fit_least_squares
from bpmid.io.motion_logs import MotionLog
from bpmid.params import ParamSet


class ModelFamily(abc.ABC):
    """A model of a bending muscle: gauge pressure (Pa) in, bending angle (deg) out.

    Subclasses set :attr:`name` (the registry name, e.g. ``"gpi"``) and :attr:`label` (for plots),
    and implement :meth:`default_params` and :meth:`simulate`.
    """

    name: ClassVar[str] = ""
    label: ClassVar[str] = ""
    #: smallest number of samples a fit needs (logs shorter in total are refused with a message)
    min_samples: ClassVar[int] = 20
    #: the fit starts from the training data (an equation-error fit): a constant held there as not identifiable
    #: still came from the data and counts in :meth:`n_params`. False where the start is prior knowledge (the
    #: VBMM's relaxation constants): a constant held at it was not estimated from these logs.
    start_from_data: ClassVar[bool] = True

    @abc.abstractmethod
    def default_params(self) -> ParamSet:
        """Starting parameters with units and bounds (also the priors for identifiability)."""

    @abc.abstractmethod
    def simulate(self, params: ParamSet, log: MotionLog) -> np.ndarray:
        """Free-running prediction of the angle (deg), shape (log.n,), from the log's pressure only."""

    def initial_guess(self, logs: Sequence[MotionLog], params: ParamSet) -> ParamSet:
        """A cheap start from data (linear least squares where the model allows it). Default: ``params``."""
        return params

    def residual(self, params: ParamSet, logs: Sequence[MotionLog]) -> np.ndarray:
        """Concatenated prediction minus measurement over all logs (deg)."""
        return np.concatenate([self.simulate(params, lg) - lg.angle_deg for lg in logs])

    def fit(self, logs: Sequence[MotionLog], params: ParamSet | None = None, **fit_kw) -> FitResult:
        """Fit on ``logs`` (all at once): initial guess, then least squares on the angle error."""
        check_fit_logs(self, logs)
        params = self.default_params() if params is None else params
        params = self.initial_guess(logs, params)
        fit_kw.setdefault("prior_from_data", self.start_from_data)
        return fit_least_squares(lambda p: self.residual(p, logs), params,
                                 segments=[lg.n for lg in logs], **fit_kw)

    def n_params(self, params: ParamSet) -> int:
        """Number of constants estimated from the training data: the free ones, and those held as not identifiable
        at a start computed from the same data (:attr:`start_from_data`). Settings fixed by design are not counted."""
        held = [p for p in params if p.fixed and p.identifiable is False] if self.start_from_data else []
        return len(params.free()) + len(held)

    def describe(self, params: ParamSet) -> dict:
        """Parameters as YAML (``{name: {value, stderr, unit}}``) plus the family's settings."""
        return {"model": self.name, "parameters": params.to_yaml()}


def check_fit_logs(model: ModelFamily, logs: Sequence[MotionLog]) -> None:
    """Refuse logs a model cannot be identified from (no angle, too short)."""
    if not logs:
        raise InputError(f"{model.name}: no training logs")
    for lg in logs:
        if lg.angle_deg is None:
            raise InputError(f"{model.name}: a training log needs an angle_deg column", path=lg.path)
    total = sum(lg.n for lg in logs)
    if total < model.min_samples:
        raise InputError(f"{model.name}: {total} samples are too few to identify the model "
                         f"(needs at least {model.min_samples})",
                         path=logs[0].path if len(logs) == 1 else None)
