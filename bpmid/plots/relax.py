"""Figure of a relaxation fit: stress (or modulus) with the fit, the modulus curves overlaid, residuals.

Functions here return figures and never write files (:func:`bpmid.plots.common.save_figure` does).
"""
from __future__ import annotations

import numpy as np

from bpmid.plots.common import label_synthetic, new_figure


def relax_figure(fit, *, synthetic: bool = False, max_logs: int = 12):
    """Three panels for a :class:`bpmid.relax.fit.RelaxFit`.

    (a) each log's measured stress (ramp mode) or modulus (step mode) with the fit; (b) the
    relaxation-modulus curves of all logs overlaid with the fitted E(t) (the paper's Fig. 14(c)), on a
    log time axis when the data span more than three decades; (c) residuals against time.

    Parameters
    ----------
    fit : RelaxFit
    synthetic : mark the figure as made from synthetic data
    max_logs : draw at most this many logs in panels (a) and (c) (the fit used all of them)
    """
    fig, (ax_a, ax_b, ax_c) = new_figure(1, 3, width=15.0, height=4.6)
    logs = fit.logs[:max_logs]
    colors = [f"C{i % 10}" for i in range(len(logs))]
    unit, scale = ("kPa", 1e3) if fit.E_inf + fit.E.sum() < 1.0 else ("MPa", 1.0)
    all_t = np.concatenate([lg.hold.t for lg in fit.logs])
    span = max(float(np.ptp(all_t)), 1e-12) if all_t.size else 10.0
    pos = np.concatenate([lg.hold.t[lg.hold.t > 0] for lg in fit.logs])
    log_time = pos.size > 0 and span / max(float(pos.min()), 1e-300) > 1e4
    for lg, c in zip(logs, colors):
        t = lg.t
        ax_a.plot(t, lg.y * scale, ".", ms=1.5, color=c, alpha=0.5)
        ax_a.plot(t, lg.y_fit * scale, "-", lw=1.0, color=c, label=lg.name if len(logs) <= 12 else None)
        ax_c.plot(t, (lg.y - lg.y_fit) * scale, "-", lw=0.5, color=c, alpha=0.6)
    what = "stress" if fit.quantity == "stress" else "relaxation modulus"
    ax_a.set(xlabel="time (s)", ylabel=f"{what} ({unit})",
             title=f"(a) {what}: data (dots) and {fit.mode}-mode fit")
    if log_time:
        ax_a.set_xscale("log")
        ax_c.set_xscale("log")
    if fit.mode == "ramp":  # the ramp and the first 10 s of the hold carry the information
        t_end = max(float(lg.t[lg.hold.start]) for lg in fit.logs if lg.hold.t.size) + 10.0 \
            if any(lg.hold.t.size for lg in fit.logs) else np.inf
        if t_end < max(float(lg.t[-1]) for lg in fit.logs):
            ax_a.set_xlim(float(min(lg.t[0] for lg in fit.logs)), t_end)
            ax_a.set_title(f"(a) {what}: data (dots) and ramp-mode fit (first {t_end:.0f} s)")
    if len(logs) <= 12:
        ax_a.legend(fontsize=6, ncol=2, loc="best")
    for lg, c in zip(fit.logs, [f"C{i % 10}" for i in range(len(fit.logs))]):
        h = lg.hold
        tt = h.t[h.t > 0] if log_time else h.t
        ee = h.modulus_mpa[h.t > 0] if log_time else h.modulus_mpa
        ax_b.plot(tt, ee * scale, "-", lw=0.7, color=c, alpha=0.7)
    if pos.size == 0:
        pos = np.array([1e-3, span])
    grid = (np.logspace(np.log10(pos.min()), np.log10(pos.max()), 400) if log_time
            else np.linspace(0.0, min(span, 10.0), 400))
    ax_b.plot(grid, fit.modulus(grid) * scale, "k-", lw=2.0, label=f"fitted E(t), {fit.m} term(s)")
    if fit.mode == "ramp":
        ax_b.text(0.98, 0.80, "curves: sigma/eps of each hold\n(biased low early on by the ramp)",
                  transform=ax_b.transAxes, ha="right", va="top", fontsize=7, color="0.3")
    ax_b.set(xlabel="time since the step / hold start (s)", ylabel=f"E(t) ({unit})",
             title="(b) relaxation modulus of every log")
    if log_time:
        ax_b.set_xscale("log")
    else:  # the paper's Fig. 14(c) shows the first 10 s, where the relaxation happens
        ax_b.set_xlim(0.0, min(span, 10.0))
    ax_b.legend(fontsize=7, loc="upper right")
    ax_c.axhline(0.0, color="k", lw=0.5)
    ax_c.set(xlabel="time (s)", ylabel=f"residual ({unit})",
             title=f"(c) residuals, RMSE {fit.rmse_mpa * scale:.3g} {unit}, R² {fit.r2:.4f}")
    if synthetic:
        label_synthetic(fig)
    return fig
