"""Every figure the package draws: no text box overlaps another text or leaves the canvas; the house style
is shipped with the package; pressure is gauge everywhere; synthetic figures carry the stamp."""
from __future__ import annotations

import matplotlib
import matplotlib.pyplot as plt
import pytest

from _report_study import shared_study

#: every figure a bpmid run (plus predict) writes
EXPECTED = {"relax_fit.png", "vbmm_fit.png", "compare_timeseries.png", "compare_loops.png", "compare_errors.png",
            "compare_summary.png", "history_modes.png", "residual_before_after.png", "screening_ranking.png",
            "heldout_error.png", "fig18.png", "modulus_curves.png", "error_bands.png", "residuals.png", "predict.png"}


@pytest.fixture(scope="module")
def figures(timed_small_study, tmp_path_factory):
    return shared_study(tmp_path_factory)[1]


def test_every_figure_was_drawn_and_checked(figures):
    assert EXPECTED <= set(figures), sorted(EXPECTED - set(figures))


def test_no_text_overlaps_or_leaves_the_canvas(figures):
    bad = {name: probs for name, probs in figures.items() if probs}
    assert not bad, "\n".join(f"{n}: {p}" for n, ps in bad.items() for p in ps[:5])


def test_checker_finds_overlap_and_clipping():
    """The checker itself fails on a figure with the defects it looks for."""
    from bpmid.plots.check import text_problems
    from bpmid.plots.common import new_figure

    fig, ax = new_figure(1, 1, width=4, height=3)
    ax.set_title("a title")
    ax.text(0.5, 1.0, "a stamp right on the title", transform=ax.transAxes, ha="center", va="bottom", fontsize=12)
    fig.text(0.99, 0.5, "runs off the right edge of the canvas", fontsize=12)
    probs = text_problems(fig)
    plt.close(fig)
    assert any("overlap" in p for p in probs)
    assert any("leaves the canvas" in p for p in probs)


def test_house_style_ships_with_the_package():
    from bpmid.plots import common

    assert common.style_path().is_file() and common.style_path().suffix == ".mplstyle"
    common.style()
    cyc = matplotlib.rcParams["axes.prop_cycle"].by_key()
    assert cyc["color"][0].lower() in ("#0072b2", "0072b2") and len(set(map(str, cyc["linestyle"]))) >= 3
    assert not matplotlib.rcParams["figure.constrained_layout.use"]


def test_gauge_pressure_and_stamp_in_footer():
    from bpmid.plots.check import text_problems
    from bpmid.plots.common import PRESSURE_LABEL, label_synthetic, new_figure

    assert "gauge" in PRESSURE_LABEL and "abs" not in PRESSURE_LABEL
    fig, axes = new_figure(1, 2, width=6, height=3)
    for ax in axes:
        ax.set_xticks(range(5), [f"long tick label {i}" for i in range(5)], rotation=30, ha="right")
        ax.set_xlabel(PRESSURE_LABEL)
    label_synthetic(fig)
    stamp = [t for t in fig.texts if "synthetic" in t.get_text()][0]
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    sb = stamp.get_window_extent(r)
    assert sb.y0 >= 0 and all(sb.y1 <= ax.get_window_extent(r).y0 for ax in axes)
    plt.close(fig)


def test_figures_option_on_a_drawing_command(tmp_path, repo_root):
    """--figures svg on fit relax: a vector figure under the same stem, stamped (shipped synthetic logs)."""
    from pathlib import Path

    from typer.testing import CliRunner

    from bpmid.cli import app

    logs = sorted(str(p) for p in (Path(repo_root) / "datasets" / "relaxation").glob("*.csv"))[:2]
    out = tmp_path / "relax_fit.yaml"
    r = CliRunner().invoke(app, ["fit", "relax", *logs, "--out", str(out), "--figures", "svg"])
    assert r.exit_code == 0, r.output
    svg = out.with_suffix(".svg")
    assert svg.is_file() and not out.with_suffix(".png").exists()
    text = svg.read_text()
    assert text.lstrip().startswith("<?xml") and "<svg" in text
    assert "synthetic" in text or "glyph" in text  # text as paths: the stamp is drawn, not a font reference
    r = CliRunner().invoke(app, ["fit", "relax", *logs, "--out", str(tmp_path / "b.yaml"), "--figures", "gif"])
    assert r.exit_code == 2 and "--figures" in r.output and "gif" in r.output


