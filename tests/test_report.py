"""bpmid report: one self-contained HTML file plus a Markdown twin; quoted and measured numbers kept apart."""
from __future__ import annotations

import re
import shutil
from pathlib import Path

import pandas as pd
import yaml
import pytest
from typer.testing import CliRunner

from bpmid.cli import app
from bpmid.report import PAPER_ROWS, fmt

runner = CliRunner()


@pytest.fixture(scope="module")
def study(timed_small_study):
    """The session's small study (tests/_report_study.py): one fixture, so pytest-xdist keeps its users together."""
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

    return block("**Paper's numbers (quoted, the paper's data)**"), block("**Measured here (bpmid, this run's synthetic data)**")


#: columns of wall-clock timings: measured on this machine, any value, so one can equal a quoted number by chance
TIMING_HEADERS = ("µs per step", "us_per_step", "seconds")


def _without_timings(md: str) -> str:
    """report.md with the cells of wall-clock timing columns blanked (a timing of 2.137 us per step once equalled the
    paper's RMSE 2.137 exactly: a coincidence of this machine's clock, not a quoted number in a measured table)."""
    out, cols = [], None
    for ln in md.splitlines():
        cells = ln.split("|")
        if ln.startswith("|") and cols is None:
            cols = [i for i, c in enumerate(cells) if c.strip().startswith(TIMING_HEADERS)]
        elif not ln.startswith("|"):
            cols = None
        if ln.startswith("|") and cols:
            cells = [" t " if i in cols and not set(c.strip()) <= set("-:") else c for i, c in enumerate(cells)]
        out.append("|".join(cells))
    return "\n".join(out)


def test_timing_cells_are_blanked_only_in_timing_columns():
    md = "| mode | RMSE (°) | µs per step (whole log) |\n|---|---|---|\n| full | 2.137 | 2.137 |\n\n| a | b |\n|---|---|\n| 2.137 | 1 |"
    got = _without_timings(md)
    assert got.count("2.137") == 2 and "| full | 2.137 | t |" in got and "|---|---|---|" in got


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
    for section in ("Summary", "Model", "Provenance", "Relaxation fit", "Motion fit", "The paper's numbers beside ours",
                    "Model comparison", "History modes", "Residual diagnostics", "Discovery of missing effects",
                    "Closed-loop control"):
        assert f"## {section}" in md, section


def test_quoted_and_measured_numbers_never_mix(study):
    md = (study / "report.md").read_text()
    quoted, measured = _panels_md(md)
    paper_values = {fmt(v) for _e, _q, v, _u in PAPER_ROWS}
    for v in ("2.122", "3.339", "0.936", "3.388", "2.137", "3.686", "0.928", "2.148"):
        assert v in paper_values
        assert f"| {v} |" in quoted
        assert f"| {v} |" not in measured
        # the paper's numbers appear nowhere in the report outside the quoted panel (wall-clock timings aside)
        assert _without_timings(md).count(f"| {v} |") == quoted.count(f"| {v} |")
    # a stage's wall time is printed to 0.1 s: it once read "| discover | done | 0.936 |", the paper's R^2 exactly
    stage_rows = re.findall(r"^\| (relax|motion|compare|history|discover|control) \| done \| ([^|]+) \|", md, re.M)
    assert len(stage_rows) == 6 and all(re.fullmatch(r"\d+\.\d", t.strip()) for _s, t in stage_rows), stage_rows
    assert "quoted" in quoted.lower() or "published" in quoted.lower()
    # measured panel: this run's numbers, from its own files
    by_set = pd.read_csv(study / "compare" / "summary_by_set.csv")
    row = by_set[(by_set.set == "variable_rate") & (by_set.model == "vbmm-fit")].iloc[0]
    assert f"| 1b variable rate, VBMM-fit | RMSE | {fmt(row.rmse_deg)} | ° |" in measured
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
    assert "µs per step" in md and "window" in md and "full" in md
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
    assert re.search(r"On variable_rate, the baseline two-branch \(0\.001°\) beats the best VBMM variant", md)
    assert "On variable_amplitude, the best VBMM variant" in md
    # a stage the run recorded as done whose files were deleted since: said to be missing, not "not run"
    shutil.rmtree(d / "discover")
    assert runner.invoke(app, ["report", str(d)]).exit_code == 0
    disc = (d / "report.md").read_text().split("## Discovery of missing effects")[1].split("\n## ")[0]
    assert "Missing: run.yaml records the discover stage as done" in disc and "Not run" not in disc
    # the geometry the fit used, and the discovery scores with and without the per-log factors
    md = (study / "report.md").read_text()
    assert "Muscle geometry (the fit file's): th " in md and "before, no per-log factors" in md
    # synthetic data named with the protocol and seed that made them (the shipped relaxation logs' headers)
    assert "Made by bpmid simulate from the protocols" in md and "protocol relaxation, seed 14062025" in md


