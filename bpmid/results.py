"""One result protocol for every workflow (relaxation fit, VBMM fit, prediction, comparison, discovery,
simulation, control).

A :class:`Result` is what a workflow's file says, held in memory: its ``schema`` (``bpmid.<kind>/1``), its
``body`` (the file's keys, plain YAML types) and its ``provenance``. The live objects a workflow built (fitted
model, arrays of every trace) ride along as ``raw`` where the result was computed in this process; they make
``plot()`` richer and let ``save`` write the same figures and tables the CLI writes, but they are not part of the
result's identity: ``bpmid.load(result.save(path)) == result``.

Every result offers

- ``params``: the named constants (value, stderr, unit, identifiability) -> :class:`Parameters`
- ``metrics``: the fit statistics (a flat dict, units in the key names)
- ``correlations(threshold)``: pairs of estimated parameters correlated beyond ``threshold``
- ``warnings``: what the workflow warned about
- ``summary()``: a plain-text report in the spirit of lmfit's ``fit_report``
- ``_repr_html_()``: the same for notebooks; ``repr()`` is one line
- ``plot()``: a matplotlib Figure (matplotlib is imported only here)
- ``save(path)``: the file(s) the CLI writes, with provenance; ``to_dict()`` the file's mapping

Adding a workflow: a subclass with ``kind`` (and ``main_file`` when it writes a folder) plus the few properties
it can answer; :data:`KINDS` finds it by schema.
"""
from __future__ import annotations

import dataclasses
import html
import math
from pathlib import Path
from typing import Any, ClassVar, Iterator, Mapping

from bpmid.errors import InputError


# --------------------------------------------------------------------------------------------------
# parameters
# --------------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class ParamInfo:
    """One reported constant.

    Attributes
    ----------
    name : the parameter's name (``K_inf``, ``tau_1``, ``gpi.w_1`` ...)
    value : in ``unit``
    stderr : standard error in ``unit`` (None: not estimated, fixed, or not identifiable)
    unit : unit string (``Pa``, ``s``, ``deg``, ``bar/deg`` ...)
    identifiability : ``estimated``, ``fixed ...``, ``not identifiable: ...`` or ``""`` when not judged
    note : what else the file says of it, e.g. that its standard error is conditional on a held constant
    """

    name: str
    value: float
    stderr: float | None = None
    unit: str = ""
    identifiability: str = ""
    note: str = ""

    @property
    def rel_stderr(self) -> float | None:
        if self.stderr is None or not self.value:
            return None
        return abs(self.stderr / self.value)


class Parameters(Mapping[str, ParamInfo]):
    """Named parameters in order (a read-only mapping name -> :class:`ParamInfo`)."""

    def __init__(self, items=()):
        self._items: dict[str, ParamInfo] = {p.name: p for p in items}

    def __getitem__(self, name: str) -> ParamInfo:
        try:
            return self._items[name]
        except KeyError:
            raise KeyError(f"no parameter {name!r} (known: {', '.join(self._items) or 'none'})") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)

    def values(self):  # noqa: D102 - the ParamInfo objects, in order
        return list(self._items.values())

    def valuesdict(self) -> dict[str, float]:
        """name -> value (lmfit's name for it)."""
        return {k: p.value for k, p in self._items.items()}

    def table(self) -> str:
        """Aligned text table: name, value, stderr (and %), unit, identifiability."""
        if not self._items:
            return "    (none)"
        from bpmid.identifiability import conditional_caveat

        w = max(len(n) for n in self._items)
        lines = []
        for p in self._items.values():
            se = "" if p.stderr is None else f" +/- {p.stderr:.4g}"
            rel = p.rel_stderr
            se += "" if rel is None else f" ({100 * rel:.2f}%)"
            ident = f"  [{p.identifiability}]" if p.identifiability else ""
            caveat = conditional_caveat(p.note)   # an estimate's standard error that assumes a held constant
            if caveat:
                ident += f"  ({caveat})"
            lines.append(f"    {p.name:<{w}} = {_num(p.value):>12}{se} {p.unit}{ident}")
        return "\n".join(lines)

    def __repr__(self) -> str:
        return f"Parameters({', '.join(f'{k}={_num(p.value)} {p.unit}'.strip() for k, p in self._items.items())})"


def _num(v) -> str:
    if v is None:
        return "None"
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return str(v)
    return f"{v:.6g}"


def _verdict_of(entry: Mapping) -> str:
    """The identifiability an entry states itself (``fixed``, ``identifiable``, ``note``), in the words of
    :attr:`ParamInfo.identifiability`; "" when it states none."""
    note = str(entry.get("note") or "")
    if entry.get("identifiable") is False:
        return note if note.startswith("not identifiable") else ("not identifiable" + (f": {note}" if note else ""))
    if entry.get("fixed"):
        return "fixed" + (f": {note}" if note else "")
    if entry.get("identifiable") is True:
        return "estimated"
    return ""


def _effect_unit(effect_id: str, name: str) -> str:
    """The unit of catalogue effect ``effect_id``'s constant ``name`` ("" when the catalogue does not know it): for
    an effects-list entry written as a bare number."""
    from bpmid.effects import CATALOGUE, get_effect

    if effect_id not in CATALOGUE:
        return ""
    try:
        return get_effect(effect_id).default_params()[f"{effect_id}.{name}"].unit
    except (KeyError, TypeError, ValueError, InputError):
        return ""


def _entry(name: str, entry, unit: str = "", identifiability: str = "") -> ParamInfo:
    """A ParamInfo from a ``{value, stderr, unit}`` entry or a bare number."""
    if isinstance(entry, Mapping):
        se = entry.get("stderr")
        return ParamInfo(name, float(entry.get("value")), None if se is None else float(se),
                         str(entry.get("unit", unit) or unit), identifiability or _verdict_of(entry),
                         str(entry.get("note") or ""))
    return ParamInfo(name, float(entry), None, unit, identifiability)


# --------------------------------------------------------------------------------------------------
# the base class
# --------------------------------------------------------------------------------------------------
def _normalised(data: dict) -> dict:
    """``data`` as it reads back from its YAML file (plain types: str keys, lists, NaN -> None), so equality
    survives save/load. Computed directly rather than by a YAML round trip, which cost ~0.8 s on a fit of a
    481-point master curve (tests/test_api.py checks both agree on every result type)."""
    from bpmid.io.results import _plain

    def plain(v):  # on the output of _plain (plain types already): one pass, no second conversion per node
        if isinstance(v, dict):
            return {k: plain(x) for k, x in v.items()}
        if isinstance(v, list):
            return [plain(x) for x in v]
        if isinstance(v, float) and v != v:  # a NaN numpy scalar: _plain's .item() leaves it a float
            return None
        if isinstance(v, str) and not v.isprintable():  # YAML folds some line breaks (\x85, \r): as it reads back
            from bpmid.io.results import dump_yaml
            from bpmid.io.yamlsafe import loads

            return loads(dump_yaml({"v": v}))["v"]
        return v

    return plain(_plain(data)) or {}


