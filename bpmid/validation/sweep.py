"""Sweeps of out-of-family cases through ``bpmid discover`` on Dask, with calibration and a confusion matrix.

``bpmid calibrate SWEEP.yaml --out DIR`` (the CLI, :mod:`bpmid.cli.calibrate`) calls :func:`run_sweep`:

1. design the cases (:func:`bpmid.validation.make_cases`) and keep those of the requested split
   (``calibration``, ``heldout`` or ``all``; the split of a case follows from a hash of its id alone);
2. calibration half: each case is simulated, written as a user would have recorded it, read back through
   bpmid's readers and run through :func:`bpmid.discover.workflow.discover` with permissive thresholds
   (``calibration.discover`` of the sweep config), so every candidate's statistics are recorded; then
   :func:`bpmid.discover.calibrate.thresholds_from_records` sets the thresholds and
   :func:`~bpmid.discover.calibrate.write_thresholds` writes ``DIR/thresholds.yaml``;
3. held-out half: the same, with the thresholds calibrated in step 2 (or ``--thresholds FILE``, or those in
   ``DIR/thresholds.yaml`` from an earlier run, or bpmid's shipped ones) and ``evaluation.discover`` overrides;
4. ``DIR/confusion.csv`` and ``DIR/confusion.md`` (rows: hidden truth incl. none / pair / out_of_catalogue;
   columns: the effect named first), ``DIR/summary.yaml`` (single-effect accuracy, false-positive rate on nulls,
   pair recall, out-of-catalogue nothing-named rate, gap-halved rate), ``DIR/answers/<split>.yaml`` (the truth).

Every finished case's record is appended to ``DIR/records.jsonl`` and flushed as soon as it arrives, so an
interrupted sweep resumes: a rerun into the same folder skips finished case ids (a torn last line is dropped).
Dask is imported only here: ``pip install 'bpmid[cluster]'``. By default a ``LocalCluster`` on the machine's
cores (``workers``); ``scheduler`` connects to an existing cluster instead.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Callable, Literal, Mapping, Optional, Sequence, Union

import numpy as np
import yaml

from bpmid.io import yamlsafe

from bpmid.errors import InputError
from bpmid.validation.forms import CATALOGUE_IDS
from bpmid.validation.generator import (GENERATOR, Case, GeneratorConfig, GeometrySpec, answer_entry, case_paths,
                                        generator_config, make_cases, realize, write_answers, write_case)

SWEEP_SCHEMA = "bpmid.sweep/1"
RECORDS = "records.jsonl"
#: what a sweep writes in its folder (a folder holding anything else is not a sweep's)
SWEEP_FILES = frozenset({"sweep.yaml", RECORDS, "thresholds.yaml", "summary.yaml", "confusion.csv", "confusion.md",
                         "answers", "cases"})
#: what a sweep runs: one half, both (calibrate on one, score the other), or ``pool``: every case with the
#: calibration half's permissive settings, all of them calibrating (more calibration data from a draw whose
#: held-out half was already looked at, so it can no longer score a gate)
SPLITS = ("calibration", "heldout", "all", "pool")
#: record fields that differ between runs of the same case (left out when comparing runs)
TIMING_FIELDS = ("elapsed_s", "generate_s", "discover_s", "worker")


def _permissive() -> dict:
    """The calibration half's default discover settings: :data:`bpmid.discover.calibrate.PERMISSIVE` (every
    candidate is confirmed and its statistics recorded)."""
    from bpmid.discover.calibrate import PERMISSIVE
    return dict(PERMISSIVE)


def check_split(split: str) -> None:
    if split not in SPLITS:
        raise InputError(f"must be {', '.join(SPLITS[:-1])} or {SPLITS[-1]}, found {split!r}", key="--split")


# ---------------------------------------------------------------------------------------------
# the sweep config
# ---------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class SweepSection:
    """Section ``sweep``: name (prefix of the case ids), seed, and whether to keep the case folders."""

    name: str = "oof"
    seed: int = 0
    keep_cases: bool = False

    def validate(self, where, path):
        if not self.name or any(ch in self.name for ch in "/\\ "):
            raise InputError(f"must be a plain name (no spaces or slashes), found {self.name!r}", path=path,
                             key=f"{where}.name")


@dataclasses.dataclass(frozen=True)
class RigSection:
    """Section ``rig``: the user's own rig; each key given replaces the generator's range or choices.

    Attributes
    ----------
    noise_deg : sensor noise standard deviation (deg)
    noise_ar1_rho : lag-1 correlation of the noise from one sample to the next at ``sampling_hz`` (0 = white)
    sampling_hz : sampling rate (Hz)
    geometry : a built-in name or {name, th_mm, alpha0_deg, R0_mm, l0_mm, n}
    pressure_unit, pressure_reference, time_unit : how the rig logs
    pressure_noise_pa : the pressure transducer's noise standard deviation (Pa)
    """

    noise_deg: Optional[float] = None
    noise_ar1_rho: Optional[float] = None
    sampling_hz: Optional[float] = None
    geometry: Optional[Union[str, GeometrySpec]] = None
    pressure_unit: Optional[Literal["bar", "kpa", "psi"]] = None
    pressure_reference: Optional[Literal["absolute", "gauge"]] = None
    time_unit: Optional[Literal["s", "ms"]] = None
    pressure_noise_pa: Optional[float] = None

    def validate(self, where, path):
        """Each rig value checked under its own key (not as the generator's range it replaces)."""
        from bpmid.validation.generator import VALUE_RANGES

        for name, gen_name, unit in (("noise_deg", "noise_deg", " deg"), ("noise_ar1_rho", "noise_rho", ""),
                                     ("sampling_hz", "sampling_hz", " Hz"), ("pressure_noise_pa", "pressure_noise_pa",
                                                                             " Pa")):
            v, (lo, hi) = getattr(self, name), VALUE_RANGES[gen_name]
            # sensor noise must be above 0 (discovery needs raw measurements), as the generator asks
            if v is not None and not (math.isfinite(v) and lo <= v <= hi and (v > 0 or name != "noise_deg")):
                what = (f"above 0 and at most {hi:g}" if name == "noise_deg" else
                        f"from {lo:g}{' (white)' if name == 'noise_ar1_rho' else ''} to {hi:g}")
                raise InputError(f"must be {what}{unit}, found {v!r}", path=path, key=f"{where}.{name}")

    def apply(self, gen: GeneratorConfig, path=None) -> GeneratorConfig:
        d = gen.to_yaml()
        if self.noise_deg is not None:
            d["noise_deg"] = [self.noise_deg, self.noise_deg]
        if self.noise_ar1_rho is not None:
            d["noise_rho"] = [self.noise_ar1_rho, self.noise_ar1_rho]
            d["white_share"] = 1.0 if self.noise_ar1_rho == 0 else 0.0
        if self.sampling_hz is not None:
            d["sampling_hz"] = [self.sampling_hz]
        if self.pressure_noise_pa is not None:
            d["pressure_noise_pa"] = [self.pressure_noise_pa, self.pressure_noise_pa]
        if self.geometry is not None:
            d["geometries"] = [self.geometry if isinstance(self.geometry, str) else dataclasses.asdict(self.geometry)]
        for key, gkey in (("pressure_unit", "pressure_units"), ("pressure_reference", "pressure_references"),
                          ("time_unit", "time_units")):
            if getattr(self, key) is not None:
                d[gkey] = [getattr(self, key)]
        return generator_config(d, path, where="rig")


@dataclasses.dataclass(frozen=True)
class PhaseSection:
    """Sections ``calibration`` and ``evaluation``: overrides of the config section ``discover`` for that half
    (the calibration half: of :data:`bpmid.discover.calibrate.PERMISSIVE`, which fills every key not given)."""

    discover: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    def __post_init__(self):
        object.__setattr__(self, "discover", dict(self.discover))


@dataclasses.dataclass(frozen=True)
class SweepConfig:
    """A sweep: ``sweep``, ``generator``, ``rig``, ``calibration``, ``evaluation`` (see the shipped
    configs/sweeps/*.yaml)."""

    sweep: SweepSection = dataclasses.field(default_factory=SweepSection)
    generator: GeneratorConfig = dataclasses.field(default_factory=GeneratorConfig)
    rig: RigSection = dataclasses.field(default_factory=RigSection)
    calibration: PhaseSection = dataclasses.field(default_factory=lambda: PhaseSection(_permissive()))
    evaluation: PhaseSection = dataclasses.field(default_factory=PhaseSection)
    path: Optional[str] = None
    sha256: Optional[str] = None

    @property
    def effective_generator(self) -> GeneratorConfig:
        return self.rig.apply(self.generator, self.path)

    def discover_config(self, phase: str, thresholds: Mapping[str, float] | None = None):
        """The ``DiscoverConfig`` of a half: the phase's overrides, plus calibrated thresholds (held-out half)."""
        from bpmid.config import build_dataclass
        from bpmid.discover.workflow import DiscoverConfig
        sec = self.calibration if phase == "calibration" else self.evaluation
        over = dict(sec.discover)
        fields = {f.name for f in dataclasses.fields(DiscoverConfig)}
        for k, v in (thresholds or {}).items():
            if k in fields and k not in over:
                over[k] = dict(v) if isinstance(v, Mapping) else float(v)
        return build_dataclass(DiscoverConfig, over, f"{phase}.discover", self.path)

    def to_yaml(self) -> dict:
        return {"sweep": dataclasses.asdict(self.sweep), "generator": self.effective_generator.to_yaml(),
                "calibration": {"discover": dict(self.calibration.discover)},
                "evaluation": {"discover": dict(self.evaluation.discover)}}


def _model_geometry_keys() -> dict:
    """A model's geometry keys (``model.geometry``: the SI fields, and :attr:`Geometry.UNIT_KEYS`, which state their
    unit) that are not the rig's own mm/deg keys -> (the rig's key, factor to it)."""
    from bpmid.models.vbmm.model import Geometry

    rig = {"th": ("th_mm", 1e3), "R0": ("R0_mm", 1e3), "l0": ("l0_mm", 1e3), "alpha0": ("alpha0_deg", 180.0 / math.pi)}
    keys = dict(rig)
    for k, (field, to_si) in Geometry.UNIT_KEYS.items():
        to, factor = rig[field]
        if k != to:
            keys[k] = (to, to_si * factor)
    return keys


def _rig_geometry(geo: dict, path) -> dict:
    """``rig.geometry`` as the generator takes it ({name, th_mm, alpha0_deg, R0_mm, l0_mm, n}) from the same block a
    discover config's ``model.geometry`` holds (th, R0, l0 in m and alpha0 in rad, or keys stating their unit); the
    name defaults to ``rig``. A field given twice is refused under the second key."""
    keys = _model_geometry_keys()
    out = {"name": "rig"} if "name" not in geo else {}
    for k, v in geo.items():
        if k not in keys:
            if k in out and k != "name":
                raise InputError(f"{k} is given twice: keep one", path=path, key=f"rig.geometry.{k}")
            out[k] = v
            continue
        to, factor = keys[k]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise InputError(f"expected a number, found {v!r}", path=path, key=f"rig.geometry.{k}")
        if to in out or to in geo:
            raise InputError(f"{to.split('_')[0]} is given twice ({to} and {k}): keep one", path=path,
                             key=f"rig.geometry.{k}")
        field = to.split("_")[0]
        if field == "alpha0" and not float(v) < math.pi / 2:
            raise InputError(f"{float(v):g} rad is a right angle or more: degrees given under {k}? {k} takes radians "
                             f"({math.radians(float(v)):.4g} for {float(v):g} deg), alpha0_deg degrees", path=path,
                             key=f"rig.geometry.{k}")
        if field != "alpha0":   # metres as the model checks them, said under the key the user wrote
            from bpmid.models.vbmm.model import GEOMETRY_MAX_M, GEOMETRY_MIN_M
            lo, hi = GEOMETRY_MIN_M[field], GEOMETRY_MAX_M[field]
            if not lo <= float(v) <= hi:
                raise InputError(f"{float(v):g} m is too {'large' if v > hi else 'small'} for a muscle ({lo:g}-{hi:g} "
                                 f"m): {k} takes metres ({float(v) * 1e-3:g} for {float(v):g} mm), {to} millimetres",
                                 path=path, key=f"rig.geometry.{k}")
        out[to] = float(v) * factor
    return out


def load_sweep(path: str | Path) -> SweepConfig:
    """Read SWEEP.yaml; every key is checked (an unknown or bad key is an InputError naming it)."""
    from bpmid.config import build_dataclass, read_yaml
    path = Path(path)
    data, sha = read_yaml(path, "sweep config")
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise InputError("a sweep config must be a mapping of sections sweep, generator, rig, calibration, "
                         "evaluation", path=path)
    known = ("sweep", "generator", "rig", "calibration", "evaluation")
    for k in data:
        if k not in known:
            raise InputError(f"unknown section (known: {', '.join(known)})", path=path, key=str(k))
    rig = data.get("rig")
    if isinstance(rig, dict):
        rig = dict(rig)
        for k in ("pressure_unit", "pressure_reference", "time_unit"):   # kPa as the rest of bpmid spells it
            if isinstance(rig.get(k), str):
                rig[k] = rig[k].strip().lower()
        geo = rig.get("geometry")
        if isinstance(geo, str):   # a built-in name, as written (PAPER is paper), refused under the user's key
            from bpmid.validation.generator import GEOMETRIES
            rig["geometry"] = geo = geo.strip().lower()
            if geo not in GEOMETRIES:
                raise InputError(f"unknown geometry {geo!r} (built in: {', '.join(GEOMETRIES)}; or give a mapping "
                                 "name, th_mm, alpha0_deg, R0_mm, l0_mm, n)", path=path, key="rig.geometry")
        if isinstance(geo, dict):   # a mapping: every key named when one is missing (not a Python signature)
            rig["geometry"] = geo = _rig_geometry(geo, path)
            need = ("name", "th_mm", "alpha0_deg", "R0_mm", "l0_mm", "n")
            missing = [k for k in need if k not in geo]
            if missing:
                raise InputError(f"missing {', '.join(missing)} (a geometry is {{name, th_mm, alpha0_deg, R0_mm, "
                                 f"l0_mm, n}}, as a model's geometry may be given (th, R0, l0 in m, alpha0 in rad), "
                                 f"or a built-in name: paper, slim, wide)", path=path,
                                 key=f"rig.geometry.{missing[0]}")
            from bpmid.validation.generator import GeometrySpec
            build_dataclass(GeometrySpec, geo, "rig.geometry", path)   # each value checked under its own key
        data = {**data, "rig": rig}
    kw = {}
    for name, cls in (("sweep", SweepSection), ("generator", GeneratorConfig), ("rig", RigSection),
                      ("calibration", PhaseSection), ("evaluation", PhaseSection)):
        if name in data:
            kw[name] = build_dataclass(cls, data[name], name, path)
    if "calibration" in kw:
        # the calibration half stays permissive in every key its section does not set: a section written before a
        # gate condition existed (fit_share_min, the later-round gain) must not have the shipped value of it
        # applied to the run that records the statistics to calibrate it from
        from bpmid.discover.calibrate import later_gain_follows

        given = kw["calibration"].discover
        kw["calibration"] = PhaseSection(later_gain_follows({**_permissive(), **given}, given))
    cfg = SweepConfig(**kw, path=str(path), sha256=sha)
    _ = cfg.effective_generator
    cfg.discover_config("calibration")  # check the discover overrides now, naming the key
    cfg.discover_config("evaluation")
    return cfg


# ---------------------------------------------------------------------------------------------
# one case (runs on a Dask worker)
# ---------------------------------------------------------------------------------------------
def _plain_result(res) -> dict:
    """What the record keeps of a DiscoveryResult."""
    cands = []
    for k, rnd in enumerate(res.rounds, start=1):
        for c in rnd.confirmations:
            y = c.to_yaml() if hasattr(c, "to_yaml") else {}
            keep = {kk: v for kk, v in y.items() if isinstance(v, (int, float, str, bool)) or v is None}
            keep.update({"round": k, "effect": c.effect_id, "accepted": bool(getattr(c, "accepted", False))})
            cands.append(keep)
    from bpmid.discover.rivals import own_shape, rival_constants
    rivals = [{"round": k, "effect": rv.effect_id, "withheld": bool(rnd.withheld) and rv is rnd.rival,
               "own_shape": bool(own_shape(rv)), "constants": rival_constants(rv),
               "heldout_rmse_after_deg": float(rv.heldout_rmse_after), "likelihood_ratio_p": float(rv.lr_p)}
              for k, rnd in enumerate(res.rounds, start=1)
              for rv in (rnd.rivals or ([rnd.rival] if rnd.rival is not None else []))]
    return {"named": list(res.named_effects), "unexplained": bool(res.unexplained),
            "heldout_before_deg": float(res.heldout_before), "heldout_after_deg": float(res.heldout_after),
            "noise_floor_deg": float(res.noise_floor_deg), "candidates": cands, "rivals": rivals,
            "screening_round1": [s.effect_id for s in res.rounds[0].ranking] if res.rounds else []}


def calibration_truth(case_kind: str, truth_ids: Sequence[str]) -> Optional[str]:
    """The ``truth`` handed to ``records_from_result``: the id for a single effect, ``none`` for a null and for an
    out-of-catalogue case (nothing in the catalogue is true there), the two ids joined by ``+`` for a pair, None
    (no calibration records) for anything else."""
    if case_kind == "single":
        return truth_ids[0]
    if case_kind in ("null", "out_of_catalogue"):
        return "none"
    if case_kind == "pair" and len(truth_ids) == 2:
        return "+".join(truth_ids)
    return None


def run_case(case: Case, phase: str, discover_cfg, keep_dir: Optional[str] = None) -> dict:
    """Simulate, write, read back and discover one case; a record (plain JSON types). Never raises for a case
    discovery cannot judge: the record says ``error``."""
    from bpmid.discover.calibrate import pair_records_from_result, records_from_result
    from bpmid.discover.workflow import discover
    from bpmid.progress import set_quiet

    set_quiet(True)
    t0 = time.perf_counter()
    settings = discover_settings(discover_cfg)
    data = realize(case)
    entry = answer_entry(data)
    t1 = time.perf_counter()
    rec: dict = {"id": case.id, "split": case.split, "phase": phase, "truth_label": case.truth_label,
                 "kind": case.kind, "truth_ids": [e.effect for e in case.effects],
                 "truth_forms": [e.form for e in case.effects], "truth": entry["truth"],
                 "geometry": case.geometry.name, "sampling_hz": case.fs_hz,
                 "noise_deg": round(case.noise_deg, 5), "noise_ar1_rho": round(case.noise_rho, 4),
                 "variation": round(case.variation, 5), "discover_settings": settings}
    tmp = None
    try:
        root = Path(keep_dir) if keep_dir else Path(tmp := tempfile.mkdtemp(prefix="bpmid-oof-"))
        write_case(data, root)
        try:  # as ``bpmid discover fit/*.csv --holdout holdout/*.csv --init init.yaml --config case.yaml``
            paths, cfg, fit, ho = read_written_case(root / case.id)
            base = _load_base(paths["init"], cfg)
            res = discover(fit, base, holdout=ho, cfg=discover_cfg)
        except InputError as exc:  # includes ConvergenceError: discovery declined to judge
            rec.update({"error": exc.format() if hasattr(exc, "format") else str(exc), "error_kind": "declined",
                        "named": [], "unexplained": None, "candidates": [], "calibration_records": []})
        except Exception as exc:  # an internal failure on one case must not end a sweep of thousands: record it
            import traceback
            rec.update({"error": f"{type(exc).__name__}: {exc} | {traceback.format_exc(limit=-2)[-600:]}",
                        "error_kind": "internal", "named": [], "unexplained": None, "candidates": [],
                        "calibration_records": []})
        else:
            rec.update(_plain_result(res))
            truth = calibration_truth(case.kind, rec["truth_ids"])
            recs = records_from_result(truth, res, kind=case.kind) if truth is not None else []
            pairs = pair_records_from_result(truth, res, kind=case.kind) if truth is not None else []
            rec["calibration_truth"] = truth
            rec["calibration_records"] = [_record_dict(r) for r in recs]
            rec["calibration_pairs"] = [_record_dict(r) for r in pairs]
            rec["error"] = None
            rec["error_kind"] = None
    finally:
        if tmp is not None:
            import shutil
            shutil.rmtree(tmp, ignore_errors=True)
    t2 = time.perf_counter()
    rec.update({"generate_s": round(t1 - t0, 3), "discover_s": round(t2 - t1, 3), "elapsed_s": round(t2 - t0, 3)})
    return json.loads(json.dumps(_fix_nan(rec), default=_json_default))   # as written: NaN -> None


def read_written_case(case_dir: str | Path):
    """(paths, config, fitting logs, held-out logs) of a case written by :func:`write_case`, read as ``bpmid
    discover fit/*.csv --holdout holdout/*.csv --config case.yaml`` reads them."""
    from bpmid.config import load_config
    from bpmid.io.motion_logs import read_motion_logs

    paths = case_paths(Path(case_dir))
    cfg = load_config(paths["config"])
    fit = read_motion_logs(paths["fit"], cfg.section("io"), require_angle=True)
    ho = read_motion_logs(paths["holdout"], cfg.section("io"), require_angle=True)
    return paths, cfg, fit, ho


def discover_settings(discover_cfg) -> dict:
    """The discover settings a record was made with (plain JSON): a resumed sweep reruns a case whose settings
    (thresholds, overrides) differ from the current ones."""
    d = dataclasses.asdict(discover_cfg) if dataclasses.is_dataclass(discover_cfg) else dict(discover_cfg or {})
    if d.get("thresholds_file") is None:   # unset: the records written before the key existed stay current
        d.pop("thresholds_file", None)
    return json.loads(json.dumps(_fix_nan(d), sort_keys=True, default=_json_default))


def _load_base(init: Path, cfg):
    """The starting model as ``bpmid discover --init init.yaml --config case.yaml`` builds it."""
    try:
        from bpmid.cli.discover import load_base
    except ImportError:  # the CLI helper moved: the same file read directly (init.yaml is bpmid.vbmm/1)
        from bpmid.models.vbmm import load_vbmm
        return load_vbmm(init, cfg.section("model"))
    return load_base(init, cfg)[0]


def _record_dict(r) -> dict:
    if dataclasses.is_dataclass(r):
        return dataclasses.asdict(r)
    return dict(r)


def _json_default(x):
    if isinstance(x, (np.floating,)):
        return float(x)
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    if isinstance(x, np.ndarray):
        return x.tolist()
    return str(x)


def _fix_nan(obj):
    """JSON has no NaN: write null."""
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, dict):
        return {k: _fix_nan(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_fix_nan(v) for v in obj]
    return obj


# ---------------------------------------------------------------------------------------------
# streaming records, resuming
# ---------------------------------------------------------------------------------------------
def read_records(path: str | Path) -> list[dict]:
    """Records of a JSONL file; a torn last line (an interrupted write) is dropped and cut from the file. A bad
    line elsewhere is an InputError naming it."""
    path = Path(path)
    if not path.exists():
        return []
    raw = path.read_bytes()
    lines = raw.split(b"\n")
    out, good_end, pos = [], 0, 0
    for i, line in enumerate(lines):
        end = pos + len(line) + 1
        if line.strip():
            try:
                out.append(json.loads(line))
                good_end = min(end, len(raw))
            except json.JSONDecodeError:
                if i < len(lines) - 1 and any(x.strip() for x in lines[i + 1:]):
                    raise InputError("not a JSON record; the records file is damaged (move it away to start over)",
                                     path=path, line=i + 1) from None
                with open(path, "r+b") as fh:  # torn last line: cut it
                    fh.truncate(good_end)
                break
        else:
            good_end = min(end, len(raw)) if i < len(lines) - 1 else good_end
        pos = end
    return out


def _compact_records(path: Path) -> None:
    """Rewrite a records file with one line per case id, the last one (the one every reader uses), when a case
    was recorded more than once; atomically, so an interruption leaves the old file."""
    recs = read_records(path)
    last = {r["id"]: r for r in recs}
    if len(last) == len(recs):
        return
    from bpmid.io.atomic import write_text

    order = list(dict.fromkeys(r["id"] for r in recs))
    write_text(path, "".join(json.dumps(_fix_nan(last[i]), sort_keys=True, allow_nan=False) + "\n" for i in order))


class RecordWriter:
    """Append one JSON record per line, flushed and synced as each arrives."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if self.path.exists() and self.path.stat().st_size:
            with open(self.path, "rb") as fh:  # make sure we start on a new line
                fh.seek(-1, os.SEEK_END)
                last = fh.read(1)
            if last != b"\n":
                with open(self.path, "ab") as fh:
                    fh.write(b"\n")
        self.fh = open(self.path, "a", encoding="utf-8")

    def write(self, rec: dict) -> None:
        self.fh.write(json.dumps(_fix_nan(rec), sort_keys=True, allow_nan=False) + "\n")
        self.fh.flush()
        os.fsync(self.fh.fileno())

    def close(self):
        self.fh.close()


def sweep_stamp(out: str | Path) -> dict | None:
    """The folder's ``sweep.yaml`` when ``bpmid calibrate`` wrote it (its schema and fingerprint), else None."""
    stamp = Path(out) / "sweep.yaml"
    try:
        head = yaml.safe_load(stamp.read_text("utf-8")) if stamp.is_file() else None
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        return None
    ok = isinstance(head, dict) and head.get("schema") == SWEEP_SCHEMA and bool(head.get("fingerprint"))
    return head if ok else None


def refuse_sweep_folder(out: str | Path, command: str) -> None:
    """InputError naming ``--out`` when ``out`` is a sweep's folder (:func:`sweep_stamp`): another command's files
    beside a sweep's read as one result, and the sweep could not resume."""
    if sweep_stamp(out) is not None:
        raise InputError(f"this folder holds a sweep of bpmid calibrate (sweep.yaml, records.jsonl); bpmid {command} "
                         f"needs a folder of its own: give another --out (nothing was written)", path=out,
                         key="--out")


def _time_left(counter: dict, total: int) -> str:
    """``; about N min left in this half``: the wall time per case so far in this run (workers in parallel) times the
    cases left; said once a few cases have finished."""
    left = total - counter["n"]
    if counter["run"] < 3 or left <= 0:
        return ""
    per = (time.perf_counter() - counter["t0"]) / counter["run"]
    sec = per * left
    return f"; about {sec / 60:.0f} min left in this half" if sec >= 90 else f"; about {sec:.0f} s left in this half"


def _check_folder(out: Path, cfg: SweepConfig, force: bool = False) -> None:
    """A folder holds one sweep: refuse to resume another config's sweep into it."""
    stamp = out / "sweep.yaml"
    cases_def = {"sweep": dataclasses.asdict(cfg.sweep), "generator": cfg.effective_generator.to_yaml(),
                 "generator_version": GENERATOR}
    fp = hashlib.sha256(json.dumps(cases_def, sort_keys=True, default=str).encode()).hexdigest()
    if not force:
        # a folder is a sweep's when its sweep.yaml is one bpmid wrote; any other folder must be empty: a folder of
        # another command's outputs (discover's discovery.yaml) would read as one result with the sweep's, and a
        # user's own sweep.yaml or thresholds.yaml there would be replaced
        old = sweep_stamp(out)
        other = sorted(p.name for p in out.iterdir() if not p.name.startswith(".")
                       and (old is None or p.name not in SWEEP_FILES))
        if other:
            shown = ", ".join(other[:4]) + (f" and {len(other) - 4} more" if len(other) > 4 else "")
            raise InputError(f"this folder holds files that are not a sweep's ({shown}"
                             + ("; its sweep.yaml is not one bpmid calibrate wrote" if stamp.exists() and old is None
                                else "") + "); a sweep needs a folder of its own: give a new --out (nothing was "
                             "written)", path=out, key="--out")
        if old is not None and old["fingerprint"] != fp:
            raise InputError("this folder holds a sweep of another config (other cases); give a new --out to "
                             "start a new sweep", path=stamp, key="fingerprint")
    from bpmid.io.atomic import write_text
    body = {"schema": SWEEP_SCHEMA, "fingerprint": fp, "config_path": cfg.path, "config_sha256": cfg.sha256,
            "generator": GENERATOR, **cfg.to_yaml()}
    write_text(stamp, yamlsafe.dump(body, sort_keys=False))


# ---------------------------------------------------------------------------------------------
# the Dask driver
# ---------------------------------------------------------------------------------------------
def _client(scheduler: Optional[str], workers: Optional[int], processes: bool):
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise InputError("sweeps run on Dask: pip install 'bpmid[cluster]' (dask[distributed])") from exc
    if scheduler:
        what_to_do = (f"check the address (tcp://HOST:8786, as `dask scheduler` prints it), start a scheduler there "
                      f"(`dask scheduler`) with workers (`dask worker tcp://HOST:8786`, in an environment where bpmid "
                      f"is installed), or leave out --scheduler to run on a LocalCluster on this machine")
        client = _connect(Client, scheduler, what_to_do)
        try:
            _check_workers(client, scheduler)
        except BaseException:
            client.close()
            raise
        return client, None
    n = workers or os.cpu_count() or 1
    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=processes, dashboard_address=":0",
                           silence_logs=40)
    return Client(cluster), cluster