def test_report_bad_folder_exit_2(tmp_path):
    r = runner.invoke(app, ["report", str(tmp_path / "absent")])
    assert r.exit_code == 2 and "absent" in r.output
    (tmp_path / "empty").mkdir()
    r = runner.invoke(app, ["report", str(tmp_path / "empty")])
    assert r.exit_code == 2 and "no stage outputs" in r.output
    assert not (tmp_path / "empty" / "report.html").exists()


# --------------------------------------------------------------------------------------------------
# order, control, model, figures (issue 18)
# --------------------------------------------------------------------------------------------------
def test_summary_first_provenance_last_and_collapsed(study):
    md = (study / "report.md").read_text()
    heads = re.findall(r"^## (.+)$", md, re.M)
    assert heads[0] == "Summary" and heads[-1].startswith("Provenance")
    page = (study / "report.html").read_text()
    secs = re.findall(r'<section id="([^"]+)"', page)
    assert secs[0] == "summary" and secs[-1] == "provenance"
    prov = page[page.index('<section id="provenance"'):]
    assert prov.index("<details>") < prov.index("sha256")
    # the summary names what was fitted on what, the ranking, discovery, control, and the data's status
    summ = md[md.index("## Summary"):md.index("## Model")]
    for word in ("SYNTHETIC", "relaxation log", "fitting log", "ranked by pooled test RMSE", "Discovery:",
                 "VBMM-PI", "±"):
        assert word in summ, word


def test_control_section_beside_the_paper_quoted_apart(study):
    md = (study / "report.md").read_text()
    ctl = md[md.index("## Closed-loop control"):md.index("## Provenance")]
    tab = pd.read_csv(study / "control" / "summary.csv")
    vb = tab[(tab.controller == "vbmm-pi") & (tab.reference == "ALL")].iloc[0]
    quoted = ctl[ctl.index("**Paper's control result"):ctl.index("**Measured here")]
    measured = ctl[ctl.index("**Measured here"):]
    assert "| VBMM-PI | RMSE | 2.411 | ° |" in quoted and "52.9" in quoted
    assert f"| VBMM-PI | {fmt(vb.rmse_deg)} |" in measured and "2.411" not in measured
    assert re.search(r"!\[Figure \d+\]\(control/fig18\.png\)", ctl)
    # the study's plant is the controller's own model: the report says the reductions are an ideal case
    cy = yaml.safe_load((study / "control" / "control.yaml").read_text())
    ideal = not cy["plant"]["effects"] and cy["plant"]["model"]["material"] == cy["controller_model"]["material"]
    assert ("an ideal case" in ctl) == ideal


def test_model_equations_as_mathml_and_numbered_captions(study):
    page = (study / "report.html").read_text()
    assert page.count("<math") >= 5 and "<script" not in page
    nums = [int(n) for n in re.findall(r"<b>Figure (\d+)\.</b>", page)]
    assert nums == list(range(1, len(nums) + 1)) and len(nums) == len(re.findall(r"<img ", page))
    md = (study / "report.md").read_text()
    assert "E(t) = E_inf + sum_j E_j exp(-t/tau_j)" in md
    for bad in (" us ", "R^2", "(deg)"):
        assert bad not in md, bad


def test_svg_figures_inlined_one_self_contained_file(study, tmp_path):
    d = tmp_path / "copy"
    shutil.copytree(study, d)
    r = runner.invoke(app, ["report", str(d), "--figures", "svg"])
    assert r.exit_code == 0, r.output
    from bpmid.plots.options import figure_format
    assert figure_format() == "png"     # the command's --figures ends with it (nothing left for the next call)
    for name in ("modulus_curves", "error_bands", "residuals"):
        assert (d / "report_figures" / f"{name}.svg").is_file()
    page = (d / "report.html").read_text()
    n_fig = len(re.findall(r"<figure ", page))
    n_svg = len(re.findall(r"<figure [^>]*>\s*<svg", page))
    assert n_svg >= 3 and n_svg + len(re.findall(r"<img ", page)) == n_fig
    assert "<?xml" not in page and "<!DOCTYPE svg" not in page and "<script" not in page.lower()
    assert not re.search(r'(?:href|src)\s*=\s*"(?:https?:|//|file:)', page)
    ids = re.findall(r'\bid="([^"]+)"', page)
    assert len(ids) == len(set(ids)), "ids repeat between inlined figures"
    # every url(#x) / href="#x" points at an id of the page
    refs = set(re.findall(r'url\(#([^)]+)\)', page)) | set(re.findall(r'href="#([^"]+)"', page))
    assert refs <= set(ids)