def test_a_vector_figure_keeps_its_text_as_text_and_draws_dense_dots_as_an_image(tmp_path):
    """SVG and PDF for a paper: labels stay text (searchable, editable), a layer of tens of thousands of dots is
    one image instead of megabytes of paths; sparse markers and lines stay vector."""
    import numpy as np

    from bpmid.plots.common import DENSE_POINTS, new_figure, save_figure

    rng = np.random.default_rng(3)
    fig, ax = new_figure()
    ax.plot(rng.normal(size=20 * DENSE_POINTS), rng.normal(size=20 * DENSE_POINTS), ".", ls="none")
    ax.plot([0, 1], [0, 1], "o-")
    ax.set_xlabel("time (s)")
    path = save_figure(fig, tmp_path / "dense.svg")
    text = path.read_text()
    assert "<image" in text and ">time (s)</text>" in text
    assert path.stat().st_size < 400_000     # 40 000 dots as paths: several MB


# ---------------------------------------------------------------------------------------------------------------
# the library's .plot() of results loaded from their folders: the CLI's figures, in the house style
# ---------------------------------------------------------------------------------------------------------------
def _stamp_of(fig) -> list[str]:
    return [t.get_text() for t in fig.texts if "synthetic" in t.get_text()]


def test_a_loaded_study_plots_its_comparison_or_names_the_stages_to_plot(timed_small_study, tmp_path):
    """bpmid.load(<run folder>).plot() drew an empty axes titled 'parameter uncertainty': it draws the study's model
    comparison (compare_summary, as the run drew it and the report shows it), stamped as the run's figures; a study
    without a comparison says which stage results to plot."""
    import shutil

    import bpmid
    from bpmid.plots.check import text_problems

    study = bpmid.load(timed_small_study)
    fig = study.plot()
    assert fig.get_suptitle() == "Model comparison, pooled over all test logs"
    assert [ax.get_ylabel() for ax in fig.axes] == ["RMSE (°)", "R²", "MAPE (%)", "cost per simulated step (µs)"]
    assert [t.get_text() for t in fig.axes[0].get_xticklabels()] == list(study.results["compare"].table["model"])
    assert _stamp_of(fig) == [study.body["synthetic_stamp"]] and not text_problems(fig)
    assert not any(ax.get_legend() for ax in fig.axes) and fig.legends   # beside the axes, never over the bars
    plt.close(fig)
    d = tmp_path / "no_compare"
    d.mkdir()
    for f in ("run.yaml", "relax_fit.yaml"):
        shutil.copy(timed_small_study / f, d / f)
    with pytest.raises(bpmid.InputError, match=r"plot a stage's own result instead, study.results\['relax'\].plot\(\) "
                                               r"\(stages here: relax\)"):
        bpmid.load(d).plot()


def test_a_loaded_prediction_draws_the_figure_predict_writes(timed_small_study):
    """A prediction loaded from its folder plotted against 'sample' with no measured angle and its legend over the
    data: it draws predict.png's figure (loop, angle and error against time, one row per log), from its CSVs."""
    import yaml

    import bpmid
    from bpmid.plots.check import text_problems

    folder = timed_small_study.parent / "pred"
    res = bpmid.load(folder)
    fig = res.plot()
    names = list(yaml.safe_load((folder / "predict.yaml").read_text())["logs"])
    assert fig.get_suptitle() == "Prediction: measured and predicted angle, error" and len(fig.axes) == 3 * len(names)
    loop, angle, err = fig.axes[:3]
    assert loop.get_title() == f"{names[0]}: loop" and loop.get_xlabel().startswith("gauge pressure (bar")
    assert angle.get_xlabel() == "time (s)" and angle.get_ylabel() == "bending angle (°)"
    assert len(angle.get_lines()) == 2 and err.get_title().startswith(f"{names[0]}: error, RMSE ")
    assert abs(angle.get_lines()[0].get_xdata()[-1] - res.body["logs"][names[0]]["samples"] * 0.1) < 1.0  # seconds
    assert [t.get_text() for t in fig.legends[0].get_texts()] == ["measured", "prediction"]
    assert not any(ax.get_legend() for ax in fig.axes) and _stamp_of(fig) and not text_problems(fig)
    plt.close(fig)


