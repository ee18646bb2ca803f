"""The discovery loop: fit the base VBMM, diagnose, screen the catalogue, confirm, add one effect at a time.

:func:`discover` is the library entry point of ``bpmid discover``. It never scores an effect on the samples
that fitted it: candidates are refitted on the fitting logs and judged on whole held-out logs (given with
``--holdout``, or a fixed split of the logs: every ``holdout_every``-th log). It stops when no candidate passes,
and says so: "no missing effect found" is a legitimate answer.

Accepting an effect needs all of (the gate, stated in plain words in every ``discovery.yaml`` and verdict;
thresholds: :mod:`bpmid.discover.calibrate`):

- its refit really tested it: started from the screening regression's estimate and from a grid over the effect's
  physical range; a refit that did not move is reported "not tested", never counted as evidence against it,
- a drop of the held-out error above the noise of at least ``heldout_gain_min_sigma`` noise floors that removes at
  least ``gap_share_min`` of that gap (the gap is the RMSE above the noise floor in quadrature,
  ``sqrt(RMSE^2 - floor^2)``: noise and a systematic error add that way, :func:`bpmid.discover.confirm.excess_deg`),
- a likelihood-ratio test on the fitting logs (effective sample size, boundary-corrected p-value) that passes at
  family-wise level ``family_alpha`` after a Holm correction over every candidate screened in the round,
- at least one of its own parameters identifiable (the others held).

When no candidate passes all of these, the path down to the noise floor (:func:`judge_to_floor`): a candidate that
was tested, is identifiable and passes the same likelihood-ratio test, whose refit leaves the held-out RMSE at or
below the noise floor (at most ``to_floor_ratio_max`` floors) and removes at least ``to_floor_drop_min_sigma`` noise
floors of held-out error in quadrature (``sqrt(before^2 - after^2)``,
:func:`bpmid.discover.confirm.heldout_drop_sigma`). It is there for an effect the refitted base model had mostly
absorbed (a short pressure lag looks much like a faster relaxation branch): the gap left above the floor is then
within the floor's own uncertainty, so the gap-based gain and shares say little, or there is no fitting gap for the
fitting share to measure; the drop is still measured on logs the effect was not fitted on. Why the gate refused
the candidate is reported beside it. Its drop is calibrated like the rest of the gate.

Whatever a round would name is held against the rivals outside the catalogue (:mod:`bpmid.discover.rivals`: payload
inertia that rings, an air leak through an orifice, the Mullins effect; beside a pressure lag, noise on the logged
pressure), refitted and scored the same way; when a rival explains the
held-out logs better and needs its own shape, nothing is named that round and the remainder is reported
unexplained.

Among the candidates that pass, the one with the largest confirmed held-out gain is added (the leading
``n_confirm`` screened candidates, by default all, are confirmed, so screening order never decides); when several pass,
each one's gain is reported with why the winner won. A BIC is reported, never a gate. With ``per_log_gain``
(default) every log gets a stiffness-like gain (a nuisance factor for log-to-log variation of the constants):
fitted in closed form on fitting logs (geometric mean 1) and on each held-out log for every model alike.
"""
from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path
from typing import Mapping, Optional, Sequence

import numpy as np

from bpmid.discover.calibrate import (BY_EFFECT_KEY, THRESHOLD_KEYS as GATE_KEYS, check_drops_by_effect,
                                      floor_drops, gain_winner, later_gain_follows, load_thresholds,
                                      thresholds_calibration, winner_rank)
from bpmid.discover.confirm import (Confirmation, PairTrial, confirm, excess_deg, heldout_drop_sigma, holm_adjusted,
                                   p_note, p_words, pair_trial)
from bpmid.discover.cautions import ambient_cautions, data_cautions, gate_cautions, sampling_cautions
from bpmid.discover.diagnose import diagnose, noise_floor
from bpmid.discover.rivals import (IMITATES, RIVALS, adds_beside, beats, check_rival, held_against, own_shape,
                                   rival_constants)
from bpmid.discover.model import (LogNuisance, ModelState, fit_state, gained_residuals, heldout_residual, residuals,
                                  rmse_deg, scored_rmse, sensitivities, simulate, stacked)
from bpmid.discover.screen import ScreenResult, screen
from bpmid.effects import CATALOGUE, get_effect
from bpmid.effects.base import Effect, held
from bpmid.errors import ConvergenceError, InputError
from bpmid.io.motion_logs import MotionLog
from bpmid.models.vbmm import VBMM
from bpmid.models.vbmm.fit import check_angle_range
from bpmid.progress import Progress, note
from bpmid.relax._blas import one_blas_thread


def checked_thresholds_file(value, key: str, config_path=None) -> str:
    """The absolute path of a thresholds file (``bpmid calibrate``'s thresholds.yaml) given under ``key`` (a
    relative one from the folder of ``config_path``, if any), read and checked now so a bad one is refused before
    any work: InputError naming the key."""
    tf = Path(str(value)).expanduser()
    if not tf.is_absolute() and config_path is not None:
        tf = Path(config_path).resolve().parent / tf
    if not tf.is_file():
        raise InputError(f"thresholds file not found: {tf} (bpmid calibrate writes OUT/thresholds.yaml)",
                         path=config_path, key=key)
    try:
        load_thresholds(tf)
    except InputError as exc:
        where = f"{tf}, key '{exc.key}'" if exc.key else str(tf)
        raise InputError(f"{where}: {exc.message}", path=config_path, key=key) from None
    return str(tf.resolve())


