"""The paper's published numbers (QUOTED) beside the numbers measured here, in two separate panels."""
from __future__ import annotations

from bpmid import __version__
from bpmid.report.doc import fmt
from bpmid.report.paper import PAPER_ROWS, PAPER_SOURCE, SET_1A, SET_1B
from bpmid.report.sections import stale_ref

KEY = "paper"
TITLE = "The paper's numbers beside ours"


def _set_row(st, names, model):
    c = st.compare
    if c is None or c.by_set is None:
        return None
    g = c.by_set[(c.by_set["set"].isin(names)) & (c.by_set["model"] == model)]
    return None if g.empty else g.iloc[0]


def _what_differs(st) -> str:
    """What the study's files say of its logs beside the paper's: the protocols they follow (the manifest.yaml
    beside each log) and the muscle (the motion fit's geometry against the paper's Table I). Nothing is said
    that the files do not tell."""
    import math

    from bpmid.models.vbmm.model import Geometry

    paper, other, unknown = st.protocols()
    parts = []
    if other:
        parts.append(f"this study's logs follow other protocols than the paper's ({', '.join(other)}, as the "
                     "manifest.yaml beside them records)")
    elif paper and not unknown:
        parts.append(f"this study's logs follow the paper's protocols (bpmid's shipped {', '.join(paper)}, as the "
                     "manifest.yaml beside them records)")
    g = st.motion.geometry if st.motion is not None else {}
    ref = Geometry()
    shown = (("th", 1e3, "mm"), ("alpha0", 180 / math.pi, "°"), ("R0", 1e3, "mm"), ("l0", 1e3, "mm"), ("n", 1.0, ""))
    try:
        differ = [(k, float(g[k]) * f, getattr(ref, k) * f, u) for k, f, u in shown
                  if k in g and not math.isclose(float(g[k]), getattr(ref, k), rel_tol=1e-6)]
    except (TypeError, ValueError):
        differ = []
    if differ:
        def val(x, u):
            return f"{fmt(x)}{u}" if u in ("", "°") else f"{fmt(x)} {u}"

        words = ", ".join(f"{k} {val(a, u)} against {val(b, u)}" for k, a, b, u in differ)
        parts.append(f"this study's muscle is not the paper's (the motion fit's geometry against the paper's Table I: {words})")
    if not parts:
        return "They are different data."
    return "They are different data: " + ", and ".join(parts) + "."


def build(doc, st, figs) -> None:
    doc.section(KEY, TITLE)
    doc.p("Two separate tables. The left one is QUOTED from the paper and describes the paper's muscle and data; "
          "the right one is MEASURED HERE by bpmid on this study's logs. " + _what_differs(st)
          + " Read them side by side, never as one table.")
    with doc.panel("Paper's numbers (quoted, the paper's data)", "quoted"):
        doc.p(PAPER_SOURCE)
        doc.table(["experiment", "quantity", "value", "unit"], [[e, q, fmt(v), u] for e, q, v, u in PAPER_ROWS])
    paper, other, unknown = st.protocols()   # "shipped" only for logs the manifests tie to the shipped protocols
    twin = st.synthetic and st.made_by_twin()
    label = ("Measured here (bpmid, synthetic shipped data)" if twin and paper and not other and not unknown else
             "Measured here (bpmid, this run's synthetic data, made by bpmid's digital twin)" if twin else
             "Measured here (bpmid, this run's synthetic data)" if st.synthetic else "Measured here (bpmid, this run's data)")
    with doc.panel(label, "measured"):
        doc.p(f"Computed by bpmid {__version__}; test sets as in the comparison.")
        stale_ref(doc, st, ("relax", "compare", "history"), "the numbers")
        rows = []
        r = st.relax
        if r is not None:
            for p in r.constants:
                if p.value is None:
                    continue
                v, u = (p.value / 1e6, "MPa") if p.unit == "Pa" else (p.value, p.unit)
                rows.append(["Relaxation fit", p.name, fmt(v), u])
            if r.rmse_pa is not None:
                rows.append(["Relaxation fit", "RMSE", fmt(r.rmse_pa / 1e6), "MPa"])
            rows.append(["Relaxation fit", "R²", fmt(r.r2), "1"])
            rows.append(["Relaxation fit", "MAPE", fmt(r.mape_pct), "%"])
        for tag, names in (("1a variable amplitude", SET_1A), ("1b variable rate", SET_1B)):
            for model, lab in (("vbmm-fit", "VBMM-fit"), ("vbmm-mat", "VBMM-mat.")):
                row = _set_row(st, names, model)
                if row is None:
                    continue
                rows += [[f"{tag}, {lab}", "RMSE", fmt(row.rmse_deg), "°"],
                         [f"{tag}, {lab}", "MAPE", fmt(row.get("mape_pct")), "%"],
                         [f"{tag}, {lab}", "R²", fmt(row.get("r2")), "1"]]
        h = st.history
        if h is not None:
            w = h.window_s
            rows += [["2 long term, full history", "RMSE", fmt(h.accuracy.get("full", {}).get("rmse_deg")), "°"],
                     [f"2 long term, window (T_win = {fmt(w)} s)", "RMSE",
                      fmt(h.accuracy.get("window", {}).get("rmse_deg")), "°"],
                     [f"2 long term, window (T_win = {fmt(w)} s)", "cost per step", fmt(h.us_per_step.get("window")),
                      "µs"],
                     ["2 long term, recursive (exact)", "cost per step", fmt(h.us_per_step.get("recursive")), "µs"],
                     ["2 long term, window vs full", "cost reduction", fmt(h.reduction_pct), "%"]]
        if rows:
            doc.table(["experiment", "quantity", "value", "unit"], rows)
        else:
            doc.p("No stage outputs to set beside the paper's numbers.", css="muted")
    doc.p("The paper's control experiment (Fig. 18) is set beside bpmid's closed-loop results in the Control "
          "section.", css="muted")
