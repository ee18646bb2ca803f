"""Compare model families on the same logs: fit on training logs only, simulate free-running on test logs.

Works for every family in :data:`bpmid.models.REGISTRY` through the :class:`~bpmid.models.base.ModelFamily`
interface alone (``fit``, ``simulate``, ``n_params``, ``describe``); adding a family needs no change here.
Per-family constructor settings start from :data:`DEFAULT_OPTIONS` (baseline settings whose static parts
extrapolate sanely for a bending muscle, chosen on training data: see ``configs/compare_paper.yaml``) and are
overridden key by key by the config (``compare.options.<name>``); a family whose constructor takes a relaxation
fit (``vbmm-mat``) gets the one named by ``--relax`` or ``compare.relax``.

Outputs (the README's compare section): ``metrics.csv`` (one row per model and test log) and ``summary.csv`` (one row per model,
pooled over all test logs, ``log = ALL``), with ``model, log, rmse_deg, mape_pct, r2, fit_pct,
max_abs_err_deg, us_per_step, n_params``. Extra files: ``summary_by_set.csv`` (pooled per named test set),
``compare.yaml`` (fitted constants of every model, fit diagnostics, provenance), ``predictions/<log>.csv``
and the figures.

``us_per_step`` is a wall-clock measurement (best of ``timing_repeats`` free-running simulations of the
log after one warm-up run, divided by the number of samples); it is the only column that differs between
two runs of the same inputs. ``compare.timing: false`` leaves it empty for byte-identical files.
"""
from __future__ import annotations

import dataclasses
import glob
import os
import inspect
import sys
import time
import warnings
from pathlib import Path
from typing import Any, Mapping, Optional, Sequence

import numpy as np
import pandas as pd

from bpmid import metrics as M
from bpmid.errors import _IN_COMMAND, InputError
from bpmid.fitting import FitResult
from bpmid.io.motion_logs import MotionLog, is_synthetic, synthetic_line, synthetic_note
from bpmid.models import REGISTRY, model_class
from bpmid.progress import Progress, note

#: metrics.csv / summary.csv columns fixed by CLI.md, in this order
COLUMNS = ("model", "log", "rmse_deg", "mape_pct", "r2", "fit_pct", "max_abs_err_deg", "us_per_step", "n_params")
#: constructor keywords through which a family may receive a relaxation fit (a ``bpmid.relax/1`` path)
RELAX_KEYWORDS = ("relax_fit", "relax", "relax_path", "init")


class CompareWarning(UserWarning):
    """A comparison that runs but deserves a second look (e.g. a log in both the training and test sets)."""


@dataclasses.dataclass(frozen=True)
class CompareConfig:
    """Config section ``compare``.

    Attributes
    ----------
    models : registry names to compare (default: all registered families)
    train : training logs (paths or glob patterns, relative to the config file)
    test : test logs, or
    test_sets : named groups of test logs (``{variable_amplitude: [...], variable_rate: [...]}``); their
        metrics are also pooled per group in ``summary_by_set.csv``
    relax : relaxation fit (``bpmid.relax/1``) for families that start from one (vbmm-mat)
    options : per-family constructor settings, ``{gpi: {n_operators: 10}}``, over :data:`DEFAULT_OPTIONS`
    timing : measure ``us_per_step`` (false leaves it empty: byte-identical reruns)
    timing_repeats : timed free-running simulations per model and test log (best one counts)
    figure_logs : test logs drawn in the per-log figures (spread over the test sets)
    """

    models: tuple[str, ...] = ()
    train: tuple[str, ...] = ()
    test: tuple[str, ...] = ()
    test_sets: Mapping[str, tuple[str, ...]] = dataclasses.field(default_factory=dict)
    relax: Optional[str] = None
    options: Mapping[str, Mapping[str, Any]] = dataclasses.field(default_factory=dict)
    timing: bool = True
    timing_repeats: int = 3
    figure_logs: int = 4

    def validate(self, where, path):
        for i, name in enumerate(self.models):
            if name not in REGISTRY:
                raise InputError(f"unknown model {name!r} (known: {', '.join(REGISTRY)})", path=path,
                                 key=f"{where}.models[{i}]")
        dup = sorted({n for n in self.models if self.models.count(n) > 1})
        if dup:
            raise InputError(f"model {dup[0]!r} is listed twice", path=path, key=f"{where}.models")
        for name in self.options:
            if name not in REGISTRY:
                raise InputError(f"options for an unknown model (known: {', '.join(REGISTRY)})", path=path,
                                 key=f"{where}.options.{name}")
        if self.test and self.test_sets:
            raise InputError("give either test or test_sets, not both", path=path, key=f"{where}.test_sets")
        if self.timing_repeats < 1:
            raise InputError("timing_repeats must be at least 1", path=path, key=f"{where}.timing_repeats")
        if self.figure_logs < 0:
            raise InputError("figure_logs must be >= 0", path=path, key=f"{where}.figure_logs")


