"""The study report: the only module that writes one.

``bpmid report DIR`` reads the stage outputs a ``bpmid run`` (or single commands) left in DIR, with the
names of CLI.md, and writes

- ``DIR/report.html``: one self-contained file (PNG figures embedded as base64, inline CSS, no scripts, no
  external links), and
- ``DIR/report.md``: the same content in Markdown, figures referenced as files next to it.

Sections appear for the stages whose files exist (a stage not run is said so): provenance; relaxation fit;
motion fit (VBMM-mat. vs VBMM-fit); the paper's published numbers (quoted, the paper's data) kept apart from
the numbers measured here; the model comparison; history modes; residual diagnostics; discovery.

The document is built once as a list of blocks (:class:`Doc`) and rendered twice, so the two files never
disagree.
"""
from __future__ import annotations

import base64
import dataclasses
import html
import math
from pathlib import Path
from typing import Any, Iterable, Sequence

import numpy as np
import pandas as pd
import yaml

from bpmid import __version__
from bpmid.errors import InputError

#: figures the report draws itself, in this subfolder of DIR
FIGURE_DIR = "report_figures"

# --------------------------------------------------------------------------------------------------
# the paper's published figures (../shared/spec/EXPERIMENTS.md): QUOTED, measured on the paper's data
# --------------------------------------------------------------------------------------------------
PAPER_SOURCE = ("Published figures of the source paper (seed 000, section V), as listed in spec/EXPERIMENTS.md; "
                "measured by the paper's authors on their own muscle and test rig.")
PAPER_RELAX = {"E_inf": 0.0272e6, "E_1": 0.0549e6, "tau_1": 0.399}
#: (experiment, quantity, value, unit)
PAPER_ROWS = [
    ("Relaxation fit (one term)", "E_inf", 0.0272, "MPa"),
    ("Relaxation fit (one term)", "E_1", 0.0549, "MPa"),
    ("Relaxation fit (one term)", "tau_1", 0.399, "s"),
    ("Relaxation fit (one term)", "RMSE", 0.00192, "MPa"),
    ("Relaxation fit (one term)", "R^2", 0.873, "1"),
    ("Relaxation fit (one term)", "MAPE", 5.472, "%"),
    ("1a variable amplitude, VBMM-fit", "RMSE", 2.122, "deg"),
    ("1a variable amplitude, VBMM-fit", "MAPE", 3.339, "%"),
    ("1a variable amplitude, VBMM-fit", "R^2", 0.936, "1"),
    ("1a variable amplitude, VBMM-mat.", "RMSE", 3.388, "deg"),
    ("1a variable amplitude, VBMM-mat.", "MAPE", 5.459, "%"),
    ("1a variable amplitude, VBMM-mat.", "R^2", 0.836, "1"),
    ("1b variable rate, VBMM-fit", "RMSE", 2.137, "deg"),
    ("1b variable rate, VBMM-fit", "MAPE", 3.686, "%"),
    ("1b variable rate, VBMM-fit", "R^2", 0.928, "1"),
    ("1b variable rate, VBMM-mat.", "RMSE", 3.416, "deg"),
    ("1b variable rate, VBMM-mat.", "MAPE", 6.021, "%"),
    ("1b variable rate, VBMM-mat.", "R^2", 0.815, "1"),
    ("2 long term, full history", "RMSE", 2.148, "deg"),
    ("2 long term, window (T_win = 20 s)", "RMSE", 2.148, "deg"),
    ("2 long term, window (T_win = 20 s)", "cost per step", 4.0, "us (about)"),
    ("2 long term, window vs full", "cost reduction", 97.0, "%"),
]
#: test-set names of the run config that correspond to the paper's experiments 1a and 1b
SET_1A = ("variable_amplitude", "exp1a", "1a")
SET_1B = ("variable_rate", "exp1b", "1b")


# --------------------------------------------------------------------------------------------------
# a tiny document model, rendered to Markdown and to self-contained HTML
# --------------------------------------------------------------------------------------------------
@dataclasses.dataclass
class Block:
    kind: str  # h, p, list, table, fig, panel, code
    text: str = ""
    level: int = 2
    items: list = dataclasses.field(default_factory=list)
    header: list = dataclasses.field(default_factory=list)
    rows: list = dataclasses.field(default_factory=list)
    path: str = ""  # figure path relative to DIR
    css: str = ""
    children: list = dataclasses.field(default_factory=list)
    anchor: str = ""