@dataclasses.dataclass(frozen=True)
class DiscoverConfig:
    """Config section ``discover``.

    Attributes
    ----------
    candidates : catalogue ids to consider (empty: the whole catalogue)
    max_effects : stop after adding this many effects
    n_confirm : leading screening candidates refitted per round (the winner is chosen by held-out gain); the
        default confirms every screened candidate of the catalogue (screening order missed the true effect
        on out-of-family data, and the refits cost little next to the base fit)
    holdout_every : without ``--holdout``, every n-th log (counting from the last) is held out; at least one
    min_fit_samples : fewer fitting samples than this cannot be judged (exit 2)
    min_log_samples : a log shorter than this cannot be judged (exit 2)
    base_max_nfev : function-evaluation budget of each base fit; a fit that runs out did not converge (exit 2)
    base_starts : starts of the base fit refitted (best of the given start and scaled variants of it)
    confirm_max_nfev : budget of each augmented refit (fixed: the cost grows linearly with the data)
    heldout_gain_min_sigma : accept only if the held-out error above the noise (``sqrt(RMSE^2 - floor^2)``) drops by
        this many noise floors (None: calibrated)
    gap_share_min : accept only if the drop removes at least this share of that gap (None: calibrated)
    family_alpha : family-wise level of the Holm-corrected likelihood-ratio tests of a round (None: calibrated)
    fit_share_min : accept only if the refit removes at least this share of the fitting logs' gap above the noise
        floor (None: calibrated; 0: no such condition) ...
    fit_share_waived_above_sigma : ... unless its held-out gain is at least this many noise floors (None:
        calibrated: above any wrong candidate's gain on the calibration cases with nothing to find)
    heldout_gain_min_sigma_later : the held-out gain asked of a further effect once one is named (the gap left is
        smaller); None: calibrated, or ``heldout_gain_min_sigma`` when that is set here
    to_floor_drop_min_sigma : the path down to the noise floor, for a round where no candidate passes the gate:
        the held-out error (in quadrature) a candidate must remove, in noise floors (None: calibrated; inf: no
        such path) ...
    to_floor_ratio_max : ... leaving a held-out RMSE of at most this many noise floors (None: calibrated, 1)
    to_floor_drop_by_effect : the effects asked their own drop on that path, catalogue id -> noise floors (None:
        calibrated; a mapping here replaces the calibrated one whole, so list every effect that should keep its
        own; ``{}``: every effect asked ``to_floor_drop_min_sigma``; .inf: that effect never takes the path; with
        ``to_floor_drop_min_sigma: .inf`` there is no path at all)
    identifiable_waived_above_sigma : condition (4), a parameter identifiable, is not asked of a held-out gain above
        this many noise floors (None: calibrated, the fitting-share waiver's value; inf: always asked)
    pair_share_min : two effects at once, for a first round where no candidate passes either path: the share of
        the held-out gap two candidates refitted together must remove (None: calibrated; inf: no such path) ...
    pair_gain_min_sigma : ... with each adding at least this held-out gain (noise floors) beside the other
        (None: calibrated)
    pair_over_single_min_sigma : two effects at once over the single effect a first round would name: their joint
        refit's held-out gain must exceed that effect's by this many noise floors (None: calibrated; inf: no such
        path) ...
    pair_over_gain_min_sigma : ... with each adding at least this held-out gain (noise floors) beside the other
        (None: calibrated)
    record_pair_trials : refit the leading pairs of the first round together even when a candidate passes and no
        path asks for them (the calibration runs record them; they never change what is named)
    withhold_for_rivals : a round names nothing when a rival outside the catalogue (:mod:`bpmid.discover.rivals`:
        payload inertia that rings) explains the held-out logs better than the effect it would name; False (the
        calibration runs): every round's rival is refitted and recorded, and decides nothing
    per_log_gain : score with one stiffness-like gain per log (log-to-log variation is not an effect)
    per_log_constants : give every log its own small factors on K_inf, the branch moduli and the time
        constants instead of the gain (first order, :class:`~bpmid.discover.model.LogNuisance`): log-to-log
        variation of the constants is absorbed log by log instead of being left in the residual, where it hides
        small effects
    unexplained_gap_sigma : the remainder is reported unexplained when the held-out RMSE stays more than this
        many noise floors above the floor
    hold : effect parameters held at a value instead of fitted, ``<effect id>.<name>`` -> value in the
        parameter's unit (e.g. ``{pressure_lag.share: 0}``: a single first-order lag, for a rig whose line is
        known to be short); a held parameter is not a new parameter of the candidate
    """

    candidates: tuple[str, ...] = ()
    max_effects: int = 3
    n_confirm: int = len(CATALOGUE)
    holdout_every: int = 3
    min_fit_samples: int = 200
    min_log_samples: int = 30
    base_max_nfev: int = 300
    base_starts: int = 2
    confirm_max_nfev: int = 60
    heldout_gain_min_sigma: Optional[float] = None
    gap_share_min: Optional[float] = None
    family_alpha: Optional[float] = None
    fit_share_min: Optional[float] = None
    fit_share_waived_above_sigma: Optional[float] = None
    heldout_gain_min_sigma_later: Optional[float] = None
    to_floor_drop_min_sigma: Optional[float] = None
    to_floor_ratio_max: Optional[float] = None
    to_floor_drop_by_effect: Optional[Mapping[str, float]] = None
    identifiable_waived_above_sigma: Optional[float] = None
    pair_share_min: Optional[float] = None
    pair_gain_min_sigma: Optional[float] = None
    pair_over_single_min_sigma: Optional[float] = None
    pair_over_gain_min_sigma: Optional[float] = None
    record_pair_trials: bool = False
    withhold_for_rivals: bool = True
    per_log_gain: bool = True
    per_log_constants: bool = True
    unexplained_gap_sigma: float = 0.5
    hold: Optional[Mapping[str, float]] = None
    thresholds_file: Optional[str] = None

    def __post_init__(self):
        # a plain dict (a config file's mapping arrives read-only, and a sweep ships the config to its workers)
        for name in ("to_floor_drop_by_effect", "hold"):
            if isinstance(getattr(self, name), Mapping):
                object.__setattr__(self, name, dict(getattr(self, name)))

    def validate(self, where, path):
        if self.thresholds_file is not None:   # relative to the config that names it
            object.__setattr__(self, "thresholds_file", checked_thresholds_file(
                self.thresholds_file, f"{where}.thresholds_file", path))
        for c in self.candidates:
            if c not in CATALOGUE:
                raise InputError(f"unknown effect id {c!r} (known: {', '.join(CATALOGUE)})", path=path,
                                 key=f"{where}.candidates")
        for name in ("max_effects", "n_confirm", "holdout_every", "min_fit_samples", "min_log_samples",
                     "base_max_nfev", "base_starts", "confirm_max_nfev"):
            if getattr(self, name) < 1:
                raise InputError(f"must be at least 1, found {getattr(self, name)}", path=path, key=f"{where}.{name}")
        if not (self.unexplained_gap_sigma >= 0 and math.isfinite(self.unexplained_gap_sigma)):
            raise InputError(f"must be 0 or more noise floors, found {self.unexplained_gap_sigma}", path=path,
                             key=f"{where}.unexplained_gap_sigma")
        if self.family_alpha is not None and not 0 < self.family_alpha < 1:
            raise InputError(f"must be between 0 and 1, found {self.family_alpha}", path=path,
                             key=f"{where}.family_alpha")
        w = self.fit_share_waived_above_sigma
        if w is not None and not (w >= 0):
            raise InputError(f"must be 0 or more noise floors, found {w}", path=path,
                             key=f"{where}.fit_share_waived_above_sigma")
        if self.fit_share_min is not None and not 0 <= self.fit_share_min < 1:
            raise InputError(f"must be in [0, 1), found {self.fit_share_min}", path=path,
                             key=f"{where}.fit_share_min")
        if self.gap_share_min is not None and not 0 <= self.gap_share_min < 1:
            raise InputError(f"must be in [0, 1), found {self.gap_share_min}", path=path,
                             key=f"{where}.gap_share_min")
        inf_ok = lambda x: x == math.inf  # noqa: E731
        for name, ok, what in (
                ("to_floor_drop_min_sigma", lambda x: x >= 0, "0 or more noise floors (.inf: no path to the floor)"),
                ("to_floor_ratio_max", lambda x: x > 0 and math.isfinite(x), "a finite number of noise floors above 0"),
                ("identifiable_waived_above_sigma", lambda x: x >= 0, "0 or more noise floors (.inf: always asked)"),
                ("pair_share_min", lambda x: 0 <= x < 1 or inf_ok(x),
                 "in [0, 1) (.inf: no path for two effects at once)"),
                ("pair_gain_min_sigma", lambda x: x >= 0, "0 or more noise floors"),
                ("pair_over_single_min_sigma", lambda x: x > 0,
                 "above 0 noise floors (.inf: no pair over a single effect)"),
                ("pair_over_gain_min_sigma", lambda x: x >= 0, "0 or more noise floors")):
            v = getattr(self, name)
            if v is not None and not ok(v):
                raise InputError(f"must be {what}, found {v}", path=path, key=f"{where}.{name}")
        if self.to_floor_drop_by_effect is not None:
            check_drops_by_effect(self.to_floor_drop_by_effect, path, f"{where}.to_floor_drop_by_effect")
        for name, value in (self.hold or {}).items():
            eid = str(name).split(".", 1)[0]
            if eid not in CATALOGUE or "." not in str(name):
                raise InputError(f"{name!r} names no effect parameter: give <effect id>.<name>, e.g. "
                                 f"pressure_lag.share (effect ids: {', '.join(CATALOGUE)})", path=path,
                                 key=f"{where}.hold")
            try:
                held(get_effect(eid), {str(name): float(value)})
            except ValueError as e:
                raise InputError(str(e), path=path, key=f"{where}.hold.{name}") from None

    def thresholds(self) -> dict:
        """The gate: the thresholds file's (``thresholds_file``, else the shipped calibration), with this config's
        per-key overrides on top."""
        return self.overrides(load_thresholds(self.thresholds_file))

    def overrides(self, thr: dict) -> dict:
        """``thr`` with this config's threshold overrides; a ``heldout_gain_min_sigma`` set here without
        ``heldout_gain_min_sigma_later`` sets both."""
        given = {k: float(getattr(self, k)) for k in GATE_KEYS if getattr(self, k) is not None}
        out = later_gain_follows({**thr, **given}, given)
        if self.to_floor_drop_by_effect is not None:
            out[BY_EFFECT_KEY] = {str(k): float(v) for k, v in self.to_floor_drop_by_effect.items()}
        return out


def _thr(x: float) -> str:
    """A threshold in noise floors as the gate's words give it: two decimals, more where two would change it (a
    margin of 0.004 reads 0.004, never 0.00)."""
    x = float(x)
    return f"{x:.2f}" if not math.isfinite(x) or round(x, 2) == x else f"{x:.4g}"


def _pct(x: float) -> str:
    """A threshold share as a percentage: whole per cent, more where that would change it (0.655 reads 65.5%)."""
    x = float(x)
    return f"{x:.0%}" if not math.isfinite(x) or round(100 * x) == 100 * x else f"{100 * x:.3g}%"


def _later_words(thr: dict) -> str:
    g, later = float(thr["heldout_gain_min_sigma"]), float(thr.get("heldout_gain_min_sigma_later", math.nan))
    if not math.isfinite(later) or later == g:
        return ""
    return f" ({_thr(later)} for a further effect once one is named: the gap left is smaller)"


def gate_in_words(thr: dict) -> str:
    """The acceptance rule, as printed in discovery.yaml and the verdict."""
    return (f"an effect is named only if (1) its refit really tested it (started from the screening estimate and "
            f"from a grid over its physical range; a refit that did not move counts as 'not tested', never as "
            f"evidence against), (2) it cuts the held-out error above the noise (sqrt(RMSE^2 - floor^2)) by at least "
            f"{_thr(thr['heldout_gain_min_sigma'])} noise floors" + _later_words(thr)
            + f", removing at least {_pct(thr['gap_share_min'])} of that gap"
            + (f" and its refit removes at least {_pct(thr['fit_share_min'])} of the fitting logs' gap (not asked of a "
               f"held-out gain above {_thr(thr.get('fit_share_waived_above_sigma', math.inf))} noise floors, more than "
               f"any wrong candidate's on the calibration cases with nothing to find)"
               if float(thr.get("fit_share_min", 0.0)) > 0 else "") +
            f", (3) its likelihood-ratio test on the fitting logs (effective sample size, boundary-corrected p-value) "
            f"passes at family-wise level {thr['family_alpha']:.2g} after a Holm correction over every candidate "
            f"screened in the round, and (4) at least one of its parameters is identifiable"
            + (f" (not asked above {_thr(thr.get('identifiable_waived_above_sigma', math.inf))} noise floors of "
               f"held-out gain, more than any wrong candidate's on the calibration cases with nothing to find: the "
               f"effect is then named with its constants reported as not determined separately)"
               if math.isfinite(float(thr.get("identifiable_waived_above_sigma", math.inf))) else "")
            + "; of several that pass, "
            f"the largest held-out gain wins (of equal gains, as when each takes the error to the floor, the larger "
            f"held-out drop), unless another's gain is within the gain asked of an effect at all "
            f"({_thr(thr['heldout_gain_min_sigma'])} noise floors"
            + ("" if float(thr.get("heldout_gain_min_sigma_later", thr["heldout_gain_min_sigma"]))
               == float(thr["heldout_gain_min_sigma"]) else
               f"; {_thr(thr['heldout_gain_min_sigma_later'])} for a further effect")
            + f") of it: the held-out logs then leave them level, and the one whose refit removed "
            f"the larger share of the fitting logs' gap wins" + _to_floor_words(thr) + _pair_paths_words(thr)
            + ". Whatever a round would name, three rivals outside the catalogue (payload inertia that rings: an "
              "underdamped response of the angle; an air leak through an orifice: a pressure shortfall growing as "
              "the square root of the pressure; the Mullins effect: rubber softer below the largest pressure so "
              "far) are refitted beside it, and a fourth beside a pressure lag (noise on the logged pressure, "
              "which the muscle never saw: a smoothing of the logged pressure with no delay); when a rival passes "
              f"the likelihood-ratio test at {thr['family_alpha']:.2g} uncorrected, needs its own shape (damping "
              "off its bound of 0.5; a leak above 0; a softening above 0; a smoothing wider than 0) and leaves a "
              "lower held-out RMSE, nothing is named that round (a catalogue effect would only imitate it)"
            + ". BIC is reported, never a gate")