# --------------------------------------------------------------------------------------------------
# partial and stale folders (issue 15, item 7)
# --------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def broken(study, tmp_path_factory):
    """One copy of the study with every kind of damage at once (one report call for the tests below):
    partial files (relax_fit.yaml with only its schema line, a header-only compare/summary.csv), wrong types
    inside history_modes.yaml, and discover/control left over from an earlier run (run.yaml says skipped)."""
    import yaml

    d = tmp_path_factory.mktemp("broken") / "study"
    shutil.copytree(study, d)
    (d / "relax_fit.yaml").write_text("schema: bpmid.relax/1\n")
    (d / "compare" / "summary.csv").write_text("model,rmse_deg,mape_pct,r2\n")
    (d / "history_modes.yaml").write_text("schema: bpmid.history_modes/1\naccuracy: [1, 2]\nwindow_s: fast\n"
                                          "window_vs_full: 3\nus_per_step_longest: [x]\n")
    run = yaml.safe_load((d / "run.yaml").read_text())
    for s in run["stages"]:
        if s["name"] in ("discover", "control"):
            s.update(status="skipped", seconds=None, outputs=[], note="not in run.stages")
    (d / "run.yaml").write_text(yaml.safe_dump(run, sort_keys=False))
    r = runner.invoke(app, ["report", str(d)])
    return d, r


def test_partial_stage_files_named_and_the_rest_built(broken):
    d, r = broken
    assert r.exit_code == 0, r.output
    assert "relax_fit.yaml" in r.output and "compare/summary.csv" in r.output and "warning" in r.output
    md = (d / "report.md").read_text()
    assert "Incomplete: relax_fit.yaml: partial" in md and "Incomplete: compare/summary.csv: partial" in md
    assert "## Motion fit" in md and "Not available: relax_fit.yaml is unusable (partial" in md
    assert "Not available: compare/summary.csv is unusable (partial" in md
    assert "VBMM-fit: refitted" in md  # the stages that are whole are reported


def test_hostile_values_inside_a_file_never_crash_the_report(broken):
    d, r = broken
    assert r.exit_code == 0, r.output
    md = (d / "report.md").read_text()
    assert "## History modes" in md and "## Discovery of missing effects" in md and "## Provenance" in md


def test_stale_stages_from_an_earlier_run_are_marked(broken):
    d, r = broken
    assert "stage discover" in r.output and "stage control" in r.output
    md = (d / "report.md").read_text()
    summ = md[md.index("## Summary"):md.index("## Model")]
    assert "Stale: stage discover" in summ and "Control (STALE: from an earlier run)" in summ
    disc = md[md.index("## Discovery of missing effects"):md.index("## Closed-loop control")]
    assert "STALE:" in disc
    ctl = md[md.index("## Closed-loop control"):md.index("## Provenance")]
    assert "STALE:" in ctl
    motion = md[md.index("## Motion fit"):md.index("## Model comparison")]
    assert "STALE:" not in motion


def test_nothing_usable_exit_2_naming_the_files(tmp_path):
    d = tmp_path / "only_partial"
    d.mkdir()
    (d / "relax_fit.yaml").write_text("schema: bpmid.relax/1\n")
    r = runner.invoke(app, ["report", str(d)])
    assert r.exit_code == 2 and "relax_fit.yaml" in r.output and "partial" in r.output
    assert not (d / "report.html").exists()


def test_correlations_of_both_fits_are_shown(study):
    md = (study / "report.md").read_text()
    relax = md[md.index("## Relaxation fit"):md.index("## Motion fit")]
    motion = md[md.index("## Motion fit"):md.index("## Model comparison")]
    assert "Parameter correlations" in relax and "| tau_1 |" in relax
    assert "Correlations of the estimated VBMM-fit constants" in motion


def test_pdf_figures_with_png_twins_for_the_page(study, tmp_path):
    d = tmp_path / "pdf"
    shutil.copytree(study, d)
    r = runner.invoke(app, ["report", str(d), "--figures", "pdf"])
    assert r.exit_code == 0, r.output
    for name in ("modulus_curves", "error_bands", "residuals"):
        pdf = d / "report_figures" / f"{name}.pdf"
        assert pdf.read_bytes()[:5] == b"%PDF-" and pdf.with_suffix(".png").is_file()
    md = (d / "report.md").read_text()
    assert "(report_figures/residuals.pdf)" in md
    page = (d / "report.html").read_text()
    assert "<script" not in page and page.count("data:image/png;base64,") == len(re.findall(r"<figure ", page))