class Doc:
    """An ordered list of blocks; :meth:`panel` opens a boxed group (the quoted and measured panels)."""

    def __init__(self):
        self.blocks: list[Block] = []
        self._stack: list[list[Block]] = [self.blocks]

    def _add(self, b: Block) -> None:
        self._stack[-1].append(b)

    def h(self, text: str, level: int = 2) -> None:
        anchor = "".join(c if c.isalnum() else "-" for c in text.lower()).strip("-")
        self._add(Block("h", text, level=level, anchor=anchor))

    def p(self, text: str, css: str = "") -> None:
        self._add(Block("p", text, css=css))

    def list(self, items: Iterable[str]) -> None:
        self._add(Block("list", items=list(items)))

    def table(self, header: Sequence[str], rows: Sequence[Sequence[Any]], css: str = "") -> None:
        self._add(Block("table", header=list(header), rows=[list(r) for r in rows], css=css))

    def fig(self, path: str, caption: str) -> None:
        self._add(Block("fig", caption, path=path))

    def code(self, text: str) -> None:
        self._add(Block("code", text))

    def panel(self, title: str, css: str):
        doc = self

        class _Ctx:
            def __enter__(self_inner):
                b = Block("panel", title, css=css)
                doc._add(b)
                doc._stack.append(b.children)
                return b

            def __exit__(self_inner, *exc):
                doc._stack.pop()
                return False

        return _Ctx()

    def headings(self) -> list[Block]:
        return [b for b in self.blocks if b.kind == "h" and b.level == 2]


def fmt(v: Any, digits: int = 4) -> str:
    """Numbers for tables: 4 significant digits, '-' for missing."""
    if v is None:
        return "-"
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        if not math.isfinite(v):
            return "-"
        if v == 0:
            return "0"
        a = abs(v)
        if 1e-3 <= a < 1e5:
            return f"{v:.{digits}g}"
        return f"{v:.{max(digits - 1, 1)}e}"
    return str(v)


def _md_cell(v) -> str:
    return str(v).replace("|", "\\|").replace("\n", " ")


def render_markdown(doc: Doc, title: str) -> str:
    out = [f"# {title}", ""]

    def emit(blocks, quote=False):
        pre = "> " if quote else ""
        for b in blocks:
            if b.kind == "h":
                out.extend([pre + "#" * b.level + " " + b.text, pre])
            elif b.kind == "p":
                out.extend([pre + b.text, pre])
            elif b.kind == "list":
                out.extend([pre + f"- {it}" for it in b.items] + [pre])
            elif b.kind == "code":
                out.extend([pre + "```"] + [pre + ln for ln in b.text.splitlines()] + [pre + "```", pre])
            elif b.kind == "table":
                out.append(pre + "| " + " | ".join(_md_cell(h) for h in b.header) + " |")
                out.append(pre + "|" + "|".join("---" for _ in b.header) + "|")
                for r in b.rows:
                    out.append(pre + "| " + " | ".join(_md_cell(c) for c in r) + " |")
                out.append(pre)
            elif b.kind == "fig":
                out.extend([pre + f"![{b.text}]({b.path})", pre, pre + f"*{b.text}*", pre])
            elif b.kind == "panel":
                out.extend([f"**{b.text}**", ""])
                emit(b.children, quote=True)
                out.append("")

    emit(doc.blocks)
    return "\n".join(out).rstrip() + "\n"


CSS = """
body{font-family:-apple-system,Segoe UI,Helvetica,Arial,sans-serif;max-width:1100px;margin:2em auto;padding:0 1em;
color:#222;line-height:1.45}
h1{border-bottom:2px solid #333;padding-bottom:.2em}h2{border-bottom:1px solid #bbb;margin-top:2em}
table{border-collapse:collapse;margin:.6em 0 1.2em 0;font-size:.9em}
th,td{border:1px solid #ccc;padding:.25em .6em;text-align:right}th{background:#f0f0f0}
td:first-child,th:first-child{text-align:left}
figure{margin:1em 0}figure img{max-width:100%;border:1px solid #ddd}figcaption{font-size:.85em;color:#555}
.panels{display:flex;gap:1.2em;flex-wrap:wrap;align-items:flex-start}
.panel{flex:1 1 440px;padding:.6em 1em;border-radius:6px}
.panel h3{margin-top:.2em}
.quoted{background:#f6f3ea;border:2px dashed #a08a4a}
.measured{background:#eef5fb;border:2px solid #2b6ca3}
.badge{display:inline-block;font-size:.75em;font-weight:bold;padding:.1em .5em;border-radius:3px;margin-right:.5em}
.quoted .badge{background:#a08a4a;color:#fff}.measured .badge{background:#2b6ca3;color:#fff}
.verdict{background:#fff8e1;border-left:4px solid #e0a800;padding:.4em .8em}
.good{background:#eaf7ea;border-left:4px solid #3c9a3c;padding:.4em .8em}
.muted{color:#666;font-size:.9em}
pre{background:#f7f7f7;padding:.6em;overflow-x:auto;font-size:.85em}
nav ul{columns:2;font-size:.9em}
"""