#: how long an existing cluster may take to show its first worker (s)
WORKER_WAIT_S = 60.0
#: how long connecting to a scheduler may take in all (s): a port that accepts the connection but is no Dask
#: scheduler (its dashboard, a web server) never answers the handshake, and the client's own timeout does not end it
CONNECT_WAIT_S = 20.0


def _connect(Client, scheduler: str, what_to_do: str):
    """``Client(scheduler)`` within :data:`CONNECT_WAIT_S`, else InputError naming the address and what to do."""
    import threading

    box: dict = {}

    def go():
        try:
            box["client"] = Client(scheduler, timeout="10s")
        except BaseException as exc:   # noqa: BLE001 - reported below
            box["error"] = exc

    th = threading.Thread(target=go, name="bpmid-connect", daemon=True)
    th.start()
    th.join(CONNECT_WAIT_S)
    if "client" in box:
        return box["client"]
    exc = box.get("error")
    why = (f"{type(exc).__name__}: {exc}" if exc is not None else
           f"no Dask scheduler answered within {CONNECT_WAIT_S:g} s: is it the scheduler's port (8786 by default), not "
           f"its dashboard's?")
    # a malformed address is a ValueError, an unreachable one an OSError/TimeoutError
    raise InputError(f"cannot connect to the Dask scheduler at {scheduler!r} ({why}): {what_to_do}",
                     key="--scheduler") from None


