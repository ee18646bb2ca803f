"""Writing a discovery result: ``discovery.yaml`` (schema ``bpmid.discovery/1``), ``verdict.txt`` and the
three figures, all or nothing (one staged folder). Used by ``bpmid discover`` and by ``bpmid run``."""
from __future__ import annotations

import textwrap
from pathlib import Path

from bpmid.io.atomic import staged_dir, write_text
from bpmid.io.motion_logs import is_synthetic
from bpmid.io.results import write_result
from bpmid.plots import discover as P
from bpmid.plots.common import label_synthetic, save_figure

SCHEMA = "bpmid.discovery/1"

#: file name -> figure function of :mod:`bpmid.plots.discover`
FIGURES = {"residual_before_after.png": P.residual_figure, "screening_ranking.png": P.ranking_figure,
           "heldout_error.png": P.heldout_figure}


#: the width verdict.txt is wrapped to (a statement of the gate runs to some 3000 characters)
VERDICT_WIDTH = 110


def readable(verdict: str) -> str:
    """The verdict as ``verdict.txt`` gives it: each statement wrapped to :data:`VERDICT_WIDTH` columns, its
    continuation lines indented, words and numbers never split, and a blank line between statements."""
    lines = [ln for ln in verdict.split("\n") if ln.strip()]
    return "\n\n".join(textwrap.fill(ln, VERDICT_WIDTH, subsequent_indent="  ", break_long_words=False,
                                      break_on_hyphens=False) for ln in lines)


def write_discovery(out_dir: str | Path, result, prov: dict, *, base_from: str) -> list[str]:
    """Write ``result`` (a :class:`~bpmid.discover.workflow.DiscoveryResult`) into ``out_dir``.

    Figures made from synthetic logs say so in their corner. Returns the names of the files written.
    """
    body = result.to_yaml()
    body["base_from"] = base_from
    synthetic = is_synthetic(list(result.fit_logs) + list(result.holdout_logs))
    with staged_dir(out_dir) as tmp:
        write_result(tmp / "discovery.yaml", SCHEMA, body, prov)
        write_text(tmp / "verdict.txt", readable(result.verdict) + "\n")
        for name, make in FIGURES.items():
            fig = make(result)
            if synthetic:
                label_synthetic(fig)
            save_figure(fig, tmp / name)
    return ["discovery.yaml", "verdict.txt", *FIGURES]
