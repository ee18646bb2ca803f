"""Figures of the study report: history-mode timing, relaxation-modulus curves, error bands, residual
diagnostics and the prediction figure. They take results (tables, dicts, arrays) and return figures; they
never write files."""
from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
import pandas as pd

from bpmid.plots.common import (OKABE_ITO, PA_PER_BAR, PRESSURE_RATE_LABEL, color_of, finish, new_figure,
                                outside_legend, style_of)

MODE_COLORS = {"recursive": OKABE_ITO["blue"], "window": OKABE_ITO["green"], "full": OKABE_ITO["vermillion"]}
MODE_STYLES = {"recursive": "-", "window": "--", "full": "-."}
MODE_MARKERS = {"recursive": "o", "window": "s", "full": "^"}


def history_figure(study, *, synthetic: bool = True):
    """(a) cost per simulated step against log length for each history mode; (b) on the whole long log, the
    prediction error of full and window (on top of each other when they agree); (c) the difference window
    minus full on its own axis, so that a difference of 1e-12° is visible and read off its own scale."""
    fig, (a, b, c) = new_figure(1, 3, width=13.0, height=3.7, legend="top", legend_size=0.45, wgap=0.9)
    t = study.timing
    for mode, g in t.groupby("mode", sort=False):
        a.plot(g["n_steps"], g["us_per_step"], marker=MODE_MARKERS.get(mode, "o"), color=MODE_COLORS.get(mode),
               ls=MODE_STYLES.get(mode, "-"), label=f"{mode} history")
    a.set_xlabel("log length (steps)")
    a.set_ylabel("cost per simulated step (µs)")
    a.set_yscale("log")
    a.set_title(f"(a) cost per step (T_win = {study.window_s:g} s)")
    lg = study.log
    for mode in ("full", "window"):
        if mode in study.predictions:
            b.plot(lg.time_s, study.predictions[mode] - lg.angle_deg, lw=1.6 if mode == "full" else 0.9,
                   color=MODE_COLORS[mode], ls=MODE_STYLES[mode])
    b.set_xlabel("time (s)")
    b.set_ylabel("model − measured (°)")
    rm = {m: study.accuracy[m]["rmse_deg"] for m in ("full", "window") if m in study.accuracy}
    b.set_title("(b) error: " + ", ".join(f"{m} RMSE {v:.3f}°" for m, v in rm.items()))
    if "window" in study.predictions and "full" in study.predictions:
        d = study.predictions["window"] - study.predictions["full"]
        c.plot(lg.time_s, d, lw=0.9, color="black")
        c.set_title(f"(c) window − full: max |diff| {np.max(np.abs(d)):.2g}°")
        c.ticklabel_format(axis="y", style="sci", scilimits=(-2, 3), useMathText=True)
    else:
        c.text(0.5, 0.5, "window or full not run", transform=c.transAxes, ha="center")
        c.set_title("(c) window − full")
    c.set_xlabel("time (s)")
    c.set_ylabel("difference (°)")
    outside_legend(fig, ax=a, ncol=3)
    return finish(fig, synthetic)


def _modulus_unit(values) -> tuple[float, str]:
    """(Pa per unit, unit) in which the largest of ``values`` (Pa) reads between 1 and 1000: kPa for a rubber's E,
    MPa for its nearly incompressible K, GPa for a glassy polymer; MPa when there is nothing to show."""
    top = float(np.nanmax(np.abs(values))) if values is not None and np.size(values) else 0.0
    for factor, unit in ((1e9, "GPa"), (1e6, "MPa"), (1e3, "kPa"), (1.0, "Pa")):
        if top >= factor:
            return factor, unit
    return 1e6, "MPa"


