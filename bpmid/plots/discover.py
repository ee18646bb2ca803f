"""Figures of ``bpmid discover``: functions that take a :class:`~bpmid.discover.workflow.DiscoveryResult` and
return figures (the CLI writes them).

- :func:`residual_figure`: residual before and after the named effects, against time, pressure and pressure rate
- :func:`ranking_figure`: the screening ranking of each round
- :func:`heldout_figure`: held-out RMSE per log before and after, with the noise floor
"""
from __future__ import annotations

import numpy as np

from bpmid.discover.diagnose import pressure_rate
from bpmid.discover.model import residuals
from bpmid.plots.common import MODEL_COLORS, new_figure


def residual_figure(result):
    """3 x 1 panels: residual (deg) against time, gauge pressure (bar) and pressure rate (bar/s), before (base
    VBMM) and after (VBMM + named effects), on every log (fitting and held-out)."""
    logs = list(result.fit_logs) + list(result.holdout_logs)
    before = residuals(result.base_state, logs)
    after = residuals(result.final_state, logs)
    fig, axes = new_figure(3, 1, width=8.0, height=8.0)
    t0 = 0.0
    for lg, rb, ra in zip(logs, before, after):
        t = lg.time_s - lg.time_s[0] + t0
        axes[0].plot(t, rb, color=MODEL_COLORS["vbmm-fit"], lw=0.6)
        axes[0].plot(t, ra, color=MODEL_COLORS["vbmm+effects"], lw=0.6)
        t0 = t[-1] + 1.0
        p = lg.pressure_pa / 1e5
        rate = pressure_rate(lg) / 1e5
        for ax, x in ((axes[1], p), (axes[2], rate)):
            ax.plot(x, rb, ".", ms=1.5, color=MODEL_COLORS["vbmm-fit"], alpha=0.4)
            ax.plot(x, ra, ".", ms=1.5, color=MODEL_COLORS["vbmm+effects"], alpha=0.4)
    named = " + ".join(result.named_effects) or "nothing added"
    axes[0].plot([], [], color=MODEL_COLORS["vbmm-fit"], label="base VBMM")
    axes[0].plot([], [], color=MODEL_COLORS["vbmm+effects"], label=f"VBMM + {named}")
    axes[0].legend(loc="upper right", fontsize=8)
    axes[0].set_xlabel("time, logs end to end (s)")
    axes[1].set_xlabel("gauge pressure (bar)")
    axes[2].set_xlabel("pressure rate (bar/s)")
    floor = result.noise_floor_deg
    for ax in axes:
        ax.set_ylabel("model - measured (deg)")
        ax.axhspan(-floor, floor, color="0.85", zorder=0)
    axes[0].set_title(f"residual before and after (grey band: noise floor +-{floor:.2f} deg)")
    return fig


def ranking_figure(result):
    """Screening score of every candidate, one panel per round; accepted effect highlighted."""
    n = max(len(result.rounds), 1)
    fig, axes = new_figure(1, n, width=4.0 * n, height=3.6, squeeze=False)
    for k, rnd in enumerate(result.rounds):
        ax = axes[0, k]
        ids = [s.effect_id for s in rnd.ranking][::-1]
        expl = [100 * s.explained for s in rnd.ranking][::-1]
        colors = ["#e377c2" if i == rnd.accepted else ("#1f77b4" if any(c.effect_id == i for c in rnd.confirmations)
                                                      else "0.6") for i in ids]
        ax.barh(ids, expl, color=colors)
        ax.set_xlabel("residual explained by the signature (%)")
        ax.set_title(f"round {k + 1}: " + (f"added {rnd.accepted}" if rnd.accepted else "none passed"), fontsize=9)
        ax.tick_params(axis="y", labelsize=8)
    return fig


def heldout_figure(result):
    """Held-out RMSE per log, base VBMM vs VBMM + named effects, with the noise floor."""
    logs = result.holdout_logs
    rb = [float(np.sqrt(np.mean(r**2))) for r in residuals(result.base_state, logs)]
    ra = [float(np.sqrt(np.mean(r**2))) for r in residuals(result.final_state, logs)]
    fig, ax = new_figure(1, 1, width=6.5, height=3.6)
    x = np.arange(len(logs))
    ax.bar(x - 0.2, rb, 0.4, color=MODEL_COLORS["vbmm-fit"], label=f"base VBMM (all: {result.heldout_before:.2f} deg)")
    ax.bar(x + 0.2, ra, 0.4, color=MODEL_COLORS["vbmm+effects"],
           label=f"+ {' + '.join(result.named_effects) or 'nothing'} (all: {result.heldout_after:.2f} deg)")
    ax.axhline(result.noise_floor_deg, color="k", ls="--", lw=1, label=f"noise floor {result.noise_floor_deg:.2f} deg")
    ax.set_xticks(x, [lg.name for lg in logs], rotation=20, fontsize=8)
    ax.set_ylabel("held-out RMSE (deg)")
    ax.legend(fontsize=8)
    return fig
