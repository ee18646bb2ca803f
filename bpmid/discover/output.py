"""Writing a discovery result: ``discovery.yaml`` (schema ``bpmid.discovery/1``), ``verdict.txt``, the three
figures and ``model.yaml`` (the final model as a ``bpmid.vbmm/1`` fit with its ``effects`` list, which
``bpmid predict`` and ``bpmid export --to c`` run), all or nothing (one staged folder). Used by ``bpmid discover``
and by ``bpmid run``."""
from __future__ import annotations

import re
import textwrap
from pathlib import Path

import numpy as np

from bpmid.io.atomic import staged_dir, write_text
from bpmid.io.motion_logs import is_synthetic, synthetic_note
from bpmid.io.results import write_result
from bpmid.plots import discover as P
from bpmid.plots.common import label_synthetic, save_figure

SCHEMA = "bpmid.discovery/1"
#: the final model's file: a ``bpmid.vbmm/1`` fit (CLI.md) with the named effects
MODEL_FILE = "model.yaml"
MODEL_SCHEMA = "bpmid.vbmm/1"

#: file name -> figure function of :mod:`bpmid.plots.discover`
FIGURES = {"residual_before_after.png": P.residual_figure, "screening_ranking.png": P.ranking_figure,
           "heldout_error.png": P.heldout_figure}


#: the width verdict.txt is wrapped to (a statement of the gate runs to some 3000 characters)
VERDICT_WIDTH = 110


def _fill(text: str, first: str = "", rest: str = "  ") -> str:
    return textwrap.fill(text, VERDICT_WIDTH, initial_indent=first, subsequent_indent=rest, break_long_words=False,
                         break_on_hyphens=False)


def _gate_parts(statement: str) -> list[tuple[int, str]]:
    """The gate's statement cut before each numbered rule's first appearance ("(1) its refit ...") and before each
    sentence: (depth, text) pieces, their words in order and unchanged."""
    cuts = {m.start() for m in re.finditer(r"(?<=\.) (?=[A-Z])", statement)}
    seen = set()
    for m in re.finditer(r"(?<= )\((\d)\) (?=[a-z])", statement):
        if m.group(1) not in seen:
            seen.add(m.group(1))
            cuts.add(m.start() - 1)
    out, start = [], 0
    for c in sorted(cuts):
        out.append(statement[start:c].strip())
        start = c
    out.append(statement[start:].strip())
    return [(1 if re.match(r"\(\d\) ", x) else 0, x) for x in out if x]


def readable(verdict: str) -> str:
    """The verdict as ``verdict.txt`` gives it: each statement wrapped to :data:`VERDICT_WIDTH` columns, its
    continuation lines indented, words and numbers never split, and a blank line between statements. The gate's
    statement (some 3000 characters) starts a line at each numbered rule and each sentence: the same words as in
    ``discovery.yaml``."""
    lines = [ln for ln in verdict.split("\n") if ln.strip()]
    out = []
    for ln in lines:
        if ln.startswith("gate: "):
            out.append("\n".join(_fill(x, "  " * (depth + bool(k)), "  " * (depth + bool(k)) + "    ")
                                 for k, (depth, x) in enumerate(_gate_parts(ln))))
        else:
            out.append(_fill(ln))
    return "\n\n".join(out)


def write_discovery(out_dir: str | Path, result, prov: dict, *, base_from: str) -> list[str]:
    """Write ``result`` (a :class:`~bpmid.discover.workflow.DiscoveryResult`) into ``out_dir``.

    Figures made from synthetic logs say so in their corner. Returns the names of the files written.
    """
    body = result.to_yaml()
    body["base_from"] = base_from
    logs = list(result.fit_logs) + list(result.holdout_logs)
    # as predict.yaml and compare.yaml say it: every log synthetic, and which are
    body["synthetic"] = is_synthetic(logs)
    body["synthetic_logs"] = sorted({lg.name for lg in logs if is_synthetic([lg])})
    note = synthetic_note(logs)   # the figures' stamp: the twin's, another generator's, or a mix
    with staged_dir(out_dir) as tmp:
        write_result(tmp / "discovery.yaml", SCHEMA, body, prov)
        write_result(tmp / MODEL_FILE, MODEL_SCHEMA, model_body(result), prov)
        write_text(tmp / "verdict.txt", readable(result.verdict) + "\n")
        for name, make in FIGURES.items():
            fig = make(result)
            if note:
                label_synthetic(fig, note)
            save_figure(fig, tmp / name)
    return ["discovery.yaml", "verdict.txt", *FIGURES, MODEL_FILE]


