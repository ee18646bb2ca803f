"""``bpmid compare``: fit every model on training logs, score it free-running on test logs
(the science is in :mod:`bpmid.compare`)."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from bpmid.plots.options import figures_option, set_figure_format

from bpmid.cli._app import app, command, multi_value_command
from bpmid.cli._logopts import log_options

EPILOG = ("Example (shipped synthetic data):  bpmid compare --train datasets/motion/fitting_set/*.csv "
          "--test datasets/motion/variable_amplitude/*.csv datasets/motion/variable_rate/*.csv "
          "--models vbmm-fit,gpi,maxwell-slip --out out/compare  |  the paper's comparison as a config:  "
          "bpmid compare --config configs/compare_paper.yaml --out out/compare")

#: options that take several values in a row (``--train a.csv b.csv --test c.csv``)
MultiValueCommand = multi_value_command("--train", "--test")


@command(app, "compare", epilog=EPILOG, cls=MultiValueCommand)
@log_options("motion")
def compare(
    train: Optional[List[Path]] = typer.Option(None, "--train", metavar="LOG...",
                                               help="Training motion logs (every model is fitted on these only)."),
    test: Optional[List[Path]] = typer.Option(None, "--test", metavar="LOG...",
                                              help="Test motion logs (every model runs free on each; needs angle_deg)."),
    models: Optional[str] = typer.Option(None, "--models", help="Comma list of: vbmm-mat, vbmm-fit, gpi, "
                                         "maxwell-slip, three-element, two-branch. Default: compare.models of the "
                                         "config, else all."),
    relax: Optional[Path] = typer.Option(None, "--relax", help="Relaxation fit (bpmid.relax/1) for vbmm-mat. "
                                         "Default: compare.relax of the config."),
    config: Optional[Path] = typer.Option(None, "--config", help="Config YAML (sections io, compare; "
                                          "compare.train/test_sets name the logs when --train/--test are not given)."),
    out: Path = typer.Option(..., "--out", help="Output folder: metrics.csv, summary.csv, summary_by_set.csv, "
                             "compare.yaml, predictions/, figures."),
    logopts=None,
    figures: Optional[str] = figures_option(),
):
    """Fit every model on the training logs only, simulate each free-running on every test log, score it."""
    set_figure_format(figures)
    from bpmid.api import compare
    from bpmid.compare import verdicts
    from bpmid.config import load_config

    cfg = logopts.apply(load_config(config))
    from bpmid.compare import resolve_inputs

    train_paths, test_sets, relax_path = resolve_inputs(cfg.section("compare"), cfg, train=train, test=test,
                                                        relax=relax)
    from bpmid.io.atomic import check_outputs_not_inputs  # before any work: no output may replace an input

    tests = [p for v in test_sets.values() for p in v]
    check_outputs_not_inputs([Path(out) / n for n in ("metrics.csv", "summary.csv", "summary_by_set.csv",
                                                      "compare.yaml")]
                             + [Path(out) / "predictions" / f"{Path(p).stem}.csv" for p in tests],
                             list(train_paths) + tests + [relax_path, config])
    res = compare(train, test, models=models, relax=relax, config=cfg)   # its warnings said on stderr as it runs
    res.save(out)
    result = res.raw
    s = result.summary
    typer.echo(f"{'rank':>4}  {'model':<14}{'rmse_deg':>9}{'mape_pct':>9}{'r2':>8}{'us/step':>9}{'params':>7}")
    for r in s.itertuples():
        typer.echo(f"{r.rank:>4}  {r.model:<14}{r.rmse_deg:>9.3f}{r.mape_pct:>9.3f}{r.r2:>8.3f}"
                   f"{r.us_per_step:>9.3g}{r.n_params:>7d}")
    for line in verdicts(result)[1:]:
        typer.echo(line)
    motion_cfg = cfg.section("motion")
    if "vbmm-mat" in set(s["model"]) and relax_path is None and motion_cfg.relax_fit is None:
        typer.echo(f"note: vbmm-mat ran on the paper's printed constants (motion.prior {motion_cfg.prior}; no "
                   "--relax, compare.relax or motion.relax_fit): give your material's relaxation fit (bpmid fit "
                   "relax) to compare your own muscle's")
    typer.echo(f"wrote {Path(out) / 'metrics.csv'}, {Path(out) / 'summary.csv'} and figures")
    # files a command does not write are left alone: an earlier run's predictions stay beside this run's, said
    ours = {f"{lg.name}.csv" for lg in result.test}
    earlier = sorted(p.name for p in (Path(out) / "predictions").glob("*.csv") if p.name not in ours)
    if earlier:
        shown = ", ".join(earlier[:5]) + (f" and {len(earlier) - 5} more" if len(earlier) > 5 else "")
        typer.echo(f"note: {Path(out) / 'predictions'} also holds {len(earlier)} file(s) this run did not write "
                   f"(an earlier run's, left as they were: {shown}); compare.yaml lists this run's")
