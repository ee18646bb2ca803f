"""Thresholds of the discovery loop's gate, calibrated on simulated data (never tuned by hand to one case).

The gate (:func:`bpmid.discover.workflow.judge`) has numbers whose meaning does not depend on any generator:
``heldout_gain_min_sigma`` (the drop of the held-out error above the noise, ``sqrt(RMSE^2 - floor^2)``, in noise
floors), ``gap_share_min`` (the share of that gap the effect must remove), ``family_alpha`` (the family-wise level
of the Holm-corrected likelihood-ratio tests of a round) and the fitting-share condition; and, for a round where
no candidate passes those, the path down to the noise floor: ``to_floor_drop_min_sigma`` (the held-out error the
effect removes, ``sqrt(before^2 - after^2)``, in noise floors) with the held-out RMSE left at most
``to_floor_ratio_max`` (1: not above the floor), with each effect's own drop where it scores better
(``to_floor_drop_by_effect``); and the two paths for two effects at once (``pair_share_min`` /
``pair_gain_min_sigma`` when nothing passes alone, ``pair_over_single_min_sigma`` / ``pair_over_gain_min_sigma``
over the single effect a first round would name).
:func:`thresholds_from_records` chooses them from the candidates recorded on a CALIBRATION set run with permissive
thresholds (:data:`PERMISSIVE`), pairs included: among the gates that name nothing on a null case and something on
so few out-of-catalogue cases that the naming rate stays under 20 % with 90 % confidence
(:func:`ooc_names_allowed`), the values that reproduce the most right decisions case by case, wrong names counting
double against, ties broken towards the stricter gate. The committed ``thresholds.yaml`` is written by
``python benchmarks/recalibrate.py`` from the calibration halves of out-of-family sweeps (``bpmid calibrate``), or by
``python benchmarks/bench_discover.py --calibrate``.
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import yaml

from bpmid.discover.rivals import held_against, own_shape, takes_the_round
from bpmid.effects.base import AugmentedVBMM, Effect
from bpmid.io.motion_logs import ATMOSPHERE_PA, MotionLog, from_arrays
from bpmid.models.vbmm import VBMM, Material
from bpmid.params import ParamSet

THRESHOLDS_PATH = Path(__file__).with_name("thresholds.yaml")
THRESHOLD_KEYS = ("heldout_gain_min_sigma", "gap_share_min", "family_alpha", "fit_share_min",
                  "fit_share_waived_above_sigma", "heldout_gain_min_sigma_later", "to_floor_drop_min_sigma",
                  "to_floor_ratio_max", "pair_share_min", "pair_gain_min_sigma", "identifiable_waived_above_sigma",
                  "pair_over_single_min_sigma", "pair_over_gain_min_sigma")
#: thresholds a file written before they existed may lack, with the value that leaves the gate as it was (None:
#: the held-out gain asked of a further effect is the one asked of the first)
OPTIONAL_THRESHOLDS = {"fit_share_min": 0.0, "fit_share_waived_above_sigma": math.inf,
                       "heldout_gain_min_sigma_later": None, "to_floor_drop_min_sigma": math.inf,
                       "to_floor_ratio_max": 1.0, "pair_share_min": math.inf, "pair_gain_min_sigma": math.inf,
                       "identifiable_waived_above_sigma": math.inf, "pair_over_single_min_sigma": math.inf,
                       "pair_over_gain_min_sigma": math.inf}
#: the drop asked on the path to the noise floor of the effects that have their own (catalogue id -> noise floors):
#: an effect whose signature is confined to short stretches of a log (a lag shows only while the pressure moves)
#: removes less of a whole log's error than one seen everywhere; those not listed are asked
#: ``to_floor_drop_min_sigma``
BY_EFFECT_KEY = "to_floor_drop_by_effect"


class Drops(float):
    """The drop asked on the path to the noise floor: the common value (the float itself) and the effects with
    their own (``by_effect``). Everywhere a single drop is used, it reads as the common value."""

    def __new__(cls, common: float, by_effect: Mapping[str, float] | None = None):
        obj = super().__new__(cls, common)
        obj.by_effect = {str(k): float(v) for k, v in (by_effect or {}).items()}
        return obj

    def of(self, effect_id: str) -> float:
        return self.by_effect.get(effect_id, float(self))


def drop_for(drop: float, effect_id: str) -> float:
    """The drop asked of ``effect_id`` on the path to the floor (``drop``: a number, or :class:`Drops`)."""
    return drop.of(effect_id) if isinstance(drop, Drops) else float(drop)


def floor_drops(thr: Mapping) -> Drops:
    """The drops asked on the path to the noise floor by a gate's thresholds (common and each effect's own)."""
    return Drops(float(thr["to_floor_drop_min_sigma"]), thr.get(BY_EFFECT_KEY))


def check_drops_by_effect(by, path, key: str) -> None:
    """Refuse (:class:`~bpmid.errors.InputError` naming ``path`` and the key) a mapping of effects' own drops that
    is not catalogue id -> 0 or more noise floors: in a thresholds file and in a discover config alike."""
    from bpmid.effects import CATALOGUE
    from bpmid.errors import InputError

    if not isinstance(by, Mapping):
        raise InputError(f"must be a mapping of effect id to a drop in noise floors, found {by!r}", path=path, key=key)
    for k, v in by.items():
        if k not in CATALOGUE:
            raise InputError(f"unknown effect id {k!r} (known: {', '.join(CATALOGUE)})", path=path, key=f"{key}.{k}")
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not v >= 0:
            raise InputError(f"must be 0 or more noise floors, found {v!r}", path=path, key=f"{key}.{k}")


def gate_values(values: Mapping) -> dict:
    """The gate's thresholds out of a calibration's values or a thresholds file: the numbers of
    :data:`THRESHOLD_KEYS` as floats, and the effects with their own drop on the path to the floor."""
    out = {k: float(values[k]) for k in THRESHOLD_KEYS}
    out[BY_EFFECT_KEY] = {str(k): float(v) for k, v in (values.get(BY_EFFECT_KEY) or {}).items()}
    return out


#: the held-out RMSE an effect named on the path to the floor may leave, in noise floors: at the floor, by the
#: path's meaning (the effect explains what the base model left); not calibrated
TO_FLOOR_RATIO = 1.0
#: discover-config overrides for a calibration run: every candidate's statistics are recorded, the best by
#: held-out gain is added each round (so later rounds are recorded too). The path to the floor asks every effect
#: the same drop of 0: no effect's own drop from the shipped thresholds may stop a permissive run short of its
#: second round
PERMISSIVE = {"heldout_gain_min_sigma": -1e9, "gap_share_min": 0.0, "family_alpha": 0.999999, "fit_share_min": 0.0,
              "fit_share_waived_above_sigma": 0.0, "heldout_gain_min_sigma_later": -1e9,
              "to_floor_drop_min_sigma": 0.0, "to_floor_ratio_max": 1e9, "max_effects": 2, "record_pair_trials": True,
              "identifiable_waived_above_sigma": math.inf, "withhold_for_rivals": False,
              "pair_over_single_min_sigma": math.inf, BY_EFFECT_KEY: {}}
SCHEMA = "bpmid.discover-thresholds/1"


def load_thresholds(path: str | Path | None = None) -> dict:
    """The calibrated thresholds (:data:`THRESHOLD_KEYS`)."""
    return read_thresholds(path)[0]


def thresholds_calibration(path: str | Path) -> dict:
    """What a thresholds file says of the calibration that made it (its checked ``calibration`` block: the sweep's
    ``generator`` and the ``warnings`` calibrate gave; empty when it has none)."""
    return read_thresholds(path)[1]


def read_thresholds(path: str | Path | None = None) -> tuple[dict, dict]:
    """(the gate's values, the ``calibration`` block) of a thresholds file, every key checked."""
    path = Path(path) if path else THRESHOLDS_PATH
    from bpmid.io.yamlsafe import load_file

    data, _raw = load_file(path, "thresholds file")   # not found, not UTF-8, bad YAML: exit 2 naming the file
    from bpmid.errors import InputError
    if not isinstance(data, dict) or data.get("schema") != SCHEMA:
        raise InputError(f"not a {SCHEMA} file (a thresholds file written by bpmid calibrate or "
                         "benchmarks/recalibrate.py)", path=path, key="schema")
    known = {"schema", "calibration", BY_EFFECT_KEY, *THRESHOLD_KEYS}
    for k in data:
        if k not in known:   # a typo (gap_share_minn) was read as the key missing, and an extra key ignored
            import difflib
            near = difflib.get_close_matches(str(k), sorted(known), n=1)
            raise InputError("unknown key" + (f" (did you mean {near[0]}?)" if near else
                                              f" (known: {', '.join(sorted(known))})"), path=path, key=str(k))
    check_calibration_block(data.get("calibration"), path)
    data = {**OPTIONAL_THRESHOLDS, **data}
    missing = [k for k in THRESHOLD_KEYS if k not in data]
    if missing:
        raise InputError(f"missing {', '.join(missing)} (an old thresholds file? recalibrate)", path=path,
                         key=missing[0])
    data = later_gain_follows(data)
    check_drops_by_effect(data.get(BY_EFFECT_KEY) or {}, path, BY_EFFECT_KEY)
    check_threshold_values(data, path)
    return gate_values(data), dict(data.get("calibration") or {})


def check_calibration_block(cal, path) -> None:
    """Refuse, naming the key, a thresholds file's ``calibration`` block that discover could not read where it says
    the gate's conditions and warnings (:func:`bpmid.discover.cautions.gate_cautions`): it was read only after the
    whole fit, and a hand-edited ``warnings: 5`` crashed there."""
    from bpmid.errors import InputError

    if cal is None:
        return
    if not isinstance(cal, Mapping):
        raise InputError(f"must be a mapping (what the calibration was), found {cal!r}", path=path, key="calibration")
    w = cal.get("warnings")
    if w is not None and not (isinstance(w, list) and all(isinstance(x, str) for x in w)):
        raise InputError(f"must be a list of sentences, found {w!r}", path=path, key="calibration.warnings")
    gen = cal.get("generator")
    if gen is None:
        return
    if not isinstance(gen, Mapping):
        raise InputError(f"must be a mapping (the sweep's generator), found {gen!r}", path=path,
                         key="calibration.generator")
    for k in ("noise_deg", "noise_rho", "sampling_hz"):
        v = gen.get(k)
        vals = v if isinstance(v, list) else [v]
        if v is not None and not (vals and all(not isinstance(x, bool) and isinstance(x, (int, float))
                                               and math.isfinite(x) for x in vals)):
            raise InputError(f"must be a number or a list of numbers, found {v!r}", path=path,
                             key=f"calibration.generator.{k}")


#: the thresholds that are shares of a gap (0 to 1; ``pair_share_min`` may be .inf: the path closed)
_SHARE_KEYS = ("gap_share_min", "fit_share_min", "pair_share_min")


def check_threshold_values(data: Mapping, path) -> None:
    """Refuse (naming the file and key) a thresholds file's value a calibration never writes: not a number, a
    family-wise level outside (0, 1), a share outside [0, 1], a negative number of noise floors (a hand-edited file
    would otherwise change the gate in silence)."""
    from bpmid.errors import InputError

    for k in THRESHOLD_KEYS:
        v = data[k]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or math.isnan(v):
            raise InputError(f"must be a number, found {v!r}", path=path, key=k)
        if k == "family_alpha":
            ok, want = 0 < v < 1, "a family-wise level between 0 and 1"
        elif k == "to_floor_ratio_max":
            ok, want = v > 0, "above 0 noise floors"
        elif k in _SHARE_KEYS:
            ok, want = 0 <= v <= 1 or (k == "pair_share_min" and v == math.inf), (
                "a share from 0 to 1" + (" (or .inf: the path closed)" if k == "pair_share_min" else ""))
        else:
            ok, want = v >= 0, "0 or more noise floors (.inf: never)"
        if not ok:
            raise InputError(f"must be {want}, found {v!r}; bpmid calibrate never writes this (a hand-edited file?): "
                             f"recalibrate, or restore the value it wrote", path=path, key=k)


def later_gain_follows(thr: Mapping, given: Mapping | None = None) -> dict:
    """``thr`` where the gain asked of a further effect follows the first round's when it is not set, or when
    ``given`` (the overrides just applied) set the first round's gain without it."""
    out, given = dict(thr), given or {}
    if out.get("heldout_gain_min_sigma_later") is None or (
            given.get("heldout_gain_min_sigma") is not None and given.get("heldout_gain_min_sigma_later") is None):
        out["heldout_gain_min_sigma_later"] = out["heldout_gain_min_sigma"]
    return out


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
                    noise_rho: float = 0.0, truth: VBMM | None = None, protocols: dict | None = None,
                    pressure_noise_pa: float = 0.0) -> tuple[list[MotionLog], list[MotionLog]]:
    """Fitting logs and held-out logs simulated with ``effect`` hidden (None: no effect).

    Noise: AR(1) Gaussian with standard deviation ``noise_deg`` and lag-1 correlation ``noise_rho``, seeded;
    ``pressure_noise_pa``: white Gaussian noise of that standard deviation on the logged pressure (a transducer's:
    the muscle saw the pressure without it).
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
        logged = pg + rng.normal(0.0, pressure_noise_pa, t.size) if pressure_noise_pa > 0 else pg
        lg = from_arrays(name, t, logged, beta + e)
        (ho if name in HELDOUT else fit).append(lg)
    return fit, ho


# ---------------------------------------------------------------------------------------------
# calibration
# ---------------------------------------------------------------------------------------------
@dataclasses.dataclass
class Record:
    """One confirmed candidate in a calibration run."""

    truth: str            # injected effect id, or "none" (null or out-of-catalogue: nothing in the catalogue is true)
    round: int            # 1-based
    candidate: str
    gain_sigma: float     # drop of the held-out error above the noise (in quadrature), in noise floors
    delta_bic: float      # reported only
    truth_in_model: bool  # the injected effect was already added before this round
    gap_share: float = float("nan")
    lr_p: float = 1.0
    lr_p_holm: float = 1.0
    tested: bool = True
    identifiable: bool = True
    case: str = ""        # which data set (records of one case are judged together)
    fit_share: float = float("nan")   # share of the fitting logs' gap above the floor the refit removed
    kind: str = ""        # single, null, out_of_catalogue or pair ("" in records written before it existed)
    named_before: str = ""  # the effects added before this round, joined by "+" (the permissive run's path)
    drop_sigma: float = float("nan")        # held-out error removed, sqrt(before^2 - after^2), in noise floors
    after_over_floor: float = float("nan")  # held-out RMSE with the candidate, in noise floors
    rival: bool = False   # the round's rival outside the catalogue (bpmid.discover.rivals), never a candidate
    own_shape: bool = False  # a rival's fit needed what only it has (rivals.own_shape)
    #: held-out error removed where the candidate acts (confirm.drop_where_it_acts), in noise floors; NaN in
    #: records written before it existed
    local_drop_sigma: float = float("nan")

    def __post_init__(self):
        _floats(self, ("gain_sigma", "delta_bic", "gap_share", "lr_p", "lr_p_holm", "fit_share", "drop_sigma",
                       "after_over_floor", "local_drop_sigma"))


def _floats(rec, names: Sequence[str]) -> None:
    """Records read back from JSON carry None where a value was not a number: NaN again."""
    for f in names:
        v = getattr(rec, f)
        setattr(rec, f, float("nan") if v is None else float(v))


@dataclasses.dataclass
class PairRecord:
    """Two first-round candidates refitted together in a calibration run (:class:`bpmid.discover.confirm.PairTrial`)."""

    case: str
    truth: str
    kind: str
    first: str
    second: str
    gain_sigma: float           # the pair's held-out gain above the noise, in noise floors
    gap_share: float            # share of the held-out gap the pair removes
    min_gain_given_other: float  # the weaker one's held-out gain beside the other, in noise floors
    p_corrected: float          # the larger conditional likelihood-ratio p, Bonferroni over the pairs tried
    tested: bool = True
    identifiable: bool = True

    def __post_init__(self):
        _floats(self, ("gain_sigma", "gap_share", "min_gain_given_other", "p_corrected"))


def _case_key(truth: str, result) -> str:
    """Which data set records belong to (a resumed sweep must reproduce it): the data set's own numbers, never a
    time."""
    return f"{truth}|{result.heldout_raw_before:.12g}|{result.noise_floor_deg:.12g}"


def pair_records_from_result(truth: str, result, case: str | None = None, kind: str = "") -> list[PairRecord]:
    """The first round's pair trials of a discovery result (recorded when ``record_pair_trials`` is set)."""
    case = case or _case_key(truth, result)
    if not result.rounds:
        return []
    return [PairRecord(case, truth, kind, pt.first.effect_id, pt.second.effect_id, float(pt.gain_sigma),
                       float(pt.gap_share), float(pt.min_gain_given_other), float(pt.p_corrected), bool(pt.tested),
                       bool(pt.identifiable)) for pt in result.rounds[0].pair_trials]