def test_loaders_take_wrong_types_inside_a_file(tmp_path):
    """A discovery.yaml with values of the wrong type: read, shown, never a traceback (no figures drawn)."""
    from bpmid.report import build_report, read_study, render_markdown

    (tmp_path / "discover").mkdir()
    (tmp_path / "discover" / "discovery.yaml").write_text(
        "schema: bpmid.discovery/1\ngap: {before_rmse_deg: x, after_rmse_deg: [1]}\nnamed_effects: 5\n"
        "steps: [1, {id: a, evidence: {z: 1}}]\nverdict: 7\n")
    (tmp_path / "relax_fit.yaml").write_text("schema: bpmid.relax/1\nprony: {E_inf: 1.0, terms: {E: 2}}\n"
                                             "uncertainty: {parameters: [a, b], correlation: [[1, x]]}\n")
    st = read_study(tmp_path)
    assert st.discovery is not None and st.discovery.named == [] and st.discovery.before_deg is None
    assert st.relax is not None and st.relax.corr == [] and [p.name for p in st.relax.constants] == ["E_inf"]
    md = render_markdown(build_report(st, {}), "t")
    assert "## Discovery of missing effects" in md and "| a |" in md and "## Relaxation fit" in md


# --------------------------------------------------------------------------------------------------
# a stage file another command wrote into a run's folder (new-user review, item 2)
# --------------------------------------------------------------------------------------------------
STAGE_YAMLS = ("relax_fit.yaml", "vbmm_fit.yaml", "vbmm_mat.yaml", "compare/compare.yaml", "history_modes.yaml",
               "discover/discovery.yaml", "control/control.yaml")


def test_every_file_of_a_run_carries_the_run_s_id(study):
    import yaml

    rid = yaml.safe_load((study / "run.yaml").read_text())["provenance"]["run_id"]
    assert isinstance(rid, str) and len(rid) >= 16
    for f in STAGE_YAMLS:
        assert yaml.safe_load((study / f).read_text())["provenance"]["run_id"] == rid, f
    md = (study / "report.md").read_text()
    assert "STALE" not in md and f"| run id | {rid} |" in md


def test_a_stage_another_command_rewrote_is_marked_with_what_to_do(study, tmp_path, monkeypatch):
    """`bpmid compare --out DIR/compare` after `bpmid run --out DIR`: run.yaml still lists compare as done, but
    compare/ now holds another command's comparison (other logs, other models); the report says so."""
    import sys

    import yaml

    d = shutil.copytree(study, tmp_path / "study")
    r = runner.invoke(app, ["report", str(d)])  # a plain copy of a run: nothing to flag
    assert r.exit_code == 0 and "warning" not in r.output, r.output
    assert "STALE" not in (d / "report.md").read_text()
    logs = study.parent / "logs"
    args = ["compare", "--train", str(logs / "fit_a.csv"), "--test", str(logs / "rate_0p114.csv"), "--models",
            "vbmm-mat", "--out", str(d / "compare")]
    monkeypatch.setattr(sys, "argv", ["bpmid", *args])  # the command line the provenance records
    r = runner.invoke(app, args)
    assert r.exit_code == 0, r.output
    r = runner.invoke(app, ["report", str(d)])
    assert r.exit_code == 0, r.output
    out = " ".join(r.output.split())
    assert "warning: stage compare: compare/compare.yaml was written by `bpmid compare --train" in out
    rid = yaml.safe_load((d / "run.yaml").read_text())["provenance"]["run_id"]
    assert "not by the run that run.yaml records (`" in out and f", run id {rid})" in out
    assert "rerun `bpmid run` into this folder" in out
    md = (d / "report.md").read_text()
    summ = md[md.index("## Summary"):md.index("## Model")]
    assert "Stale: stage compare: compare/compare.yaml was written by `bpmid compare" in summ
    assert "Comparison (STALE: not from the run in run.yaml)" in summ and "VBMM-fit: refitted" in summ
    comp = md[md.index("## Model comparison"):md.index("## The paper's numbers")]
    assert comp.count("STALE: compare/compare.yaml was written by") == 1
    for title, nxt in (("## The paper's numbers", "## History modes"), ("## Residual diagnostics", "## Discovery")):
        assert "STALE: the " in md[md.index(title):md.index(nxt)], title
    for title, nxt in (("## Motion fit", "## Model comparison"), ("## History modes", "## Residual diagnostics"),
                       ("## Discovery", "## Closed-loop control")):
        assert "STALE" not in md[md.index(title):md.index(nxt)], title
    assert "| compare | done; its files were since replaced by another command (STALE) |" in md