def _pair_paths_words(thr: dict) -> str:
    """The two paths for two effects at once, in words (each only when the gate has it)."""
    sh = float(thr.get("pair_share_min", math.inf))
    m = float(thr.get("pair_over_single_min_sigma", math.inf))
    words = ""
    if math.isfinite(sh):
        words += (f". When no candidate passes alone in the first round, the {PAIR_LEADERS} largest held-out gains "
                  f"among those tested and identifiable, and the {PAIR_LEADERS} with the smallest Holm-corrected "
                  f"likelihood-ratio p on the fitting logs (two effects that mask each other can each gain nothing "
                  f"alone), are refitted two at a time; two that both meet (1), (3) and "
                  f"(4) alone are named together when their joint refit removes at least {_pct(sh)} of the held-out gap "
                  f"with a gain of at least {_thr(thr['heldout_gain_min_sigma'])} noise floors, each adds at least "
                  f"{_thr(thr.get('pair_gain_min_sigma', math.inf))} noise floors of held-out gain beside the "
                  f"other, and each passes the likelihood-ratio test beside the other at the same level (Bonferroni "
                  f"over the pairs tried): two effects sharing a residual each remove too small a share of it alone")
    if math.isfinite(m):
        words += (f". When a first-round candidate passes, the same leading candidates are also refitted two "
                  f"at a time; two that both pass (3) alone, each beside the other (Bonferroni over the pairs tried), "
                  f"and are tested and identifiable are named together instead when their joint held-out gain exceeds "
                  f"the passing candidate's by at least {_thr(m)} noise floors and each adds at least "
                  f"{_thr(thr.get('pair_over_gain_min_sigma', math.inf))} noise floors beside the other (no pair is "
                  f"refitted when the passing candidate leaves less than that margin above the floor: none could "
                  f"beat it): two effects at once can make a third the best alone")
    return words


def _ordinal(k: int) -> str:
    """1st, 2nd, 3rd, 4th, ..., 11th, 12th, 13th, 21st."""
    suffix = "th" if 10 <= k % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(k % 10, "th")
    return f"{k}{suffix}"


def _to_floor_words(thr: dict) -> str:
    d = float(thr.get("to_floor_drop_min_sigma", math.inf))
    if not math.isfinite(d):
        return ""
    q = float(thr.get("to_floor_ratio_max", 1.0))
    where = "at or below the noise floor" if q == 1.0 else f"at most {q:.3g} noise floors"
    by = {e: float(x) for e, x in (thr.get(BY_EFFECT_KEY) or {}).items()}
    own = ("; these effects are asked their own drop: " + ", ".join(
        f"{e} {_thr(x)} noise floors" if math.isfinite(x) else f"{e} not on this path" for e, x in sorted(by.items()))
        + ("; a lag shows only while the pressure moves, so it removes less of a whole log's error"
           if by.get("pressure_lag", d) < d else "")) if by else ""
    return (f". When no candidate passes (1)-(4), one meeting (1), (3) and (4) whose refit leaves the held-out RMSE "
            f"{where} and removes at least {_thr(d)} noise floors of held-out error (sqrt(before^2 - after^2)){own}; it is "
            f"named, with the gate's reasons for refusing it (an effect the refitted base model mostly absorbed "
            f"leaves too little gap above the floor for (2); of several, the largest such drop wins)")


@dataclasses.dataclass
class Round:
    """One pass of diagnose -> screen -> confirm."""

    diagnostics: dict
    ranking: list[ScreenResult]
    confirmations: list[Confirmation]
    accepted: Optional[str]
    family_size: int = 1
    competition: str = ""
    #: the first round's leading candidates refitted two at a time (the path for two effects at once)
    pair_trials: list = dataclasses.field(default_factory=list)
    #: a round that only records the second of two effects named together in the round before
    joint_with: str = ""
    #: the rival outside the catalogue reported for this round (:mod:`bpmid.discover.rivals`: the one that withheld
    #: the effect the round would have named, else the first refitted), and why it withheld it ("" when none did)
    rival: Optional[Confirmation] = None
    withheld: str = ""
    #: every rival refitted this round, in the order asked
    rivals: list = dataclasses.field(default_factory=list)


@dataclasses.dataclass
class DiscoveryResult:
    """Everything ``bpmid discover`` reports (angles in deg).

    ``heldout_before``/``heldout_after`` are the scored held-out RMSE (with per-log gains when
    ``per_log_gain``); ``heldout_raw_before``/``heldout_raw_after`` without any gain."""

    named_effects: list[str]
    rounds: list[Round]
    noise: dict
    base_state: ModelState
    final_state: ModelState
    fit_logs: list[MotionLog]
    holdout_logs: list[MotionLog]
    heldout_before: float
    heldout_after: float
    thresholds: dict
    unexplained: bool
    verdict: str
    split: str
    elapsed_s: float
    variation: Optional[dict] = None
    base_fit: Optional[dict] = None
    heldout_raw_before: float = float("nan")
    heldout_raw_after: float = float("nan")
    per_log_gain: object = True   # True/False or the LogNuisance that scored the held-out logs
    #: the thresholds file the gate came from (None: the shipped calibration, bpmid/discover/thresholds.yaml)
    thresholds_file: Optional[str] = None
    #: the gate's keys a config's discover section (or a calibration) set over the file's
    overridden: tuple = ()
    #: what a careful user should know before trusting the verdict (:mod:`bpmid.discover.cautions`)
    cautions: tuple = ()

    @property
    def noise_floor_deg(self) -> float:
        return float(self.noise["sigma_deg"])

    def steps(self) -> list[dict]:
        out = []
        for rnd in self.rounds:
            if rnd.accepted is None:
                continue
            c = next(c for c in rnd.confirmations if c.effect_id == rnd.accepted)
            s = next(s for s in rnd.ranking if s.effect_id == rnd.accepted)
            out.append({"effect": c.effect_id, "screening": s.to_yaml(), "evidence": c.to_yaml(),
                        "explanation": rnd_explanation(c, rnd, self.noise_floor_deg),
                        "competition": rnd.competition or None})
        return out

    def scoring(self) -> str:
        """How the held-out RMSEs (``gap.*``) were scored, in words."""
        if isinstance(self.per_log_gain, LogNuisance):
            return ("held-out RMSE with each held-out log's own nuisance factors fitted on that log for every model "
                    "alike (every round, and before and after, with the base model's directions and bounds): "
                    + self.per_log_gain.describe() + " (log-to-log variation of the constants is not "
                    "scored as an effect); raw_*: without them")
        if self.per_log_gain:
            return ("held-out RMSE with one stiffness-like gain per held-out log fitted on that log for every model "
                    "alike (log-to-log variation of the constants is not scored as an effect); raw_*: without the gain")
        return "plain held-out RMSE"

    def to_yaml(self) -> dict:
        floor = self.noise_floor_deg
        return {
            "named_effects": list(self.named_effects),
            "steps": self.steps(),
            "gap": {"before_rmse_deg": round(self.heldout_before, 4), "after_rmse_deg": round(self.heldout_after, 4),
                    "noise_floor_deg": round(floor, 4),
                    "before_gap_deg": round(self.heldout_before - floor, 4),
                    "after_gap_deg": round(self.heldout_after - floor, 4),
                    "raw_before_rmse_deg": round(self.heldout_raw_before, 4),
                    "raw_after_rmse_deg": round(self.heldout_raw_after, 4),
                    "scoring": self.scoring()},
            "unexplained": bool(self.unexplained),
            "log_to_log_variation": self.variation,
            "verdict": self.verdict,
            "gate": gate_in_words(self.thresholds),
            "thresholds_from": (self.thresholds_file or "bpmid's shipped calibration (bpmid/discover/thresholds.yaml)")
            + (f"; the config's discover section sets {', '.join(self.overridden)}" if self.overridden
               else "; no config override"),
            "noise_floor": {"method": self.noise.get("method", ""),
                            "sigma_deg": round(floor, 4),
                            "noise_lag1_correlation": round(float(self.noise.get("rho", 0.0)), 3),
                            "white_noise_reading_deg": round(float(self.noise.get("white_noise_sigma_deg", floor)), 4),
                            "per_log_deg": {k: round(v, 4) for k, v in self.noise["per_log"].items()},
                            "left_out_logs": list(self.noise.get("left_out") or []),
                            "caution": list(self.noise.get("caution") or [])},
            "base_fit": self.base_fit,
            "cautions": list(self.cautions),
            "split": {"how": self.split, "fitting_logs": [lg.name for lg in self.fit_logs],
                      "heldout_logs": [lg.name for lg in self.holdout_logs]},
            "thresholds": {k: (float(f"{v:.6g}") if isinstance(v, float) else v) for k, v in self.thresholds.items()},
            "rounds": [{"diagnostics": rnd.diagnostics, "screening": [s.to_yaml() for s in rnd.ranking],
                        "candidates_in_family": rnd.family_size,
                        "confirmed": [c.to_yaml() for c in rnd.confirmations], "accepted": rnd.accepted,
                        "competition": rnd.competition or None,
                        "pairs_refitted_together": [pt.to_yaml() for pt in rnd.pair_trials] or None,
                        "named_together_with": rnd.joint_with or None,
                        "rival_outside_catalogue": rival_yaml(rnd, self.thresholds, floor),
                        "rivals_outside_catalogue": [rival_yaml(rnd, self.thresholds, floor, c)
                                                     for c in rnd.rivals] or None}
                       for rnd in self.rounds],
            "base_model": {p.name: p.to_yaml() for p in self.base_state.params},
            "final_model": {p.name: p.to_yaml() for p in self.final_state.params},
            "elapsed_s": round(self.elapsed_s, 2),
        }


# ---------------------------------------------------------------------------------------------
# plain-language evidence
# ---------------------------------------------------------------------------------------------
#: a rival's constants as discovery.yaml names them (with their unit where they have one)
_RIVAL_CONSTANT_NAMES = {"period": "period_s", "zeta": "damping_ratio", "d": "softening_share",
                         "w": "onset_width_share", "width": "smoothing_width_s"}


