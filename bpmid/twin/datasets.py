"""Regenerate every shipped dataset from ``configs/datasets/`` byte-identically.

    python -m bpmid.twin.datasets [--out DIR] [--only NAME ...]

Each protocol file runs through :func:`bpmid.twin.simulate.simulate` (the same library call as
``bpmid simulate``) with its own seed, no creation time and a fixed command line, so the files depend only
on the configs and the code. Where each protocol's output goes:

- kind relaxation -> ``relaxation/``; kind reference -> ``control/``
- ``configs/datasets/discovery/<case>.yaml`` -> ``discovery/<case>/`` (blind: the effect goes only to
  ``discovery/ANSWERS.yaml``)
- every other motion protocol -> ``motion/<config stem>/``
"""
from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from bpmid.io.atomic import write_bytes
from bpmid.io.results import dump_yaml
from bpmid.twin.protocol import Protocol, load_protocol
from bpmid.twin.simulate import Simulation, simulate

REPO = Path(__file__).resolve().parents[2]
CONFIGS = Path("configs/datasets")
COMMAND = "python -m bpmid.twin.datasets"


def protocol_files(repo: Path = REPO) -> list[Path]:
    """Every dataset protocol, relative to the repository (sorted: the build order)."""
    root = repo / CONFIGS
    return sorted(p.relative_to(repo) for p in root.rglob("*.yaml"))


def output_folder(rel: Path, proto: Protocol) -> Path:
    if proto.kind == "relaxation":
        return Path("relaxation")
    if proto.kind == "reference":
        return Path("control")
    if rel.parent.name == "discovery":
        return Path("discovery") / rel.stem
    return Path("motion") / rel.stem


def build(rel: Path, repo: Path = REPO) -> tuple[Path, Simulation]:
    """Simulate one protocol (path relative to the repository); returns its output folder and result."""
    proto = load_protocol(repo / rel)
    proto = dataclasses.replace(proto, path=rel.as_posix())
    return output_folder(rel, proto), simulate(proto, command=COMMAND, timestamp=False)


def regenerate(out: str | Path | None = None, only: list[str] | None = None, repo: Path = REPO) -> list[Path]:
    """Write the datasets (default: ``<repo>/datasets``); returns the folders written."""
    out = Path(out) if out is not None else repo / "datasets"
    answers: dict = {}
    written = []
    for rel in protocol_files(repo):
        if only and rel.stem not in only:
            continue
        folder, sim = build(rel, repo)
        sim.write(out / folder, answer_name=None)
        written.append(out / folder)
        if sim.answer is not None:
            answers[folder.name] = {"config": rel.as_posix(), "effects": sim.answer["effects"],
                                    "named": [e["id"] for e in sim.answer["effects"]]}
    if answers and not only:
        body = {"schema": "bpmid.discovery_answers/1",
                "note": "SPOILER: the hidden effect of each discovery demo case (empty list: no effect). "
                        "Synthetic data; see datasets/README.md.",
                "cases": answers}
        write_bytes(out / "discovery" / "ANSWERS.yaml", dump_yaml(body).encode())
    return written


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description="Regenerate the shipped synthetic datasets from configs/datasets/.")
    ap.add_argument("--out", default=None, help="target folder (default: datasets/ of the repository)")
    ap.add_argument("--only", nargs="*", default=None, help="config stems to build (default: all)")
    a = ap.parse_args(argv)
    folders = regenerate(a.out, a.only)
    print(f"wrote {len(folders)} dataset folders to {a.out or REPO / 'datasets'}")


if __name__ == "__main__":
    main()
