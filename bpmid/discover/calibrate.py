"""Thresholds of the discovery loop, calibrated on simulated data (never tuned by hand to one case).

The committed file ``bpmid/discover/thresholds.yaml`` holds the calibrated values; it is written by

    python benchmarks/bench_discover.py --calibrate

which simulates paper-sized data sets (:func:`paper_sized_set`) with each catalogue effect injected at several
sizes, seeds and noise levels (in the twin's variants of the physics, not the model terms' form) plus null data
with no effect, runs the loop with permissive thresholds, and places each threshold between what null
candidates reach and what true effects reach (:func:`thresholds_from_records`). The same script then
evaluates the calibrated loop on fresh seeds and prints the confusion matrix and the false-positive rate.
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Sequence

import numpy as np
import yaml

from bpmid.effects.base import AugmentedVBMM, Effect
from bpmid.io.motion_logs import ATMOSPHERE_PA, MotionLog, from_arrays
from bpmid.models.vbmm import VBMM, Material
from bpmid.params import ParamSet

THRESHOLDS_PATH = Path(__file__).with_name("thresholds.yaml")
THRESHOLD_KEYS = ("heldout_gain_min_sigma", "delta_bic_max")
SCHEMA = "bpmid.discover-thresholds/1"


def load_thresholds(path: str | Path | None = None) -> dict:
    """The calibrated thresholds (``heldout_gain_min_sigma``, ``delta_bic_max``)."""
    path = Path(path) if path else THRESHOLDS_PATH
    from bpmid.io.yamlsafe import loads

    data = loads(path.read_text("utf-8"), path=path)
    if not isinstance(data, dict) or data.get("schema") != SCHEMA:
        raise RuntimeError(f"{path}: not a {SCHEMA} file")
    return {k: float(data[k]) for k in THRESHOLD_KEYS}


# ---------------------------------------------------------------------------------------------
# simulated data sets (paper-sized: EXPERIMENTS.md protocols, 10 Hz)
# ---------------------------------------------------------------------------------------------
def _profile(segments: Sequence[tuple[float, float]], p0: float, dt: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """Piecewise-linear absolute pressure (bar): segments of (target bar, rate bar/s or 0 = hold seconds)."""
    t, p = [0.0], [p0]
    for target, how in segments:
        if how == 0:
            raise ValueError("use (level, -seconds) for holds")
        if how < 0:  # hold for -how seconds
            n = int(round(-how / dt))
            t += [t[-1] + dt * (k + 1) for k in range(n)]
            p += [p[-1]] * n
        else:
            dur = abs(target - p[-1]) / how
            n = max(int(round(dur / dt)), 1)
            start = p[-1]
            t += [t[-1] + dt * (k + 1) for k in range(n)]
            p += [start + (target - start) * (k + 1) / n for k in range(n)]
    return np.array(t), np.array(p)


def _triangles(lo, hi, rate, cycles, hold=0.0):
    seg = []
    for _ in range(cycles):
        seg.append((hi, rate))
        if hold:
            seg.append((hi, -hold))
        seg.append((lo, rate))
        if hold:
            seg.append((lo, -hold))
    return seg


#: name -> (segments, start bar); fitting set first, then the held-out logs
PROTOCOLS = {
    "fit_cyclic_1.6": (_triangles(1.2, 1.6, 0.2, 8), 1.2),
    "va_1.8": (_triangles(1.2, 1.8, 0.2, 4, hold=2.0), 1.2),
    "va_2.2": (_triangles(1.2, 2.2, 0.2, 3, hold=2.0), 1.2),
    "vr_0.114": (_triangles(1.2, 2.0, 0.114, 3), 1.2),
    "vr_0.267": (_triangles(1.2, 2.0, 0.267, 6), 1.2),
    "hold_2.0": ([(2.0, 0.4), (2.0, -20.0), (1.2, 0.4), (1.2, -10.0), (1.8, 0.4), (1.8, -15.0)], 1.2),
    "long_1.8": (_triangles(1.2, 1.8, 0.2, 40), 1.2),
    "ho_va_2.0": (_triangles(1.2, 2.0, 0.2, 4, hold=2.0), 1.2),
    "ho_vr_0.16": (_triangles(1.2, 2.0, 0.16, 4), 1.2),
    "ho_mixed": ([(1.8, 0.2), (1.8, -10.0), (1.4, 0.3), (2.1, 0.15), (1.2, 0.25), (1.2, -5.0), (2.0, 0.2),
                  (2.0, -8.0), (1.3, 0.2)], 1.2),
    "ho_long_2.0": (_triangles(1.2, 2.0, 0.2, 25), 1.2),
}
HELDOUT = ("ho_va_2.0", "ho_vr_0.16", "ho_mixed", "ho_long_2.0")


def truth_model() -> VBMM:
    """The simulated muscle: the paper's VBMM-fit constants."""
    return VBMM(material=Material.paper_fit())


def start_model() -> VBMM:
    """Where discovery starts on simulated data: the relaxation-test constants (not the truth)."""
    return VBMM(material=Material.paper_mat())


