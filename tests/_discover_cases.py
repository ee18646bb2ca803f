"""Shared by the discovery tests: ``bpmid discover`` on the shipped blind case 1 with a given config, and the short
protocols and loose gate the end-to-end discovery tests run with."""
from __future__ import annotations

import math
from pathlib import Path

import yaml
from typer.testing import CliRunner

from bpmid.cli import app
from bpmid.discover.calibrate import PROTOCOLS

#: the paper-sized protocols without the two long runs (the test's cost)
SHORT = {k: v for k, v in PROTOCOLS.items() if not k.startswith(("long", "ho_long"))}
#: a gate that names whatever its likelihood-ratio test passes (no gain or share asked; no floor or pair path)
LOOSE = {"heldout_gain_min_sigma": 0.0, "gap_share_min": 0.0, "family_alpha": 1e-6, "fit_share_min": 0.0,
         "to_floor_drop_min_sigma": math.inf, "pair_share_min": math.inf}


def discover_case_01(tmp_path, config_text: str) -> dict:
    """``bpmid discover`` on the shipped blind case 1 with ``config_text`` as its --config, through the CLI;
    the discovery.yaml it writes, read back (the command must exit 0)."""
    cfg = tmp_path / "cfg.yaml"
    cfg.write_text(config_text)
    case = Path(__file__).resolve().parents[1] / "datasets" / "discovery" / "case_01"
    out = tmp_path / "out"
    r = CliRunner().invoke(app, ["--quiet", "discover", *[str(p) for p in sorted(case.glob("train_*.csv"))],
                                 "--holdout", str(case / "holdout_mixed.csv"), "--config", str(cfg),
                                 "--out", str(out)])
    assert r.exit_code == 0, r.output
    return yaml.safe_load((out / "discovery.yaml").read_text())
