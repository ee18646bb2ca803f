"""Figures of the study report: history-mode timing, relaxation-modulus curves, error bands and residual
diagnostics. They take results (tables, dicts, arrays) and return figures; they never write files."""
from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np
import pandas as pd

from bpmid.plots.common import MODEL_COLORS, new_figure
from bpmid.plots.compare import finish as _finish

MODE_COLORS = {"recursive": "#1f77b4", "window": "#2ca02c", "full": "#d62728"}


def color_of(name: str, i: int = 0) -> str:
    import matplotlib.pyplot as plt

    return MODEL_COLORS.get(name, plt.rcParams["axes.prop_cycle"].by_key()["color"][i % 10])


def history_figure(study, *, synthetic: bool = True):
    """Left: cost per simulated step against log length for each history mode. Right: on the whole long
    log, the prediction error of each mode and the difference window minus full."""
    fig, (a, b) = new_figure(1, 2, width=10.0, height=3.8)
    t = study.timing
    for mode, g in t.groupby("mode", sort=False):
        a.plot(g["n_steps"], g["us_per_step"], "o-", color=MODE_COLORS.get(mode), label=mode)
    a.set_xlabel("log length (steps)")
    a.set_ylabel("cost per simulated step (us)")
    a.set_yscale("log")
    a.set_title(f"Cost per step vs log length (T_win = {study.window_s:g} s)", fontsize=9)
    a.legend(fontsize=8)
    lg = study.log
    for mode in ("full", "window"):
        if mode in study.predictions:
            b.plot(lg.time_s, study.predictions[mode] - lg.angle_deg, lw=0.6, color=MODE_COLORS[mode],
                   label=f"{mode}: error vs measured (RMSE {study.accuracy[mode]['rmse_deg']:.3f} deg)")
    if "window" in study.predictions and "full" in study.predictions:
        d = study.predictions["window"] - study.predictions["full"]
        b.plot(lg.time_s, d, lw=1.0, color="black",
               label=f"window - full (max |diff| {np.max(np.abs(d)):.2e} deg)")
    b.set_xlabel("time (s)")
    b.set_ylabel("angle (deg)")
    b.set_title(f"Long-term run {lg.name}: error and window - full", fontsize=9)
    b.legend(fontsize=7, loc="upper right")
    return _finish(fig, synthetic)


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
    fig, axes = new_figure(1, 2, width=10.0, height=3.6)
    a, b = axes
    e = curve("prony", "E", "E_inf", t)
    if e is not None:
        a.semilogx(t, e / 1e6, color="#1f77b4", lw=2, label="E(t), fitted here")
    if paper:
        ep = paper["E_inf"] + paper["E_1"] * np.exp(-t / paper["tau_1"])
        a.semilogx(t, ep / 1e6, "--", color="0.35", lw=1.3, label="E(t), paper's published fit (quoted, paper's data)")
    a.set_xlabel("time (s)")
    a.set_ylabel("relaxation modulus (MPa)")
    a.set_title("Tensile relaxation modulus", fontsize=9)
    a.legend(fontsize=7)
    g = curve("shear", "G", "G_inf", t)
    k = curve("bulk", "K", "K_inf", t)
    if g is not None:
        b.semilogx(t, g / 1e6, color="#d62728", lw=2, label="G(t) (MPa)")
    b.set_ylabel("shear modulus G (MPa)")
    b.set_xlabel("time (s)")
    if k is not None:
        b2 = b.twinx()
        b2.semilogx(t, k / 1e6, color="#9467bd", lw=2, ls="-.", label="K(t) (MPa)")
        b2.set_ylabel("bulk modulus K (MPa)")
        h1, l1 = b.get_legend_handles_labels()
        h2, l2 = b2.get_legend_handles_labels()
        b.legend(h1 + h2, l1 + l2, fontsize=7)
    b.set_title(f"Shear and bulk moduli (nu = {relax.get('poisson_ratio', float('nan')):.5g})", fontsize=9)
    return _finish(fig, synthetic)


