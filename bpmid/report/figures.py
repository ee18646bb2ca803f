"""Figures of the report: those the report draws itself (into DIR/report_figures/, in the chosen format) and
the lookup of the figures the stages wrote (any of SVG, PNG, PDF)."""
from __future__ import annotations

from pathlib import Path

from bpmid.report.inputs import Study
from bpmid.report.paper import PAPER_RELAX

#: figures the report draws itself, in this subfolder of DIR
FIGURE_DIR = "report_figures"
SUFFIXES = (".svg", ".png", ".pdf")


def find_figure(root: Path, stem: str) -> str | None:
    """``stem`` (relative to ``root``, no suffix) as written by a stage, in the chosen format if present, else
    any; returns the path relative to ``root``."""
    from bpmid.plots.common import figure_format

    want = "." + figure_format()
    for suf in (want,) + tuple(s for s in SUFFIXES if s != want):
        p = root / (stem + suf)
        if p.is_file():
            return p.relative_to(root).as_posix()
    return None


def _save(root: Path, figs: dict, key: str, fig, name: str) -> None:
    from bpmid.plots.common import save_figure

    p = save_figure(fig, root / FIGURE_DIR / f"{name}.png", png_twin=True)
    figs[key] = p.relative_to(root).as_posix()


def relax_figures(root: Path, relax, synthetic: bool) -> dict[str, str]:
    """The report's figure of the relaxation fit (``relax``: :class:`~bpmid.report.inputs.RelaxInfo`)."""
    from bpmid.plots import report as RP

    figs: dict[str, str] = {}
    _save(root, figs, "modulus", RP.modulus_curves(relax.raw, paper=PAPER_RELAX, synthetic=synthetic), "modulus_curves")
    return figs


def compare_figures(root: Path, compare, synthetic: bool) -> dict[str, str]:
    """The report's figures of the comparison's predictions (``compare``: :class:`~bpmid.report.inputs.CompareInfo`)."""
    from bpmid.plots import report as RP

    figs: dict[str, str] = {}
    if compare.predictions:
        models = list(compare.summary["model"])
        _save(root, figs, "bands", RP.error_bands(compare.predictions, models, synthetic=synthetic), "error_bands")
        frames = [f for v in compare.predictions.values() for f in v]
        _save(root, figs, "residuals", RP.residual_diagnostics(frames, models, synthetic=synthetic), "residuals")
    return figs


#: the stages whose outputs the report's own figures are drawn from
FIGURE_STAGES = ("relax", "compare")


def stage_figures(root: str | Path, stage: str, synthetic: bool) -> dict[str, str]:
    """Draw the report's figures of one stage (:data:`FIGURE_STAGES`) from that stage's files under ``root``,
    as :func:`make_figures` draws them; ``bpmid run`` draws them beside its other stages, as soon as the stage's
    files are written, and hands them to the report (``drawn``). Returns key -> path relative to ``root``."""
    from bpmid.report.inputs import _Reader, load_compare, load_relax

    root = Path(root)
    rd = _Reader(root)
    if stage == "relax":
        info = load_relax(rd)
        return {} if info is None else relax_figures(root, info, synthetic)
    if stage == "compare":
        info = load_compare(rd)
        return {} if info is None else compare_figures(root, info, synthetic)
    raise ValueError(f"no report figures for stage {stage!r} (those of {', '.join(FIGURE_STAGES)})")


def make_figures(st: Study, drawn: dict[str, str] | None = None) -> dict[str, str]:
    """Draw the report's own figures; returns key -> path relative to DIR. ``drawn``: figures already drawn from
    this study's files (:func:`stage_figures`), used as they are."""
    figs: dict[str, str] = dict(drawn or {})
    if st.relax is not None and "modulus" not in figs:
        figs.update(relax_figures(st.root, st.relax, st.stamp))
    if st.compare is not None and not {"bands", "residuals"} & set(figs):
        figs.update(compare_figures(st.root, st.compare, st.stamp))
    return figs