def rival_yaml(rnd: Round, thr: dict, floor: float, c: Optional[Confirmation] = None) -> Optional[dict]:
    """A rival outside the catalogue (:mod:`bpmid.discover.rivals`; default: the round's reported one) for
    ``discovery.yaml``: its evidence, constants, whether its fit needs what only it has, and whether it withheld
    the round's effect."""
    c = rnd.rival if c is None else c
    if c is None:
        return None
    return {"effect": c.effect_id, "meaning": type(c.state.effects[-1]).meaning,
            "constants": {_RIVAL_CONSTANT_NAMES.get(k, k): round(v, 4) for k, v in rival_constants(c).items()},
            "needs_its_own_shape": own_shape(c), "withheld_the_round": bool(rnd.withheld) and c is rnd.rival,
            "reported_because": None if c is not rnd.rival else (
                "it withheld the round's effect" if rnd.withheld else
                "no rival withheld; this is the one that came nearest (the lowest held-out RMSE of the rivals "
                "tested; rivals_outside_catalogue lists them all)"),
            "reason": (rnd.withheld or None) if c is rnd.rival else None,
            "heldout_rmse_after_deg": round(c.heldout_rmse_after, 4),
            "heldout_rmse_after_in_noise_floors": round(c.heldout_rmse_after / floor, 4),
            "fit_rmse_after_deg": round(c.fit_rmse_after, 4),
            "likelihood_ratio_p": float(f"{c.lr_p:.3g}"),
            "likelihood_ratio_p_note": p_note(c.lr_p) if c.tested else None,
            "tested": bool(c.tested),
            "not_tested_reason": c.not_tested_reason or None,
            "effect_refitted_beside": None if c.effect_beside is None else {
                "effect": c.effect_beside.effect_id,
                "heldout_rmse_after_deg": round(c.effect_beside.heldout_rmse_after, 4),
                "likelihood_ratio_p": float(f"{c.effect_beside.lr_p:.3g}"),
                "heldout_drop_below_the_rival_in_noise_floors": round(heldout_drop_sigma(
                    c.heldout_rmse_after, c.effect_beside.heldout_rmse_after, floor), 4),
                "still_adds": bool(c.effect_beside_adds),
                "rule": "refitted on top of the rival before it may withhold the effect; when it is tested, p < "
                        "family_alpha and it removes at least the held-out drop the gate asks of it on the path "
                        "to the noise floor below the rival alone, the rival does not take the round (both can "
                        "be there)"},
            "rule": "withholds the round's effect when tested, p < family_alpha "
                    f"({thr.get('family_alpha', math.nan):.3g}), its own shape needed, and its held-out RMSE below "
                    "that effect's"}


def residual_feature(diag: dict) -> str:
    """The residual's most salient feature, in words, from the conditional summaries."""
    c = diag["conditional"]
    rms = max(diag["rmse_deg"], 1e-9)
    loop = c["mean_rising_deg"] - c["mean_falling_deg"]
    cands = [
        (abs(loop) / rms, f"keeps a loop of about {abs(loop):.2g} deg between rising and falling pressure"),
        (abs(c["mean_deg"]) / rms, f"sits {c['mean_deg']:+.2g} deg off on average"),
        (abs(c["corr_with_elapsed_time"]), f"drifts with elapsed time (r = {c['corr_with_elapsed_time']:+.2f})"),
        (abs(c["corr_with_pressure"]), f"grows with pressure (r = {c['corr_with_pressure']:+.2f})"),
        (abs(c["corr_with_sign_rate"]), f"follows the sign of the pressure rate (r = {c['corr_with_sign_rate']:+.2f})"),
    ]
    return max(cands, key=lambda x: x[0])[1]


def rnd_explanation(c: Confirmation, rnd: Round, floor: float) -> str:
    s = next(s for s in rnd.ranking if s.effect_id == c.effect_id)
    e = c.state.effects[-1]
    if c.passed_by == "pair":
        return _pair_member_explanation(c, rnd, floor, s, e)
    if c.passed_by == "floor":
        how = (f"{c.heldout_rmse_after:.3f} deg against a noise floor of {floor:.3f} deg, removing "
               f"{c.drop_sigma:.3f} noise floors of held-out error (sqrt(before^2 - after^2)); named on the path to "
               f"the floor, the gate having refused it because " + "; ".join(c.gate_reasons) + " (")
    else:
        how = (f"{c.heldout_rmse_after:.2f} deg (its part above the noise by {c.heldout_gain_sigma:.2f} noise floors "
               f"of {floor:.2f} deg; ")
    return (f"{e.describe(c.state.params, mark_held=True)}: {e.meaning}. Where it shows: {e.where_it_shows}. "
            f"Here the residual {residual_feature(rnd.diagnostics)}, and the effect's signature explains "
            f"{s.explained:.0%} of what the model left after the base constants' own compensation (screening's "
            f"first-order ranking; the refit moves the base constants with the effect, and its held-out error "
            f"decides); adding it cut the held-out error from "
            + (f"{c.heldout_rmse_before:.3f}" if c.passed_by == "floor" else f"{c.heldout_rmse_before:.2f}")
            + " to "
            + how +
            f"likelihood-ratio p {p_words(c.lr_p)}, Holm-corrected {p_words(c.lr_p_holm, eq=False)})"
            + ("" if c.identifiable else
               f"; named for its held-out gain although none of its constants is determined separately by these logs "
               f"(" + "; ".join(f"{k}: {v}" for k, v in c.not_identifiable.items()) + "): its values are one point of "
               f"a ridge, not estimates"))


def _pair_member_explanation(c: Confirmation, rnd: Round, floor: float, s, e) -> str:
    """One of two effects named together: its constants from the joint refit, its numbers alone (why the gate
    refused it) kept apart from its numbers beside the other."""
    params = c.named_with.params if c.named_with is not None else c.state.params
    head = (f"{e.describe(params, mark_held=True)}: {e.meaning}. Where it shows: {e.where_it_shows}. Named as one "
            f"of two effects that share the residual (constants from their joint refit). ")
    if rnd.joint_with:
        body = (f"Beside {rnd.joint_with} it cut the held-out error from {c.heldout_rmse_before:.3f} to "
                f"{c.heldout_rmse_after:.3f} deg (noise floor {floor:.3f} deg; likelihood-ratio p {p_words(c.lr_p)}, "
                f"{p_words(c.lr_p_holm, eq=False)} Bonferroni-corrected over the pairs tried)")
    else:
        body = (f"Alone it cut the held-out error from {c.heldout_rmse_before:.3f} to {c.heldout_rmse_after:.3f} deg "
                f"(noise floor {floor:.3f} deg; its signature explained {s.explained:.0%} of what the base model left "
                f"after the base constants' own compensation; likelihood-ratio p {p_words(c.lr_p)}, Holm-corrected "
                f"{p_words(c.lr_p_holm, eq=False)})")
    return head + body + ("; alone the gate refused it because " + "; ".join(c.gate_reasons) if c.gate_reasons else
                          "; it passed the gate alone, but the two refitted together explain the held-out logs "
                          "better by more than the margin asked")


#: the verdict's "the fitting logs do not show it": the base model within this many noise floors on the fitting logs
FIT_AT_FLOOR = 1.15
#: ... while the scored held-out error is at least this many
HELDOUT_ABOVE = 1.3
#: how far below 0 deg a measured angle may go before discovery refuses the log: angle_offset's bound (its sensor
#: zero may sit up to 30 deg off), so only a flipped sign or a sensor mounted the other way is refused
ANGLE_BELOW_ZERO_DEG = 30.0


def make_verdict(named: list[str], rounds: list[Round], before: float, after: float, floor: float,
                 unexplained: bool, variation: Optional[dict] = None, thr: Optional[dict] = None,
                 base_fit: Optional[dict] = None, raw_after: Optional[float] = None,
                 noise: Optional[dict] = None, unexplained_margin: float = 0.5, final=None,
                 cautions: Sequence[str] = (), held_out_odd: bool = False) -> str:
    lines = []
    for r in rounds:
        if r.accepted:
            lines.append(rnd_explanation(next(c for c in r.confirmations if c.effect_id == r.accepted), r, floor))
            if r.competition:
                lines.append(r.competition)
    if final is not None and len(named) >= 2:
        # each round prints its effect's constants as named; a later round refits them all
        lines.append("constants of the final model (every named effect refitted beside the others; each round above "
                     "gives them as named): " + "; ".join(e.describe(final.params, mark_held=True) for e in final.effects))
    for r in rounds:
        if r.withheld:
            lines.append(r.withheld.replace("withheld: ", "nothing named: ", 1))
    not_tested = [c for r in rounds for c in r.confirmations if not c.tested]
    if not_tested:
        lines.append("not tested (no evidence either way): " + "; ".join(
            f"{c.effect_id}: {c.not_tested_reason}" for c in not_tested))
    if not named and any(r.withheld for r in rounds):
        lines.append(f"no catalogue effect named: what the round would have named imitates an effect outside the "
                     f"catalogue (held-out error {before:.2f} deg, noise floor {floor:.2f} deg)")
    elif not named:
        lines.append(f"no missing effect found: no catalogue effect improved the held-out error "
                     f"({before:.2f} deg, noise floor {floor:.2f} deg) enough to pass")
    raw_after = after if raw_after is None else raw_after
    scored = (f" (scored as the gate scores candidates, each held-out log with its own small factors: "
              f"{after:.2f} deg)" if abs(after - raw_after) >= 0.005 else "")
    if unexplained and any(r.withheld for r in rounds):
        lines.append(f"unexplained: the held-out error of the model as fitted, with no per-log factor "
                     f"({raw_after:.2f} deg, {raw_after - floor:.2f} deg above the noise floor){scored}, holds a "
                     f"residual that an effect outside the catalogue explains better than any catalogue effect "
                     f"(above)")
    elif unexplained:
        varies = variation is not None and variation["share_of_gap"] >= 0.5
        lines.append(f"unexplained: the held-out error of the model as fitted, with no per-log factor "
                     f"({raw_after:.2f} deg), stays {raw_after - floor:.2f} deg above the noise floor{scored}; "
                     + ("the constants' variation from log to log can account for most of it (next line), and no "
                        "effect in a model with one set of constants takes that up"
                        + (" (the gate judged the effects named on the scored error)" if named else "")
                        if varies else "no catalogue effect accounts for it"))
        if varies:
            lines.append(f"log-to-log variation of the constants can account for most of that remainder: "
                         f"refitting the model's constants on each held-out log alone brings it to "
                         f"{variation['per_log_refit_rmse_deg']:.2f} deg ({variation['share_of_gap']:.0%} of the gap). "
                         f"An in-sample check: per-log constants also take up part of an effect they can imitate, "
                         f"so this is an upper bound on the variation, not a finding that no effect is missing")
            if after - floor > unexplained_margin * floor:
                # the share above is of the raw gap; the scored error (each log with its own factors) may be
                # untouched by it, and that remainder is the one that matters (a payload ringing read as variation)
                lines.append(f"but scored with each held-out log's own factors the error stays at {after:.2f} deg, "
                             f"{after - floor:.2f} deg ({(after - floor) / floor:.2f} noise floors) above the floor: "
                             f"a remainder that neither the catalogue nor log-to-log variation explains (an effect "
                             f"outside the catalogue, or a sensor or rig problem); look at the residual diagnostics "
                             f"(whiteness, correlations) in discovery.yaml")
    else:
        lines.append(f"the held-out error ({raw_after:.2f} deg) is within the noise floor ({floor:.2f} deg) give or "
                     f"take the reporting margin ({unexplained_margin:g} noise floors): nothing left to explain")
    fit_rmse = None
    if base_fit is not None:
        fit_rmse = (base_fit.get("per_log_constants") or {}).get("rmse_deg", base_fit.get("rmse_deg"))
    if (not named and unexplained and fit_rmse is not None and floor > 0 and fit_rmse <= FIT_AT_FLOOR * floor
            and after >= HELDOUT_ABOVE * floor and not held_out_odd):
        # a cause the user can act on: what the held-out logs show, the fitting logs never asked of the model
        lines.append(f"the fitting logs do not show it: the base model fits them to {fit_rmse:.2f} deg "
                     f"({fit_rmse / floor:.2f} noise floors) while the held-out logs stay at {after:.2f} deg "
                     f"({after / floor:.2f}): the held-out logs exercise the muscle in a way the fitting logs do not "
                     f"(faster pressure changes, other amplitudes or holds, or later in a session that warms the "
                     f"muscle), and an effect that shows only there cannot "
                     f"pass a test on the fitting logs; fit on logs like the held-out ones as well")
    if base_fit is not None and not base_fit.get("converged", True):
        lines.append(f"caution: the base fit did not converge ({base_fit.get('message')})")
    lines += [f"caution: {c}" for c in cautions]
    for c in (noise or {}).get("caution") or []:
        lines.append(f"caution on the noise floor: {c}")
    if thr is not None:
        lines.append("gate: " + gate_in_words(thr))
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# the loop
# ---------------------------------------------------------------------------------------------
def split_logs(logs: Sequence[MotionLog], holdout: Sequence[MotionLog] | None, cfg: DiscoverConfig):
    """Fitting and held-out logs; InputError (exit 2) when the data cannot be judged."""
    logs = list(logs)
    for lg in list(logs) + list(holdout or []):
        if lg.angle_deg is None:
            raise InputError("the log has no angle column; discovery needs measured angles", path=lg.path or lg.name)
        if lg.n < cfg.min_log_samples:
            raise InputError(f"cannot judge: the log has {lg.n} samples, fewer than {cfg.min_log_samples} (the "
                             f"config's discover.min_log_samples; default 30)", path=lg.path or lg.name)
        # a sign flipped, named before any fit; an angle offset (a catalogue effect, up to -30 deg) may dip below 0
        check_angle_range(lg, tolerance_deg=ANGLE_BELOW_ZERO_DEG)
    if holdout:
        fit, ho, how = logs, list(holdout), "held-out logs given with --holdout"
    else:
        if len(logs) < 2:
            raise InputError("cannot judge: one log leaves nothing to hold out. Discovery scores every effect on "
                             "whole logs it did not fit; give more logs or --holdout LOG", path=logs[0].path or logs[0].name)
        k = max(2, cfg.holdout_every)
        idx_ho = {i for i in range(len(logs) - 1, -1, -k)}
        fit = [lg for i, lg in enumerate(logs) if i not in idx_ho]
        ho = [lg for i, lg in enumerate(logs) if i in idx_ho]
        how = f"fixed split: every {_ordinal(k)} log from the last is held out"
    n_fit = sum(lg.n for lg in fit)
    if n_fit < cfg.min_fit_samples:
        raise InputError(f"cannot judge: the fitting logs hold {n_fit} samples, fewer than {cfg.min_fit_samples}; "
                         "record longer or more logs")
    return fit, ho, how


