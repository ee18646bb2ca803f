"""The report's inputs, read once into typed records by one loader per stage file.

Every loader returns a record or None, and never raises for a file that is absent, partial (a YAML holding
only its schema line, a CSV with a header and no rows) or unreadable: it records a :class:`Problem` instead,
so the report can say which file is at fault and build every section it can. A stage whose files are on disk
but which ``run.yaml`` (the record of the last ``bpmid run``) does not list as done is marked stale, and so is a
stage run.yaml lists as done whose files another command wrote afterwards (their provenance does not carry the
run's id: :func:`not_from_run`).
"""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import pandas as pd

from bpmid.errors import InputError


@dataclasses.dataclass(frozen=True)
class Problem:
    path: str  # relative to DIR
    what: str
    line: int | None = None

    def where(self, root: Path) -> str:
        return f"{root / self.path}" + (f":{self.line}" if self.line else "")


@dataclasses.dataclass(frozen=True)
class Param:
    """One fitted constant as the report shows it."""

    name: str
    value: float | None
    stderr: float | None = None
    unit: str = ""
    verdict: str = ""  # identifiability of a motion fit


def _num(v) -> float | None:
    try:
        return None if v is None else float(v)
    except (TypeError, ValueError):
        return None


def _param(name: str, entry: Any, default_unit: str = "") -> Param:
    if isinstance(entry, dict):
        return Param(name, _num(entry.get("value")), _num(entry.get("stderr")), str(entry.get("unit") or default_unit))
    return Param(name, _num(entry), None, default_unit)


def _dict(d: Any) -> dict:
    return d if isinstance(d, dict) else {}


def _list(d: Any) -> list:
    return d if isinstance(d, list) else []


class _Reader:
    """Reads files of DIR, collecting problems (partial, unreadable) instead of raising."""

    def __init__(self, root: Path):
        self.root = root
        self.problems: list[Problem] = []
        self.found: set[str] = set()
        self.provenance: dict[str, Any] = {}  # relative path -> the provenance block of each YAML read

    def rel(self, path: Path) -> str:
        try:
            return path.relative_to(self.root).as_posix()
        except ValueError:
            return str(path)

    def yaml(self, path: Path, required: tuple[str, ...] = ()) -> dict | None:
        from bpmid.config import read_yaml

        if not path.is_file():
            return None
        self.found.add(self.rel(path))
        try:
            data, _sha = read_yaml(path)
        except InputError as exc:
            self.problems.append(Problem(self.rel(path), f"unreadable ({exc.message})", exc.line))
            return None
        if not isinstance(data, dict):
            self.problems.append(Problem(self.rel(path), "not a YAML mapping"))
            return None
        self.provenance[self.rel(path)] = data.get("provenance")
        schema = str(data.get("schema", ""))
        kind, sep, version = schema.rpartition("/")
        if sep and kind.startswith("bpmid.") and version != "1":   # every schema this bpmid writes is /1
            self.problems.append(Problem(self.rel(path), f"written by another version of bpmid (schema {schema}; "
                                         f"this one reads {kind}/1): read as far as its keys go, check its numbers"))
        missing = [k for k in required if data.get(k) is None]
        if missing:
            self.problems.append(Problem(self.rel(path), "partial: no " + ", ".join(missing)
                                         + " (the stage did not finish writing it or the file was cut)"))
            return None
        return data

    def csv(self, path: Path, required: tuple[str, ...] = ()) -> pd.DataFrame | None:
        if not path.is_file():
            return None
        self.found.add(self.rel(path))
        try:
            df = pd.read_csv(path, comment="#")   # a prediction of a synthetic log says so on a '#' line
        except (pd.errors.EmptyDataError, pd.errors.ParserError, UnicodeDecodeError, OSError) as exc:
            self.problems.append(Problem(self.rel(path), f"unreadable ({type(exc).__name__}: {exc})".strip()))
            return None
        missing = [c for c in required if c not in df.columns]
        if missing:
            self.problems.append(Problem(self.rel(path), "partial: no column " + ", ".join(missing)))
            return None
        if df.empty:
            self.problems.append(Problem(self.rel(path), "partial: a header and no rows"))
            return None
        return df


# --------------------------------------------------------------------------------------------------
# stage records
# --------------------------------------------------------------------------------------------------
@dataclasses.dataclass
class StageRecord:
    name: str
    status: str
    seconds: float | None
    outputs: list[str]
    note: str = ""


