"""Figures of a model comparison (they return figures; :func:`bpmid.plots.common.save_figure` writes them)."""
from __future__ import annotations

import numpy as np

from bpmid.plots.common import MODEL_COLORS, label_synthetic, new_figure

PA_PER_BAR = 1e5


def finish(fig, synthetic: bool):
    """Label a figure made from synthetic data (with room for the label below the axes)."""
    if synthetic:
        label_synthetic(fig)
        engine = fig.get_layout_engine()
        if engine is not None and hasattr(engine, "set"):
            engine.set(rect=(0, 0.03, 1, 0.97))
    return fig


def _color(name: str, i: int) -> str:
    import matplotlib.pyplot as plt

    return MODEL_COLORS.get(name, plt.rcParams["axes.prop_cycle"].by_key()["color"][i % 10])


def _axes_list(axes, n):
    return list(np.atleast_1d(axes).ravel())[:n]


def time_series(result, logs, *, synthetic: bool = True):
    """Measured angle and every model's free-running prediction against time, one panel per log."""
    fig, axes = new_figure(len(logs), 1, width=8.0, height=2.3 * len(logs) + 0.6, squeeze=False)
    for ax, lg in zip(_axes_list(axes, len(logs)), logs):
        ax.plot(lg.time_s, lg.angle_deg, color="black", lw=1.6, label="measured")
        for i, o in enumerate(result.outcomes):
            ax.plot(lg.time_s, o.predictions[lg.name], color=_color(o.name, i), lw=1.0, label=o.name)
        ax.set_title(lg.name, fontsize=9)
        ax.set_ylabel("angle (deg)")
    axes.ravel()[-1].set_xlabel("time (s)")
    axes.ravel()[0].legend(fontsize=7, ncol=4, loc="upper left")
    fig.suptitle("Free-running predictions on test logs (models fitted on the training logs only)", fontsize=10)
    return finish(fig, synthetic)


def loops(result, logs, *, synthetic: bool = True):
    """Pressure-angle loops: one row per log, one column per model, measured loop in grey behind."""
    nm = len(result.outcomes)
    fig, axes = new_figure(len(logs), nm, width=2.2 * nm + 0.6, height=2.2 * len(logs) + 0.6, squeeze=False,
                           sharey="row")
    for r, lg in enumerate(logs):
        p_bar = lg.pressure_pa / PA_PER_BAR
        for c, o in enumerate(result.outcomes):
            ax = axes[r, c]
            ax.plot(p_bar, lg.angle_deg, color="0.55", lw=1.4, label="measured")
            ax.plot(p_bar, o.predictions[lg.name], color=_color(o.name, c), lw=1.0, label=o.name)
            if r == 0:
                ax.set_title(o.name, fontsize=9)
            if c == 0:
                ax.set_ylabel(f"{lg.name}\nangle (deg)", fontsize=8)
            if r == len(logs) - 1:
                ax.set_xlabel("gauge pressure (bar)", fontsize=8)
            ax.tick_params(labelsize=7)
    fig.suptitle("Pressure-angle loops: measured (grey) and model", fontsize=10)
    return finish(fig, synthetic)


def errors(result, logs, *, synthetic: bool = True):
    """Prediction error (model minus measured) against time, one panel per log."""
    fig, axes = new_figure(len(logs), 1, width=8.0, height=2.0 * len(logs) + 0.6, squeeze=False)
    for ax, lg in zip(_axes_list(axes, len(logs)), logs):
        for i, o in enumerate(result.outcomes):
            ax.plot(lg.time_s, o.predictions[lg.name] - lg.angle_deg, color=_color(o.name, i), lw=0.9, label=o.name)
        ax.axhline(0.0, color="black", lw=0.6)
        ax.set_title(lg.name, fontsize=9)
        ax.set_ylabel("error (deg)")
    axes.ravel()[-1].set_xlabel("time (s)")
    axes.ravel()[0].legend(fontsize=7, ncol=3)
    fig.suptitle("Error against time (prediction minus measurement)", fontsize=10)
    return finish(fig, synthetic)


def summary_bars(summary, by_set=None, *, synthetic: bool = True):
    """Bar charts of the pooled summary: RMSE per test set, R^2, MAPE and cost per step."""
    models = list(summary["model"])
    colors = [_color(m, i) for i, m in enumerate(models)]
    fig, axes = new_figure(2, 2, width=9.0, height=6.0)
    ax = axes[0, 0]
    sets = [] if by_set is None or not len(by_set) else list(dict.fromkeys(by_set["set"]))
    groups = ["ALL"] + [s for s in sets if s != "ALL"]
    width = 0.8 / len(groups)
    x = np.arange(len(models))
    for g, s in enumerate(groups):
        if s == "ALL":
            vals = summary.set_index("model").loc[models, "rmse_deg"].to_numpy()
        else:
            sub = by_set[by_set["set"] == s].set_index("model")
            vals = np.array([sub.loc[m, "rmse_deg"] if m in sub.index else np.nan for m in models])
        ax.bar(x + (g - (len(groups) - 1) / 2) * width, vals, width, color=colors, alpha=1.0 - 0.6 * g / len(groups),
               edgecolor="black", lw=0.4, label=s)
    ax.set_xticks(x, models, rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("RMSE (deg)")
    ax.set_title("RMSE (bars left to right: " + ", ".join(groups) + ")", fontsize=9)
    for ax, col, lab in ((axes[0, 1], "r2", "R$^2$"), (axes[1, 0], "mape_pct", "MAPE (%)"),
                         (axes[1, 1], "us_per_step", "cost per simulated step (us)")):
        vals = summary[col].to_numpy(dtype=float)
        ax.bar(x, np.nan_to_num(vals), color=colors, edgecolor="black", lw=0.4)
        ax.set_xticks(x, models, rotation=30, ha="right", fontsize=8)
        ax.set_ylabel(lab)
        if col == "us_per_step" and np.all(np.isfinite(vals)) and np.all(vals > 0):
            ax.set_yscale("log")
        if col == "r2":
            lo = np.nanmin(vals) if np.any(np.isfinite(vals)) else 0.0
            ax.set_ylim(min(0.0, lo - 0.05), 1.0)
    fig.suptitle("Model comparison, pooled over all test logs (ranked by RMSE)", fontsize=10)
    return finish(fig, synthetic)
