"""``bpmid run``: the whole study from one config (the stages are in :mod:`bpmid.run`)."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from bpmid.plots.options import figures_option, set_figure_format

from bpmid.cli._app import app, command

EPILOG = ("Example:  bpmid run   (configs/paper.yaml on the shipped datasets, into out/paper)  |  "
          "bpmid run configs/paper.yaml --out out/paper  then open out/paper/report.html")


@command(app, "run", epilog=EPILOG)
def run(
    config: Optional[Path] = typer.Argument(None, metavar="CONFIG", help="Study config (sections run, compare, "
                                            "relax, motion, model, discover, io). Default: the shipped "
                                            "configs/paper.yaml (`bpmid shipped` prints where it is)."),
    out: Optional[Path] = typer.Option(None, "--out", help="Output folder (default: run.out of the config, else "
                                       "out/<config name>)."),
    figures: Optional[str] = figures_option(),
    workers: Optional[int] = typer.Option(None, "--workers", min=0, help="Processes for the stages after the motion "
                                          "fit (compare, history, discover, control side by side); 1 = one after "
                                          "another; 0 = the idle cores, at most 2. Default: run.workers of the "
                                          "config (0). The numbers are the same either way."),
):
    """The whole study in one command: relaxation fit, motion fit (VBMM-mat and VBMM-fit), comparison of all
    models, history modes, discovery and the report; every stage's files in the output folder, progress on stderr."""
    set_figure_format(figures)
    from bpmid.config import load_config
    from bpmid.run import default_config_path, run_study

    path = Path(config) if config is not None else default_config_path()
    cfg = load_config(path)
    if workers is not None:
        import dataclasses

        from bpmid.config import Config

        rc0 = cfg.section("run")
        cfg = Config({**cfg.sections, "run": dataclasses.replace(rc0, workers=workers)}, cfg.path, cfg.sha256)
    rc = cfg.section("run")
    out_dir = out if out is not None else Path(rc.out) if rc.out else Path("out") / path.stem
    from bpmid.errors import reading_flags_absent

    with reading_flags_absent():   # its logs are read by the config's io section: errors name those keys
        records = run_study(cfg, out_dir)
    for r in records:
        extra = f" ({r.note})" if r.note else ""
        typer.echo(f"{r.name:<9} {r.status:<8} {r.seconds:7.1f} s{extra}")
    done = [r for r in records if r.status == "done"]
    typer.echo(f"wrote {out_dir} ({len(done)} stage(s))" + (f"; report: {out_dir / 'report.html'}"
                                                             if any(r.name == 'report' for r in done) else ""))