def records_from_result(truth: str, result, case: str | None = None, kind: str = "") -> list[Record]:
    """The confirmed candidates of a discovery result, labelled with the injected ``truth`` (a catalogue id,
    ``none``, or two ids joined by ``+`` for a pair) and the case's ``kind``."""
    case = case or _case_key(truth, result)
    truths = set(truth.split("+"))
    out = []
    named_before: list[str] = []
    for k, rnd in enumerate(result.rounds, start=1):
        if rnd.joint_with:   # the second of two named together: not a round of its own
            named_before.append(rnd.accepted)
            continue
        def record(c, rival=False):
            # a rival's p is its own, uncorrected (it is no candidate of the round's Holm family)
            p_holm = c.lr_p_holm if math.isfinite(c.lr_p_holm) and not rival else c.lr_p
            return Record(truth, k, c.effect_id, float(c.heldout_gain_sigma), float(c.delta_bic),
                          bool(truths & set(named_before)), float(c.gap_share), float(c.lr_p), float(p_holm),
                          bool(c.tested), bool(c.identifiable), case, float(c.fit_share), kind,
                          "+".join(named_before), float(c.drop_sigma),
                          float(c.heldout_rmse_after) / result.noise_floor_deg, rival=rival,
                          own_shape=bool(rival and own_shape(c)), local_drop_sigma=float(c.local_drop_sigma))
        out += [record(c) for c in rnd.confirmations]
        out += [record(c, rival=True) for c in (rnd.rivals or ([rnd.rival] if rnd.rival is not None else []))]
        if rnd.accepted:
            named_before.append(rnd.accepted)
    return out


