"""``bpmid fit relax``: fit a Prony series to relaxation logs or frequency sweeps (the science is in
:mod:`bpmid.relax`)."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from bpmid.plots.options import figure_path, figures_option, set_figure_format

from bpmid.cli._app import check_outputs, command, existing_files, fit_app
from bpmid.cli._logopts import log_options

EPILOG = ("\b\nExample (shipped synthetic logs):  bpmid fit relax datasets/relaxation/*.csv --out relax_fit.yaml  |\n"
          "measured master curve, step mode:  bpmid fit relax datasets/reference/pyvisco/time_user_master.csv "
          "--out master_fit.yaml  |\n"
          "DMTA storage and loss modulus:  bpmid fit relax "
          "datasets/reference/pyvisco-frequency/freq_user_master.csv --terms 26 --out freq_fit.yaml  |\n"
          "raw sweeps at 21 temperatures, master curve at -5 C:  bpmid fit relax "
          "datasets/reference/pyvisco-frequency/freq_user_raw.csv --ref-temp -5 --out raw_fit.yaml")


@command(fit_app, "relax", epilog=EPILOG)
@log_options("relax")
def fit_relax(
    logs: List[Path] = typer.Argument(..., metavar="LOG", help="Relaxation logs (CSV): time_s,strain,stress_mpa or "
                                      "time_s,extension_mm,load_n or time_s,modulus_mpa (other header styles too); "
                                      "or frequency-domain data: f (Hz) with E_stor/E' and E_loss/E'' (or G), a "
                                      "master curve or raw sweeps with T (C) and Set columns, CSV or an Eplexor "
                                      ".xls export; or raw relaxation curves t, E_relax, T, Set."),
    out: Path = typer.Option(..., "--out", help="Result YAML (schema bpmid.relax/1); the figure goes beside it "
                             "as .png."),
    terms: Optional[str] = typer.Option(None, "--terms", help="Number of Prony terms, or auto (information "
                                        "criterion, printed per candidate). Default: relax.terms of the config "
                                        "(auto)."),
    max_error: Optional[float] = typer.Option(None, "--max-error", help="Pick the fewest terms whose error (%) is at "
                                              "most this (frequency data: RMS of |E*_fit - E*|/|E*|; modulus "
                                              "curves: RMS relative error; stress: RMSE / RMS stress). Overrides "
                                              "--terms."),
    mode: Optional[str] = typer.Option(None, "--mode", help="ramp: stress through each log's strain history; "
                                       "step: modulus curve of each hold, as an ideal step. Default: ramp, or step "
                                       "for modulus curves. Not for frequency-domain data."),
    ref_temp: Optional[float] = typer.Option(None, "--ref-temp", help="Reference temperature (C) of the master curve "
                                             "built from raw sets at several temperatures (default: the median set "
                                             "temperature)."),
    shift: Optional[Path] = typer.Option(None, "--shift", help="CSV of shift factors (header 'T (C)',log_aT: the temperature's unit in the header) to "
                                         "use instead of finding them from the data."),
    poisson: Optional[float] = typer.Option(None, "--poisson", help="Poisson's ratio for G and K, below 0.5 "
                                            "(default 0.49933, which reproduces the paper's K values)."),
    config: Optional[Path] = typer.Option(None, "--config", help="Config YAML (section relax)."),
    no_figure: bool = typer.Option(False, "--no-figure", help="Do not write the figure."),
    logopts=None,
    figures: Optional[str] = figures_option(),
):
    """Fit a Prony series E(t) = E_inf + sum E_j exp(-t/tau_j) to relaxation logs or to storage and loss moduli
    (shifting raw sets at several temperatures into a master curve first); write E, G and K."""
    set_figure_format(figures)
    from bpmid.api import fit_relaxation
    from bpmid.config import load_config
    from bpmid.relax.result import check_mode, save_relax_result

    check_mode(mode, flags=True)
    cfg = logopts.apply(load_config(config))
    paths = existing_files(logs, "relaxation log")
    if shift is not None:
        existing_files([shift], "shift-factor")
    check_outputs([out], paths + [config, shift], suffix=".yaml")
    if not no_figure:
        check_outputs([figure_path(out.with_suffix(".png"))], paths + [config, shift])
    result = fit_relaxation(paths, terms=terms, mode=mode, poisson=poisson, config=cfg, max_error_pct=max_error,
                            ref_temp=ref_temp, shift=shift, _flags=True)
    yaml_path, fig_path, fit = save_relax_result(result, out, figure=not no_figure)
    shift_res = getattr(fit, "shift", None)
    inner = getattr(fit, "fit", fit)
    if inner.criterion and inner.criterion != "max-error":
        typer.echo(f"terms  {inner.criterion} (lower is better; * chosen)")
        for c in inner.selection:
            if c.get("criterion") is not None:
                typer.echo(f"{c['terms']:5d}  {c['criterion']:.2f}{'  *' if c['terms'] == inner.m else ''}")
    elif inner.criterion == "max-error":
        meets = any(c["error_pct"] <= max_error for c in inner.selection)
        typer.echo("terms  error %  (* " + ("the fewest that meet --max-error)" if meets else
                                           f"chosen: none meets --max-error {max_error:g} %, the smallest error)"))
        for c in inner.selection:
            typer.echo(f"{c['terms']:5d}  {c['error_pct']:.3g}{'  *' if c['terms'] == inner.m else ''}")
    if shift_res is not None:
        wl = shift_res.wlf
        fn = getattr(shift_res, "from_function", None)
        fn = [False] * shift_res.T.size if fn is None else [bool(v) for v in fn]
        typer.echo(f"shift factors ({shift_res.source}) at T_ref {shift_res.T_ref:g} C: " + ", ".join(
            f"{t + 0.0:g} C: {a:+.2f}{' (shift function)' if f else ''}"
            for t, a, f in sorted(zip(shift_res.T.tolist(), shift_res.log_aT.tolist(), fn)))
            + ("  (shift function: not determined by the data; see the warning)" if any(fn) else ""))
        if wl is not None:
            typer.echo(f"WLF: C1 = {wl['C1']:.4g} +- {wl['se_C1']:.2g}, C2 = {wl['C2']:.4g} +- {wl['se_C2']:.2g} C, "
                       f"T_ref = {wl['T_ref']:g} C, RMSE {wl['rmse']:.3g} decades")
    sym = getattr(inner, "modulus", "E")   # G for shear data: the constants are G's
    sym = sym if sym in ("E", "G") else "E"
    terms_txt = ", ".join(f"{sym}={e * 1e6:.4g} Pa tau={t:.4g} s" for e, t in zip(inner.E[:4], inner.tau[:4]))
    more = f" (+{inner.m - 4} more)" if inner.m > 4 else ""
    if getattr(inner, "mode", "") == "frequency":
        typer.echo(f"frequency domain, {inner.m} term(s): {sym}_inf={inner.E_inf * 1e6:.4g} Pa, {terms_txt}{more}; "
                   f"RMS relative error {inner.modulus}' {inner.rms_rel_storage_pct:.3g} %, {inner.modulus}'' "
                   f"{inner.rms_rel_loss_pct:.3g} %, fit {inner.seconds:.2f} s")
    else:
        typer.echo(f"{inner.mode} mode, {inner.m} term(s): {sym}_inf={inner.E_inf * 1e6:.4g} Pa, {terms_txt}{more}; "
                   f"RMSE {inner.rmse_mpa * 1e6:.4g} Pa, R2 {inner.r2:.5f}, fit {inner.seconds:.2f} s")
    typer.echo(f"wrote {yaml_path}" + (f" and {fig_path}" if fig_path else ""))
