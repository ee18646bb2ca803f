"""Ringing of a closed loop: the tracking error swinging back and forth, found where it happens (episodes), not
averaged over a run.

A run's error e = reference - angle (``bpmid control`` passes the true angle, what the muscle did, as its RMSE does)
is walked with a dead band: a turning point is an extreme that the error has left by more than the band the other
way (a band sensor noise cannot cross, so a reading of the angle would show the same swings), so the error becomes
a chain of half-swings from one turning point to the next, each larger than the band. A half-swing is the loop's
own when it is quick (at most :data:`RINGING_MAX_HALF_PERIOD_S`), the reference does not turn during it, and the
angle moved at least as far as the reference over it (a reference's jump moves the error, not the loop). An
episode is a chain of at least :data:`RINGING_MIN_SWINGS` of the loop's own half-swings in a row: three periods.

At the paper's gains on a plant that answers within the sample (no valve or volume lag) the loop rings at the
Nyquist frequency: the command of eq. (20) is one sample behind the angle and the rubber's instantaneous (elastic)
gain, about 23 deg/bar, times P = 0.04 bar/deg is about 0.9, so each sample's error comes back at about -0.9 times
itself. A slower ringing (a plant with a pressure lag and a higher gain) is found the same way.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from bpmid._jit import lazy_njit

#: the smallest peak-to-peak swing (deg) that counts when the sensor is quiet: 1 deg is a fifth of the paper's PI
#: tracking error (5.1 deg RMSE) and under half its VBMM-PI error (2.4 deg); a smaller ringing cannot move the
#: comparison experiment 3 makes
RINGING_MIN_SWING_DEG = 1.0
#: ... and it must be larger than this many standard deviations of the change sensor noise alone makes between two
#: readings (sqrt(2) sigma: white noise and quantisation), so noise does not make turning points
RINGING_NOISE_SIGMAS = 3.0
#: half-swings in a row that make an episode: three periods. A damped response to a step turns once or twice
#: (overshoot, return); noise beyond the band does not alternate six times in a row. On the paper's 15 deg steps
#: (1 deg band) a loop reaches six only when each swing keeps more than about half of the one before: a Nyquist
#: pole beyond about -0.52, a damping ratio below about 0.2 (the paper's gains on a lag-free plant: about -0.9)
RINGING_MIN_SWINGS = 6
#: the longest half-swing (s) that counts: a loop's own ringing is at least twice this fast (0.5 Hz); the paper's
#: references turn no faster than every 5 s (sawtooth corners, sines at 0.083 Hz), and a faster reference's own
#: turns are told apart by the reference-turn rule
RINGING_MAX_HALF_PERIOD_S = 1.0


def swing_band_deg(noise_sigma_deg: float) -> float:
    """The dead band (deg) of the turning points: :data:`RINGING_MIN_SWING_DEG`, or three standard deviations of the
    change between two readings that sensor noise of ``noise_sigma_deg`` makes, if larger."""
    return max(RINGING_MIN_SWING_DEG, RINGING_NOISE_SIGMAS * math.sqrt(2.0) * float(noise_sigma_deg))


@dataclasses.dataclass(frozen=True)
class Episode:
    """One ringing episode: from ``start_s`` to ``end_s`` (s, the run's time), ``swings`` half-swings of the error
    and ``period_s`` (twice the median half-swing). Its first half-swing is the loop's answer to what started it (a
    step's response); the swings back after it are the ringing: peak to peak ``first_swing_deg`` (the first swing
    back), ``largest_swing_deg`` at most and ``last_swing_deg`` at its end."""

    start_s: float
    end_s: float
    swings: int
    first_swing_deg: float
    largest_swing_deg: float
    last_swing_deg: float
    period_s: float

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s

    def words(self) -> str:
        """'from 20 s for 1.8 s: 18 swings, the first back 10.9 deg peak to peak, 1.6 deg at the end, period 0.2 s'"""
        return (f"from {self.start_s:.4g} s for {self.duration_s:.2g} s: {self.swings} swings, the first back "
                f"{self.first_swing_deg:.3g} deg peak to peak"
                + (f" (at most {self.largest_swing_deg:.3g})" if self.largest_swing_deg > self.first_swing_deg * 1.05
                   else "")
                + f", {self.last_swing_deg:.2g} deg at the end, period {self.period_s:.2g} s")


def turning_points(x: np.ndarray, band: float) -> np.ndarray:
    """Indices of the alternating extremes of ``x`` that ``x`` left by more than ``band`` the other way (a dead-band
    walk), with the first sample's extreme and the last extreme reached; consecutive points differ by more than
    ``band``. Fewer than two points: ``x`` never moved by more than ``band``."""
    x = np.ascontiguousarray(x, dtype=np.float64)
    if x.size < 2:
        return np.zeros(0, np.int64)
    out = np.empty(x.size + 1, np.int64)
    n = _turning_points_kernel(x, float(band), out)
    return out[:n].copy()


@lazy_njit(cache=True)
def _turning_points_kernel(x, band, out):   # pragma: no cover - compiled; its Python twin is tested as well
    """The dead-band walk of :func:`turning_points`, sample by sample: writes the indices into ``out`` and returns
    how many."""
    n = 0
    i_hi = 0
    i_lo = 0
    direction = 0
    ext = 0
    for k in range(1, x.size):
        v = x[k]
        if direction == 0:
            if v > x[i_hi]:
                i_hi = k
            if v < x[i_lo]:
                i_lo = k
            if x[i_hi] - x[i_lo] > band:
                direction = 1 if i_hi > i_lo else -1
                out[n] = min(i_hi, i_lo)
                n += 1
                ext = max(i_hi, i_lo)
        elif direction > 0:
            if v > x[ext]:
                ext = k
            elif x[ext] - v > band:
                out[n] = ext
                n += 1
                direction = -1
                ext = k
        else:
            if v < x[ext]:
                ext = k
            elif v - x[ext] > band:
                out[n] = ext
                n += 1
                direction = 1
                ext = k
    if direction != 0:
        out[n] = ext
        n += 1
    return n


def episodes(time_s: np.ndarray, reference_deg: np.ndarray, angle_deg: np.ndarray, band_deg: float, *,
             min_swings: int = RINGING_MIN_SWINGS, max_half_period_s: float = RINGING_MAX_HALF_PERIOD_S
             ) -> list[Episode]:
    """The ringing episodes of a run (module docstring): ``time_s``, ``reference_deg`` and ``angle_deg`` (N,);
    ``band_deg`` from :func:`swing_band_deg`."""
    t = np.asarray(time_s, float)
    r = np.asarray(reference_deg, float)
    y = np.asarray(angle_deg, float)
    e = r - y
    p = turning_points(e, band_deg)
    if p.size < 2:
        return []
    a, b = p[:-1], p[1:]
    ref_turns = turning_points(r, band_deg)
    # a reference turn strictly inside a half-swing: the error followed the reference, not the loop
    inside = np.searchsorted(ref_turns, b, side="left") - np.searchsorted(ref_turns, a, side="right") > 0
    own = ((t[b] - t[a] <= max_half_period_s + 1e-9) & ~inside
           & (np.abs(y[b] - y[a]) >= np.abs(r[b] - r[a])))
    swing = np.abs(e[b] - e[a])
    out = []
    j = 0
    while j < own.size:
        if not own[j]:
            j += 1
            continue
        k = j
        while k + 1 < own.size and own[k + 1] and a[k + 1] == b[k]:
            k += 1
        n = k - j + 1
        if n >= min_swings:
            s = swing[j + 1:k + 1]   # the swings back (the first half-swing answers what started the episode)
            out.append(Episode(float(t[a[j]]), float(t[b[k]]), int(n), float(s[0]), float(np.max(s)), float(s[-1]),
                               float(2.0 * np.median(t[b[j:k + 1]] - t[a[j:k + 1]]))))
        j = k + 1
    return out


def summary(eps: list[Episode]) -> dict:
    """The summary.csv columns of a run's episodes: ``ringing_episodes``, ``ringing_s`` (all of them),
    ``ringing_longest_s``, ``ringing_from_s`` (start of the longest; NaN when none), ``ringing_swing_deg`` (the
    largest peak-to-peak swing back in any), ``ringing_period_s`` (of the longest; NaN when none)."""
    if not eps:
        return {"ringing_episodes": 0, "ringing_s": 0.0, "ringing_longest_s": 0.0, "ringing_from_s": float("nan"),
                "ringing_swing_deg": 0.0, "ringing_period_s": float("nan")}
    longest = max(eps, key=lambda ep: (ep.duration_s, ep.largest_swing_deg))
    return {"ringing_episodes": len(eps), "ringing_s": float(sum(ep.duration_s for ep in eps)),
            "ringing_longest_s": longest.duration_s, "ringing_from_s": longest.start_s,
            "ringing_swing_deg": float(max(ep.largest_swing_deg for ep in eps)), "ringing_period_s": longest.period_s}


__all__ = ["Episode", "episodes", "turning_points", "swing_band_deg", "summary", "RINGING_MIN_SWING_DEG",
           "RINGING_NOISE_SIGMAS", "RINGING_MIN_SWINGS", "RINGING_MAX_HALF_PERIOD_S"]