def case_records(rec: Mapping) -> list[Record]:
    """The calibration records of one sweep record (a line of ``records.jsonl``). Records written before the path
    to the noise floor existed lack its two numbers; they are taken from the same case's confirmed candidates
    (``candidates``: one per round and effect, with the held-out RMSE before and after and the case's floor)."""
    out = [Record(**x) for x in (rec.get("calibration_records") or [])]
    floor = rec.get("noise_floor_deg")
    if not floor or not all(math.isnan(r.drop_sigma) for r in out):
        return out
    from bpmid.discover.confirm import heldout_drop_sigma

    seen = {}
    for c in rec.get("candidates") or []:
        b, a = c.get("heldout_rmse_before_deg"), c.get("heldout_rmse_after_deg")
        if b is not None and a is not None:
            seen[(int(c["round"]), c["effect"])] = (heldout_drop_sigma(float(b), float(a), float(floor)),
                                                    float(a) / float(floor))
    for r in out:
        r.drop_sigma, r.after_over_floor = seen.get((r.round, r.candidate), (float("nan"), float("nan")))
    return out


def pair_records(rec: Mapping) -> list[PairRecord]:
    """The pair trials of one sweep record (``calibration_pairs``; none in records written before they existed)."""
    return [PairRecord(**x) for x in (rec.get("calibration_pairs") or [])]


def _passes(r: Record, g: float, share: float, alpha: float, fit_share: float = 0.0,
            waive: float = math.inf) -> bool:
    return (r.tested and (r.identifiable or r.gain_sigma > waive) and math.isfinite(r.gain_sigma)
            and r.gain_sigma >= g
            and math.isfinite(r.gap_share) and r.gap_share >= share and r.lr_p_holm < alpha
            and (fit_share <= 0 or r.gain_sigma > waive
                 or (math.isfinite(r.fit_share) and r.fit_share >= fit_share)))


def fit_share_waiver(records: Sequence[Record]) -> float:
    """Held-out gain (noise floors) above which (strictly) the fitting-gap share is not asked: any candidate
    reached in round 1 on a calibration case with nothing in the catalogue to find (nulls, effects outside the
    catalogue), rounded up to 0.01. A candidate that strong is no imitation of an absent effect, and asking it to
    explain most of the fitting gap alone would refuse the first of two effects present at once. Above the same gain
    an identifiable parameter is not asked either (``identifiable_waived_above_sigma``): two parameters that trade
    off (a softening linear in time: only the amount over the time constant is determined) leave none identifiable
    alone, although the effect is plainly needed; its constants are then reported as not determined separately."""
    neg = [r.gain_sigma for r in records if r.truth == "none" and r.round == 1 and not r.rival
           and math.isfinite(r.gain_sigma)]
    return math.ceil(max(neg) * 100.0 - 1e-9) / 100.0 if neg else math.inf


def _passes_to_floor(r: Record, drop: float, alpha: float, ratio: float = TO_FLOOR_RATIO) -> bool:
    """The path down to the noise floor (:func:`bpmid.discover.workflow.judge_to_floor`)."""
    return (r.tested and r.identifiable and r.lr_p_holm < alpha and math.isfinite(r.drop_sigma)
            and r.drop_sigma >= drop_for(drop, r.candidate) and math.isfinite(r.after_over_floor)
            and r.after_over_floor <= ratio)


def winner_rank(score: float, drop: float = math.nan) -> tuple[float, float]:
    """How a round ranks the candidates that pass: by ``score`` (the held-out gain above the noise, or the drop on
    the path to the floor), then by the held-out ``drop`` (sqrt(before^2 - after^2), noise floors). The gain is
    the gap above the floor removed, so every candidate that takes the held-out error down to the floor has the
    same gain, the whole gap; the drop still tells which removed more error. Scores are compared at 1e-9 noise
    floors (equal gains are equal up to rounding); a missing number ranks last."""
    def low(x: float) -> float:
        return float(x) if math.isfinite(float(x)) else -math.inf
    return (round(low(score), 9), low(drop))


