"""The model that was fitted, as equations (MathML; plain text in the Markdown)."""
from __future__ import annotations

import math

from bpmid.report import mathml as M
from bpmid.report.doc import fmt

KEY = "model"
TITLE = "Model"


def _prony_fitted(st) -> tuple[str, str] | None:
    if st.relax is None:
        return None
    vals = {p.name: p.value for p in st.relax.constants}
    if vals.get("E_inf") is None:
        return None
    n = st.relax.n_terms
    parts = [M.mn(fmt(vals["E_inf"] / 1e3)), M.mtext("\u00a0kPa")]  # a no-break space: MathML drops plain ones
    text = f"E(t) = {fmt(vals['E_inf'] / 1e3)} kPa"
    for j in range(1, n + 1):
        e, tau = vals.get(f"E_{j}"), vals.get(f"tau_{j}")
        if e is None or tau is None:
            continue
        parts += [M.mo("+"), M.mn(fmt(e / 1e3)), M.mtext("\u00a0kPa"), M.mo("·"),
                  M.exp(M.row(M.mo("−"), M.mi("t"), M.mo("/"), M.mn(fmt(tau)), M.mtext("\u00a0s")))]
        text += f" + {fmt(e / 1e3)} kPa · exp(−t / {fmt(tau)} s)"
    return M.math(M.mi("E"), M.paren(M.mi("t")), M.mo("="), *parts), text


def build(doc, st, figs) -> None:
    doc.section(KEY, TITLE)
    doc.p("The viscoelasticity-based mechanistic model (VBMM) of the source paper, as bpmid implements it "
          "(docs/model.md in the bpmid repository). The material is a Prony series; its shear and bulk parts act through hereditary "
          "integrals on the wall strains, and a pressure closure turns the wall stresses into the gauge pressure "
          "that bends the muscle.")
    j, t, inf = M.mi("j"), M.mi("t"), M.mi("∞")
    doc.math(M.math(M.mi("E"), M.paren(t), M.mo("="), M.sub(M.mi("E"), inf), M.mo("+"),
                    M.under_over("∑", M.row(j, M.mo("="), M.mn(1)), M.mi("m")), M.sub(M.mi("E"), j),
                    M.exp(M.row(M.mo("−"), M.frac(t, M.sub(M.mi("τ"), j)))), M.mo(","), M.mtext("   "), M.mi("G"), M.mo("="),
                    M.frac(M.mi("E"), M.row(M.mn(2), M.paren(M.mn(1), M.mo("+"), M.mi("ν")))), M.mo(","),
                    M.mtext("   "), M.mi("K"), M.mo("="),
                    M.frac(M.mi("E"), M.row(M.mn(3), M.paren(M.mn(1), M.mo("−"), M.mn(2), M.mi("ν"))))),
            "E(t) = E_inf + sum_j E_j exp(-t/tau_j),  G = E / (2 (1 + nu)),  K = E / (3 (1 - 2 nu))",
            "Prony series")
    fitted = _prony_fitted(st)
    if fitted is not None:
        doc.math(fitted[0], fitted[1], "fitted here")
    k, i = M.mi("k"), M.mi("i")
    x = M.mi("x")
    doc.math(M.math(M.sub(M.row(M.hat(M.mi("M")), M.mo("["), x, M.mo("]")), k), M.mo("="),
                    M.sub(M.mi("M"), inf), M.sub(x, M.mn(0)), M.mo("+"),
                    M.under_over("∑", M.row(i, M.mo("="), M.mn(1)), k), M.mi("M"),
                    M.paren(M.sub(t, k), M.mo("−"), M.sub(t, i)),
                    M.paren(M.sub(x, i), M.mo("−"), M.sub(x, M.row(i, M.mo("−"), M.mn(1))))),
            "M^[x]_k = M_inf x_0 + sum_{i=1..k} M(t_k - t_i) (x_i - x_{i-1})", "hereditary integral, eq. 5")
    doc.math(M.math(M.sub(M.mi("h"), M.row(j, M.mo(","), k)), M.mo("="),
                    M.exp(M.row(M.mo("−"), M.frac(M.row(M.sub(t, k), M.mo("−"), M.sub(t, M.row(k, M.mo("−"), M.mn(1)))),
                                                  M.sub(M.mi("τ"), j)))),
                    M.sub(M.mi("h"), M.row(j, M.mo(","), k, M.mo("−"), M.mn(1))), M.mo("+"),
                    M.paren(M.sub(x, k), M.mo("−"), M.sub(x, M.row(k, M.mo("−"), M.mn(1))))),
            "h_{j,k} = exp(-(t_k - t_{k-1})/tau_j) h_{j,k-1} + (x_k - x_{k-1})   (exact, O(1) per step)",
            "recursive history")
    s1, s2, e1, e2 = (M.sub(M.mi("σ"), M.mn(1)), M.sub(M.mi("σ"), M.mn(2)), M.sub(M.mi("ε"), M.mn(1)),
                      M.sub(M.mi("ε"), M.mn(2)))
    lam = M.hat(M.mi("λ"))
    doc.math(M.math(s1, M.mo("="), M.mn(2), M.hat(M.mi("G")), M.mo("["), e1, M.mo("]"), M.mo("+"), lam, M.mo("["),
                    M.sub(M.mi("ε"), M.mi("kk")), M.mo("]"), M.mo(","), M.mtext("   "), s2, M.mo("="), M.mn(2),
                    M.hat(M.mi("G")), M.mo("["), e2, M.mo("]"), M.mo("+"), lam, M.mo("["),
                    M.sub(M.mi("ε"), M.mi("kk")), M.mo("]"), M.mo(","), M.mtext("   "), lam, M.mo("="),
                    M.hat(M.mi("K")), M.mo("−"), M.frac(M.mn(2), M.mn(3)), M.hat(M.mi("G"))),
            "sigma1 = 2 G^[eps1] + lambda^[eps_kk],  sigma2 = 2 G^[eps2] + lambda^[eps_kk],  lambda^ = K^ - (2/3) G^",
            "wall stresses, eq. 6")
    gb, F = M.mi("Ḡ"), M.mi("F")  # G with macron: one glyph, no accent stacking needed
    doc.math(M.math(M.mi("P"), M.mo("="), M.frac(M.mi("th"), M.mi("R")),
                    M.paren(s2, M.mo("+"), M.frac(M.row(s2, gb, M.mo("+"), s1, M.paren(F, M.mo("−"), M.mn(1))),
                                                  M.row(M.mn(1), M.mo("−"), M.mn(2), gb, F)))),
            "P = th/R * (sigma2 + (sigma2 Gbar + sigma1 (F - 1)) / (1 - 2 Gbar F))",
            "pressure closure, eq. 18 ('paper' closure)")
    doc.p(_fit_sentence(st) + "P is gauge pressure (above atmosphere): every pressure axis in this report is gauge "
          "pressure in bar. Angles are in degrees (°), times in seconds, costs in microseconds (µs).", css="muted")