def error_bands(sets: Mapping[str, Sequence[pd.DataFrame]], models: Sequence[str], *, synthetic: bool = True):
    """Per test set (one panel each): every model's mean prediction error over the set's logs against time,
    with a band from the smallest to the largest error across the logs (aligned by sample, cut to the
    shortest log). ``sets``: set name -> prediction frames (``time_s``, ``angle_deg``, ``pred_<model>_deg``)."""
    names = list(sets)
    fig, axes = new_figure(len(names), 1, width=9.0, height=2.4 * len(names) + 0.6, squeeze=False)
    for ax, s in zip(axes.ravel(), names):
        frames = sets[s]
        n = min(len(f) for f in frames)
        t = frames[0]["time_s"].to_numpy()[:n] - frames[0]["time_s"].iloc[0]
        for i, m in enumerate(models):
            col = f"pred_{m}_deg"
            if col not in frames[0]:
                continue
            err = np.stack([f[col].to_numpy()[:n] - f["angle_deg"].to_numpy()[:n] for f in frames])
            c = color_of(m, i)
            ax.fill_between(t, err.min(axis=0), err.max(axis=0), color=c, alpha=0.18, lw=0)
            ax.plot(t, err.mean(axis=0), color=c, lw=1.0, label=m)
        ax.axhline(0, color="black", lw=0.5)
        ax.set_title(f"{s}: mean error over {len(frames)} log(s), band = min..max", fontsize=9)
        ax.set_ylabel("error (deg)")
    axes.ravel()[-1].set_xlabel("time from start of log (s)")
    axes.ravel()[0].legend(fontsize=7, ncol=3)
    return _finish(fig, synthetic)


def acf(r: np.ndarray, max_lag: int) -> np.ndarray:
    """Normalised autocorrelation r(tau) = R(tau)/R(0), tau = 0..max_lag."""
    r = np.asarray(r, float) - np.mean(r)
    den = float(np.dot(r, r)) or 1.0
    return np.array([np.dot(r[k:], r[:r.size - k]) / den for k in range(max_lag + 1)])


def residual_diagnostics(frames: Sequence[pd.DataFrame], models: Sequence[str], *, max_lag: int = 100,
                         synthetic: bool = True):
    """Residual diagnostics of every model on the pooled test logs: autocorrelation with the +-2.576/sqrt(N)
    whiteness bounds, residual against the pressure rate, and residual histograms."""
    fig, (a, b, c) = new_figure(1, 3, width=12.0, height=3.6)
    n_total = sum(len(f) for f in frames)
    for i, m in enumerate(models):
        col = f"pred_{m}_deg"
        res, rate = [], []
        for f in frames:
            if col not in f:
                continue
            e = f[col].to_numpy() - f["angle_deg"].to_numpy()
            res.append(e)
            p = f["pressure_pa_gauge"].to_numpy() / 1e5
            rate.append(np.gradient(p, f["time_s"].to_numpy()))
        if not res:
            continue
        clr = color_of(m, i)
        lags = min(max_lag, min(len(r) for r in res) - 1)
        a.plot(np.arange(lags + 1), np.mean([acf(r, lags) for r in res], axis=0), color=clr, lw=1.0, label=m)
        e_all, r_all = np.concatenate(res), np.concatenate(rate)
        b.scatter(r_all, e_all, s=2, color=clr, alpha=0.25, rasterized=True)
        order = np.argsort(r_all)
        bins = np.array_split(order, 12)
        b.plot([r_all[k].mean() for k in bins], [e_all[k].mean() for k in bins], color=clr, lw=1.5, label=m)
        c.hist(e_all, bins=50, histtype="step", color=clr, lw=1.2, label=m, density=True)
    bound = 2.576 / np.sqrt(max(n_total / max(len(frames), 1), 1))
    a.axhspan(-bound, bound, color="0.85", label="whiteness bounds (99 %)")
    a.set_xlabel("lag (samples)")
    a.set_ylabel("residual autocorrelation")
    a.set_title("Whiteness (mean over test logs)", fontsize=9)
    a.legend(fontsize=7)
    b.axhline(0, color="black", lw=0.5)
    b.set_xlabel("pressure rate (bar/s)")
    b.set_ylabel("residual (deg)")
    b.set_title("Residual vs pressure rate (line: binned mean)", fontsize=9)
    c.set_xlabel("residual (deg)")
    c.set_ylabel("density")
    c.set_title("Residual distribution", fontsize=9)
    return _finish(fig, synthetic)
