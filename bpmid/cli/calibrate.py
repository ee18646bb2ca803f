"""``bpmid calibrate``: calibrate discovery on out-of-family cases and score it (science: :mod:`bpmid.validation`)."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from bpmid.cli._app import app, command

EPILOG = ("Sweeps run on Dask, an optional extra: pip install 'bpmid[cluster]' first. Rerun the same command to "
          "resume an interrupted sweep; --scheduler tcp://HOST:8786 runs it on an existing Dask cluster. Example (24 "
          "short cases on 2 local workers, 1-2 minutes on 2 cores):  "
          "bpmid calibrate configs/sweeps/small.yaml --out out/sweep-small --workers 2")


@command(app, "calibrate", epilog=EPILOG)
def calibrate_cmd(
    sweep: Path = typer.Argument(..., metavar="SWEEP.yaml", help="Sweep config: sections sweep, generator, rig, "
                                 "calibration, evaluation (see configs/sweeps/)."),
    out: Path = typer.Option(..., "--out", help="Output folder: records.jsonl (streamed), thresholds.yaml, "
                             "confusion.csv/.md, summary.yaml, answers/<split>.yaml."),
    split: str = typer.Option("all", "--split", help="calibration, heldout or all (calibrate on one half, score "
                              "on the other), or pool (every case run as calibration: a draw whose held-out half "
                              "was looked at can still calibrate)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", metavar="ADDRESS",
                                            help="Address of a running Dask scheduler (default: a LocalCluster)."),
    workers: Optional[int] = typer.Option(None, "--workers", min=1, help="LocalCluster workers (default: cores)."),
    thresholds: Optional[Path] = typer.Option(None, "--thresholds", help="Thresholds file (bpmid.discover-"
                                              "thresholds/1) for the held-out half instead of the calibrated ones."),
    threads: bool = typer.Option(False, "--threads", help="LocalCluster workers as threads of this process "
                                 "(faster start, for small sweeps)."),
):
    """Generate out-of-family cases (bpmid.validation), run discovery on each on Dask, calibrate the thresholds on
    the calibration half and write the confusion matrix and rates of the held-out half. Every finished case is
    appended to DIR/records.jsonl at once; rerunning into the same DIR resumes."""
    from bpmid.errors import InputError
    from bpmid.progress import line
    from bpmid.validation.sweep import check_split, confusion_markdown, load_sweep, run_sweep

    check_split(split)
    if scheduler and (workers is not None or threads):
        raise InputError("--workers and --threads size a LocalCluster on this machine; with --scheduler the "
                         "existing cluster's own workers run the sweep: give one or the other",
                         key="--workers" if workers is not None else "--threads")
    if thresholds is not None and not Path(thresholds).is_file():
        raise InputError("thresholds file not found", path=thresholds, key="--thresholds")
    cfg = load_sweep(sweep)
    res = run_sweep(cfg, out, split=split, scheduler=scheduler, workers=workers, processes=not threads,
                    thresholds_path=thresholds, progress=line)
    if res.summary is not None:
        typer.echo(confusion_markdown(res.summary))
    if res.thresholds is not None and split != "heldout":
        typer.echo(f"thresholds: {Path(out) / 'thresholds.yaml'}")
    typer.echo(f"wrote {Path(out) / 'records.jsonl'} ({len(res.records)} cases), confusion.csv, confusion.md, "
               f"summary.yaml, answers/ in {out}")
