"""bpmid report: one self-contained HTML file plus a Markdown twin; quoted and measured numbers kept apart."""
from __future__ import annotations

import re
import shutil
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from bpmid.cli import app
from bpmid.report import PAPER_ROWS, fmt

runner = CliRunner()


@pytest.fixture(scope="module")
def study(timed_small_study):
    """The small study run once per session with timing on (tests/conftest.py)."""
    return timed_small_study


def _panels_md(md: str) -> tuple[str, str]:
    """The quoted panel and the measured panel of report.md (each a block of '> ' lines after its title)."""
    def block(title):
        i = md.index(title)
        lines = []
        for ln in md[i:].splitlines()[2:]:
            if not ln.startswith(">"):
                break
            lines.append(ln)
        return "\n".join(lines)

    return block("**Paper's numbers (quoted, the paper's data)**"), block("**Measured here (bpmid, synthetic shipped data)**")


def test_html_is_self_contained(study):
    page = (study / "report.html").read_text()
    assert "<script" not in page.lower()
    assert not re.search(r"(?:href|src)\s*=\s*\"(?:https?:|//|file:)", page, re.I)
    assert "http://" not in page and "https://" not in page
    assert "<link" not in page.lower()
    srcs = re.findall(r'<img [^>]*src="([^"]+)"', page)
    assert len(srcs) >= 10
    assert all(s.startswith("data:image/png;base64,") for s in srcs)
    # every internal link points at a heading of the page
    ids = set(re.findall(r'id="([^"]+)"', page))
    assert all(h[1:] in ids for h in re.findall(r'href="([^"]+)"', page))


def test_markdown_twin_references_figures_next_to_it(study):
    md = (study / "report.md").read_text()
    page = (study / "report.html").read_text()
    figs = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", md)
    assert len(figs) == len(re.findall(r"<img ", page))
    for f in figs:
        assert not Path(f).is_absolute() and (study / f).is_file(), f
    for section in ("Provenance", "Relaxation fit", "Motion fit", "The paper's numbers beside ours",
                    "Model comparison", "History modes", "Residual diagnostics", "Discovery of missing effects"):
        assert f"## {section}" in md, section


def test_quoted_and_measured_numbers_never_mix(study):
    md = (study / "report.md").read_text()
    quoted, measured = _panels_md(md)
    paper_values = {fmt(v) for _e, _q, v, _u in PAPER_ROWS}
    for v in ("2.122", "3.339", "0.936", "3.388", "2.137", "3.686", "0.928", "2.148"):
        assert v in paper_values
        assert f"| {v} |" in quoted
        assert f"| {v} |" not in measured
        # the paper's numbers appear nowhere in the report outside the quoted panel
        assert md.count(f"| {v} |") == quoted.count(f"| {v} |")
    assert "quoted" in quoted.lower() or "published" in quoted.lower()
    # measured panel: this run's numbers, from its own files
    by_set = pd.read_csv(study / "compare" / "summary_by_set.csv")
    row = by_set[(by_set.set == "variable_rate") & (by_set.model == "vbmm-fit")].iloc[0]
    assert f"| 1b variable rate, VBMM-fit | RMSE | {fmt(row.rmse_deg)} | deg |" in measured
    page = (study / "report.html").read_text()
    q = page.index('class="panel quoted"')
    m = page.index('class="panel measured"')
    assert q < m and "2.122" in page[q:m] and "2.122" not in page[m:]
    assert "QUOTED" in page and "MEASURED HERE" in page


def test_report_contents(study):
    md = (study / "report.md").read_text()
    assert "bpmid version" in md and "sha256" in md and "| seed | 7 |" in md
    assert "synthetic" in md
    # constants with uncertainties and units
    assert re.search(r"\| E_inf \| [0-9.e+-]+ \| [0-9.e+-]+ \| Pa \|", md)
    assert "VBMM-fit verdict" in md and ("estimated" in md or "not identifiable" in md)
    assert "Ranking by pooled test RMSE" in md
    assert "us_per_step" in md and "window" in md and "full" in md
    assert "lag-1 autocorrelation" in md
    assert ("Named effects" in md) or ("No missing effect found" in md)


def test_report_says_when_a_baseline_wins(study, tmp_path):
    d = tmp_path / "copy"
    shutil.copytree(study, d)
    by_set = pd.read_csv(d / "compare" / "summary_by_set.csv")
    sel = (by_set.set == "variable_rate") & (by_set.model == "two-branch")
    by_set.loc[sel, "rmse_deg"] = 1e-3
    by_set.to_csv(d / "compare" / "summary_by_set.csv", index=False)
    r = runner.invoke(app, ["report", str(d)])
    assert r.exit_code == 0, r.output
    md = (d / "report.md").read_text()
    assert re.search(r"On variable_rate, the baseline two-branch \(0\.001 deg\) beats the best VBMM variant", md)
    assert "On variable_amplitude, the best VBMM variant" in md


def test_report_bad_folder_exit_2(tmp_path):
    r = runner.invoke(app, ["report", str(tmp_path / "absent")])
    assert r.exit_code == 2 and "absent" in r.output
    (tmp_path / "empty").mkdir()
    r = runner.invoke(app, ["report", str(tmp_path / "empty")])
    assert r.exit_code == 2 and "no stage outputs" in r.output
    assert not (tmp_path / "empty" / "report.html").exists()
