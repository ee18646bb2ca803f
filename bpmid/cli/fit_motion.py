"""``bpmid fit motion``: fit the VBMM to pressure-angle logs (library: :func:`bpmid.fit_motion`, :mod:`bpmid.models.vbmm.fit`)."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from bpmid.errors import InputError
from bpmid.plots.options import FIGURE_SUFFIXES, figure_path, figures_option, set_figure_format

from bpmid.cli._app import check_outputs, command, existing_files, fit_app
from bpmid.cli._logopts import log_options


@command(fit_app, "motion", epilog="Example (shipped synthetic logs): bpmid fit relax datasets/relaxation/*.csv "
                                   "--out relax_fit.yaml  then  bpmid fit motion datasets/motion/fitting_set/*.csv "
                                   "--init relax_fit.yaml --out VBMM.yaml   (writes VBMM.yaml and the figure VBMM.png)  |  "
                                   "a rig file without units or reference: ... --pressure-unit kPa --pressure-reference "
                                   "gauge --columns time=Zeit,pressure=Druck,angle=Winkel --time-unit ms")
@log_options("motion")
def fit_motion_command(
    logs: List[Path] = typer.Argument(..., metavar="LOG", help="Motion logs (time_s, pressure_bar|kpa|pa, angle_deg), fitted at once."),
    out: Path = typer.Option(..., "--out", help="Output parameter file (schema bpmid.vbmm/1)."),
    init: Optional[Path] = typer.Option(None, "--init", help="Relaxation fit (bpmid fit relax) to start from; "
                                                             "default: motion.relax_fit or the paper's constants."),
    config: Optional[Path] = typer.Option(None, "--config", help="Config file (sections io, model, motion)."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Figure path (default: --out with .png)."),
    no_plot: bool = typer.Option(False, "--no-plot", "--no-figure", help="Write no figure (--no-figure, as fit relax and control say it, is the same)."),
    logopts=None,
    figures: Optional[str] = figures_option(),
):
    """Fit the VBMM's moduli and time constants on motion logs (angle error of the forward model)."""
    set_figure_format(figures)
    from bpmid.api import fit_motion
    from bpmid.config import load_config

    cfg = logopts.apply(load_config(config))
    paths = existing_files(logs, "motion log")
    if init is not None:
        existing_files([init], "relaxation fit")
    figure = None if no_plot else (plot or figure_path(out.with_suffix(".png")))
    if plot is not None and not no_plot and figures and plot.suffix.lower() != "." + figures.strip().lower():
        typer.echo(f"note: --plot {plot} is written in the format its suffix names ({plot.suffix or 'none'}); "
                   f"--figures {figures} sets the format of the figures whose names bpmid chooses", err=True)
    check_outputs([out], paths + [init, config], suffix=".yaml")
    if figure is not None:
        check_outputs([figure], paths + [init, config], key="--plot")
        if figure.suffix and figure.suffix.lower() not in FIGURE_SUFFIXES:   # no suffix: written as PNG   # matplotlib's own error came after the fit, as a traceback
            raise InputError(f"a figure is written as {', '.join(s.lstrip('.') for s in FIGURE_SUFFIXES)}; "
                             f"{figure.name!r} names none of them", path=figure, key="--plot")
    result = fit_motion(paths, init=init, config=cfg)
    from bpmid.models.vbmm.model import paper_geometry_note

    geometry_note = paper_geometry_note(cfg.section("model").geometry)
    if geometry_note:   # after the inputs were judged: not beside an error
        typer.echo("note: " + geometry_note, err=True)
    for extra in result.body.get("notes") or []:   # the fit's other notes (the sampling step its constants hold for)
        if extra != geometry_note:
            typer.echo("note: " + extra, err=True)
    from bpmid.io import plausibility as plaus

    plaus.emit(result.warnings, strict=cfg.io.strict, what=str(out), key=plaus.strict_key(cfg.io))
    ambient = plaus.assumed_ambient_note(result.raw.logs)
    if ambient:
        typer.echo("note: " + ambient, err=True)
    from bpmid.io.motion_logs import synthetic_note

    result.save(out, figure=figure, synthetic=synthetic_note(result.raw.logs))   # the stamp's words, or None
    fit = result.raw
    m = fit.metrics
    typer.echo(f"VBMM fit on {len(fit.logs)} log{'s' if len(fit.logs) != 1 else ''}: RMSE {m['rmse_deg']:.4g} deg, MAPE {m['mape_pct']:.4g} %, "
               f"R^2 {m['r2']:.4f}, fit {m['fit_pct']:.2f} % ({fit.seconds:.2f} s)")
    for p in fit.fit.params:
        se = "" if p.stderr is None else f" +- {p.stderr:.3g}"
        cond = [h for h, others in fit.fit.conditional.items() if p.name in others and p.name in fit.fit.free_names]
        typer.echo(f"  {p.name:7s} {p.value:.6g}{se} {p.unit}   {fit.verdicts()[p.name]}"
                   + (f" (standard error conditional on the held {', '.join(cond)})" if cond else ""))
    typer.echo("wrote " + ", ".join(str(w) for w in [out] + ([figure] if figure is not None else [])))
