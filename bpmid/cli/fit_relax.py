"""``bpmid fit relax``: fit a Prony series to relaxation logs (the science is in :mod:`bpmid.relax`)."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from bpmid.plots.options import figure_path, figures_option, set_figure_format

from bpmid.cli._app import check_outputs, command, existing_files, fit_app

EPILOG = ("Example (shipped synthetic logs):  bpmid fit relax datasets/relaxation/*.csv --out relax_fit.yaml  "
          "|  measured master curve, step mode:  bpmid fit relax datasets/reference/pyvisco/time_user_master.csv "
          "--out master_fit.yaml")


@command(fit_app, "relax", epilog=EPILOG)
def fit_relax(
    logs: List[Path] = typer.Argument(..., metavar="LOG", help="Relaxation logs (CSV): time_s,strain,stress_mpa or "
                                      "time_s,extension_mm,load_n or time_s,modulus_mpa (other header styles too)."),
    out: Path = typer.Option(..., "--out", help="Result YAML (schema bpmid.relax/1); the figure goes beside it "
                             "as .png."),
    terms: Optional[str] = typer.Option(None, "--terms", help="Number of Prony terms, or auto (information "
                                        "criterion). Default: relax.terms of the config (auto)."),
    mode: Optional[str] = typer.Option(None, "--mode", help="ramp: stress through each log's strain history; "
                                       "step: modulus curve of each hold, as an ideal step. Default: ramp, or step "
                                       "for modulus curves."),
    poisson: Optional[float] = typer.Option(None, "--poisson", help="Poisson's ratio for G and K, below 0.5 "
                                            "(default 0.49933, which reproduces the paper's K values)."),
    config: Optional[Path] = typer.Option(None, "--config", help="Config YAML (section relax)."),
    no_figure: bool = typer.Option(False, "--no-figure", help="Do not write the figure."),
    figures: Optional[str] = figures_option(),
):
    """Fit a Prony series E(t) = E_inf + sum E_j exp(-t/tau_j) to relaxation logs; write E, G and K."""
    set_figure_format(figures)
    from bpmid.config import load_config
    from bpmid.errors import InputError
    from bpmid.relax import run_fit_relax

    if mode is not None and mode not in ("ramp", "step"):
        raise InputError(f"--mode takes ramp or step, found {mode!r}", key="--mode")
    cfg = load_config(config)
    paths = existing_files(logs, "relaxation log")
    check_outputs([out], paths + [config], suffix=".yaml")
    if not no_figure:
        check_outputs([figure_path(out.with_suffix(".png"))], paths + [config])
    yaml_path, fig_path, fit = run_fit_relax(paths, out, terms=terms, mode=mode, poisson=poisson, config=cfg,
                                             figure=not no_figure)
    terms_txt = ", ".join(f"E={e * 1e6:.4g} Pa tau={t:.4g} s" for e, t in zip(fit.E[:4], fit.tau[:4]))
    more = f" (+{fit.m - 4} more)" if fit.m > 4 else ""
    typer.echo(f"{fit.mode} mode, {fit.m} term(s): E_inf={fit.E_inf * 1e6:.4g} Pa, {terms_txt}{more}; "
               f"RMSE {fit.rmse_mpa * 1e6:.4g} Pa, R2 {fit.r2:.5f}, fit {fit.seconds:.2f} s")
    typer.echo(f"wrote {yaml_path}" + (f" and {fig_path}" if fig_path else ""))