@dataclasses.dataclass
class RunInfo:
    stages: list[StageRecord]
    synthetic: bool | None
    provenance: dict
    test_sets: dict
    #: run.yaml's data_logs: {total, synthetic, synthetic_files (when some, not all, are)}; {} from older runs
    data_logs: dict = dataclasses.field(default_factory=dict)
    #: run.yaml's synthetic_stamp: the figures' stamp in the logs' own words (None: measured, or an older run)
    stamp: str | None = None

    def status(self, stage: str) -> str | None:
        for s in self.stages:
            if s.name == stage:
                return s.status
        return None


@dataclasses.dataclass
class RelaxInfo:
    mode: str
    constants: list[Param]  # E_inf, E_j, tau_j
    derived: list[Param]  # G, K
    poisson: float | None
    rmse_pa: float | None
    r2: float | None
    mape_pct: float | None
    corr_names: list[str]
    corr: list[list[float]]
    logs: list[str]
    raw: dict  # the file, for figures
    provenance: dict

    @property
    def n_terms(self) -> int:
        return sum(1 for p in self.constants if p.name.startswith("tau_"))


@dataclasses.dataclass(frozen=True)
class EffectInfo:
    """One effect of a fit file's ``effects`` list: its id, settings and constants."""

    id: str
    settings: dict
    params: list[Param]


@dataclasses.dataclass
class MotionInfo:
    fit: list[Param]
    mat: list[Param]
    rmse_deg: float | None
    mape_pct: float | None
    r2: float | None
    closure: str | None  # None: the file does not say
    history: str | None
    logs: list[str]
    provenance: dict
    corr_names: list[str] = dataclasses.field(default_factory=list)
    corr: list[list[float]] = dataclasses.field(default_factory=list)
    #: the file the VBMM-fit was read from (relative to DIR), or None (only vbmm_mat.yaml)
    fit_file: str | None = "vbmm_fit.yaml"
    #: the muscle geometry of the fit file (SI: th, R0, l0 in m, alpha0 in rad, n), {} when absent
    geometry: dict = dataclasses.field(default_factory=dict)
    #: what made the fit (``fit.by``: "bpmid discover" for discovery's model.yaml), None when the file does not say
    by: str | None = None
    #: where its starting (prior) constants came from (``fit.initial``), None when the file does not say
    initial: str | None = None
    #: the catalogue effects the fit file runs with its constants (its ``effects`` list): its metrics include them
    effects: list[EffectInfo] = dataclasses.field(default_factory=list)

    @property
    def effect_ids(self) -> list[str]:
        return [e.id for e in self.effects]


@dataclasses.dataclass
class CompareInfo:
    dir: Path
    summary: pd.DataFrame
    by_set: pd.DataFrame | None
    train: list[str]
    test_sets: dict[str, list[str]]
    warnings: list[str]
    synthetic: bool | None
    predictions: dict[str, list[pd.DataFrame]]
    provenance: dict

    @property
    def ranking(self) -> pd.DataFrame:
        return self.summary.sort_values("rmse_deg", kind="mergesort")


@dataclasses.dataclass
class HistoryInfo:
    raw: dict
    table: pd.DataFrame | None
    log: str
    window_s: float | None
    accuracy: dict[str, dict]
    us_per_step: dict[str, float]
    window_vs_full: dict
    reduction_pct: float | None
    provenance: dict


@dataclasses.dataclass
class DiscoveryInfo:
    dir: Path
    named: list[str]
    before_deg: float | None
    after_deg: float | None
    floor_deg: float | None
    unexplained: bool
    verdict: str
    steps: list[dict]
    provenance: dict
    #: a round withheld its effect for a rival outside the catalogue (discovery.yaml rounds[].rival_outside_catalogue)
    withheld: bool = False
    #: the held-out RMSE without the per-log factors the scored one fits on each held-out log (deg)
    raw_before_deg: float | None = None
    raw_after_deg: float | None = None
    scoring: str = ""
    #: where the starting VBMM came from (discovery.yaml base_from), None when the file does not say
    base_from: str | None = None
    #: what a careful user should know before trusting the verdict (discovery.yaml cautions)
    cautions: list = dataclasses.field(default_factory=list)


def fmt_value(v) -> str:
    """A parameter as control.yaml holds it ({value, unit} or a number), in words."""
    if isinstance(v, dict):
        val, unit = v.get("value"), v.get("unit")
        return f"{val:.4g} {unit}".strip() if isinstance(val, (int, float)) else str(val)
    return f"{v:.4g}" if isinstance(v, (int, float)) else str(v)


