"""Run a fitted VBMM on new pressure logs (``bpmid predict``).

Output per log (README, "Fit the VBMM on motion logs, then predict another log"): ``<log stem>.csv`` with a ``# pressure_reference:`` line, ``time_s``, the pressure column exactly as given
(``pressure_bar``, ``pressure_kpa`` or ``pressure_pa``, same reference as the input), ``angle_pred_deg``, and
``angle_deg`` when the log had one. When angles are present the metrics are returned too.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd

from bpmid.errors import InputError
from bpmid.io.atomic import staged_dir
from bpmid.io.ambient import atmosphere_line
from bpmid.io.motion_logs import MotionLog, is_synthetic, pressure_column_name, synthetic_line
from bpmid.io.tables import UNITS
from bpmid.models.vbmm import VBMM
from bpmid.models.vbmm.model import PressureAboveRange
from bpmid.models.vbmm.fit import check_pressure_range, log_metrics
from bpmid.units import PA_PER_BAR


@dataclasses.dataclass
class Prediction:
    """One log's prediction.

    Attributes
    ----------
    log : the input log
    angle_pred_deg : (N,) predicted bending angle (deg)
    metrics : rmse_deg, mape_pct, r2, fit_pct, max_abs_err_deg when the log has angles, else None
    """

    log: MotionLog
    angle_pred_deg: np.ndarray
    metrics: dict | None

    def ambient_series_pa(self) -> np.ndarray | None:
        """The ambient pressure (Pa) at each sample of an absolute log read with an ambient column that varies
        (absolute as given minus the gauge pressure the model saw); None when one value served every sample."""
        lg = self.log
        if lg.pressure_reference != "absolute" or lg.pressure_as_given is None:
            return None
        amb = lg.pressure_as_given * UNITS["pressure"][lg.pressure_unit] - lg.pressure_pa
        return amb if float(np.ptp(amb)) > 1.0 else None   # > 1 Pa: more than the rounding of the columns

    def frame(self, decimals: int = 6) -> pd.DataFrame:
        lg = self.log
        given = lg.pressure_as_given if lg.pressure_as_given is not None else lg.pressure_pa
        unit = lg.pressure_unit if lg.pressure_as_given is not None else "pa"
        # CLI.md fixes `pressure_bar` (in the log's own reference, absolute or gauge); a log in another unit
        # also keeps its pressure column exactly as given
        cols = {"time_s": lg.time_s, "pressure_bar": np.round(given * UNITS["pressure"][unit] / PA_PER_BAR, 9)}
        if unit != "bar":
            cols[pressure_column_name(unit)] = np.round(given, 9)
        amb = self.ambient_series_pa()
        if amb is not None:   # an ambient column the log was read with: kept, so the file reads back the same
            cols["ambient_pressure_kpa"] = np.round(amb / 1e3, 9)
        cols["angle_pred_deg"] = np.round(self.angle_pred_deg, decimals)
        df = pd.DataFrame(cols)
        if lg.angle_deg is not None:
            df["angle_deg"] = lg.angle_deg
        return df


def predict(logs: Sequence[MotionLog], model) -> list[Prediction]:
    """Forward model on each log (free-running, from the pressure only). ``model``: a VBMM, or an
    :class:`~bpmid.effects.base.AugmentedVBMM` (a fit file with an ``effects`` list: the effects act too).

    Raises InputError naming the log when a pressure is below vacuum or beyond the model's range.
    """
    from bpmid.effects.base import AugmentedVBMM

    out = []
    for lg in logs:
        check_pressure_range(lg)
        try:
            if isinstance(model, AugmentedVBMM):
                pred = model.simulate_deg(lg.time_s, lg.pressure_pa, name=lg.name, path=lg.path)
            else:
                pred = model.forward_deg(lg.time_s, lg.pressure_pa, name=lg.name, path=lg.path)
        except PressureAboveRange as exc:
            raise _above_range(lg, exc) from None
        met = None if lg.angle_deg is None else log_metrics(lg.angle_deg, pred)
        out.append(Prediction(lg, pred, met))
    return out


def _above_range(lg: MotionLog, exc: PressureAboveRange) -> InputError:
    """The model's refusal of a pressure beyond its range, with the log's file line, the value as logged and, when
    the log's pressure peak looks like a unit slip, the same hint the reading checks give (what it would be in, and
    the form that states it: :func:`bpmid.io.plausibility.pressure_slip`)."""
    from bpmid.io.plausibility import _column, pressure_slip

    k = exc.sample
    msg = exc.message
    if lg.pressure_as_given is not None and 0 <= k < lg.n:
        msg += f"; the log gives {lg.pressure_as_given[k]:g} {lg.pressure_unit} ({lg.pressure_reference}) there"
    slip = pressure_slip(lg)
    msg += f". In the log, {slip}" if slip is not None else (
        ". Check the pressure column's unit and reference, and that the parameter file (--params) is for this muscle")
    return InputError(msg, path=lg.path if lg.path is not None else exc.path, line=lg.line_of(k),
                      key=_column(lg, "pressure").get("column"))


def predict_yaml_body(preds: Sequence[Prediction], *, params: str | Path | None = None, model=None) -> dict:
    """The body of ``predict.yaml`` (schema ``bpmid.predict/1``): the parameter file, model settings, per-log
    metrics."""
    from bpmid.effects.base import AugmentedVBMM

    body = {"params": None if params is None else str(params)}
    if model is not None:
        base = model.base if isinstance(model, AugmentedVBMM) else model
        body["model"] = {"closure": base.closure, "history": base.history, "window_s": base.window_s,
                         "geometry": base.geometry.to_yaml()}   # SI (m, rad): the muscle the prediction is for
        if isinstance(model, AugmentedVBMM):
            # the fit file's effects list acted on every prediction (in this order)
            body["model"]["effects"] = [e.id for e in model.effects]
    body["logs"] = {p.log.name: {"samples": p.log.n, "file": f"{p.log.name}.csv",
                                 "metrics": None if p.metrics is None else
                                 {k: float(v) for k, v in p.metrics.items()}} for p in preds}
    # the input logs' own label (each output file keeps its log's '# synthetic:' line)
    body["synthetic"] = is_synthetic([p.log for p in preds])
    body["synthetic_logs"] = sorted(p.log.name for p in preds if is_synthetic([p.log]))
    return body


#: the line every prediction file bpmid writes carries (how a rerun knows the file is its own to replace)
PREDICTION_MARK = "# angle_pred_deg: bpmid predict output"


def _refuse_foreign_files(out_dir: Path, names: Sequence[str]) -> None:
    """InputError when a file bpmid is about to write into ``out_dir`` exists and is not one bpmid wrote (a
    prediction without its mark, a predict.yaml of another schema): a user's own ``m.csv`` was replaced, silently."""
    from bpmid.io.atomic import file_head, refuse_foreign_files

    def ours(f: Path) -> tuple[bool, str]:
        head = file_head(f)
        return ("schema: bpmid.predict/" in head) if f.name == "predict.yaml" else (PREDICTION_MARK in head), \
            "no bpmid predict mark"

    refuse_foreign_files(out_dir, names, ours)