def gain_winner(items: Sequence, gain, drop, fit_share, tie: float):
    """The candidate a round names among ``items`` passing the gate on the held-out gap: the largest held-out gain
    (equal gains by the held-out drop, :func:`winner_rank`), unless the held-out logs do not tell it from another:
    a candidate whose gain is within ``tie`` noise floors of the largest (the gain the gate asks of an effect at
    all: less than that is no evidence for naming one, so none for preferring one either) and whose refit removed
    a larger share of the fitting logs' gap above the noise is named instead: the fitting logs, a second and
    larger data set, decide between candidates the held-out logs leave level. ``gain``, ``drop``, ``fit_share``:
    accessors of a candidate (noise floors, noise floors, share; a share that is not a number, when the fitting
    logs leave no gap above the noise, decides nothing)."""
    best = max(items, key=lambda c: winner_rank(gain(c), drop(c)))
    if not math.isfinite(float(fit_share(best))):
        return best
    tie = max(float(tie), 0.0)   # a permissive gate's negative gain: only equal gains are level
    close = [c for c in items if gain(c) >= gain(best) - tie - 1e-12 and math.isfinite(float(fit_share(c)))]
    return max(close, key=lambda c: (round(float(fit_share(c)), 9),) + winner_rank(gain(c), drop(c)))


def _record_winner(passing: Sequence[Record], tie: float) -> Record:
    return gain_winner(passing, lambda r: r.gain_sigma, lambda r: r.drop_sigma, lambda r: r.fit_share, tie)


def _first_passing(recs: Sequence[Record], g, share, alpha, fit_share, waive,
                   to_floor: float = math.inf, to_floor_ratio: float = TO_FLOOR_RATIO,
                   withhold: bool = True) -> str | None:
    """The candidate a round names: the largest held-out gain among those passing the gate, the fitting logs
    deciding between gains within ``g`` of each other (:func:`gain_winner`); when none passes, the largest held-out
    drop among those leaving the held-out error at most ``to_floor_ratio`` floors with a drop of ``to_floor``; None
    also when the round's rival outside the catalogue withholds that candidate (:func:`rival_withholds`;
    ``withhold=False``: the candidate before that check)."""
    cands = [r for r in recs if not r.rival]
    passing = [r for r in cands if _passes(r, g, share, alpha, fit_share, waive)]
    if passing:
        best = _record_winner(passing, g)
        return (None if withhold and rival_withholds(recs, best.after_over_floor, alpha, (best.candidate,))
                    else best.candidate)
    if math.isfinite(to_floor):
        passing = [r for r in cands if _passes_to_floor(r, to_floor, alpha, to_floor_ratio)]
        if passing:
            best = max(passing, key=lambda r: r.drop_sigma)
            return (None if withhold and rival_withholds(recs, best.after_over_floor, alpha, (best.candidate,))
                    else best.candidate)
    return None


def rival_withholds(recs: Sequence[Record], named_after_over_floor: float, alpha: float,
                    named: Sequence[str]) -> bool:
    """Whether a rival outside the catalogue among one round's records takes the round from ``named`` (effect ids),
    which leaves ``named_after_over_floor`` (:func:`bpmid.discover.rivals.beats`, asked as
    :func:`bpmid.discover.rivals.held_against` says; records without a rival: never)."""
    return any(r.rival and held_against(r.candidate, named)
               and takes_the_round(r.tested, r.own_shape, r.lr_p, r.after_over_floor, named_after_over_floor, alpha)
               for r in recs)


def pair_leader_records(r1: Sequence[Record]) -> list[Record]:
    """The first-round records whose candidates discovery's paths for two effects at once pair up: its own
    :func:`bpmid.discover.workflow.pair_leaders` read from the recorded numbers (rivals are never candidates)."""
    from types import SimpleNamespace

    from bpmid.discover.workflow import pair_leaders

    seen = [SimpleNamespace(effect_id=r.candidate, tested=r.tested, identifiable=r.identifiable,
                            heldout_gain_sigma=r.gain_sigma, record=r,
                            family_p=r.lr_p_holm if math.isfinite(r.lr_p_holm) else r.lr_p)   # as Confirmation's
            for r in r1 if not r.rival]
    return [c.record for c in pair_leaders(seen)]


def _pair_eligible(recs: Sequence[Record], pairs: Sequence[PairRecord], g: float, alpha: float) -> list[PairRecord]:
    """The pair trials that meet the conditions of the paths for two effects at once that no calibrated share or
    gain sets: tested, identifiable, both members significant alone (Holm) and beside the other (Bonferroni), a
    joint held-out gain of at least ``g``, and numbers to judge."""
    p1 = {r.candidate: r.lr_p_holm for r in recs if r.round == 1 and not r.rival}
    return [q for q in pairs if q.tested and q.identifiable and p1.get(q.first, 1.0) < alpha
            and p1.get(q.second, 1.0) < alpha and q.p_corrected < alpha
            and math.isfinite(q.gain_sigma) and q.gain_sigma >= g and math.isfinite(q.gap_share)
            and math.isfinite(q.min_gain_given_other)]


def _pair_best(recs: Sequence[Record], pairs: Sequence[PairRecord], g: float, alpha: float, pair_share: float,
               pair_gain: float, above: float = -math.inf) -> PairRecord | None:
    """The pair trial the path for two effects at once would take (the largest joint held-out gain among those
    meeting its conditions, and above ``above``), before the rival's check; None when none does."""
    if not pairs or not math.isfinite(pair_share):
        return None
    ok = [q for q in _pair_eligible(recs, pairs, g, alpha) if q.gain_sigma >= above and q.gap_share >= pair_share
          and q.min_gain_given_other >= pair_gain]
    return max(ok, key=lambda q: q.gain_sigma) if ok else None


def _pair_withheld(recs: Sequence[Record], q: PairRecord, alpha: float) -> bool:
    """Whether the round's rival outside the catalogue withholds the pair ``q`` (judged against the better of its
    two members alone, as in discovery)."""
    r1 = [r for r in recs if r.round == 1]
    alone = [r.after_over_floor for r in r1 if not r.rival and r.candidate in (q.first, q.second)]
    return bool(alone) and rival_withholds(r1, min(alone), alpha, (q.first, q.second))


def _pair_named(recs: Sequence[Record], pairs: Sequence[PairRecord], g: float, alpha: float, pair_share: float,
                pair_gain: float) -> tuple[str, str] | None:
    """The two effects the path for two at once names in a first round where nothing passes alone
    (:func:`bpmid.discover.workflow.judge_pair`), or None."""
    q = _pair_best(recs, pairs, g, alpha, pair_share, pair_gain)
    if q is None or _pair_withheld(recs, q, alpha):
        return None
    return q.first, q.second


def _gain_of(r1: Sequence[Record], candidate: str) -> float:
    """The held-out gain of the candidate a first round would name (a pair over it must beat it by the margin)."""
    return max(r.gain_sigma for r in r1 if r.candidate == candidate and not r.rival)


def _pair_path_outcome(truth: str, named: tuple[str, str]) -> tuple[int, int]:
    """(right, wrong names) of two effects named together: a pair case is right when they are its two; a single
    case when the first is its effect (the second is a wrong name either way); a case with nothing in the
    catalogue counts one false positive."""
    if truth == "none":
        return 0, 1
    if "+" in truth:
        return (1, 0) if set(named) == set(truth.split("+")) else (0, 1)
    return int(named[0] == truth), 1


def _pair_outcome(recs: Sequence[Record], g: float, share: float, alpha: float,
                  fit_share: float = 0.0, waive: float = math.inf, g_later: float | None = None,
                  share_later: float | None = None, to_floor: float = math.inf) -> tuple[int, int]:
    """(both named, wrong names) the gate makes on a two-effect case: round 1 must name one of the two, the round
    after it (recorded when the permissive run took the same first effect) the other one, judged with the held-out
    gain ``g_later`` and share ``share_later`` (None: ``g``, ``share``). When the gate's first choice is not the one
    the recorded run continued from, the second round is unknown: not counted as right."""
    g2 = g if g_later is None else g_later
    sh2 = share if share_later is None else share_later
    truths = set(recs[0].truth.split("+"))
    first = _first_passing([r for r in recs if r.round == 1], g, share, alpha, fit_share, waive, to_floor)
    if first is None:
        return 0, 0
    if first not in truths:
        return 0, 1
    later = [r for r in recs if r.round == 2 and r.named_before == first]
    second = _first_passing(later, g2, sh2, alpha, fit_share, waive, to_floor) if later else None
    if second is None:
        return 0, 0
    return (1, 0) if second in truths - {first} else (0, 1)


