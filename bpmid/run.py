"""``bpmid run``: the whole study, one stage after another, each through its library function.

Stages (each writes into DIR with the names of CLI.md; a stage whose inputs the config does not give is
skipped and says so in ``run.yaml``):

============  =========================================================  ==========================================
stage         library call                                               files in DIR
============  =========================================================  ==========================================
relax         :func:`bpmid.relax.run_fit_relax`                          relax_fit.yaml, relax_fit.png
motion        :func:`bpmid.motion_fit.fit_motion` +                      vbmm_fit.yaml, vbmm_fit.png, vbmm_mat.yaml
              :func:`bpmid.motion_fit.write_motion_fit`
compare       :func:`bpmid.compare.run_compare`                          compare/metrics.csv, summary.csv, ...
history       :func:`bpmid.history_modes.history_mode_study` +           history_modes.csv, .yaml, .png
              :func:`bpmid.history_modes.write_history_study`
discover      :func:`bpmid.discover.discover`                            discover/discovery.yaml, verdict.txt, figures
control       :func:`bpmid.control.run_control` (PI, VBMM-PI, MS-PI on   control/summary.csv, control.yaml, traces/,
              the shipped references) + :func:`~bpmid.control.write_control`  fig18.png
report        :func:`bpmid.report.write_report`                          report.html, report.md, report_figures/
============  =========================================================  ==========================================

Every input of every stage that will run is read and checked before the first stage starts: the paths of the
config (a missing one is an InputError naming the config key and the path), every log with the reader its stage
uses, and the parameter files the config names (:func:`check_stage_inputs`). Every file is written atomically;
``run.yaml`` (schema ``bpmid.run/1``: stages, status, wall time, provenance with the sha256 of every input and of
the config, the seed and the run's id) is written last, so a folder with a ``run.yaml`` holds a complete run; every
file the run writes carries the same ``provenance.run_id`` (:func:`bpmid.io.results.run_stamp`), so ``bpmid report``
can tell a stage file that another command wrote into DIR afterwards. A run that still
fails in a stage, or is interrupted (Ctrl-C), is rolled back (:class:`OutputJournal`): the files it wrote are
removed and the files it replaced are put back, so DIR is as it was before (absent if it did not exist). The
stages write in place, so every path recorded in the outputs (provenance, report) is the final one.

Side by side: compare, history, discover and control need nothing but the inputs and the two fits, so after the
motion stage they run in processes forked from the run, up to ``run.workers`` at a time (default: the idle cores, at
most 2; :func:`stage_workers`), together with the drawing of the relaxation and motion figures; the report comes
last, in the run's process. Each process starts from the run's state after the motion stage, so the numbers are
those of a run with ``workers: 1``. A failure in one, Ctrl-C or SIGTERM stops the others before the rollback; a
run killed outright takes them with it (``PR_SET_PDEATHSIG``), and the next command rolls the folder back.

Determinism: no stage draws random numbers except where a seed is recorded (``run.seed``); two runs of the
same config give identical tables except the wall-clock columns (``us_per_step``, ``seconds``).
"""
from __future__ import annotations

import dataclasses
import signal
import sys
import time
from pathlib import Path
from typing import Mapping, Optional

from bpmid.errors import InputError, interrupted
from bpmid.io.motion_logs import synthetic_note
from bpmid.progress import note

STAGES = ("relax", "motion", "compare", "history", "discover", "control", "report")
SCHEMA = "bpmid.run/1"
DEFAULT_CONFIG = Path("configs") / "paper.yaml"


@dataclasses.dataclass(frozen=True)
class RunConfig:
    """Config section ``run``: the inputs of every stage (paths or glob patterns, relative to the config file).

    Attributes
    ----------
    relax_logs : relaxation tests (stage relax)
    fitting_set : motion logs the models are fitted on (stages motion and compare)
    test_sets : named groups of test logs (stage compare), e.g. ``{variable_amplitude: [...], variable_rate: [...]}``
    long_term : the long-term log for the history-mode comparison (stage history)
    discover_logs : logs the discovery workflow fits on (stage discover)
    discover_holdout : its held-out logs (default: the workflow's own split of ``discover_logs``)
    control_references : reference angle files (``time_s, angle_deg``) the control stage tracks (default: the
        shipped references of the paper's experiment 3, ``datasets/control/``)
    stages : stages to run, in the fixed order of :data:`STAGES`
    history_durations_s : prefix durations of the long-term log for the cost-per-step curve (s)
    history_repeats : timed runs per point in the recursive and window modes (the fastest counts)
    seed : recorded in every output's provenance (no stage draws random numbers without it)
    out : default output folder (relative to the working directory) when ``--out`` is not given
    workers : processes for the stages that only need the motion fit (compare, history, discover, control run
        side by side, each in a process forked after the motion stage; Linux only, elsewhere always 1); 0 = the
        idle cores this process may use (cores minus the load average beyond this run's own 1, rounded), at
        least 1 and at most 2 (:data:`MAX_AUTO_WORKERS`); 1 = one stage after another in this process. The
        outputs are the same either way except the wall-clock columns.
    """

    relax_logs: tuple[str, ...] = ()
    fitting_set: tuple[str, ...] = ()
    test_sets: Mapping[str, tuple[str, ...]] = dataclasses.field(default_factory=dict)
    long_term: Optional[str] = None
    discover_logs: tuple[str, ...] = ()
    discover_holdout: tuple[str, ...] = ()
    control_references: tuple[str, ...] = ()
    stages: tuple[str, ...] = STAGES
    history_durations_s: tuple[float, ...] = (100.0, 200.0, 450.0, 900.0, 1800.0)
    history_repeats: int = 3
    seed: int = 0
    out: Optional[str] = None
    workers: int = 0

    def validate(self, where, path):
        for i, s in enumerate(self.stages):
            if s not in STAGES:
                raise InputError(f"unknown stage {s!r} (known: {', '.join(STAGES)})", path=path,
                                 key=f"{where}.stages[{i}]")
        dup = sorted({s for s in self.stages if self.stages.count(s) > 1})
        if dup:
            raise InputError(f"stage {dup[0]} is named twice", path=path, key=f"{where}.stages")
        if self.seed < 0:
            raise InputError(f"must be a seed >= 0, found {self.seed}", path=path, key=f"{where}.seed")
        if self.workers < 0:
            raise InputError("must be 0 (as many as cores, at most 2) or a positive number of processes", path=path,
                             key=f"{where}.workers")
        if self.history_repeats < 1:
            raise InputError("must be at least 1", path=path, key=f"{where}.history_repeats")
        if any(d <= 0 for d in self.history_durations_s):
            raise InputError("durations must be positive", path=path, key=f"{where}.history_durations_s")