def _fit_sentence(st) -> str:
    """Which closure and history mode the motion fit used, as far as its file says (never a placeholder)."""
    m = st.motion
    if m is None:
        return several_fits(st) or ("No motion fit in this folder (vbmm_fit.yaml, or one bpmid.vbmm/1 fit under "
                                    "another name), so the closure and history mode are not stated here. ")
    which = (f"This study's motion fit ({m.fit_file})" if m.fit_file else
             "This study's VBMM-mat. (vbmm_mat.yaml; no motion fit in this folder)")
    used = [f"the '{v}' {what}" for v, what in ((m.closure, "closure"), (m.history, "history mode")) if v]
    unsaid = [key for v, key in ((m.closure, "closure"), (m.history, "model.history")) if not v]
    text = f"{which} used {' and '.join(used)}. " if used else f"{which} "
    if m.history and m.history != "recursive":
        text += (f"(The recursive form above is the exact history; the '{m.history}' mode sums the hereditary "
                 "integral directly, eq. 5" + (", over a sliding window, eq. 19" if m.history == "window" else "")
                 + ".) ")
    if unsaid:
        text += ("It does not state " if used else "does not state ") + " or ".join(
            "its closure" if k == "closure" else "its history mode" for k in unsaid) + f" (no key {', '.join(unsaid)}). "
    g = m.geometry or {}
    try:
        text += (f"Muscle geometry (the fit file's): th {1e3 * float(g['th']):.4g} mm, alpha0 "
                 f"{math.degrees(float(g['alpha0'])):.4g}°, R0 {1e3 * float(g['R0']):.4g} mm, l0 "
                 f"{1e3 * float(g['l0']):.4g} mm, n {float(g['n']):.4g}. ")
    except (KeyError, TypeError, ValueError):
        pass
    return text


def several_fits(st) -> str:
    """What to do when the folder has no vbmm_fit.yaml but several motion fits under other names ('' if not)."""
    from bpmid.report.inputs import other_motion_fits

    others = other_motion_fits(st.root)
    if len(others) < 2:
        return ""
    return (f"This folder has no vbmm_fit.yaml but {len(others)} bpmid.vbmm/1 motion fits ({', '.join(others)}), so "
            "the report shows none of them: copy the one it is about to vbmm_fit.yaml and run bpmid report again. ")
