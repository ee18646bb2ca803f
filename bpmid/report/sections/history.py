"""History modes (recursive, window, full) on the long-term run: accuracy and cost."""
from __future__ import annotations

from bpmid.report.doc import fmt
from bpmid.report.figures import find_figure
from bpmid.report.sections import absent, stale_note
from bpmid.report.sections.summary import cost_phrase

KEY = "history"
TITLE = "History modes on the long-term run"


def build(doc, st, figs) -> None:
    doc.section(KEY, TITLE)
    h = st.history
    if h is None:
        absent(doc, st, "history_modes.yaml")
        return
    stale_note(doc, st, "history")
    raw = h.raw
    # the stage's constants are this run's fit or, without a motion stage, the paper's: not always "fitted"
    doc.p(f"The VBMM ({raw.get('params') or 'constants'}) run forward on {h.log} ({raw.get('samples')} "
          f"samples, {fmt(raw.get('duration_s'))} s) in the three history modes: recursive (exact, O(1) per step), "
          f"window (eq. 19, T_win = {fmt(h.window_s)} s) and full (eq. 5, O(k) at step k). Timings are wall-clock "
          "on this machine.")
    for w in h.provenance.get("warnings") or []:   # as the stage printed them (a poor fit to this log, ...)
        doc.p("Warning: " + str(w), css="verdict")
    doc.table(["mode", "RMSE vs measured (°)", "MAPE (%)", "R²", "µs per step (whole log)"],
              [[m, fmt(a.get("rmse_deg")), fmt(a.get("mape_pct")), fmt(a.get("r2")), fmt(h.us_per_step.get(m))]
               for m, a in h.accuracy.items()])
    w = h.window_vs_full
    doc.p(f"Window minus full on the whole log: RMS difference {fmt(w.get('rmse_diff_deg'))}°, largest "
          f"{fmt(w.get('max_abs_diff_deg'))}°, RMSE change {fmt(w.get('rmse_change_deg'))}°; the window costs "
          f"{cost_phrase(h.reduction_pct)} per step than the full sum at this length.")
    if h.table is not None:
        doc.table(list(h.table.columns), [[fmt(v) if not isinstance(v, str) else v for v in r]
                                          for r in h.table.itertuples(index=False)])
    f = find_figure(st.root, "history_modes")
    if f:
        doc.fig(f, "(a) Cost per simulated step against log length for the three history modes; (b) error of full "
                "and window on the long-term run (they lie on each other when they agree); (c) window minus full on "
                "its own scale.")