def default_config_path() -> Path:
    """``configs/paper.yaml`` of the source tree bpmid was installed from (``pip install -e .``), else of the
    working directory; InputError when neither exists."""
    from bpmid import data

    candidates = [(data.root() / DEFAULT_CONFIG).resolve(), Path.cwd() / DEFAULT_CONFIG]
    for c in candidates:
        if c.is_file():
            return c
    raise InputError("no CONFIG given and the default configs/paper.yaml was not found (looked in "
                     + " and ".join(str(c) for c in candidates)
                     + "); it ships with the source tree: install with `pip install -e .` from a checkout, or give "
                     "the config path: bpmid run path/to/config.yaml")


@dataclasses.dataclass
class StageRecord:
    name: str
    status: str  # done, skipped
    seconds: float = 0.0
    outputs: list = dataclasses.field(default_factory=list)
    note: str = ""

    def to_yaml(self) -> dict:
        out = {"name": self.name, "status": self.status, "seconds": round(self.seconds, 3),
               "outputs": list(self.outputs)}
        if self.note:
            out["note"] = self.note
        return out


@dataclasses.dataclass
class RunInputs:
    relax_logs: list
    fitting_set: list
    test_sets: dict
    long_term: Optional[Path]
    discover_logs: list
    discover_holdout: list
    control_references: list = dataclasses.field(default_factory=list)   # not data logs: never in all()

    def all(self) -> list[Path]:
        out = list(self.relax_logs) + list(self.fitting_set) + [p for v in self.test_sets.values() for p in v]
        out += ([self.long_term] if self.long_term else []) + list(self.discover_logs) + list(self.discover_holdout)
        seen, uniq = set(), []
        for p in out:
            if str(p) not in seen:
                seen.add(str(p))
                uniq.append(p)
        return uniq


def resolve_run_inputs(config) -> RunInputs:
    """Every input path of the ``run`` section, expanded and checked (InputError: config key and path)."""
    from bpmid.compare import expand_paths

    rc: RunConfig = config.section("run")
    base = config.base_dir
    cpath = config.path

    def many(key, pats):
        return expand_paths(pats, base=base, key=f"run.{key}", config_path=cpath) if pats else []

    long_term = None
    if rc.long_term:
        long_term = expand_paths(rc.long_term, base=base, key="run.long_term", config_path=cpath)[0]
    return RunInputs(
        relax_logs=many("relax_logs", rc.relax_logs), fitting_set=many("fitting_set", rc.fitting_set),
        test_sets={s: many(f"test_sets.{s}", v) for s, v in rc.test_sets.items()}, long_term=long_term,
        discover_logs=many("discover_logs", rc.discover_logs),
        discover_holdout=many("discover_holdout", rc.discover_holdout),
        control_references=many("control_references", rc.control_references))


def control_references(config, inp: RunInputs) -> list:
    """The references the control stage tracks: the config's ``run.control_references`` read with its ``io``
    section, else every shipped one (InputError naming the file, or the key of a name given twice)."""
    from bpmid.control import check_reference_names, load_references, read_reference

    rate = config.section("control").rate_hz
    if not inp.control_references:
        return load_references("all", rate)
    return check_reference_names([read_reference(p, rate, io=config.section("io")) for p in inp.control_references],
                                 key="run.control_references", path=config.path)


def stages_to_run(rc: "RunConfig", inp: RunInputs) -> list[str]:
    """The stages of ``run.stages`` whose inputs the config gives, in the fixed order of :data:`STAGES`."""
    return [s for s in STAGES if s in rc.stages and _missing_inputs(s, inp) is None]


def _param_file(config, section: str, key: str, value) -> Path:
    p = config.resolve_path(value)
    if not p.is_file():
        raise InputError("folder, not a file" if p.is_dir() else "file not found", path=p,
                         key=f"{section}.{key}")
    return p