#: a noise floor below this is rounding of noise-free numbers, not a sensor's noise (no sensor resolves 1e-9 deg)
NOISE_FLOOR_MIN_DEG = 1e-9

#: scale factors of the start's moduli and time constants the base fit's multi-start scores
_BASE_MODULUS_SCALES = (0.35, 0.6, 1.0, 1.7, 3.0)
_BASE_TAU_SCALES = (0.3, 1.0, 3.0)


def fit_base(state0: ModelState, fit_logs: Sequence[MotionLog], cfg: DiscoverConfig):
    """Base VBMM fit from several starts: the given constants with every modulus and time constant scaled
    (:data:`_BASE_MODULUS_SCALES` x :data:`_BASE_TAU_SCALES`), each scored by one simulation; the best
    ``cfg.base_starts`` are refitted and the lowest error kept. Returns (state, FitResult, report)."""
    p0 = state0.params
    starts = []
    for sm in _BASE_MODULUS_SCALES:
        for st in _BASE_TAU_SCALES:
            vals = {}
            for prm in p0:
                if prm.fixed:
                    continue
                f = st if ".tau_" in prm.name else sm
                vals[prm.name] = min(max(prm.value * f, prm.lower), prm.upper)
            ps = p0.with_values(vals)
            r = stacked(gained_residuals(simulate(state0, fit_logs, ps), fit_logs, per_log_gain=cfg.per_log_gain))
            starts.append((float(r @ r), sm, st, ps))
    starts.sort(key=lambda x: x[0])
    best, tried = None, []
    for sse, sm, st, ps in starts[:cfg.base_starts]:
        if best is not None and best[1].success:
            break                      # the best-scored start converged: the next one is not needed
        st_state = dataclasses.replace(state0, params=ps)
        state, res = fit_state(st_state, fit_logs, max_nfev=cfg.base_max_nfev, check_identifiability=False,
                               per_log_gain=cfg.per_log_gain)
        tried.append({"moduli_times": sm, "time_constants_times": st,
                      "start_rmse_deg": round(math.sqrt(sse / max(res.residual.size, 1)), 4),
                      "rmse_deg": round(res.rmse, 4), "converged": bool(res.success), "evaluations": int(res.nfev)})
        if best is None or (res.success, -res.rmse) > (best[1].success, -best[1].rmse):
            best = (state, res)
    state, res = best
    start_rmse = math.sqrt(starts[[s[1:3] for s in starts].index((1.0, 1.0))][0] / max(res.residual.size, 1))
    report = {"converged": bool(res.success), "message": str(res.message), "rmse_deg": round(res.rmse, 4),
              "rmse_at_given_start_deg": round(start_rmse, 4), "evaluations": int(res.nfev),
              "starts_scored": len(starts), "starts_refitted": tried,
              "per_log_gain": bool(cfg.per_log_gain),
              "method": "multi-start: the given constants with moduli x (0.35..3) and time constants x (0.3..3), "
                        "each scored by one simulation; the best refitted by least squares (fixed budget)"}
    return state, res, report