def test_provenance_decides_which_stage_files_are_the_run_s(study, tmp_path):
    """By run id; for a run.yaml without one (written before runs stamped it), by command and config."""
    import yaml

    from bpmid.report import read_study

    d = shutil.copytree(study, tmp_path / "study", ignore=shutil.ignore_patterns("*.png", "*.html", "traces"))

    def edit(rel, **prov):
        data = yaml.safe_load((d / rel).read_text())
        for k, v in prov.items():
            if v is None:
                data["provenance"].pop(k, None)
            else:
                data["provenance"][k] = v
        (d / rel).write_text(yaml.safe_dump(data, sort_keys=False))

    edit("vbmm_mat.yaml", run_id="0123456789abcdef")  # the same command, run again: another run's file
    st = read_study(d)
    assert set(st.stale) == {"motion"} and st.foreign == {"motion"}
    assert "vbmm_mat.yaml was written by another run of the same command (run id 0123456789abcdef" in st.stale["motion"]
    edit("history_modes.yaml", run_id=None, command="bpmid run elsewhere.yaml")  # a bpmid without run ids
    assert set(read_study(d).stale) == {"motion", "history"}
    for rel in STAGE_YAMLS + ("run.yaml",):  # a whole run written before run ids: command and config decide
        edit(rel, run_id=None)
    st = read_study(d)
    assert set(st.stale) == {"history"} and "`bpmid run elsewhere.yaml`" in st.stale["history"]
    cfg = yaml.safe_load((d / "run.yaml").read_text())["provenance"]["config"]
    edit("history_modes.yaml", command=yaml.safe_load((d / "run.yaml").read_text())["provenance"]["command"])
    assert read_study(d).stale == {}
    edit("control/control.yaml", config=dict(cfg, sha256="0" * 64))  # same command, another config
    assert set(read_study(d).stale) == {"control"}


# --------------------------------------------------------------------------------------------------
# a folder of single commands without vbmm_fit.yaml (new-user review, item 10)
# --------------------------------------------------------------------------------------------------
def test_a_motion_fit_under_another_name_is_read_and_no_placeholder_is_printed(study, tmp_path):
    """`bpmid fit relax --out relax_fit.yaml` and `bpmid fit motion --out VBMM.yaml` (the README's names) in one
    folder: the report reads the fit from VBMM.yaml; it never prints '?' for what a file does not say."""
    import yaml

    from bpmid.report import build_report, read_study, render_markdown

    fit = yaml.safe_load((study / "vbmm_fit.yaml").read_text())
    d = tmp_path / "single"
    d.mkdir()
    shutil.copy(study / "relax_fit.yaml", d / "relax_fit.yaml")
    shutil.copy(study / "vbmm_fit.yaml", d / "VBMM.yaml")
    shutil.copy(study / "vbmm_fit.png", d / "VBMM.png")
    r = runner.invoke(app, ["report", str(d)])
    assert r.exit_code == 0 and "warning" not in r.output, r.output
    md = (d / "report.md").read_text()
    assert "'?'" not in md and "closure ?" not in md
    assert (f"This study's motion fit (VBMM.yaml) used the '{fit['closure']}' closure and the "
            f"'{fit['model']['history']}' history mode." in md)
    motion = md[md.index("## Motion fit"):md.index("## Model comparison")]
    assert "VBMM-fit read from VBMM.yaml" in motion and "(VBMM.png)" in motion and "| K_inf |" in motion
    assert "VBMM-fit (VBMM.yaml): refitted on" in md

    def model_text(folder):
        md = render_markdown(build_report(read_study(folder), {}), "t")
        assert "?" not in md[md.index("## Model"):md.index("## Relaxation fit")]
        return " ".join(md.split())

    (d / "VBMM.yaml").unlink()  # only the relaxation fit: the sentence says what is missing
    assert "No motion fit in this folder (vbmm_fit.yaml, or one bpmid.vbmm/1 fit" in model_text(d)
    del fit["closure"], fit["model"]["history"]  # a fit that does not say: named keys, no placeholder
    (d / "vbmm_fit.yaml").write_text(yaml.safe_dump(fit, sort_keys=False))
    assert ("This study's motion fit (vbmm_fit.yaml) does not state its closure or its history mode (no key "
            "closure, model.history)." in model_text(d))
    (d / "vbmm_fit.yaml").rename(d / "A.yaml")
    shutil.copy(d / "A.yaml", d / "B.yaml")  # two candidates: which one is meant is not guessed
    assert "no vbmm_fit.yaml but 2 bpmid.vbmm/1 motion fits (A.yaml, B.yaml)" in model_text(d)