@dataclasses.dataclass
class ControlInfo:
    dir: Path
    table: pd.DataFrame  # summary.csv
    gains: dict
    rate_hz: float | None
    cost: dict
    warnings: list[str]
    provenance: dict
    plant: dict = dataclasses.field(default_factory=dict)              # control.yaml's plant block
    controller_model: dict = dataclasses.field(default_factory=dict)   # ... and the controller's model
    references: list = dataclasses.field(default_factory=list)         # ... and its references block

    @property
    def references_shipped(self) -> bool:
        """Every reference is built in or one of bpmid's shipped files (datasets/control)."""
        def shipped(r) -> bool:
            src = str((r or {}).get("source", ""))
            return src == "built in" or "/datasets/control/" in src.replace("\\", "/")
        return bool(self.references) and all(shipped(r) for r in self.references)

    def troubled_runs(self) -> str:
        """'5 of 15 runs unstable, 15 oscillating' (summary.csv's status column; '' when every run tracks, or
        only touches a pressure limit, which the paper's loop did too)."""
        if "status" not in self.table:
            return ""
        runs = self.table[self.table["reference"] != "ALL"] if "reference" in self.table else self.table
        status = [str(x) for x in runs["status"]]
        n = len(status)
        parts = [f"{c} of {n} runs {word}" for word in ("unstable", "oscillating")
                 for c in [sum(word in x for x in status)] if c]
        return ", ".join(parts)

    def paper_gains(self) -> bool:
        """The loop ran with the paper's gains (P 0.04 bar/deg, I 0.01 bar/deg/s)."""
        def val(k):
            v = (self.gains or {}).get(k)
            return v.get("value") if isinstance(v, dict) else v
        return val("kp") == 0.04 and val("ki") == 0.01

    def plant_words(self) -> str:
        """The plant's departures from the controller's model, in words ('' when none is recorded)."""
        pl = self.plant or {}
        out = []
        for key, what in (("modulus_scale", "moduli"), ("tau_scale", "time constants")):
            v = pl.get(key)
            if isinstance(v, (int, float)) and v != 1.0:
                out.append(f"{what} x {v:g}")
        for e in pl.get("effects") or []:
            if isinstance(e, dict):
                prm = ", ".join(f"{k} = {fmt_value(v)}" for k, v in (e.get("parameters") or {}).items())
                out.append(f"{e.get('id', '?')}" + (f" ({prm})" if prm else ""))
        if pl.get("pressure_dynamics"):
            out.append("valve and line dynamics")
        return "; ".join(out)

    @property
    def plant_is_the_model(self) -> bool:
        """The plant is the controller's own model, without effects, valve dynamics or a scaled material: the
        feedforward inverts the plant exactly (an ideal case)."""
        pl = self.plant
        if not pl or pl.get("effects") or pl.get("pressure_dynamics"):
            return False
        # the whole model: constants, geometry, closure and history alike
        return bool(pl.get("model")) and pl.get("model") == (self.controller_model or {})

    def pooled(self, controller: str):
        g = self.table[(self.table.controller == controller) & (self.table.reference == "ALL")]
        return None if g.empty else g.iloc[0]


