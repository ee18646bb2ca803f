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


def make_figures(st: Study) -> dict[str, str]:
    """Draw the report's own figures; returns key -> path relative to DIR."""
    from bpmid.plots import report as RP
    from bpmid.plots.common import save_figure

    figs: dict[str, str] = {}
    fdir = st.root / FIGURE_DIR

    def save(key, fig, name):
        p = save_figure(fig, fdir / f"{name}.png", png_twin=True)
        figs[key] = p.relative_to(st.root).as_posix()

    if st.relax is not None:
        save("modulus", RP.modulus_curves(st.relax.raw, paper=PAPER_RELAX, synthetic=st.synthetic), "modulus_curves")
    c = st.compare
    if c is not None and c.predictions:
        models = list(c.summary["model"])
        save("bands", RP.error_bands(c.predictions, models, synthetic=st.synthetic), "error_bands")
        frames = [f for v in c.predictions.values() for f in v]
        save("residuals", RP.residual_diagnostics(frames, models, synthetic=st.synthetic), "residuals")
    return figs
