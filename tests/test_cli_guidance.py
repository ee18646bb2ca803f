"""What a new user meets beside the numbers (a new-user review's findings): messages that name the files and say
what works, counts and notes that are true, results that read back with their verdicts."""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

import bpmid
from bpmid.cli import app
from bpmid.models.vbmm import VBMM, Material, vbmm_yaml_body

REPO = Path(__file__).resolve().parents[1]
FIT_LOG = REPO / "datasets" / "motion" / "fitting_set" / "fit_1p2_1p6_r1.csv"
RELAX = sorted((REPO / "datasets" / "relaxation").glob("*.csv"))
runner = CliRunner()


def _params(tmp_path: Path) -> Path:
    p = tmp_path / "VBMM.yaml"
    data = {"schema": "bpmid.vbmm/1", **vbmm_yaml_body(VBMM(material=Material.paper_fit()))}
    p.write_text(yaml.safe_dump(data, sort_keys=False))
    return p


def test_predict_and_export_count_the_files_they_wrote(tmp_path):
    params = _params(tmp_path)
    r = runner.invoke(app, ["predict", str(FIT_LOG), "--params", str(params), "--out", str(tmp_path / "p")])
    assert r.exit_code == 0, r.output
    written = sorted(f.name for f in (tmp_path / "p").iterdir())
    line = [ln for ln in r.output.splitlines() if ln.startswith("wrote ")][0]
    assert line.startswith(f"wrote {len(written)} files") and all(n in line for n in written)
    r = runner.invoke(app, ["export", str(params), "--to", "c", "--out", str(tmp_path / "c")])
    assert r.exit_code == 0, r.output
    assert "wrote 3 files" in r.output and "1 files" not in r.output


def test_logs_sharing_a_file_name_are_refused_naming_both_paths(tmp_path):
    for d in ("a", "b"):
        (tmp_path / d).mkdir()
        shutil.copy(FIT_LOG, tmp_path / d / "run.csv")
    params = _params(tmp_path)
    r = runner.invoke(app, ["predict", str(tmp_path / "a" / "run.csv"), str(tmp_path / "b" / "run.csv"),
                            "--params", str(params), "--out", str(tmp_path / "out")])
    assert r.exit_code == 2
    text = " ".join(r.output.split())
    assert str(tmp_path / "a" / "run.csv") in text.replace("\n", "") or "a/run.csv" in text
    assert "rename" in text and not (tmp_path / "out").exists()


def test_simulate_given_a_fit_says_it_is_no_protocol(tmp_path):
    r = runner.invoke(app, ["simulate", str(_params(tmp_path)), "--out", str(tmp_path / "s")])
    assert r.exit_code == 2
    assert "bpmid.vbmm/1 result, not a protocol" in r.output and "--params" in r.output
    assert "Traceback" not in r.output and not (tmp_path / "s").exists()


def test_strict_refusal_reads_once_and_says_what_to_do(tmp_path):
    # a log whose times are milliseconds under a seconds header: a warning, refused by --strict
    lines = FIT_LOG.read_text().splitlines()
    head = [ln for ln in lines if ln.startswith("#") or not ln[:1].isdigit()]
    body = [ln for ln in lines if ln[:1].isdigit()]
    ms = [",".join([str(int(round(float(ln.split(",")[0]) * 1000)))] + ln.split(",")[1:]) for ln in body]
    (tmp_path / "ms.csv").write_text("\n".join(head + ms) + "\n")
    r = runner.invoke(app, ["predict", str(tmp_path / "ms.csv"), "--params", str(_params(tmp_path)), "--out",
                            str(tmp_path / "o"), "--strict"])
    assert r.exit_code == 2, r.output
    err = [ln for ln in r.output.splitlines() if ln.startswith("error")][0]
    assert "--strict: " not in err and "refused by --strict" in err     # the key once, then the words
    assert "leave out --strict" in err and not (tmp_path / "o").exists()