def check_stage_inputs(config, inp: RunInputs, stages) -> list:
    """Read and check every input of every stage in ``stages`` with the reader that stage uses, before any
    stage runs (InputError naming the file, line or key). Returns the motion logs of the fitting and test sets
    (read without requiring angles when the stages that need them do not run)."""
    from bpmid.io.motion_logs import read_motion_log, read_motion_logs
    from bpmid.io.relax_logs import read_relax_logs
    from bpmid.motion_fit import initial_material, material_from_relax

    io_cfg = config.section("io")
    stages = set(stages)
    if "relax" in stages:
        rcfg = config.section("relax")
        gap = rcfg.max_gap_factor if rcfg.max_gap_factor is not None else io_cfg.max_gap_factor
        read_relax_logs(inp.relax_logs, column_map=rcfg.columns, gauge_length_mm=rcfg.specimen.gauge_length_mm,
                        cross_section_mm2=rcfg.specimen.cross_section_mm2, gap_factor=gap, io_cfg=io_cfg)
    angled: list[Path] = []  # logs whose stage needs measured angles
    if stages & {"motion", "compare"}:
        angled += list(inp.fitting_set)
    if "compare" in stages:
        angled += [p for v in inp.test_sets.values() for p in v]
    if "history" in stages:
        angled.append(inp.long_term)
    if "discover" in stages:
        angled += list(inp.discover_logs) + list(inp.discover_holdout)
        fitted = {Path(p).resolve() for p in inp.discover_logs}
        for i, p in enumerate(inp.discover_holdout):   # said in the config's keys, not the command's LOG/--holdout
            if Path(p).resolve() in fitted:
                raise InputError(f"{p} is also in run.discover_logs: discovery would score its fit on its own data; "
                                 "give each log in one of the two lists", path=config.path,
                                 key=f"run.discover_holdout[{i}]")
    seen: dict = {}
    for p in angled:
        if str(p) not in seen:
            seen[str(p)] = read_motion_logs([p], io_cfg, require_angle=True)[0]
    # the parameter files the config names (used when this run's relaxation fit does not replace them)
    if "relax" not in stages:
        mcfg = config.section("motion")
        if "motion" in stages and mcfg.relax_fit is not None:
            p = _param_file(config, "motion", "relax_fit", mcfg.relax_fit)
            initial_material(mcfg, p)
        ccfg = config.section("compare")
        if "compare" in stages and ccfg.relax is not None:
            material_from_relax(_param_file(config, "compare", "relax", ccfg.relax))
    if "control" in stages and inp.control_references:
        control_references(config, inp)
    motion_paths = inp.fitting_set + [p for v in inp.test_sets.values() for p in v]
    if not motion_paths:
        return []
    # each file read once: the logs checked above are the same files read the same way (their angle is there)
    logs = [seen[str(p)] if str(p) in seen else read_motion_log(p, io_cfg) for p in motion_paths]
    from bpmid.io.motion_logs import check_distinct_names

    check_distinct_names(logs)
    return logs


# the names a run writes in DIR (files, and folders written whole)
RUN_FILES = ("relax_fit.yaml", "relax_fit.png", "vbmm_fit.yaml", "vbmm_fit.png", "vbmm_mat.yaml",
             "history_modes.csv", "history_modes.yaml", "history_modes.png", "report.html", "report.md", "run.yaml")
RUN_FILES = RUN_FILES + tuple(f[:-4] + s for f in RUN_FILES if f.endswith(".png") for s in (".svg", ".pdf"))
RUN_FOLDERS = ("compare", "discover", "control", "report_figures")


class OutputJournal:
    """Undo for a run that writes into ``out`` in place, safe against a kill at any instant.

    Before the run, the files under the run's own names (:data:`RUN_FILES`, :data:`RUN_FOLDERS`) are copied into
    a hidden backup folder in ``out`` and every name in ``out`` is recorded in a journal
    (:class:`bpmid.io.atomic.Journal`, written before the first stage writes). Nothing is moved, so an input that
    lives in ``out`` (a relaxation fit of an earlier run, say) stays where the config says it is.
    :meth:`rollback` removes every file and folder the run created and puts back every file it replaced or
    removed; :meth:`commit` removes the journal (the commit point) and then the backup. A run killed outright
    (SIGKILL) leaves the journal: the next command on the folder (:func:`bpmid.io.atomic.recover`) rolls it back,
    so the folder holds the earlier complete run again. When ``out`` does not exist, the rollback removes it, and
    any parent folder the run made for it; a kill before the commit leaves ``out`` without ``run.yaml`` and with
    its journal, and the next command removes what the run wrote.
    """

    def __init__(self, out: Path):
        import contextlib
        import os

        from bpmid.io.atomic import Journal, os_error, recover

        self.out = Path(os.path.abspath(out))
        recover(self.out)  # a run killed earlier: put its folder back first
        self.existed = self.out.is_dir()
        top = self.out
        while not top.parent.exists() and top.parent != top:
            top = top.parent
        self.created_top = top  # the outermost folder this run will create (when out does not exist)
        from bpmid.io.atomic import folder_lock

        self.lock = contextlib.ExitStack()
        try:
            if self.existed:  # one writer at a time: a second command into this folder is refused, not mixed in
                self.lock.enter_context(folder_lock(self.out, wait_s=0.0))
                self.journal = Journal(self.out)
                self.journal.snapshot(self._own_files(), walk=RUN_FOLDERS)
            else:  # the folder appears with its journal inside; a rollback removes it (and parents made for it)
                d, dirs = self.out, []
                while True:
                    dirs.append(str(d))
                    if d == top:
                        break
                    d = d.parent
                self.out.parent.mkdir(parents=True, exist_ok=True)
                self.journal = Journal.new_folder(self.out, len(dirs))
                self.lock.enter_context(folder_lock(self.out, wait_s=0.0))
        except OSError as exc:
            self.lock.close()
            self._remove_created()
            raise os_error(exc, out) from exc
        except BaseException:
            self.lock.close()
            self._remove_created()
            raise

    def _remove_created(self) -> None:
        import shutil

        if not self.existed:
            shutil.rmtree(self.created_top, ignore_errors=True)

    def _own_files(self) -> list[str]:
        out = [n for n in RUN_FILES if (self.out / n).is_file() and not (self.out / n).is_symlink()]
        for d in RUN_FOLDERS:
            if (self.out / d).is_dir() and not (self.out / d).is_symlink():
                out += [str(p.relative_to(self.out)) for p in sorted((self.out / d).rglob("*"))
                        if p.is_file() and not p.is_symlink()]
        return out

    def commit(self) -> None:
        self.journal.commit()
        self.lock.close()

    def rollback(self) -> None:
        self.journal.rollback()
        self.lock.close()
        if not self.existed:
            self._remove_created()


def _prov(inputs, config, seed, command):
    from bpmid.io.results import provenance

    return provenance([p for p in inputs if p is not None], config=config, seed=seed, command=command)


def _ambient_note(logs, ctx: dict) -> None:
    """The stand-alone commands' note for logs turned to gauge with an ambient nothing stated, each log once per
    run (the motion stage notes its logs before the stages after it are forked, so they note only others)."""
    from bpmid.io import plausibility as plaus

    seen = ctx.setdefault("ambient_noted", set())
    new = [lg for lg in logs if str(getattr(lg, "path", None) or lg.name) not in seen]
    seen.update(str(getattr(lg, "path", None) or lg.name) for lg in new)
    text = plaus.assumed_ambient_note(new)
    if text:
        print("note: " + text, file=sys.stderr, flush=True)


