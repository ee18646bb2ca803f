"""The discovery loop: fit the base VBMM, diagnose, screen the catalogue, confirm, add one effect at a time.

:func:`discover` is the library entry point of ``bpmid discover``. It never scores an effect on the samples
that fitted it: candidates are refitted on the fitting logs and judged on whole held-out logs (given with
``--holdout``, or a fixed split of the logs: every ``holdout_every``-th log). It stops when no candidate passes,
and says so: "no missing effect found" is a legitimate answer.

Accepting an effect needs all of (thresholds: :mod:`bpmid.discover.calibrate`, calibrated on twin data):

- held-out RMSE drop of at least ``heldout_gain_min_sigma`` noise floors,
- delta BIC (effective N) at most ``delta_bic_max`` and the boundary-corrected LR p-value below ``lr_p_max``,
- at least one of its own parameters identifiable (the others held at their default).

Among the candidates that pass, the one with the lowest held-out RMSE is added.
"""
from __future__ import annotations

import dataclasses
import math
import time
from typing import Optional, Sequence

import numpy as np

from bpmid.discover.calibrate import load_thresholds
from bpmid.discover.confirm import Confirmation, confirm
from bpmid.discover.diagnose import diagnose, noise_floor
from bpmid.discover.model import ModelState, fit_state, residuals, rmse_deg, simulate, stacked
from bpmid.discover.screen import ScreenResult, screen
from bpmid.effects import CATALOGUE, get_effect
from bpmid.effects.base import Effect
from bpmid.errors import ConvergenceError, InputError
from bpmid.io.motion_logs import MotionLog
from bpmid.models.vbmm import VBMM
from bpmid.progress import Progress, note
from bpmid.relax._blas import one_blas_thread


@dataclasses.dataclass(frozen=True)
class DiscoverConfig:
    """Config section ``discover``.

    Attributes
    ----------
    candidates : catalogue ids to consider (empty: the whole catalogue)
    max_effects : stop after adding this many effects
    n_confirm : leading screening candidates refitted per round
    holdout_every : without ``--holdout``, every n-th log (counting from the last) is held out; at least one
    min_fit_samples : fewer fitting samples than this cannot be judged (exit 2)
    min_log_samples : a log shorter than this cannot be judged (exit 2)
    base_max_nfev : function-evaluation budget of the base fit; a fit that runs out did not converge (exit 2)
    confirm_max_nfev : budget of each augmented refit
    heldout_gain_min_sigma : accept only if the held-out RMSE drops by this many noise floors (None: calibrated)
    delta_bic_max : accept only if delta BIC (effective N) is at most this (None: calibrated)
    lr_p_max : accept only if the boundary-corrected likelihood-ratio p-value is below this
    unexplained_gap_sigma : the remainder is reported unexplained when the held-out RMSE stays more than this
        many noise floors above the floor
    """

    candidates: tuple[str, ...] = ()
    max_effects: int = 3
    n_confirm: int = 3
    holdout_every: int = 3
    min_fit_samples: int = 200
    min_log_samples: int = 30
    base_max_nfev: int = 300
    confirm_max_nfev: int = 200
    heldout_gain_min_sigma: Optional[float] = None
    delta_bic_max: Optional[float] = None
    lr_p_max: float = 1e-3
    unexplained_gap_sigma: float = 0.5

    def validate(self, where, path):
        for c in self.candidates:
            if c not in CATALOGUE:
                raise InputError(f"unknown effect id {c!r} (known: {', '.join(CATALOGUE)})", path=path,
                                 key=f"{where}.candidates")
        for name in ("max_effects", "n_confirm", "holdout_every", "min_fit_samples", "min_log_samples",
                     "base_max_nfev", "confirm_max_nfev"):
            if getattr(self, name) < 1:
                raise InputError(f"must be at least 1, found {getattr(self, name)}", path=path, key=f"{where}.{name}")
        if not 0 < self.lr_p_max < 1:
            raise InputError(f"must be between 0 and 1, found {self.lr_p_max}", path=path, key=f"{where}.lr_p_max")

    def thresholds(self) -> dict:
        cal = load_thresholds()
        out = dict(cal)
        if self.heldout_gain_min_sigma is not None:
            out["heldout_gain_min_sigma"] = float(self.heldout_gain_min_sigma)
        if self.delta_bic_max is not None:
            out["delta_bic_max"] = float(self.delta_bic_max)
        out["lr_p_max"] = float(self.lr_p_max)
        return out


@dataclasses.dataclass
class Round:
    """One pass of diagnose -> screen -> confirm."""

    diagnostics: dict
    ranking: list[ScreenResult]
    confirmations: list[Confirmation]
    accepted: Optional[str]