#: what a material constant discovery does not refit carries in ``model.yaml``
_HELD_NOTE = "held at the starting model's value (discovery refits K_inf and each branch's K and tau only)"


def _material_params(state):
    """The final VBMM's material constants in the naming of :func:`~bpmid.models.vbmm.model.material_params`,
    with the standard errors and verdicts of those discovery refitted (``vbmm.*``) and the others marked held."""
    from bpmid.models.vbmm.model import material_params

    mat = state.material()
    out = material_params(mat)
    for p in out:
        src = f"vbmm.{p.name}"
        if mat.split and p.name.startswith("tauK_"):
            src = f"vbmm.tau_{p.name.split('_', 1)[1]}"
        if src in state.params:   # a split material's tauG_j has no vbmm.* counterpart: held
            q = state.params[src]
            out = out.replace(p.name, value=float(q.value), stderr=q.stderr, identifiable=q.identifiable,
                              note=q.note, fixed=q.fixed)
        else:
            out = out.replace(p.name, fixed=True, stderr=None, identifiable=None, note=_HELD_NOTE)
    return out


def model_body(result) -> dict:
    """``model.yaml``: the model discovery ends with (the refitted VBMM and every effect named, with their
    constants) as a ``bpmid.vbmm/1`` fit, so ``bpmid predict``, ``bpmid export --to c`` and the library run it as
    discovery scored it. Metrics (deg, %, 1) are those of this model as a file runs it: on the fitting logs, and on
    the held-out logs without the per-log nuisance factors the held-out scoring allows."""
    from bpmid.discover.model import simulate
    from bpmid.effects.fitfile import effects_to_yaml
    from bpmid.models.vbmm.fit import MAPE_FLOOR_DEG, log_metrics
    from bpmid.models.vbmm.model import vbmm_yaml_body

    state = result.final_state
    vbmm = state.fitted_vbmm()
    body = vbmm_yaml_body(vbmm, params=_material_params(state))
    body["model"]["time_constants"] = "split" if vbmm.material.split else "shared"

    def pooled(logs):
        if not logs:
            return None
        y = np.concatenate([lg.angle_deg for lg in logs])
        y_hat = np.concatenate(simulate(state, logs))
        ok = np.isfinite(y_hat) & np.isfinite(y)
        m = {k: float(v) for k, v in log_metrics(y[ok], y_hat[ok]).items()}
        m["n_samples"] = int(ok.sum())
        return m

    fit_m = pooled(list(result.fit_logs))
    ho_m = pooled(list(result.holdout_logs))
    body["effects"] = effects_to_yaml(state.effects, state.params)
    body["metrics"] = {**(fit_m or {}), "mape_floor_deg": MAPE_FLOOR_DEG,
                       "scope": "the fitting logs, the model as this file runs it"}
    if ho_m is not None:
        body["metrics"]["heldout"] = {**ho_m, "scope": "the held-out logs, without per-log nuisance factors"}
    body["fit"] = {"by": "bpmid discover",
                   "named_effects": list(state.ids),
                   "objective": "angle error (deg) of the forward model with the named effects, fitting logs at once",
                   "logs": [{"name": lg.name, "samples": lg.n, "duration_s": round(lg.duration_s, 6),
                             "step_s": round(lg.dt_s, 9) if lg.n > 1 else None,   # median sampling step
                             # the gauge pressures fitted on, as a motion fit records them (predict's range check)
                             "pressure_gauge_pa": [float(np.min(lg.pressure_pa)), float(np.max(lg.pressure_pa))]}
                            for lg in result.fit_logs],
                   "heldout_logs": [lg.name for lg in result.holdout_logs],
                   "see": "discovery.yaml (the evidence) and verdict.txt"}
    return body
