"""Residual diagnostics of every compared model on the test logs."""
from __future__ import annotations

from typing import Sequence

import numpy as np
import pandas as pd

from bpmid.report.doc import fmt
from bpmid.report.sections import stale_ref

KEY = "residuals"
TITLE = "Residual diagnostics"


def residual_table(frames: Sequence[pd.DataFrame], models: Sequence[str]) -> list[list]:
    """Per model on the pooled test logs: lag-1 autocorrelation, share of lags 1..50 outside the 99 %
    whiteness bounds, correlation of the residual with the pressure rate, mean residual rising and falling."""
    from bpmid.plots.report import acf

    rows = []
    for m in models:
        col = f"pred_{m}_deg"
        res, rate, outside, lag1 = [], [], [], []
        for f in frames:
            if col not in f:
                continue
            e = f[col].to_numpy() - f["angle_deg"].to_numpy()
            p = f["pressure_pa_gauge"].to_numpy()
            rt = np.gradient(p, f["time_s"].to_numpy()) if len(p) > 1 else np.zeros_like(p)
            res.append(e)
            rate.append(rt)
            lags = min(50, e.size - 1)
            a = acf(e, lags)
            lag1.append(a[1] if lags >= 1 else np.nan)
            outside.append(np.mean(np.abs(a[1:]) > 2.576 / np.sqrt(e.size)) if lags >= 1 else np.nan)
        if not res:
            continue
        e, rt = np.concatenate(res), np.concatenate(rate)
        corr = float(np.corrcoef(e, rt)[0, 1]) if np.std(e) > 0 and np.std(rt) > 0 else float("nan")
        up, down = e[rt > 0], e[rt < 0]
        rows.append([m, fmt(float(np.mean(lag1))), fmt(100 * float(np.mean(outside))), fmt(corr),
                     fmt(float(up.mean()) if up.size else None), fmt(float(down.mean()) if down.size else None)])
    return rows


def build(doc, st, figs) -> None:
    doc.section(KEY, TITLE)
    c = st.compare
    if c is None or not c.predictions:
        doc.p("Not available (no compare/predictions/).", css="muted")
        return
    stale_ref(doc, st, ("compare",), "the predictions")
    frames = [f for v in c.predictions.values() for f in v]
    doc.p("Residual = prediction minus measurement on the test logs. A model that has captured the dynamics leaves "
          "a residual that is close to white and does not track the pressure rate or its sign.")
    doc.table(["model", "lag-1 autocorrelation", "lags 1..50 outside 99 % bounds (%)", "corr. with pressure rate",
               "mean residual, rising (°)", "mean residual, falling (°)"], residual_table(frames, list(c.summary["model"])))
    if "residuals" in figs:
        doc.fig(figs["residuals"], "(a) Residual autocorrelation with the 99 % whiteness bounds; (b) mean residual "
                "against the pressure rate (12 bins); (c) residual distributions, all test logs.")