def _case_outcome(recs: Sequence[Record], g: float, share: float, alpha: float,
                  fit_share: float = 0.0, waive: float = math.inf, g_later: float | None = None,
                  share_later: float | None = None, to_floor: float = math.inf,
                  pairs: Sequence[PairRecord] = (), pair_share: float = math.inf,
                  pair_gain: float = math.inf, pair_over: float = math.inf,
                  pair_over_gain: float = math.inf) -> tuple[int, int]:
    """(right decisions, false positives) the gate (g, share, alpha) makes on one case's records: round 1 must
    name the truth (nothing, on a case with no catalogue truth); the round after the truth was added must name
    nothing (judged with the held-out gain ``g_later`` and share ``share_later``, None: ``g``, ``share``); on a
    pair, both effects must be named (:func:`_pair_outcome`). ``to_floor``: the drop asked on the path to the noise
    floor (inf: no such path). ``pairs``, ``pair_share``, ``pair_gain``: the path for two effects at once, asked
    when round 1 names nothing (:func:`_pair_named`; inf: no such path). ``pair_over``, ``pair_over_gain``: two
    effects at once over the one round 1 would name, when their joint held-out gain exceeds its gain by
    ``pair_over`` noise floors and each adds ``pair_over_gain`` beside the other (inf: no such path)."""
    truth = recs[0].truth
    r1 = [r for r in recs if r.round == 1]
    if pairs and (math.isfinite(pair_share) or math.isfinite(pair_over)):
        first = _first_passing(r1, g, share, alpha, fit_share, waive, to_floor, withhold=False)
        q = None
        if first is None:
            q = _pair_best(recs, pairs, g, alpha, pair_share, pair_gain)
        elif math.isfinite(pair_over):
            q = _pair_best(recs, pairs, g, alpha, 0.0, pair_over_gain, above=_gain_of(r1, first) + pair_over)
        if q is not None:
            if not _pair_withheld(recs, q, alpha):
                return _pair_path_outcome(truth, (q.first, q.second))
            if first is not None:   # the round is withheld: nothing named
                return (1, 0) if truth == "none" else (0, 0)
    if "+" in truth:
        return _pair_outcome(recs, g, share, alpha, fit_share, waive, g_later, share_later, to_floor)
    g2 = g if g_later is None else g_later
    sh2 = share if share_later is None else share_later
    first = _first_passing(r1, g, share, alpha, fit_share, waive, to_floor)
    if truth == "none":
        return (1, 0) if first is None else (0, 1)
    right = int(first == truth)
    fp = int(first is not None and first != truth)
    later = [r for r in recs if r.truth_in_model and r.round == 2]
    if right and later and _first_passing(later, g2, sh2, alpha, fit_share, waive, to_floor) is not None:
        fp += 1
    return right, fp


#: shares of the fitting logs' gap (above the noise floor) a named effect's refit must remove, considered by the
#: calibration (0: no such condition)
FIT_SHARES = (0.0, 0.3, 0.5, 0.6, 0.7, 0.8, 0.9)

#: family-wise levels the calibration considers
ALPHAS = (0.05, 0.01, 1e-3, 1e-4, 1e-6, 1e-9)


#: the largest share of out-of-catalogue cases a gate may name something on (issue 12: nothing named on at least
#: 80 %) and the confidence with which the calibration cases must show it (one-sided Clopper-Pearson upper bound)
OOC_NAMED_TARGET = 0.2
OOC_CONFIDENCE = 0.9


def ooc_names_allowed(n_cases: int, target: float = OOC_NAMED_TARGET, confidence: float = OOC_CONFIDENCE) -> int:
    """How many of ``n_cases`` out-of-catalogue calibration cases a gate may name something on: the most whose
    one-sided ``confidence`` upper bound on the naming rate stays within ``target`` (0 when even none does: 21
    cases allow 1, 25 allow 2, 10 allow none). A share seen in sample is not enough: 2 of 21 calibration cases
    named (10 %) came with 7 of 20 (35 %) on a fresh held-out draw."""
    from scipy.special import betaincinv  # the beta quantile, without importing scipy.stats

    k = 0
    while k < n_cases and float(betaincinv(k + 2, n_cases - k - 1, confidence)) <= target:
        k += 1
    return k


def _tally(cases: Sequence[Sequence[Record]], g: float, sh: float, a: float, fs: float, waive: float,
           g_later: float | None = None, to_floor: float = math.inf, pairs: Mapping | None = None,
           pair_share: float = math.inf, pair_gain: float = math.inf, pair_over: float = math.inf,
           pair_over_gain: float = math.inf) -> dict:
    """Outcomes of one gate over the calibration cases: right decisions, wrong names (on cases with a catalogue
    truth), names on nulls, names on out-of-catalogue cases. ``pairs``: case -> its pair trials."""
    t = {"right": 0, "wrong": 0, "null_named": 0, "ooc_named": 0, "ooc": 0}
    pairs = pairs or {}
    for recs in cases:
        _add_outcome(t, recs, *_case_outcome(recs, g, sh, a, fs, waive, g_later, to_floor=to_floor,
                                             pairs=pairs.get(recs[0].case, ()), pair_share=pair_share,
                                             pair_gain=pair_gain, pair_over=pair_over, pair_over_gain=pair_over_gain))
    return t


def _add_outcome(t: dict, recs: Sequence[Record], right: int, named_wrong: int) -> None:
    """Add one case's (right decisions, names counted against) to a :func:`_tally` outcome."""
    t["right"] += right
    if recs[0].truth == "none" and recs[0].kind == "out_of_catalogue":
        t["ooc"] += 1
        t["ooc_named"] += named_wrong
    elif recs[0].truth == "none":
        t["null_named"] += named_wrong
    else:
        t["wrong"] += named_wrong


def _sum_tallies(a: Mapping, b: Mapping) -> dict:
    """Two :func:`_tally` outcomes of disjoint sets of cases, added."""
    return {k: a[k] + b[k] for k in a}


def _tally_gains(cases: Sequence[Sequence[Record]], gains: np.ndarray, sh: float, a: float, fs: float,
                 waive: float) -> dict:
    """:func:`_tally` for every held-out gain threshold in ``gains`` at once (arrays over ``gains``; the same
    outcomes). Given the other conditions, the candidate a round names is the one with the largest gain among those
    meeting them, and it is named exactly when its gain reaches the threshold; so each case needs only those gains."""
    ng = len(gains)
    t = {k: np.zeros(ng, int) for k in ("right", "wrong", "null_named", "ooc_named")}
    t["ooc"] = 0
    neg_inf = -math.inf

    def named(recs) -> list[tuple[Record, np.ndarray]]:
        """(candidate, where it is named) over ``gains``: at threshold g the candidates with a gain of at least g
        pass, and :func:`gain_winner` with the tie g chooses among them; a rival may withhold the one chosen."""
        ok = [r for r in recs if not r.rival and _passes(r, neg_inf, sh, a, fs, waive)]
        if not ok:
            return []
        top = max(ok, key=lambda r: winner_rank(r.gain_sigma, r.drop_sigma))
        # in the order gain_winner prefers them; each is named where it passes, is level with the top (within g)
        # and no candidate before it is
        if math.isfinite(top.fit_share):
            order = sorted((r for r in ok if math.isfinite(r.fit_share) or r is top),
                           key=lambda r: (round(r.fit_share, 9) if math.isfinite(r.fit_share) else neg_inf,)
                           + winner_rank(r.gain_sigma, r.drop_sigma), reverse=True)
        else:
            order = [top]
        taken = np.zeros(ng, bool)
        out = []
        for r in order:
            level = ((np.maximum(gains, 0.0) >= top.gain_sigma - r.gain_sigma - 1e-12) if r is not top
                     else np.ones(ng, bool))
            m = ~taken & (gains <= r.gain_sigma) & level
            taken |= m
            if m.any() and not rival_withholds(recs, r.after_over_floor, a, (r.candidate,)):
                out.append((r, m))
        return out

    for recs in cases:
        truth, kind = recs[0].truth, recs[0].kind
        firsts = named([r for r in recs if r.round == 1])
        if truth == "none":
            named1 = np.zeros(ng, bool)
            for _, m in firsts:
                named1 |= m
            key = "ooc_named" if kind == "out_of_catalogue" else "null_named"
            t["ooc"] += kind == "out_of_catalogue"
            t[key] += named1
            t["right"] += ~named1
            continue
        for b1, named1 in firsts:
            if "+" in truth:
                truths = set(truth.split("+"))
                if b1.candidate not in truths:
                    t["wrong"] += named1
                    continue
                later = [r for r in recs if r.round == 2 and r.named_before == b1.candidate]
                for b2, m2 in (named(later) if later else []):
                    named2 = named1 & m2
                    t["right" if b2.candidate in truths - {b1.candidate} else "wrong"] += named2
                continue
            if b1.candidate != truth:
                t["wrong"] += named1
                continue
            t["right"] += named1
            for _, m2 in named([r for r in recs if r.truth_in_model and r.round == 2]):
                t["wrong"] += named1 & m2
    return t