def render_html(doc: Doc, title: str, base: Path) -> str:
    """Self-contained HTML: every figure read from ``base / path`` and embedded as base64."""
    esc = html.escape
    out = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
           f"<title>{esc(title)}</title>", f"<style>{CSS}</style></head><body>", f"<h1>{esc(title)}</h1>"]
    heads = doc.headings()
    if heads:
        out.append("<nav><ul>" + "".join(f'<li><a href="#{h.anchor}">{esc(h.text)}</a></li>' for h in heads)
                   + "</ul></nav>")

    def emit(blocks):
        i = 0
        while i < len(blocks):
            b = blocks[i]
            if b.kind == "panel":
                # consecutive panels sit side by side
                group = []
                while i < len(blocks) and blocks[i].kind == "panel":
                    group.append(blocks[i])
                    i += 1
                out.append('<div class="panels">')
                for g in group:
                    badge = "QUOTED" if "quoted" in g.css else "MEASURED HERE"
                    out.append(f'<section class="panel {esc(g.css)}"><h3><span class="badge">{badge}</span>'
                               f"{esc(g.text)}</h3>")
                    emit(g.children)
                    out.append("</section>")
                out.append("</div>")
                continue
            if b.kind == "h":
                out.append(f'<h{b.level} id="{esc(b.anchor)}">{esc(b.text)}</h{b.level}>')
            elif b.kind == "p":
                cls = f' class="{esc(b.css)}"' if b.css else ""
                out.append(f"<p{cls}>{esc(b.text)}</p>")
            elif b.kind == "list":
                out.append("<ul>" + "".join(f"<li>{esc(str(it))}</li>" for it in b.items) + "</ul>")
            elif b.kind == "code":
                out.append(f"<pre>{esc(b.text)}</pre>")
            elif b.kind == "table":
                cls = f' class="{esc(b.css)}"' if b.css else ""
                out.append(f"<table{cls}><thead><tr>" + "".join(f"<th>{esc(str(h))}</th>" for h in b.header)
                           + "</tr></thead><tbody>")
                for r in b.rows:
                    out.append("<tr>" + "".join(f"<td>{esc(str(c))}</td>" for c in r) + "</tr>")
                out.append("</tbody></table>")
            elif b.kind == "fig":
                data = base64.b64encode((base / b.path).read_bytes()).decode("ascii")
                out.append(f'<figure><img alt="{esc(b.text)}" src="data:image/png;base64,{data}">'
                           f"<figcaption>{esc(b.text)}</figcaption></figure>")
            i += 1

    emit(doc.blocks)
    out.append(f'<p class="muted">Written by bpmid {esc(__version__)} (bpmid report).</p></body></html>')
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------------------------------
# reading the stage outputs
# --------------------------------------------------------------------------------------------------
def _load_yaml(path: Path) -> dict | None:
    from bpmid.config import read_yaml

    if not path.is_file():
        return None
    data, _sha = read_yaml(path)  # one line "file:line: not valid YAML: ..." on a broken file
    if not isinstance(data, dict):
        raise InputError("expected a YAML mapping", path=path)
    return data


def _load_csv(path: Path) -> pd.DataFrame | None:
    return pd.read_csv(path) if path.is_file() else None


@dataclasses.dataclass
class StudyFiles:
    """What a report can find in DIR (None where a stage's file is absent)."""

    root: Path
    run: dict | None
    relax: dict | None
    vbmm_fit: dict | None
    vbmm_mat: dict | None
    compare_yaml: dict | None
    metrics: pd.DataFrame | None
    summary: pd.DataFrame | None
    by_set: pd.DataFrame | None
    history: dict | None
    history_csv: pd.DataFrame | None
    discovery: dict | None

    @property
    def compare_dir(self) -> Path:
        return self.root / "compare" if (self.root / "compare" / "summary.csv").is_file() else self.root

    @property
    def synthetic(self) -> bool:
        for d in (self.run, self.compare_yaml):
            if d is not None and "synthetic" in d:
                return bool(d["synthetic"])
        return True

    def any(self) -> bool:
        return any(x is not None for x in (self.run, self.relax, self.vbmm_fit, self.compare_yaml, self.summary,
                                           self.history, self.discovery))


def read_study(root: str | Path) -> StudyFiles:
    """Load every stage output under ``root`` that exists (CLI.md names; ``compare/`` or DIR itself)."""
    root = Path(root)
    if root.exists() and not root.is_dir():
        raise InputError("is a file, not a folder (bpmid report takes the folder a run wrote)", path=root)
    if not root.is_dir():
        raise InputError("report folder not found", path=root)
    cdir = root / "compare" if (root / "compare" / "summary.csv").is_file() else root
    ddir = root / "discover" if (root / "discover" / "discovery.yaml").is_file() else root
    return StudyFiles(
        root=root, run=_load_yaml(root / "run.yaml"), relax=_load_yaml(root / "relax_fit.yaml"),
        vbmm_fit=_load_yaml(root / "vbmm_fit.yaml"), vbmm_mat=_load_yaml(root / "vbmm_mat.yaml"),
        compare_yaml=_load_yaml(cdir / "compare.yaml"), metrics=_load_csv(cdir / "metrics.csv"),
        summary=_load_csv(cdir / "summary.csv"), by_set=_load_csv(cdir / "summary_by_set.csv"),
        history=_load_yaml(root / "history_modes.yaml"), history_csv=_load_csv(root / "history_modes.csv"),
        discovery=_load_yaml(ddir / "discovery.yaml"))


