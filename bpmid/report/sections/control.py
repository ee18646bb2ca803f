"""Closed-loop control: PI, VBMM-PI and MS-PI on the shipped references (the paper's Fig. 18), with the
paper's quoted numbers in a panel of their own."""
from __future__ import annotations

from bpmid.report.doc import fmt
from bpmid.report.figures import find_figure
from bpmid.report.paper import PAPER_CONTROL, PAPER_CONTROL_SOURCE
from bpmid.report.sections import absent, stale_note

KEY = "control"
TITLE = "Closed-loop control"
LABELS = {"pi": "PI", "vbmm-pi": "VBMM-PI", "ms-pi": "MS-PI"}


def build(doc, st, figs) -> None:
    doc.section(KEY, TITLE)
    k = st.control
    if k is None:
        absent(doc, st, "control/summary.csv", ": run bpmid control, or bpmid run with the control stage")
        return
    stale_note(doc, st, "control")
    kp = (k.gains.get("kp") or {}).get("value")
    ki = (k.gains.get("ki") or {}).get("value")
    refs = [r for r in dict.fromkeys(k.table.reference) if r != "ALL"]
    doc.p(f"Each controller tracks every reference on a simulated plant at {fmt(k.rate_hz)} Hz: PI alone (eq. 20 "
          f"without feedforward), VBMM-PI (inverse VBMM feedforward) and MS-PI (Maxwell-slip feedforward); gains "
          f"P = {fmt(kp)} bar/°, I = {fmt(ki)} bar/(° s). References: {', '.join(refs)}. The controller's model is "
          "this study's VBMM-fit where there is one; the plant adds sensor noise. RMSE is of the true angle against "
          "the reference.")
    plant = k.plant_words()
    if plant:
        doc.p(f"The plant departs from the controller's model: {plant}.")
    notes = [f"{r.get('name')}: {r.get('resampled')}" for r in k.references if r.get("resampled")]
    if notes:
        doc.p("References read from files, as they were run:")
        doc.list(notes, css="muted")
    if k.plant_is_the_model:
        doc.p("The plant here is the controller's own model (the same constants, no effects, no valve dynamics): the "
              "feedforward inverts the plant exactly, an ideal case a real muscle does not offer. The reductions "
              "below are an upper bound for this model; the paper's are on its rig. A plant off the model: bpmid "
              "control --plant-modulus-scale, --plant-tau-scale, --plant-effect, --pressure-dynamics.", css="verdict")
    if k.warnings:
        doc.p(f"Warnings of the control stage ({len(k.warnings)}): runs whose command touched a pressure limit, "
              "runs that ring (the error swinging back and forth after a step or jump, with where, how long and how "
              "large) and what ringing does to the comparison.", css="verdict")
        doc.list(k.warnings, css="muted")
    pooled = k.table[k.table.reference == "ALL"]
    with doc.panel("Paper's control result (quoted, the paper's data)", "quoted"):
        doc.p(PAPER_CONTROL_SOURCE)
        doc.table(["controller", "quantity", "value", "unit"], [[c, q, fmt(v), u] for c, q, v, u in PAPER_CONTROL])
    label = "Measured here (bpmid, synthetic plant)" if st.synthetic else "Measured here (bpmid)"
    with doc.panel(label, "measured"):
        doc.p("Tracking RMSE over all references (control/summary.csv, reference ALL):")
        doc.table(["controller", "RMSE (°)", "max |error| (°)", "below PI (%)", "at limit (%)", "status"],
                  [[LABELS.get(r.controller, r.controller), fmt(r.rmse_deg), fmt(r.max_abs_err_deg),
                    "-" if r.controller == "pi" else fmt(r.reduction_pct), fmt(r.saturated_pct), r.status]
                   for r in pooled.itertuples()])
    doc.p("Per reference:")
    per = k.table[k.table.reference != "ALL"]
    doc.table(["reference", "controller", "RMSE (°)", "below PI (%)", "status"],
              [[r.reference, LABELS.get(r.controller, r.controller), fmt(r.rmse_deg),
                "-" if r.controller == "pi" else fmt(r.reduction_pct), r.status] for r in per.itertuples()])
    if k.cost:
        doc.p(f"Feedforward cost (incremental inverse VBMM): {fmt(k.cost.get('incremental_kernel_us_per_step'))} µs "
              f"per step, {fmt(k.cost.get('share_of_period_pct'))} % of the control period (wall clock, this "
              "machine).")
    f = find_figure(st.root, "control/fig18")
    if f:
        doc.fig(f, "Closed-loop tracking (the paper's Fig. 18 in kind): (a) reference and measured response of each "
                "controller, (b) tracking error with each run's ringing episodes marked, (c) command pressure (gauge) "
                "with its limits; references end to end, every sample; (d) every sample of the longest ringing, a "
                "marker each.")