# --------------------------------------------------------------------------------------------------
# inputs
# --------------------------------------------------------------------------------------------------
def _base_hint(pat, base: Path | None) -> str:
    """What to add to 'not found' for a config's relative path: it is read from the config's folder, and when the
    path as written matches from the working directory instead, the path to write (relative to the config's
    folder)."""
    if base is None or Path(pat).is_absolute() or Path(base).resolve() == Path.cwd().resolve():
        return ""
    hint = f" (a path in a config is read relative to the config's folder, {base}"
    here = [h for h in glob.glob(str(pat)) if Path(h).is_file()]
    if here:
        fix = os.path.relpath(os.path.abspath(str(pat)), Path(base).resolve())
        hint += (f"; {pat} {'matches files' if len(here) > 1 else 'is a file'} from the working directory: write "
                 f"{fix}, or an absolute path")
    return hint + ")"


def expand_paths(patterns: Sequence[str | Path], *, base: Path | None = None, key: str | None = None,
                 config_path: Path | None = None) -> list[Path]:
    """Paths and glob patterns (relative to ``base``) -> sorted existing files; a pattern that matches
    nothing is an InputError naming ``key`` and the pattern."""
    single = isinstance(patterns, (str, Path))   # a key that holds one path is named without an index
    if single:
        patterns = [patterns]
    out: list[Path] = []
    for i, pat in enumerate(patterns):
        p = Path(pat)
        if base is not None and not p.is_absolute():
            p = Path(os.path.normpath(base / p))  # "configs/../datasets" -> "datasets" in messages and provenance
        k = (key if single else f"{key}[{i}]") if key else None
        if any(ch in str(pat) for ch in "*?["):
            hits = sorted(Path(h) for h in glob.glob(str(p)))
            hits = [h for h in hits if h.is_file()]
            if not hits:
                raise InputError(f"no file matches {p}" + _base_hint(pat, base), path=config_path, key=k)
            out.extend(hits)
        else:
            if not p.is_file():
                raise InputError(f"file not found: {p}" + _base_hint(pat, base), path=config_path, key=k)
            out.append(p)
    seen, uniq = set(), []
    for p in out:
        r = p.resolve()
        if r not in seen:
            seen.add(r)
            uniq.append(p)
    return uniq


#: the ``set`` of a test log that is also a training log in metrics.csv (scored, left out of every summary)
FITTED_SET = "fitted (not a test)"


def overlap_warnings(train: Sequence[MotionLog], test: Sequence[MotionLog]) -> list[str]:
    """Messages for test logs that are also training logs (same file, or identical content)."""
    return list(overlapping_logs(train, test).values())


def same_logs(train: Sequence[MotionLog], test: Sequence[MotionLog]) -> dict[str, tuple[str, bool]]:
    """Test log name -> (the training log it repeats, whether it is the same file), for test logs that are also
    training logs (the same file, or identical content under another name)."""
    def key(lg: MotionLog):
        return (lg.n, hash(np.asarray(lg.time_s).tobytes()), hash(np.asarray(lg.pressure_pa).tobytes()),
                hash(b"" if lg.angle_deg is None else np.asarray(lg.angle_deg).tobytes()))

    train_paths = {Path(lg.path).resolve(): lg.name for lg in train if lg.path is not None}
    train_keys = {key(lg): lg.name for lg in train}
    out = {}
    for lg in test:
        if lg.path is not None and Path(lg.path).resolve() in train_paths:
            out[lg.name] = (train_paths[Path(lg.path).resolve()], True)
        elif key(lg) in train_keys:
            out[lg.name] = (train_keys[key(lg)], False)
    return out


def near_copies(train: Sequence[MotionLog], test: Sequence[MotionLog],
                exact: Mapping[str, tuple[str, bool]] | None = None) -> dict[str, str]:
    """Test log name -> a warning, for test logs (not exact copies: :func:`same_logs`) that repeat a training
    log's samples within rounding: a re-export of it (time shifted or in other units, pressure in other units,
    rows dropped) whose score tests nothing, or a replicate of a rig whose noise is below its sensors' resolution.
    Said, not set aside: bpmid cannot tell the two apart. ``exact``: :func:`same_logs` of the two, when the caller
    has it already."""
    exact = same_logs(train, test) if exact is None else exact
    out = {}
    for lg in test:
        if lg.name in exact:
            continue
        other = next((tr.name for tr in train if _same_samples(tr, lg)), None)
        if other is not None:
            out[lg.name] = (f"test log {lg.name} repeats training log {other} within rounding on at least "
                            f"{100 * SAME_DATA_SHARE:.0f} % of its samples: a re-export of it (then its score tests "
                            "nothing: give a log the models were not fitted on), or a replicate whose noise is "
                            "below the sensors' resolution (then it is a test as any)")
    return out