def _val(entry) -> float | None:
    if isinstance(entry, dict):
        v = entry.get("value")
    else:
        v = entry
    return None if v is None else float(v)


def _se(entry) -> float | None:
    return None if not isinstance(entry, dict) or entry.get("stderr") is None else float(entry["stderr"])


def _rel(path: Path, root: Path) -> str:
    return path.relative_to(root).as_posix()


# --------------------------------------------------------------------------------------------------
# sections
# --------------------------------------------------------------------------------------------------
def _provenance_section(doc: Doc, st: StudyFiles) -> None:
    doc.h("Provenance: what was run")
    run = st.run or {}
    prov = run.get("provenance") or {}
    if not prov:  # a folder made by single commands: take the first provenance block found
        for d in (st.compare_yaml, st.vbmm_fit, st.relax, st.history, st.discovery):
            if d and d.get("provenance"):
                prov = d["provenance"]
                break
    rows = [["bpmid version (this report)", __version__],
            ["bpmid version (the run)", prov.get("bpmid_version", "-")],
            ["command", prov.get("command", "-")],
            ["config", (prov.get("config") or {}).get("path", "-")],
            ["config sha256", (prov.get("config") or {}).get("sha256", "-")],
            ["created", prov.get("created", "-")],
            ["seed", prov.get("seed", "-")]]
    doc.table(["item", "value"], rows)
    if run.get("stages"):
        doc.p("Stages of the run (wall time on this machine):")
        doc.table(["stage", "status", "seconds", "outputs"],
                  [[s.get("name"),
                    "this report" if (s.get("name"), s.get("status")) == ("report", "running") else s.get("status"),
                    fmt(s.get("seconds")), ", ".join(s.get("outputs") or []) or "-"]
                   for s in run["stages"]])
    inputs: dict[str, str] = {}
    for d in (st.run, st.relax, st.vbmm_fit, st.compare_yaml, st.history, st.discovery):
        if d and isinstance(d.get("provenance"), dict):
            inputs.update(d["provenance"].get("inputs") or {})
    if inputs:
        doc.p(f"Input files ({len(inputs)}) and their sha256:")
        doc.table(["input file", "sha256"], [[k, v] for k, v in sorted(inputs.items())])
    if st.synthetic:
        doc.p("All motion and relaxation logs of this run are synthetic (bpmid's digital twin, shipped "
              "datasets); every figure made from them says so in its corner. Numbers in this report labelled "
              "'measured here' are bpmid's results on these synthetic logs.", css="verdict")


def _relax_section(doc: Doc, st: StudyFiles, figs: dict) -> None:
    doc.h("Relaxation fit (material)")
    r = st.relax
    if r is None:
        doc.p("Not run (no relax_fit.yaml in this folder).", css="muted")
        return
    rows = []
    pr = r.get("prony") or {}
    rows.append(["E_inf", fmt(_val(pr.get("E_inf"))), fmt(_se(pr.get("E_inf"))), (pr.get("E_inf") or {}).get("unit", "Pa")])
    for j, tr in enumerate(pr.get("terms") or [], 1):
        rows.append([f"E_{j}", fmt(_val(tr.get("E"))), fmt(_se(tr.get("E"))), (tr.get("E") or {}).get("unit", "Pa")])
        rows.append([f"tau_{j}", fmt(_val(tr.get("tau"))), fmt(_se(tr.get("tau"))), (tr.get("tau") or {}).get("unit", "s")])
    rows.append(["poisson_ratio", fmt(r.get("poisson_ratio"), 6), "-", "1"])
    for block, name in (("shear", "G"), ("bulk", "K")):
        b = r.get(block) or {}
        if f"{name}_inf" in b:
            rows.append([f"{name}_inf", fmt(_val(b[f"{name}_inf"])), fmt(_se(b[f"{name}_inf"])), "Pa"])
            for j, tr in enumerate(b.get("terms") or [], 1):
                rows.append([f"{name}_{j}", fmt(_val(tr.get(name))), fmt(_se(tr.get(name))), "Pa"])
    doc.p(f"Prony series fitted in {r.get('mode', '?')} mode; constants with standard errors "
          "(G and K follow from E with the Poisson ratio).")
    doc.table(["constant", "value", "stderr", "unit"], rows)
    m = r.get("metrics") or {}
    doc.table(["metric", "value"], [["RMSE (Pa)", fmt(m.get("rmse"))], ["R^2", fmt(m.get("r2"))],
                                    ["MAPE (%)", fmt(m.get("mape_pct"))]])
    if "modulus" in figs:
        doc.fig(figs["modulus"], "Relaxation-modulus curves E(t), G(t), K(t) of the fit (the paper's published "
                "E(t) dashed, quoted for comparison: it was fitted to the paper's own tests).")
    png = st.root / "relax_fit.png"
    if png.is_file():
        doc.fig("relax_fit.png", "Relaxation fit against the relaxation logs (from bpmid fit relax).")