@one_blas_thread  # a sequence of small solves: one BLAS thread (bpmid.relax._blas is the one place that sets it)
def discover(logs: Sequence[MotionLog], base: VBMM, *, holdout: Sequence[MotionLog] | None = None,
             cfg: DiscoverConfig | None = None, effects: Sequence[Effect] | None = None,
             thresholds: dict | None = None) -> DiscoveryResult:
    """Run the discovery loop (see module docstring).

    Parameters
    ----------
    logs : motion logs with measured angles
    base : the starting VBMM (its material is refitted: K_inf, K_j, tau_j)
    holdout : held-out logs; None = a fixed split of ``logs``
    cfg : settings and threshold overrides
    effects : candidate effects (default: the catalogue, or ``cfg.candidates``)
    thresholds : the gate's thresholds (``heldout_gain_min_sigma``, ``gap_share_min``, ``family_alpha``);
        None = the calibrated ones (``cfg`` overrides win over both)

    Raises
    ------
    InputError : inputs the workflow cannot judge (too short, nothing to hold out, base fit not converged)
    """
    t0 = time.perf_counter()
    cfg = cfg or DiscoverConfig()
    thr = cfg.thresholds()
    if thresholds is not None:
        given = {k: float(v) for k, v in thresholds.items() if k in thr}
        thr = cfg.overrides(later_gain_follows({**thr, **given}, given))
    if effects is None:
        effects = [get_effect(i) for i in (cfg.candidates or tuple(CATALOGUE))]
    if cfg.hold:
        effects = [held(e, cfg.hold) for e in effects]
    fit_logs, ho_logs, how = split_logs(logs, holdout, cfg)
    # a held-out score on a fitting log tests nothing: the verdict would rest on it (given twice, or a copy)
    from bpmid.compare import near_copies, same_logs

    exact = same_logs(fit_logs, ho_logs)
    for name, (other, same_file) in exact.items():
        bad = next(lg for lg in ho_logs if lg.name == name)
        raise InputError(f"the held-out log {bad.path or name} " + ("is also a fitting log" if same_file else
                         f"has the same data as the fitting log {other}") + ": the held-out check would score the "
                         "fit on its own data; " + ("give it either as a LOG or after --holdout, not both"
                                                    if holdout is not None else "give each log once"),
                         path=bad.path)
    copies = [w.replace("test log", "held-out log", 1).replace("training log", "fitting log", 1)
              .replace("give a log the models were not fitted on", "hold out a log the fit does not see")
              for w in near_copies(fit_logs, ho_logs, exact).values()]
    noise = noise_floor(list(fit_logs) + list(ho_logs))
    floor = noise["sigma_deg"]
    if not (np.isfinite(floor) and floor > NOISE_FLOOR_MIN_DEG):
        quiet = [lg for lg in list(fit_logs) + list(ho_logs) if not noise["per_log"].get(lg.name, 0.0) > NOISE_FLOOR_MIN_DEG]
        names = ", ".join(str(lg.path or lg.name) for lg in quiet[:4]) + (", ..." if len(quiet) > 4 else "")
        raise InputError("cannot judge: the measured angle shows no noise at all (noise floor 0"
                         + (f"; logs without noise: {names}" if quiet else "") + "); discovery needs raw "
                         "measurements, not smoothed or simulated noise-free data",
                         path=quiet[0].path if quiet and quiet[0].path is not None else None)
    gain = cfg.per_log_gain

    note(f"discover: fitting the base VBMM on {len(fit_logs)} log(s), {len(ho_logs)} held out")
    state, res, base_report = fit_base(ModelState.start(base), fit_logs, cfg)
    if not res.success or not np.all(np.abs(res.residual) < 1e2):
        raise ConvergenceError(f"cannot judge: the base VBMM fit did not converge ({res.message}; "
                               f"{res.nfev} evaluations, RMSE {res.rmse:.3g} deg). A verdict on missing effects needs a "
                               "converged base model: check the logs' pressure reference and units, or start it with --init")
    all_logs = list(fit_logs) + list(ho_logs)

    def nuisance_for(st: ModelState):
        # the factors on K_inf and the branch moduli carry the stiffness; a gain beside them would be nearly
        # collinear with them and loosen the tie of the fitting logs' factors (sum zero)
        return (LogNuisance.for_state(st, all_logs, gain=False, fit_logs=fit_logs) if cfg.per_log_constants
                else cfg.per_log_gain)

    if cfg.per_log_constants:
        # the common constants refitted with every log's own factors beside them (the factors sum to zero)
        gain = nuisance_for(state)
        state2, res2 = fit_state(state, fit_logs, max_nfev=cfg.base_max_nfev, check_identifiability=False,
                                 per_log_gain=gain)
        if res2.success and res2.rmse <= res.rmse:
            state, res = state2, res2
        base_report["per_log_constants"] = {"rmse_deg": round(res2.rmse, 4), "converged": bool(res2.success),
                                            "evaluations": int(res2.nfev), "nuisance": gain.describe()}
        gain = nuisance_for(state)
    base_state = state
    if res.rmse < floor:
        # the noise cannot exceed what the fitted base model leaves on the fitting logs: a coloured-noise estimate
        # above it mistook slow signal for noise
        noise = dict(noise, sigma_deg=float(res.rmse), capped_by_base_fit=True,
                     method=noise.get("method", "") + "; capped by the base fit's RMSE on the fitting logs",
                     caution=list(noise.get("caution") or [])
                     + [f"the floor used is {res.rmse:.3g} deg, the base fit's RMSE on the fitting logs: the noise "
                        f"reading above ({noise['sigma_deg']:.3g} deg) cannot exceed what the model leaves"])
        floor = noise["sigma_deg"]
    before = scored_rmse(state, ho_logs, per_log_gain=gain)
    raw_before = rmse_deg(residuals(state, ho_logs))
    rounds: list[Round] = []
    named: list[str] = []
    while len(named) < cfg.max_effects:
        k = len(rounds)   # two effects named together take two rounds of the record
        remaining = [e for e in effects if e.id not in named]
        if not remaining:
            break
        # every round scores with the base model's per-log factors (``gain`` is not re-derived for the model as it
        # now stands), as the final before/after does: the same two effects then score the same on the held-out
        # logs whether a pair trial or a later round refitted them. Re-derived for a model with a switching term
        # (a faster deflation's rise/fall switch, friction's stick and slip), the finite-difference directions
        # carry spikes where the switch moves with the step, which score every model of the round worse and
        # shrink a second effect's gain (draw58-0017: stiffening beside a slower deflation 0.24 noise floors in
        # the pair trial, 0.09 in round 2); re-derived for any named effect, their bounds come from a smaller
        # fitting-log spread (see the before and after below).
        sim = simulate(state, fit_logs)
        parts = gained_residuals(sim, fit_logs, per_log_gain=gain)
        diag = diagnose(fit_logs, parts)
        note(f"discover: round {k + 1}: screening {len(remaining)} effect(s)")
        J = sensitivities(state, fit_logs, base_sim=sim)
        ranking = screen(state, remaining, fit_logs, base_sim=sim, nuisance=J, per_log_gain=gain)
        lead = [s.effect_id for s in ranking[:cfg.n_confirm]]
        ho_res_now = heldout_residual(state, ho_logs, gain)
        ho_now = rmse_deg([ho_res_now])   # scored_rmse, the residual kept for every candidate
        confs = []
        with Progress(len(lead), f"round {k + 1}: confirming") as pr:
            for eid in lead:
                e = next(x for x in remaining if x.id == eid)
                c = confirm(state, e, fit_logs, ho_logs, noise_floor_deg=floor, base_fit_residual=stacked(parts),
                            heldout_before=ho_now, max_nfev=cfg.confirm_max_nfev, nuisance=J, per_log_gain=gain,
                            heldout_before_res=ho_res_now)
                confs.append(c)
                pr.advance(detail=eid)
        family = len(remaining)
        for c, ph in zip(confs, holm_adjusted([c.lr_p if c.tested else 1.0 for c in confs], family)):
            c.lr_p_holm = ph
        for c in confs:
            c.reasons = judge(c, thr, floor, later=bool(named))
            c.accepted = not c.reasons
            c.passed_by = "gap" if c.accepted else ""
        passing = [c for c in confs if c.accepted]
        if not passing and math.isfinite(float(thr.get("to_floor_drop_min_sigma", math.inf))):
            for c in confs:
                why = judge_to_floor(c, thr, floor)
                if not why:
                    c.accepted, c.passed_by = True, "floor"
                    c.gate_reasons, c.reasons = list(c.reasons), []
                elif _open_to_floor(c, thr):
                    c.reasons.append("nor does it take the held-out error to the noise floor: " + "; ".join(why))
            passing = [c for c in confs if c.accepted]
        # the best of those passing alone (by the held-out drop on the path to the floor, else by the held-out gain,
        # equal gains by the drop: :func:`winner_rank`; gains within the round's gain threshold of each other by the
        # fitting logs: :func:`gain_winner`)
        by_floor = bool(passing) and passing[0].passed_by == "floor"
        score = (lambda c: c.drop_sigma) if by_floor else (lambda c: c.heldout_gain_sigma)
        tie = float(thr.get("heldout_gain_min_sigma_later", thr["heldout_gain_min_sigma"]) if named
                    else thr["heldout_gain_min_sigma"])
        top = max(passing, key=lambda c: winner_rank(score(c), c.drop_sigma)) if passing else None
        best = (top if by_floor or top is None else
                gain_winner(passing, lambda c: c.heldout_gain_sigma, lambda c: c.drop_sigma, lambda c: c.fit_share,
                            tie))
        trials: list[PairTrial] = []
        pair_open = math.isfinite(float(thr.get("pair_share_min", math.inf)))
        margin = float(thr.get("pair_over_single_min_sigma", math.inf))
        # a pair's held-out gain is at most the whole gap above the floor, so it can beat the passing candidate by
        # the margin only when that candidate leaves at least the margin of it: otherwise no pair is refitted
        over_open = (math.isfinite(margin) and best is not None
                     and excess_deg(best.heldout_rmse_after, floor) / max(floor, 1e-9) >= margin - 1e-9)
        if not named and len(remaining) >= 2 and cfg.max_effects >= 2 and (
                cfg.record_pair_trials or (pair_open and not passing) or (over_open and passing)):
            trials = try_pairs(confs, remaining, fit_logs, ho_logs, floor=floor, heldout_before=ho_now,
                               max_nfev=cfg.confirm_max_nfev, per_log_gain=gain,
                               alpha=None if cfg.record_pair_trials else thr["family_alpha"])
            for pt in trials:
                if not passing:
                    pt.reasons = judge_pair(pt, thr) if pair_open else [
                        "not asked: no path for two effects at once in this gate"]
                else:
                    pt.reasons = judge_pair_over(pt, thr, best) if math.isfinite(margin) else [
                        "not asked: a candidate passed alone"]
                pt.accepted = not pt.reasons
        won = [pt for pt in trials if pt.accepted]
        # what the round would name: two effects together, or the best of those passing alone
        pt = max(won, key=lambda x: x.gain_sigma) if won else None
        rival, withheld, rivals = None, "", []
        if pt is not None or best is not None or not cfg.withhold_for_rivals:
            # the rivals outside the catalogue, each refitted and scored like the candidates; the first that takes
            # the round withholds it
            # what the round would name, and the held-out RMSE a rival must beat (two effects named together: the
            # better of the two alone)
            names, named_id, named_after = None, "", math.nan
            if pt is not None:
                names, named_after = pt.ids, min(pt.first.heldout_rmse_after, pt.second.heldout_rmse_after)
            elif best is not None:
                names, named_after = (best.effect_id,), best.heldout_rmse_after
            if names is not None:
                named_id = "+".join(names)
            for R in RIVALS:
                if names is not None and not held_against(R.id, names):
                    continue   # a rival asked only of the effects it can pass for (rivals.IMITATES)
                rv = confirm(state, R(), fit_logs, ho_logs, noise_floor_deg=floor,
                             base_fit_residual=stacked(parts), heldout_before=ho_now, heldout_before_res=ho_res_now,
                             max_nfev=cfg.confirm_max_nfev, nuisance=J, per_log_gain=gain)
                if names is not None and R.id in IMITATES and beats(rv, named_after, thr["family_alpha"]):
                    # a nuisance that can stand beside the effect: the effect refitted on top of it must add nothing
                    # before the rival takes the round
                    _refit_beside(rv, next(x for x in remaining if x.id in names and x.id in IMITATES[R.id]),
                                  fit_logs, ho_logs, floor=floor, thr=thr, max_nfev=cfg.confirm_max_nfev, gain=gain)
                rivals.append(rv)
                why = (check_rival(rv, named_id, named_after, thr["family_alpha"], floor) or "") if names else ""
                if why and not withheld:
                    rival, withheld = rv, why
            if rival is None and rivals:   # none withheld: report the one that came nearest (lowest held-out RMSE)
                rival = min(rivals, key=lambda c: (not c.tested, c.heldout_rmse_after))
        if withheld and cfg.withhold_for_rivals:
            for c in passing:
                c.accepted, c.passed_by = False, ""
                c.reasons = [withheld if c is best else
                             f"passed, but the round was withheld: {named_id} explained the held-out logs better, "
                             "and the rival outside the catalogue better still (see its reason)"]
            for x in won:
                x.accepted = False
                x.reasons = [withheld]
            rounds.append(Round(diag, ranking, confs, None, family, "", trials, rival=rival, withheld=withheld,
                                rivals=rivals))
            note(f"discover: round {k + 1}: nothing named: " + withheld.split(":", 1)[1].split(";")[0].strip())
            break
        if pt is not None:
            for x in won:
                if x is not pt:
                    x.accepted = False
                    x.reasons = [f"passed, but {'+'.join(pt.ids)} explains the held-out logs better (held-out gain "
                                 f"{pt.gain_sigma:.2f} vs {x.gain_sigma:.2f} noise floors)"]
            # each member's verdict alone (empty: it passed alone, and the pair was named over a single effect)
            alone = {id(x): list(x.reasons) for x in (pt.first, pt.second)}
            for c in passing:   # a pair named over the single effect the round would have named
                if c is pt.first:
                    continue
                c.accepted, c.passed_by = False, ""
                c.reasons = ([f"named together with {pt.first.effect_id}: its numbers beside it are the next "
                              f"round's"] if c is pt.second else
                             [f"passed, but {'+'.join(pt.ids)} refitted together explain the held-out logs better "
                              f"(held-out gain {pt.gain_sigma:.2f} vs {c.heldout_gain_sigma:.2f} noise floors)"])
            a, b = pt.first, pt.joint
            for c in (a, b):
                c.gate_reasons = alone[id(pt.first) if c is a else id(pt.second)]
                c.accepted, c.passed_by, c.reasons = True, "pair", []
                c.named_with = b.state    # the constants named are the joint refit's
            b.lr_p_holm = pt.p_corrected  # its test beside the first, Bonferroni over the pairs tried
            words = pair_words(pt, floor, over=best)
            rounds.append(Round(diag, ranking, confs, a.effect_id, family, words, trials, rival=rival,
                                rivals=rivals))
            # the second's record: its evidence beside the first, on the residual the first left
            parts_a = gained_residuals(simulate(a.state, fit_logs), fit_logs, per_log_gain=gain)
            rounds.append(Round(diagnose(fit_logs, parts_a), [x for x in ranking if x.effect_id != a.effect_id],
                                [b], b.effect_id, pt.n_pairs,
                                f"named together with {a.effect_id} (round {k + 1}): the two were refitted together, "
                                f"and these are {b.effect_id}'s numbers beside {a.effect_id}",
                                [], joint_with=a.effect_id))
            named += [a.effect_id, b.effect_id]
            state = b.state
            note(f"discover: added {a.effect_id} and {b.effect_id} together (held-out {pt.heldout_rmse_before:.3f} "
                 f"-> {pt.heldout_rmse_after:.3f} deg)")
            continue
        what = "held-out drop" if by_floor else "held-out gain"
        what_vs = "held-out drop " if by_floor else ""
        competition = ""
        if best is not None and len(passing) > 1:
            others = [c for c in passing if c is not best]
            competition = (f"{len(passing)} candidates passed the gate"
                           + (" on the path to the noise floor" if by_floor else "")
                           + " this round and may explain the same residual: "
                           + ", ".join(f"{c.effect_id} ({what} {score(c):.2f} noise floors"
                                       + ("" if by_floor else f", {c.gap_share:.0%} of the gap") + ")"
                                       for c in sorted(passing, key=lambda c: winner_rank(score(c), c.drop_sigma),
                                                       reverse=True))
                           + (f"; {best.effect_id} won on the larger confirmed {what}" if best is top else
                              f"; the held-out logs leave {best.effect_id} and {top.effect_id} level (held-out gains "
                              f"{score(best):.2f} and {score(top):.2f} noise floors, within the {tie:g} the gate asks "
                              f"of an effect at all), so the fitting logs decided: {best.effect_id}'s refit removed "
                              f"{best.fit_share:.0%} of their gap above the noise, {top.effect_id}'s "
                              f"{top.fit_share:.0%}")
                           + ("" if by_floor or best is not top
                              or not any(winner_rank(score(c))[0] == winner_rank(score(best))[0] for c in others) else
                              f" (gains equal: each left the held-out error at the noise floor, so the larger "
                              f"held-out drop, sqrt(before^2 - after^2), decided: {best.drop_sigma:.3f} noise floors)")
                           + ", and the others are judged again in the next round with it in the model")
            for c in others:
                c.accepted, c.passed_by = False, ""
                c.reasons = [f"passed, but {best.effect_id} explains the held-out logs better "
                             f"({what_vs}{score(best):.2f} vs {score(c):.2f} noise floors)"
                             if score(best) >= score(c) else
                             f"passed, level with {best.effect_id} on the held-out logs ({score(c):.2f} vs "
                             f"{score(best):.2f} noise floors, within {tie:g}), whose refit explains more of the "
                             f"fitting logs ({best.fit_share:.0%} vs {c.fit_share:.0%} of their gap above the noise)"]
        rounds.append(Round(diag, ranking, confs, best.effect_id if best else None, family, competition, trials,
                            rival=rival, rivals=rivals))
        if best is None:
            break
        named.append(best.effect_id)
        state = best.state
        note(f"discover: added {best.effect_id} (held-out {best.heldout_rmse_before:.3f} -> "
             f"{best.heldout_rmse_after:.3f} deg)")
    # before and after scored alike: with the base model's nuisance, the one every round used. A nuisance
    # re-derived for the final model would bound the held-out factors by its own, smaller, fitting-log spread, and
    # held against the base model's looser scoring it would understate what the named effects removed.
    after = scored_rmse(state, ho_logs, per_log_gain=gain)
    raw_after = rmse_deg(residuals(state, ho_logs))
    # a round withheld for a rival outside the catalogue leaves a systematic residual the catalogue cannot explain
    unexplained = bool(raw_after - floor > cfg.unexplained_gap_sigma * floor or any(r.withheld for r in rounds))
    variation = log_to_log_variation(state, ho_logs, raw_after, floor, cfg) if unexplained else None
    cautions, held_out_odd = data_cautions(base_state, state, fit_logs, ho_logs, floor)
    cautions += ambient_cautions(all_logs, named) + sampling_cautions(all_logs, named) + copies \
        + gate_cautions(cfg.thresholds_file, thresholds_calibration(cfg.thresholds_file) if cfg.thresholds_file
                        else {}, all_logs, noise)
    verdict = make_verdict(named, rounds, before, after, floor, unexplained, variation, thr, base_report, raw_after,
                           noise, cfg.unexplained_gap_sigma, final=state, cautions=cautions,
                           held_out_odd=held_out_odd)
    return DiscoveryResult(named, rounds, noise, base_state, state, list(fit_logs), list(ho_logs), before, after,
                           thr, unexplained, verdict, how, time.perf_counter() - t0, variation, base_report,
                           raw_before, raw_after, gain, thresholds_file=cfg.thresholds_file,
                           overridden=tuple(sorted({k for k in GATE_KEYS if getattr(cfg, k, None) is not None}
                                                   | ({BY_EFFECT_KEY} if cfg.to_floor_drop_by_effect is not None
                                                      else set()) | {k for k in (thresholds or {}) if k in thr})),
                           cautions=tuple(cautions))