@dataclasses.dataclass
class Study:
    root: Path
    run: RunInfo | None = None
    relax: RelaxInfo | None = None
    motion: MotionInfo | None = None
    compare: CompareInfo | None = None
    history: HistoryInfo | None = None
    discovery: DiscoveryInfo | None = None
    control: ControlInfo | None = None
    problems: list[Problem] = dataclasses.field(default_factory=list)
    stale: dict[str, str] = dataclasses.field(default_factory=dict)  # stage -> why
    #: the stages of :attr:`stale` whose files run.yaml lists as done but another command wrote (not the run)
    foreign: set[str] = dataclasses.field(default_factory=set)
    #: files of stages run.yaml lists as done that are not in the folder (deleted or moved since)
    missing: list[str] = dataclasses.field(default_factory=list)

    @property
    def synthetic(self) -> bool:
        if self.run is not None and self.run.synthetic is not None:
            return self.run.synthetic
        if self.compare is not None and self.compare.synthetic is not None:
            return self.compare.synthetic
        return True

    def any(self) -> bool:
        return any(x is not None for x in (self.run, self.relax, self.motion, self.compare, self.history,
                                           self.discovery, self.control))

    def provenance(self) -> dict:
        if self.run is not None and self.run.provenance:
            return self.run.provenance
        for x in (self.compare, self.motion, self.relax, self.history, self.discovery, self.control):
            if x is not None and x.provenance:
                return x.provenance
        return {}

    def inputs(self) -> dict[str, str]:
        out: dict[str, str] = {}
        for x in (self.run, self.relax, self.motion, self.compare, self.history, self.discovery, self.control):
            if x is not None:
                out.update(_dict(_dict(x.provenance).get("inputs")))
        return out

    def made_by_twin(self) -> bool:
        """True when the study's logs are synthetic and all the twin's (:attr:`stamp`)."""
        from bpmid.io.motion_logs import TWIN_NOTE

        return self.stamp == TWIN_NOTE

    @property
    def stamp(self):
        """What figures drawn from this study's logs are stamped with: run.yaml's record; else, for a synthetic
        study, the twin's words when every input file that says it is synthetic is the twin's
        (:func:`bpmid.io.motion_logs.file_is_twin`; a file that cannot be found is not claimed for the twin)."""
        from bpmid.io.motion_logs import TWIN_NOTE, file_is_synthetic, file_is_twin

        if self.run is not None and self.run.stamp is not None:
            return self.run.stamp
        if not self.synthetic:
            return None
        for f in self.data_log_files():
            if not f.is_file() or (file_is_synthetic(f) and not file_is_twin(f)):
                return "synthetic data (the logs' own headers say so)"
        return TWIN_NOTE

    def data_log_files(self) -> list[Path]:
        """The study's input files that are data logs (text tables), each resolved as recorded: as given, else
        relative to the run config's folder (where a run records them); a file not found stays as given."""
        cfg = _dict(_dict(self.run.provenance if self.run else {}).get("config")).get("path")
        out = []
        for path in self.inputs():
            f = Path(path)
            if f.suffix.lower() not in (".csv", ".txt", ".tsv", ".dat"):
                continue
            if not f.is_absolute() and not f.is_file() and cfg and (Path(cfg).parent / f).is_file():
                f = Path(cfg).parent / f   # recorded relative to the config's folder
            out.append(f)
        return out

    def protocols(self) -> tuple[list[str], list[str], int]:
        """The protocols this study's data logs follow, as the ``manifest.yaml`` beside each log records them
        (``bpmid simulate`` writes it): (the paper's: names of bpmid's shipped protocol files, matched by their
        sha256; others: names of any other protocol; the number of logs whose protocol no file states: measured
        logs, a log not found from here, a log without a manifest)."""
        import hashlib

        from bpmid import data
        from bpmid.config import read_yaml

        shipped = {}
        for f in sorted((data.root() / "configs" / "datasets").glob("*.yaml")):
            try:
                shipped[hashlib.sha256(f.read_bytes()).hexdigest()] = f.stem
            except OSError:
                continue
        paper: set[str] = set()
        other: set[str] = set()
        unknown = 0
        manifests: dict[Path, dict | None] = {}
        for f in self.data_log_files():
            man = f.parent / "manifest.yaml"
            if man not in manifests:
                try:
                    manifests[man] = read_yaml(man)[0] if f.is_file() and man.is_file() else None
                except (InputError, OSError):
                    manifests[man] = None
            m = _dict(manifests[man])
            listed = {str(_dict(lg).get("file")) for lg in _list(m.get("logs"))}
            proto = _dict(m.get("protocol"))
            if not proto or f.name not in listed:   # a manifest that does not list this log says nothing of it
                unknown += 1
            elif shipped.get(str(proto.get("sha256"))) is not None:
                paper.add(shipped[str(proto["sha256"])])
            else:
                other.add(str(proto.get("name") or "unnamed"))
        return sorted(paper), sorted(other), unknown

    def data_origins(self) -> list[str]:
        """What made the synthetic data logs, read from their own header lines: one entry per protocol with its
        seeds (``protocol fitting_set, seeds 1001-1004 (4 logs)``); logs that say nothing are not listed."""
        import re

        from bpmid.io.motion_logs import file_is_twin, header_lines

        groups: dict[str, set[int]] = {}
        counts: dict[str, int] = {}
        for path in self.inputs():
            f = Path(path)
            if f.suffix.lower() not in (".csv", ".txt", ".tsv", ".dat") or not f.is_file():
                continue
            lines = header_lines(f)
            if lines is None:
                continue
            head = " ".join(lines)
            proto = re.search(r"protocol[:\s]+([A-Za-z0-9_.\-]+)", head)
            if proto is None or "synthetic" not in head.lower() and "generator" not in head.lower():
                continue
            if not file_is_twin(f):   # another generator's protocol line is not bpmid simulate's
                continue
            name = proto.group(1).rstrip(").,;")
            groups.setdefault(name, set()).update(int(x) for x in re.findall(r"seed[:\s]+(\d+)", head))
            counts[name] = counts.get(name, 0) + 1
        out = []
        for name in sorted(groups):
            seeds = sorted(groups[name])
            if not seeds:
                txt = "no seed stated"
            elif len(seeds) == 1:
                txt = f"seed {seeds[0]}"
            elif seeds == list(range(seeds[0], seeds[-1] + 1)):
                txt = f"seeds {seeds[0]}-{seeds[-1]}"
            else:
                txt = "seeds " + ", ".join(map(str, seeds[:6])) + (" ..." if len(seeds) > 6 else "")
            out.append(f"protocol {name}, {txt} ({counts[name]} log{'s' if counts[name] > 1 else ''})")
        return out