def _log_warnings(logs, config, what: Path, ctx: dict) -> list[str]:
    """What the stand-alone command says of its logs before any model runs on them: the readers' warnings and the
    unit and reference checks (printed; ``io.strict`` refuses them), then the ambient note. Returns the warnings
    (the stage's file records them with the reading, :func:`bpmid.io.plausibility.attach`)."""
    from bpmid.io import plausibility as plaus

    warnings = plaus.log_warnings(logs)
    plaus.emit(warnings, strict=config.section("io").strict, what=str(what), key=plaus.strict_key(config.section("io")))
    _ambient_note(logs, ctx)
    return warnings


# --------------------------------------------------------------------------------------------------
# stages (each returns the files it wrote, relative to DIR)
# --------------------------------------------------------------------------------------------------
def stage_relax(inp: RunInputs, out: Path, config, ctx: dict) -> list[str]:
    from bpmid.relax import run_fit_relax

    from bpmid.plots.common import figure_path

    fig_path = figure_path(out / "relax_fit.png")
    deferred = ctx.get("deferred")
    if deferred is not None:  # the figure is drawn later, beside the stages that follow the motion fit
        from bpmid.api import fit_relaxation
        from bpmid.plots.common import save_figure
        from bpmid.relax.result import save_relax_result

        # what run_fit_relax does, with the figure left for later
        result = fit_relaxation(inp.relax_logs, config=config, _flags=True)
        yaml_path, _, _fit = save_relax_result(result, out / "relax_fit.yaml", figure=False)
        deferred.append(("relax figure", lambda: save_figure(result._figure(), fig_path)))
        fig = fig_path
    else:
        yaml_path, fig, _fit = run_fit_relax(inp.relax_logs, out / "relax_fit.yaml", config=config, figure=fig_path)
    ctx["relax_fit"] = yaml_path
    return ["relax_fit.yaml"] + ([Path(fig).name] if fig else [])


def _motion_figure(mf, figure: Path, synthetic: bool) -> None:
    """The figure :func:`bpmid.models.vbmm.fit.write_motion_fit` draws beside ``vbmm_fit.yaml`` (same drawing)."""
    import io

    import matplotlib.pyplot as plt

    from bpmid.io.atomic import write_bytes
    from bpmid.plots.motion import motion_fit_figure

    fig = motion_fit_figure(mf.logs, mf.predictions, title=f"VBMM fit ({mf.model.closure} closure, "
                            f"{mf.model.history} history): RMSE {mf.metrics['rmse_deg']:.3g}°", synthetic=synthetic)
    buf = io.BytesIO()
    try:
        fig.savefig(buf, dpi=110, format=Path(figure).suffix.lstrip(".") or "png")
    finally:
        plt.close(fig)
    write_bytes(figure, buf.getvalue())


def stage_motion(inp: RunInputs, out: Path, config, ctx: dict) -> list[str]:
    import numpy as np

    from bpmid import metrics as M
    from bpmid.io.motion_logs import read_motion_logs
    from bpmid.io.results import write_result
    from bpmid.models.vbmm import VBMM, vbmm_yaml_body
    from bpmid.motion_fit import fit_motion, initial_material, write_motion_fit

    logs = read_motion_logs(inp.fitting_set, config.section("io"), require_angle=True)
    relax = ctx.get("relax_fit")
    prov = _prov(inp.fitting_set + ([relax] if relax else []), config, ctx["seed"], ctx["command"])
    mf = fit_motion(logs, config=config, init=relax)
    from bpmid.io import plausibility as plaus
    from bpmid.plots.common import figure_path

    warnings = plaus.reader_warnings(logs) + plaus.motion_fit_warnings(mf)
    plaus.emit(warnings, strict=config.section("io").strict, what=str(out / "vbmm_fit.yaml"),
               key=plaus.strict_key(config.section("io")))
    _ambient_note(logs, ctx)
    fig = figure_path(out / "vbmm_fit.png")
    deferred = ctx.get("deferred")
    write_motion_fit(out / "vbmm_fit.yaml", mf, plaus.attach(dict(prov), logs, warnings),
                     figure=fig if deferred is None else None, synthetic=synthetic_note(logs))
    if deferred is not None:  # drawn beside the stages that follow (same figure)
        synthetic = synthetic_note(logs)   # the figure's own logs
        deferred.append(("motion figure", lambda: _motion_figure(mf, fig, synthetic)))
    ctx["vbmm_fit"] = out / "vbmm_fit.yaml"
    # VBMM-mat.: the relaxation constants as they are, scored on the same fitting set
    mat, source = initial_material(config.section("motion"), relax, base_dir=config.base_dir)
    model = VBMM.from_config(mat, config.section("model"))
    y = np.concatenate([lg.angle_deg for lg in logs])
    yh = np.concatenate([model.forward_deg(lg.time_s, lg.pressure_pa, name=lg.name, path=lg.path) for lg in logs])
    body = vbmm_yaml_body(model)
    body["metrics"] = M.summary(y, yh)
    body["source"] = f"relaxation constants, not refitted ({source})"
    write_result(out / "vbmm_mat.yaml", "bpmid.vbmm/1", body, prov)
    return ["vbmm_fit.yaml", fig.name, "vbmm_mat.yaml"]


def stage_compare(inp: RunInputs, out: Path, config, ctx: dict) -> list[str]:
    from bpmid.compare import run_compare

    relax = ctx.get("relax_fit")
    if relax is None and config.section("compare").relax is not None:
        relax = config.resolve_path(config.section("compare").relax)
    run_compare(inp.fitting_set, inp.test_sets, out / "compare", config=config, relax_fit=relax,
                prov_command=ctx["command"])
    return ["compare/metrics.csv", "compare/summary.csv", "compare/summary_by_set.csv", "compare/compare.yaml"]


