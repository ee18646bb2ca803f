"""The one-screen summary: what was fitted on what, the headline numbers with their uncertainty, the
comparison ranking, the discovery verdict, the control result, and whether the data are synthetic."""
from __future__ import annotations

import re
from pathlib import Path

from bpmid.report.doc import fmt, pm

KEY = "summary"
TITLE = "Summary"


def cost_phrase(reduction_pct) -> str:
    """'42 % less' or '12 % more' (a negative reduction is an increase: short logs, timing noise)."""
    if reduction_pct is None or reduction_pct != reduction_pct:
        return "(not measured)"
    return f"{fmt(abs(reduction_pct))} % {'less' if reduction_pct >= 0 else 'more'}"


def _num_or_zero(x) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return 0.0


def _stale(st, stage):
    if stage in st.foreign:
        return " (STALE: not from the run in run.yaml)"
    return " (STALE: from an earlier run)" if stage in st.stale else ""


def held_at(st) -> str:
    """Where the motion fit's constants that it did not estimate were held, as its files say: the starting
    model's values (discovery's model.yaml, with discovery.yaml's base_from) or the prior values the fit started
    from (fit.initial); no source when the files give none."""
    m = st.motion
    if m.by == "bpmid discover":
        base = st.discovery.base_from if st.discovery is not None else None
        return "the starting model's values" + (f" ({base})" if base else "")
    return "their prior values" + (f" ({m.initial})" if m.initial else "")


def effects_words(m) -> str:
    """'pressure_lag (tau = 0.09012 s, share = 0.5, sat = 0 1/kPa; none estimated)': a fit file's effects and
    their constants with units."""
    out = []
    for e in m.effects:
        cons = ", ".join(f"{p.name.split('.', 1)[1]} = {pm(p.value, p.stderr)}" + (f" {p.unit}" if p.unit not in
                         ("", "1") else "") for p in e.params if p.value is not None)
        est = sum(1 for p in e.params if p.verdict == "estimated")
        tail = f"{est} of {len(e.params)} estimated" if est else "none estimated, each held"
        out.append(f"{e.id} ({cons}; {tail})" if cons else e.id)
    return "; ".join(out)


def _motion_item(st) -> str:
    m = st.motion
    estimated = [p for p in m.fit if p.verdict.startswith("estimated")]
    est = ", ".join(f"{p.name} = {pm(p.value, p.stderr)} {p.unit}" for p in estimated if p.value is not None)
    src = f" ({m.fit_file})" if m.fit_file not in (None, "vbmm_fit.yaml") else ""
    with_fx = f" with {', '.join(m.effect_ids)}" if m.effects else ""
    by = " by bpmid discover" if m.by == "bpmid discover" else ""
    logs = (f"on {len(m.logs)} fitting log(s) ({', '.join(m.logs)})" if m.logs else
            "on fitting logs the file does not list")
    rest = len(m.fit) - len(estimated)
    text = (f"VBMM-fit{with_fx}{src}{_stale(st, 'motion')}: refitted{by} {logs}: RMSE {fmt(m.rmse_deg)}° on its own "
            f"fitting set" + (f" (the model with {' and '.join(m.effect_ids)})" if m.effects else "")
            + f"; {len(estimated)} of {len(m.fit)} VBMM constants estimated" + (f" ({est})" if est else ""))
    if rest:
        text += f", the rest held at {held_at(st)}"
    if m.effects:
        text += f"; effect constants: {effects_words(m)}"
    return text + "."


