"""Figures of ``bpmid control``: the paper's Fig. 18 in kind (reference and responses; error against time),
plus the command pressure with its limits. Functions return figures; the CLI writes them."""
from __future__ import annotations

from typing import Sequence

import numpy as np

from bpmid.plots.common import label_synthetic, new_figure

CONTROL_COLORS = {"pi": "#1f77b4", "vbmm-pi": "#d62728", "ms-pi": "#9467bd"}
LABELS = {"pi": "PI", "vbmm-pi": "VBMM-PI", "ms-pi": "MS-PI"}


def _concatenated(runs, controller, references):
    """Runs of one controller laid end to end in time (the order of ``references``)."""
    t, ref, ang, err, cmd, bounds, off = [], [], [], [], [], [], 0.0
    for name in references:
        r = next(r for r in runs if r.controller == controller and r.reference == name)
        t.append(r.time_s + off)
        ref.append(r.reference_deg)
        ang.append(r.angle_deg)
        err.append(r.error_deg)
        cmd.append(r.command_bar_abs)
        off += r.time_s[-1] + (r.time_s[1] - r.time_s[0])
        bounds.append(off)
    cat = np.concatenate
    return cat(t), cat(ref), cat(ang), cat(err), cat(cmd), bounds[:-1]


def fig18(runs: Sequence, *, limits_bar: tuple[float, float] | None = None, synthetic: bool = True):
    """(a) reference and measured responses, (b) tracking error, (c) command pressure, against time; every
    reference of ``runs`` end to end, one colour per controller."""
    refs = list(dict.fromkeys(r.reference for r in runs))
    ctrls = list(dict.fromkeys(r.controller for r in runs))
    fig, ax = new_figure(3, 1, width=9.0, height=7.5, sharex=True, gridspec_kw={"height_ratios": [3, 2, 1.4]})
    for i, c in enumerate(ctrls):
        t, ref, ang, err, cmd, bounds = _concatenated(runs, c, refs)
        if i == 0:
            ax[0].plot(t, ref, color="black", lw=1.4, ls="--", label="reference")
            for b in bounds:
                for a in ax:
                    a.axvline(b, color="0.8", lw=0.8)
        col = CONTROL_COLORS.get(c)
        ax[0].plot(t, ang, color=col, lw=1.0, label=LABELS.get(c, c))
        ax[1].plot(t, err, color=col, lw=0.9, label=LABELS.get(c, c))
        ax[2].plot(t, cmd, color=col, lw=0.8)
    if limits_bar is not None:
        for lim in limits_bar:
            ax[2].axhline(lim, color="0.3", ls=":", lw=0.8)
    ax[0].set_ylabel("bending angle (deg)")
    ax[0].set_title("(a) time-angle", loc="left", fontsize=10)
    ax[0].legend(loc="upper right", fontsize=8, ncol=len(ctrls) + 1)
    ax[1].axhline(0.0, color="0.5", lw=0.6)
    ax[1].set_ylabel("error (deg)")
    ax[1].set_title("(b) time-error", loc="left", fontsize=10)
    ax[2].set_ylabel("command (bar abs)")
    ax[2].set_xlabel("time (s); references end to end: " + ", ".join(refs))
    if synthetic:
        label_synthetic(fig)
    return fig


__all__ = ["fig18", "CONTROL_COLORS"]