def _material_rows(d: dict) -> dict[str, dict]:
    mat = (d or {}).get("material") or {}
    out = {}
    for k in ("G_inf", "K_inf"):
        if k in mat:
            out[k] = mat[k]
    for j, b in enumerate(mat.get("branches") or [], 1):
        for k, v in b.items():
            out[f"{k}_{j}"] = v
    return out


def _motion_section(doc: Doc, st: StudyFiles, figs: dict) -> None:
    doc.h("Motion fit: VBMM-mat. and VBMM-fit")
    fit = st.vbmm_fit
    mat_params = None
    if st.vbmm_mat is not None:
        mat_params = _material_rows(st.vbmm_mat)
    elif st.compare_yaml and "vbmm-mat" in (st.compare_yaml.get("models") or {}):
        mat_params = (st.compare_yaml["models"]["vbmm-mat"].get("parameters") or {})
    if fit is None and mat_params is None:
        doc.p("Not run (no vbmm_fit.yaml in this folder).", css="muted")
        return
    fit_params = _material_rows(fit) if fit is not None else {}
    verdicts = ((fit or {}).get("uncertainty") or {}).get("identifiability") or {}
    names = list(dict.fromkeys(list(mat_params or {}) + list(fit_params)))
    rows = []
    for n in names:
        a = (mat_params or {}).get(n)
        b = fit_params.get(n)
        unit = (b or a or {}).get("unit", "") if isinstance(b or a, dict) else ""
        rows.append([n, fmt(_val(a)) if a is not None else "-", fmt(_val(b)) if b is not None else "-",
                     fmt(_se(b)) if b is not None else "-", unit, verdicts.get(n, "-")])
    doc.p("VBMM-mat. takes its constants straight from the relaxation fit (nothing refitted); VBMM-fit refits "
          "them on the fitting set. A constant the motion data cannot determine is held at its prior value and "
          "says so (identifiability).")
    doc.table(["constant", "VBMM-mat.", "VBMM-fit", "VBMM-fit stderr", "unit", "VBMM-fit verdict"], rows)
    if fit is not None:
        m = fit.get("metrics") or {}
        doc.p(f"VBMM-fit on its own fitting set: RMSE {fmt(m.get('rmse_deg'))} deg, MAPE {fmt(m.get('mape_pct'))} %, "
              f"R^2 {fmt(m.get('r2'))} (closure {fit.get('closure', '?')}, history "
              f"{(fit.get('model') or {}).get('history', '?')}).")
    png = st.root / "vbmm_fit.png"
    if png.is_file():
        doc.fig("vbmm_fit.png", "VBMM-fit on the fitting set (from the motion fit).")


def _set_row(st: StudyFiles, names: Sequence[str], model: str):
    if st.by_set is None:
        return None
    g = st.by_set[(st.by_set["set"].isin(names)) & (st.by_set["model"] == model)]
    return None if g.empty else g.iloc[0]