def stage_history(inp: RunInputs, out: Path, config, ctx: dict) -> list[str]:
    from bpmid.history_modes import history_mode_study, write_history_study
    from bpmid.io.motion_logs import read_motion_log
    from bpmid.models.vbmm import starting_vbmm

    mcfg = config.section("model")
    model = starting_vbmm(ctx.get("vbmm_fit"), mcfg)[0]
    source = "VBMM-fit of this run (vbmm_fit.yaml)" if ctx.get("vbmm_fit") else "the paper's VBMM-fit constants"
    log = read_motion_log(inp.long_term, config.section("io"), require_angle=True)
    from bpmid.io import plausibility as plaus

    warnings = _log_warnings([log], config, out / "history_modes.yaml", ctx)
    rc: RunConfig = config.section("run")
    _history_length_notes(log, rc, mcfg)
    study = history_mode_study(model, log, durations_s=rc.history_durations_s, repeats=rc.history_repeats)
    r2 = float(study.accuracy["full"]["r2"])
    if not r2 >= plaus.R2_MIN:   # as bpmid predict warns: the modes are then compared on a model of another muscle
        poor = [f"{log.name}: the constants used ({source}) explain little of the long log's angle (R^2 {r2:.3g} < "
                f"{plaus.R2_MIN:g}): the history modes' accuracy is that of a model not of this muscle; give "
                f"run.fitting_set (the motion stage fits this muscle's constants), and check the log's units and "
                f"pressure reference (io)"]
        plaus.emit(poor, strict=config.section("io").strict, what=str(out / "history_modes.yaml"),
                   key=plaus.strict_key(config.section("io")))
        warnings = list(warnings) + poor
    inputs = [inp.long_term] + ([ctx["vbmm_fit"]] if ctx.get("vbmm_fit") else [])
    written = write_history_study(study, out, plaus.attach(_prov(inputs, config, ctx["seed"], ctx["command"]), [log],
                                                            warnings),
                                  params_source=source, synthetic=synthetic_note([log]))
    return [Path(p).name for p in written]


def _history_length_notes(log, rc: "RunConfig", mcfg) -> None:
    """Say what the history stage cannot do on a long log shorter than asked: a prefix duration beyond the log is
    the whole log (its row says the log's length, not the one asked for), and a window as long as the log drops
    nothing (window and full history are then the same sum)."""
    import numpy as np

    length = float(log.duration_s)
    step = float(np.median(np.diff(log.time_s))) if log.time_s.size > 1 else 0.0
    beyond = [d for d in rc.history_durations_s if d > length + step + 1e-9]   # within a sample: the whole log
    if beyond:
        print(f"note: run.history_durations_s: {', '.join(f'{d:g}' for d in beyond)} s "
              f"{'is' if len(beyond) == 1 else 'are'} beyond the long log "
              f"({log.name}, {length:g} s): the cost-per-step curve ends at the whole log, and history_modes.csv "
              f"has no row of that length; give durations up to {length:g} s or a longer run.long_term",
              file=sys.stderr, flush=True)
    window = getattr(mcfg, "window_s", None)
    if window is not None and float(window) >= length:
        print(f"note: model.window_s ({float(window):g} s) is not shorter than the long log ({log.name}, {length:g} s):"
              f" the window drops nothing, so window and full history are the same sum here; use a log longer than "
              f"the window to compare them", file=sys.stderr, flush=True)


def stage_discover(inp: RunInputs, out: Path, config, ctx: dict) -> list[str]:
    from bpmid.discover import discover
    from bpmid.discover.output import write_discovery
    from bpmid.io.motion_logs import read_motion_logs
    from bpmid.models.vbmm import starting_vbmm

    io_cfg = config.section("io")
    fit_logs = read_motion_logs(inp.discover_logs, io_cfg, require_angle=True)
    ho = read_motion_logs(inp.discover_holdout, io_cfg, require_angle=True) if inp.discover_holdout else None
    every = fit_logs + (ho or [])
    warnings = _log_warnings(every, config, out / "discover", ctx)
    base = starting_vbmm(ctx.get("vbmm_fit"), config.section("model"))[0]
    base_from = "vbmm_fit.yaml (motion fit of this run)" if ctx.get("vbmm_fit") else "paper VBMM-fit constants"
    result = discover(fit_logs, base, holdout=ho, cfg=config.section("discover"))
    inputs = inp.discover_logs + inp.discover_holdout + ([ctx["vbmm_fit"]] if ctx.get("vbmm_fit") else []) \
        + ([Path(result.thresholds_file)] if result.thresholds_file else [])   # the gate's file is an input too
    from bpmid.io import plausibility as plaus

    written = write_discovery(out / "discover", result,
                              plaus.attach(_prov(inputs, config, ctx["seed"], ctx["command"]), every, warnings),
                              base_from=base_from)
    return [f"discover/{name}" for name in written if not name.endswith(".png")]


def stage_control(inp: RunInputs, out: Path, config, ctx: dict) -> list[str]:
    """The paper's experiment 3 in kind: PI, VBMM-PI and MS-PI on the shipped references (or the config's
    ``run.control_references``), the controller's
    model being this run's VBMM-fit (else the paper's constants), the plant the same model with sensor noise."""
    from bpmid.control import build_plant, references_reading, run_control, write_control
    from bpmid.models.vbmm import VBMM, Material, load_vbmm

    cfg = config.section("control")
    mcfg = config.section("model")
    if ctx.get("vbmm_fit") is not None:
        model = load_vbmm(ctx["vbmm_fit"], mcfg)
    else:
        model = VBMM.from_config(Material.paper_fit(), mcfg)
    plant = build_plant(model, [], cfg)
    refs = control_references(config, inp)
    result = run_control(model, plant, refs, cfg)
    if ctx.get("vbmm_fit") is not None:
        from bpmid.models.vbmm.rig import loop_step_warning

        result.warnings[:0] = loop_step_warning(cfg.rate_hz, ctx["vbmm_fit"], model, what="the controller's model")
    from bpmid.io import plausibility as plaus

    plaus.emit([f"control: {w}" for w in result.warnings])   # said on stderr as bpmid control says them
    inputs = [r.path for r in refs if r.path is not None] + ([ctx["vbmm_fit"]] if ctx.get("vbmm_fit") else [])
    prov = _prov(inputs, config, cfg.seed, ctx["command"])
    prov["reading"] = references_reading(refs)
    written = write_control(result, out / "control", cfg, prov,
                            model=model, plant=plant, figure=True)
    return [Path(p).relative_to(out).as_posix() for p in written if Path(p).parent.name != "traces"]