def _score(t: Mapping) -> int:
    """What the calibration maximises: right decisions minus twice the wrong names minus the names on
    out-of-catalogue cases minus twice the names on nulls."""
    return t["right"] - 2 * t["wrong"] - t["ooc_named"] - 2 * t["null_named"]


#: held-out drops (noise floors) the calibration considers for the path to the noise floor
TO_FLOOR_DROPS = tuple(np.round(np.arange(0.05, 1.0001, 0.025), 3))


def _to_floor_from(cases, gate: tuple, t: dict, allowed: int) -> tuple[float, dict]:
    """The drop asked on the path to the noise floor, with the gate ``(g, share, alpha, fit_share, waive, g_later)``
    fixed: among the drops in :data:`TO_FLOOR_DROPS` that name nothing on a null case and keep the names on
    out-of-catalogue cases within ``allowed``, the one whose right decisions minus twice the wrong names minus the
    out-of-catalogue names beat the gate without the path (``t``); ties to the larger drop. inf (no path) when none
    does. The path only decides rounds where no candidate passes the gate, so it cannot undo a decision the gate
    makes."""
    best, best_t = math.inf, t
    # only a case with a record that could take the path at the smallest drop tried can change its outcome
    alpha, d_min = gate[2], min(TO_FLOOR_DROPS)
    able = [recs for recs in cases if any(not r.rival and _passes_to_floor(r, d_min, alpha) for r in recs)]
    if not able:
        return best, best_t
    ids = {id(recs) for recs in able}
    rest = _tally([recs for recs in cases if id(recs) not in ids], *gate)
    seen = None
    for d in sorted(TO_FLOOR_DROPS, reverse=True):
        reach = _reaching(able, float(d), alpha)
        if reach == seen:   # the same records reach the path: the same outcome, and not a better one
            continue
        seen = reach
        t2 = _sum_tallies(rest, _tally(able, *gate, to_floor=float(d)))
        if t2["null_named"] == 0 and t2["ooc_named"] <= allowed and _score(t2) > _score(best_t):
            best, best_t = float(d), t2
    return best, best_t


def _reaching(cases, drop: float, alpha: float, effect: str | None = None) -> frozenset:
    """Which records (of ``effect``, or any) meet the path to the floor at ``drop``: the outcome of a drop
    depends on nothing else."""
    return frozenset(id(r) for recs in cases for r in recs if not r.rival and (effect is None or r.candidate == effect)
                     and _passes_to_floor(r, drop, alpha))


def _to_floor_by_effect(cases, gate: tuple, to_floor: float, t: dict, allowed: int) -> tuple[float, dict]:
    """Each effect's own drop on the path to the noise floor, with the gate and the common drop fixed: effect by
    effect (twice over the catalogue), the drop in :data:`TO_FLOOR_DROPS` that improves the score (the same bounds:
    nothing named on a null case, the out-of-catalogue names within ``allowed``), ties to the larger; an effect
    keeps the common drop unless its own does better. Returns (:class:`Drops`, outcome)."""
    if not math.isfinite(to_floor):
        return to_floor, t
    alpha, d_min = gate[2], min(TO_FLOOR_DROPS)
    by: dict[str, float] = {}
    best_t = t
    effects = sorted({r.candidate for recs in cases for r in recs if not r.rival})
    # only a case with a record of that effect that could take the path at the smallest drop can change
    able = {e: [recs for recs in cases if any(not r.rival and r.candidate == e and _passes_to_floor(r, d_min, alpha)
                                              for r in recs)] for e in effects}
    for _ in range(2):
        for e in effects:
            if not able[e]:
                continue
            ids = {id(recs) for recs in able[e]}
            rest = _tally([recs for recs in cases if id(recs) not in ids], *gate, to_floor=Drops(to_floor, by))
            seen = {_reaching(able[e], by.get(e, float(to_floor)), alpha, e)}   # the outcome already held
            for d in sorted(TO_FLOOR_DROPS, reverse=True):
                reach = _reaching(able[e], float(d), alpha, e)
                if reach in seen:   # the same records of the effect reach the path: the same outcome
                    continue
                seen.add(reach)
                trial = Drops(to_floor, {**by, e: float(d)})
                t2 = _sum_tallies(rest, _tally(able[e], *gate, to_floor=trial))
                if t2["null_named"] == 0 and t2["ooc_named"] <= allowed and _score(t2) > _score(best_t):
                    by, best_t = trial.by_effect, t2
    return Drops(to_floor, by), best_t


#: joint shares of the held-out gap and gains of each beside the other (noise floors) the calibration considers
#: for the path for two effects at once
PAIR_SHARES = tuple(np.round(np.arange(0.3, 0.951, 0.05), 2))
PAIR_GAINS = tuple(np.round(np.arange(0.0, 0.401, 0.02), 2))


def _search_pair_grid(rest: dict, able: list, grid_a: Sequence[float], grid_b: Sequence[float], takes, t: dict,
                      allowed: int) -> tuple[float, float, dict]:
    """Two thresholds of a path for two effects at once, by the calibration's score within its bounds (ties to the
    stricter, both taken from the top of their grids; (inf, inf) when no value beats ``t``). ``rest``: the outcome
    of the cases the path cannot change; ``able``: per other case (records, outcome without the path, its pair
    trials ranked by joint held-out gain with the outcome each would give); ``takes(q, a, b, recs)``: whether the
    path takes trial ``q`` at values ``a``, ``b`` (the first that does is the one :func:`_pair_best` picks)."""
    best, best_t = (math.inf, math.inf), t
    for a in sorted(grid_a, reverse=True):
        for b in sorted(grid_b, reverse=True):
            t2 = dict(rest)
            for recs, base, ranked in able:
                _add_outcome(t2, recs, *next((out for q, out in ranked if takes(q, a, b, recs)), base))
            if t2["null_named"] == 0 and t2["ooc_named"] <= allowed and _score(t2) > _score(best_t):
                best, best_t = (float(a), float(b)), t2
    return best[0], best[1], best_t