def _paper_section(doc: Doc, st: StudyFiles) -> None:
    doc.h("The paper's numbers beside ours")
    doc.p("Two separate tables. The left one is QUOTED from the paper and describes the paper's muscle and data; "
          "the right one is MEASURED HERE by bpmid on the shipped synthetic logs. They follow the same protocols "
          "but are different data: read them side by side, never as one table.")
    with doc.panel("Paper's numbers (quoted, the paper's data)", "quoted"):
        doc.p(PAPER_SOURCE)
        doc.table(["experiment", "quantity", "value", "unit"], [[e, q, fmt(v), u] for e, q, v, u in PAPER_ROWS])
    label = "Measured here (bpmid, synthetic shipped data)" if st.synthetic else "Measured here (bpmid, this run's data)"
    with doc.panel(label, "measured"):
        doc.p(f"Computed by bpmid {__version__} in this run; test sets as in the comparison below.")
        rows = []
        r = st.relax
        if r is not None:
            pr = r.get("prony") or {}
            terms = pr.get("terms") or []
            rows.append(["Relaxation fit", "E_inf", fmt(_val(pr.get("E_inf")) / 1e6), "MPa"])
            for j, tr in enumerate(terms, 1):
                rows.append(["Relaxation fit", f"E_{j}", fmt(_val(tr["E"]) / 1e6), "MPa"])
                rows.append(["Relaxation fit", f"tau_{j}", fmt(_val(tr["tau"])), "s"])
            m = r.get("metrics") or {}
            if m.get("rmse") is not None:
                rows.append(["Relaxation fit", "RMSE", fmt(m["rmse"] / 1e6), "MPa"])
            rows.append(["Relaxation fit", "R^2", fmt(m.get("r2")), "1"])
            rows.append(["Relaxation fit", "MAPE", fmt(m.get("mape_pct")), "%"])
        for tag, names in (("1a variable amplitude", SET_1A), ("1b variable rate", SET_1B)):
            for model, lab in (("vbmm-fit", "VBMM-fit"), ("vbmm-mat", "VBMM-mat.")):
                row = _set_row(st, names, model)
                if row is None:
                    continue
                rows += [[f"{tag}, {lab}", "RMSE", fmt(row.rmse_deg), "deg"],
                         [f"{tag}, {lab}", "MAPE", fmt(row.mape_pct), "%"],
                         [f"{tag}, {lab}", "R^2", fmt(row.r2), "1"]]
        h = st.history
        if h is not None:
            acc = h.get("accuracy") or {}
            us = h.get("us_per_step_longest") or {}
            w = h.get("window_s")
            rows += [["2 long term, full history", "RMSE", fmt((acc.get("full") or {}).get("rmse_deg")), "deg"],
                     [f"2 long term, window (T_win = {fmt(w)} s)", "RMSE",
                      fmt((acc.get("window") or {}).get("rmse_deg")), "deg"],
                     [f"2 long term, window (T_win = {fmt(w)} s)", "cost per step", fmt(us.get("window")), "us"],
                     ["2 long term, recursive (exact)", "cost per step", fmt(us.get("recursive")), "us"],
                     ["2 long term, window vs full", "cost reduction", fmt(h.get("window_cost_reduction_pct")), "%"]]
        if rows:
            doc.table(["experiment", "quantity", "value", "unit"], rows)
        else:
            doc.p("No stage outputs to set beside the paper's numbers.", css="muted")


def _compare_section(doc: Doc, st: StudyFiles, figs: dict) -> None:
    from bpmid.compare import verdicts

    doc.h("Model comparison")
    if st.summary is None:
        doc.p("Not run (no compare/summary.csv).", css="muted")
        return
    cy = st.compare_yaml or {}
    sets = cy.get("test_sets") or {}
    train = cy.get("train") or []
    doc.p(f"Every model was fitted on the training logs only ({len(train)} log(s)) and then run free (pressure in, "
          f"angle out, no measured angle fed back) on every test log ({sum(len(v) for v in sets.values())} log(s) in "
          f"{len(sets)} set(s): {', '.join(sets)}). Cost per step: wall-clock time of one free-running simulation "
          "on this machine, divided by its samples.")
    for w in cy.get("warnings") or []:
        doc.p("Warning: " + w, css="verdict")
    lines = verdicts((st.summary, st.by_set))
    doc.p(lines[0], css="good")
    for line in lines[1:]:
        doc.p(line, css="verdict" if "beats" in line else "good")
    s = st.summary.sort_values("rmse_deg", kind="mergesort")
    cols = ["model", "rmse_deg", "mape_pct", "r2", "fit_pct", "max_abs_err_deg", "us_per_step", "n_params"]
    doc.p("Pooled over all test logs (summary.csv), ranked by RMSE:")
    doc.table(["rank"] + cols, [[i + 1] + [fmt(getattr(r, c)) if c != "model" else r.model for c in cols]
                                for i, r in enumerate(s.itertuples())])
    if st.by_set is not None and st.by_set["set"].nunique() > 1:
        doc.p("Per test set (summary_by_set.csv):")
        rows = []
        for name, g in st.by_set.groupby("set", sort=False):
            for r in g.sort_values("rmse_deg", kind="mergesort").itertuples():
                rows.append([name, r.model, fmt(r.rmse_deg), fmt(r.mape_pct), fmt(r.r2), fmt(r.us_per_step)])
        doc.table(["test set", "model", "rmse_deg", "mape_pct", "r2", "us_per_step"], rows)
    cdir = st.compare_dir
    for name, cap in (("compare_summary.png", "Summary bar chart: RMSE (pooled and per set), R^2, MAPE, cost per step."),
                      ("compare_timeseries.png", "All models over the measured angle, on test logs from each set."),
                      ("compare_loops.png", "Pressure-angle loops: measured (grey) and each model."),
                      ("compare_errors.png", "Error against time on the same test logs.")):
        if (cdir / name).is_file():
            doc.fig(_rel(cdir / name, st.root), cap)
    if "bands" in figs:
        doc.fig(figs["bands"], "Error bands: each model's mean error over the logs of a test set, shaded from the "
                "smallest to the largest error across the set.")


