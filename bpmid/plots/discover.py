"""Figures of ``bpmid discover``: functions that take a :class:`~bpmid.discover.workflow.DiscoveryResult` and
return figures (the CLI writes them).

- :func:`residual_figure`: residual before and after the named effects, against time, pressure and pressure rate
- :func:`ranking_figure`: the screening ranking of each round
- :func:`heldout_figure`: held-out RMSE per log before and after, with the noise floor

Before is drawn solid, after dashed and on top, so that identical curves (nothing added) stay visible as one
dashed-over-solid line, and the legend says when they are identical.
"""
from __future__ import annotations

import numpy as np

from bpmid.discover.diagnose import pressure_rate
from bpmid.discover.model import gained_residuals, residuals, simulate
from bpmid.plots.common import (MODEL_COLORS, PA_PER_BAR, PRESSURE_LABEL, PRESSURE_RATE_LABEL, new_figure,
                                outside_legend)

BEFORE = MODEL_COLORS["vbmm-fit"]
AFTER = MODEL_COLORS["vbmm+effects"]


def residual_figure(result):
    """3 x 1 panels: residual (°) against time, gauge pressure (bar) and pressure rate (bar/s), before (base
    VBMM) and after (VBMM + named effects), on every log (fitting and held-out)."""
    logs = list(result.fit_logs) + list(result.holdout_logs)
    before = residuals(result.base_state, logs)
    after = residuals(result.final_state, logs)
    same = all(np.allclose(a, b, rtol=0, atol=1e-9) for a, b in zip(before, after))
    fig, axes = new_figure(3, 1, width=9.0, height=8.0, legend="top", legend_size=0.45, hgap=0.75)
    t0 = 0.0
    for lg, rb, ra in zip(logs, before, after):
        t = lg.time_s - lg.time_s[0] + t0
        axes[0].plot(t, rb, color=BEFORE, lw=0.9)
        axes[0].plot(t, ra, color=AFTER, lw=0.9, ls=(0, (4, 3)))
        t0 = t[-1] + 1.0
        p = lg.pressure_pa / PA_PER_BAR
        rate = pressure_rate(lg) / PA_PER_BAR
        for ax, x in ((axes[1], p), (axes[2], rate)):
            ax.plot(x, rb, "o", ms=2.0, color=BEFORE, alpha=0.35, ls="none", mew=0)
            ax.plot(x, ra, "x", ms=2.0, color=AFTER, alpha=0.35, ls="none")
    named = " + ".join(result.named_effects) or "nothing added"
    floor = result.noise_floor_deg
    import matplotlib.patches as mpatches
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color=BEFORE, lw=1.2, marker="o", ms=3), Line2D([], [], color=AFTER, lw=1.2,
               ls=(0, (4, 3)), marker="x", ms=3), mpatches.Patch(color="0.85")]
    labels = ["before: base VBMM", f"after: VBMM + {named}" + (" (identical to before)" if same else ""),
              f"noise floor ±{floor:.2f}°"]
    outside_legend(fig, handles, labels, ncol=3)
    axes[0].set_xlabel("time, logs end to end (s)")
    axes[1].set_xlabel(PRESSURE_LABEL)
    axes[2].set_xlabel(PRESSURE_RATE_LABEL)
    for ax in axes:
        ax.set_ylabel("model − measured (°)")
        ax.axhspan(-floor, floor, color="0.85", zorder=0)
    axes[0].set_title("residual before and after, every log (raw: no per-log factors, unlike the held-out scores)")
    return fig


def ranking_figure(result):
    """Screening score of every candidate, one panel per round; accepted effect highlighted."""
    n = max(len(result.rounds), 1)
    longest = max((len(s.effect_id) for rnd in result.rounds for s in rnd.ranking), default=10)
    left = 0.3 + 0.065 * longest
    nbars = max((len(rnd.ranking) for rnd in result.rounds), default=1)
    fig, axes = new_figure(1, n, width=left + 3.6 * n, height=max(3.0, 0.22 * nbars + 1.6), squeeze=False,
                           left=left, wgap=left, legend="top", legend_size=0.4)
    for k, rnd in enumerate(result.rounds):
        ax = axes[0, k]
        ids = [s.effect_id for s in rnd.ranking][::-1]
        expl = [100 * s.explained for s in rnd.ranking][::-1]
        colors = [AFTER if i == rnd.accepted else (BEFORE if any(c.effect_id == i for c in rnd.confirmations)
                                                   else "0.65") for i in ids]
        ax.barh(ids, expl, color=colors)
        ax.set_xlabel("residual explained (%)")
        together = getattr(rnd, "joint_with", "")
        ax.set_title(f"round {k + 1}: " + (f"added {rnd.accepted} (with {together})" if together
                                           else f"added {rnd.accepted}" if rnd.accepted else "none passed"))
        ax.grid(axis="y", visible=False)
    import matplotlib.patches as mpatches

    kinds = [(AFTER, "accepted"), (BEFORE, "confirmation tried"), ("0.65", "screened only")]
    shown = {c for ax in axes[0] for p in ax.patches for c in [p.get_facecolor()]}   # only the kinds drawn
    from matplotlib.colors import to_rgba

    kinds = [(c, w) for c, w in kinds if to_rgba(c) in shown] or kinds[:1]
    outside_legend(fig, [mpatches.Patch(color=c) for c, _w in kinds], [w for _c, w in kinds], ncol=3)
    return fig


def heldout_figure(result):
    """Held-out RMSE per log, base VBMM vs VBMM + named effects, with the noise floor."""
    logs = result.holdout_logs
    # scored as the totals are: with the per-log factors (LogNuisance) that scored them, when discovery scored so
    gain = getattr(result, "per_log_gain", False)
    gain = False if gain is None else gain

    def per_log(state):
        parts = gained_residuals(simulate(state, logs), logs, per_log_gain=gain, normalise=False)
        return [float(np.sqrt(np.nanmean(r**2))) for r in parts]

    rb, ra = per_log(result.base_state), per_log(result.final_state)
    longest = max((len(lg.name) for lg in logs), default=8)
    fig, ax = new_figure(1, 1, width=7.5, height=3.8, legend="right", legend_size=2.6,
                         bottom=0.45 + 0.045 * longest)
    x = np.arange(len(logs))
    ax.bar(x - 0.2, rb, 0.4, color=BEFORE, label=f"base VBMM (all: {result.heldout_before:.2f}°)")
    ax.bar(x + 0.2, ra, 0.4, color=AFTER, hatch="//", edgecolor="white",
           label=f"+ {' + '.join(result.named_effects) or 'nothing'} (all: {result.heldout_after:.2f}°)")
    ax.axhline(result.noise_floor_deg, color="k", ls="--", lw=1, label=f"noise floor {result.noise_floor_deg:.2f}°")
    ax.set_xticks(x, [lg.name for lg in logs], rotation=30, ha="right")
    ax.set_ylabel("held-out RMSE, each log's own factors fitted (°)" if gain is not False else "held-out RMSE (°)")
    ax.set_title("Held-out error per log")
    outside_legend(fig, ax=ax)
    return fig