#: share of a log's samples that must repeat another's (time from its first sample, gauge pressure and angle
#: within rounding) for the two to count as the same data
SAME_DATA_SHARE = 0.9


def _resolution(x: np.ndarray) -> float:
    """The finest step between distinct values of a column (its written resolution, e.g. 0.1 deg or 1 kPa)."""
    d = np.diff(np.unique(np.asarray(x, float)))
    return float(np.min(d)) if d.size else 0.0


def _same_samples(a: MotionLog, b: MotionLog) -> bool:
    """Whether ``b`` repeats ``a``'s data re-exported: time in other units, shifted or cut at the start (aligned on
    one of ``a``'s samples that ``b``'s first one repeats), pressure in other units or references (compared as gauge
    Pa), rows dropped, values rounded as exports round them (0.2 % of the range, or the coarser of the two columns'
    written resolutions); at least :data:`SAME_DATA_SHARE` of ``b``'s samples must find their twin in ``a``."""
    if a.angle_deg is None or b.angle_deg is None or b.n < 3 or a.n < 3 or b.n > 1.2 * a.n:
        return False
    ta0, tb0 = np.asarray(a.time_s, float), np.asarray(b.time_s, float)
    pa, pb = np.asarray(a.pressure_pa, float), np.asarray(b.pressure_pa, float)
    aa, ab = np.asarray(a.angle_deg, float), np.asarray(b.angle_deg, float)
    tol_p = max(2e-3 * max(float(np.ptp(pa)), 1e-9), 0.51 * max(_resolution(pa), _resolution(pb)))
    tol_a = max(2e-3 * max(float(np.ptp(aa)), 1e-9), 0.51 * max(_resolution(aa), _resolution(ab)))
    dt = float(np.median(np.diff(ta0)))
    res_b = _resolution(tb0 - tb0[0])   # b's time as written (0.01 s, whole ms): its rounding is no difference
    tol_t = max(1e-3 * dt, 0.51 * res_b if res_b < 0.5 * dt else 0.0)
    starts = np.flatnonzero((np.abs(pa - pb[0]) <= tol_p) & (np.abs(aa - ab[0]) <= tol_a))[:20]
    for k in starts:   # b's first sample is a's k-th (a cut start), else nothing aligns
        ta, tb = ta0 - ta0[k], tb0 - tb0[0]
        j = np.clip(np.searchsorted(ta, tb), 1, ta.size - 1)
        j = np.where(np.abs(ta[j - 1] - tb) < np.abs(ta[j] - tb), j - 1, j)
        same = (np.abs(ta[j] - tb) <= tol_t) & (np.abs(pa[j] - pb) <= tol_p) & (np.abs(aa[j] - ab) <= tol_a)
        if np.mean(same) >= SAME_DATA_SHARE:
            return True
    return False


def overlapping_logs(train: Sequence[MotionLog], test: Sequence[MotionLog],
                     exact: Mapping[str, tuple[str, bool]] | None = None) -> dict[str, str]:
    """Test log name -> message, for test logs that are also training logs (same file, or identical content)."""
    apart = (f": its score is not a test of prediction; metrics.csv keeps it as set '{FITTED_SET}', left out of "
             "the summaries and the ranking")
    paths = {lg.name: lg.path for lg in test}
    return {name: (f"test log {paths[name]} is also a training log" if same_file else
                   f"test log {name} has the same data as training log {other}") + apart
            for name, (other, same_file) in (same_logs(train, test) if exact is None else exact).items()}


def check_test_logs(test: Sequence[MotionLog]) -> None:
    if not test:
        raise InputError("no test logs", key="--test")
    for lg in test:
        if lg.angle_deg is None:
            raise InputError("a test log needs an angle_deg column to be scored", path=lg.path)
        if lg.n < 3:
            raise InputError(f"a test log needs at least 3 samples, found {lg.n}", path=lg.path)