def build(doc, st, figs) -> None:
    doc.section(KEY, TITLE)
    if st.synthetic:
        who = "made by bpmid's digital twin" if st.made_by_twin() else "synthetic (their own headers say so)"
        doc.p(f"Data: SYNTHETIC. Every log of this study was {who}; the numbers below are "
              "bpmid's results on those logs, not measurements of a real muscle.", css="verdict")
        origins = st.data_origins()   # the twin's files only (a user's '# protocol:' line is not bpmid's)
        if origins:   # the config and seed that made them, as each log's header states them
            doc.p("Made by bpmid simulate from the protocols (configs/datasets/<protocol>.yaml for the shipped "
                  "ones; each log's header and its folder's manifest.yaml give the rest): " + "; ".join(origins)
                  + ".", css="muted")
    elif st.run is not None and _num_or_zero(st.run.data_logs.get("synthetic")) > 0:
        dl = st.run.data_logs
        files = [str(f) for f in (dl.get("synthetic_files") or [])]
        folders = sorted({str(Path(f).parent) for f in files})
        doc.p(f"Data: MIXED. {int(dl['synthetic'])} of {int(_num_or_zero(dl.get('total')))} logs of this study say "
              f"they are synthetic (made by bpmid's digital twin, not measured)"
              + (f", in {', '.join(folders)}" if folders else "")
              + "; the rest are measured. Results on the synthetic logs are bpmid's results on its own model's "
              "output, not measurements of a real muscle; run.yaml (data_logs) lists them.", css="warn")
    else:
        doc.p("Data: measured logs (no log of this study says it is synthetic).", css="good")
    for p in st.problems:
        doc.p(f"Incomplete: {p.path}: {p.what}. The sections that need it say so.", css="warn")
    for stage, why in st.stale.items():
        doc.p(f"Stale: stage {stage}: {why}.", css="stale")
    items = []
    if st.relax is not None:
        r = st.relax
        cons = ", ".join(f"{p.name} = {pm(p.value / 1e3, None if p.stderr is None else p.stderr / 1e3)} kPa"
                         if p.unit == "Pa" and p.value is not None else f"{p.name} = {pm(p.value, p.stderr)} {p.unit}"
                         for p in r.constants)
        items.append(f"Material{_stale(st, 'relax')}: {r.n_terms}-term Prony series ({r.mode} mode) fitted on "
                     f"{len(r.logs)} relaxation log(s): {cons}; R² {fmt(r.r2)}.")
    if st.motion is not None and st.motion.rmse_deg is not None:
        items.append(_motion_item(st))
    if st.compare is not None:
        c = st.compare
        rank = c.ranking
        order = "; ".join(f"{i + 1}. {r.model} {fmt(r.rmse_deg)}°" for i, r in enumerate(rank.itertuples()))
        n_test = sum(len(v) for v in c.test_sets.values())
        items.append(f"Comparison{_stale(st, 'compare')} (fitted on {len(c.train)} training log(s), scored free-"
                     f"running on {n_test} test log(s) in {len(c.test_sets)} set(s)), ranked by pooled test RMSE: "
                     f"{order}.")
    if st.discovery is not None:
        d = st.discovery
        what = (f"named {', '.join(d.named)}" if d.named else
                "no catalogue effect named (an effect outside the catalogue explains the residual better)"
                if d.withheld else "no missing effect found")
        items.append(f"Discovery{_stale(st, 'discover')}: {what}; held-out RMSE {fmt(d.before_deg)}° before, "
                     f"{fmt(d.after_deg)}° after, sensor-noise floor {fmt(d.floor_deg)}°"
                     + ("; an unexplained remainder is left." if d.unexplained else ".")
                     + (f" Read its {len(d.cautions)} caution(s) before the verdict (Discovery, below): "
                        + "; ".join(re.split(r"[(:]", c)[0].strip().rstrip(",;") for c in d.cautions[:2])
                        + ("; ..." if len(d.cautions) > 2 else "") + "." if d.cautions else ""))
    if st.control is not None:
        k = st.control
        pi, vb, ms = k.pooled("pi"), k.pooled("vbmm-pi"), k.pooled("ms-pi")
        parts = []
        for name, row in (("PI", pi), ("VBMM-PI", vb), ("MS-PI", ms)):
            if row is not None:
                red = "" if name == "PI" or row.reduction_pct != row.reduction_pct else \
                    (f" ({fmt(abs(row.reduction_pct))} % below PI)" if row.reduction_pct >= 0.05 else
                     f" ({fmt(abs(row.reduction_pct))} % above PI)" if row.reduction_pct <= -0.05 else " (as PI)")
                parts.append(f"{name} {fmt(row.rmse_deg)}°{red}")
        refs = "the shipped references" if k.references_shipped or not k.references else \
            "references " + ", ".join(str(r.get("name")) for r in k.references)
        plant = k.plant_words()
        bad = k.troubled_runs()
        items.append(f"Control{_stale(st, 'control')} (closed loop on {refs}"
                     + (f", plant {plant}" if plant else "") + ", tracking RMSE): " + ", ".join(parts) + "."
                     + (f" Caution: {bad}; the RMSEs compare loops that do not track well"
                        + (" (an oscillating run rings: its error swings back and forth, control's warnings say where, "
                           "how long and how large)" if "oscillating" in bad else "")
                        + f" (the gains are "
                        f"{'the paper' + chr(39) + 's' if k.paper_gains() else 'the config' + chr(39) + 's'}, "
                        f"control.kp_bar_per_deg and control.ki_bar_per_deg_s set them for another muscle)."
                        if bad else ""))
    if st.history is not None:
        h = st.history
        items.append(f"History modes{_stale(st, 'history')}: window (T_win = {fmt(h.window_s)} s) vs full history "
                     f"differ by at most {fmt(h.window_vs_full.get('max_abs_diff_deg'))}° on the long-term log; the "
                     f"window costs {cost_phrase(h.reduction_pct)} per step than the full sum (wall clock, this "
                     "machine).")
    if items:
        doc.list(items)
    else:
        doc.p("No stage result could be read in this folder.", css="warn")
    doc.p("Numbers MEASURED HERE are bpmid's; the source paper's published numbers are QUOTED only in their own "
          "marked panels. Uncertainties are ± one standard error. Provenance (inputs and their sha256) is at the "
          "end.", css="muted")
