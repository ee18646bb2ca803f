"""Figures of a motion fit or prediction: pressure-angle loops measured and modelled, angle and error against
time.

Functions return figures and never write files (:func:`bpmid.plots.common.save_figure` does). Pressure is
always gauge pressure in bar (the model's input), whatever the log's own unit and reference.
"""
from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from bpmid.io.motion_logs import MotionLog
from bpmid.plots.common import (MODEL_COLORS, MODEL_STYLES, PA_PER_BAR, PRESSURE_LABEL, finish, new_figure,
                                outside_legend)

MAX_ROWS = 6


def motion_fit_figure(logs: Sequence[MotionLog], predictions: Mapping[str, np.ndarray], *,
                      model: str = "vbmm-fit", label: str = "VBMM-fit", title: str | None = None,
                      synthetic: bool = False):
    """One row per log (at most :data:`MAX_ROWS`): loop | angle vs time | error vs time.

    Parameters
    ----------
    logs : motion logs (a log without ``angle_deg`` shows the prediction only)
    predictions : log name -> (N,) predicted angle (deg)
    model, label : colour key of :data:`MODEL_COLORS` and legend text
    synthetic : mark the figure as made from synthetic data

    Returns
    -------
    matplotlib Figure
    """
    shown = list(logs)[:MAX_ROWS]
    rows = max(len(shown), 1)
    fig, axes = new_figure(rows, 3, width=12.0, height=2.3 * rows + 0.9, squeeze=False, legend="right",
                           legend_size=1.6, suptitle=bool(title), hgap=0.8)
    color = MODEL_COLORS.get(model, "#0072B2")
    ls = MODEL_STYLES.get(model, "-")
    meas = MODEL_COLORS["measured"]
    for r, lg in enumerate(shown):
        pred = np.asarray(predictions[lg.name], float)
        p = np.asarray(lg.pressure_pa, float) / PA_PER_BAR
        ax_loop, ax_t, ax_e = axes[r]
        if lg.angle_deg is not None:
            # measured: broad and light behind, so a model lying on it stays visible on top
            ax_loop.plot(p, lg.angle_deg, color=meas, lw=2.4, alpha=0.3, label="measured")
            ax_t.plot(lg.time_s, lg.angle_deg, color=meas, lw=2.4, alpha=0.3)
            err = pred - lg.angle_deg
            rmse = float(np.sqrt(np.nanmean(err**2)))
            ax_e.plot(lg.time_s, err, color=color, lw=0.8)
            ax_e.axhline(0.0, color="0.5", lw=0.6)
            ax_e.set_title(f"{lg.name}: error, RMSE {rmse:.3g}°")
        else:
            ax_e.text(0.5, 0.5, "no measured angle in this log", transform=ax_e.transAxes, ha="center", color="0.4")
            ax_e.set_title(f"{lg.name}: error")
        ax_loop.plot(p, pred, color=color, lw=1.1, ls=ls, label=label)
        ax_t.plot(lg.time_s, pred, color=color, lw=1.1, ls=ls)
        ax_loop.set_xlabel(PRESSURE_LABEL)
        ax_loop.set_ylabel("bending angle (°)")
        ax_loop.set_title(f"{lg.name}: loop")
        ax_t.set_title(f"{lg.name}: angle")
        ax_t.set_xlabel("time (s)")
        ax_t.set_ylabel("bending angle (°)")
        ax_e.set_xlabel("time (s)")
        ax_e.set_ylabel("model − measured (°)")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    if len(logs) > MAX_ROWS:
        handles.append(axes[0, 0].plot([], [], color="none")[0])
        labels.append(f"(first {MAX_ROWS} of {len(logs)} logs)")
    outside_legend(fig, handles, labels)
    if title:
        fig.suptitle(title, y=1 - 0.08 / fig.get_size_inches()[1], va="top")
    return finish(fig, synthetic)


__all__ = ["motion_fit_figure", "MAX_ROWS"]