def _history_section(doc: Doc, st: StudyFiles) -> None:
    doc.h("History modes on the long-term run")
    h = st.history
    if h is None:
        doc.p("Not run (no history_modes.yaml).", css="muted")
        return
    acc = h.get("accuracy") or {}
    wvf = h.get("window_vs_full") or {}
    doc.p(f"The fitted VBMM ({h.get('params') or 'constants'}) run forward on {h.get('log')} "
          f"({h.get('samples')} samples, {fmt(h.get('duration_s'))} s) in the three history modes: recursive "
          f"(exact, O(1) per step), window (eq. 19, T_win = {fmt(h.get('window_s'))} s) and full (eq. 5, O(k) at step "
          "k). Timings are wall-clock on this machine.")
    doc.table(["mode", "RMSE vs measured (deg)", "MAPE (%)", "R^2", "us per step (whole log)"],
              [[m, fmt(a.get("rmse_deg")), fmt(a.get("mape_pct")), fmt(a.get("r2")),
                fmt((h.get("us_per_step_longest") or {}).get(m))] for m, a in acc.items()])
    doc.p(f"Window minus full on the whole log: RMS difference {fmt(wvf.get('rmse_diff_deg'))} deg, largest "
          f"{fmt(wvf.get('max_abs_diff_deg'))} deg, RMSE change {fmt(wvf.get('rmse_change_deg'))} deg; the window "
          f"costs {fmt(h.get('window_cost_reduction_pct'))} % less per step than the full sum at this length.")
    if st.history_csv is not None:
        doc.table(list(st.history_csv.columns),
                  [[fmt(v) if not isinstance(v, str) else v for v in r] for r in st.history_csv.itertuples(index=False)])
    if (st.root / "history_modes.png").is_file():
        doc.fig("history_modes.png", "Cost per simulated step against log length for the three history modes, and "
                "the error of full and window on the long-term run with their difference.")


def residual_table(frames: Sequence[pd.DataFrame], models: Sequence[str]) -> list[list]:
    """Per model on the pooled test logs: lag-1 autocorrelation, share of lags 1..50 outside the 99 %
    whiteness bounds, correlation of the residual with the pressure rate, mean residual rising and falling."""
    from bpmid.plots.report import acf

    rows = []
    for m in models:
        col = f"pred_{m}_deg"
        res, rate, outside, lag1 = [], [], [], []
        for f in frames:
            if col not in f:
                continue
            e = f[col].to_numpy() - f["angle_deg"].to_numpy()
            p = f["pressure_pa_gauge"].to_numpy()
            rt = np.gradient(p, f["time_s"].to_numpy())
            res.append(e)
            rate.append(rt)
            lags = min(50, e.size - 1)
            a = acf(e, lags)
            lag1.append(a[1] if lags >= 1 else np.nan)
            outside.append(np.mean(np.abs(a[1:]) > 2.576 / np.sqrt(e.size)) if lags >= 1 else np.nan)
        if not res:
            continue
        e, rt = np.concatenate(res), np.concatenate(rate)
        corr = float(np.corrcoef(e, rt)[0, 1]) if np.std(e) > 0 and np.std(rt) > 0 else float("nan")
        up, down = e[rt > 0], e[rt < 0]
        rows.append([m, fmt(float(np.mean(lag1))), fmt(100 * float(np.mean(outside))), fmt(corr),
                     fmt(float(up.mean()) if up.size else None), fmt(float(down.mean()) if down.size else None)])
    return rows


def _residual_section(doc: Doc, st: StudyFiles, figs: dict, frames, models) -> None:
    doc.h("Residual diagnostics")
    if not frames:
        doc.p("Not available (no compare/predictions/).", css="muted")
        return
    doc.p("Residual = prediction minus measurement on the test logs. A model that has captured the dynamics leaves "
          "a residual that is close to white and does not track the pressure rate or its sign.")
    doc.table(["model", "lag-1 autocorrelation", "lags 1..50 outside 99 % bounds (%)", "corr. with pressure rate",
               "mean residual, rising (deg)", "mean residual, falling (deg)"], residual_table(frames, models))
    if "residuals" in figs:
        doc.fig(figs["residuals"], "Residual autocorrelation with whiteness bounds, residual against pressure rate, "
                "and residual distributions (all test logs).")