def test_the_ideal_plant_line_needs_the_whole_model_the_same():
    from pathlib import Path as _P

    from bpmid.report.inputs import ControlInfo

    model = {"geometry": {"th": 0.002, "l0": 0.1959}, "closure": "paper", "material": {"K_inf": 1.0},
             "model": {"history": "recursive"}}
    same = ControlInfo(_P("."), pd.DataFrame(), {}, 10.0, {}, [], {}, {"model": model, "effects": []}, model)
    other = dict(model, geometry={"th": 0.002, "l0": 0.25})
    moved = ControlInfo(_P("."), pd.DataFrame(), {}, 10.0, {}, [], {}, {"model": other, "effects": []}, model)
    assert same.plant_is_the_model and not moved.plant_is_the_model


def test_the_control_lines_name_the_user_s_references_and_the_plant():
    """The summary said 'the shipped references' for a user's CSV, and named no plant effect or scale."""
    from pathlib import Path as _P

    from bpmid.report.inputs import ControlInfo

    plant = {"model": {}, "modulus_scale": 1.05, "tau_scale": 0.9,
             "effects": [{"id": "pressure_lag", "parameters": {"tau": {"value": 0.1, "unit": "s"}}}]}
    mine = ControlInfo(_P("."), pd.DataFrame(), {}, 10.0, {}, [], {}, plant, {},
                       [{"name": "ref100hz", "source": "/home/me/ref100hz.csv", "resampled": "logged every 0.01 s"}])
    shipped = ControlInfo(_P("."), pd.DataFrame(), {}, 10.0, {}, [], {}, {"model": {}}, {},
                          [{"name": "steps", "source": "built in"},
                           {"name": "sines", "source": "/x/bpmid/datasets/control/sines.csv"}])
    assert not mine.references_shipped and shipped.references_shipped
    assert mine.plant_words() == "moduli x 1.05; time constants x 0.9; pressure_lag (tau = 0.1 s)"
    assert shipped.plant_words() == ""


def test_a_deleted_stage_file_a_cut_summary_and_another_version_are_said(study, tmp_path):
    """A run folder whose vbmm_fit.yaml was deleted (the report fell back to VBMM-mat silently), whose summary was
    cut to two models (ranked as if those were all), and whose run.yaml says another schema: each is a warning on
    stderr and the report is still written (exit 0)."""
    out = tmp_path / "copy"
    shutil.copytree(study, out)
    (out / "vbmm_fit.yaml").unlink()
    lines = (out / "compare" / "summary.csv").read_text().splitlines()
    (out / "compare" / "summary.csv").write_text("\n".join(lines[:3]) + "\n")
    run = (out / "run.yaml").read_text().replace("schema: bpmid.run/1", "schema: bpmid.run/2")
    (out / "run.yaml").write_text(run)
    r = CliRunner().invoke(app, ["report", str(out)])
    assert r.exit_code == 0, r.output
    err = r.stderr if hasattr(r, "stderr") else r.output
    assert "vbmm_fit.yaml: missing, though run.yaml records its stage as done" in err, err
    assert "Missing: run.yaml records the motion stage as done" in (out / "report.md").read_text()
    assert "compare/summary.csv: partial: ranks 2 of the" in err, err
    assert "run.yaml: written by another version of bpmid (schema bpmid.run/2" in err, err
    assert (out / "report.html").is_file()


def test_report_on_a_control_folder_reads_it_as_control(tmp_path):
    """bpmid report on the folder bpmid control wrote: its summary.csv is the controllers' (it was read as a
    comparison and refused: 'summary.csv: partial: no column model')."""
    from test_simulate_predict_review import TRUTH

    params = tmp_path / "vbmm.yaml"
    params.write_text(TRUTH % (6.434e6, 3.2e6))
    r = CliRunner().invoke(app, ["control", "--params", str(params), "--reference", "steps", "--controller", "pi",
                                 "--out", str(tmp_path / "ctl"), "--no-figure"])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(app, ["report", str(tmp_path / "ctl")])
    assert r.exit_code == 0 and "no column model" not in r.output, r.output
    md = (tmp_path / "ctl" / "report.md").read_text()
    assert "## Closed-loop control" in md and "Control (closed loop" in md