def _guarded_save(save):
    """``save`` run so that no file it writes replaces one of the result's inputs (as every CLI command runs:
    :func:`bpmid.io.atomic.guard_inputs`); inside a command's own guard, as it is."""
    import functools

    @functools.wraps(save)
    def wrapper(self, path, *a, **kw):
        from bpmid.io.atomic import _guard, guard_inputs

        if _guard() is not None:
            return save(self, path, *a, **kw)
        # the inputs by content (their recorded sha256), not by the path as written: a path recorded relative to
        # the folder a command ran in names another file from here
        with guard_inputs((), hashes=self.input_hashes()), _kept_rc():
            return save(self, path, *a, **kw)

    return wrapper


def _guarded_plot(plot):
    """``plot`` run so that the caller's matplotlib settings come back after bpmid's house style drew."""
    import functools

    @functools.wraps(plot)
    def wrapper(self, *a, **kw):
        with _kept_rc():
            return plot(self, *a, **kw)

    return wrapper


def _kept_rc():
    """matplotlib's rc_context when matplotlib is in use (a figure may be drawn), else nothing to keep."""
    import contextlib
    import sys

    if "matplotlib" not in sys.modules:
        # bpmid imports matplotlib only to draw; if it does so now, the caller had no settings of their own, and
        # the house style applied while drawing is still undone for their first figure
        import matplotlib
    return sys.modules["matplotlib"].rc_context()


#: suffixes of a file name: a folder result refuses a path ending so (``pred.yaml`` became a folder)
FILE_SUFFIXES = (".yaml", ".yml", ".csv", ".json", ".txt", ".png", ".pdf", ".svg", ".xlsx")


