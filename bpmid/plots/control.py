"""Figures of ``bpmid control``: the paper's Fig. 18 in kind (reference and responses; error against time),
plus the command pressure with its limits and every sample of the loop's worst ringing. Functions return figures;
the CLI writes them."""
from __future__ import annotations

from typing import Sequence

import numpy as np
from matplotlib.lines import Line2D

from bpmid.plots.common import OKABE_ITO, finish, new_figure, outside_legend

CONTROL_COLORS = {"pi": OKABE_ITO["orange"], "vbmm-pi": OKABE_ITO["blue"], "ms-pi": OKABE_ITO["purple"]}
#: the zoom panel's line style and marker per controller (the time panels draw every controller solid: a dash
#: pattern laid along a line that swings every sample leaves gaps where the swings are, and hid a ringing)
CONTROL_STYLES = {"pi": (0, (5, 2)), "vbmm-pi": "-", "ms-pi": "-."}
CONTROL_MARKERS = {"pi": "o", "vbmm-pi": "s", "ms-pi": "^"}
LABELS = {"pi": "PI", "vbmm-pi": "VBMM-PI", "ms-pi": "MS-PI"}
#: the legend's words for each panel's own marks
BOUNDARY_LABEL = "end of a reference"
LIMITS_LABEL = "command limits"
RINGING_LABEL = "ringing episodes"
#: the zoom panel shows at most this long a stretch (s) of an episode, and this much (s) before and after it
ZOOM_MAX_S = 4.0
ZOOM_PAD_S = 0.5


def _concatenated(runs, controller, references):
    """Runs of one controller laid end to end in time (the order of ``references``): every sample, no decimation."""
    t, ref, ang, err, cmd, bounds, offs, off = [], [], [], [], [], [], [], 0.0
    for name in references:
        r = next(r for r in runs if r.controller == controller and r.reference == name)
        t.append(r.time_s + off)
        offs.append(off)
        ref.append(r.reference_deg)
        ang.append(r.angle_deg)
        err.append(r.error_deg)
        cmd.append(r.command_bar_abs)
        off += r.time_s[-1] + (r.time_s[1] - r.time_s[0])
        bounds.append(off)
    cat = np.concatenate
    return cat(t), cat(ref), cat(ang), cat(err), cat(cmd), bounds[:-1], offs


def _episodes(run) -> list:
    return list(getattr(run, "ringing", []) or [])


def zoom_window(runs: Sequence) -> tuple[str, float, float, str]:
    """(reference, t0, t1, words) of the zoom panel: the longest ringing episode of any run (the larger swing on a
    tie), or, when no run rings, the largest error of any run; times in that reference's own clock."""
    best = None
    for r in runs:
        for ep in _episodes(r):
            key = (ep.duration_s, ep.largest_swing_deg)
            if best is None or key > best[0]:
                best = (key, r, ep)
    if best is not None:
        _k, r, ep = best
        t1 = min(ep.end_s, ep.start_s + ZOOM_MAX_S)
        words = (f"{LABELS.get(r.controller, r.controller)} rings {ep.duration_s:.2g} s from {ep.start_s:.4g} s, "
                 f"swings back up to {ep.largest_swing_deg:.3g}° peak to peak, period {ep.period_s:.2g} s")
        return r.reference, ep.start_s - ZOOM_PAD_S, t1 + ZOOM_PAD_S, words
    r = max(runs, key=lambda r: float(np.max(np.abs(r.error_deg))))
    k = int(np.argmax(np.abs(r.error_deg)))
    t0 = float(r.time_s[k])
    words = (f"no run rings; the largest error, {LABELS.get(r.controller, r.controller)} "
             f"{abs(float(r.error_deg[k])):.3g}° at {t0:.4g} s")
    return r.reference, t0 - ZOOM_MAX_S / 2, t0 + ZOOM_MAX_S / 2, words


