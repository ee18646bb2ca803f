"""Figures of a model comparison (they return figures; :func:`bpmid.plots.common.save_figure` writes them).
Legends sit beside the axes, never over data; every model keeps its colour and line style in every figure."""
from __future__ import annotations

import numpy as np

from bpmid.plots.common import (PA_PER_BAR, PRESSURE_LABEL, color_of, finish, new_figure, outside_legend,
                                style_of)


def _color(name: str, i: int) -> str:
    return color_of(name, i)


def _axes_list(axes, n):
    return list(np.atleast_1d(axes).ravel())[:n]


def _logged(lg) -> str:
    """The legend of a log's own angle: "measured", or "logged (synthetic)" for a synthetic log."""
    from bpmid.io.motion_logs import is_synthetic

    return "logged (synthetic)" if is_synthetic([lg]) else "measured"


def time_series(result, logs, *, synthetic: bool | str | None = True):
    """Measured angle and every model's free-running prediction against time, one panel per log."""
    fig, axes = new_figure(len(logs), 1, width=9.0, height=2.0 * len(logs) + 1.1, squeeze=False, sharex=False,
                           legend="right", legend_size=1.5, suptitle=True, hgap=0.7)
    for ax, lg in zip(_axes_list(axes, len(logs)), logs):
        ax.plot(lg.time_s, lg.angle_deg, color="black", lw=2.2, alpha=0.35, label=_logged(lg))
        for i, o in enumerate(result.outcomes):
            ax.plot(lg.time_s, o.predictions[lg.name], color=_color(o.name, i), ls=style_of(o.name, i), lw=1.1,
                    label=o.name)
        ax.set_title(lg.name)
        ax.set_ylabel("angle (°)")
        ax.set_xlabel("time (s)")
    outside_legend(fig, ax=axes.ravel()[0])
    fig.suptitle("Free-running predictions on test logs (models fitted on the training logs only)",
                 y=1 - 0.08 / fig.get_size_inches()[1], va="top")
    return finish(fig, synthetic)


def loops(result, logs, *, synthetic: bool | str | None = True):
    """Pressure-angle loops: one row per log, one column per model, measured loop in grey behind."""
    nm = len(result.outcomes)
    fig, axes = new_figure(len(logs), nm, width=2.3 * nm + 1.0, height=2.1 * len(logs) + 1.0, squeeze=False,
                           sharey="row", sharex=True, suptitle=True, wgap=0.25, hgap=0.35, left=0.9)
    for r, lg in enumerate(logs):
        p_bar = lg.pressure_pa / PA_PER_BAR
        for c, o in enumerate(result.outcomes):
            ax = axes[r, c]
            ax.plot(p_bar, lg.angle_deg, color="0.6", lw=1.6, label=_logged(lg))
            ax.plot(p_bar, o.predictions[lg.name], color=_color(o.name, c), ls=style_of(o.name, c), lw=1.0,
                    label=o.name)
            if r == 0:
                ax.set_title(o.name)
            if c == 0:
                ax.set_ylabel(f"{lg.name}\nangle (°)")
            if r == len(logs) - 1:
                ax.set_xlabel("gauge pressure (bar)")
    fig.suptitle("Pressure-angle loops: the log's own (grey) and each model; " + PRESSURE_LABEL,
                 y=1 - 0.08 / fig.get_size_inches()[1], va="top", fontsize=9)
    return finish(fig, synthetic)


def errors(result, logs, *, synthetic: bool | str | None = True):
    """Prediction error (model minus measured) against time, one panel per log."""
    fig, axes = new_figure(len(logs), 1, width=9.0, height=1.9 * len(logs) + 1.1, squeeze=False,
                           legend="right", legend_size=1.5, suptitle=True, hgap=0.7)
    for ax, lg in zip(_axes_list(axes, len(logs)), logs):
        for i, o in enumerate(result.outcomes):
            ax.plot(lg.time_s, o.predictions[lg.name] - lg.angle_deg, color=_color(o.name, i), ls=style_of(o.name, i),
                    lw=1.0, label=o.name)
        ax.axhline(0.0, color="black", lw=0.6)
        ax.set_title(lg.name)
        ax.set_ylabel("error (°)")
        ax.set_xlabel("time (s)")
    outside_legend(fig, ax=axes.ravel()[0])
    fig.suptitle("Error against time (prediction minus the log's angle)", y=1 - 0.08 / fig.get_size_inches()[1], va="top")
    return finish(fig, synthetic)