def modulus_curves(relax: Mapping, *, paper: Mapping | None = None, synthetic: bool = True):
    """Relaxation moduli E(t), G(t), K(t) of a ``bpmid.relax/1`` fit (dicts as in the file), with the
    paper's published one-term E(t) as a dashed, labelled line when ``paper`` is given
    (``{E_inf, E_1, tau_1}`` in Pa and s)."""
    def curve(block, name, inf_name, t):
        b = relax.get(block) or {}
        if inf_name not in b:
            return None
        y = np.full_like(t, float(b[inf_name]["value"]))
        for term in b.get("terms") or []:
            y += float(term[name]["value"]) * np.exp(-t / float(term["tau"]["value"]))
        return y

    taus = [float(tr["tau"]["value"]) for tr in (relax.get("prony") or {}).get("terms") or []] or [1.0]
    t = np.logspace(np.log10(min(taus) / 30), np.log10(max(max(taus) * 30, 10.0)), 300)
    fig, axes = new_figure(1, 3, width=12.5, height=3.5, legend="top", legend_size=0.45, wgap=0.9)
    a, b, k_ax = axes
    e = curve("prony", "E", "E_inf", t)
    fe, ue = _modulus_unit(e)   # each panel in the unit its values read best in (E and G of a rubber: kPa)
    if e is not None:
        a.semilogx(t, e / fe, color=OKABE_ITO["blue"], lw=2, label="fitted here")
    if paper:
        ep = paper["E_inf"] + paper["E_1"] * np.exp(-t / paper["tau_1"])
        a.semilogx(t, ep / fe, "--", color="0.35", lw=1.3, label="paper's published fit (quoted, paper's data)")
    a.set_xlabel("time (s)")
    a.set_ylabel(f"E(t) ({ue})")
    a.set_title("(a) tensile relaxation modulus")
    g = curve("shear", "G", "G_inf", t)
    k = curve("bulk", "K", "K_inf", t)
    fg, ug = _modulus_unit(g)
    if g is not None:
        b.semilogx(t, g / fg, color=OKABE_ITO["blue"], lw=2)
    b.set_ylabel(f"G(t) ({ug})")
    b.set_xlabel("time (s)")
    b.set_title(f"(b) shear modulus (ν = {relax.get('poisson_ratio', float('nan')):.5g})")
    fk, uk = _modulus_unit(k)
    if k is not None:
        k_ax.semilogx(t, k / fk, color=OKABE_ITO["blue"], lw=2)
    k_ax.set_ylabel(f"K(t) ({uk})")
    k_ax.set_xlabel("time (s)")
    k_ax.set_title("(c) bulk modulus")
    outside_legend(fig, ax=a, ncol=2)
    return finish(fig, synthetic)


def error_bands(sets: Mapping[str, Sequence[pd.DataFrame]], models: Sequence[str], *, synthetic: bool = True):
    """Small multiples, one row per test set and one column per model: the model's mean prediction error
    over the set's logs against time, with a band from the smallest to the largest error across the logs
    (aligned by sample, cut to the shortest log). One line per panel: nothing to untangle.
    ``sets``: set name -> prediction frames (``time_s``, ``angle_deg``, ``pred_<model>_deg``)."""
    names = list(sets)
    models = [m for m in models if any(f"pred_{m}_deg" in fr for v in sets.values() for fr in v)] or list(models)
    nm = max(len(models), 1)
    fig, axes = new_figure(len(names), nm, width=1.2 + 2.3 * nm, height=1.9 * len(names) + 0.9, squeeze=False,
                           sharey=True, sharex="row", wgap=0.2, hgap=0.75, left=0.95, legend="top", legend_size=0.35)
    for r, s in enumerate(names):
        frames = sets[s]
        n = min(len(f) for f in frames)
        t = frames[0]["time_s"].to_numpy()[:n] - frames[0]["time_s"].iloc[0]
        cut = any(len(f) > n for f in frames)
        for c, m in enumerate(models):
            ax = axes[r, c]
            col = f"pred_{m}_deg"
            if col not in frames[0]:
                ax.text(0.5, 0.5, "not run", transform=ax.transAxes, ha="center")
                continue
            err = np.stack([f[col].to_numpy()[:n] - f["angle_deg"].to_numpy()[:n] for f in frames])
            clr = color_of(m, c)
            ax.fill_between(t, err.min(axis=0), err.max(axis=0), color=clr, alpha=0.25, lw=0)
            ax.plot(t, err.mean(axis=0), color=clr, lw=1.0)
            ax.axhline(0, color="black", lw=0.5)
            ax.set_title(m if r == 0 else "")
            if c == 0:
                ax.set_ylabel(f"{s}\n({len(frames)} log(s))\nerror (°)")
            ax.set_xlabel("time in log (s)" + (f", the first {t[-1]:.0f} s of each" if cut else ""))
    import matplotlib.patches as mpatches
    from matplotlib.lines import Line2D

    outside_legend(fig, [Line2D([], [], color="0.3", lw=1.0), mpatches.Patch(color="0.3", alpha=0.25)],
                   ["mean error over the set's logs, sample by sample (aligned by time in log, not by cycle)",
                    "smallest to largest error across the logs"], ncol=2)
    return finish(fig, synthetic)


