"""The figure of a digital-twin simulation (``bpmid.simulate(...).plot()``): every log it made, one small panel
each, so that logs of different lengths and ranges stay readable; no legend (each panel is titled by its log).
It returns a figure and never writes files; it is always stamped synthetic (the twin made every log)."""
from __future__ import annotations

import math
from typing import Mapping

import pandas as pd

from bpmid.plots.common import MODEL_COLORS, finish, new_figure

#: the most panels one figure draws (a protocol of more logs: the figure says how many of how many it shows)
MAX_PANELS = 24
#: the columns of the panel grid
COLUMNS = 3

#: a log's quantity -> its axis label, in the order one is looked for (the first column present is drawn)
QUANTITIES = (("angle_deg", "bending angle (°)"), ("stress_mpa", "stress (MPa)"), ("stress_pa", "stress (Pa)"),
              ("pressure_bar", "pressure (bar, as logged)"))


def _quantity(df: pd.DataFrame) -> tuple[str, str]:
    for col, label in QUANTITIES:
        if col in df.columns:
            return col, label
    col = df.columns[-1]
    return col, col


def simulation_figure(frames: Mapping[str, pd.DataFrame], *, title: str, total: int | None = None,
                      synthetic: "bool | str" = True):
    """One panel per log (at most :data:`MAX_PANELS`, in a grid of :data:`COLUMNS`): the log's angle (or the
    stress of a relaxation log) against time.

    Parameters
    ----------
    frames : log name -> its table (``time_s`` first, as bpmid simulate writes it)
    title : what was simulated (the protocol); the figure adds how many logs it draws of how many
    total : how many logs the simulation made (``len(frames)`` when None)
    synthetic : the stamp (the twin's words by default)
    """
    names = list(frames)
    total = len(names) if total is None else total
    shown = names[:MAX_PANELS]
    n = max(len(shown), 1)
    cols = min(COLUMNS, n)
    rows = math.ceil(n / cols)
    fig, axes = new_figure(rows, cols, width=3.6 * cols + 0.9, height=1.9 * rows + 1.0, squeeze=False,
                           suptitle=True, hgap=0.65, wgap=0.75, top=0.35)
    drawn = 0
    for i, name in enumerate(shown):
        ax = axes[i // cols, i % cols]
        df = frames[name]
        col, label = _quantity(df)
        ax.plot(df[df.columns[0]], df[col], color=MODEL_COLORS["vbmm-fit"], lw=0.9)
        ax.set_title(name, fontsize=8)
        ax.set_xlabel("time (s)")
        ax.set_ylabel(label)
        drawn += 1
    for j in range(len(shown), rows * cols):   # the grid's empty places
        axes[j // cols, j % cols].set_visible(False)
    if not shown:
        axes[0, 0].text(0.5, 0.5, "no logs", transform=axes[0, 0].transAxes, ha="center", color="0.4")
    count = (("its one log" if total == 1 else f"all {total} logs") if drawn == total else
             f"{drawn} of {total} logs drawn (the first {drawn})")
    fig.suptitle(f"{title}: {count}", y=1 - 0.08 / fig.get_size_inches()[1], va="top")
    return finish(fig, synthetic)


__all__ = ["simulation_figure", "MAX_PANELS"]