def test_the_study_s_synthetic_wording_is_recorded_and_kept_wherever_the_report_is_made(study, tmp_path, monkeypatch):
    """The small study's motion logs say 'synthetic: true (test twin)', not the twin's words: the run records its
    stamp in run.yaml, and the report, made again from another folder (the inputs' relative paths then resolve
    nowhere), still says 'their own headers' and never 'made by bpmid's digital twin'."""
    import yaml

    run = yaml.safe_load((study / "run.yaml").read_text())
    assert run["synthetic_stamp"] == "synthetic data (the logs' own headers say so)"
    d = tmp_path / "copy"
    shutil.copytree(study, d)
    monkeypatch.chdir(tmp_path)
    assert runner.invoke(app, ["report", str(d)]).exit_code == 0
    md = (d / "report.md").read_text()
    assert "synthetic (their own headers say so)" in md and "made by bpmid's digital twin" not in md


def _discovery_folder(study, tmp_path, *, sha: str, protocol: str = "mymuscle"):
    """A copy of the small study's discover folder whose model.yaml runs pressure_lag on another muscle, and whose
    logs sit beside a manifest.yaml naming ``protocol`` with the sha256 ``sha``."""
    d = tmp_path / "d_geo"
    shutil.copytree(study / "discover", d)
    logs = tmp_path / "sim"
    logs.mkdir()
    model = yaml.safe_load((d / "model.yaml").read_text())
    disc = yaml.safe_load((d / "discovery.yaml").read_text())
    inputs = {}
    for path, digest in model["provenance"]["inputs"].items():
        if Path(path).suffix == ".csv":
            shutil.copy(path, logs / Path(path).name)
            inputs[str(logs / Path(path).name)] = digest
    (logs / "manifest.yaml").write_text(yaml.safe_dump({
        "schema": "bpmid.simulation/1", "protocol": {"name": protocol, "kind": "motion", "sha256": sha},
        "logs": [{"file": Path(p).name} for p in inputs]}))
    for body in (model, disc):
        body["provenance"]["inputs"] = inputs
    model["geometry"]["th"] = 0.0025
    model["effects"] = [{"id": "pressure_lag", "settings": {"dead_time": 0.0}, "parameters": {
        "tau": {"value": 0.0901, "stderr": None, "unit": "s", "fixed": True, "identifiable": False,
                "note": "not identifiable: relative standard error 53% > 50%; kept at 0.0901, its start"},
        "share": {"value": 0.5, "stderr": None, "unit": "1", "fixed": True},
        "sat": {"value": 0.0, "stderr": None, "unit": "1/kPa", "fixed": True}}}]
    model["fit"]["named_effects"] = ["pressure_lag"]
    (d / "model.yaml").write_text(yaml.safe_dump(model, sort_keys=False))
    (d / "discovery.yaml").write_text(yaml.safe_dump(disc, sort_keys=False))
    return d, model


def test_report_on_a_discovery_folder_states_what_its_files_record(study, tmp_path):
    """bpmid report on a discover folder (new-user trial): the fit was refitted on its fitting logs (it said 0), the
    constants discovery does not refit are held at the starting model's values (it said 'prior (relaxation)'), the
    motion fit says it runs pressure_lag, and the paper panel says the protocols and muscle differ (it said 'the
    same protocols')."""
    import hashlib

    from bpmid import data

    d, model = _discovery_folder(study, tmp_path, sha="0" * 64)
    r = runner.invoke(app, ["report", str(d)])
    assert r.exit_code == 0, r.output
    md = " ".join((d / "report.md").read_text().split())
    names = [lg["name"] for lg in model["fit"]["logs"]]
    assert f"refitted by bpmid discover on {len(names)} fitting log(s) ({', '.join(names)})" in md
    assert "0 fitting log(s)" not in md and "prior (relaxation)" not in md
    assert "the rest held at the starting model's values (vbmm_fit.yaml (motion fit of this run))" in md
    assert "VBMM-fit with pressure_lag (model.yaml)" in md and "pressure_lag (tau = 0.0901 s, share = 0.5" in md
    motion = md[md.index("## Motion fit"):md.index("## Model comparison")]
    assert "model.yaml runs the VBMM with the effect(s) pressure_lag" in motion
    assert "| pressure_lag.tau | 0.0901 | - | s | not identifiable: relative standard error 53%" in motion
    assert "dead_time = 0 s" in motion and "with pressure_lag acting: RMSE" in motion
    assert "| G_inf | - |" in motion and "held at the starting model's value (discovery refits" in motion
    paper = md[md.index("## The paper's numbers"):md.index("**Paper's numbers")]
    assert "same protocols" not in paper
    assert "follow other protocols than the paper's (mymuscle, as the manifest.yaml beside them records)" in paper
    assert "this study's muscle is not the paper's" in paper and "th 2.5 mm against 2 mm" in paper
    # logs made from a shipped protocol file (its sha256): the paper's protocols, said as such
    shipped = hashlib.sha256(data.path("configs/datasets/fitting_set.yaml").read_bytes()).hexdigest()
    d2, _ = _discovery_folder(study, tmp_path / "b", sha=shipped, protocol="fitting_set")
    assert runner.invoke(app, ["report", str(d2)]).exit_code == 0
    md = " ".join((d2 / "report.md").read_text().split())
    assert "this study's logs follow the paper's protocols (bpmid's shipped fitting_set" in md
    # discovery's cautions reach the summary, not only the Discovery section (a log of another muscle mixed in)
    disc = yaml.safe_load((d2 / "discovery.yaml").read_text())
    disc["cautions"] = ["fitting log x.csv bends 31% more than the model predicts at its pressures, against the other "
                        "logs (the least-squares scale ...): runs of one muscle differ by a few per cent"]
    (d2 / "discovery.yaml").write_text(yaml.safe_dump(disc, sort_keys=False))
    assert runner.invoke(app, ["report", str(d2)]).exit_code == 0
    md = " ".join((d2 / "report.md").read_text().split())
    summary = md[md.index("## Summary"):md.index("## Summary") + 3000]
    assert ("Read its 1 caution(s) before the verdict (Discovery, below): fitting log x.csv bends 31% more than the "
            "model predicts at its pressures, against the other logs.") in summary


