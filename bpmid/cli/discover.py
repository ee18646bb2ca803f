"""``bpmid discover``: name the effects the VBMM lacks (the science is in :mod:`bpmid.discover`)."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from bpmid.plots.options import figures_option, set_figure_format

from bpmid.cli._app import app, command, existing_files, multi_value_command


#: ``--holdout a.csv b.csv`` takes every following value up to the next option
HoldoutCommand = multi_value_command("--holdout")

EPILOG = ("Example (a shipped blind case; its answer is in datasets/discovery/ANSWERS.yaml):  bpmid discover "
          "datasets/discovery/case_01/train_*.csv --holdout datasets/discovery/case_01/holdout_mixed.csv "
          "--out out/discover   |   without --holdout, whole logs are held out in turn")


def load_base(init: Optional[Path], cfg):
    """The starting VBMM: ``--init`` (bpmid.vbmm/1 or bpmid.relax/1, told apart by schema) or the paper's
    VBMM-fit constants; geometry, closure and history from the config section ``model``."""
    from bpmid.io.results import read_result
    from bpmid.models.vbmm import VBMM, Material, load_vbmm
    from bpmid.errors import InputError

    mcfg = cfg.section("model")
    if init is None:
        return VBMM.from_config(Material.paper_fit(), mcfg), "paper VBMM-fit constants"
    data = read_result(init, ("bpmid.vbmm/", "bpmid.relax/"))
    schema = str(data.get("schema"))
    if schema.startswith("bpmid.vbmm/"):
        return load_vbmm(init, mcfg), f"{init} (motion fit)"
    if schema.startswith("bpmid.relax/"):
        from bpmid.motion_fit import material_from_relax
        return VBMM.from_config(material_from_relax(init), mcfg), f"{init} (relaxation fit)"
    raise InputError(f"--init needs a bpmid.vbmm/1 or bpmid.relax/1 file, found schema {schema!r}", path=init,
                     key="schema")


@command(app, "discover", epilog=EPILOG, cls=HoldoutCommand)
def discover_cmd(
    logs: List[Path] = typer.Argument(..., metavar="LOG", help="Motion logs with measured angles."),
    holdout: Optional[List[Path]] = typer.Option(None, "--holdout", metavar="LOG...",
                                                 help="Held-out logs (default: a fixed split of LOG...)."),
    init: Optional[Path] = typer.Option(None, "--init", help="Starting constants: bpmid.vbmm/1 or bpmid.relax/1 "
                                        "(default: the paper's VBMM-fit)."),
    config: Optional[Path] = typer.Option(None, "--config", help="Config YAML (sections io, model, discover)."),
    out: Path = typer.Option(..., "--out", help="Output folder: discovery.yaml, verdict.txt, figures."),
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

    cfg = load_config(config)
    paths = existing_files(list(logs))
    ho_paths = existing_files(list(holdout), "held-out log") if holdout else []
    fit_logs = read_motion_logs(paths, cfg.section("io"), require_angle=True)
    ho_logs = read_motion_logs(ho_paths, cfg.section("io"), require_angle=True) if ho_paths else None
    base, base_from = load_base(init, cfg)
    result = discover(fit_logs, base, holdout=ho_logs, cfg=cfg.section("discover"))
    inputs = list(paths) + list(ho_paths) + ([init] if init else [])
    note("discover: writing figures")
    write_discovery(out, result, provenance(inputs, config=cfg), base_from=base_from)
    typer.echo(result.verdict)
    typer.echo(f"named effects: {', '.join(result.named_effects) or 'none'}; held-out RMSE "
               f"{result.heldout_before:.3f} -> {result.heldout_after:.3f} deg (noise floor "
               f"{result.noise_floor_deg:.3f} deg); wrote {Path(out) / 'discovery.yaml'}")