def test_a_simulation_draws_every_log_or_says_how_many_it_draws(repo_root, monkeypatch):
    """bpmid.simulate(<protocol>).plot() drew 6 of 15 logs without saying so, its legend over the data: one panel
    per log, titled by the log, the count in the title, the synthetic stamp in the footer."""
    from pathlib import Path

    import bpmid
    import bpmid.plots.simulate as S
    from bpmid.plots.check import text_problems

    sim = bpmid.load(Path(repo_root) / "datasets" / "motion" / "variable_rate")
    fig = sim.plot()
    shown = [ax for ax in fig.axes if ax.get_visible()]
    assert len(sim.logs) == 15 and len(shown) == 15
    assert fig.get_suptitle() == "Digital-twin simulation, protocol variable_rate: all 15 logs"
    assert [ax.get_title() for ax in shown] == [Path(n).stem for n in sim.logs]
    assert all(ax.get_ylabel() == "bending angle (°)" and ax.get_xlabel() == "time (s)" for ax in shown)
    assert not fig.legends and not any(ax.get_legend() for ax in fig.axes)
    assert _stamp_of(fig) == ["synthetic data (bpmid digital twin)"] and not text_problems(fig)
    plt.close(fig)
    monkeypatch.setattr(S, "MAX_PANELS", 6)
    fig = sim.plot()
    assert sum(ax.get_visible() for ax in fig.axes) == 6 and "6 of 15 logs drawn" in fig.get_suptitle()
    plt.close(fig)
    fig = bpmid.load(Path(repo_root) / "datasets" / "relaxation").plot()   # a relaxation protocol: its stress
    assert fig.axes[0].get_ylabel() == "stress (MPa)"
    plt.close(fig)


def test_figures_of_loaded_files_are_in_the_house_style(timed_small_study):
    """The figures a loaded fit, control or discovery draws from its file's numbers: the house style (bpmid's layout,
    angles in °, gauge pressure), stamped when the logs say they are synthetic (they said 'deg', stamped nothing)."""
    import bpmid
    from bpmid.plots.check import text_problems
    from bpmid.plots.common import PRESSURE_LABEL

    for name in ("relax_fit.yaml", "vbmm_fit.yaml", "control", "discover"):
        fig = bpmid.load(timed_small_study / name).plot()
        labels = [t for ax in fig.axes for t in (ax.get_xlabel(), ax.get_ylabel(), ax.get_title())]
        assert hasattr(fig, "_bpmid_legend") and not any("deg" in t for t in labels), (name, labels)
        assert _stamp_of(fig) and not text_problems(fig), name
        if name == "vbmm_fit.yaml":
            assert fig.axes[0].get_xlabel() == PRESSURE_LABEL and fig.axes[0].get_ylabel().endswith("(°)")
        plt.close(fig)


def test_a_constant_without_a_standard_error_gets_its_reason_not_a_bar_of_zero(timed_small_study, tmp_path):
    """A loaded discovery drew its held (not determined) constants as bars of length 0 on 'relative standard error',
    which reads as perfectly determined: each such constant gets no bar and says why."""
    import yaml

    import bpmid
    from bpmid.plots.check import text_problems

    d = yaml.safe_load((timed_small_study / "vbmm_fit.yaml").read_text())
    held = [k for k, v in d["material"].items() if isinstance(v, dict) and v.get("stderr") is None]
    assert held   # G_inf: held at its prior (the angle hardly depends on it)
    # the figure a loaded result draws from its file's constants (a discovery's .plot(); every result's fallback)
    fig = bpmid.load(timed_small_study / "vbmm_fit.yaml")._params_figure()
    ax = fig.axes[0]
    labels = [t.get_text().split(" (")[0] for t in ax.get_yticklabels()]
    said = [t.get_text() for t in ax.texts]
    assert set(held) <= set(labels) and len(said) >= len(held)
    assert all(s.startswith("no standard error: ") for s in said) and not text_problems(fig)
    plt.close(fig)
