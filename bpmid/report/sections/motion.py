"""Motion fit: VBMM-mat. (the relaxation constants as they are) beside VBMM-fit (refitted on motion logs)."""
from __future__ import annotations

from bpmid.report.doc import fmt
from bpmid.report.figures import find_figure
from bpmid.report.sections import absent, stale_note

KEY = "motion"
TITLE = "Motion fit: VBMM-mat. and VBMM-fit"


def build(doc, st, figs) -> None:
    doc.section(KEY, TITLE)
    m = st.motion
    if m is None:
        from bpmid.report.sections.model import several_fits

        several = several_fits(st)
        if several:
            doc.p(several.strip(), css="warn")
        else:
            absent(doc, st, "vbmm_fit.yaml")
        return
    stale_note(doc, st, "motion")
    if "vbmm_fit.yaml" in st.missing and m.fit_file in (None, "vbmm_fit.yaml"):
        doc.p("Missing: run.yaml records the motion stage as done, but vbmm_fit.yaml is not in this folder (moved or "
              "deleted after the run): the VBMM-fit column is empty; rerun the stage to restore it.", css="warn")
    if m.fit_file not in (None, "vbmm_fit.yaml"):
        doc.p(f"VBMM-fit read from {m.fit_file}: this folder has no vbmm_fit.yaml, and {m.fit_file} is its one "
              "bpmid.vbmm/1 motion fit.", css="muted")
    mat = {p.name: p for p in m.mat}
    fit = {p.name: p for p in m.fit}
    names = list(dict.fromkeys(list(mat) + list(fit)))
    rows = []
    for n in names:
        a, b = mat.get(n), fit.get(n)
        unit = (b or a).unit
        rows.append([n, fmt(a.value) if a else "-", fmt(b.value) if b else "-", fmt(b.stderr) if b else "-", unit,
                     (b.verdict if b else "") or "-"])
    if m.by == "bpmid discover":
        from bpmid.report.sections.summary import held_at

        doc.p(f"VBMM-fit here is the model bpmid discover ended with ({m.fit_file}): it refitted the constants "
              f"whose verdict below says estimated on the fitting set, with the effects it named acting, and held "
              f"the others at {held_at(st)}, as their verdicts say.")
    else:
        doc.p("VBMM-mat. takes its constants straight from the relaxation fit (nothing refitted); VBMM-fit refits "
              "them on the fitting set. A constant the motion data cannot determine is held at its prior value and "
              "says so (identifiability).")
    doc.table(["constant", "VBMM-mat.", "VBMM-fit", "VBMM-fit stderr", "unit", "VBMM-fit verdict"], rows)
    if m.effects:
        names = ", ".join(m.effect_ids)
        doc.p(f"{m.fit_file or 'The fit file'} runs the VBMM with the effect(s) {names} (its effects list), in the "
              "order they act; their constants:")
        doc.table(["effect constant", "VBMM-fit", "VBMM-fit stderr", "unit", "verdict"],
                  [[p.name, fmt(p.value), fmt(p.stderr), p.unit, p.verdict or "-"] for e in m.effects
                   for p in e.params])
        from bpmid.effects.fitfile import settings_words

        sets = "; ".join(f"{e.id}: {settings_words(e.id, e.settings)}" for e in m.effects if e.settings)
        if sets:
            doc.p(f"Settings of the effects (fixed, not fitted): {sets}.", css="muted")
    if m.rmse_deg is not None:
        how = ", ".join(f"{k} {v}" for k, v in (("closure", m.closure), ("history", m.history)) if v)
        with_fx = f", with {' and '.join(m.effect_ids)} acting" if m.effects else ""
        doc.p(f"VBMM-fit on its own fitting set{with_fx}: RMSE {fmt(m.rmse_deg)}°, MAPE {fmt(m.mape_pct)} %, "
              f"R² {fmt(m.r2)}" + (f" ({how})." if how else "."))
    if m.corr_names:
        doc.p("Correlations of the estimated VBMM-fit constants (|r| near 1: the motion data hardly separate them):")
        doc.table(["", *m.corr_names], [[n, *[fmt(v, 3) for v in row]] for n, row in zip(m.corr_names, m.corr)])
    f = find_figure(st.root, m.fit_file[:-len(".yaml")]) if m.fit_file else None
    if f:
        doc.fig(f, "VBMM-fit on the fitting set: pressure-angle loop, angle against time, and error against time, "
                "one row per log (gauge pressure).")
