"""``bpmid discover``: name the effects the VBMM lacks (the science is in :mod:`bpmid.discover`)."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from bpmid.plots.options import figures_option, set_figure_format

from bpmid.cli._app import app, command, existing_files, multi_value_command
from bpmid.cli._logopts import log_options


#: ``--holdout a.csv b.csv`` takes every following value up to the next option
HoldoutCommand = multi_value_command("--holdout")

EPILOG = ("Without --holdout, a fixed split holds out whole logs (every 3rd, counting from the last; "
          "discover.holdout_every in a config). Example (a shipped blind case; its answer is in "
          "datasets/discovery/ANSWERS.yaml):  bpmid discover datasets/discovery/case_05/train_*.csv --holdout "
          "datasets/discovery/case_05/holdout_mixed.csv --out out/discover")


def load_base(init: Optional[Path], cfg):
    """The starting VBMM: ``--init`` (bpmid.vbmm/1 or bpmid.relax/1, told apart by schema) or the paper's
    VBMM-fit constants; geometry, closure and history from the config section ``model``."""
    from bpmid.models.vbmm import starting_vbmm

    return starting_vbmm(init, cfg.section("model"))[:2]


@command(app, "discover", epilog=EPILOG, cls=HoldoutCommand)
@log_options("motion")
def discover_cmd(
    logs: List[Path] = typer.Argument(..., metavar="LOG", help="Motion logs with measured angles."),
    holdout: Optional[List[Path]] = typer.Option(None, "--holdout", metavar="LOG...",
                                                 help="Held-out logs (default: a fixed split of LOG...)."),
    init: Optional[Path] = typer.Option(None, "--init", help="Starting constants: bpmid.vbmm/1 or bpmid.relax/1 "
                                        "(default: the paper's VBMM-fit)."),
    config: Optional[Path] = typer.Option(None, "--config", help="Config YAML (sections io, model, discover)."),
    thresholds: Optional[Path] = typer.Option(None, "--thresholds", help="The gate's thresholds: a "
                                              "bpmid.discover-thresholds/1 file, as bpmid calibrate writes it "
                                              "(OUT/thresholds.yaml, calibrated on your rig's noise); default "
                                              "bpmid's shipped calibration (config: discover.thresholds_file)."),
    out: Path = typer.Option(..., "--out", help="Output folder: discovery.yaml, verdict.txt, model.yaml (the final model, bpmid.vbmm/1), figures."),
    logopts=None,
    figures: Optional[str] = figures_option(),
):
    """Fit the base VBMM, diagnose the residual, screen every catalogue effect, confirm the best on held-out
    logs, add one effect at a time; write DIR/discovery.yaml, a plain-language verdict and figures."""
    set_figure_format(figures)
    from bpmid.config import load_config
    from bpmid.discover import discover
    from bpmid.discover.output import write_discovery
    from bpmid.io.motion_logs import read_motion_logs
    from bpmid.io.results import provenance
    from bpmid.progress import note

    from bpmid.io import plausibility as plaus

    cfg = logopts.apply(load_config(config))
    paths = existing_files(list(logs))
    ho_paths = existing_files(list(holdout), "held-out log") if holdout else []
    from bpmid.io.atomic import check_outputs_not_inputs  # before any work: no output may replace an input
    from bpmid.validation.sweep import refuse_sweep_folder

    refuse_sweep_folder(out, "discover")
    check_outputs_not_inputs([out / "discovery.yaml", out / "verdict.txt", out / "model.yaml"],
                             list(paths) + list(ho_paths)
                             + [init, config, thresholds])
    dcfg = cfg.section("discover")
    if thresholds is not None:   # the flag over the config's discover.thresholds_file, checked before any work
        import dataclasses

        from bpmid.discover.workflow import checked_thresholds_file

        dcfg = dataclasses.replace(dcfg, thresholds_file=checked_thresholds_file(thresholds, "--thresholds"))
    fit_logs = read_motion_logs(paths, cfg.section("io"), require_angle=True)
    ho_logs = read_motion_logs(ho_paths, cfg.section("io"), require_angle=True) if ho_paths else None
    all_logs = fit_logs + (ho_logs or [])
    warnings = plaus.log_warnings(all_logs)
    plaus.emit(warnings, strict=cfg.section("io").strict, what=str(out),
               key=plaus.strict_key(cfg.section("io")))
    ambient = plaus.assumed_ambient_note(all_logs)
    if ambient:
        typer.echo("note: " + ambient, err=True)
    base, base_from = load_base(init, cfg)
    result = discover(fit_logs, base, holdout=ho_logs, cfg=dcfg)
    from bpmid.models.vbmm.model import paper_geometry_note

    geometry_note = paper_geometry_note(base.geometry)
    if geometry_note:   # after the inputs were judged: not beside an error
        typer.echo("note: " + geometry_note, err=True)
    inputs = list(paths) + list(ho_paths) + ([init] if init else []) \
        + ([Path(dcfg.thresholds_file)] if dcfg.thresholds_file else [])
    note("discover: writing figures")
    write_discovery(out, result, plaus.attach(provenance(inputs, config=cfg), all_logs, warnings), base_from=base_from)
    typer.echo(result.verdict)
    typer.echo(f"named effects: {', '.join(result.named_effects) or 'none'}; held-out RMSE "
               f"{result.heldout_before:.3f} -> {result.heldout_after:.3f} deg (noise floor "
               f"{result.noise_floor_deg:.3f} deg)"
               + (f"; gate from {dcfg.thresholds_file}" if dcfg.thresholds_file else "")
               + f"; wrote {Path(out) / 'discovery.yaml'} and "
               f"{Path(out) / 'model.yaml'} (the final model: bpmid predict --params, bpmid export --to c)")