#: compare's per-family settings unless the config says otherwise. The library defaults of the baselines
#: follow their papers (contracting McKibben muscles, friction); for pressure in, bending angle out and test
#: logs beyond the training pressures, these give each a static part that extrapolates sanely. Maxwell-slip's
#: loop orientation is chosen on the training data (``auto``): a muscle's angle lags its pressure (``lag``, as
#: on the shipped logs), but data in the seeds' leading form fitted with ``lag`` collapse to k_i = 0 (no
#: hysteresis at all). Reasons and the training-set numbers: configs/compare_paper.yaml.
DEFAULT_OPTIONS: dict[str, dict[str, Any]] = {
    "gpi": {"envelope": "linear", "monotone": True},
    "maxwell-slip": {"orientation": "auto", "poly_degree": 1, "monotone": True},
    "three-element": {"static": "linear"},
    "two-branch": {"branch": "linear"},
}


def effective_options(name: str, options: Mapping[str, Any] | None) -> dict[str, Any]:
    """:data:`DEFAULT_OPTIONS` of ``name`` overridden key by key by ``options`` (the config's)."""
    out = dict(DEFAULT_OPTIONS.get(name, {}))
    out.update(dict(options or {}))
    return out


def build_model(name: str, options: Mapping[str, Any] | None = None, relax_fit: str | Path | None = None,
                config=None):
    """An instance of the family ``name`` with its constructor settings (``compare.options.<name>``).

    Shared context reaches a family only through constructor keywords it declares: a relaxation fit
    (``relax_fit``, for vbmm-mat and vbmm-fit; InputError when a family requires one and none was given)
    and the loaded ``config`` (for families with config sections of their own).
    """
    cls = model_class(name)
    kw = dict(options or {})
    try:
        sig = inspect.signature(cls)
    except (TypeError, ValueError):  # pragma: no cover - builtins only
        sig = None
    if sig is not None:
        for word in RELAX_KEYWORDS:
            if word in sig.parameters and word not in kw:
                par = sig.parameters[word]
                if relax_fit is not None:
                    kw[word] = Path(relax_fit)
                elif par.default is inspect.Parameter.empty:
                    raise InputError(f"model {name} starts from a relaxation fit: give --relax FIT.yaml "
                                     "(or compare.relax in the config)", key="--relax")
                break
        if "config" in sig.parameters and "config" not in kw and config is not None:
            kw["config"] = config
        unknown = [k for k in kw if k not in sig.parameters
                   and not any(p.kind == p.VAR_KEYWORD for p in sig.parameters.values())]
        if unknown:
            known = [p for p in sig.parameters if p not in ("self", "config") + RELAX_KEYWORDS]
            raise InputError(f"model {name} has no setting {unknown[0]!r} (known: {', '.join(known) or 'none'})",
                             path=getattr(config, "path", None), key=f"compare.options.{name}.{unknown[0]}")
    cpath = getattr(config, "path", None)
    try:
        return cls(**kw)
    except InputError as exc:   # a family names its own argument: say where the user wrote it
        key = exc.key if exc.key and exc.key.startswith("compare.") or exc.key == "--relax" else \
            f"compare.options.{name}" + (f".{exc.key}" if exc.key else "")
        raise InputError(f"model {name}: {exc.message}", path=exc.path or cpath, key=key) from None
    except (TypeError, ValueError) as exc:
        raise InputError(f"model {name}: {exc}", path=cpath, key=f"compare.options.{name}") from exc


# --------------------------------------------------------------------------------------------------
# the comparison
# --------------------------------------------------------------------------------------------------
@dataclasses.dataclass
class ModelOutcome:
    """One family fitted on the training logs and run on every test log."""

    name: str
    label: str
    model: Any
    fit: FitResult
    fit_seconds: float
    predictions: dict[str, np.ndarray]
    us_per_step: dict[str, float]

    @property
    def n_params(self) -> int:
        return int(self.model.n_params(self.fit.params))


@dataclasses.dataclass
class CompareResult:
    """Everything a comparison produced (tables are pandas DataFrames with the CLI.md columns first)."""

    outcomes: list[ModelOutcome]
    train: list[MotionLog]
    test: list[MotionLog]
    sets: dict[str, list[str]]
    metrics: pd.DataFrame
    summary: pd.DataFrame
    by_set: pd.DataFrame
    warnings: list[str]

    def outcome(self, name: str) -> ModelOutcome:
        for o in self.outcomes:
            if o.name == name:
                return o
        raise KeyError(name)


def time_simulation(model, params, log: MotionLog, repeats: int) -> float:
    """Best wall-clock seconds of ``repeats`` simulations of ``log`` (after the caller's warm-up run)."""
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        model.simulate(params, log)
        best = min(best, time.perf_counter() - t0)
    return float(best)


def _metric_row(model: str, log: str, y, y_hat, us: float, n_params: int) -> dict:
    s = M.summary(y, y_hat, unit="deg")
    return {"model": model, "log": log, "rmse_deg": s["rmse_deg"], "mape_pct": s["mape_pct"], "r2": s["r2"],
            "fit_pct": s["fit_pct"], "max_abs_err_deg": s["max_abs_err_deg"], "us_per_step": us,
            "n_params": int(n_params)}