def acf(r: np.ndarray, max_lag: int) -> np.ndarray:
    """Normalised autocorrelation r(tau) = R(tau)/R(0), tau = 0..max_lag."""
    r = np.asarray(r, float) - np.mean(r)
    den = float(np.dot(r, r)) or 1.0
    return np.array([np.dot(r[k:], r[:r.size - k]) / den for k in range(max_lag + 1)])


def residual_diagnostics(frames: Sequence[pd.DataFrame], models: Sequence[str], *, max_lag: int = 100,
                         synthetic: bool = True):
    """Residual diagnostics of every model on the pooled test logs: autocorrelation with the ±2.576/√N
    whiteness bounds, binned mean residual against the pressure rate, and residual distributions."""
    fig, (a, b, c) = new_figure(1, 3, width=12.5, height=3.6, legend="right", legend_size=1.8, wgap=0.85)
    n_total = sum(len(f) for f in frames)
    for i, m in enumerate(models):
        col = f"pred_{m}_deg"
        res, rate = [], []
        for f in frames:
            if col not in f:
                continue
            e = f[col].to_numpy() - f["angle_deg"].to_numpy()
            res.append(e)
            p = f["pressure_pa_gauge"].to_numpy() / PA_PER_BAR
            rate.append(np.gradient(p, f["time_s"].to_numpy()))
        if not res:
            continue
        clr, ls = color_of(m, i), style_of(m, i)
        lags = min(max_lag, min(len(r) for r in res) - 1)
        a.plot(np.arange(lags + 1), np.mean([acf(r, lags) for r in res], axis=0), color=clr, ls=ls, lw=1.1, label=m)
        e_all, r_all = np.concatenate(res), np.concatenate(rate)
        edges = np.linspace(r_all.min(), r_all.max(), 13)
        which = np.clip(np.digitize(r_all, edges) - 1, 0, 11)
        xs, ys = [], []
        for k in range(12):
            sel = which == k
            if sel.sum() >= 5:
                xs.append(float(r_all[sel].mean()))
                ys.append(float(e_all[sel].mean()))
        b.plot(xs, ys, color=clr, ls=ls, lw=1.3, marker="o", ms=2.5)
        c.hist(e_all, bins=50, histtype="step", color=clr, ls=ls, lw=1.1, density=True)
    bound = 2.576 / np.sqrt(max(n_total / max(len(frames), 1), 1))
    a.axhspan(-bound, bound, color="0.85", label="99 % whiteness bounds")
    a.set_xlabel("lag (samples)")
    a.set_ylabel("residual autocorrelation")
    a.set_title("(a) whiteness (mean over logs)")
    b.axhline(0, color="black", lw=0.5)
    b.set_xlabel(PRESSURE_RATE_LABEL)
    b.set_ylabel("mean residual (°)")
    b.set_title("(b) residual vs pressure rate (12 equal bins)")
    c.set_xlabel("residual (°)")
    c.set_ylabel("density (1/°)")
    c.set_title("(c) residual distribution")
    outside_legend(fig, ax=a)
    return finish(fig, synthetic)


def prediction_figure(logs, predictions, *, label: str = "prediction", synthetic: bool = False):
    """``bpmid predict``: measured vs predicted angle (loop, time series) and the error, one row per log."""
    from bpmid.plots.motion import motion_fit_figure

    return motion_fit_figure(logs, predictions, model="vbmm-fit", label=label, synthetic=synthetic,
                             title="Prediction: measured and predicted angle, error")
