"""Sensor models of the rig: what the logged angle and pressure add to the true ones.

Angle (deg): a slow zero drift (Ornstein-Uhlenbeck, stationary std ``angle_drift_deg``, correlation time
``angle_drift_time_s``, starting at 0 because the sensor is zeroed before each run), white noise
``angle_noise_deg``, then quantisation to ``angle_resolution_deg``.
Pressure (bar): white noise ``pressure_noise_bar``, then quantisation to ``pressure_resolution_bar``.
A value of 0 switches that part off. Every draw comes from the numpy Generator passed in.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from bpmid.errors import InputError


@dataclasses.dataclass(frozen=True)
class Sensors:
    """Protocol section ``sensors`` (all default 0: ideal sensors)."""

    angle_noise_deg: float = 0.0
    angle_resolution_deg: float = 0.0
    angle_drift_deg: float = 0.0
    angle_drift_time_s: float = 30.0
    pressure_noise_bar: float = 0.0
    pressure_resolution_bar: float = 0.0

    def validate(self, where, path):
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if not (math.isfinite(v) and v >= 0):
                raise InputError(f"must not be negative, found {v!r}", path=path, key=f"{where}.{f.name}")
        if self.angle_drift_time_s <= 0:
            raise InputError("must be positive", path=path, key=f"{where}.angle_drift_time_s")

    def noise_floor_deg(self) -> float:
        """RMS of the angle sensor error (white + drift + quantisation), deg."""
        return math.sqrt(self.angle_noise_deg**2 + self.angle_drift_deg**2 + self.angle_resolution_deg**2 / 12.0)


def quantise(x: np.ndarray, step: float) -> np.ndarray:
    return x if step <= 0 else np.round(x / step) * step


def ou_drift(t: np.ndarray, std: float, tau: float, rng: np.random.Generator) -> np.ndarray:
    """Ornstein-Uhlenbeck path (exact discretisation), x(t0) = 0, stationary std ``std``."""
    z = rng.standard_normal(t.size)
    x = np.zeros(t.size)
    if std <= 0:
        return x
    a = np.exp(-np.diff(t) / tau)
    for k in range(1, t.size):
        x[k] = a[k - 1] * x[k - 1] + std * math.sqrt(1.0 - a[k - 1] ** 2) * z[k]
    return x


def read_angle(t: np.ndarray, angle_deg: np.ndarray, s: Sensors, rng: np.random.Generator) -> np.ndarray:
    """The logged angle (deg) for the true angle (deg)."""
    drift = ou_drift(t, s.angle_drift_deg, s.angle_drift_time_s, rng)
    white = s.angle_noise_deg * rng.standard_normal(t.size)
    return quantise(angle_deg + drift + white, s.angle_resolution_deg)


def read_pressure(p_bar: np.ndarray, s: Sensors, rng: np.random.Generator) -> np.ndarray:
    """The logged pressure (bar, same reference as given) for the true pressure (bar)."""
    white = s.pressure_noise_bar * rng.standard_normal(p_bar.size)
    return quantise(p_bar + white, s.pressure_resolution_bar)