class Result:
    """The common shape of every workflow's result (see the module docstring).

    Parameters
    ----------
    body : the file's keys except ``schema`` and ``provenance``
    provenance : the provenance block (what made it: version, command, input hashes, config, seed)
    raw : the live workflow object (not compared, not saved beyond what ``body`` holds)
    source : the file this result was loaded from, if any
    """

    #: ``bpmid.<kind>/1``
    kind: ClassVar[str] = ""
    #: for results written as a folder: the YAML inside it that carries the schema
    main_file: ClassVar[str | None] = None
    title: ClassVar[str] = "bpmid result"

    def __init_subclass__(cls, **kw):
        super().__init_subclass__(**kw)
        if "save" in cls.__dict__:   # every result's save refuses to replace a file it was made from
            cls.save = _guarded_save(cls.__dict__["save"])
        if "plot" in cls.__dict__:   # and drawing leaves the caller's matplotlib settings as they were
            cls.plot = _guarded_plot(cls.__dict__["plot"])

    def input_hashes(self) -> dict[str, str]:
        """sha256 -> path of the files this result was made from (its provenance's inputs, at any depth)."""
        out: dict[str, str] = {}

        def walk(block):
            if isinstance(block, Mapping):
                ins = block.get("inputs")
                if isinstance(ins, Mapping):
                    out.update({str(v): str(k) for k, v in ins.items() if isinstance(v, str) and len(v) == 64})
                for v in block.values():
                    if isinstance(v, Mapping):
                        walk(v)

        walk(self.provenance)
        return out

    def __init__(self, body: Mapping, provenance: Mapping | None = None, *, raw: Any = None,
                 source: str | Path | None = None):
        self.body = _normalised(dict(body))
        self.body.pop("schema", None)
        self.body.pop("provenance", None)
        self.provenance = _normalised(dict(provenance or {}))
        self.raw = raw
        # absolute: a loaded result finds the files beside it after the working directory changes
        self.source = None if source is None else Path(source).resolve()

    # ----- identity -------------------------------------------------------------------------------
    @property
    def schema(self) -> str:
        return f"bpmid.{self.kind}/1"

    def to_dict(self) -> dict:
        """The file's mapping: ``{schema, <body...>, provenance}``."""
        return {"schema": self.schema, **self.body, "provenance": self.provenance}

    def __eq__(self, other) -> bool:
        if not isinstance(other, Result):
            return NotImplemented
        return (type(self) is type(other) and self.schema == other.schema and self.body == other.body
                and self.provenance == other.provenance)

    __hash__ = None  # mutable mapping inside

    # ----- what every result answers --------------------------------------------------------------
    @property
    def params(self) -> Parameters:
        return Parameters()

    @property
    def metrics(self) -> dict[str, float]:
        return {}

    @property
    def warnings(self) -> list[str]:
        w = self.body.get("warnings")
        return [str(x) for x in w] if isinstance(w, list) else []

    def correlations(self, threshold: float = 0.3) -> list[tuple[str, str, float]]:
        """Pairs ``(a, b, r)`` of estimated parameters with ``|r| > threshold``, largest first."""
        names, corr = self._correlation()
        out = []
        for i in range(len(names)):
            for j in range(i + 1, len(names)):
                try:
                    r = corr[i][j]
                except (IndexError, TypeError):
                    continue
                if r is not None and math.isfinite(r) and abs(r) > threshold:
                    out.append((names[i], names[j], float(r)))
        return sorted(out, key=lambda x: -abs(x[2]))

    def _correlation(self) -> tuple[list[str], list]:
        return [], []

    def _headline(self) -> str:
        return ", ".join(f"{k} {_num(v)}" for k, v in list(self.metrics.items())[:3])

    def _extra_sections(self) -> list[tuple[str, str]]:
        return []

    # ----- text -----------------------------------------------------------------------------------
    def summary(self, min_correl: float = 0.3) -> str:
        """A plain-text report: fit statistics, parameters with standard errors and identifiability,
        correlations above ``min_correl``, warnings, and where it came from."""
        lines = [f"[[{self.title}]]  ({self.schema})"]
        if self.metrics:
            lines.append("[[Fit statistics]]")
            w = max(len(k) for k in self.metrics)
            lines += [f"    {k:<{w}} = {_num(v)}" for k, v in self.metrics.items()]
        lines.append("[[Parameters]]")
        lines.append(self.params.table())
        corr = self.correlations(min_correl)
        if corr:
            lines.append(f"[[Correlations]] (unreported correlations are < {min_correl:.3f})")
            w = max(len(f"C({a}, {b})") for a, b, _ in corr)
            lines += [f"    {f'C({a}, {b})':<{w}} = {r:+.4f}" for a, b, r in corr]
        for head, text in self._extra_sections():
            lines.append(f"[[{head}]]")
            lines += ["    " + ln for ln in text.splitlines()]
        if self.warnings:
            lines.append("[[Warnings]]")
            lines += [f"    - {w}" for w in self.warnings]
        prov = self.provenance
        if prov:
            made = f"bpmid {prov.get('bpmid_version', '?')}"
            if prov.get("created"):
                made += f", {prov['created']}"
            if prov.get("seed") is not None:
                made += f", seed {prov['seed']}"
            lines.append(f"[[Provenance]] {made}; {len(prov.get('inputs') or {})} input file(s)")
        return "\n".join(lines)

    def __repr__(self) -> str:
        head = self._headline()
        where = f", from {self.source}" if self.source else ""
        return f"<{type(self).__name__} {self.schema}: {len(self.params)} params{', ' + head if head else ''}{where}>"

    def __str__(self) -> str:
        return self.__repr__()

    def _repr_html_(self) -> str:
        rows = "".join(
            f"<tr><td>{html.escape(p.name)}</td><td>{_num(p.value)}</td>"
            f"<td>{'' if p.stderr is None else f'{p.stderr:.4g}'}</td><td>{html.escape(p.unit)}</td>"
            f"<td>{html.escape(p.identifiability)}</td></tr>" for p in self.params.values())
        stats = "".join(f"<tr><td>{html.escape(k)}</td><td>{_num(v)}</td></tr>" for k, v in self.metrics.items())
        warn = "".join(f"<li>{html.escape(w)}</li>" for w in self.warnings)
        corr = "".join(f"<tr><td>{html.escape(a)}</td><td>{html.escape(b)}</td><td>{r:+.4f}</td></tr>"
                       for a, b, r in self.correlations())
        parts = [f"<h4>{html.escape(self.title)} <small>({html.escape(self.schema)})</small></h4>"]
        if stats:
            parts.append(f"<table><tr><th>statistic</th><th>value</th></tr>{stats}</table>")
        if rows:
            parts.append("<table><tr><th>name</th><th>value</th><th>stderr</th><th>unit</th>"
                         f"<th>identifiability</th></tr>{rows}</table>")
        if corr:
            parts.append(f"<table><tr><th colspan=2>pair</th><th>correlation</th></tr>{corr}</table>")
        if warn:
            parts.append(f"<p>Warnings:</p><ul>{warn}</ul>")
        return "\n".join(parts)

    # ----- figures --------------------------------------------------------------------------------
    def _stamp(self) -> str | None:
        """The synthetic-data stamp of a loaded result's figure, as the command that wrote it stamps it: from the
        headers of its input logs (:func:`bpmid.io.motion_logs.stamp_for_files`) when every one is found, else
        from what the file records (``synthetic``, ``synthetic_logs``); None for measured data."""
        from bpmid.io.motion_logs import stamp_for_files

        ins = [Path(p) for p in (self.provenance.get("inputs") or {})
               if Path(p).suffix.lower() in (".csv", ".txt", ".tsv", ".dat")]
        if ins and all(p.is_file() for p in ins):
            return stamp_for_files(ins)
        if self.body.get("synthetic") is True:
            return "synthetic data (the logs' own headers say so)"
        syn = self.body.get("synthetic_logs")
        if isinstance(syn, list) and syn:
            return (f"partly synthetic: {len(syn)} of {len(ins)} logs" if len(ins) >= len(syn) else
                    f"partly synthetic: {len(syn)} logs")
        return None

    def plot(self):
        """A matplotlib Figure of the result (the CLI's figure where the live result is at hand, else a
        figure drawn from the file's numbers)."""
        return self._params_figure()

    def _params_figure(self):
        """The relative standard error of each constant (house style; stamped as the inputs' headers say)."""
        from bpmid.plots.common import OKABE_ITO, finish, new_figure

        ps = [p for p in self.params.values() if p.value or p.stderr is None]
        fig, ax = new_figure(1, 1, width=6.4, height=0.3 * max(len(ps), 3) + 1.6, left=2.2)
        if ps:
            # a constant with no standard error (held, not determined, fixed) gets no bar but its reason: a bar of
            # length 0 read as perfectly determined
            rel = [100.0 * p.rel_stderr if p.stderr is not None and p.rel_stderr is not None else 0.0 for p in ps]
            ax.barh([f"{p.name} ({p.unit})" if p.unit else p.name for p in ps], rel, color=OKABE_ITO["blue"])
            for k, p in enumerate(ps):
                if p.stderr is None or p.rel_stderr is None:
                    why = ("not determined (held)" if p.identifiability.startswith("not identifiable") else
                           "held or fixed" if p.identifiability.startswith("fixed") or p.stderr is None else
                           "a value of 0")
                    ax.text(0.01, k, f"no standard error: {why}", transform=ax.get_yaxis_transform(), va="center",
                            fontsize=7, color="0.35")
            ax.invert_yaxis()
        else:
            ax.text(0.5, 0.5, "no constants in this file", transform=ax.transAxes, ha="center", color="0.4")
        ax.set_xlabel("relative standard error (%)")
        ax.set_title(f"{self.title}: parameter uncertainty")
        return finish(fig, self._stamp())

    # ----- files ----------------------------------------------------------------------------------
    def _check_folder_path(self, path) -> None:
        """A folder result refuses a path that names a file (``pred.yaml`` made a folder of that name)."""
        if self.main_file and Path(path).suffix.lower() in FILE_SUFFIXES:
            raise InputError(f"a {type(self).__name__} is a folder ({self.main_file} and the files beside it): give a "
                             f"folder path, found {Path(path).name!r}", path=path)

    def save(self, path: str | Path, **kw) -> Path:
        """Write the result's YAML (schema, body, provenance) atomically; returns the path written.

        Folder results (``main_file`` set) take a folder and write ``main_file`` inside it."""
        from bpmid.io.results import write_result

        path = Path(path)
        self._check_folder_path(path)
        if not self.main_file and path.suffix.lower() not in (".yaml", ".yml"):
            raise InputError(f"a {type(self).__name__} is written as YAML: give a path ending .yaml (found "
                             f"{path.name!r})", path=path)
        if self.main_file and self.raw is None and self.source is not None and self.source.parent.is_dir():
            return self._save_loaded_folder(path)
        target = path / self.main_file if self.main_file else path
        write_result(target, self.schema, self.body, self.provenance)
        return path

    def _save_loaded_folder(self, path: Path) -> Path:
        """A folder result loaded from disk, saved elsewhere: the files beside its main file (tables, predictions,
        logs, figures) are copied with it and the main file written, all or nothing, so that the copy loads to the
        same data (before, only the main file was written: an equal result whose tables were gone)."""
        import shutil

        from bpmid.io.atomic import staged_dir
        from bpmid.io.results import write_result

        src = self.source.parent
        if Path(path).resolve() == src.resolve():
            raise InputError("the result was loaded from this folder: give another folder to save it to", path=path)
        n = sum(1 for _ in zip(range(_COPY_MAX_FILES + 1), src.rglob("*")))
        if n > _COPY_MAX_FILES:   # not an output folder bpmid wrote: copy nothing rather than a whole tree
            raise InputError(f"the folder the result was loaded from holds more than {_COPY_MAX_FILES} files, more "
                             f"than a bpmid output folder: copy the files you need with {self.main_file} yourself",
                             path=src)
        with staged_dir(path) as tmp:
            for item in src.iterdir():
                if item.name == self.main_file or item.name.startswith("."):
                    continue
                (shutil.copytree if item.is_dir() else shutil.copy2)(item, tmp / item.name)
            write_result(tmp / self.main_file, self.schema, self.body, self.provenance)
        return Path(path)

    @classmethod
    def from_file(cls, data: dict, path: Path) -> "Result":
        return cls(data, data.get("provenance"), source=path)


#: the most files a loaded folder result's folder may hold to be copied whole when it is saved elsewhere
_COPY_MAX_FILES = 5000