# --------------------------------------------------------------------------------------------------
# loaders
# --------------------------------------------------------------------------------------------------
def load_run(rd: _Reader) -> RunInfo | None:
    d = rd.yaml(rd.root / "run.yaml", required=("stages",))
    if d is None:
        return None
    stages = []
    for s in _list(d.get("stages")):
        s = _dict(s)
        stages.append(StageRecord(str(s.get("name", "?")), str(s.get("status", "?")), _num(s.get("seconds")),
                                  [str(o) for o in _list(s.get("outputs"))], str(s.get("note") or "")))
    syn = d.get("synthetic")
    stamp = d.get("synthetic_stamp")
    return RunInfo(stages, None if syn is None else bool(syn), _dict(d.get("provenance")), _dict(d.get("test_sets")),
                   _dict(d.get("data_logs")), str(stamp) if isinstance(stamp, str) else None)


def load_relax(rd: _Reader) -> RelaxInfo | None:
    d = rd.yaml(rd.root / "relax_fit.yaml", required=("prony",))
    if d is None:
        return None
    pr = _dict(d.get("prony"))
    if "E_inf" not in pr:
        rd.problems.append(Problem("relax_fit.yaml", "partial: prony has no E_inf"))
        return None
    cons = [_param("E_inf", pr["E_inf"], "Pa")]
    for j, tr in enumerate(_list(pr.get("terms")), 1):
        tr = _dict(tr)
        cons += [_param(f"E_{j}", tr.get("E"), "Pa"), _param(f"tau_{j}", tr.get("tau"), "s")]
    derived = []
    for block, name in (("shear", "G"), ("bulk", "K")):
        b = _dict(d.get(block))
        if f"{name}_inf" in b:
            derived.append(_param(f"{name}_inf", b[f"{name}_inf"], "Pa"))
            for j, tr in enumerate(_list(b.get("terms")), 1):
                derived.append(_param(f"{name}_{j}", _dict(tr).get(name), "Pa"))
    m = _dict(d.get("metrics"))
    unc = _dict(d.get("uncertainty"))
    logs = [str(_dict(lg).get("name")) for lg in _list(_dict(d.get("data")).get("logs"))]
    names, corr = _corr(unc)
    return RelaxInfo(str(d.get("mode", "?")), cons, derived, _num(d.get("poisson_ratio")), _num(m.get("rmse")),
                     _num(m.get("r2")), _num(m.get("mape_pct")), names, corr, logs, d, _dict(d.get("provenance")))


def _material(d: dict) -> list[Param]:
    from bpmid.identifiability import conditional_caveat

    mat = _dict(d.get("material"))
    ident = _dict(_dict(d.get("uncertainty")).get("identifiability"))
    out = []

    def verdict(name, entry):
        e = _dict(entry)
        caveat = conditional_caveat(str(e.get("note") or ""))   # the caveat the fit file gives an estimate
        cond = f"; {caveat}" if caveat else ""
        note = str(e.get("note") or "").strip()
        if name in ident:
            return str(ident[name]) + cond
        if e.get("identifiable") is False:
            return "not identifiable, held at prior"
        if e.get("identifiable"):
            # an estimate the file notes more of (discovery's refit: "not identifiable: ... (estimated, not held)")
            said = f"; the file notes: {note}" if note.startswith("not identifiable") else ""
            return "estimated" + cond + said
        if e.get("fixed") and note:   # held for another reason the file gives (discovery: "held at the starting
            return note               # model's value ...")
        return ""

    for k in ("G_inf", "K_inf"):
        if k in mat:
            p = _param(k, mat[k], "Pa")
            out.append(dataclasses.replace(p, verdict=verdict(k, mat[k])))
    for j, b in enumerate(_list(mat.get("branches")), 1):
        for k, v in _dict(b).items():
            p = _param(f"{k}_{j}", v, "s" if k == "tau" else "Pa")
            out.append(dataclasses.replace(p, verdict=verdict(f"{k}_{j}", v)))
    return out


#: YAML files of DIR that are never a motion fit under another name
_NOT_A_MOTION_FIT = {"run.yaml", "relax_fit.yaml", "vbmm_fit.yaml", "vbmm_mat.yaml", "history_modes.yaml"}
#: larger YAML files are not looked into for a motion fit under another name (a fit is a few kB)
_MAX_FIT_BYTES = 1 << 20