def _ranked_trials(recs: Sequence[Record], trials: Sequence[PairRecord], g: float, alpha: float,
                   withheld_outcome: tuple[int, int]) -> list:
    """The eligible pair trials of a case, largest joint held-out gain first, each with the outcome its naming
    gives (``withheld_outcome`` when the round's rival withholds it)."""
    ranked = sorted(_pair_eligible(recs, trials, g, alpha), key=lambda q: -q.gain_sigma)
    return [(q, _pair_path_outcome(recs[0].truth, (q.first, q.second)) if not _pair_withheld(recs, q, alpha)
             else withheld_outcome) for q in ranked]


def _pair_path_from(cases, pairs: Mapping, gate: tuple, to_floor: float, t: dict, allowed: int
                    ) -> tuple[float, float, dict]:
    """The joint share and the gain of each beside the other asked on the path for two effects at once, with the
    gate and the path to the floor fixed: among :data:`PAIR_SHARES` x :data:`PAIR_GAINS` the pair that names
    nothing on a null case, keeps the out-of-catalogue names within ``allowed`` and has the best score (right
    decisions minus twice the wrong names minus the out-of-catalogue names), if it beats the gate without the path
    (``t``); ties to the stricter. (inf, inf) (no path) otherwise, and always without any pair trial recorded.
    (:func:`_case_outcome` with ``pair_share``, evaluated once per case and pair trial instead of once per value.)"""
    if not any(pairs.values()):
        return math.inf, math.inf, t
    g, sh, a, fs, waive = gate[:5]
    able, ids = [], set()
    for recs in cases:   # only a case with pair trials whose first round names nothing can change its outcome
        trials = pairs.get(recs[0].case)
        if not trials or _first_passing([r for r in recs if r.round == 1], g, sh, a, fs, waive, to_floor,
                                        withhold=False) is not None:
            continue
        base = _case_outcome(recs, *gate, to_floor=to_floor)
        ranked = _ranked_trials(recs, trials, g, a, base)   # withheld: as if the path had not acted
        if ranked:
            ids.add(id(recs))
            able.append((recs, base, ranked))
    rest = _tally([recs for recs in cases if id(recs) not in ids], *gate, to_floor=to_floor)
    if not able:
        return math.inf, math.inf, t
    return _search_pair_grid(rest, able, PAIR_SHARES, PAIR_GAINS,
                             lambda q, share, gain, recs: q.gap_share >= share and q.min_gain_given_other >= gain,
                             t, allowed)


#: margins of the joint held-out gain over the single effect's (noise floors) the calibration considers for two
#: effects named at once over the one a first round would name (a pair must explain more than its better member)
PAIR_MARGINS = tuple(np.round(np.arange(0.05, 1.0001, 0.05), 2))


def _pair_over_from(cases, pairs: Mapping, gate: tuple, to_floor: float, pair_share: float, pair_gain: float,
                    t: dict, allowed: int) -> tuple[float, float, dict]:
    """The margin and the gain of each beside the other asked of two effects named at once over the single effect
    a first round would name, with everything before fixed: among :data:`PAIR_MARGINS` x :data:`PAIR_GAINS` the
    pair that names nothing on a null case, keeps the out-of-catalogue names within ``allowed`` and has the best
    score, if it beats the gate without this path (``t``); ties to the stricter. (inf, inf) otherwise.
    (:func:`_case_outcome` with ``pair_over``, evaluated once per case and pair trial instead of once per value.)"""
    g, sh, a, fs, waive = gate[:5]
    kw = dict(to_floor=to_floor, pairs=pairs, pair_share=pair_share, pair_gain=pair_gain)
    able, ids, alone = [], set(), {}
    for recs in cases:   # only a case whose first round names one effect, with pair trials, can change
        trials = pairs.get(recs[0].case)
        r1 = [r for r in recs if r.round == 1]
        first = _first_passing(r1, g, sh, a, fs, waive, to_floor, withhold=False) if trials else None
        if first is None:
            continue
        alone[id(recs)] = _gain_of(r1, first)
        nothing = (1, 0) if recs[0].truth == "none" else (0, 0)   # withheld: the round names nothing
        ranked = [(q, out) for q, out in _ranked_trials(recs, trials, g, a, nothing)
                  if q.gain_sigma >= alone[id(recs)] + min(PAIR_MARGINS) and q.min_gain_given_other >= 0.0
                  and q.gap_share >= 0.0]
        if ranked:
            ids.add(id(recs))
            able.append((recs, _case_outcome(recs, *gate, **kw), ranked))
    if not able:
        return math.inf, math.inf, t
    rest = _tally([recs for recs in cases if id(recs) not in ids], *gate, **kw)
    return _search_pair_grid(rest, able, PAIR_MARGINS, PAIR_GAINS,
                             lambda q, margin, gain, recs: (q.gain_sigma >= alone[id(recs)] + margin
                                                            and q.min_gain_given_other >= gain), t, allowed)


#: the held-out gains the calibration tries (noise floors): 0 .. 1 in steps of 0.01, then to 6 in steps of 0.25
GAINS = np.unique(np.round(np.concatenate([np.arange(0.0, 1.0, 0.01), np.arange(1.0, 6.01, 0.25)]), 2))


#: first-stage gates (held-out gain, gap share, alpha, fitting share) taken to the later stages, best first (with
#: the best of every gap share besides)
FINALISTS = 10


def _finish(cases, by_case_pairs: Mapping, gains: np.ndarray, g: float, sh: float, a: float, fs: float,
            waive: float, t: dict, allowed: int) -> tuple:
    """The later stages for a first-stage gate: (later-round gain, drop on the path to the floor (:class:`Drops`:
    with each effect's own), pair share, pair gain, margin and gain of a pair over a single effect, final
    outcome)."""
    # a further effect, once one is named: the gap left is smaller, so the same gain in noise floors asks more of
    # it. With the first round's gate fixed, the held-out gain asked in later rounds (never more than g) that makes
    # the most right decisions minus twice the wrong names; ties to the stricter. Nulls and out-of-catalogue cases
    # are judged on round 1 only, so the feasibility above holds for every value tried.
    g_later, best_later = g, (t["right"] - 2 * t["wrong"], g)
    later_rounds = any(r.round > 1 for recs in cases for r in recs)
    for g2 in (gains[gains < g][::-1] if later_rounds else ()):   # no later round recorded: nothing to judge
        t2 = _tally(cases, g, sh, a, fs, waive, float(g2))
        key = (t2["right"] - 2 * t2["wrong"], float(g2))
        if key[0] > best_later[0]:
            best_later, g_later, t = key, float(g2), t2
    to_floor, t = _to_floor_from(cases, (g, sh, a, fs, waive, g_later), t, allowed)
    to_floor, t = _to_floor_by_effect(cases, (g, sh, a, fs, waive, g_later), to_floor, t, allowed)
    pair_share, pair_gain, t = _pair_path_from(cases, by_case_pairs, (g, sh, a, fs, waive, g_later), to_floor, t,
                                               allowed)
    pair_over, pair_over_gain, t = _pair_over_from(cases, by_case_pairs, (g, sh, a, fs, waive, g_later), to_floor,
                                                   pair_share, pair_gain, t, allowed)
    return g_later, to_floor, pair_share, pair_gain, pair_over, pair_over_gain, t