def _save_with_figure(result: Result, path: Path, fig_path: Path) -> None:
    """The result's YAML and its :meth:`~Result.plot` figure, both staged: on any failure neither appears."""
    from bpmid.io.atomic import staged_file
    from bpmid.io.results import write_result
    from bpmid.plots.common import save_figure

    with staged_file(path) as tmp_yaml, staged_file(fig_path) as tmp_fig:
        write_result(tmp_yaml, result.schema, result.body, result.provenance)
        save_figure(result.plot(), tmp_fig)


Result.save = _guarded_save(Result.save)
Result.plot = _guarded_plot(Result.plot)


# --------------------------------------------------------------------------------------------------
# the workflows
# --------------------------------------------------------------------------------------------------
class RelaxationResult(Result):
    """A Prony-series fit of relaxation logs (``bpmid.relax/1``; :func:`bpmid.fit_relaxation`)."""

    kind = "relax"
    title = "Relaxation fit (Prony series)"

    @property
    def params(self) -> Parameters:
        out = []
        fitted = "shear" if str(self.body.get("fitted_modulus", "E")).upper() == "G" else "prony"

        from bpmid import identifiability

        def judged(info: ParamInfo) -> ParamInfo:
            # the rule every fit uses (bpmid.identifiability: a relative standard error above 50 %), reported here
            if info.identifiability == "estimated" and info.stderr is not None and info.value:
                why = identifiability.judge(info.stderr, info.stderr / abs(info.value), rel_se_max=0.5)
                if why:
                    return dataclasses.replace(info, identifiability=f"not identifiable: {why} (estimated)")
            return info

        for block, inf_name, mod in (("prony", "E_inf", "E"), ("shear", "G_inf", "G"), ("bulk", "K_inf", "K")):
            b = self.body.get(block) or {}
            tag = "estimated" if block == fitted else "derived (Poisson's ratio)"
            if inf_name in b:
                out.append(judged(_entry(inf_name, b[inf_name], "Pa", tag)))
            for j, term in enumerate(b.get("terms") or [], start=1):
                out.append(judged(_entry(f"{mod}_{j}", term[mod], "Pa", tag)))
                if block == "prony":
                    out.append(judged(_entry(f"tau_{j}", term["tau"], "s", "estimated")))
        if "poisson_ratio" in self.body:
            out.append(ParamInfo("poisson_ratio", float(self.body["poisson_ratio"]), None, "1", "given"))
        # a master curve's shift function: the WLF constants with their standard errors (shift.wlf)
        wlf = ((self.body.get("shift") or {}).get("wlf") or {})
        if isinstance(wlf, Mapping):
            for name, unit in (("C1", "1"), ("C2", "C")):
                if isinstance(wlf.get(name), (int, float)):
                    se = wlf.get(f"se_{name}")
                    out.append(ParamInfo(f"wlf.{name}", float(wlf[name]), float(se) if isinstance(se, (int, float))
                                         else None, unit, "estimated (shift.wlf)"))
            if isinstance(wlf.get("T_ref"), (int, float)):
                out.append(ParamInfo("wlf.T_ref", float(wlf["T_ref"]), None, "C", "given (reference temperature)"))
        return Parameters(out)

    @property
    def metrics(self) -> dict[str, float]:
        m = self.body.get("metrics") or {}
        out = {f"rmse_{m.get('rmse_unit', 'Pa')}": m.get("rmse"), "r2": m.get("r2"), "mape_pct": m.get("mape_pct"),
               "rms_rel_storage_pct": m.get("rms_rel_storage_pct"), "rms_rel_loss_pct": m.get("rms_rel_loss_pct"),
               "n_terms": m.get("n_terms")}
        unc = self.body.get("uncertainty") or {}
        out.update({"n_obs": unc.get("n_obs"), "n_eff": unc.get("n_eff")})
        return {k: v for k, v in out.items() if v is not None}

    def _correlation(self):
        unc = self.body.get("uncertainty") or {}
        return list(unc.get("parameters") or []), unc.get("correlation") or []

    def _headline(self) -> str:
        m = self.metrics
        n = m.get("n_terms")
        if n is None:   # a file with the contract's keys only (CLI.md): count its terms
            n = len((self.body.get("prony") or {}).get("terms") or [])
        mode = self.body.get("mode")
        return ", ".join(x for x in (f"{mode} mode" if mode else "", f"{n} term(s)",
                                     f"R^2 {_num(m.get('r2'))}" if m.get("r2") is not None else "") if x)

    def modulus_pa(self, t_s, which: str = "E"):
        """E(t), G(t) or K(t) in Pa at times ``t_s`` (s) from the fitted Prony series."""
        import numpy as np

        block, inf = {"E": ("prony", "E_inf"), "G": ("shear", "G_inf"), "K": ("bulk", "K_inf")}[which]
        b = self.body[block]
        t = np.asarray(t_s, float)
        out = np.full_like(t, float(b[inf]["value"]))
        for term in b.get("terms") or []:
            out = out + float(term[which]["value"]) * np.exp(-t / float(term["tau"]["value"]))
        return out

    def plot(self):
        if self.raw is not None:
            return self._figure()
        import numpy as np

        from bpmid.plots.common import finish, new_figure

        taus = [float(t["tau"]["value"]) for t in (self.body.get("prony") or {}).get("terms") or []] or [1.0]
        t = np.logspace(np.log10(min(taus)) - 2, np.log10(max(taus)) + 2, 300)
        fig, ax = new_figure(1, 1, width=6.4, height=4.0)
        ax.semilogx(t, self.modulus_pa(t, "E") / 1e6)
        ax.set_xlabel("time (s)")
        ax.set_ylabel("relaxation modulus E (MPa)")
        ax.set_title(f"{self.title}: E(t) of the file's Prony series")
        return finish(fig, self._stamp())

    def save(self, path: str | Path, *, figure: str | Path | bool | None = None) -> Path:
        """Write the ``bpmid.relax/1`` YAML (and, for a live result, the figure: True = beside it as .png)."""
        path = Path(path)
        if figure and self.raw is not None:
            from bpmid.io.atomic import staged_file
            from bpmid.plots.common import save_figure

            fig_path = path.with_suffix(".png") if figure is True else Path(figure)
            # both are staged: on any failure neither file appears
            with staged_file(path) as tmp_yaml, staged_file(fig_path) as tmp_fig:
                super().save(tmp_yaml)
                save_figure(self._figure(), tmp_fig)
            return path
        if figure:   # a loaded result: its figure drawn from the file's numbers
            _save_with_figure(self, path, path.with_suffix(".png") if figure is True else Path(figure))
            return path
        return super().save(path)

    def _figure(self):
        """The CLI's figure of the live fit (a master curve's for frequency sweeps and raw sets)."""
        from bpmid.plots.relax import material_figure, relax_figure
        from bpmid.relax.material import MaterialFit

        if isinstance(self.raw, MaterialFit):
            return material_figure(self.raw)
        return relax_figure(self.raw, synthetic=bool(getattr(self, "_synthetic", False)))

    @property
    def relax_parameters(self):
        """The constants as :class:`bpmid.relax.result.RelaxParameters` (what fit motion's ``init`` takes)."""
        from bpmid.relax.result import relax_fit_from_mapping

        return relax_fit_from_mapping(self.to_dict(), self.source)