def code_fingerprint() -> str:
    """A short SHA-256 of the bpmid package this process runs (every ``.py`` and ``.yaml`` file under it, by path
    relative to the package and content; not the shipped example data of ``_data``): equal on two machines when they
    run the same code, whatever the version string says (every commit of a release carries the same one) or where it
    is installed."""
    import hashlib
    from pathlib import Path

    import bpmid

    root = Path(bpmid.__file__).resolve().parent
    h = hashlib.sha256()
    files = (p for ext in ("*.py", "*.yaml") for p in root.rglob(ext)
             if not {"__pycache__", "_data"} & set(p.relative_to(root).parts))
    for f in sorted(files):
        h.update(f.relative_to(root).as_posix().encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()[:16]


def _check_workers(client, scheduler: str) -> None:
    """An existing cluster must have workers, and every worker must run this bpmid: a worker that cannot import it
    dies on the first case and the sweep would wait forever. Asked with standard-library functions only (they
    unpickle on any worker)."""
    import importlib.metadata

    from bpmid import __version__

    try:
        client.wait_for_workers(1, timeout=WORKER_WAIT_S)
    except Exception:   # TimeoutError (of asyncio or of dask)
        raise InputError(f"the Dask scheduler at {scheduler!r} has no worker after {WORKER_WAIT_S:g} s: start one "
                         f"(`dask worker {scheduler}`, in an environment where bpmid is installed), or leave out "
                         f"--scheduler to run on a LocalCluster on this machine", key="--scheduler") from None
    found = client.run(importlib.metadata.version, "bpmid", on_error="return")
    bad = {w: v for w, v in found.items() if v != __version__}
    if bad:
        w, v = next(iter(bad.items()))
        has = (f"bpmid {v}" if isinstance(v, str) else
               "no bpmid" if isinstance(v, importlib.metadata.PackageNotFoundError) else f"an error ({v!r})")
        raise InputError(f"{len(bad)} of the {len(found)} Dask worker(s) at {scheduler!r} cannot run this sweep: "
                         f"{w} has {has}, this command bpmid {__version__}. Install the same bpmid (with "
                         f"'bpmid[cluster]') in the workers' environment and restart them", key="--scheduler")
    # the same version string can be other code (another commit, local edits): its discovery would decide otherwise
    mine = code_fingerprint()
    prints = client.run(code_fingerprint, on_error="return")
    other = {w: v for w, v in prints.items() if v != mine}
    if other:
        w, v = next(iter(other.items()))
        raise InputError(f"{len(other)} of the {len(prints)} Dask worker(s) at {scheduler!r} run other bpmid code: "
                         f"{w} has bpmid {__version__} with code fingerprint "
                         f"{v if isinstance(v, str) else f'(an error: {v!r})'}, this command {mine} (another commit, "
                         f"or local edits; the fingerprint hashes every .py and .yaml file of the package). Install "
                         f"this bpmid in the workers' environment and restart them", key="--scheduler")


def run_cases(cases: Sequence[Case], phase: str, discover_cfg, writer: RecordWriter, client, *,
              keep_dir: Optional[str] = None, stop_after: Optional[int] = None,
              on_record: Optional[Callable[[dict], None]] = None) -> list[dict]:
    """Submit the cases to the Dask client, stream each record to ``writer`` as it finishes. ``stop_after``: stop
    (cancel the rest) once that many records were written in this call (an interruption, for tests)."""
    from dask.distributed import as_completed

    if not cases:
        return []
    futures = [client.submit(run_case, c, phase, discover_cfg, keep_dir, key=f"bpmid-oof-{phase}-{c.id}",
                             pure=False) for c in cases]
    out = []
    try:
        for fut in as_completed(futures):
            rec = fut.result()
            writer.write(rec)
            out.append(rec)
            if on_record:
                on_record(rec)
            if stop_after is not None and len(out) >= stop_after:
                break
    finally:
        for f in futures:
            if not f.done():
                f.cancel()
    return out


def cases_by_id(configs: Sequence[str | Path]) -> dict[str, tuple[SweepConfig, Case]]:
    """Every case of the given sweep configs (both halves), by id, with the config that makes it."""
    out = {}
    for c in configs:
        cfg = load_sweep(c)
        for case in make_cases(cfg.effective_generator, cfg.sweep.seed, prefix=cfg.sweep.name):
            out[case.id] = (cfg, case)
    return out


def calibration_records(paths: Sequence[str | Path]) -> dict[str, dict]:
    """The records run with the permissive calibration settings in the given records files, by case id (a later
    file's record of a case replaces an earlier one)."""
    out = {}
    for path in paths:
        for rec in read_records(path):
            if rec.get("phase", rec.get("split")) == "calibration":
                out[rec["id"]] = rec
    return out


def rerun_calibration(chosen: Sequence[tuple[SweepConfig, Case]], out: str | Path, workers: Optional[int] = None,
                      on_record: Optional[Callable[[dict], None]] = None, processes: bool = True) -> None:
    """Run the chosen cases again with their config's calibration settings (the permissive run, which records
    the pair trials too) on a local Dask cluster, streaming each record to ``OUT/records.jsonl`` (``processes``:
    worker processes, or threads of this one, as in :func:`run_sweep`)."""
    client, cluster = _client(None, workers, processes)
    writer = RecordWriter(Path(out) / "records.jsonl")
    try:
        by_cfg: dict = {}
        for cfg, case in chosen:
            by_cfg.setdefault(id(cfg), (cfg, []))[1].append(case)
        for cfg, cs in by_cfg.values():
            run_cases(cs, "calibration", cfg.discover_config("calibration"), writer, client, on_record=on_record)
    finally:
        writer.close()
        client.close()
        if cluster is not None:
            cluster.close()


@dataclasses.dataclass
class SweepOutcome:
    """What :func:`run_sweep` did: records per half, thresholds used or written, the summary of the evaluated
    half, and the files written."""

    records: list[dict]
    thresholds: Optional[dict]
    summary: Optional[dict]
    files: dict
    complete: bool


def run_sweep(cfg: SweepConfig, out: str | Path, *, split: str = "all", scheduler: Optional[str] = None,
              workers: Optional[int] = None, processes: bool = True, thresholds_path: Optional[str | Path] = None,
              stop_after: Optional[int] = None, progress: Optional[Callable[[str], None]] = None,
              max_cases: Optional[int] = None, warn: Optional[Callable[[str], None]] = None) -> SweepOutcome:
    """Run a sweep into ``out`` (see the module docstring). Resumes: finished case ids in ``out/records.jsonl``
    are skipped. ``stop_after`` stops after that many new records (an interruption, used by the tests);
    ``max_cases`` keeps only the first cases of each half (by id; a quick subset that a full rerun extends)."""
    from bpmid.discover.calibrate import load_thresholds, thresholds_from_records, write_thresholds

    if warn is None:   # a warning is said even when progress is silenced (-q)
        warn = lambda m: print(m, file=sys.stderr)  # noqa: E731
    check_split(split)
    out = Path(out)
    # a given thresholds file is read (and a bad one refused) before anything is written
    given = load_thresholds(thresholds_path) if thresholds_path is not None else None
    try:  # before anything is written: without Dask the sweep cannot run, so no folder is left behind
        import dask.distributed  # noqa: F401
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise InputError("sweeps run on Dask: pip install 'bpmid[cluster]' (dask[distributed])") from exc
    # an existing cluster is asked before anything is written: a bad address, no workers or workers without bpmid
    # leave no folder behind (a LocalCluster starts only when there are cases to run)
    client, cluster = _client(scheduler, workers, processes) if scheduler else (None, None)
    try:
        out.mkdir(parents=True, exist_ok=True)
        _check_folder(out, cfg)
    except BaseException:
        if client is not None:
            client.close()
        raise
    say = progress or (lambda m: None)
    gen = cfg.effective_generator
    cases = make_cases(gen, cfg.sweep.seed, prefix=cfg.sweep.name)
    halves = {"calibration": [c for c in cases if c.split == "calibration"],
              "heldout": [c for c in cases if c.split == "heldout"]}
    if max_cases is not None:
        halves = {k: v[:max(int(max_cases), 0)] for k, v in halves.items()}
    if split == "pool":  # both halves calibrate: a held-out half once looked at can no longer score anything
        halves = {"calibration": sorted(halves["calibration"] + halves["heldout"], key=lambda c: c.index),
                  "heldout": []}
    phases = {"all": ["calibration", "heldout"], "pool": ["calibration"]}.get(split, [split])
    done = {r["id"]: r for r in read_records(out / RECORDS)}
    writer = RecordWriter(out / RECORDS)
    # absolute: the workers of an existing cluster run in their own working folder
    keep = str(out.resolve() / "cases") if cfg.sweep.keep_cases else None
    files = {"records": str(out / RECORDS), "sweep": str(out / "sweep.yaml")}
    thresholds = None
    new = 0
    try:
        for phase in phases:
            if phase == "heldout":
                thresholds = _thresholds_for_heldout(out, given, thresholds, load_thresholds)
            dcfg = cfg.discover_config(phase, thresholds if phase == "heldout" else None)
            now = discover_settings(dcfg)
            todo = [c for c in halves[phase] if c.id not in done or done[c.id].get("discover_settings") != now]
            total = len(halves[phase])
            say(f"{'every case (pool), as the calibration half' if split == 'pool' else phase + ' half'}: {total} "
                f"case{'s' if total != 1 else ''}, {total - len(todo)} already done, {len(todo)} to run"
                + ("; run with a permissive gate so that every candidate's statistics are recorded for calibration: "
                   "what it names on a case (even on a null) is not a verdict" if phase == "calibration" else ""))
            if todo and stop_after is not None and new >= stop_after:
                return SweepOutcome(sorted(done.values(), key=lambda r: r["id"]), thresholds, None, files, False)
            if todo:
                if client is None:
                    client, cluster = _client(scheduler, workers, processes)
                    say(f"dask: {client.scheduler_info().get('address', '?')}, "
                        f"{len(client.scheduler_info().get('workers', {}))} worker(s)")
                counter = {"n": total - len(todo), "run": 0, "t0": time.perf_counter()}

                def on_record(rec, counter=counter, total=total, phase=phase):
                    counter["n"] += 1
                    counter["run"] += 1
                    named = ",".join(rec.get("named") or []) or "-"
                    err = f" error: {rec['error'][:60]}" if rec.get("error") else ""
                    say(f"[{phase} {counter['n']}/{total}] {rec['id']} truth {rec['truth_label']}: named {named} "
                        f"({rec['elapsed_s']:.1f} s{_time_left(counter, total)}){err}")
                left = None if stop_after is None else stop_after - new
                got = run_cases(todo, phase, dcfg, writer, client, keep_dir=keep, stop_after=left, on_record=on_record)
                new += len(got)
                for r in got:
                    done[r["id"]] = r
                if stop_after is not None and new >= stop_after and len(got) < len(todo):
                    return SweepOutcome(sorted(done.values(), key=lambda r: r["id"]), thresholds, None, files, False)
            if phase == "calibration":
                thresholds = _calibrate(out, cfg, [done[c.id] for c in halves["calibration"]],
                                        thresholds_from_records, write_thresholds, warn=warn)
                files["thresholds"] = str(out / "thresholds.yaml")
    except InputError:
        raise
    except BaseException as exc:   # Ctrl-C, a lost scheduler or worker: what is kept and how to go on
        what = "interrupted" if isinstance(exc, KeyboardInterrupt) else f"stopped ({type(exc).__name__}: {exc})"
        try:   # what the file holds (the running half's records are not in `done` yet)
            writer.fh.flush()
            kept = len({r["id"] for r in read_records(out / RECORDS)})
        except Exception:   # pragma: no cover - the count is a courtesy
            kept = len(done)
        warn(f"sweep {what}: the {kept} finished case(s) are kept in {out / RECORDS}; rerun the same command "
             f"to resume from them")
        raise
    finally:
        writer.close()
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    _compact_records(out / RECORDS)   # a case rerun (other settings, a rescore) leaves one record, the last
    evaluated = "heldout" if "heldout" in phases else "calibration"
    recs = [done[c.id] for c in halves[evaluated]]
    summary = summarize(recs, evaluated if split != "pool" else "pool (both halves run as calibration)")
    summary["thresholds_from"] = (
        None if evaluated != "heldout" else str(thresholds_path) if thresholds_path is not None
        else "thresholds.yaml, calibrated in this run on the calibration half" if "calibration" in phases
        else "this folder's thresholds.yaml (calibrated earlier)" if (out / "thresholds.yaml").exists()
        else "bpmid's shipped calibration (bpmid/discover/thresholds.yaml)")
    # 4 significant digits (rounding to 4 decimals wrote a family alpha of 1e-9 as 0)
    summary["thresholds"] = ({k: ({e: float(f"{x:.4g}") for e, x in v.items()} if isinstance(v, Mapping)
                                  else float(f"{float(v):.4g}")) for k, v in thresholds.items()} if thresholds and
                             evaluated == "heldout" else "permissive (calibration half)" if split != "pool"
                             else "permissive (both halves run as calibration)")
    files.update(write_tables(out, summary, recs))
    for phase in phases:
        entries = [{"id": done[c.id]["id"], "split": c.split, "truth": done[c.id]["truth"]} for c in halves[phase]]
        p = write_answers(entries, out / "answers" / f"{phase}.yaml", config=gen, seed=cfg.sweep.seed)
        files[f"answers_{phase}"] = str(p)
    return SweepOutcome(sorted(done.values(), key=lambda r: r["id"]), thresholds, summary, files, True)


def _thresholds_for_heldout(out: Path, given, calibrated, load_thresholds) -> dict:
    if given is not None:
        return given
    if calibrated is not None:
        return calibrated
    if (out / "thresholds.yaml").exists():
        return load_thresholds(out / "thresholds.yaml")
    return load_thresholds()


#: fewer judged calibration cases than this (or no null among them) get a warning: a gate from a handful of
#: cases is set by their ties, not by the rig's noise
MIN_CALIBRATION_CASES = 20


def _calibrate(out: Path, cfg: SweepConfig, recs: list[dict], thresholds_from_records, write_thresholds,
               warn=lambda m: None) -> dict:
    from bpmid.discover.calibrate import case_records, pair_records
    judged = [r for r in recs if not r.get("error")]
    n_err = len(recs) - len(judged)
    if not judged:
        why = next((str(r.get("error")) for r in recs if r.get("error")), "no calibration case was drawn")
        raise InputError(f"no calibration case could be judged ({len(recs)} run, {n_err} declined or failed; the "
                         f"first: {why[:300]}): thresholds calibrated on nothing would mean nothing, so none are "
                         f"written. Make the logs long and fast enough for discovery (rig.sampling_hz, "
                         f"generator.duration_scale), or ask discovery less (calibration.discover: min_fit_samples, "
                         f"min_log_samples), or draw more cases (generator.n_cases); records.jsonl keeps the cases",
                         path=cfg.path, key="generator")
    records = [r for rec in judged for r in case_records(rec)]
    values = thresholds_from_records(records, [q for rec in judged for q in pair_records(rec)])
    kinds = [r.get("kind") for r in judged]
    said = []   # kept in thresholds.yaml too: discover repeats them where the file is used
    if kinds.count("null") == 0 or len(judged) < MIN_CALIBRATION_CASES:
        said.append(f"warning: the thresholds were calibrated on {len(judged)} judged case(s), "
                    f"{kinds.count('null')} of them null: too few to bound the false positives on your rig (at "
                    f"least {MIN_CALIBRATION_CASES}, nulls among them, are needed for a gate to mean much); draw more "
                    f"cases (generator.n_cases, generator.mix)")
    closed = closed_paths(values)
    if closed:
        said.append("warning: this calibration closed paths the shipped gate has open (too few cases of their kind "
                    "to open them on your rig): " + "; ".join(closed) + ". Draw more cases of those kinds "
                    "(generator.n_cases, generator.mix), or keep the shipped thresholds for them")
    for w in said:
        warn(w)
    meta = {"produced_by": f"bpmid calibrate {cfg.path or 'SWEEP.yaml'} (sweep {cfg.sweep.name}, "
                           f"seed {cfg.sweep.seed})",
            "data": f"{len(recs)} out-of-family cases ({GENERATOR}), "
                    + ("both halves run as calibration (pool)" if any(r.get("split") == "heldout" for r in recs)
                       else "calibration half") + f"; {n_err} not judged",
            "generator": cfg.effective_generator.to_yaml(), "warnings": said}
    write_thresholds(values, meta, out / "thresholds.yaml")
    from bpmid.discover.calibrate import gate_values
    return gate_values(values)


#: gate settings whose .inf closes a path, and what the path does
_PATHS = {"pair_share_min": "two effects named at once (pair_share_min: .inf, no pair will be named)",
          "to_floor_drop_min_sigma": "naming on the path to the noise floor (to_floor_drop_min_sigma: .inf)"}


def closed_paths(values: dict) -> list[str]:
    """What a calibration closed (a threshold at .inf) that the shipped thresholds keep open, in words."""
    import math

    from bpmid.discover.calibrate import load_thresholds

    shipped = load_thresholds()   # the shipped ones
    out = []
    for key, words in _PATHS.items():
        v, s = values.get(key), (shipped or {}).get(key)
        if isinstance(v, (int, float)) and math.isinf(v) and isinstance(s, (int, float)) and math.isfinite(s):
            out.append(words)
    return out


# ---------------------------------------------------------------------------------------------
# scoring
# ---------------------------------------------------------------------------------------------
ROWS = tuple(CATALOGUE_IDS) + ("none", "pair", "out_of_catalogue")
COLUMNS = tuple(CATALOGUE_IDS) + ("none",)


def gap_halved(rec: dict) -> Optional[bool]:
    """Held-out gap (RMSE minus noise floor) at least halved by the named effects; None when nothing was named."""
    if not rec.get("named") or rec.get("heldout_before_deg") is None:
        return None
    floor = rec["noise_floor_deg"]
    before, after = rec["heldout_before_deg"] - floor, rec["heldout_after_deg"] - floor
    return bool(after <= 0.5 * before) if before > 0 else bool(after <= before)


#: bands of the size a user sees: the fitted base model's held-out RMSE over the true sensor noise (the generator
#: sizes each effect on the *true* base model; a refit absorbs part of it, so a case drawn at 1.5 can show 1.05)
SIZE_BANDS = ((0.0, 1.2, "below 1.2"), (1.2, 1.5, "1.2 to 1.5"), (1.5, float("inf"), "1.5 or more"))


def case_right(rec: dict) -> Optional[bool]:
    """The case's outcome as the targets count it: a single named first right, both of a pair named, nothing named
    on a null or out-of-catalogue case (None: not judged)."""
    if rec.get("error"):
        return None
    named = rec.get("named") or []
    if rec["kind"] == "single":
        return bool(named) and named[0] == rec["truth_label"]
    if rec["kind"] == "pair":
        return set(rec["truth_ids"]) <= set(named)
    return not named


def visible_size(rec: dict) -> Optional[float]:
    """The fitted base model's held-out RMSE over the case's true sensor noise (None: not judged or no truth)."""
    b, n = rec.get("heldout_before_deg"), rec.get("noise_deg")
    return None if rec.get("error") or b is None or not n else float(b) / float(n)


def by_visible_size(recs: Sequence[dict]) -> dict:
    """Right outcomes per case kind and band of :func:`visible_size`: where the misses sit. The issue asks for sizes
    from just detectable (a held-out RMSE about 1.5 times the noise) up; the generator's size is the true base
    model's, so some cases show less than that to the fitted one."""
    out = {}
    for kind in ("single", "null", "pair", "out_of_catalogue"):
        row = {}
        for lo, hi, name in SIZE_BANDS:
            these = [r for r in recs if r["kind"] == kind and (v := visible_size(r)) is not None and lo <= v < hi]
            right = sum(1 for r in these if case_right(r))
            row[name] = {"n": len(these), "right": right, "rate": round(right / len(these), 4) if these else None}
        out[kind] = row
    return out


def summarize(recs: Sequence[dict], split: str) -> dict:
    """Confusion matrix and rates of one half's records. The matrix and every rate count the judged cases only: a
    case discovery declined (too short a log) or failed on names nothing without having judged anything, so it is
    counted apart (``not_judged``, ``internal_failures``), never as a null rightly left unnamed."""
    all_recs = list(recs)
    recs = [r for r in all_recs if not r.get("error")]
    M = {r: {c: 0 for c in COLUMNS} for r in ROWS}
    for rec in recs:
        first = rec["named"][0] if rec.get("named") else "none"
        M[rec["truth_label"]][first if first in COLUMNS else "none"] += 1
    single = [r for r in recs if r["kind"] == "single"]
    null = [r for r in recs if r["kind"] == "null"]
    pair = [r for r in recs if r["kind"] == "pair"]
    oof = [r for r in recs if r["kind"] == "out_of_catalogue"]
    named_any = [r for r in recs if r.get("named")]
    halved = [gap_halved(r) for r in named_any]

    def rate(num, den):
        return None if den == 0 else round(num / den, 4)

    single_right = sum(1 for r in single if case_right(r))
    pair_both = sum(1 for r in pair if case_right(r))

    return {
        "split": split, "n_cases": len(all_recs), "judged": len(recs),
        "not_judged": sum(1 for r in all_recs if r.get("error") and r.get("error_kind") != "internal"),
        "internal_failures": sum(1 for r in all_recs if r.get("error_kind") == "internal"),
        "single_named_first_right": {"n": len(single), "right": single_right, "rate": rate(single_right, len(single))},
        "null_false_positive": {"n": len(null), "named_something": sum(1 for r in null if r.get("named")),
                                "rate": rate(sum(1 for r in null if r.get("named")), len(null))},
        "pair_both_named": {"n": len(pair), "both": pair_both, "rate": rate(pair_both, len(pair)),
                            "at_least_one_rate": rate(sum(1 for r in pair if set(r["truth_ids"]) &
                                                          set(r.get("named") or [])), len(pair))},
        "out_of_catalogue_nothing_named": {"n": len(oof), "nothing": sum(1 for r in oof if not r.get("named")),
                                           "rate": rate(sum(1 for r in oof if not r.get("named")), len(oof)),
                                           "unexplained_rate": rate(sum(1 for r in oof if r.get("unexplained")),
                                                                    len(oof))},
        "gap_halved_where_named": {"n": len(named_any), "halved": sum(1 for h in halved if h),
                                   "rate": rate(sum(1 for h in halved if h), len(named_any))},
        "by_visible_size": by_visible_size(all_recs),
        "confusion": M,
    }


def confusion_markdown(summary: dict) -> str:
    M = summary["confusion"]
    short = {"second_relaxation": "2nd relax", "braid_friction": "friction", "pressure_lag": "lag",
             "asymmetric_relaxation": "asym relax", "strain_stiffening": "stiffening", "angle_offset": "offset",
             "thermal_softening": "thermal", "none": "none"}
    judged = summary.get("judged", summary["n_cases"])
    which = summary["split"] if str(summary["split"]).startswith("pool") else f"{summary['split']} half"
    lines = [f"Confusion matrix, {which} ({summary['n_cases']} cases"
             + (f", {judged} judged" if judged != summary["n_cases"] else "")
             + "; rows: hidden truth, columns: effect named first)", "",
             "| hidden \\ named | " + " | ".join(short[c] for c in COLUMNS) + " |",
             "|---" * (len(COLUMNS) + 1) + "|"]
    for r in ROWS:
        if sum(M[r].values()) or r in CATALOGUE_IDS:
            lines.append(f"| {r} | " + " | ".join(str(M[r][c]) for c in COLUMNS) + " |")
    s = summary

    def pct(x):
        # one decimal unless whole: a rate rounded to a whole per cent can read as meeting a target it misses
        # (53/59 is 89.8 %, not 90 %)
        if x is None:
            return "n/a"
        v = 100 * x
        return f"{v:.0f} %" if abs(v - round(v)) < 1e-9 else f"{v:.1f} %"
    lines += ["", "| measure | value |", "|---|---|",
              f"| single effect named first right | {s['single_named_first_right']['right']}/"
              f"{s['single_named_first_right']['n']} ({pct(s['single_named_first_right']['rate'])}) |",
              f"| false positives on nulls | {s['null_false_positive']['named_something']}/"
              f"{s['null_false_positive']['n']} ({pct(s['null_false_positive']['rate'])}) |",
              f"| pairs: both effects named | {s['pair_both_named']['both']}/{s['pair_both_named']['n']} "
              f"({pct(s['pair_both_named']['rate'])}) |",
              f"| out of catalogue: nothing named | {s['out_of_catalogue_nothing_named']['nothing']}/"
              f"{s['out_of_catalogue_nothing_named']['n']} ({pct(s['out_of_catalogue_nothing_named']['rate'])}) |",
              f"| gap at least halved where an effect was named | {s['gap_halved_where_named']['halved']}/"
              f"{s['gap_halved_where_named']['n']} ({pct(s['gap_halved_where_named']['rate'])}) |",
              f"| cases discovery declined to judge (left out of the rates above) | {s['not_judged']} |",
              f"| internal failures (see records.jsonl; left out of the rates above) | "
              f"{s.get('internal_failures', 0)} |"]
    if s.get("by_visible_size"):
        kinds = {"single": "single effect named first right", "null": "null: nothing named",
                 "pair": "pair: both named", "out_of_catalogue": "out of catalogue: nothing named"}
        lines += ["", "By the size a user sees: the fitted base model's held-out RMSE over the true sensor noise "
                  "(effects are sized on the true base model; a refit absorbs part of them)", "",
                  "| case kind | " + " | ".join(name for _, _, name in SIZE_BANDS) + " |",
                  "|---" * (len(SIZE_BANDS) + 1) + "|"]
        for kind, label in kinds.items():
            row = s["by_visible_size"].get(kind) or {}
            cells = [(f"{c['right']}/{c['n']} ({pct(c['rate'])})" if c.get("n") else "-")
                     for c in (row.get(name) or {} for _, _, name in SIZE_BANDS)]
            lines.append(f"| {label} | " + " | ".join(cells) + " |")
    if s.get("thresholds") is not None:
        thr = s["thresholds"]
        lines += ["", "Thresholds: " + (", ".join(f"{k} = {v:g}" if not isinstance(v, dict) else
                                                  f"{k} = {{" + ", ".join(f"{e}: {x:g}" for e, x in v.items()) + "}"
                                                  for k, v in thr.items()) if isinstance(thr, dict) else str(thr))
                  + (f" (from {s['thresholds_from']})" if s.get("thresholds_from") else "")]
    return "\n".join(lines) + "\n"


def write_tables(out: Path, summary: dict, recs: Sequence[dict]) -> dict:
    from bpmid.io.atomic import write_text
    M = summary["confusion"]
    csv = ["hidden_truth," + ",".join(f"named_first_{c}" for c in COLUMNS)]
    csv += [f"{r}," + ",".join(str(M[r][c]) for c in COLUMNS) for r in ROWS]
    write_text(out / "confusion.csv", "\n".join(csv) + "\n")
    write_text(out / "confusion.md", confusion_markdown(summary))
    body = {"schema": "bpmid.sweep-summary/1", "synthetic": True, "generator": GENERATOR,
            **{k: v for k, v in summary.items() if k != "confusion"},
            "confusion": {r: dict(v) for r, v in M.items()},
            "per_case": [{"id": r["id"], "truth": r["truth_label"], "truth_ids": r["truth_ids"],
                          "named": r.get("named") or [], "unexplained": r.get("unexplained"),
                          "gap_halved": gap_halved(r), "error": r.get("error")} for r in recs]}
    write_text(out / "summary.yaml", yamlsafe.dump(_fix_nan(body), sort_keys=False))
    return {"confusion_csv": str(out / "confusion.csv"), "confusion_md": str(out / "confusion.md"),
            "summary": str(out / "summary.yaml")}


def comparable(recs: Sequence[dict]) -> list[dict]:
    """Records sorted by id without the timing fields (two runs of the same sweep compare equal)."""
    return [{k: v for k, v in r.items() if k not in TIMING_FIELDS} for r in sorted(recs, key=lambda r: r["id"])]