def thresholds_from_records(records: Sequence[Record], pairs: Sequence[PairRecord] = ()) -> dict:
    """The gate's thresholds from calibration records (see module docstring): a grid over the held-out gain
    (0 .. 1 noise floor in steps of 0.01, then to 6 in steps of 0.25), the held-out gap share (0 .. 0.9), the
    fitting-gap share (:data:`FIT_SHARES`) and the family-wise alpha (:data:`ALPHAS`).

    Among the gates that name nothing on any null case and something on at most :func:`ooc_names_allowed` of the
    out-of-catalogue cases, the one with the most right decisions (a single effect named first, both effects of a
    pair named, nothing named where nothing in the catalogue is true) minus twice the wrong names (another effect,
    or a further one after the truth) minus the names on out-of-catalogue cases wins; ties go to the stricter gate.
    Records without a case kind (written before pairs were recorded) count every case with nothing to find as a
    null. Then, for each of the :data:`FINALISTS` best such gates, the gain asked of a further effect, the drop
    asked on the path to the noise floor (:func:`_to_floor_from`), and those of the path for two effects at once
    (:func:`_pair_path_from`, from ``pairs``: the first rounds' pair trials); the finalist with the best final
    score wins (the same score and bounds; ties: the better first stage)."""
    cases, by_case_pairs, allowed = _grouped(records, pairs)
    waive = fit_share_waiver(records)
    gains = GAINS
    shares = np.round(np.arange(0.0, 0.91, 0.05), 2)
    stage1 = []
    for fs in FIT_SHARES:
        for sh in shares:
            for a in ALPHAS:
                tg = _tally_gains(cases, gains, float(sh), a, fs, waive)
                feasible = (tg["null_named"] == 0) & (tg["ooc_named"] <= allowed)
                score = _score(tg)                                     # over every gain at once
                # the block's best gains only (the finalists are among them): feasible, then score, then the
                # stricter (larger) gain
                for i in np.lexsort((gains, score, feasible))[::-1][:FINALISTS]:
                    key = (bool(feasible[i]), int(score[i]), gains[i], sh, fs, -a)   # ties: the stricter gate
                    stage1.append((key, (float(gains[i]), float(sh), float(a), float(fs), tg, int(i))))
    # the gate is chosen on its whole outcome: the leading first-stage gates each get their later-round gain, path
    # to the floor and path for two effects, and the best final score wins (ties: the better first stage). Chosen
    # in stages alone, a looser first stage could crowd out the paths and end with a lower score.
    stage1.sort(key=lambda x: x[0], reverse=True)
    finalists, seen_shares = list(stage1[:FINALISTS]), set()
    for x in stage1:   # and the best first stage of every gap share: ties at the top must not crowd out the rest
        if x[1][1] not in seen_shares:
            seen_shares.add(x[1][1])
            if all(x is not y for y in finalists):
                finalists.append(x)
    best, best_key = None, None
    for key1, (g, sh, a, fs, tg, i) in finalists:
        t = {k: (v if k == "ooc" else int(v[i])) for k, v in tg.items()}
        out = _finish(cases, by_case_pairs, gains, g, sh, a, fs, waive, t, allowed)
        tf = out[-1]
        key = (tf["null_named"] == 0 and tf["ooc_named"] <= allowed, _score(tf), key1)
        if best_key is None or key > best_key:
            best_key, best = key, (g, sh, a, fs) + out
    if best is None:
        z = {"right": 0, "wrong": 0, "null_named": 0, "ooc_named": 0, "ooc": 0}
        best = (1.0, 0.25, 0.01, 0.0, 1.0, math.inf, math.inf, math.inf, math.inf, math.inf, z)
    return _values(records, pairs, len(cases), waive, allowed, best)


def _grouped(records: Sequence[Record], pairs: Sequence[PairRecord]) -> tuple[list, dict, int]:
    """The records by case, the pair trials by case, and the out-of-catalogue names allowed."""
    by_case: dict[str, list[Record]] = {}
    for r in records:
        by_case.setdefault(r.case or f"{r.truth}#{id(r)}", []).append(r)
    cases = list(by_case.values())
    by_case_pairs: dict[str, list[PairRecord]] = {}
    for q in pairs:
        by_case_pairs.setdefault(q.case, []).append(q)
    n_ooc = sum(1 for recs in cases if recs[0].truth == "none" and recs[0].kind == "out_of_catalogue")
    return cases, by_case_pairs, ooc_names_allowed(n_ooc)


def later_stages_from_records(records: Sequence[Record], pairs: Sequence[PairRecord], first: Mapping) -> dict:
    """The later stages of the gate (the gain asked of a further effect, the drops on the path to the noise floor,
    the paths for two effects at once) chosen from calibration records exactly as :func:`thresholds_from_records`
    chooses them for a finalist, with the first stage held at ``first``'s ``heldout_gain_min_sigma``,
    ``gap_share_min``, ``family_alpha``, ``fit_share_min`` and ``fit_share_waived_above_sigma`` (e.g. the shipped
    thresholds). For a change that touches only later rounds (how they are scored), on records regenerated with it:
    the first rounds' records, and so the first stage chosen from them, cannot have moved."""
    cases, by_case_pairs, allowed = _grouped(records, pairs)
    g, sh, a, fs, waive = (float(first[k]) for k in ("heldout_gain_min_sigma", "gap_share_min", "family_alpha",
                                                     "fit_share_min", "fit_share_waived_above_sigma"))
    t = _tally(cases, g, sh, a, fs, waive)
    best = (g, sh, a, fs) + _finish(cases, by_case_pairs, GAINS, g, sh, a, fs, waive, t, allowed)
    return _values(records, pairs, len(cases), waive, allowed, best)


def _values(records: Sequence[Record], pairs: Sequence[PairRecord], n_cases: int, waive: float, allowed: int,
            best: tuple) -> dict:
    """The thresholds and the calibration's summary from the chosen gate ``best``: (g, share, alpha, fitting
    share) followed by :func:`_finish`'s result."""
    g, sh, a, fs, g_later, to_floor, pair_share, pair_gain, pair_over, pair_over_gain, t = best
    pos = [r for r in records if r.truth != "none" and r.round == 1 and r.candidate in r.truth.split("+")]
    neg = [r for r in records if not r.rival and (r.truth == "none" or (r.truth_in_model and "+" not in r.truth))]
    return {"heldout_gain_min_sigma": g, "gap_share_min": sh, "family_alpha": a, "fit_share_min": fs,
            "fit_share_waived_above_sigma": waive, "heldout_gain_min_sigma_later": g_later,
            "to_floor_drop_min_sigma": float(to_floor), BY_EFFECT_KEY: dict(getattr(to_floor, "by_effect", {})),
            "to_floor_ratio_max": TO_FLOOR_RATIO,
            "pair_share_min": pair_share, "pair_gain_min_sigma": pair_gain, "identifiable_waived_above_sigma": waive,
            "pair_over_single_min_sigma": pair_over, "pair_over_gain_min_sigma": pair_over_gain,
            "n_pair_trials": len(pairs),
            "n_cases": n_cases, "right_decisions": int(t["right"]),
            "false_positives": int(t["wrong"] + t["null_named"] + t["ooc_named"]),
            "wrong_names": int(t["wrong"]), "null_cases_named": int(t["null_named"]),
            "out_of_catalogue_named": int(t["ooc_named"]), "out_of_catalogue_cases": int(t["ooc"]),
            "out_of_catalogue_names_allowed": int(allowed),
            "n_positive": len(pos), "n_negative": len(neg),
            "positive_gain_min": float(min((r.gain_sigma for r in pos), default=float("nan"))),
            "negative_gain_max": float(max((r.gain_sigma for r in neg), default=float("nan")))}


def write_thresholds(values: dict, meta: dict, path: str | Path | None = None) -> Path:
    from bpmid.io.atomic import write_text
    path = Path(path) if path else THRESHOLDS_PATH
    body = {"schema": SCHEMA}
    body.update({k: float(f"{float(values[k]):.4g}") for k in THRESHOLD_KEYS})
    body[BY_EFFECT_KEY] = {k: float(f"{float(v):.4g}") for k, v in sorted((values.get(BY_EFFECT_KEY) or {}).items())}
    body["calibration"] = {k: (round(v, 4) if isinstance(v, float) else v) for k, v in values.items()
                           if k not in THRESHOLD_KEYS and k != BY_EFFECT_KEY}
    body["calibration"].update(meta)
    return write_text(path, yaml.safe_dump(body, sort_keys=False))