def write_predictions(out_dir: str | Path, preds: Sequence[Prediction], *, prov: dict | None = None,
                      params: str | Path | None = None, model: VBMM | None = None, figure: bool = False,
                      synthetic: "bool | str | None" = False) -> list[Path]:
    """Write ``DIR/<log stem>.csv`` for every prediction, and ``DIR/predict.yaml`` (schema
    ``bpmid.predict/1``: model settings, per-log metrics, provenance) when ``prov`` is given, and with ``figure``
    ``DIR/predict.png`` (measured and predicted angle, error; format of ``--figures``); all or nothing."""
    from bpmid.io.results import dump_yaml

    out_dir = Path(out_dir)
    inputs = {Path(p.log.path).resolve() for p in preds if p.log.path is not None}   # said as inputs, later
    _refuse_foreign_files(out_dir, [f"{p.log.name}.csv" for p in preds if (out_dir / f"{p.log.name}.csv").resolve()
                                    not in inputs] + (["predict.yaml"] if prov is not None else []))
    names = []
    with staged_dir(out_dir) as tmp:
        for p in preds:
            name = f"{p.log.name}.csv"
            # the reference line and unit-suffixed columns let bpmid (and anyone) read the file back unambiguously
            # one ambient value as a line; an ambient that varied is the frame's column instead (never both)
            head = f"# pressure_reference: {p.log.pressure_reference}\n" \
                + (atmosphere_line(p.log) if p.ambient_series_pa() is None else "") \
                + synthetic_line(p.log) + PREDICTION_MARK + "\n"
            (tmp / name).write_text(head + p.frame().to_csv(index=False, lineterminator="\n"), encoding="utf-8")
            names.append(out_dir / name)
        if prov is not None:
            body = {"schema": "bpmid.predict/1", **predict_yaml_body(preds, params=params, model=model)}
            if "warnings" in prov:
                body["warnings"] = list(prov["warnings"])
            body["provenance"] = prov
            (tmp / "predict.yaml").write_text(dump_yaml(body), encoding="utf-8")
            names.append(out_dir / "predict.yaml")
        if figure and preds:
            from bpmid.plots.common import save_figure
            from bpmid.plots.report import prediction_figure

            fig = prediction_figure([p.log for p in preds], {p.log.name: p.angle_pred_deg for p in preds},
                                    synthetic=synthetic)
            names.append(out_dir / save_figure(fig, tmp / "predict.png").name)
    return names

__all__ = ["Prediction", "predict", "predict_yaml_body", "write_predictions"]

# ``bpmid.predict(...)`` is the public workflow (bpmid.api.predict); this module stays importable as before
from bpmid._callable import make_callable as _make_callable  # noqa: E402

_make_callable(__name__, "bpmid.api:predict")
