"""Discovery of missing effects: the verdict, the gap before and after, the evidence and the figures."""
from __future__ import annotations

import re


from bpmid.report.doc import fmt
from bpmid.report.figures import find_figure
from bpmid.report.sections import absent, stale_note

KEY = "discovery"
TITLE = "Discovery of missing effects"

CAPTIONS = {"residual_before_after": "Residual before (base VBMM, solid) and after (with the named effects, dashed) "
            "against time, gauge pressure and pressure rate, raw: one set of constants for every log, without the "
            "per-log factors the held-out scores allow for log-to-log variation (so larger than those scores); "
            "grey band: sensor-noise floor.",
            "screening_ranking": "Screening: share of the residual each catalogue effect's signature explains, per "
            "round; accepted and tried effects coloured.",
            "heldout_error": "Held-out RMSE per log before and after, scored as discovery scored them (each log's "
            "own per-log factors), with the sensor-noise floor; the legend's totals pool these bars."}


def build(doc, st, figs) -> None:
    doc.section(KEY, TITLE)
    d = st.discovery
    if d is None:
        absent(doc, st, "discover/discovery.yaml", ": the discovery stage had no inputs or did not run")
        return
    stale_note(doc, st, "discover")
    if d.named:
        doc.p(f"Named effects, in the order added: {', '.join(d.named)}.", css="verdict")
    elif d.withheld:
        doc.p("No catalogue effect named: what passed the confirmation tests only imitates an effect outside the "
              "catalogue, which explains the held-out logs better (below).", css="verdict")
    else:
        doc.p("No missing effect found: no catalogue entry passed the confirmation tests.", css="good")
    for line in (d.verdict or "").splitlines():  # one paragraph per statement of the verdict
        if line.strip():
            doc.p(re.sub(r"(\d) deg\b", "\\1°", line.strip()))
    rows = [["before (base model)", fmt(d.before_deg)], ["after (with named effects)", fmt(d.after_deg)],
            ["sensor-noise floor", fmt(d.floor_deg)]]
    if d.raw_before_deg is not None:
        rows += [["before, no per-log factors", fmt(d.raw_before_deg)],
                 ["after, no per-log factors", fmt(d.raw_after_deg)]]
    doc.table(["gap on held-out data", "RMSE (°)"], rows)
    if d.raw_before_deg is not None:
        doc.p("The held-out RMSE discovery scores is taken with each held-out log's own small factors on the "
              "stiffness and the time constants, fitted on that log for every model alike (log-to-log variation of "
              "the constants is not scored as an effect); the last two rows are the same models without them.",
              css="muted")
    doc.p("Unexplained remainder: " + ("yes, the gap is not closed by the catalogue" if d.unexplained
                                       else "no, what remains is at the noise floor"))
    rows = []
    for s in d.steps:
        ev = s.get("evidence")
        name = s.get("id", s.get("effect", "?"))
        if isinstance(ev, dict):  # the numbers a reader checks; the whole record is in discovery.yaml
            rows.append([name, f"{fmt(ev.get('heldout_rmse_before_deg'))} → {fmt(ev.get('heldout_rmse_after_deg'))}",
                         fmt(ev.get("heldout_gain_in_noise_floors")), fmt(ev.get("share_of_heldout_gap_removed")),
                         fmt(ev.get("likelihood_ratio_p_holm", ev.get("likelihood_ratio_p"))),
                         fmt(ev.get("new_parameters")), "yes" if ev.get("identifiable") else "no"])
        else:
            rows.append([name, str(ev or "-")[:300], "", "", "", "", ""])
    if rows:
        doc.table(["effect", "held-out RMSE (°)", "gain (noise floors)", "share of gap removed",
                   "LR p (Holm)", "new parameters", "identifiable"], rows)
    rel = d.dir.relative_to(st.root).as_posix() if d.dir != st.root else ""
    for stem, cap in CAPTIONS.items():
        f = find_figure(st.root, f"{rel}/{stem}" if rel else stem)
        if f:
            doc.fig(f, cap)