@dataclasses.dataclass
class DiscoveryResult:
    """Everything ``bpmid discover`` reports (angles in deg)."""

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
                        "explanation": rnd_explanation(c, rnd, self.noise_floor_deg)})
        return out

    def to_yaml(self) -> dict:
        return {
            "named_effects": list(self.named_effects),
            "steps": self.steps(),
            "gap": {"before_rmse_deg": round(self.heldout_before, 4), "after_rmse_deg": round(self.heldout_after, 4),
                    "noise_floor_deg": round(self.noise_floor_deg, 4),
                    "before_gap_deg": round(self.heldout_before - self.noise_floor_deg, 4),
                    "after_gap_deg": round(self.heldout_after - self.noise_floor_deg, 4)},
            "unexplained": bool(self.unexplained),
            "log_to_log_variation": self.variation,
            "verdict": self.verdict,
            "noise_floor": {"method": "median absolute deviation of the second difference of the measured angle / sqrt(6)",
                            "sigma_deg": round(self.noise_floor_deg, 4),
                            "per_log_deg": {k: round(v, 4) for k, v in self.noise["per_log"].items()}},
            "split": {"how": self.split, "fitting_logs": [lg.name for lg in self.fit_logs],
                      "heldout_logs": [lg.name for lg in self.holdout_logs]},
            "thresholds": dict(self.thresholds),
            "rounds": [{"diagnostics": rnd.diagnostics, "screening": [s.to_yaml() for s in rnd.ranking],
                        "confirmed": [c.to_yaml() for c in rnd.confirmations], "accepted": rnd.accepted}
                       for rnd in self.rounds],
            "base_model": {p.name: p.to_yaml() for p in self.base_state.params},
            "final_model": {p.name: p.to_yaml() for p in self.final_state.params},
            "elapsed_s": round(self.elapsed_s, 2),
        }


# ---------------------------------------------------------------------------------------------
# plain-language evidence
# ---------------------------------------------------------------------------------------------
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
    return (f"{e.describe(c.state.params)}: {e.meaning}. Where it shows: {e.where_it_shows}. Here the residual "
            f"{residual_feature(rnd.diagnostics)}, and the effect's signature explains {s.explained:.0%} of what the "
            f"model left; adding it cut the held-out error from {c.heldout_rmse_before:.2f} to "
            f"{c.heldout_rmse_after:.2f} deg (noise floor {floor:.2f} deg)")


def make_verdict(named: list[str], rounds: list[Round], before: float, after: float, floor: float,
                 unexplained: bool, variation: Optional[dict] = None) -> str:
    lines = [rnd_explanation(next(c for c in r.confirmations if c.effect_id == r.accepted), r, floor)
             for r in rounds if r.accepted]
    if not named:
        lines.append(f"no missing effect found: no catalogue effect improved the held-out error "
                     f"({before:.2f} deg, noise floor {floor:.2f} deg) enough to pass")
    if unexplained:
        lines.append(f"unexplained: the held-out error ({after:.2f} deg) stays {after - floor:.2f} deg above the "
                     f"noise floor; no catalogue effect accounts for it")
        if variation is not None and variation["share_of_gap"] >= 0.5:
            lines.append(f"most of that remainder is log-to-log variation of the constants, not a missing effect: "
                         f"refitting the model's constants on each held-out log alone brings it to "
                         f"{variation['per_log_refit_rmse_deg']:.2f} deg ({variation['share_of_gap']:.0%} of the gap; "
                         f"an in-sample check, so it bounds what specimen or replicate variation can explain)")
    else:
        lines.append(f"the held-out error ({after:.2f} deg) is within the noise floor ({floor:.2f} deg) give or take "
                     f"the reporting margin: nothing left to explain")
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
            raise InputError(f"cannot judge: the log has {lg.n} samples, fewer than {cfg.min_log_samples}",
                             path=lg.path or lg.name)
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
        how = f"fixed split: every {k}-th log from the last is held out"
    n_fit = sum(lg.n for lg in fit)
    if n_fit < cfg.min_fit_samples:
        raise InputError(f"cannot judge: the fitting logs hold {n_fit} samples, fewer than {cfg.min_fit_samples}; "
                         "record longer or more logs")
    return fit, ho, how