def stage_report(inp: RunInputs, out: Path, config, ctx: dict) -> list[str]:
    from bpmid.report import write_report

    write_report(out, drawn=ctx.get("drawn"))
    return ["report.html", "report.md"]


STAGE_FUNCTIONS = {"relax": stage_relax, "motion": stage_motion, "compare": stage_compare,
                   "history": stage_history, "discover": stage_discover, "control": stage_control,
                   "report": stage_report}


def _missing_inputs(stage: str, inp: RunInputs) -> str | None:
    need = {"relax": (inp.relax_logs, "run.relax_logs"), "motion": (inp.fitting_set, "run.fitting_set"),
            "compare": (inp.fitting_set and inp.test_sets, "run.fitting_set and run.test_sets"),
            "history": (inp.long_term, "run.long_term"), "discover": (inp.discover_logs, "run.discover_logs")}
    if stage in need and not need[stage][0]:
        return f"skipped: the config gives no {need[stage][1]}"
    return None


#: the stages that read the study's data (control and report can run on defaults alone)
DATA_STAGES = ("relax", "motion", "compare", "history", "discover")


def check_stages_can_run(rc: "RunConfig", inp: RunInputs, path=None) -> None:
    """A stage the config names in ``run.stages`` must have its inputs (it was skipped, exit 0, before); a config
    that names no stages and gives no data for any (one that only overrides settings, ``model: {history:
    window}``) would run control on default constants alone: both are refused before anything is written."""
    from bpmid.config import stated_keys

    if "stages" in stated_keys(rc):
        for i, stage in enumerate(rc.stages):
            why = _missing_inputs(stage, inp)
            if why:
                raise InputError(f"stage {stage} is asked for but cannot run: the config gives no "
                                 f"{why.split('gives no ', 1)[1]}", path=path, key=f"run.stages[{i}]")
        return
    if not any(_missing_inputs(s, inp) is None for s in DATA_STAGES if s in rc.stages):
        raise InputError("the config gives no data for any stage (run.relax_logs, run.fitting_set, run.test_sets, "
                         "run.long_term, run.discover_logs): bpmid run reads its logs from the config's section run. "
                         "Start from configs/paper.yaml (what bpmid run uses without a config), or name the stages "
                         "to run (run: {stages: [control, report]})", path=path, key="run")


def _param_inputs(config, rc: "RunConfig", inp: RunInputs) -> list[Path]:
    """The parameter files the config names for the stages that will run (they may live in DIR)."""
    stages = set(stages_to_run(rc, inp))
    out = []
    if "relax" not in stages:
        m, c = config.section("motion"), config.section("compare")
        if "motion" in stages and m.relax_fit is not None:
            out.append(config.resolve_path(m.relax_fit))
        if "compare" in stages and c.relax is not None:
            out.append(config.resolve_path(c.relax))
    return out


def check_run_outputs(out: Path, inputs) -> None:
    """Before any stage runs: refuse when an input (config, log, parameter file) sits in DIR under a name the
    run writes (:data:`RUN_FILES`, or inside :data:`RUN_FOLDERS`), by resolved path or as the same file."""
    import os

    from bpmid.io.atomic import check_outputs_not_inputs

    out_real = Path(os.path.realpath(out))
    targets = [out / n for n in RUN_FILES]
    for p in inputs:
        if p is None:
            continue
        real = Path(os.path.realpath(p))
        for d in RUN_FOLDERS:
            if out_real / d == real or out_real / d in real.parents:
                raise InputError(f"the input {p} lies in {d}/, which this run rewrites; move it or choose another "
                                 "output folder (--out)", path=out / d, key="--out")
    check_outputs_not_inputs(targets, inputs)


def run_study(config, out_dir: str | Path, *, command: str | None = None) -> list[StageRecord]:
    """Run every stage of ``config.run.stages`` into ``out_dir`` (see module docstring); returns the records.

    Parameters
    ----------
    config : a loaded :class:`bpmid.config.Config`
    out_dir : output folder (created)
    command : the command line to record (default: ``sys.argv``)
    """
    from bpmid.io.read_once import reading_once

    with reading_once():  # every log is parsed once: checked before the stages, then handed to them
        return _run_study(config, out_dir, command)


def _run_study(config, out_dir: str | Path, command: str | None) -> list[StageRecord]:
    from bpmid.io.motion_logs import file_is_synthetic
    from bpmid.io.results import command_line, new_run_id, run_stamp, write_result

    rc: RunConfig = config.section("run")
    inp = resolve_run_inputs(config)  # every path checked before any work
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError("--out must be a folder, found a file", path=out)
    check_stages_can_run(rc, inp, config.path)
    # every input of every stage read and checked before the first stage runs (and before DIR is touched)
    check_stage_inputs(config, inp, stages_to_run(rc, inp))
    check_run_outputs(out, [config.path] + inp.all() + inp.control_references + _param_inputs(config, rc, inp))
    # synthetic only when every log the study reads is (a measured relaxation curve is not; the report says so); a
    # study mixing them with measured logs is not called measured (the report names the synthetic ones)
    data_logs = inp.all()
    synth_logs = [str(p) for p in data_logs if file_is_synthetic(p)]
    ctx = {"seed": rc.seed, "command": command or command_line(),
           "synthetic": len(synth_logs) == len(data_logs),
           "data_logs": {"total": len(data_logs), "synthetic": len(synth_logs),
                         **({"synthetic_files": synth_logs} if 0 < len(synth_logs) < len(data_logs) else {})},
           "run_id": new_run_id()}
    # the figures' stamp in the logs' own words: the twin's, another generator's, or a mix (None: measured)
    from bpmid.io.motion_logs import stamp_for_files

    ctx["stamp"] = stamp_for_files(data_logs)   # run.yaml records it: the report's wording and stamps
    journal = OutputJournal(out)
    try:
        with run_stamp(ctx["run_id"], ctx["command"]):  # every file of this run says so (provenance.run_id)
            records = _run_stages(config, rc, inp, out, ctx, write_result)
    except BaseException as exc:  # a failing stage or Ctrl-C: leave DIR as it was
        journal.rollback()
        if isinstance(exc, SystemError) and interrupted(exc):
            # Ctrl-C inside a compiled kernel can surface as nested SystemErrors: say "interrupted"
            raise KeyboardInterrupt() from exc
        raise
    journal.commit()
    return records


