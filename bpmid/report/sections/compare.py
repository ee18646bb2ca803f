"""Model comparison: every model fitted on the training logs and run free on the test logs."""
from __future__ import annotations

import re

from bpmid.report.doc import fmt
from bpmid.report.figures import find_figure
from bpmid.report.sections import absent, stale_note

KEY = "compare"
TITLE = "Model comparison"


def build(doc, st, figs) -> None:
    from bpmid.compare import verdicts

    doc.section(KEY, TITLE)
    c = st.compare
    if c is None:
        absent(doc, st, "compare/summary.csv")
        return
    stale_note(doc, st, "compare")
    doc.p(f"Every model was fitted on the training logs only ({len(c.train)} log(s)) and then run free (pressure in, "
          f"angle out, no measured angle fed back) on every test log ({sum(len(v) for v in c.test_sets.values())} "
          f"log(s) in {len(c.test_sets)} set(s): {', '.join(c.test_sets) or '-'}). Cost per step: wall-clock time of "
          "one free-running simulation on this machine, divided by its samples.")
    for w in c.warnings:
        doc.p("Warning: " + w, css="verdict")
    try:
        lines = verdicts((c.summary, c.by_set))
    except (KeyError, ValueError, IndexError, AttributeError) as exc:  # a table without the columns verdicts needs
        lines = [f"(no verdict: {type(exc).__name__} {exc})"]
    lines = [re.sub(r"(\d) deg\b", "\\1°", line) for line in lines]  # the report's unit symbol
    doc.p(lines[0], css="good")
    for line in lines[1:]:
        doc.p(line, css="verdict" if "beats" in line else "good")
    s = c.ranking
    cols = [("model", "model"), ("rmse_deg", "RMSE (°)"), ("mape_pct", "MAPE (%)"), ("r2", "R²"), ("fit_pct", "fit (%)"),
            ("max_abs_err_deg", "max |error| (°)"), ("us_per_step", "µs per step"), ("n_params", "parameters")]
    cols = [(k, lab) for k, lab in cols if k in s.columns]
    doc.p("Pooled over all test logs (summary.csv), ranked by RMSE:")
    doc.table(["rank"] + [lab for _k, lab in cols],
              [[i + 1] + [getattr(r, k) if k == "model" else fmt(getattr(r, k)) for k, _lab in cols]
               for i, r in enumerate(s.itertuples())])
    if c.by_set is not None and c.by_set["set"].nunique() > 1:
        doc.p("Per test set (summary_by_set.csv):")
        rows = []
        for name, g in c.by_set.groupby("set", sort=False):
            for r in g.sort_values("rmse_deg", kind="mergesort").itertuples():
                rows.append([name, r.model, fmt(r.rmse_deg), fmt(getattr(r, "mape_pct", None)),
                             fmt(getattr(r, "r2", None)), fmt(getattr(r, "us_per_step", None))])
        doc.table(["test set", "model", "RMSE (°)", "MAPE (%)", "R²", "µs per step"], rows)
    rel = c.dir.relative_to(st.root).as_posix() if c.dir != st.root else ""
    pre = f"{rel}/" if rel else ""
    for stem, cap in (("compare_summary", "Summary: RMSE pooled and per test set (hatching), R², MAPE and cost per "
                       "simulated step (log scale) of every model."),
                      ("compare_timeseries", "Free-running predictions of every model over the measured angle "
                       "(grey), on test logs from each set; each model keeps its colour and line style."),
                      ("compare_loops", "Pressure-angle loops: measured (grey) and each model, gauge pressure."),
                      ("compare_errors", "Prediction error against time on the same test logs.")):
        f = find_figure(st.root, pre + stem)
        if f:
            doc.fig(f, cap)
    if "bands" in figs:
        doc.fig(figs["bands"], "Error bands, one panel per test set (rows) and model (columns): the mean error over "
                "the set's logs, shaded from the smallest to the largest error across them.")
