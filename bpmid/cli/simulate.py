"""``bpmid simulate``: run a protocol file on the digital twin (library: :mod:`bpmid.twin.simulate`)."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from bpmid.cli._app import app, command


@command(app, "simulate", epilog="Example: bpmid simulate configs/datasets/variable_amplitude.yaml "
                                 "--effect thermal_softening:amount=0.1,T=300 --seed 7 --out sim/   (an effect "
                                 "the protocol's rig does not already have: a 10 % softening with a time constant "
                                 "T of 300 s; ids, parameters and their units: docs/model.md section 9)")
def simulate_cmd(
    protocol: Path = typer.Argument(..., metavar="PROTOCOL", help="Protocol file (YAML, schema bpmid.protocol/1; see datasets/README.md)."),
    out: Path = typer.Option(..., "--out", help="Folder for the logs (CSV) and manifest.yaml."),
    params: Optional[Path] = typer.Option(None, "--params", help="VBMM constants (bpmid.vbmm/1) for the plant."),
    effect: Optional[List[str]] = typer.Option(None, "--effect", help="Inject a catalogue effect: ID[:key=value,...]; "
                                               "repeatable. Keys: the effect's parameters or settings, in their "
                                               "units (ids: second_relaxation, braid_friction, pressure_lag, "
                                               "asymmetric_relaxation, strain_stiffening, angle_offset, "
                                               "thermal_softening; parameters and units: docs/model.md section 9)."),
    seed: Optional[int] = typer.Option(None, "--seed", help="Seed of every random draw (default: the protocol's)."),
    no_timestamp: bool = typer.Option(False, "--no-timestamp", help="Omit the creation time (byte-reproducible)."),
):
    """Simulate the test rig running PROTOCOL: synthetic logs plus a manifest naming protocol, parameters,
    seed and any injected effect (never in the CSV)."""
    from bpmid.api import simulate
    from bpmid.errors import InputError

    if seed is not None and seed < 0:   # the library names its argument (seed); here it is the flag
        raise InputError(f"a seed is a non-negative whole number, found {seed}", key="--seed")
    result = simulate(protocol, params=params, effects=tuple(effect or ()), seed=seed, timestamp=not no_timestamp)
    before = {q.name for q in Path(out).glob("*.csv")} if Path(out).is_dir() else set()
    result.save(out)
    others = sorted(before - set(result.raw.files))
    if others:   # never in silence: `fit motion DIR/*.csv` would mix them with this run's logs
        typer.echo(f"note: {out} already held {len(others)} other log file{'s' if len(others) != 1 else ''} "
                   f"({', '.join(others[:4])}{', ...' if len(others) > 4 else ''}), not in this manifest and left as "
                   "they were: give an empty or new folder, or DIR/*.csv mixes them with these logs", err=True)
    n = len(result.raw.files)
    if "seed" in result.body:
        how = f"seed {result.body['seed']}"
    else:   # a reference protocol: designed signals, nothing drawn at random
        how = "designed signals: nothing random" + ("; --seed has no effect on them" if seed is not None else "")
    typer.echo(f"wrote {n} file{'s' if n != 1 else ''} and manifest.yaml to {out} ({how})")