def test_report_into_a_folder_another_command_is_writing_waits_then_is_refused(tmp_path, monkeypatch):
    """`bpmid report DIR` while `bpmid run --out DIR` was writing DIR built a report from the half-written folder,
    wrote it beside the run's files and said nothing; the folder has one writer at a time (docs/robustness.md)."""
    from _holders import held_by_another_process

    from bpmid.io import atomic
    from test_simulate_predict_review import TRUTH

    params = tmp_path / "vbmm.yaml"
    params.write_text(TRUTH % (6.434e6, 3.2e6))
    ctl = tmp_path / "ctl"
    r = runner.invoke(app, ["control", "--params", str(params), "--reference", "steps", "--controller", "pi",
                            "--out", str(ctl), "--no-figure"])
    assert r.exit_code == 0, r.output
    with held_by_another_process(ctl):
        monkeypatch.setattr(atomic, "COMMIT_WAIT_S", 0.2)
        r = runner.invoke(app, ["report", str(ctl)])
        assert r.exit_code == 2 and "another bpmid command is writing into this folder" in r.output, r.output
        assert "then report again" in r.output and "--out" not in r.output   # report has no --out to choose
        assert not (ctl / "report.html").exists() and not (ctl / "report.md").exists()
    r = runner.invoke(app, ["report", str(ctl)])   # free again
    assert r.exit_code == 0 and (ctl / "report.html").is_file(), r.output


def _measured_panel_title(*, synthetic, twin, protocols):
    """The title the paper section gives its MEASURED HERE panel for a study whose files say what is stubbed."""
    import types

    from bpmid.report.doc import Doc
    from bpmid.report.sections import paper as paper_section

    st = types.SimpleNamespace(synthetic=synthetic, made_by_twin=lambda: twin, protocols=lambda: protocols,
                               motion=None, relax=None, compare=None, history=None, stale=())
    doc = Doc()
    paper_section.build(doc, st, figs=None)
    panels = [b.text for b in doc.sections[-1].blocks if b.kind == "panel"]
    assert len(panels) == 2, panels
    return panels[1]


def test_the_measured_panel_calls_data_shipped_only_when_they_follow_the_shipped_protocols():
    """A user's own muscle simulated with bpmid simulate (their own protocols, or files without a manifest beside
    them) is this run's synthetic data; a trial's report on such a study titled it 'synthetic shipped data'."""
    mine = _measured_panel_title(synthetic=True, twin=True, protocols=([], ["my_fitting", "my_rate"], 0))
    assert "shipped" not in mine and mine == "Measured here (bpmid, this run's synthetic data, made by bpmid's digital twin)"
    no_manifest = _measured_panel_title(synthetic=True, twin=True, protocols=([], [], 12))
    assert "shipped" not in no_manifest
    mixed = _measured_panel_title(synthetic=True, twin=True, protocols=(["fitting_set"], [], 3))
    assert "shipped" not in mixed
    assert _measured_panel_title(synthetic=True, twin=True, protocols=(["fitting_set", "relaxation"], [], 0)) == \
        "Measured here (bpmid, synthetic shipped data)"
    assert _measured_panel_title(synthetic=True, twin=False, protocols=([], [], 5)) == \
        "Measured here (bpmid, this run's synthetic data)"
    assert _measured_panel_title(synthetic=False, twin=False, protocols=([], [], 5)) == \
        "Measured here (bpmid, this run's data)"