def fig18(runs: Sequence, *, limits_bar: tuple[float, float] | None = None, synthetic: bool = True,
          atmosphere_bar: float = 1.01325):
    """(a) reference and measured responses, (b) tracking error with each run's ringing episodes marked, (c) command
    pressure (gauge) with its limits, against time, every reference of ``runs`` end to end, one colour per controller;
    (d) every sample of the worst ringing (:func:`zoom_window`), one marker per controller. Each panel's legend sits
    beside it."""
    refs = list(dict.fromkeys(r.reference for r in runs))
    ctrls = list(dict.fromkeys(r.controller for r in runs))
    fig, ax = new_figure(4, 1, width=9.5, height=9.6, gridspec_kw={"height_ratios": [3, 2, 1.4, 2.2]},
                         legend="right", legend_size=1.3, hgap=0.35, bottom=0.7)
    for a in ax[1:3]:
        a.sharex(ax[0])
    for a in ax[:2]:
        a.tick_params(labelbottom=False)
    errs = []
    for i, c in enumerate(ctrls):
        t, ref, ang, err, cmd, bounds, offs = _concatenated(runs, c, refs)
        errs.append(err)
        col = CONTROL_COLORS.get(c)
        if i == 0:
            ax[0].plot(t, ref, color="black", lw=1.6, alpha=0.5, label="reference")
            for j, b in enumerate(bounds):
                for a in ax[:3]:
                    a.axvline(b, color="0.6", lw=0.8, ls=":", label=BOUNDARY_LABEL if (a is ax[0] and j == 0)
                              else "_nolegend_")
        ax[0].plot(t, ang, color=col, ls="-", lw=0.9, label=LABELS.get(c, c))
        ax[1].plot(t, err, color=col, ls="-", lw=0.8)
        ax[2].plot(t, cmd - atmosphere_bar, color=col, ls="-", lw=0.8)
        # each run's ringing episodes: a bar at the top of the error panel, one row per controller
        for name, off in zip(refs, offs):
            r = next(r for r in runs if r.controller == c and r.reference == name)
            for ep in _episodes(r):
                ax[1].plot([off + ep.start_s, off + ep.end_s], [0.97 - 0.06 * i] * 2, color=col, lw=3.0,
                           solid_capstyle="butt", transform=ax[1].get_xaxis_transform(), label="_ringing")
    if limits_bar is not None:
        for j, lim in enumerate(limits_bar):
            ax[2].axhline(lim - atmosphere_bar, color="0.2", ls=(0, (6, 3)), lw=0.8,
                          label=LIMITS_LABEL if j == 0 else "_nolegend_")
    ax[0].set_ylabel("bending angle,\nmeasured (°)")
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
    _zoom(ax[3], runs, ctrls)
    # (d) below (c)'s time label: its top comes down by the room that label takes
    w_in, h_in = fig.get_size_inches()
    p = ax[3].get_position()
    ax[3].set_position([p.x0, p.y0, p.width, p.height - 0.45 / h_in])
    # the legends, each beside its own panel: the controllers and what (a) draws; the ringing bars of (b); the limits
    # of (c); the markers of (d)
    h0, l0 = ax[0].get_legend_handles_labels()
    outside_legend(fig, h0, l0)
    if any(_episodes(r) for r in runs):
        _panel_legend(fig, ax[1], [Line2D([], [], color="0.3", lw=3.0, solid_capstyle="butt")], [RINGING_LABEL])
    h2, l2 = ax[2].get_legend_handles_labels()
    if h2:
        _panel_legend(fig, ax[2], h2, l2)
    h3, l3 = ax[3].get_legend_handles_labels()
    _panel_legend(fig, ax[3], h3, l3)
    return finish(fig, synthetic)


def _zoom(ax, runs, ctrls) -> None:
    """(d): every sample of one stretch of one reference (:func:`zoom_window`), a marker per sample."""
    name, t0, t1, words = zoom_window(runs)
    drew_ref = False
    for c in ctrls:
        r = next((r for r in runs if r.controller == c and r.reference == name), None)
        if r is None:
            continue
        k = (r.time_s >= t0 - 1e-9) & (r.time_s <= t1 + 1e-9)
        if not drew_ref:
            ax.plot(r.time_s[k], r.reference_deg[k], color="black", lw=1.6, alpha=0.5, label="reference")
            drew_ref = True
        ax.plot(r.time_s[k], r.angle_deg[k], color=CONTROL_COLORS.get(c), ls=CONTROL_STYLES.get(c, "-"), lw=0.7,
                marker=CONTROL_MARKERS.get(c, "o"), ms=3.2, mfc="none", mew=0.8, label=LABELS.get(c, c))
    ax.set_xlim(t0, t1)
    ax.set_ylabel("bending angle,\nmeasured (°)")
    ax.set_xlabel(f"time in {name} (s); one marker per sample")
    ax.set_title(f"(d) every sample: {words}", loc="left")


def _panel_legend(fig, ax, handles, labels):
    """A legend in the column beside the axes (where :func:`outside_legend` puts the first), at the top of ``ax``."""
    w_in, _h = fig.get_size_inches()
    p = ax.get_position()
    return fig.legend(handles, labels, loc="upper left", bbox_to_anchor=(p.x1 + 0.05 / w_in, p.y1),
                      borderaxespad=0.0)


__all__ = ["fig18", "zoom_window", "CONTROL_COLORS"]