def log_to_log_variation(state: ModelState, ho_logs: Sequence[MotionLog], after: float, floor: float,
                         cfg: DiscoverConfig) -> dict:
    """How much of an unexplained held-out gap the constants' variation between logs can account for.

    The final model's constants are refitted on each held-out log alone and scored on that same log (in
    sample, on purpose: it bounds what specimen or replicate variation of the constants can explain, as
    opposed to a missing effect, which no choice of constants removes).
    """
    note("discover: checking whether log-to-log variation of the constants explains the remainder")
    parts = []
    for lg in ho_logs:
        st, _ = fit_state(state, [lg], max_nfev=cfg.base_max_nfev, check_identifiability=False)
        parts.append(residuals(st, [lg])[0])
    refit = rmse_deg(parts)
    gap = max(after - floor, 1e-12)
    share = float(np.clip((after - refit) / gap, 0.0, 1.0))
    return {"per_log_refit_rmse_deg": round(refit, 4), "share_of_gap": round(share, 3),
            "method": "constants refitted on each held-out log alone, scored in sample"}


def _refit_beside(rv: Confirmation, effect: Effect, fit_logs, ho_logs, *, floor: float, thr: dict, max_nfev: int,
                  gain) -> None:
    """Refit ``effect`` on top of the rival ``rv``'s fit and store on ``rv`` whether it still adds what the rival
    cannot (:func:`bpmid.discover.rivals.adds_beside`, asked the drop the gate asks of the effect on the path to
    the noise floor, or the gain asked of an effect at all when the gate has no such path)."""
    rv.effect_beside = confirm(
        rv.state, effect, fit_logs, ho_logs, noise_floor_deg=floor,
        base_fit_residual=stacked(gained_residuals(simulate(rv.state, fit_logs), fit_logs, per_log_gain=gain)),
        heldout_before=rv.heldout_rmse_after, max_nfev=max_nfev, nuisance=sensitivities(rv.state, fit_logs),
        per_log_gain=gain)
    drop = floor_drops(thr).of(effect.id)
    rv.effect_beside_adds = adds_beside(rv.effect_beside, rv, thr["family_alpha"], floor,
                                        drop if math.isfinite(drop) else float(thr["heldout_gain_min_sigma"]))


def judge(c: Confirmation, thr: dict, floor: float | None = None, later: bool = False) -> list[str]:
    """Reasons to reject a confirmed candidate (empty: it passes). A candidate that was not tested is rejected
    with that reason only: it is no evidence against the effect. ``later``: a further effect, after one was named
    (judged with ``heldout_gain_min_sigma_later``)."""
    if not c.tested:
        return [f"not tested: {c.not_tested_reason}"]
    why = []
    waive_id = float(thr.get("identifiable_waived_above_sigma", math.inf))
    if not c.identifiable and not (math.isfinite(c.heldout_gain_sigma) and c.heldout_gain_sigma > waive_id):
        why.append("none of its parameters is identifiable: " + "; ".join(f"{k}: {v}" for k, v in c.not_identifiable.items()))
    g_min = thr["heldout_gain_min_sigma"]
    if later:
        g_min = thr.get("heldout_gain_min_sigma_later", g_min)
    if not math.isfinite(c.heldout_gain_sigma) or c.heldout_gain_sigma < g_min:
        x, lim = _apart(c.heldout_gain_sigma + 0.0, g_min, 2)   # + 0.0: no "-0.00"
        why.append(f"held-out gain above the noise {x} noise floors < {lim}"
                   + (" (asked of a further effect)" if later else ""))
    if not (math.isfinite(c.gap_share) and c.gap_share >= thr["gap_share_min"]):
        share, lim = _share_apart(c.gap_share, thr["gap_share_min"])
        share = share if math.isfinite(c.gap_share) else "none (no held-out gap above the floor)"
        why.append(f"share of the held-out gap removed {share} < {lim}")
    fs = float(thr.get("fit_share_min", 0.0))
    waive = float(thr.get("fit_share_waived_above_sigma", math.inf))
    if fs > 0 and not (math.isfinite(c.heldout_gain_sigma) and c.heldout_gain_sigma > waive) and not (
            math.isfinite(c.fit_share) and c.fit_share >= fs):
        share, lim = _share_apart(c.fit_share, fs)
        share = share if math.isfinite(c.fit_share) else "none (no fitting gap above the floor)"
        why.append(f"share of the fitting logs' gap removed {share} < {lim}: it leaves most of what the model "
                   "misses unexplained")
    p = c.family_p
    if not p < thr["family_alpha"]:
        why.append(f"Holm-corrected likelihood-ratio p = {p:.2g} >= family-wise {thr['family_alpha']:.2g}")
    return why