def other_motion_fits(root: Path) -> list[str]:
    """The YAML files at the top of ``root``, other than the run's own names, that are motion fits (schema
    ``bpmid.vbmm/1`` with ``material`` and a ``fit`` block, as ``bpmid fit motion --out VBMM.yaml`` writes).
    The report reads the fit from one such file when the folder has no vbmm_fit.yaml (with more than one, which
    is meant is not known)."""
    from bpmid.config import read_yaml

    found = []
    for p in sorted(root.glob("*.yaml")):
        if p.name in _NOT_A_MOTION_FIT or not p.is_file():
            continue
        try:
            if p.stat().st_size > _MAX_FIT_BYTES:
                continue
            data, _sha = read_yaml(p)
        except (InputError, OSError):
            continue
        if (isinstance(data, dict) and data.get("schema") == "bpmid.vbmm/1" and isinstance(data.get("fit"), dict)
                and isinstance(data.get("material"), dict)):
            found.append(p.name)
    return found


def _text(v: Any) -> str | None:
    return v if isinstance(v, str) and v.strip() else None


def load_motion(rd: _Reader) -> MotionInfo | None:
    fit_file: str | None = "vbmm_fit.yaml"
    if not (rd.root / fit_file).is_file():  # a fit written by `bpmid fit motion --out VBMM.yaml`, say
        others = other_motion_fits(rd.root)
        fit_file = others[0] if len(others) == 1 else None
    fit = rd.yaml(rd.root / fit_file, required=("material",)) if fit_file else None
    mat = rd.yaml(rd.root / "vbmm_mat.yaml", required=("material",))
    if fit is None and mat is None:
        return None
    m = _dict((fit or {}).get("metrics"))
    per_log = list(_dict(m.get("per_log")))
    unc = _dict((fit or {}).get("uncertainty"))
    names, corr = _corr(unc)
    how = _dict((fit or {}).get("fit"))
    # the fitting logs as the fit records them (fit.logs; discover's model.yaml has no per-log metrics)
    logs = [str(_dict(lg).get("name")) for lg in _list(how.get("logs")) if _dict(lg).get("name") is not None]
    return MotionInfo(_material(fit) if fit else [], _material(mat) if mat else [], _num(m.get("rmse_deg")),
                      _num(m.get("mape_pct")), _num(m.get("r2")), _text((fit or mat).get("closure")),
                      _text(_dict((fit or mat).get("model")).get("history")), logs or per_log,
                      _dict((fit or mat).get("provenance")), names, corr, fit_file if fit is not None else None,
                      _dict((fit or mat).get("geometry")), _text(how.get("by")), _text(how.get("initial")),
                      _effects(fit) if fit else [])


def _effects(d: dict) -> list[EffectInfo]:
    """The ``effects`` list of a fit file as the report shows it (entries that are not mappings are left out)."""
    out = []
    for e in _list(d.get("effects")):
        e = _dict(e)
        eid = _text(e.get("id"))
        if eid is None:
            continue
        prm = []
        for name, entry in _dict(e.get("parameters")).items():
            p = _param(f"{eid}.{name}", entry)
            ent = _dict(entry)
            note = str(ent.get("note") or "").strip()
            verdict = ((note if note.startswith("not identifiable") else "not identifiable, held")
                       if ent.get("identifiable") is False else
                       (note or "held") if ent.get("fixed") else "estimated" if ent.get("identifiable") else "")
            prm.append(dataclasses.replace(p, verdict=verdict))
        out.append(EffectInfo(eid, _dict(e.get("settings")), prm))
    return out


def _corr(unc: dict) -> tuple[list[str], list[list[float]]]:
    """Parameter names and correlation matrix of an ``uncertainty`` block (empty when absent or malformed)."""
    names = [str(x) for x in _list(unc.get("parameters"))]
    try:
        corr = [[float(v) for v in _list(row)] for row in _list(unc.get("correlation"))]
    except (TypeError, ValueError):
        return [], []
    if len(corr) != len(names) or any(len(r) != len(names) for r in corr):
        return [], []
    return names, corr


