"""Synthetic uniaxial stress-relaxation tests (ramp and hold), as an Instron logs them.

The crosshead moves at a constant rate from rest to the strain level, then holds. The specimen is
linear viscoelastic with a Prony relaxation modulus; its nominal stress is the hereditary integral
of the strain history, evaluated here in closed form for the linear ramp (independent of the
recursions the fits use). The machine logs crosshead extension (quantised to the encoder
resolution) and load with load-cell noise: white Gaussian noise passed through a first-order filter
(the instrument's anti-alias filter makes neighbouring samples correlated) and quantised.
"""
from __future__ import annotations

import dataclasses
from typing import Sequence

import numpy as np
import pandas as pd


@dataclasses.dataclass(frozen=True)
class PronyTruth:
    """A Prony relaxation modulus E(t) = E_inf + sum_j E_j exp(-t/tau_j).

    Attributes
    ----------
    E_inf_mpa : float, MPa
    E_mpa : tuple of float, MPa, one per branch
    tau_s : tuple of float, s, one per branch
    """

    E_inf_mpa: float = 0.0272
    E_mpa: tuple[float, ...] = (0.0549,)
    tau_s: tuple[float, ...] = (0.399,)

    def __post_init__(self):
        if len(self.E_mpa) != len(self.tau_s):
            raise ValueError("E_mpa and tau_s need one entry per branch")
        if self.E_inf_mpa < 0 or any(e < 0 for e in self.E_mpa) or any(t <= 0 for t in self.tau_s):
            raise ValueError("moduli must be >= 0 and time constants > 0")

    def modulus(self, t) -> np.ndarray:
        """E(t) in MPa for (N,) times t (s)."""
        t = np.asarray(t, float)
        return self.E_inf_mpa + np.exp(-t[:, None] / np.asarray(self.tau_s)[None, :]) @ np.asarray(self.E_mpa)

    def scaled(self, modulus_factor: float = 1.0, tau_factor: float = 1.0) -> "PronyTruth":
        """All moduli times ``modulus_factor``, all time constants times ``tau_factor``."""
        return PronyTruth(self.E_inf_mpa * modulus_factor, tuple(e * modulus_factor for e in self.E_mpa),
                          tuple(t * tau_factor for t in self.tau_s))


@dataclasses.dataclass(frozen=True)
class RelaxationTest:
    """One ramp-and-hold test on a tensile machine.

    Attributes
    ----------
    crosshead_mm_per_min : crosshead speed during the ramp (mm/min)
    strain_level : engineering strain held (dimensionless, 0.15 = 15 %)
    gauge_length_mm : specimen gauge length (mm); strain = extension / gauge length
    cross_section_mm2 : specimen cross-section (mm^2); nominal stress = load / cross-section
    hold_s : hold duration after the ramp (s)
    pre_s : logged time at rest before the ramp starts (s)
    rate_hz : logging rate (Hz)
    load_noise_n : standard deviation of the load-cell noise (N)
    load_noise_corr : lag-1 correlation of the load noise (first-order filter pole, 0 = white)
    load_resolution_n : load quantisation step (N), 0 for none
    extension_resolution_mm : extension quantisation step (mm), 0 for none
    """

    crosshead_mm_per_min: float = 300.0
    strain_level: float = 0.25
    gauge_length_mm: float = 50.0
    cross_section_mm2: float = 12.0
    hold_s: float = 60.0
    pre_s: float = 0.5
    rate_hz: float = 50.0
    load_noise_n: float = 0.002
    load_noise_corr: float = 0.5
    load_resolution_n: float = 0.0001
    extension_resolution_mm: float = 0.001

    @property
    def strain_rate(self) -> float:
        """Engineering strain rate of the ramp (1/s)."""
        return self.crosshead_mm_per_min / 60.0 / self.gauge_length_mm

    @property
    def ramp_s(self) -> float:
        """Ramp duration (s)."""
        return self.strain_level / self.strain_rate


def ramp_hold_stress(t, test: RelaxationTest, truth: PronyTruth) -> tuple[np.ndarray, np.ndarray]:
    """Noise-free strain and nominal stress of a ramp-and-hold test, in closed form.

    Parameters
    ----------
    t : (N,) times (s), the ramp starting at ``test.pre_s``

    Returns
    -------
    strain : (N,) dimensionless
    stress : (N,) MPa
    """
    t = np.asarray(t, float)
    r, tr = test.strain_rate, test.ramp_s
    s = np.clip(t - test.pre_s, 0.0, None)          # time since the ramp started
    strain = r * np.minimum(s, tr)
    tau = np.asarray(truth.tau_s, float)[None, :]
    E = np.asarray(truth.E_mpa, float)
    # sigma(s) = r int_0^min(s,tr) E(s - u) du
    lo = np.clip(s - tr, 0.0, None)[:, None]        # age of the end of the ramp (0 during the ramp)
    branch = tau * (np.exp(-lo / tau) - np.exp(-s[:, None] / tau))
    stress = r * (truth.E_inf_mpa * np.minimum(s, tr) + branch @ E)
    return strain, stress


def simulate_relaxation_test(test: RelaxationTest, truth: PronyTruth, rng: np.random.Generator) -> pd.DataFrame:
    """Simulate what the machine logs in one ramp-and-hold test.

    Parameters
    ----------
    test : the test description
    truth : the specimen's relaxation modulus
    rng : the random generator (seeded by the caller, who records the seed)

    Returns
    -------
    DataFrame with columns ``time_s``, ``extension_mm``, ``load_n`` (as logged: quantised, noisy) and
    ``strain``, ``stress_mpa`` (the same data reduced with the gauge length and cross-section)
    """
    n = int(round((test.pre_s + test.ramp_s + test.hold_s) * test.rate_hz)) + 1
    t = np.arange(n) / test.rate_hz
    strain, stress = ramp_hold_stress(t, test, truth)
    ext = strain * test.gauge_length_mm
    load = stress * test.cross_section_mm2
    a = float(test.load_noise_corr)
    white = rng.standard_normal(n)
    # first-order filter, scaled so the noise keeps the requested standard deviation
    from scipy.signal import lfilter  # here: importing scipy.signal costs 0.9 s

    noise = lfilter([np.sqrt(1.0 - a * a)], [1.0, -a], white) * test.load_noise_n
    load = load + noise
    if test.load_resolution_n > 0:
        load = np.round(load / test.load_resolution_n) * test.load_resolution_n
    if test.extension_resolution_mm > 0:
        ext = np.round(ext / test.extension_resolution_mm) * test.extension_resolution_mm
    return pd.DataFrame({"time_s": t, "extension_mm": ext, "load_n": load,
                         "strain": ext / test.gauge_length_mm, "stress_mpa": load / test.cross_section_mm2})


def paper_protocol(rates_mm_per_min: Sequence[float] = (300.0, 400.0),
                   strain_levels: Sequence[float] = (0.15, 0.20, 0.25, 0.30, 0.35, 0.40),
                   **kw) -> list[RelaxationTest]:
    """The paper's tests: every crosshead rate at every strain level (keyword arguments go to each test)."""
    return [RelaxationTest(crosshead_mm_per_min=r, strain_level=e, **kw)
            for r in rates_mm_per_min for e in strain_levels]
