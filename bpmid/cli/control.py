"""``bpmid control``: closed-loop tracking with PI, VBMM-PI and MS-PI (the science is in :mod:`bpmid.control`)."""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import List, Optional

import typer

from bpmid.plots.options import figure_path, figures_option, set_figure_format

from bpmid.cli._app import app, command
from bpmid.cli._logopts import log_options

EPILOG = ("Example (the paper's experiment 3 on a plant 5 % stiffer with 10 % faster relaxation):  bpmid control "
          "--params VBMM.yaml --reference all --controller pi,vbmm-pi,ms-pi --plant-modulus-scale 1.05 "
          "--plant-tau-scale 0.9 --out control_out  |  gains: --kp bar/deg, --ki bar/(deg s)")


@command(app, "control", epilog=EPILOG)
@log_options("reference")
def control(
    params: Path = typer.Option(..., "--params", help="The controller's model (bpmid.vbmm/1, e.g. from fit motion)."),
    reference: str = typer.Option(..., "--reference", help="Comma list of reference CSVs (time_s, angle_deg) or "
                                  "names of shipped references (datasets/control/; built in: steps, sawtooth, "
                                  "sines); 'all' = every shipped one."),
    out: Path = typer.Option(..., "--out", help="Output folder: summary.csv, control.yaml, traces/, fig18.png."),
    controller: str = typer.Option("pi,vbmm-pi,ms-pi", "--controller", help="Comma list of pi, vbmm-pi, ms-pi."),
    plant_params: Optional[Path] = typer.Option(None, "--plant-params", help="The plant's VBMM (default: the "
                                                "controller's constants)."),
    plant_effect: Optional[List[str]] = typer.Option(None, "--plant-effect", help="Catalogue effect of the plant, "
                                                     "ID[:key=value,...]; repeatable (ids, parameters and their "
                                                     "units: docs/model.md section 9)."),
    plant_modulus_scale: Optional[float] = typer.Option(None, "--plant-modulus-scale", help="Plant moduli times "
                                                        "this (default 1)."),
    plant_tau_scale: Optional[float] = typer.Option(None, "--plant-tau-scale", help="Plant time constants times "
                                                    "this (default 1)."),
    kp: Optional[float] = typer.Option(None, "--kp", help="Proportional gain, bar per deg of error (default 0.04)."),
    ki: Optional[float] = typer.Option(None, "--ki", help="Integral gain, bar per deg of error per second "
                                       "(default 0.01; 0.1 reads eq. 20's sum per step literally)."),
    pressure_dynamics: Optional[bool] = typer.Option(None, "--pressure-dynamics/--no-pressure-dynamics",
                                                     help="Valve and muscle-volume dynamics in the plant "
                                                     "(seed 003 eqs. 12-17; constants in config control.pneumatics)."),
    seed: Optional[int] = typer.Option(None, "--seed", help="Seed of the sensor noise (default 0)."),
    config: Optional[Path] = typer.Option(None, "--config", help="Config YAML (sections control, model)."),
    no_figure: bool = typer.Option(False, "--no-figure", help="Do not write fig18.png."),
    logopts=None,
    figures: Optional[str] = figures_option(),
):
    """Simulate closed-loop tracking at the control rate and compare the controllers (the paper's Fig. 18)."""
    set_figure_format(figures)
    from bpmid.api import control
    from bpmid.config import load_config
    from bpmid.errors import InputError

    cfg_all = logopts.apply(load_config(config))   # --columns/--time-unit/--angle-unit/--sheet: reference files
    cfg = cfg_all.section("control")
    changes = {k: v for k, v in {"kp_bar_per_deg": kp, "ki_bar_per_deg_s": ki, "seed": seed,
                                 "pressure_dynamics": pressure_dynamics, "plant_modulus_scale": plant_modulus_scale,
                                 "plant_tau_scale": plant_tau_scale}.items() if v is not None}
    if changes:
        cfg = dataclasses.replace(cfg, **changes)
        opt = {"kp_bar_per_deg": "--kp", "ki_bar_per_deg_s": "--ki", "plant_modulus_scale": "--plant-modulus-scale",
               "plant_tau_scale": "--plant-tau-scale", "seed": "--seed"}
        try:
            cfg.validate()
        except InputError as exc:
            key = (exc.key or "").split(".")[-1]
            raise InputError(exc.message, key=opt.get(key, exc.key)) from None
    controllers = [c.strip() for c in controller.split(",") if c.strip()]
    if not controllers:
        raise InputError("no controller given (a comma list of pi, vbmm-pi, ms-pi)", key="--controller")
    try:  # refuse an unknown or repeated controller before any model is read or anything is run
        dataclasses.replace(cfg, controllers=tuple(controllers)).validate()
    except InputError as exc:
        raise InputError(exc.message, key="--controller") from None
    from bpmid.io.atomic import check_outputs_not_inputs  # before any work: no output may replace an input

    check_outputs_not_inputs([out / n for n in ("summary.csv", "control.yaml", "fig18.png")],
                             [params, plant_params, config] + [Path(r.strip()) for r in reference.split(",")
                                                                if r.strip() and Path(r.strip()).is_file()])
    result = control(params, reference=reference, controllers=controllers, plant_params=plant_params,
                     plant_effects=plant_effect or [], config=cfg_all, **changes)
    result.save(out, figure=not no_figure)
    result = result.raw
    tab = result.table
    for row in tab[tab.reference == "ALL"].itertuples():
        red = "" if row.controller == "pi" or row.reduction_pct != row.reduction_pct else \
            (f", {abs(row.reduction_pct):.1f} % below pi" if row.reduction_pct >= 0.05 else
             f", {abs(row.reduction_pct):.1f} % above pi" if row.reduction_pct <= -0.05 else ", the same as pi")
        typer.echo(f"{row.controller}: RMSE {row.rmse_deg:.3f} deg over all references{red} ({row.status})")
    cost = result.feedforward_cost
    typer.echo(f"feedforward (incremental inverse VBMM): {cost['incremental_kernel_us_per_step']:.2f} us per step "
               f"= {cost['share_of_period_pct']:.4f} % of the {1e3 / cfg.rate_hz:g} ms control period")
    for ref in result.references:
        if ref.resampled:
            typer.echo(f"note: reference {ref.name}: {ref.resampled}")
    for w in result.warnings:
        typer.echo(f"warning: {w}", err=True)
    typer.echo(f"wrote {out}/summary.csv, control.yaml, traces/, {figure_path('fig18.png')}" if not no_figure else
               f"wrote {out}/summary.csv, control.yaml, traces/")