class VBMMFitResult(Result):
    """A fitted VBMM (``bpmid.vbmm/1``; :func:`bpmid.fit_motion`)."""

    kind = "vbmm"
    title = "VBMM fit"

    @property
    def params(self) -> Parameters:
        mat = self.body.get("material") or {}
        ident = ((self.body.get("uncertainty") or {}).get("identifiability") or {})
        out = []
        for name in ("G_inf", "K_inf"):
            if name in mat:
                out.append(_entry(name, mat[name], "Pa", ident.get(name, "")))
        for j, b in enumerate(mat.get("branches") or [], start=1):
            for key, unit in (("G", "Pa"), ("K", "Pa"), ("tau", "s"), ("tauG", "s"), ("tauK", "s")):
                if key in b:
                    name = f"{key}_{j}"
                    out.append(_entry(name, b[key], unit, ident.get(name, "")))
        # the constants of the effects the file runs with the VBMM (discover's model.yaml): <id>.<name>, as a
        # comparison names its models' constants; the metrics are those of the model with them
        for eid, _settings, prm in self._effects():
            for name, entry in prm.items():
                try:
                    out.append(_entry(f"{eid}.{name}", entry, _effect_unit(eid, name)))
                except (TypeError, ValueError):   # a hand-edited entry without a number: not a constant to show
                    continue
        return Parameters(out)

    def _effects(self) -> list[tuple[str, dict, dict]]:
        """The file's ``effects`` list as (id, settings, parameters); entries that are not mappings are left out."""
        fx = self.body.get("effects")
        out = []
        for e in fx if isinstance(fx, list) else []:
            if isinstance(e, Mapping) and isinstance(e.get("id"), str):
                sets, prm = e.get("settings"), e.get("parameters")
                out.append((e["id"], dict(sets) if isinstance(sets, Mapping) else {},
                            dict(prm) if isinstance(prm, Mapping) else {}))
        return out

    @property
    def effects(self) -> list[str]:
        """The ids of the catalogue effects the file runs with the VBMM, in the order they act ([] for a plain
        fit); their constants are in :attr:`params` as ``<id>.<name>``."""
        return [eid for eid, _s, _p in self._effects()]

    def _extra_sections(self):
        fx = self._effects()
        if not fx:
            return []
        from bpmid.effects.fitfile import settings_words

        lines = []
        for eid, sets, prm in fx:
            words = settings_words(eid, sets)
            lines.append(f"{eid}: constants {', '.join(f'{eid}.{n}' for n in prm) or 'none'} (in [[Parameters]])"
                         + (f"; settings {words}" if words else ""))
        lines.append("the model runs them with the VBMM: the fit statistics above include them (.model_with_effects"
                     " runs the same model; .model is the constants alone)")
        return [("Effects", "\n".join(lines))]

    @property
    def metrics(self) -> dict[str, float]:
        m = self.body.get("metrics") or {}
        keep = ("rmse_deg", "mape_pct", "r2", "fit_pct", "max_abs_err_deg", "n_samples")
        out = {k: m[k] for k in keep if k in m}
        unc = self.body.get("uncertainty") or {}
        for k in ("n_obs", "n_eff", "nfev", "converged"):
            if k in unc:
                out[k] = unc[k]
        return out

    def _correlation(self):
        unc = self.body.get("uncertainty") or {}
        return list(unc.get("parameters") or []), unc.get("correlation") or []

    def _headline(self) -> str:
        m = self.metrics
        fx = self.effects
        return (f"RMSE {_num(m.get('rmse_deg'))} deg, R^2 {_num(m.get('r2'))}"
                + (f", with effects {', '.join(fx)}" if fx else ""))

    @property
    def model(self):
        """The fitted :class:`bpmid.models.vbmm.VBMM` (history settings as recorded in the file): the constants only;
        a file's ``effects`` list is run by :func:`bpmid.predict` (or
        ``bpmid.effects.fitfile.augmented_from_file(result.model, result)``). On a fit that has effects (discover's
        model.yaml) a :class:`bpmid.BpmidWarning` says that they are not in it: a prediction from ``.model`` alone
        differs from the fit's own."""
        fx = [e.get("id", "?") if isinstance(e, Mapping) else str(e) for e in (self.body.get("effects") or [])]
        if fx:
            from bpmid.errors import warn_caller

            warn_caller([f"this fit has effects ({', '.join(fx)}) that .model leaves out (the constants only): pass "
                         "the result itself to bpmid.predict or bpmid.compare, or use .model_with_effects"])
        return self._constants()

    def _constants(self):
        if self.raw is not None and hasattr(self.raw, "model"):
            return self.raw.model
        from bpmid.models.vbmm import vbmm_from_mapping

        return vbmm_from_mapping(self.to_dict(), self.source)

    @property
    def model_with_effects(self):
        """The fitted VBMM with the file's ``effects`` list acting (what :func:`bpmid.predict` runs), or the
        constants alone when the fit has none."""
        from bpmid.effects.fitfile import augmented_from_file

        return augmented_from_file(self._constants(), self)

    def plot(self):
        if self.raw is not None and hasattr(self.raw, "predictions"):
            from bpmid.plots.motion import motion_fit_figure

            r = self.raw
            return motion_fit_figure(r.logs, r.predictions, title=f"VBMM fit: RMSE {r.metrics['rmse_deg']:.3g}°")
        import numpy as np

        from bpmid.models.vbmm import vbmm_from_mapping
        from bpmid.models.vbmm.rig import fitted_pressure_span
        from bpmid.plots.common import PRESSURE_LABEL, finish, new_figure
        from bpmid.units import PA_PER_BAR

        model = vbmm_from_mapping(self.to_dict(), self.source)   # the constants (no warning of its effects)
        # over the gauge pressures the constants were fitted on (fit.logs), else the paper's working range
        span = fitted_pressure_span(self.body)
        p_hi = 0.8 * PA_PER_BAR if span is None else span[1]
        p = np.linspace(0.0, max(p_hi, 1e3), 60)
        beta = model.equilibrium_angle(p)
        fig, ax = new_figure(1, 1, width=6.4, height=4.0)
        ax.plot(p / PA_PER_BAR, np.degrees(beta))
        ax.set_xlabel(PRESSURE_LABEL)
        ax.set_ylabel("long-term equilibrium angle (°)")
        ax.set_title(f"{self.title}: equilibrium of the file's G_inf, K_inf"
                     + (" over the fitted pressures" if span is not None else ""))
        return finish(fig, self._stamp())

    def save(self, path: str | Path, *, figure: str | Path | bool | None = None, synthetic: "bool | str | None" = False) -> Path:
        """Write the ``bpmid.vbmm/1`` YAML; with ``figure`` (a path, or True: beside it as .png) the fit figure too,
        all or nothing (a loaded result draws :meth:`plot`)."""
        path = Path(path)
        if figure is True:
            figure = path.with_suffix(".png")
        if figure and self.raw is not None:
            from bpmid.models.vbmm.fit import write_motion_fit

            write_motion_fit(path, self.raw, self.provenance, figure=figure, synthetic=synthetic)
            return path
        if figure:
            _save_with_figure(self, path, Path(figure))
            return path
        return super().save(path)


