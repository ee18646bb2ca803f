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
    if synthetic:
        label_synthetic(fig)
    return fig