def _pooled(outcomes, logs, names, label, timing) -> list[dict]:
    rows = []
    by_name = {lg.name: lg for lg in logs}
    for o in outcomes:
        y = np.concatenate([by_name[n].angle_deg for n in names])
        yh = np.concatenate([o.predictions[n] for n in names])
        if timing:
            steps = sum(by_name[n].n for n in names)
            us = sum(o.us_per_step[n] * by_name[n].n for n in names) / steps
        else:
            us = float("nan")
        rows.append(_metric_row(o.name, label, y, yh, us, o.n_params))
    return rows


def compare_models(train: Sequence[MotionLog], test: Sequence[MotionLog], models: Sequence[str], *,
                   sets: Mapping[str, Sequence[str]] | None = None, options: Mapping[str, Mapping] | None = None,
                   relax_fit: str | Path | None = None, config=None, timing: bool = True, timing_repeats: int = 3,
                   fit_kw: Mapping[str, Any] | None = None) -> CompareResult:
    """Fit every family in ``models`` on ``train`` only and simulate it free-running on every ``test`` log.

    Parameters
    ----------
    train, test : motion logs (test logs need ``angle_deg``)
    models : registry names (checked)
    sets : test-set name -> test log names (default: one set ``test`` with every test log)
    options : registry name -> constructor settings
    relax_fit : ``bpmid.relax/1`` file for families that start from a relaxation fit
    config : the loaded :class:`bpmid.config.Config`, for families whose constructor takes one
    timing : measure the cost per simulated step (``us_per_step``)
    timing_repeats : timed runs per model and log (the fastest counts)

    Returns
    -------
    CompareResult ; overlapping train/test logs are reported in ``warnings`` and as a
    :class:`CompareWarning`.
    """
    models = list(models)
    if not models:
        raise InputError("no models to compare", key="--models")
    for n in models:
        model_class(n)  # unknown names fail before any work
    check_test_logs(test)
    from bpmid.io.motion_logs import check_distinct_names

    check_distinct_names(test, key="--test")
    names = [lg.name for lg in test]
    sets = {k: list(v) for k, v in (sets or {"test": names}).items()}
    exact = same_logs(train, test)
    fitted_too = overlapping_logs(train, test, exact)
    warn = list(fitted_too.values()) + list(near_copies(train, test, exact).values())
    if fitted_too and len(fitted_too) == len(test):
        raise InputError("every test log is also a training log (the same file or the same data): nothing would "
                         "test prediction; give test logs the models are not fitted on", key="--test")
    for w in warn:   # a command (bpmid compare, the run's compare stage) says them as its other warnings
        if _IN_COMMAND.get():
            print(f"warning: {w}", file=sys.stderr, flush=True)
        else:
            warnings.warn(w, CompareWarning, stacklevel=2)
    # a log the models were fitted on tests nothing: out of every pooled score and set (kept, marked, in metrics)
    names = [n for n in names if n not in fitted_too]
    sets = {k: [n for n in v if n not in fitted_too] for k, v in sets.items()}
    sets = {k: v for k, v in sets.items() if v}
    options = options or {}
    outcomes: list[ModelOutcome] = []
    for name in models:
        model = build_model(name, effective_options(name, options.get(name)), relax_fit, config)
        note(f"compare: fitting {name} on {len(train)} training log(s)")
        t0 = time.perf_counter()
        fit = model.fit(list(train), **dict(fit_kw or {}))
        fit_s = time.perf_counter() - t0
        preds, cost = {}, {}
        with Progress(len(test), f"compare: {name} on test logs") as pr:
            for lg in test:
                y_hat = np.asarray(model.simulate(fit.params, lg), float)
                if y_hat.shape != (lg.n,):
                    raise RuntimeError(f"{name}.simulate returned shape {y_hat.shape} for {lg.n} samples")
                preds[lg.name] = y_hat
                cost[lg.name] = (1e6 * time_simulation(model, fit.params, lg, timing_repeats) / lg.n
                                 if timing else float("nan"))
                pr.advance(detail=lg.name)
        outcomes.append(ModelOutcome(name, getattr(model, "label", "") or name, model, fit, fit_s, preds, cost))
        for w in _step_warnings(name, model, fit, train, test):   # as bpmid predict says it for a fit file
            warn.append(w)
            if _IN_COMMAND.get():
                print(f"warning: {w}", file=sys.stderr, flush=True)
            else:
                warnings.warn(w, CompareWarning, stacklevel=2)
    rows = [_metric_row(o.name, lg.name, lg.angle_deg, o.predictions[lg.name], o.us_per_step[lg.name], o.n_params)
            for o in outcomes for lg in test]
    metrics = pd.DataFrame(rows, columns=list(COLUMNS))
    set_of = {n: s for s, ns in sets.items() for n in ns}
    set_of.update({n: FITTED_SET for n in fitted_too})
    metrics["set"] = [set_of.get(lg, "") for lg in metrics["log"]]
    summary = pd.DataFrame(_pooled(outcomes, test, names, "ALL", timing), columns=list(COLUMNS))
    summary = summary.sort_values(["rmse_deg", "model"], kind="mergesort").reset_index(drop=True)
    summary["rank"] = np.arange(1, len(summary) + 1)
    by_set = []
    for s, ns in sets.items():
        for r in _pooled(outcomes, test, ns, s, timing):
            r["set"] = s
            by_set.append(r)
    by_set = pd.DataFrame(by_set, columns=list(COLUMNS) + ["set"])
    return CompareResult(outcomes, list(train), list(test), sets, metrics, summary, by_set, warn)