#: stages that need nothing but the inputs and the relaxation and motion fits (they read ``ctx``, never write it),
#: longest first: with more than one worker they run side by side, each in a process forked after the motion stage
SIDE_BY_SIDE = ("discover", "compare", "history", "control")
#: workers when ``run.workers`` is 0: the cores this process may use, at most this many
MAX_AUTO_WORKERS = 2


def stage_workers(rc: RunConfig) -> int:
    """Processes for the :data:`SIDE_BY_SIDE` stages (1: one after another in this process)."""
    import multiprocessing
    import os
    import sys

    # forking a process that has loaded numpy, numba and matplotlib is safe on Linux; macOS system libraries
    # (Accelerate, Objective-C) are not fork-safe, and Windows cannot fork
    if not sys.platform.startswith("linux") or "fork" not in multiprocessing.get_all_start_methods():
        return 1
    if rc.workers:
        return rc.workers
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    try:  # cores other work keeps busy do not speed the run up (the forked processes' own start costs CPU);
        # this run itself accounts for up to 1 of the load average (so does an earlier run just finished)
        idle = cores - max(os.getloadavg()[0] - 1.0, 0.0)
    except OSError:
        idle = cores
    return max(1, min(int(idle + 0.5), cores, MAX_AUTO_WORKERS))


def _run_one(stage: str, inp: RunInputs, out: Path, config, ctx: dict) -> StageRecord:
    note(f"stage {stage} ...")
    t0 = time.perf_counter()
    outputs = STAGE_FUNCTIONS[stage](inp, out, config, ctx)
    dt = time.perf_counter() - t0
    note(f"stage {stage} done in {dt:.1f} s")
    return StageRecord(stage, "done", dt, outputs)


def _die_with_parent(parent: int) -> None:
    """A stage process ends when the run's process does (killed outright included), so nothing writes into DIR
    after the run is gone; the next command's recovery then rolls the folder back whole."""
    import ctypes
    import os
    import signal

    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG (Linux)
    except (AttributeError, OSError):
        pass
    if os.getppid() != parent:  # the run's process died before prctl took effect
        os._exit(1)


def _job_name(job) -> str:
    return job if isinstance(job, str) else job[0]


def _job_after(job) -> str | None:
    """The stage a job waits for (a figure drawn from that stage's files), or None."""
    return job[2] if not isinstance(job, str) and len(job) > 2 else None


#: the signals that stop a run (Ctrl-C, SIGTERM): blocked across the fork of a stage process
_STOP_SIGNALS = {signal.SIGINT, signal.SIGTERM}


def _stage_process(job, conn, parent: int, inp: RunInputs, out: Path, config, ctx: dict) -> None:
    """Body of a forked process: run the stage (or the deferred figure), send back its record or its exception."""
    import traceback

    _die_with_parent(parent)
    try:
        # the run forked this process with SIGTERM and SIGINT blocked (see _run_side_by_side); from here on a
        # stop request ends the stage like Ctrl-C, inside this try, and goes back to the run as an error
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _STOP_SIGNALS)
        if isinstance(job, str):
            msg = ("done", _run_one(job, inp, out, config, ctx))
        else:
            msg = ("drawn", job[1]())
    except BaseException as exc:  # noqa: BLE001 -- every failure goes back to the run's process
        msg = ("error", exc, traceback.format_exc())
    try:
        conn.send(msg)
    except Exception:  # an exception that does not pickle: its text goes back instead
        conn.send(("error", RuntimeError(f"{_job_name(job)} failed"), msg[-1]))
    conn.close()


