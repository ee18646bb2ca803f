"""History modes of the VBMM on a long run (the paper's experiment 2).

The hereditary integral can be evaluated three ways (:class:`bpmid.models.vbmm.VBMM` ``history``):
``recursive`` (exact, O(1) per step), ``window`` (eq. 19, sliding window ``T_win``) and ``full`` (eq. 5 as
written, O(k) at step k). This stage runs the same VBMM forward, free-running, on growing prefixes of a
long-term log in each mode and records

- the cost per simulated step against log length (``history_modes.csv``: ``mode, duration_s, n_steps,
  seconds, us_per_step``; the full mode's cost grows linearly, the others stay flat), and
- on the whole log, each mode's RMSE against the measured angle and the difference window minus full
  (``history_modes.yaml``, schema ``bpmid.history_modes/1``).

Timings are wall-clock measurements (best of ``repeats`` runs after a warm-up); everything else is
deterministic.
"""
from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd

from bpmid import metrics as M
from bpmid.errors import InputError
from bpmid.io.motion_logs import MotionLog
from bpmid.models.vbmm import VBMM

MODES = ("recursive", "window", "full")
SCHEMA = "bpmid.history_modes/1"


@dataclasses.dataclass
class HistoryStudy:
    """Timings and accuracy of the three history modes on one long log.

    Attributes
    ----------
    timing : DataFrame ``mode, duration_s, n_steps, seconds, us_per_step`` (one row per mode and prefix)
    accuracy : mode -> ``{rmse_deg, mape_pct, r2}`` on the whole log against the measured angle
    window_vs_full : ``{rmse_diff_deg, max_abs_diff_deg, rmse_change_deg}``: prediction difference window - full
        and the change of RMSE
    predictions : mode -> (N,) predicted angle (deg) on the whole log
    log : the long-term log
    window_s : T_win (s)
    """

    timing: pd.DataFrame
    accuracy: dict[str, dict[str, float]]
    window_vs_full: dict[str, float]
    predictions: dict[str, np.ndarray]
    log: MotionLog
    window_s: float

    def cost_reduction_pct(self) -> float:
        """Per-step cost of window vs full on the longest prefix (%, positive = window cheaper)."""
        t = self.timing
        n = t["n_steps"].max()
        full = float(t[(t["mode"] == "full") & (t["n_steps"] == n)]["us_per_step"].iloc[0])
        win = float(t[(t["mode"] == "window") & (t["n_steps"] == n)]["us_per_step"].iloc[0])
        return 100.0 * (1.0 - win / full) if full > 0 else float("nan")


def prefix_lengths(log: MotionLog, durations_s: Sequence[float]) -> list[int]:
    """Sample counts of the prefixes lasting ``durations_s`` (clipped to the log; the whole log last)."""
    t = log.time_s - log.time_s[0]
    ns = sorted({int(np.searchsorted(t, d, side="right")) for d in durations_s if d > 0})
    ns = [n for n in ns if 10 <= n < log.n] + [log.n]
    return ns


def history_mode_study(model: VBMM, log: MotionLog, *, durations_s: Sequence[float] = (100, 200, 450, 900, 1800),
                       window_s: float | None = None, repeats: int = 3, full_repeats: int = 1) -> HistoryStudy:
    """Run ``model`` forward on ``log`` in the three history modes (see module docstring).

    Parameters
    ----------
    model : the VBMM whose constants are used (its ``history`` setting is overridden per mode)
    log : the long-term log (gauge Pa in, measured angle in deg)
    durations_s : prefix durations (s) for the cost-per-step curve; the whole log is always included
    window_s : T_win (s) for the window mode (default: the model's)
    repeats, full_repeats : timed runs per point (the fastest counts); the full mode is quadratic, so once
    """
    if log.angle_deg is None:
        raise InputError("the long-term log needs an angle_deg column", path=log.path)
    if log.n < 20:
        raise InputError(f"the long-term log is too short for a timing study ({log.n} samples)", path=log.path)
    window_s = float(model.window_s if window_s is None else window_s)
    rows, preds = [], {}
    for mode in MODES:
        m = model.replace(history=mode, window_s=window_s)
        m.forward(log.time_s[:10], log.pressure_pa[:10])  # compile / warm up outside the clock
        reps = full_repeats if mode == "full" else repeats
        for n in prefix_lengths(log, durations_s):
            best, beta = np.inf, None
            for _ in range(max(reps, 1)):
                t0 = time.perf_counter()
                beta = m.forward(log.time_s[:n], log.pressure_pa[:n], name=log.name, path=log.path)
                best = min(best, time.perf_counter() - t0)
            rows.append({"mode": mode, "duration_s": float(log.time_s[n - 1] - log.time_s[0]), "n_steps": n,
                         "seconds": best, "us_per_step": 1e6 * best / n})
            if n == log.n:
                preds[mode] = np.degrees(beta)
    timing = pd.DataFrame(rows, columns=["mode", "duration_s", "n_steps", "seconds", "us_per_step"])
    acc = {}
    for mode, y_hat in preds.items():
        acc[mode] = {"rmse_deg": M.rmse(log.angle_deg, y_hat), "mape_pct": M.mape_pct(log.angle_deg, y_hat),
                     "r2": M.r2(log.angle_deg, y_hat)}
    diff = preds["window"] - preds["full"]
    wvf = {"rmse_diff_deg": float(np.sqrt(np.mean(diff ** 2))), "max_abs_diff_deg": float(np.max(np.abs(diff))),
           "rmse_change_deg": acc["window"]["rmse_deg"] - acc["full"]["rmse_deg"]}
    return HistoryStudy(timing, acc, wvf, preds, log, window_s)


def study_yaml_body(study: HistoryStudy, params_source: str | None = None) -> dict:
    t = study.timing
    longest = t[t["n_steps"] == t["n_steps"].max()]
    return {
        "log": str(study.log.path or study.log.name),
        "samples": int(study.log.n),
        "duration_s": float(study.log.duration_s),
        "window_s": study.window_s,
        "params": params_source,
        "accuracy": {m: {k: float(v) for k, v in a.items()} for m, a in study.accuracy.items()},
        "window_vs_full": dict(study.window_vs_full),
        "us_per_step_longest": {r.mode: float(r.us_per_step) for r in longest.itertuples()},
        "window_cost_reduction_pct": study.cost_reduction_pct(),
        "note": "us_per_step and seconds are wall-clock measurements on this machine; the rest is deterministic",
    }


def write_history_study(study: HistoryStudy, out_dir: str | Path, prov: dict, *, params_source: str | None = None,
                        synthetic: "bool | str | None" = True) -> list[Path]:
    """``history_modes.csv``, ``history_modes.yaml`` and ``history_modes.png`` into ``out_dir``."""
    from bpmid.io.atomic import write_text
    from bpmid.io.results import write_result
    from bpmid.plots.common import save_figure
    from bpmid.plots.report import history_figure

    out_dir = Path(out_dir)
    csv = study.timing.to_csv(index=False, lineterminator="\n", float_format="%.6g")
    paths = [write_text(out_dir / "history_modes.csv", csv),
             write_result(out_dir / "history_modes.yaml", SCHEMA, study_yaml_body(study, params_source), prov),
             save_figure(history_figure(study, synthetic=synthetic), out_dir / "history_modes.png")]
    return paths
