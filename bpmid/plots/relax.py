"""Figure of a relaxation fit: stress (or modulus) with the fit, the modulus curves overlaid, residuals.

Functions here return figures and never write files (:func:`bpmid.plots.common.save_figure` does).
"""
from __future__ import annotations

import numpy as np

from bpmid.plots.common import finish, new_figure, outside_legend


def _log_colors(n: int):
    """One colour per log from a sequential, colour-blind-safe map (order of the logs: dark to light)."""
    import matplotlib

    cmap = matplotlib.colormaps["viridis"]
    return [cmap(0.75 * i / max(n - 1, 1)) for i in range(n)]


def relax_figure(fit, *, synthetic: bool = False, max_logs: int = 12):
    """Three panels for a :class:`bpmid.relax.fit.RelaxFit`.

    (a) each log's measured stress (ramp mode) or modulus (step mode) as dots with the fit as a line;
    (b) the relaxation-modulus data of every log (dots) with the fitted E(t) over them (the paper's
    Fig. 14(c)), on a log time axis when the data span more than three decades; (c) the residuals of all
    logs in one neutral colour with their binned RMS envelope (one line, not one colour per log).

    Parameters
    ----------
    fit : RelaxFit
    synthetic : mark the figure as made from synthetic data
    max_logs : draw at most this many logs in panel (a) (the fit used all of them)
    """
    logs = fit.logs[:max_logs]
    fig, (ax_a, ax_b, ax_c) = new_figure(1, 3, width=12.5, height=3.9, legend="right", legend_size=1.9, wgap=0.85)
    colors = _log_colors(len(fit.logs))
    unit, scale = ("kPa", 1e3) if fit.E_inf + fit.E.sum() < 1.0 else ("MPa", 1.0)
    all_t = np.concatenate([lg.hold.t for lg in fit.logs])
    span = max(float(np.ptp(all_t)), 1e-12) if all_t.size else 10.0
    pos = np.concatenate([lg.hold.t[lg.hold.t > 0] for lg in fit.logs])
    log_time = pos.size > 0 and span / max(float(pos.min()), 1e-300) > 1e4
    for lg, c in zip(logs, colors):
        step = max(len(lg.t) // 400, 1)
        ax_a.plot(lg.t[::step], lg.y[::step] * scale, "o", ms=1.6, color=c, alpha=0.6, ls="none")
        ax_a.plot(lg.t, lg.y_fit * scale, "-", lw=1.0, color=c, label=lg.name if len(logs) <= 8 else None)
    what = "stress" if fit.quantity == "stress" else "relaxation modulus"
    ax_a.set(xlabel="time (s)", ylabel=f"{what} ({unit})", title=f"(a) {what}: data (dots), {fit.mode}-mode fit")
    if log_time:
        for ax in (ax_a, ax_c):
            ax.set_xscale("log")
    if fit.mode == "ramp":  # the ramp and the first 10 s of the hold carry the information
        t_end = max(float(lg.t[lg.hold.start]) for lg in fit.logs if lg.hold.t.size) + 10.0 \
            if any(lg.hold.t.size for lg in fit.logs) else np.inf
        if t_end < max(float(lg.t[-1]) for lg in fit.logs):
            # a log time axis starts at the first positive time (a log's first sample is usually t = 0)
            t0 = min(float(lg.t[lg.t > 0][0]) if log_time and np.any(lg.t > 0) else float(lg.t[0]) for lg in fit.logs)
            ax_a.set_xlim(t0, t_end)
            ax_a.set_title(f"(a) {what}: data (dots), fit (first {t_end:.0f} s)")
    # (b) data as markers, fit as a line on top: both visible even when the data are one dense master curve. A ramp
    # relaxes while it loads, so a hold's sigma/eps starts below the step modulus E(0): in ramp mode each log gets
    # the fit's own sigma/eps over its hold, and E(t) of a step is drawn dashed, as the material function
    ramp_hold = fit.mode == "ramp" and fit.quantity == "stress" and all(
        np.isfinite(lg.hold.strain_level) and lg.hold.strain_level > 0 and lg.y_fit.size >= lg.hold.start + lg.hold.t.size
        for lg in fit.logs)
    for lg, c in zip(fit.logs, colors):
        h = lg.hold
        keep = h.t > 0 if log_time else h.t <= min(span, 10.0)  # the window panel (b) shows
        tt, ee = h.t[keep], h.modulus_mpa[keep]
        # thinned to open circles large enough to show around the fitted line drawn over them
        n_show = max(60 // max(len(fit.logs), 1), 12)
        if log_time and tt.size > n_show:  # evenly in log time
            idx = np.unique(np.searchsorted(tt, np.logspace(np.log10(tt[0]), np.log10(tt[-1]), n_show)).clip(0, tt.size - 1))
            tt, ee = tt[idx], ee[idx]
        elif tt.size > 4 * n_show:
            tt, ee = tt[:: tt.size // (4 * n_show)], ee[:: ee.size // (4 * n_show)]
        ax_b.plot(tt, ee * scale, "o", ms=4.5, mfc="none", mec=c, mew=0.9, ls="none")
        if ramp_hold:   # the fit's own sigma/eps over this hold: the relaxation during the ramp included
            idx = np.arange(h.start, h.start + h.t.size)[keep]
            ax_b.plot(h.t[keep], lg.y_fit[idx] / h.strain_level * scale, "-", color=c, lw=0.9)
    if pos.size == 0:
        pos = np.array([1e-3, span])
    grid = (np.logspace(np.log10(pos.min()), np.log10(pos.max()), 400) if log_time
            else np.linspace(0.0, min(span, 10.0), 400))
    if ramp_hold:
        ax_b.plot([], [], "-", color=colors[0], lw=0.9, label="fit: σ/ε of each hold (the ramp's relaxation in)")
    ax_b.plot(grid, fit.modulus(grid) * scale, "--" if ramp_hold else "-", color="black", lw=1.0,
              label=f"fitted E(t) of a step, {fit.m} term(s)" if ramp_hold else f"fitted E(t), {fit.m} term(s)")
    ax_b.plot([], [], "o", ms=4.5, mfc="none", mec=colors[0], ls="none", label="E(t) data (σ/ε of each hold)" if fit.mode == "ramp"
              else "E(t) data")
    ax_b.set(xlabel="time since hold start (s)", ylabel=f"E(t) ({unit})", title="(b) relaxation modulus: data and fit")
    if log_time:
        ax_b.set_xscale("log")
        ax_b.set_yscale("log")
    else:  # the paper's Fig. 14(c) shows the first 10 s, where the relaxation happens
        ax_b.set_xlim(0.0, min(span, 10.0))
    # (c) residuals in one colour, the binned RMS as the envelope
    t_all = np.concatenate([lg.t for lg in fit.logs])
    r_all = np.concatenate([(lg.y - lg.y_fit) * scale for lg in fit.logs])
    ax_c.plot(t_all, r_all, ".", ms=1.0, color="0.55", alpha=0.5, ls="none", label="residual, every log")
    if t_all.size > 20:
        edges = (np.logspace(np.log10(max(t_all[t_all > 0].min(), 1e-300)), np.log10(t_all.max()), 30) if log_time
                 else np.linspace(t_all.min(), t_all.max(), 40))
        which = np.digitize(t_all, edges)
        cen, rms = [], []
        for k in np.unique(which):
            sel = which == k
            if sel.sum() >= 3:
                cen.append(float(np.median(t_all[sel])))
                rms.append(float(np.sqrt(np.mean(r_all[sel] ** 2))))
        ax_c.plot(cen, rms, "-", color="black", lw=1.2, label="± binned RMS")
        ax_c.plot(cen, -np.asarray(rms), "-", color="black", lw=1.2)
    ax_c.axhline(0.0, color="0.3", lw=0.5)
    ax_c.set(xlabel="time (s)", ylabel=f"residual ({unit})",
             title=f"(c) residuals: RMSE {fit.rmse_mpa * scale:.3g} {unit}, R² {fit.r2:.4f}")
    handles, labels = [], []
    for ax in (ax_a, ax_b, ax_c):
        h, lab = ax.get_legend_handles_labels()
        handles += h
        labels += lab
    if len(fit.logs) > len(logs):
        labels.append(f"(first {len(logs)} of {len(fit.logs)} logs in (a))")
        handles.append(ax_a.plot([], [], color="none")[0])
    outside_legend(fig, handles, labels)
    return finish(fig, synthetic)


def _sparse_log_ticks(fig) -> None:
    """At most ~8 labelled decades and no minor ticks on log axes spanning many decades (a 30-decade master curve
    otherwise draws hundreds of tick labels, which makes saving slow and the axis unreadable)."""
    from matplotlib.ticker import LogLocator, NullLocator

    for ax in fig.axes:
        for axis, scale in ((ax.xaxis, ax.get_xscale()), (ax.yaxis, ax.get_yscale())):
            if scale == "log":
                lo, hi = axis.get_view_interval()
                if lo > 0 and hi / lo > 1e6:
                    axis.set_major_locator(LogLocator(base=10.0, numticks=8))
                    axis.set_minor_locator(NullLocator())


def material_figure(mf, *, synthetic: bool = False):
    """Figure of a :class:`bpmid.relax.material.MaterialFit`.

    Frequency domain: (a) storage and loss modulus of the (master) curve with the fit, against (reduced) frequency;
    (b) relative residuals of both; (c) the fitted E(t). With shifted sets, a second row: (d) the raw sweeps as
    measured, coloured by temperature; (e) the shifted sets on the master curve; (f) the shift factors with the
    fitted WLF and polynomial shift functions. Time domain: the same with E(t) in place of E', E''.
    """
    import matplotlib.pyplot as plt

    fit, sh = mf.fit, mf.shift
    rows = 2 if sh is not None else 1
    fig, axes = new_figure(rows, 3, width=15.0, height=4.4 * rows)
    axes = np.atleast_2d(axes)
    M = mf.modulus
    freq = mf.domain == "freq"
    red = " (reduced)" if sh is not None else ""
    at = f" at T_ref = {sh.T_ref:g} °C" if sh is not None else ""
    ax_a, ax_b, ax_c = axes[0]
    if freq:
        ax_a.loglog(fit.f, fit.storage, "o", ms=2.5, color="C0", alpha=0.6, label=f"{M}' data")
        ax_a.loglog(fit.f, fit.loss, "s", ms=2.5, color="C1", alpha=0.6, label=f"{M}'' data")
        fg = np.logspace(np.log10(fit.f.min()), np.log10(fit.f.max()), 400)
        s_, l_ = fit.complex(fg)
        ax_a.loglog(fg, s_, "-", color="C0", lw=1.5, label=f"{M}' fit")
        ax_a.loglog(fg, l_, "-", color="C1", lw=1.5, label=f"{M}'' fit")
        ax_a.set(xlabel=f"frequency{red} (Hz)", ylabel=f"{M}', {M}'' (MPa)",
                 title=f"(a) storage and loss modulus{at}: {fit.m} terms")
        ax_a.legend(fontsize=7)
        ax_b.semilogx(fit.f, 100 * (fit.storage_fit - fit.storage) / fit.storage, ".-", ms=2, lw=0.6, color="C0",
                      label=f"{M}': RMS {fit.rms_rel_storage_pct:.3g} %")
        ax_b.semilogx(fit.f, 100 * (fit.loss_fit - fit.loss) / fit.loss, ".-", ms=2, lw=0.6, color="C1",
                      label=f"{M}'': RMS {fit.rms_rel_loss_pct:.3g} %")
        ax_b.axhline(0.0, color="k", lw=0.5)
        ax_b.set(xlabel=f"frequency{red} (Hz)", ylabel="relative residual, fit - data (%)",
                 title=f"(b) relative residuals ({fit.weighting} weighting)")
        ax_b.legend(fontsize=7)
        tg = np.logspace(np.log10(1 / (2 * np.pi * fit.f.max())), np.log10(1 / (2 * np.pi * fit.f.min())), 400)
        ax_c.loglog(tg, fit.modulus_t(tg), "k-", lw=1.5)
        ax_c.set(xlabel=f"time{red} (s)", ylabel=f"{M}(t) (MPa)", title="(c) relaxation modulus of the fit")
    else:
        lg = fit.logs[0]
        ax_a.loglog(lg.t, lg.y, "o", ms=2.5, alpha=0.6, color="C0", label=f"{M}(t) data")
        tg = np.logspace(np.log10(lg.t[lg.t > 0].min()), np.log10(lg.t.max()), 400)
        ax_a.loglog(tg, fit.modulus(tg), "k-", lw=1.5, label=f"fit, {fit.m} terms")
        ax_a.set(xlabel=f"time{red} (s)", ylabel=f"{M}(t) (MPa)", title=f"(a) relaxation modulus{at}")
        ax_a.legend(fontsize=7)
        ax_b.semilogx(lg.t, 100 * (lg.y_fit - lg.y) / lg.y, ".", ms=2, color="C0")
        ax_b.axhline(0.0, color="k", lw=0.5)
        ax_b.set(xlabel=f"time{red} (s)", ylabel="relative residual, fit - data (%)", title="(b) relative residuals")
        ax_c.axis("off")
        ax_c.text(0.05, 0.95, f"RMSE {fit.rmse_mpa:.4g} MPa\nR² {fit.r2:.6f}\nE_inf {fit.E_inf:.4g} MPa",
                  va="top", transform=ax_c.transAxes)
    if sh is not None:
        ax_d, ax_e, ax_f = axes[1]
        Ts = np.array([s.T for s in mf.sets])
        cmap = plt.get_cmap("coolwarm")
        norm = plt.Normalize(Ts.min(), Ts.max())
        sign = 1.0 if freq else -1.0
        for s in mf.sets:
            c = cmap(norm(s.T))
            ax_d.loglog(s.x, s.storage, ".-", ms=3, lw=0.7, color=c)
            ax_e.loglog(s.x * 10.0 ** (sign * s.log_aT), s.storage, ".", ms=3, color=c)
            if s.loss is not None:
                ax_d.loglog(s.x, s.loss, "x--", ms=2, lw=0.5, color=c, alpha=0.6)
                ax_e.loglog(s.x * 10.0 ** (sign * s.log_aT), s.loss, "x", ms=2, color=c, alpha=0.6)
        sm = plt.cm.ScalarMappable(norm=norm, cmap=cmap)
        fig.colorbar(sm, ax=ax_d, label="set temperature (°C)")
        what = f"{M}' (dots), {M}'' (crosses)" if freq else f"{M}(t)"
        ax_d.set(xlabel="frequency (Hz)" if freq else "time (s)", ylabel=f"{what} (MPa)",
                 title=f"(d) raw sets, {len(mf.sets)} temperatures")
        ax_e.set(xlabel=("frequency f·a_T (Hz)" if freq else "time t/a_T (s)"), ylabel=f"{what} (MPa)",
                 title=f"(e) shifted onto the master curve at {sh.T_ref:g} °C")
        o = np.argsort(sh.T)
        ax_f.plot(sh.T[o], sh.log_aT[o], "ko", ms=4, label=f"log a_T ({'from the data' if sh.source == 'data' else 'given'})")
        Tg = np.linspace(sh.T.min(), sh.T.max(), 200)
        if sh.wlf is not None:
            ax_f.plot(Tg, sh.wlf_log_aT(Tg), "C3-", lw=1.2,
                      label=f"WLF C1={sh.wlf['C1']:.4g}, C2={sh.wlf['C2']:.4g} °C")
        if sh.poly is not None:
            ax_f.plot(Tg, sh.poly_log_aT(Tg), "C2--", lw=1.2, label=f"polynomial, degree {sh.poly['degree']}")
        ax_f.axvline(sh.T_ref, color="0.6", lw=0.5)
        ax_f.set(xlabel="temperature (°C)", ylabel="log10 a_T (-)", title="(f) shift factors and shift functions")
        ax_f.legend(fontsize=7)
    _sparse_log_ticks(fig)
    return finish(fig, synthetic)