def scaled_params(effect: Effect, size: float) -> ParamSet:
    """The effect's parameters moved from absent (null values) towards the default by ``size`` (1 = default)."""
    ps = effect.default_params()
    null = effect.null_values()
    vals = {}
    for p in ps:
        if p.name in null:
            vals[p.name] = null[p.name] + size * (p.value - null[p.name])
    return ps.with_values(vals) if vals else ps


def paper_sized_set(effect: Effect | None, *, size: float = 1.0, seed: int = 0, noise_deg: float = 0.15,
                    noise_rho: float = 0.0, truth: VBMM | None = None, protocols: dict | None = None
                    ) -> tuple[list[MotionLog], list[MotionLog]]:
    """Fitting logs and held-out logs simulated with ``effect`` hidden (None: no effect).

    Noise: AR(1) Gaussian with standard deviation ``noise_deg`` and lag-1 correlation ``noise_rho``, seeded.
    """
    rng = np.random.default_rng(seed)
    truth = truth or truth_model()
    aug = AugmentedVBMM(truth, (effect,), scaled_params(effect, size)) if effect is not None else AugmentedVBMM(truth)
    fit, ho = [], []
    for name, (seg, p0) in (protocols or PROTOCOLS).items():
        t, pbar = _profile(seg, p0)
        pg = pbar * 1e5 - ATMOSPHERE_PA
        beta = aug.simulate_deg(t, pg, name=name)
        w = rng.normal(0.0, noise_deg * math.sqrt(1 - noise_rho**2), t.size)
        e = np.empty_like(w)
        e[0] = rng.normal(0.0, noise_deg)
        for k in range(1, t.size):
            e[k] = noise_rho * e[k - 1] + w[k]
        lg = from_arrays(name, t, pg, beta + e)
        (ho if name in HELDOUT else fit).append(lg)
    return fit, ho


# ---------------------------------------------------------------------------------------------
# calibration
# ---------------------------------------------------------------------------------------------
@dataclasses.dataclass
class Record:
    """One confirmed candidate in a calibration run."""

    truth: str            # injected effect id, or "none"
    round: int            # 1-based
    candidate: str
    gain_sigma: float
    delta_bic: float
    truth_in_model: bool  # the injected effect was already added before this round


def records_from_result(truth: str, result) -> list[Record]:
    out = []
    named_before: list[str] = []
    for k, rnd in enumerate(result.rounds, start=1):
        for c in rnd.confirmations:
            out.append(Record(truth, k, c.effect_id, float(c.heldout_gain_sigma), float(c.delta_bic),
                              truth in named_before))
        if rnd.accepted:
            named_before.append(rnd.accepted)
    return out


def _split(pos: np.ndarray, neg: np.ndarray, higher_is_positive: bool) -> float:
    """A threshold between negatives and positives: midpoint when they separate, else the value that
    misclassifies the fewest (ties: fewer false positives)."""
    if not higher_is_positive:
        return -_split(-pos, -neg, True)
    if pos.size == 0:
        return float(np.max(neg)) + 1.0
    if neg.size == 0:
        return float(np.min(pos)) - 1.0
    lo_pos, hi_neg = float(np.min(pos)), float(np.max(neg))
    if hi_neg < lo_pos:
        return 0.5 * (hi_neg + lo_pos)
    cands = np.unique(np.concatenate([pos, neg]))
    best, best_cost = cands[0], math.inf
    for c in cands:
        fp = np.sum(neg >= c)
        fn = np.sum(pos < c)
        cost = fp * 1.001 + fn
        if cost < best_cost:
            best, best_cost = c, cost
    return float(best)


def thresholds_from_records(records: Sequence[Record]) -> dict:
    """Positives: the injected effect confirmed in round 1. Negatives: every candidate on null data, and every
    candidate in a later round once the injected effect is in the model."""
    pos = [r for r in records if r.truth != "none" and r.round == 1 and r.candidate == r.truth]
    neg = [r for r in records if r.truth == "none" or r.truth_in_model]
    gain = _split(np.array([r.gain_sigma for r in pos]), np.array([r.gain_sigma for r in neg]), True)
    # delta BIC: the held-out gain does the separating; BIC has to keep every true effect with a margin (half the
    # weakest true effect's delta BIC) and at least ask for "very strong" evidence (delta BIC <= -10, Kass-Raftery)
    pos_bic = np.array([r.delta_bic for r in pos])
    bic = min(-10.0, 0.5 * float(np.max(pos_bic))) if pos_bic.size else -10.0
    return {"heldout_gain_min_sigma": float(gain), "delta_bic_max": float(bic),
            "n_positive": len(pos), "n_negative": len(neg),
            "positive_gain_min": float(min((r.gain_sigma for r in pos), default=float("nan"))),
            "negative_gain_max": float(max((r.gain_sigma for r in neg), default=float("nan")))}


def write_thresholds(values: dict, meta: dict, path: str | Path | None = None) -> Path:
    from bpmid.io.atomic import write_text
    path = Path(path) if path else THRESHOLDS_PATH
    body = {"schema": SCHEMA}
    body.update({k: round(float(values[k]), 4) for k in THRESHOLD_KEYS})
    body["calibration"] = {k: (round(v, 4) if isinstance(v, float) else v) for k, v in values.items()
                           if k not in THRESHOLD_KEYS}
    body["calibration"].update(meta)
    return write_text(path, yaml.safe_dump(body, sort_keys=False))