@one_blas_thread  # a sequence of small solves: one BLAS thread (bpmid.relax._blas is the one place that sets it)
def discover(logs: Sequence[MotionLog], base: VBMM, *, holdout: Sequence[MotionLog] | None = None,
             cfg: DiscoverConfig | None = None, effects: Sequence[Effect] | None = None) -> DiscoveryResult:
    """Run the discovery loop (see module docstring).

    Parameters
    ----------
    logs : motion logs with measured angles
    base : the starting VBMM (its material is refitted: K_inf, K_j, tau_j)
    holdout : held-out logs; None = a fixed split of ``logs``
    cfg : settings and threshold overrides
    effects : candidate effects (default: the catalogue, or ``cfg.candidates``)

    Raises
    ------
    InputError : inputs the workflow cannot judge (too short, nothing to hold out, base fit not converged)
    """
    t0 = time.perf_counter()
    cfg = cfg or DiscoverConfig()
    thr = cfg.thresholds()
    if effects is None:
        effects = [get_effect(i) for i in (cfg.candidates or tuple(CATALOGUE))]
    fit_logs, ho_logs, how = split_logs(logs, holdout, cfg)
    if holdout is not None:  # a held-out score on a fitting log tests nothing: the verdict would rest on it
        from bpmid.compare import overlap_warnings

        same = overlap_warnings(fit_logs, ho_logs)
        if same:
            bad = next((lg for lg in ho_logs if lg.path is not None and str(lg.path) in same[0]), None)
            raise InputError(same[0].replace("test log", "held-out log").replace("training log", "fitting log")
                             .replace("its score is not a test of prediction",
                                      "the held-out check would score the fit on its own data")
                             + "; give it either as a LOG or after --holdout, not both",
                             path=None if bad is None else bad.path)
    noise = noise_floor(list(fit_logs) + list(ho_logs))
    floor = noise["sigma_deg"]
    if not (np.isfinite(floor) and floor > 0):
        quiet = [lg for lg in list(fit_logs) + list(ho_logs) if not noise["per_log"].get(lg.name, 0.0) > 0]
        names = ", ".join(str(lg.path or lg.name) for lg in quiet[:4]) + (", ..." if len(quiet) > 4 else "")
        raise InputError("cannot judge: the measured angle shows no noise at all (noise floor 0"
                         + (f"; logs without noise: {names}" if quiet else "") + "); discovery needs raw "
                         "measurements, not smoothed or simulated noise-free data",
                         path=quiet[0].path if quiet and quiet[0].path is not None else None)

    note(f"discover: fitting the base VBMM on {len(fit_logs)} log(s), {len(ho_logs)} held out")
    state, res = fit_state(ModelState.start(base), fit_logs, max_nfev=cfg.base_max_nfev, check_identifiability=False)
    if not res.success or not np.all(np.abs(res.residual) < 1e2):
        raise ConvergenceError(f"cannot judge: the base VBMM fit did not converge ({res.message}; "
                               f"{res.nfev} evaluations, RMSE {res.rmse:.3g} deg). A verdict on missing effects needs a "
                               "converged base model: check the logs' pressure reference and units, or start it with --init")
    base_state = state
    before = rmse_deg(residuals(state, ho_logs))
    rounds: list[Round] = []
    named: list[str] = []
    for k in range(cfg.max_effects):
        remaining = [e for e in effects if e.id not in named]
        if not remaining:
            break
        sim = simulate(state, fit_logs)
        parts = [s - lg.angle_deg for s, lg in zip(sim, fit_logs)]
        diag = diagnose(fit_logs, parts)
        note(f"discover: round {k + 1}: screening {len(remaining)} effect(s)")
        ranking = screen(state, remaining, fit_logs, base_sim=sim)
        lead = [s.effect_id for s in ranking[:cfg.n_confirm]]
        ho_now = rmse_deg(residuals(state, ho_logs))
        confs = []
        with Progress(len(lead), f"round {k + 1}: confirming") as pr:
            for eid in lead:
                e = next(x for x in remaining if x.id == eid)
                c = confirm(state, e, fit_logs, ho_logs, noise_floor_deg=floor, base_fit_residual=stacked(parts),
                            heldout_before=ho_now, max_nfev=cfg.confirm_max_nfev)
                c.reasons = judge(c, thr)
                c.accepted = not c.reasons
                confs.append(c)
                pr.advance(detail=eid)
        passing = [c for c in confs if c.accepted]
        best = min(passing, key=lambda c: c.heldout_rmse_after) if passing else None
        for c in passing:
            if c is not best:
                c.accepted = False
                c.reasons = [f"passed, but {best.effect_id} explains the held-out logs better"]
        rounds.append(Round(diag, ranking, confs, best.effect_id if best else None))
        if best is None:
            break
        named.append(best.effect_id)
        state = best.state
        note(f"discover: added {best.effect_id} (held-out {best.heldout_rmse_before:.3f} -> "
             f"{best.heldout_rmse_after:.3f} deg)")
    after = rmse_deg(residuals(state, ho_logs))
    unexplained = bool(after - floor > cfg.unexplained_gap_sigma * floor)
    variation = log_to_log_variation(state, ho_logs, after, floor, cfg) if unexplained else None
    verdict = make_verdict(named, rounds, before, after, floor, unexplained, variation)
    return DiscoveryResult(named, rounds, noise, base_state, state, list(fit_logs), list(ho_logs), before, after,
                           thr, unexplained, verdict, how, time.perf_counter() - t0, variation)


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


def judge(c: Confirmation, thr: dict) -> list[str]:
    """Reasons to reject a confirmed candidate (empty: it passes)."""
    why = []
    if not c.identifiable:
        why.append("none of its parameters is identifiable: " + "; ".join(f"{k}: {v}" for k, v in c.not_identifiable.items()))
    if not math.isfinite(c.heldout_gain_sigma) or c.heldout_gain_sigma < thr["heldout_gain_min_sigma"]:
        why.append(f"held-out error drop {c.heldout_gain_sigma:.2f} noise floors < {thr['heldout_gain_min_sigma']:.2f}")
    if not c.delta_bic <= thr["delta_bic_max"]:
        why.append(f"delta BIC {c.delta_bic:.1f} > {thr['delta_bic_max']:.1f}")
    if not c.lr_p < thr["lr_p_max"]:
        why.append(f"likelihood-ratio p = {c.lr_p:.2g} >= {thr['lr_p_max']:.2g}")
    return why