def _step_warnings(name: str, model, fit: FitResult, train: Sequence[MotionLog], test: Sequence[MotionLog]) -> list:
    """For a VBMM refitted on the training logs: each test log sampled at another step than they were, by enough to
    move the model (:func:`bpmid.models.vbmm.rig.step_warnings`, the check ``bpmid predict`` makes on a fit file)."""
    from bpmid.models.vbmm.family import VBMMFitModel
    from bpmid.models.vbmm.rig import step_warnings

    if not isinstance(model, VBMMFitModel):
        return []
    steps = [{"step_s": float(np.median(np.diff(lg.time_s)))} for lg in train if lg.n > 1]
    return [f"{name}: {w}" for w in step_warnings(test, {"fit": {"logs": steps}}, model.vbmm(fit.params).material)]


# --------------------------------------------------------------------------------------------------
# verdicts a person reads
# --------------------------------------------------------------------------------------------------
def is_vbmm(name: str) -> bool:
    return name.startswith("vbmm")


def rate_independent(name: str) -> bool | None:
    """Whether the family is rate-independent (class attribute ``rate_independent``), None if unknown."""
    cls = model_class(name)
    val = getattr(cls, "rate_independent", None)
    return None if val is None else bool(val)


def verdicts(result_or_tables) -> list[str]:
    """Plain sentences: the ranking, and for every test set where a baseline beats the best VBMM, that it does."""
    if isinstance(result_or_tables, CompareResult):
        summary, by_set = result_or_tables.summary, result_or_tables.by_set
    else:
        summary, by_set = result_or_tables
    out = []
    ranked = summary.sort_values("rmse_deg", kind="mergesort")
    out.append("Ranking by pooled test RMSE: " + ", ".join(
        f"{i + 1}. {r.model} ({r.rmse_deg:.3f} deg)" for i, r in enumerate(ranked.itertuples())))
    groups = [("all test logs", ranked)]
    if by_set is not None and by_set["set"].nunique() > 1:
        groups += [(s, g.sort_values("rmse_deg", kind="mergesort")) for s, g in by_set.groupby("set", sort=False)]
    for label, g in groups:
        vb = g[[is_vbmm(m) for m in g["model"]]]
        base = g[[not is_vbmm(m) for m in g["model"]]]
        if vb.empty or base.empty:
            continue
        best_vb, best_base = vb.iloc[0], base.iloc[0]
        if best_base.rmse_deg < best_vb.rmse_deg:
            out.append(f"On {label}, the baseline {best_base.model} ({best_base.rmse_deg:.3f} deg) beats the best "
                       f"VBMM variant {best_vb.model} ({best_vb.rmse_deg:.3f} deg).")
        else:
            out.append(f"On {label}, the best VBMM variant {best_vb.model} ({best_vb.rmse_deg:.3f} deg) is not beaten "
                       f"by any baseline (best: {best_base.model}, {best_base.rmse_deg:.3f} deg).")
        for other in vb.iloc[1:].itertuples():
            if best_base.rmse_deg < other.rmse_deg:
                out.append(f"On {label}, the baseline {best_base.model} ({best_base.rmse_deg:.3f} deg) beats the VBMM "
                           f"variant {other.model} ({other.rmse_deg:.3f} deg).")
    return out


# --------------------------------------------------------------------------------------------------
# writing
# --------------------------------------------------------------------------------------------------
def _csv(df: pd.DataFrame) -> str:
    return df.to_csv(index=False, lineterminator="\n", float_format="%.10g", na_rep="")


