"""Figures of a motion fit: pressure-angle loops measured and fitted, angle and error against time.

Functions return figures and never write files (:func:`bpmid.plots.common.save_figure` does).
"""
from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from bpmid.io.motion_logs import MotionLog
from bpmid.plots.common import MODEL_COLORS, label_synthetic, new_figure

MAX_ROWS = 6


def _pressure_axis(log: MotionLog) -> tuple[np.ndarray, str]:
    """The pressure as logged (unit and reference of the file) for the x axis."""
    if log.pressure_as_given is not None:
        ref = "abs" if log.pressure_reference == "absolute" else "gauge"
        return np.asarray(log.pressure_as_given, float), f"pressure ({log.pressure_unit}, {ref})"
    return np.asarray(log.pressure_pa, float) / 1e5, "pressure (bar, gauge)"


def motion_fit_figure(logs: Sequence[MotionLog], predictions: Mapping[str, np.ndarray], *,
                      model: str = "vbmm-fit", label: str = "VBMM-fit", title: str | None = None,
                      synthetic: bool = False):
    """One row per log (at most :data:`MAX_ROWS`): loop | angle vs time | error vs time.

    Parameters
    ----------
    logs : logs with ``angle_deg``
    predictions : log name -> (N,) predicted angle (deg)
    model, label : colour key of :data:`MODEL_COLORS` and legend text
    synthetic : mark the figure as made from synthetic data

    Returns
    -------
    matplotlib Figure
    """
    shown = list(logs)[:MAX_ROWS]
    rows = max(len(shown), 1)
    fig, axes = new_figure(rows, 3, width=12.0, height=2.4 * rows + 0.6, squeeze=False)
    color = MODEL_COLORS.get(model, "C3")
    meas = MODEL_COLORS["measured"]
    for r, lg in enumerate(shown):
        pred = np.asarray(predictions[lg.name], float)
        p, plabel = _pressure_axis(lg)
        ax_loop, ax_t, ax_e = axes[r]
        if lg.angle_deg is not None:
            ax_loop.plot(p, lg.angle_deg, color=meas, lw=0.8, label="measured")
            ax_t.plot(lg.time_s, lg.angle_deg, color=meas, lw=0.8, label="measured")
            err = pred - lg.angle_deg
            rmse = float(np.sqrt(np.nanmean(err**2)))
            ax_e.plot(lg.time_s, err, color=color, lw=0.7)
            ax_e.axhline(0.0, color="0.6", lw=0.6)
            ax_e.set_title(f"{lg.name}: RMSE {rmse:.3g} deg", fontsize=9)
        ax_loop.plot(p, pred, color=color, lw=1.0, label=label)
        ax_t.plot(lg.time_s, pred, color=color, lw=1.0, label=label)
        ax_loop.set_xlabel(plabel)
        ax_loop.set_ylabel("bending angle (deg)")
        ax_loop.set_title(f"{lg.name}: loop", fontsize=9)
        ax_t.set_xlabel("time (s)")
        ax_t.set_ylabel("angle (deg)")
        ax_e.set_xlabel("time (s)")
        ax_e.set_ylabel("fitted - measured (deg)")
        if r == 0:
            ax_loop.legend(fontsize=8, loc="upper left")
    if len(logs) > MAX_ROWS:
        fig.text(0.005, 0.005, f"first {MAX_ROWS} of {len(logs)} logs shown", fontsize=7, color="0.4")
    if title:
        fig.suptitle(title, fontsize=10)
    if synthetic:
        label_synthetic(fig)
    return fig


__all__ = ["motion_fit_figure", "MAX_ROWS"]