class PredictionResult(Result):
    """Predictions of a fitted VBMM on logs (folder with ``predict.yaml``; :func:`bpmid.predict`)."""

    kind = "predict"
    main_file = "predict.yaml"
    title = "VBMM prediction"

    @property
    def metrics(self) -> dict[str, float]:
        out = {}
        for name, d in (self.body.get("logs") or {}).items():
            for k, v in ((d or {}).get("metrics") or {}).items():
                out[f"{name}.{k}"] = v
        return out

    @property
    def predictions(self) -> dict:
        """log name -> (N,) predicted angle (deg); from the live result or the CSVs beside the YAML."""
        if self.raw is not None:
            return {p.log.name: p.angle_pred_deg for p in self.raw}
        import pandas as pd

        base = self.source.parent if self.source is not None else Path(".")
        out = {}
        for name, d in (self.body.get("logs") or {}).items():
            f = base / d["file"]
            if not f.is_file():   # never a shorter dict than the metrics it sits beside
                raise InputError(f"the prediction of log {name!r} is not beside its result (it was written to "
                                 f"{d['file']!r}): copy or move the whole output folder", path=f)
            out[name] = pd.read_csv(f, comment="#")["angle_pred_deg"].to_numpy()
        return out

    def _headline(self) -> str:
        return f"{len(self.body.get('logs') or {})} log(s)"

    def _extra_sections(self):
        rows = []
        for name, d in (self.body.get("logs") or {}).items():
            m = (d or {}).get("metrics") or {}
            rows.append(f"{name}: " + (f"RMSE {_num(m.get('rmse_deg'))} deg, R^2 {_num(m.get('r2'))}" if m else
                                       "no measured angle (prediction only)"))
        return [("Logs", "\n".join(rows))] if rows else []

    def plot(self):
        """The figure ``bpmid predict`` writes (predict.png): measured and predicted angle as a loop and against
        time, and the error, one row per log; from a loaded folder the logs are read back from its CSVs."""
        from bpmid.io.motion_logs import synthetic_note
        from bpmid.plots.report import prediction_figure

        if self.raw is not None:
            logs, preds = [p.log for p in self.raw], {p.log.name: p.angle_pred_deg for p in self.raw}
        else:
            logs, preds = self._logs_read_back()
        return prediction_figure(logs, preds, synthetic=synthetic_note(logs))

    def _logs_read_back(self):
        """The logs of a loaded prediction as its CSVs hold them (time, pressure in their reference, the measured
        angle when the log had one) with the predicted angles; InputError naming a CSV that is not beside it."""
        import dataclasses as _dc

        import pandas as pd

        from bpmid.io.motion_logs import read_motion_log

        base = self.source.parent if self.source is not None else Path(".")
        logs, preds = [], {}
        for name, d in (self.body.get("logs") or {}).items():
            f = base / str((d or {}).get("file", f"{name}.csv"))
            if not f.is_file():
                raise InputError(f"the prediction of log {name!r} is not beside its result (it was written to "
                                 f"{f.name!r}): copy or move the whole output folder", path=f)
            logs.append(_dc.replace(read_motion_log(f), name=str(name)))
            preds[str(name)] = pd.read_csv(f, comment="#")["angle_pred_deg"].to_numpy()
        return logs, preds

    def save(self, path: str | Path, *, figure: bool = False) -> Path:
        """Write ``DIR/<log>.csv`` per log and ``DIR/predict.yaml`` (and with ``figure`` ``DIR/predict.png``), all
        or nothing (the paths written: ``.written``); a loaded result is copied whole with its CSVs."""
        self._check_folder_path(path)
        if self.raw is not None:
            from bpmid.predict import write_predictions

            from bpmid.io.motion_logs import synthetic_note

            self.written = write_predictions(path, self.raw, prov=self.provenance, params=self.body.get("params"),
                                             model=getattr(self, "_model", None), figure=figure,
                                             synthetic=synthetic_note([p.log for p in self.raw]))
            return Path(path)
        return super().save(path)


class ComparisonResult(Result):
    """Every model fitted on training logs and scored free-running on test logs (folder with
    ``compare.yaml``; :func:`bpmid.compare`)."""

    kind = "compare"
    main_file = "compare.yaml"
    title = "Model comparison"

    @property
    def params(self) -> Parameters:
        out = []
        for model, d in (self.body.get("models") or {}).items():
            for name, entry in ((d or {}).get("parameters") or {}).items():
                if isinstance(entry, Mapping) and "value" in entry:
                    ident = "" if entry.get("identifiable") is None else \
                        ("estimated" if entry["identifiable"] else "not identifiable")
                    if entry.get("fixed") and not ident:
                        ident = "fixed"
                    out.append(_entry(f"{model}.{name}", entry, "", ident))
        return Parameters(out)

    @property
    def table(self):
        """The summary table (pandas DataFrame: rank, model, rmse_deg, mape_pct, r2, us_per_step, n_params)."""
        if self.raw is not None:
            return self.raw.summary
        import pandas as pd

        base = self.source.parent if self.source is not None else None
        if base is not None and (base / "summary.csv").is_file():
            return pd.read_csv(base / "summary.csv")
        return pd.DataFrame()

    @property
    def metrics(self) -> dict[str, float]:
        out = {}
        for model, d in (self.body.get("models") or {}).items():
            fit = (d or {}).get("fit") or {}
            if "rmse_train_deg" in fit:
                out[f"{model}.rmse_train_deg"] = fit["rmse_train_deg"]
        return out

    def _extra_sections(self):
        v = self.body.get("verdicts") or []
        return [("Verdicts", "\n".join(str(x) for x in v))] if v else []

    def _headline(self) -> str:
        return f"{len(self.body.get('models') or {})} model(s)"

    def plot(self, *, synthetic: "bool | str | None" = None):
        """The figure ``bpmid compare`` writes as compare_summary (RMSE pooled and per test set, R², MAPE, cost per
        step of every model), from the live result or the folder's summary.csv and summary_by_set.csv; stamped as
        the logs' headers say (``synthetic``: the stamp to use instead). A loaded compare.yaml without its tables
        draws the training RMSE it records."""
        from bpmid.plots.compare import summary_bars

        if self.raw is not None:
            from bpmid.io.motion_logs import synthetic_note

            note = synthetic_note(list(self.raw.train) + list(self.raw.test)) if synthetic is None else synthetic
            return summary_bars(self.raw.summary, self.raw.by_set, synthetic=note)
        table = self.table
        if len(table) and {"model", "rmse_deg", "r2", "mape_pct", "us_per_step"} <= set(table.columns):
            import pandas as pd

            f = self.source.parent / "summary_by_set.csv"
            by_set = pd.read_csv(f) if f.is_file() else None
            return summary_bars(table, by_set, synthetic=self._stamp() if synthetic is None else synthetic)
        from bpmid.plots.common import color_of, finish, new_figure

        m = self.metrics
        names = [k.split(".")[0] for k in m]
        fig, ax = new_figure(1, 1, width=6.4, height=4.0, left=1.4)
        ax.barh(names, list(m.values()), color=[color_of(n, i) for i, n in enumerate(names)])
        ax.invert_yaxis()
        ax.set_xlabel("training RMSE (°)")
        ax.set_title(f"{self.title}: training RMSE (compare.yaml; no summary.csv beside it)")
        return finish(fig, self._stamp() if synthetic is None else synthetic)

    def save(self, path: str | Path) -> Path:
        """The whole comparison folder (tables, compare.yaml, predictions, figures): written for a live result,
        copied whole for a loaded one."""
        self._check_folder_path(path)
        if self.raw is not None:
            from bpmid.compare import write_compare

            body = dict(self.body)
            write_compare(self.raw, path, self.provenance, relax_fit=body.get("relax_fit"),
                          n_figure_logs=getattr(self, "_figure_logs", 4))
            return Path(path)
        return super().save(path)