def judge_to_floor(c: Confirmation, thr: dict, floor: float) -> list[str]:
    """Reasons a candidate does not pass the path down to the noise floor (empty: it passes; the path is asked
    only in a round where no candidate passes :func:`judge`). Only the reasons of this path's own numbers: the
    test, identifiability and likelihood-ratio conditions are :func:`judge`'s, already stated."""
    d = float(thr.get("to_floor_drop_min_sigma", math.inf))
    if not math.isfinite(d):
        return ["no path to the floor in this gate"]
    d = floor_drops(thr).of(c.effect_id)
    q = float(thr.get("to_floor_ratio_max", 1.0))
    if not _open_to_floor(c, thr):
        return ["not tested, not identifiable or not significant (above)"]
    why = []
    if not (math.isfinite(c.drop_sigma) and c.drop_sigma >= d):
        x, lim = _apart(c.drop_sigma, d)
        why.append(f"held-out drop {x} < {lim} noise floors")
    ratio = c.heldout_rmse_after / floor
    if not ratio <= q:
        x, lim = _apart(ratio, q)
        why.append(f"held-out RMSE left {x} noise floors ({c.heldout_rmse_after:.3f} deg against a floor of "
                   f"{floor:.3f} deg) > {lim}")
    return why


def _open_to_floor(c: Confirmation, thr: dict) -> bool:
    """The conditions the path to the floor shares with the gate: tested, identifiable, significant."""
    return bool(c.tested and c.identifiable and c.family_p < thr["family_alpha"])


def _share_apart(x: float, limit: float) -> tuple[str, str]:
    """Two shares as percentages with the fewest decimals that tell them apart ("29.7% < 30.0%", never
    "30% < 30%"); a share that is not a number reads ``none``."""
    if not math.isfinite(x):
        return "none", f"{limit:.0%}"
    for n in range(0, 8):
        a, b = f"{100 * x:.{n}f}%", f"{100 * limit:.{n}f}%"
        if a != b:
            return a, b
    return f"{x:.6%}", f"{limit:.6%}"


def _apart(x: float, limit: float, digits: int = 3) -> tuple[str, str]:
    """``x`` and ``limit`` printed with the fewest decimals (at least ``digits``) that tell them apart, so that a
    reason never reads "0.225 < 0.225"."""
    for n in range(digits, 12):
        a, b = f"{x:.{n}f}", f"{limit:.{n}f}"
        if a != b:
            return a, b
    return repr(x), repr(limit)


#: leading candidates of a first round refitted two at a time on the paths for two effects at once: this many by
#: held-out gain, joined by this many by the evidence on the fitting logs (:func:`pair_leaders`)
PAIR_LEADERS = 3


def pair_leaders(confs: Sequence[Confirmation]) -> list[Confirmation]:
    """The candidates the paths for two effects at once pair up, among those tested and identifiable: the
    :data:`PAIR_LEADERS` largest positive held-out gains, joined by the :data:`PAIR_LEADERS` with the strongest
    likelihood-ratio evidence on the fitting logs (smallest Holm-corrected p, equal p by the larger gain); ordered by
    held-out gain. Two effects that mask each other (faster deflation beside strain stiffening) can each leave the
    held-out logs no better alone, because each refit alone bends the other's residual, while both are plain on the
    fitting logs; the held-out gain of the pair, not of its members, then decides."""
    ok = [c for c in confs if c.tested and c.identifiable and math.isfinite(c.heldout_gain_sigma)]
    by_gain = [c for c in sorted(ok, key=lambda c: -c.heldout_gain_sigma) if c.heldout_gain_sigma > 0]
    by_fit = sorted(ok, key=lambda c: (c.family_p, -c.heldout_gain_sigma))
    lead = by_gain[:PAIR_LEADERS]
    lead += [c for c in by_fit[:PAIR_LEADERS] if not any(c is x for x in lead)]
    return sorted(lead, key=lambda c: -c.heldout_gain_sigma)


def try_pairs(confs: Sequence[Confirmation], effects: Sequence[Effect], fit_logs, ho_logs, *, floor: float,
              heldout_before: float, max_nfev: int, per_log_gain, alpha: float | None = None) -> list[PairTrial]:
    """The pairs of :func:`pair_leaders` refitted together (the one with the larger gain alone first). With
    ``alpha``, only pairs whose two members pass the round's Holm-corrected test alone are refitted (no other can
    be named); the Bonferroni count is every pair of the leaders either way."""
    lead = pair_leaders(confs)
    pairs = [(a, b) for i, a in enumerate(lead) for b in lead[i + 1:]]
    n_pairs = len(pairs)
    if alpha is not None:
        pairs = [(a, b) for a, b in pairs if a.family_p < alpha and b.family_p < alpha]
    out = []
    if not pairs:
        return out
    with Progress(len(pairs), "round 1: refitting pairs together") as pr:
        for a, b in pairs:
            e = next(x for x in effects if x.id == b.effect_id)
            out.append(pair_trial(a, b, e, fit_logs, ho_logs, noise_floor_deg=floor, heldout_before=heldout_before,
                                  max_nfev=max_nfev, per_log_gain=per_log_gain, n_pairs=n_pairs))
            pr.advance(detail=f"{a.effect_id}+{b.effect_id}")
    return out


def _pair_tested(pt: PairTrial, thr: dict) -> list[str]:
    """Reasons two candidates refitted together cannot be named together on any path: not tested, not
    identifiable, or a likelihood-ratio test failed (alone, Holm; beside the other, Bonferroni over the pairs)."""
    why = []
    if not pt.tested:
        why.append("not tested: " + "; ".join(c.not_tested_reason for c in (pt.first, pt.second, pt.joint)
                                                 if not c.tested))
    if not pt.identifiable:
        why.append("not identifiable: " + ", ".join(c.effect_id for c in (pt.first, pt.second, pt.joint)
                                                    if not c.identifiable))
    alpha = thr["family_alpha"]
    for c in (pt.first, pt.second):
        if not c.family_p < alpha:
            why.append(f"{c.effect_id} alone: Holm-corrected likelihood-ratio p = {c.family_p:.2g} >= {alpha:.2g}")
    if not pt.p_corrected < alpha:
        why.append(f"each beside the other: likelihood-ratio p = {pt.p_corrected:.2g} (the larger, Bonferroni over "
                   f"{pt.n_pairs} pair(s)) >= {alpha:.2g}")
    return why


def judge_pair(pt: PairTrial, thr: dict) -> list[str]:
    """Reasons two candidates refitted together are not named together (empty: both are). Asked only in a first
    round where no candidate passes alone by either path: an effect that shares the gap with another one removes
    too small a share of it alone, although together they close it."""
    why = _pair_tested(pt, thr)
    g = thr["heldout_gain_min_sigma"]
    if not (math.isfinite(pt.gain_sigma) and pt.gain_sigma >= g):
        x, lim = _apart(pt.gain_sigma, g, 2)
        why.append(f"together: held-out gain {x} < {lim} noise floors")
    sh = float(thr.get("pair_share_min", math.inf))
    if not (math.isfinite(pt.gap_share) and pt.gap_share >= sh):
        share, lim = _share_apart(pt.gap_share, sh)
        why.append(f"together: share of the held-out gap removed {share} < {lim}")
    gm = float(thr.get("pair_gain_min_sigma", math.inf))
    if not (math.isfinite(pt.min_gain_given_other) and pt.min_gain_given_other >= gm):
        x, lim = _apart(pt.min_gain_given_other, gm, 2)
        why.append(f"the weaker of the two adds a held-out gain of {x} < {lim} noise floors beside the other")
    return why


def judge_pair_over(pt: PairTrial, thr: dict, single: Confirmation) -> list[str]:
    """Reasons two candidates refitted together are not named instead of ``single``, the effect a first round
    would name alone (empty: they are): their joint held-out gain must exceed its gain by
    ``pair_over_single_min_sigma`` noise floors, and each must add ``pair_over_gain_min_sigma`` beside the other.
    Two effects present at once can make a third candidate the best alone (a slow branch imitating a softening
    with time when a stiffening is there too); refitted together, the true two explain more than it."""
    why = _pair_tested(pt, thr)
    g = thr["heldout_gain_min_sigma"]
    need = max(g, single.heldout_gain_sigma + float(thr["pair_over_single_min_sigma"]))
    if not (math.isfinite(pt.gain_sigma) and math.isfinite(pt.gap_share) and pt.gain_sigma >= need):
        x, lim = _apart(pt.gain_sigma, need, 2)
        why.append(f"together: held-out gain {x} < {lim} noise floors ({single.effect_id} alone "
                   f"{single.heldout_gain_sigma:.2f}, plus the margin {_thr(thr['pair_over_single_min_sigma'])})")
    gm = float(thr.get("pair_over_gain_min_sigma", math.inf))
    if not (math.isfinite(pt.min_gain_given_other) and pt.min_gain_given_other >= gm):
        x, lim = _apart(pt.min_gain_given_other, gm, 2)
        why.append(f"the weaker of the two adds a held-out gain of {x} < {lim} noise floors beside the other")
    return why


def pair_words(pt: PairTrial, floor: float, over: Optional[Confirmation] = None) -> str:
    """Why two effects were named together, in words (``over``: the single effect the round would have named)."""
    a, b = pt.ids
    lead = ("no candidate passed alone" if over is None else
            f"{over.effect_id} passed alone (held-out gain {over.heldout_gain_sigma:.2f} noise floors), but two "
            f"effects refitted together explained more")
    return (f"{lead}; {a} and {b} refitted together cut the held-out error from "
            f"{pt.heldout_rmse_before:.3f} to {pt.heldout_rmse_after:.3f} deg (noise floor {floor:.3f} deg), "
            f"removing {pt.gap_share:.0%} of the gap above the floor (gain {pt.gain_sigma:.2f} noise floors); beside "
            f"the other, {a} adds {pt.gain_first_given_second:.2f} and {b} {pt.gain_second_given_first:.2f} noise "
            f"floors of held-out gain (likelihood-ratio p {p_words(pt.p_first_given_second)} and "
            f"{pt.p_second_given_first:.2g}, the larger Bonferroni-corrected over {pt.n_pairs} pair(s) to "
            f"{pt.p_corrected:.2g}): "
            + ("the two share the residual, so neither removes enough of it alone, and both are named" if over is None
               else f"each is needed beside the other, and both are named instead of {over.effect_id} alone"))
