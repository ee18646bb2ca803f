"""``bpmid predict``: run a fitted VBMM on new pressure logs (library: :mod:`bpmid.predict`)."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from bpmid.plots.options import figure_path, figures_option, set_figure_format

from bpmid.cli._app import check_outputs, app, command, existing_files
from bpmid.cli._logopts import log_options


@command(app, "predict", epilog="Example (after bpmid fit motion ... --out VBMM.yaml): bpmid predict "
                                "datasets/motion/variable_amplitude/amp_2p0_r2.csv --params VBMM.yaml --out pred/   "
                                "(writes pred/amp_2p0_r2.csv with angle_pred_deg)  |  a rig file in kPa gauge without "
                                "a unit in its header: ... --pressure-unit kPa --pressure-reference gauge")
@log_options("motion")
def predict_command(
    logs: List[Path] = typer.Argument(..., metavar="LOG", help="Motion logs (time_s, pressure_bar|kpa|pa, optional angle_deg)."),
    params: Path = typer.Option(..., "--params", help="Fitted VBMM (bpmid fit motion output, bpmid.vbmm/1)."),
    out: Path = typer.Option(..., "--out", help="Output folder: one <log stem>.csv per log, plus predict.yaml."),
    config: Optional[Path] = typer.Option(None, "--config", help="Config file (sections io, model)."),
    logopts=None,
    figures: Optional[str] = figures_option(),
):
    """Predict the bending angle of new pressure logs with a fitted VBMM."""
    set_figure_format(figures)
    from bpmid.api import predict
    from bpmid.config import load_config

    cfg = logopts.apply(load_config(config))
    paths = existing_files(logs, "motion log")
    existing_files([params], "params")
    check_outputs([Path(out) / f"{Path(p).stem}.csv" for p in paths] + [Path(out) / "predict.yaml",
                                                                          figure_path(Path(out) / "predict.png")],
                  paths + [params, config])
    result = predict(paths, params, config=cfg)
    from bpmid.io import plausibility as plaus

    plaus.emit(result.warnings, strict=cfg.io.strict, what=str(out), key=plaus.strict_key(cfg.io))
    ambient = plaus.assumed_ambient_note([q.log for q in result.raw])
    if ambient:
        typer.echo("note: " + ambient, err=True)
    result.save(out, figure=True)
    for p in result.raw:
        if p.metrics is not None:
            m = p.metrics
            r2 = f"{m['r2']:.4f}" if m['r2'] == m['r2'] else "undefined (the measured angle does not vary)"
            typer.echo(f"{p.log.name}: RMSE {m['rmse_deg']:.4g} deg, MAPE {m['mape_pct']:.4g} %, R^2 {r2}")
        else:
            typer.echo(f"{p.log.name}: {p.log.n} samples predicted (no measured angle)")
    written = [p.name for p in result.written]
    typer.echo(f"wrote {len(written)} file{'s' if len(written) != 1 else ''} to {out}: {', '.join(written)}")