class DiscoveryResult(Result):
    """The effects discovery named (folder with ``discovery.yaml``; :func:`bpmid.discover`)."""

    kind = "discovery"
    main_file = "discovery.yaml"
    title = "Discovery of missing effects"

    @property
    def params(self) -> Parameters:
        return Parameters(_entry(k, v, "") for k, v in (self.body.get("final_model") or {}).items())

    @property
    def named_effects(self) -> list[str]:
        return list(self.body.get("named_effects") or [])

    @property
    def metrics(self) -> dict[str, float]:
        """The gap's numbers (deg); its ``scoring`` sentence is in ``body["gap"]``, not here (a loop over the metrics
        met a 700-character string)."""
        return {k: v for k, v in (self.body.get("gap") or {}).items()
                if isinstance(v, (int, float)) and not isinstance(v, bool)}

    @property
    def warnings(self) -> list[str]:
        """What reading the logs said (a likely unit slip, a gap), discovery's cautions, and whether part of the
        gap stays unexplained: the same as were given as :class:`bpmid.BpmidWarning`."""
        said = [str(w) for w in (self.provenance or {}).get("warnings") or []]
        said += [f"discovery: {c}" for c in self.body.get("cautions") or []]
        if self.body.get("unexplained"):
            said.append("part of the gap stays unexplained by the catalogue")
        return list(dict.fromkeys(said))

    def _extra_sections(self):
        return [("Verdict", str(self.body.get("verdict", "")))]

    def _headline(self) -> str:
        return f"named: {', '.join(self.named_effects) or 'none'}"

    def plot(self):
        if self.raw is not None:
            from bpmid.plots.discover import heldout_figure

            return heldout_figure(self.raw)
        return self._params_figure()

    def save(self, path: str | Path, *, base_from: str | None = None) -> Path:
        """discovery.yaml, verdict.txt, model.yaml and the figures: written for a live result, copied whole for a
        loaded one."""
        self._check_folder_path(path)
        if self.raw is not None:
            from bpmid.discover.output import write_discovery

            write_discovery(path, self.raw, self.provenance, base_from=base_from or self.body.get("base_from", ""))
            return Path(path)
        return super().save(path)


class SimulationResult(Result):
    """Synthetic logs from the digital twin (folder with ``manifest.yaml``; :func:`bpmid.simulate`)."""

    kind = "simulation"
    main_file = "manifest.yaml"
    title = "Digital-twin simulation"

    @property
    def params(self) -> Parameters:
        out = []
        effects = self.body.get("effects")
        for e in effects if isinstance(effects, list) else []:   # a hand-edited manifest: what is not a list of
            prm = e.get("params") if isinstance(e, dict) else None  # effects with their params gives none
            for k, v in (prm if isinstance(prm, dict) else {}).items():
                out.append(_entry(f"{e.get('id')}.{k}", v, "", "injected"))
        return Parameters(out)

    @property
    def logs(self) -> list[str]:
        """The log files' names."""
        if self.raw is not None:
            return [n for n in self.raw.files]
        return [str(x.get("file", x)) if isinstance(x, Mapping) else str(x) for x in self.body.get("logs") or []]

    def _headline(self) -> str:
        return f"seed {self.body.get('seed')}"

    def _extra_sections(self):
        prot = self.body.get("protocol") or {}
        fx = ", ".join(str(e.get("id")) for e in self.body.get("effects") or [] if isinstance(e, Mapping))
        lines = [f"protocol: {prot.get('name', '?')} ({prot.get('kind', '?')}), {prot.get('path', '')}".rstrip(", "),
                 f"seed: {self.body['seed']}" if self.body.get("seed") is not None else
                 "seed: none (designed signals, nothing drawn at random)",
                 f"logs: {len(self.logs)} ({', '.join(self.logs[:4])}"
                 f"{', ...' if len(self.logs) > 4 else ''})", f"injected effects: {fx or 'none'}",
                 "synthetic: made by bpmid's digital twin, not a measurement"]
        return [("Simulation", "\n".join(lines))]

    def plot(self):
        """Every log the simulation made, one panel each (the angle, or a relaxation log's stress, against time);
        the title says how many logs of how many are drawn; stamped synthetic."""
        import io

        import pandas as pd

        from bpmid.plots.simulate import MAX_PANELS, simulation_figure

        files = {}
        if self.raw is not None:
            files = {n: io.BytesIO(b) for n, b in self.raw.files.items() if n.endswith(".csv")}
        elif self.source is not None:
            listed = [n for n in self.logs if n.endswith(".csv") and (self.source.parent / n).is_file()]
            names = listed or [p.name for p in sorted(self.source.parent.glob("*.csv"))]
            files = {n: self.source.parent / n for n in names}
        frames = {Path(n).stem: pd.read_csv(f, comment="#") for n, f in list(files.items())[:MAX_PANELS]}
        prot = self.body.get("protocol") or {}
        name = prot.get("name") if isinstance(prot, Mapping) else None
        title = "Digital-twin simulation" + (f", protocol {name}" if name else "")
        return simulation_figure(frames, title=title, total=len(files))

    def save(self, path: str | Path) -> Path:
        """The logs and manifest.yaml (a blind case's answer beside the folder, ``<DIR>_ANSWER.yaml``): written for a
        live result, copied whole
        for a loaded one."""
        self._check_folder_path(path)
        if self.raw is not None:
            return self.raw.write(path)
        if self.source is not None:
            return self._save_loaded_folder(Path(path))
        from bpmid.io.atomic import write_text
        from bpmid.io.results import dump_yaml

        write_text(Path(path) / self.main_file, dump_yaml(self.to_dict()))
        return Path(path)