def test_fit_relax_max_error_nobody_meets_is_said_so_and_the_fewest_terms_chosen(tmp_path):
    r = runner.invoke(app, ["fit", "relax", *map(str, RELAX), "--max-error", "0.0001", "--no-figure",
                            "--out", str(tmp_path / "r.yaml")])
    assert r.exit_code == 0, r.output
    assert "none meets --max-error 0.0001 %" in r.output and "the fewest that meet" not in r.output
    rows = [ln.split() for ln in r.output.splitlines() if ln.strip()[:1].isdigit() and len(ln.split()) in (2, 3)]
    errs = {int(x[0]): float(x[1]) for x in rows}
    chosen = [int(x[0]) for x in rows if x[-1] == "*"]
    assert len(chosen) == 1 and chosen[0] == min(m for m, e in errs.items() if e <= min(errs.values()) * 1.001)
    assert f"up to 32 terms" not in r.output    # only the terms tried are named
    tried = max(errs)
    assert (f"1-{tried} terms" if tried > 1 else "1 term") in " ".join(r.output.split())


def test_fit_motion_plot_suffix_against_figures_format_is_noted(tmp_path):
    r = runner.invoke(app, ["fit", "motion", str(FIT_LOG), "--out", str(tmp_path / "v.yaml"), "--plot",
                            str(tmp_path / "fig.png"), "--figures", "svg"])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "fig.png").is_file() and "note: --plot" in r.output and "--figures svg" in r.output
    r = runner.invoke(app, ["fit", "motion", str(FIT_LOG), "--out", str(tmp_path / "w.yaml"), "--plot",
                            str(tmp_path / "fig.svg"), "--figures", "svg"])
    assert r.exit_code == 0 and "note: --plot" not in r.output


def test_compare_says_when_vbmm_mat_ran_on_the_papers_constants(tmp_path):
    test_log = REPO / "datasets" / "motion" / "variable_rate" / "rate_0p114_r1.csv"
    r = runner.invoke(app, ["compare", "--train", str(FIT_LOG), "--test", str(test_log), "--models", "vbmm-mat",
                            "--out", str(tmp_path / "c")])
    assert r.exit_code == 0, r.output
    assert "vbmm-mat ran on the paper's printed constants" in r.output


def test_results_read_back_with_their_verdicts_and_print_short():
    # a parameter a file marks not identifiable or fixed reads so in the summary, whatever result holds it
    from bpmid.results import _entry

    assert _entry("tau_1", {"value": 0.01, "stderr": 0.7, "unit": "s", "identifiable": False,
                            "note": "not identifiable: relative standard error >1000%"}).identifiability \
        .startswith("not identifiable")
    assert _entry("G_inf", {"value": 9e3, "stderr": None, "unit": "Pa", "fixed": True}).identifiability == "fixed"
    assert _entry("K_inf", {"value": 6e6, "stderr": 1.0, "unit": "Pa", "identifiable": True}).identifiability \
        == "estimated"
    assert _entry("x", {"value": 1.0, "stderr": None, "unit": "1"}).identifiability == ""
    t = np.arange(2000) * 0.01
    lg = bpmid.from_arrays(t, np.linspace(0.2, 1.0, t.size), np.linspace(10, 40, t.size), pressure_unit="bar",
                           reference="gauge")
    text = repr(lg)
    assert len(text) < 200 and "2000 samples" in text and "100 Hz" in text and "0.2..1 bar" in text


def test_a_relaxation_file_with_the_contracts_keys_only_reads_its_term_count(tmp_path):
    p = tmp_path / "min_relax.yaml"
    p.write_text("schema: bpmid.relax/1\nmode: ramp\nprony:\n  E_inf: {value: 26543.86, stderr: null, unit: Pa}\n"
                 "  terms:\n  - E: {value: 54501.97, stderr: null, unit: Pa}\n"
                 "    tau: {value: 0.38579, stderr: null, unit: s}\npoisson_ratio: 0.49933\n"
                 "metrics: {rmse: 326.2, r2: 0.98, mape_pct: 4.16}\n")
    text = repr(bpmid.load(p))
    assert "None" not in text and "1 term(s)" in text