def predictions_frame(result: CompareResult, log: MotionLog) -> pd.DataFrame:
    df = pd.DataFrame({"time_s": log.time_s, "pressure_pa_gauge": log.pressure_pa, "angle_deg": log.angle_deg})
    for o in result.outcomes:
        df[f"pred_{o.name}_deg"] = o.predictions[log.name]
    return df


def figure_logs(result: CompareResult, n: int) -> list[MotionLog]:
    """Up to ``n`` test logs for the per-log figures: shared out over the test sets, and within a set spread
    evenly over its (sorted) logs, so that different protocols of a set are shown rather than replicates."""
    by_name = {lg.name: lg for lg in result.test}
    sets = [list(v) for v in result.sets.values() if v]
    quota = [0] * len(sets)
    k = 0
    while sum(quota) < n and any(q < len(v) for q, v in zip(quota, sets)):
        if quota[k % len(sets)] < len(sets[k % len(sets)]):
            quota[k % len(sets)] += 1
        k += 1
    chosen: list[str] = []
    for q, names in zip(quota, sets):
        if q:
            idx = np.unique(np.round(np.linspace(0, len(names) - 1, q)).astype(int))
            chosen += [names[i] for i in idx]
    return [by_name[c] for c in chosen]


def compare_yaml_body(result: CompareResult, relax_fit=None) -> dict:
    models = {}
    for o in result.outcomes:
        d = o.model.describe(o.fit.params)
        d["fit"] = o.fit.uncertainty_yaml()
        d["fit"]["rmse_train_deg"] = o.fit.rmse
        d["fit_seconds"] = round(o.fit_seconds, 3)
        models[o.name] = d
    return {
        "train": [str(lg.path or lg.name) for lg in result.train],
        "test_sets": {s: list(v) for s, v in result.sets.items()},
        "relax_fit": None if relax_fit is None else str(relax_fit),
        "warnings": list(result.warnings),
        "verdicts": verdicts(result),
        "models": models,
        # which logs say they are synthetic (a comparison mixing them with measured logs is not 'synthetic')
        "synthetic_logs": sorted({lg.name for lg in list(result.train) + list(result.test) if is_synthetic([lg])}),
    }


def write_compare(result: CompareResult, out_dir: str | Path, prov: dict, *, relax_fit=None,
                  n_figure_logs: int = 4, synthetic: bool | None = None) -> Path:
    """Write the tables, ``compare.yaml``, predictions and figures into ``out_dir`` (staged: all or nothing).

    ``synthetic``: None (default) reads it from the logs (``compare.yaml``'s ``synthetic`` when every log is, each
    figure stamped by the logs it draws, a mix said as such); False stamps nothing."""
    from bpmid.io.atomic import staged_dir, write_text
    from bpmid.io.results import write_result
    from bpmid.plots import compare as P
    from bpmid.plots.common import save_figure

    out_dir = Path(out_dir)
    with staged_dir(out_dir) as tmp:
        write_text(tmp / "metrics.csv", _csv(result.metrics))
        write_text(tmp / "summary.csv", _csv(result.summary))
        write_text(tmp / "summary_by_set.csv", _csv(result.by_set))
        for lg in result.test:   # a synthetic log's predictions say so, as predict's do
            write_text(tmp / "predictions" / f"{lg.name}.csv", synthetic_line(lg) + _csv(predictions_frame(result, lg)))
        body = compare_yaml_body(result, relax_fit)
        body["synthetic"] = is_synthetic(list(result.train) + list(result.test)) if synthetic is None else bool(synthetic)
        write_result(tmp / "compare.yaml", "bpmid.compare/1", body, prov)
        logs = figure_logs(result, n_figure_logs)
        # each figure is stamped by the logs it draws (a mix of measured and synthetic logs says so); a caller's
        # synthetic=False (the library's own arrays) stamps nothing
        if logs:
            note = synthetic_note(logs) if synthetic is not False else None
            save_figure(P.time_series(result, logs, synthetic=note), tmp / "compare_timeseries.png")
            save_figure(P.loops(result, logs, synthetic=note), tmp / "compare_loops.png")
            save_figure(P.errors(result, logs, synthetic=note), tmp / "compare_errors.png")
        note = synthetic_note(list(result.train) + list(result.test)) if synthetic is not False else None
        save_figure(P.summary_bars(result.summary, result.by_set, synthetic=note), tmp / "compare_summary.png")
    return out_dir