def _discovery_section(doc: Doc, st: StudyFiles) -> None:
    doc.h("Discovery of missing effects")
    d = st.discovery
    if d is None:
        doc.p("Not run (no discover/discovery.yaml): the discovery stage had no inputs or is not available.",
              css="muted")
        return
    named = d.get("named_effects") or []
    gap = d.get("gap") or {}
    if named:
        doc.p(f"Named effects, in the order added: {', '.join(named)}.", css="verdict")
    else:
        doc.p("No missing effect found: no catalogue entry passed the confirmation tests.", css="good")
    doc.table(["gap on held-out data", "deg"], [["before (base model)", fmt(gap.get("before_rmse_deg"))],
                                                ["after (with named effects)", fmt(gap.get("after_rmse_deg"))],
                                                ["sensor-noise floor", fmt(gap.get("noise_floor_deg"))]])
    doc.p("Unexplained remainder: " + ("yes, the gap is not closed by the catalogue" if d.get("unexplained")
                                       else "no, what remains is at the noise floor"))
    steps = d.get("steps") or []
    if steps:
        rows = []
        for s in steps:
            if isinstance(s, dict):
                ev = s.get("evidence")
                ev_txt = ev if isinstance(ev, str) else yaml.safe_dump(ev, default_flow_style=True, width=10000).strip() if ev else "-"
                rows.append([s.get("id", s.get("effect", "?")), ev_txt[:300]])
        if rows:
            doc.table(["effect", "evidence"], rows)
    ddir = st.root / "discover"
    if ddir.is_dir():
        for png in sorted(ddir.glob("*.png")):
            doc.fig(_rel(png, st.root), f"Discovery: {png.stem.replace('_', ' ')}.")


# --------------------------------------------------------------------------------------------------
# figures the report draws, and the whole report
# --------------------------------------------------------------------------------------------------
def _prediction_frames(st: StudyFiles) -> tuple[dict[str, list[pd.DataFrame]], list[str]]:
    pdir = st.compare_dir / "predictions"
    if not pdir.is_dir():
        return {}, []
    sets = (st.compare_yaml or {}).get("test_sets") or {"test": sorted(p.stem for p in pdir.glob("*.csv"))}
    out: dict[str, list[pd.DataFrame]] = {}
    for s, names in sets.items():
        frames = [pd.read_csv(pdir / f"{n}.csv") for n in names if (pdir / f"{n}.csv").is_file()]
        if frames:
            out[s] = frames
    models = list(st.summary["model"]) if st.summary is not None else []
    return out, models


def make_figures(st: StudyFiles) -> dict[str, str]:
    """Draw the report's own figures into DIR/report_figures/; returns key -> path relative to DIR."""
    from bpmid.plots import report as RP
    from bpmid.plots.common import save_figure

    figs = {}
    fdir = st.root / FIGURE_DIR
    if st.relax is not None:
        save_figure(RP.modulus_curves(st.relax, paper=PAPER_RELAX, synthetic=st.synthetic), fdir / "modulus_curves.png")
        figs["modulus"] = f"{FIGURE_DIR}/modulus_curves.png"
    sets, models = _prediction_frames(st)
    if sets and models:
        save_figure(RP.error_bands(sets, models, synthetic=st.synthetic), fdir / "error_bands.png")
        figs["bands"] = f"{FIGURE_DIR}/error_bands.png"
        frames = [f for v in sets.values() for f in v]
        save_figure(RP.residual_diagnostics(frames, models, synthetic=st.synthetic), fdir / "residuals.png")
        figs["residuals"] = f"{FIGURE_DIR}/residuals.png"
    return figs


def build_report(st: StudyFiles, figs: dict[str, str]) -> Doc:
    doc = Doc()
    doc.p("This report separates two kinds of numbers: those MEASURED HERE by bpmid in this run, and the source "
          "paper's published figures, QUOTED for comparison and always labelled as the paper's numbers on the "
          "paper's data.", css="muted")
    _provenance_section(doc, st)
    _relax_section(doc, st, figs)
    _motion_section(doc, st, figs)
    _paper_section(doc, st)
    _compare_section(doc, st, figs)
    _history_section(doc, st)
    sets, models = _prediction_frames(st)
    _residual_section(doc, st, figs, [f for v in sets.values() for f in v], models)
    _discovery_section(doc, st)
    return doc


def write_report(out_dir: str | Path, *, title: str = "bpmid study report") -> tuple[Path, Path]:
    """Write ``out_dir/report.html`` (self-contained) and ``out_dir/report.md``; returns their paths.

    InputError when the folder holds no stage output at all.
    """
    from bpmid.io.atomic import write_text

    st = read_study(out_dir)
    if not st.any():
        raise InputError("no stage outputs found (expected run.yaml, relax_fit.yaml, vbmm_fit.yaml, compare/, "
                         "history_modes.yaml or discover/discovery.yaml)", path=out_dir)
    figs = make_figures(st)
    doc = build_report(st, figs)
    root = Path(out_dir)
    md = write_text(root / "report.md", render_markdown(doc, title))
    page = write_text(root / "report.html", render_html(doc, title, root))
    return page, md