class ControlResult(Result):
    """Closed-loop tracking by PI, VBMM-PI and MS-PI (folder with ``control.yaml``; :func:`bpmid.control`)."""

    kind = "control"
    main_file = "control.yaml"
    title = "Closed-loop control"

    @property
    def params(self) -> Parameters:
        g = self.body.get("gains") or {}
        return Parameters(_entry(k, g[k], "", "given") for k in ("kp", "ki") if k in g)

    @property
    def table(self):
        """Summary rows as a pandas DataFrame (controller, reference, rmse_deg, reduction_pct ...)."""
        import pandas as pd

        return pd.DataFrame(self.body.get("summary") or [])

    @property
    def metrics(self) -> dict[str, float]:
        out = {}
        for row in self.body.get("summary") or []:
            if row.get("reference") == "ALL":
                out[f"{row.get('controller')}.rmse_deg"] = row.get("rmse_deg")
        return out

    def plot(self):
        if self.raw is not None:
            from bpmid.plots.control import fig18

            lim = self.body.get("pressure_limits_bar_abs")
            return fig18(self.raw.runs, limits_bar=tuple(lim) if lim else None)
        from bpmid.plots.common import OKABE_ITO, finish, new_figure

        m = self.metrics
        fig, ax = new_figure(1, 1, width=6.4, height=4.0)
        ax.bar([k.split(".")[0] for k in m], list(m.values()), color=OKABE_ITO["blue"])
        ax.set_xlabel("controller")
        ax.set_ylabel("tracking RMSE over all references (°)")
        ax.set_title(self.title)
        return finish(fig, True)   # a closed loop on a simulated plant, stamped as bpmid control stamps fig18

    def save(self, path: str | Path, *, figure: bool = True) -> Path:
        """summary.csv, control.yaml, traces/ and fig18.png: written for a live result, copied whole for a loaded
        one."""
        self._check_folder_path(path)
        ctx = getattr(self, "_write_context", None)
        if self.raw is not None and ctx is not None:
            from bpmid.control import write_control

            write_control(self.raw, path, ctx["cfg"], self.provenance, model=ctx["model"], plant=ctx["plant"],
                          figure=figure)
            return Path(path)
        return super().save(path)


class StudyResult(Result):
    """The whole study of ``bpmid run`` (folder with ``run.yaml``): its stages and, through :attr:`results`,
    every stage's own result object."""

    kind = "run"
    main_file = "run.yaml"
    title = "Study (bpmid run)"

    #: stage output -> file or folder in the run folder
    STAGE_FILES = {"relax": "relax_fit.yaml", "vbmm_fit": "vbmm_fit.yaml", "vbmm_mat": "vbmm_mat.yaml",
                   "compare": "compare", "history": "history_modes.yaml", "discover": "discover", "control": "control"}

    @property
    def results(self) -> dict[str, Result]:
        """Stage output name -> its loaded result (only those present beside ``run.yaml``)."""
        if self.source is None:
            return {}
        base = self.source.parent
        return {k: load(base / f) for k, f in self.STAGE_FILES.items() if (base / f).exists()}

    def plot(self):
        """The study's model comparison, as ``bpmid run`` drew it (compare/compare_summary: RMSE pooled and per
        test set, R², MAPE and cost per step of every model), stamped as the run's figures. A study whose
        comparison did not run raises InputError naming the stage results it has, whose own ``.plot()`` draws
        each stage."""
        base = self.source.parent if self.source is not None else None
        status = {str(s.get("name")): s.get("status") for s in self.body.get("stages") or [] if isinstance(s, Mapping)}
        cmp = load(base / "compare") if base is not None and (base / "compare" / "compare.yaml").is_file() else None
        if cmp is None or status.get("compare") != "done" or not len(cmp.table):
            have = [k for k, f in self.STAGE_FILES.items() if base is not None and (base / f).exists()
                    and k != "compare"]
            why = ("its comparison was not run by this study (run.yaml lists compare as "
                   f"{status.get('compare') or 'not run'})" if cmp is not None and status.get("compare") != "done"
                   else "it has no model comparison (compare/summary.csv)")
            raise InputError(f"a study draws its model comparison, and {why}: plot a stage's own result instead, "
                             + (f"study.results[{have[0]!r}].plot() (stages here: {', '.join(have)})" if have else
                                "once a stage has run"), path=base)
        # the run's record (None: measured); a run.yaml written before the stamp was recorded: the comparison's
        stamp = self.body["synthetic_stamp"] if "synthetic_stamp" in self.body else cmp._stamp()
        return cmp.plot(synthetic=stamp)

    def _extra_sections(self):
        rows = [f"{s.get('name', '?'):<9} {s.get('status', '?'):<8} {s.get('seconds', 0) or 0:7.1f} s"
                for s in self.body.get("stages") or []]
        return [("Stages", "\n".join(rows))] if rows else []

    def _headline(self) -> str:
        st = self.body.get("stages") or []
        return f"{sum(1 for s in st if s.get('status') == 'done')}/{len(st)} stage(s) done"


class FileResult(Result):
    """Any other file bpmid writes (``bpmid.run/1``, ``bpmid.history_modes/1``, ``bpmid.protocol/1`` ...):
    its mapping, provenance, and whatever parameters it lists as ``{value, stderr, unit}`` entries."""

    title = "bpmid file"

    def __init__(self, body, provenance=None, *, raw=None, source=None, schema: str = "bpmid.file/1"):
        super().__init__(body, provenance, raw=raw, source=source)
        self._schema = schema

    @property
    def schema(self) -> str:
        return self._schema

    @classmethod
    def from_file(cls, data: dict, path: Path) -> "Result":
        return cls(data, data.get("provenance"), source=path, schema=str(data.get("schema")))

    def save(self, path: str | Path) -> Path:
        from bpmid.io.atomic import write_text
        from bpmid.io.results import dump_yaml

        return write_text(path, dump_yaml(self.to_dict()))


#: schema kind -> result class
KINDS: dict[str, type[Result]] = {c.kind: c for c in (RelaxationResult, VBMMFitResult, PredictionResult,
                                                     ComparisonResult, DiscoveryResult, SimulationResult,
                                                     ControlResult, StudyResult)}
#: file names that carry the schema of a folder result
MAIN_FILES = tuple(c.main_file for c in KINDS.values() if c.main_file)


def load(path: str | Path) -> Result:
    """The result object of any file (or output folder) bpmid writes.

    Parameters
    ----------
    path : a result YAML (``relax_fit.yaml``, ``VBMM.yaml``, ``compare.yaml`` ...) or a folder holding one of
        ``compare.yaml``, ``control.yaml``, ``discovery.yaml``, ``manifest.yaml``, ``predict.yaml``, ``run.yaml``

    Raises
    ------
    InputError : not a bpmid result (naming the file and the key ``schema``)
    """
    from bpmid.io.results import read_result

    path = Path(path)
    if path.is_dir():
        found = [path / n for n in MAIN_FILES if (path / n).is_file()]
        if not found:
            raise InputError(f"no bpmid result in this folder (looked for {', '.join(MAIN_FILES)})", path=path)
        if len(found) > 1:
            raise InputError(f"this folder holds {len(found)} results ({', '.join(f.name for f in found)}): load one "
                             "of the files", path=path)
        path = found[0]
    if not path.is_file():
        raise InputError("file not found", path=path)
    data = read_result(path, "bpmid.")
    kind = str(data["schema"]).split("/")[0][len("bpmid."):]
    cls = KINDS.get(kind, FileResult)
    return cls.from_file(data, path)


__all__ = ["ParamInfo", "Parameters", "Result", "RelaxationResult", "VBMMFitResult", "PredictionResult",
           "ComparisonResult", "DiscoveryResult", "SimulationResult", "ControlResult", "StudyResult", "FileResult",
           "KINDS",
           "load"]