def _run_side_by_side(jobs: list, workers: int, inp: RunInputs, out: Path, config,
                      ctx: dict) -> dict[str, StageRecord]:
    """Run ``jobs`` (stage names, or ``(label, function)`` for a figure of an earlier stage, or
    ``(label, function, stage)`` for a figure drawn from the files of ``stage``, one of ``jobs``) in up to
    ``workers`` forked processes at a time, each as soon as a process is free and the stage it waits for is done,
    in the order given (longest first). Returns the stages' records; what a figure's function returns (a dict) is
    gathered in ``ctx["drawn"]``.

    Each process is forked from this one as it stands after the motion stage, so every stage starts from the same
    state as in a sequential run. The first failure (or Ctrl-C, SIGTERM) stops the other processes before it is
    raised here, so the run's rollback (:class:`OutputJournal`) starts only when nothing writes into DIR any more.
    """
    import contextlib
    import multiprocessing
    import os
    import sys
    from multiprocessing.connection import wait

    mp = multiprocessing.get_context("fork")
    todo = list(jobs)
    running: dict = {}  # reader connection -> (job name, process)
    done: dict[str, StageRecord] = {}
    parent = os.getpid()
    try:
        while todo or running:
            while todo and len(running) < workers:
                ready = [j for j in todo if _job_after(j) is None or _job_after(j) in done]
                if not ready:
                    if not running:  # waits for a stage that is not among the jobs: a bug, not the user's
                        raise RuntimeError(f"{_job_name(todo[0])} waits for {_job_after(todo[0])}, which never runs")
                    break
                job = ready[0]
                todo.remove(job)
                for stream in (sys.stdout, sys.stderr):  # nothing buffered here is written twice by a child
                    with contextlib.suppress(Exception):
                        stream.flush()
                reader, writer = mp.Pipe(duplex=False)
                proc = mp.Process(target=_stage_process, name=f"bpmid-{_job_name(job)}",
                                  args=(job, writer, parent, inp, out, config, ctx), daemon=True)
                # a stop signal arriving while the child is still inside fork() would run this process's handler
                # in the child, on a copy of this stack (it would then act as the run): block them across the
                # fork; the child unblocks them once it is inside its own stage
                mask = signal.pthread_sigmask(signal.SIG_BLOCK, _STOP_SIGNALS)
                try:
                    proc.start()
                finally:
                    signal.pthread_sigmask(signal.SIG_SETMASK, mask)
                writer.close()
                running[reader] = (_job_name(job), proc)
            for reader in wait(list(running)):
                stage, proc = running.pop(reader)
                try:
                    msg = reader.recv()
                except EOFError:  # the process died without a word (killed, out of memory)
                    proc.join()
                    msg = ("error", RuntimeError(f"the process of {stage} ended with exit code "
                                                 f"{proc.exitcode} before finishing"), "")
                reader.close()
                proc.join()
                if msg[0] == "error":
                    exc = msg[1]
                    if not isinstance(exc, (InputError, KeyboardInterrupt)) and msg[2]:
                        exc.add_note(f"in the process of {stage}:\n{msg[2]}")
                    raise exc
                if msg[0] == "drawn":
                    if isinstance(msg[1], dict):  # the report's figures (the stages' own return their path)
                        ctx.setdefault("drawn", {}).update(msg[1])
                else:
                    done[stage] = msg[1]
    except BaseException:
        for stage, proc in running.values():
            proc.terminate()  # SIGTERM: the stage stops like on Ctrl-C (staged writes cleaned up)
        for stage, proc in running.values():
            proc.join(5.0)
            if proc.is_alive():
                proc.kill()
                proc.join()
        raise
    return done


def _run_stages(config, rc: RunConfig, inp: RunInputs, out: Path, ctx: dict, write_result) -> list[StageRecord]:
    out.mkdir(parents=True, exist_ok=True)
    stale = out / "run.yaml"
    if stale.is_file():
        stale.unlink()  # a folder with run.yaml holds a complete run; this one is about to be replaced
    records: dict[str, StageRecord] = {}
    todo = []
    for stage in STAGES:
        if stage not in rc.stages:
            records[stage] = StageRecord(stage, "skipped", note="not in run.stages")
            continue
        why = _missing_inputs(stage, inp)
        if why:
            note(f"{stage}: {why}")
            records[stage] = StageRecord(stage, "skipped", note=why)
            continue
        todo.append(stage)
    workers = stage_workers(rc)
    side = [s for s in SIDE_BY_SIDE if s in todo] if workers > 1 else []
    if len(side) < 2:
        side = []
    else:  # the relaxation and motion figures are drawn beside those stages, off the critical path
        ctx["deferred"] = []

    def so_far() -> list[StageRecord]:
        return [records[s] for s in STAGES if s in records]

    for stage in todo:
        if stage in side:
            if stage not in records:  # the first of them (they follow each other in STAGES): run them all now
                figures = ctx.pop("deferred", [])[::-1]  # the motion figure (the larger) first
                at = side.index("history") + 1 if "history" in side else len(side)
                of_relax, of_compare = _report_figure_jobs(out, side, records, todo, ctx)
                # longest first: the comparison's report figures (about 1 s) as soon as a process is free after
                # the comparison, the relaxation's (0.3 s) last
                jobs = [j for j in side[:at] + [of_compare] + figures + side[at:] + [of_relax] if j is not None]
                records.update(_run_side_by_side(jobs, workers, inp, out, config, ctx))
            continue
        if stage == "report":  # run.yaml first, so the report can show the stages
            _write_run_yaml(out, so_far() + [StageRecord("report", "running")], inp, config, ctx, write_result)
        records[stage] = _run_one(stage, inp, out, config, ctx)
    _write_run_yaml(out, so_far(), inp, config, ctx, write_result)
    return so_far()


def _report_figure_jobs(out: Path, side: list[str], records: dict, todo: list[str], ctx: dict) -> tuple:
    """The report's own figures, drawn beside the stages as soon as the files they are drawn from are written
    (the same drawing as in the report stage, which then only assembles the page): ``(of the relaxation fit, of
    the comparison)``, each a job of :func:`_run_side_by_side` or None (that stage did not run in this run, or
    not beside the others, or there is no report)."""
    from functools import partial

    if "report" not in todo:
        return None, None
    from bpmid.report.figures import stage_figures

    syn = ctx.get("stamp")   # the study's stamp, in the logs' own words (None: measured)
    of_relax = (("report figure of relax", partial(stage_figures, out, "relax", syn))
                if "relax" in records and records["relax"].status == "done" else None)
    of_compare = (("report figures of compare", partial(stage_figures, out, "compare", syn), "compare")
                  if "compare" in side else None)
    return of_relax, of_compare


def _write_run_yaml(out, records, inp, config, ctx, write_result) -> None:
    body = {"stages": [r.to_yaml() for r in records], "synthetic": bool(ctx["synthetic"]),
            "synthetic_stamp": ctx.get("stamp"),
            "data_logs": ctx["data_logs"],
            "test_sets": {s: [str(p) for p in v] for s, v in inp.test_sets.items()},
            "note": "seconds are wall-clock times on this machine; every other number is reproducible from the inputs"}
    write_result(out / "run.yaml", SCHEMA, body, _prov(inp.all() + inp.control_references, config, ctx["seed"], ctx["command"]))