def summary_bars(summary, by_set=None, *, synthetic: bool | str | None = True):
    """Bar charts of the pooled summary: RMSE per test set, R², MAPE and cost per step."""
    models = list(summary["model"])
    colors = [_color(m, i) for i, m in enumerate(models)]
    fig, axes = new_figure(2, 2, width=9.0, height=6.6, suptitle=True, bottom=0.95, hgap=1.35, wgap=0.9,
                           legend="right", legend_size=1.3)
    ax = axes[0, 0]
    sets = [] if by_set is None or not len(by_set) else list(dict.fromkeys(by_set["set"]))
    groups = ["ALL"] + [s for s in sets if s != "ALL"]
    width = 0.8 / len(groups)
    x = np.arange(len(models))
    hatches = ["", "///", "...", "xxx", "\\\\\\", "++"]
    for g, s in enumerate(groups):
        if s == "ALL":
            vals = summary.set_index("model").loc[models, "rmse_deg"].to_numpy()
        else:
            sub = by_set[by_set["set"] == s].set_index("model")
            vals = np.array([sub.loc[m, "rmse_deg"] if m in sub.index else np.nan for m in models])
        ax.bar(x + (g - (len(groups) - 1) / 2) * width, vals, width, color=colors, edgecolor="black", lw=0.4,
               hatch=hatches[g % len(hatches)], label="all test logs" if s == "ALL" else s)
    ax.set_xticks(x, models, rotation=30, ha="right")
    ax.set_ylabel("RMSE (°)")
    ax.set_title("RMSE per test set (hatching)")
    for ax, col, lab in ((axes[0, 1], "r2", "R²"), (axes[1, 0], "mape_pct", "MAPE (%)"),
                         (axes[1, 1], "us_per_step", "cost per simulated step (µs)")):
        vals = summary[col].to_numpy(dtype=float)
        ax.bar(x, np.nan_to_num(vals), color=colors, edgecolor="black", lw=0.4)
        ax.set_xticks(x, models, rotation=30, ha="right")
        ax.set_ylabel(lab)
        if col == "us_per_step" and np.all(np.isfinite(vals)) and np.all(vals > 0):
            ax.set_yscale("log")
            from matplotlib.ticker import NullFormatter

            ax.yaxis.set_minor_formatter(NullFormatter())  # decade labels only: 2x..9x labels collide
            # a log axis often spans less than a decade here (one labelled tick): each bar says its value
            lo, hi = float(np.min(vals)), float(np.max(vals))
            ax.set_ylim(lo / 2.0, hi * 3.0)
            for xi, v in zip(x, vals):
                ax.text(xi, v * 1.15, f"{v:.2g}", ha="center", va="bottom", fontsize=6.5)
        if col == "r2":
            lo = np.nanmin(vals) if np.any(np.isfinite(vals)) else 0.0
            ax.set_ylim(min(0.0, lo - 0.05), 1.0)
    import matplotlib.patches as mpatches

    handles = [mpatches.Patch(facecolor="white", edgecolor="black", hatch=hatches[g % len(hatches)],
                              label="all test logs" if s == "ALL" else s) for g, s in enumerate(groups)]
    outside_legend(fig, handles, [h.get_label() for h in handles], title="hatching of the\nRMSE panel (top left)")
    fig.suptitle("Model comparison, pooled over all test logs", y=1 - 0.08 / fig.get_size_inches()[1], va="top")
    return finish(fig, synthetic)
