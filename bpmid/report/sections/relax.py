"""Relaxation fit (material): constants with standard errors, metrics, parameter correlations, figures."""
from __future__ import annotations

from bpmid.report.doc import fmt
from bpmid.report.figures import find_figure
from bpmid.report.sections import absent, stale_note

KEY = "relax"
TITLE = "Relaxation fit (material)"


def build(doc, st, figs) -> None:
    doc.section(KEY, TITLE)
    r = st.relax
    if r is None:
        absent(doc, st, "relax_fit.yaml")
        return
    stale_note(doc, st, "relax")
    doc.p(f"Prony series fitted in {r.mode} mode on {len(r.logs)} relaxation log(s) ({', '.join(r.logs) or '-'}); "
          "constants with standard errors (G and K follow from E with the Poisson ratio).")
    rows = [[p.name, fmt(p.value), fmt(p.stderr), p.unit] for p in r.constants]
    rows.append(["ν (Poisson ratio)", fmt(r.poisson, 6), "-", "1"])
    rows += [[p.name, fmt(p.value), fmt(p.stderr), p.unit] for p in r.derived]
    doc.table(["constant", "value", "stderr", "unit"], rows)
    doc.table(["metric", "value"], [["RMSE (Pa)", fmt(r.rmse_pa)], ["R²", fmt(r.r2)], ["MAPE (%)", fmt(r.mape_pct)]])
    if r.corr_names and len(r.corr) == len(r.corr_names):
        doc.p("Parameter correlations of the fit (from the covariance; |r| near 1 means the data hardly separate "
              "the two constants):")
        doc.table(["", *r.corr_names], [[n, *[fmt(v, 3) for v in row]] for n, row in zip(r.corr_names, r.corr)])
    f = find_figure(st.root, "relax_fit")
    if f:
        doc.fig(f, "Relaxation fit: (a) stress data (dots) and fit (lines) per log; (b) relaxation-modulus data of "
                "every hold with the fitted E(t); (c) residuals of all logs with their binned RMS.")
    if "modulus" in figs:
        doc.fig(figs["modulus"], "Fitted relaxation moduli E(t), G(t), K(t); the paper's published E(t) dashed, "
                "QUOTED for comparison (fitted to the paper's own tests).")
