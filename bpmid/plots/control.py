"""Figures of ``bpmid control``: the paper's Fig. 18 in kind (reference and responses; error against time),
plus the command pressure with its limits. Functions return figures; the CLI writes them."""
from __future__ import annotations

from typing import Sequence

import numpy as np

from bpmid.plots.common import OKABE_ITO, finish, new_figure, outside_legend

CONTROL_COLORS = {"pi": OKABE_ITO["orange"], "vbmm-pi": OKABE_ITO["blue"], "ms-pi": OKABE_ITO["purple"]}
CONTROL_STYLES = {"pi": (0, (5, 2)), "vbmm-pi": "-", "ms-pi": "-."}
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


def fig18(runs: Sequence, *, limits_bar: tuple[float, float] | None = None, synthetic: bool = True,
          atmosphere_bar: float = 1.01325):
    """(a) reference and measured responses, (b) tracking error, (c) command pressure (gauge), against time;
    every reference of ``runs`` end to end, one colour and line style per controller."""
    refs = list(dict.fromkeys(r.reference for r in runs))
    ctrls = list(dict.fromkeys(r.controller for r in runs))
    fig, ax = new_figure(3, 1, width=9.5, height=7.2, sharex=True, gridspec_kw={"height_ratios": [3, 2, 1.4]},
                         legend="right", legend_size=1.3, hgap=0.35, bottom=0.7)
    errs = []
    for i, c in enumerate(ctrls):
        t, ref, ang, err, cmd, bounds = _concatenated(runs, c, refs)
        errs.append(err)
        if i == 0:
            ax[0].plot(t, ref, color="black", lw=1.6, alpha=0.5, label="reference")
            for b in bounds:
                for a in ax:
                    a.axvline(b, color="0.75", lw=0.8, ls=":")
        col, ls = CONTROL_COLORS.get(c), CONTROL_STYLES.get(c, "-")
        ax[0].plot(t, ang, color=col, ls=ls, lw=1.0, label=LABELS.get(c, c))
        ax[1].plot(t, err, color=col, ls=ls, lw=0.9)
        ax[2].plot(t, cmd - atmosphere_bar, color=col, ls=ls, lw=0.8)
    if limits_bar is not None:
        for lim in limits_bar:
            ax[2].axhline(lim - atmosphere_bar, color="0.3", ls=":", lw=0.8)
        ax[2].plot([], [], color="0.3", ls=":", lw=0.8, label="command limits")
    ax[0].set_ylabel("bending angle (°)")
    ax[0].set_title("(a) time-angle", loc="left")
    ax[1].axhline(0.0, color="0.5", lw=0.6)
    ax[1].set_ylabel("error, reference\n− angle (°)")
    # a reference's jumps (a sawtooth's reset) spike the error far beyond the tracking the panel is about: the axis
    # holds 99 % of the samples and says when it cuts the rest
    a_err = np.abs(np.concatenate(errs)) if errs else np.zeros(1)
    lim = 1.3 * float(np.percentile(a_err, 99)) if a_err.size else 0.0
    clipped = lim > 0 and float(a_err.max()) > 1.5 * lim
    if clipped:
        ax[1].set_ylim(-lim, lim)
    ax[1].set_title("(b) time-error" + (f" (axis at ±{lim:.2g}°: at a reference's jumps the error reaches "
                                        f"{float(a_err.max()):.0f}°)" if clipped else ""), loc="left")
    ax[2].set_ylabel("command\n(bar gauge)")
    ax[2].set_title("(c) command pressure", loc="left")
    ax[2].set_xlabel("time (s); references end to end: " + ", ".join(refs))
    h0, l0 = ax[0].get_legend_handles_labels()
    h2, l2 = ax[2].get_legend_handles_labels()
    outside_legend(fig, h0 + h2, l0 + l2)
    return finish(fig, synthetic)


__all__ = ["fig18", "CONTROL_COLORS"]