def load_compare(rd: _Reader) -> CompareInfo | None:
    cdir = rd.root / "compare" if (rd.root / "compare").is_dir() else rd.root
    if cdir == rd.root and (rd.root / "control.yaml").is_file() and not (rd.root / "compare.yaml").is_file():
        return None   # bpmid control's folder: its summary.csv is the controllers', not a comparison
    summary = rd.csv(cdir / "summary.csv", required=("model", "rmse_deg"))
    cy = rd.yaml(cdir / "compare.yaml") or {}
    if summary is None:
        return None
    listed = [str(m) for m in _dict(cy.get("models"))]
    ranked = {str(m) for m in summary["model"]}
    lost = [m for m in listed if m not in ranked]
    if lost:   # a cut summary ranked fewer models than were compared, silently
        rd.problems.append(Problem(rd.rel(cdir / "summary.csv"), f"partial: ranks {len(ranked)} of the {len(listed)} "
                                   f"models compare.yaml lists (missing {', '.join(lost)}): the file was cut or "
                                   f"edited; rerun bpmid compare"))
    by_set = rd.csv(cdir / "summary_by_set.csv", required=("set", "model", "rmse_deg"))
    sets = {str(k): [str(x) for x in _list(v)] for k, v in _dict(cy.get("test_sets")).items()}
    preds: dict[str, list[pd.DataFrame]] = {}
    pdir = cdir / "predictions"
    if pdir.is_dir():
        groups = sets or {"test": sorted(p.stem for p in pdir.glob("*.csv"))}
        for s, names in groups.items():
            frames = []
            for n in names:
                f = rd.csv(pdir / f"{n}.csv", required=("time_s", "angle_deg", "pressure_pa_gauge"))
                if f is not None:
                    frames.append(f)
            if frames:
                preds[s] = frames
    syn = cy.get("synthetic")
    return CompareInfo(cdir, summary, by_set, [str(x) for x in _list(cy.get("train"))], sets,
                       [str(w) for w in _list(cy.get("warnings"))], None if syn is None else bool(syn), preds,
                       _dict(cy.get("provenance")))


def load_history(rd: _Reader) -> HistoryInfo | None:
    h = rd.yaml(rd.root / "history_modes.yaml", required=("accuracy",))
    if h is None:
        return None
    tab = rd.csv(rd.root / "history_modes.csv")
    return HistoryInfo(h, tab, str(h.get("log", "?")), _num(h.get("window_s")),
                       {str(k): _dict(v) for k, v in _dict(h.get("accuracy")).items()},
                       {str(k): _num(v) for k, v in _dict(h.get("us_per_step_longest")).items()},
                       _dict(h.get("window_vs_full")), _num(h.get("window_cost_reduction_pct")),
                       _dict(h.get("provenance")))


def load_discovery(rd: _Reader) -> DiscoveryInfo | None:
    ddir = rd.root / "discover" if (rd.root / "discover").is_dir() else rd.root
    d = rd.yaml(ddir / "discovery.yaml", required=("gap",))
    if d is None:
        return None
    gap = _dict(d.get("gap"))
    return DiscoveryInfo(ddir, [str(x) for x in _list(d.get("named_effects"))], _num(gap.get("before_rmse_deg")),
                         _num(gap.get("after_rmse_deg")), _num(gap.get("noise_floor_deg")), bool(d.get("unexplained")),
                         str(d.get("verdict") or "").strip(), [s for s in _list(d.get("steps")) if isinstance(s, dict)],
                         _dict(d.get("provenance")),
                         any(_dict(_dict(r).get("rival_outside_catalogue")).get("withheld_the_round")
                             for r in _list(d.get("rounds"))),
                         _num(gap.get("raw_before_rmse_deg")), _num(gap.get("raw_after_rmse_deg")),
                         _text(gap.get("scoring")) or "", _text(d.get("base_from")),
                         [str(c) for c in _list(d.get("cautions")) if isinstance(c, str)])


def load_control(rd: _Reader) -> ControlInfo | None:
    cdir = rd.root / "control"
    if not cdir.is_dir() and (rd.root / "control.yaml").is_file():   # the folder bpmid control wrote, given itself
        cdir = rd.root
    elif not cdir.is_dir():
        return None
    tab = rd.csv(cdir / "summary.csv", required=("controller", "reference", "rmse_deg"))
    cy = rd.yaml(cdir / "control.yaml") or {}
    if tab is None:
        return None
    return ControlInfo(cdir, tab, _dict(cy.get("gains")), _num(cy.get("rate_hz")),
                       _dict(_dict(cy.get("feedforward")).get("cost")), [str(w) for w in _list(cy.get("warnings"))],
                       _dict(cy.get("provenance")), _dict(cy.get("plant")), _dict(cy.get("controller_model")),
                       [r for r in _list(cy.get("references")) if isinstance(r, dict)])


#: stage name -> Study attribute
STAGE_OF = {"relax": "relax", "motion": "motion", "compare": "compare", "history": "history",
            "discover": "discovery", "control": "control"}
#: stage name -> its YAML files that carry a provenance block (relative to DIR)
STAGE_FILES = {"relax": ("relax_fit.yaml",), "motion": ("vbmm_fit.yaml", "vbmm_mat.yaml"),
               "compare": ("compare/compare.yaml",), "history": ("history_modes.yaml",),
               "discover": ("discover/discovery.yaml",), "control": ("control/control.yaml",)}