# --------------------------------------------------------------------------------------------------
# the whole command
# --------------------------------------------------------------------------------------------------
def resolve_inputs(cfg: CompareConfig, config=None, *, train=None, test=None, relax=None):
    """Training paths, named test sets (``{name: [paths]}``) and the relaxation fit, from the command line
    where given, else from the config section ``compare`` (paths relative to the config file)."""
    base = None if config is None or config.path is None else config.base_dir
    cpath = None if config is None else config.path
    if train:
        train_paths = expand_paths(train, key="--train")
    elif cfg.train:
        train_paths = expand_paths(cfg.train, base=base, key="compare.train", config_path=cpath)
    else:
        raise InputError("no training logs: give --train LOG... (or compare.train in the config)", key="--train")
    if test:
        test_sets = {"test": expand_paths(test, key="--test")}
    elif cfg.test_sets:
        test_sets = {s: expand_paths(v, base=base, key=f"compare.test_sets.{s}", config_path=cpath)
                     for s, v in cfg.test_sets.items()}
    elif cfg.test:
        test_sets = {"test": expand_paths(cfg.test, base=base, key="compare.test", config_path=cpath)}
    else:
        raise InputError("no test logs: give --test LOG... (or compare.test in the config)", key="--test")
    if relax is not None:
        relax_path = Path(relax)
        if not relax_path.is_file():
            raise InputError("relaxation fit not found", path=relax_path, key="--relax")
    elif cfg.relax is not None:
        relax_path = config.resolve_path(cfg.relax) if config is not None else Path(cfg.relax)
        if not relax_path.is_file():
            raise InputError(f"relaxation fit not found: {relax_path}", path=cpath, key="compare.relax")
    else:
        relax_path = None
    return train_paths, test_sets, relax_path


def compare_files(train_paths: Sequence[Path], test_sets: Mapping[str, Sequence[Path]], *,
                  models: Sequence[str] | None = None, config=None, relax_fit: str | Path | None = None,
                  prov_command: str | None = None) -> tuple[CompareResult, dict, dict]:
    """Read the logs and compare the models; nothing is written.

    Returns ``(result, provenance, how)`` where ``how`` holds the keyword arguments of :func:`write_compare`
    (``relax_fit``, ``n_figure_logs``, ``synthetic``).

    Parameters
    ----------
    train_paths : training motion logs
    test_sets : test-set name -> motion logs
    models : registry names; default ``compare.models`` of the config, else every registered family
    config : a loaded :class:`bpmid.config.Config` (sections ``io`` and ``compare``) or None
    relax_fit : relaxation fit for families that start from one
    """
    from bpmid.config import load_config
    from bpmid.io.motion_logs import read_motion_logs
    from bpmid.io.results import provenance

    config = config if config is not None else load_config(None)
    cfg: CompareConfig = config.section("compare")
    io_cfg = config.section("io")
    models = list(models or cfg.models or REGISTRY)
    for n in models:
        model_class(n)
    train = read_motion_logs(list(train_paths), io_cfg, require_angle=True)
    all_test_paths = [p for v in test_sets.values() for p in v]
    test = read_motion_logs(all_test_paths, io_cfg, require_angle=True)
    by_path = {}
    for p, lg in zip(all_test_paths, test):
        by_path[str(p)] = lg.name
    sets = {s: [by_path[str(p)] for p in v] for s, v in test_sets.items()}
    result = compare_models(train, test, models, sets=sets, options=cfg.options, relax_fit=relax_fit,
                            config=config, timing=cfg.timing, timing_repeats=cfg.timing_repeats)
    inputs = list(train_paths) + all_test_paths + ([Path(relax_fit)] if relax_fit is not None else [])
    from bpmid.io import plausibility as plaus
    warnings = plaus.log_warnings(train + test) + plaus.compare_warnings(result.summary)
    plaus.emit(warnings, strict=io_cfg.strict, what="the comparison", key=plaus.strict_key(io_cfg))
    prov = plaus.attach(provenance(inputs, config=config, command=prov_command), train + test, warnings)
    return result, prov, {"relax_fit": relax_fit, "n_figure_logs": cfg.figure_logs}


def run_compare(train_paths: Sequence[Path], test_sets: Mapping[str, Sequence[Path]], out_dir: str | Path, *,
                models: Sequence[str] | None = None, config=None, relax_fit: str | Path | None = None,
                prov_command: str | None = None) -> CompareResult:
    """What ``bpmid compare`` does (and the compare stage of ``bpmid run``): read the logs, compare
    (:func:`compare_files`), write everything into ``out_dir`` (:func:`write_compare`)."""
    result, prov, how = compare_files(train_paths, test_sets, models=models, config=config, relax_fit=relax_fit,
                                      prov_command=prov_command)
    write_compare(result, out_dir, prov, **how)
    return result

# ``bpmid.compare(...)`` is the public workflow (bpmid.api.compare); this module stays importable as before
from bpmid._callable import make_callable as _make_callable  # noqa: E402

_make_callable(__name__, "bpmid.api:compare")