def _short(command: Any, n: int = 90) -> str:
    c = " ".join(str(command).split())
    return c if len(c) <= n else c[:n - 4].rstrip() + " ..."


def _written_by(p: dict) -> str:
    """'`bpmid compare ...` at 2026-...': what a provenance block says made its file."""
    cmd = f"`{_short(p['command'])}`" if p.get("command") else "an unrecorded command"
    return cmd + (f" at {p['created']}" if p.get("created") else "")


def not_from_run(run_prov: dict, prov: Any) -> str | None:
    """What wrote a stage file with provenance ``prov`` when it was not the run whose run.yaml has ``run_prov``
    (e.g. "`bpmid compare ...` at 2026-..."), or None when the run did. A run stamps its id into every file it
    writes (``provenance.run_id``); a run.yaml written before that has no id, and then the file must record the
    run's command and config (path and sha256), as every file of such a run does."""
    if not isinstance(prov, dict) or not prov:
        return "a command that recorded no provenance"
    rid = run_prov.get("run_id")
    if rid is not None:
        if prov.get("run_id") == rid:
            return None
        if prov.get("run_id") is not None and prov.get("command") == run_prov.get("command"):
            return (f"another run of the same command (run id {prov['run_id']}"
                    + (f", at {prov['created']}" if prov.get("created") else "") + ")")
        return _written_by(prov)
    if prov.get("command") != run_prov.get("command") or _dict(prov.get("config")) != _dict(run_prov.get("config")):
        return _written_by(prov)
    return None


def _check_provenance(st: Study, rd: _Reader) -> None:
    """Mark stale every stage that run.yaml lists as done but whose files say another command wrote them."""
    run_prov = st.run.provenance if st.run is not None else {}
    if not run_prov:
        return
    run = _written_by(run_prov) + (f", run id {run_prov['run_id']}" if run_prov.get("run_id") else "")
    for stage, files in STAGE_FILES.items():
        if stage in st.stale or st.run.status(stage) != "done" or getattr(st, STAGE_OF[stage]) is None:
            continue
        whys = [f"{f} was written by {who}" for f in files if f in rd.provenance
                for who in [not_from_run(run_prov, rd.provenance[f])] if who]
        if not whys:
            continue
        st.stale[stage] = ("; ".join(whys) + f", not by the run that run.yaml records ({run}). Its numbers may come "
                           "from other inputs or settings than the rest of this report: rerun `bpmid run` into "
                           "this folder to make it one study again (it rewrites every stage), and give other "
                           "commands an --out folder of their own")
        st.foreign.add(stage)


def read_study(root: str | Path) -> Study:
    """Every stage output under ``root`` that can be read (InputError only for a missing folder)."""
    root = Path(root)
    if root.exists() and not root.is_dir():
        raise InputError("is a file, not a folder (bpmid report takes the folder a run wrote)", path=root)
    if not root.is_dir():
        raise InputError("report folder not found", path=root)
    rd = _Reader(root)

    def guarded(load, path):
        try:
            return load(rd)
        except (TypeError, ValueError, KeyError, AttributeError, IndexError) as exc:  # wrong types inside a file
            rd.problems.append(Problem(path, f"malformed ({type(exc).__name__}: {exc})"))
            return None

    st = Study(root, run=guarded(load_run, "run.yaml"), relax=guarded(load_relax, "relax_fit.yaml"),
               motion=guarded(load_motion, "vbmm_fit.yaml"), compare=guarded(load_compare, "compare/summary.csv"),
               history=guarded(load_history, "history_modes.yaml"),
               discovery=guarded(load_discovery, "discover/discovery.yaml"),
               control=guarded(load_control, "control/summary.csv"))
    st.problems = rd.problems
    if st.run is not None:   # a stage the run finished whose file is gone (deleted or moved) is said, not skipped
        for stage, files in STAGE_FILES.items():
            if st.run.status(stage) == "done":
                st.missing += [f for f in files if not (root / f).is_file()]
    if st.run is not None:  # files of a stage the last run did not run are left over from an earlier run
        for stage, attr in STAGE_OF.items():
            if getattr(st, attr) is None:
                continue
            status = st.run.status(stage)
            if status != "done":
                why = ("the last run (run.yaml) skipped this stage" if status == "skipped" else
                       "the last run (run.yaml) does not list this stage" if status is None else
                       f"the last run (run.yaml) lists this stage as {status}")
                st.stale[stage] = why + "; these files are from an earlier run"
        _check_provenance(st, rd)
    return st
