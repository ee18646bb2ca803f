"""The study report: the only package that writes one.

``bpmid report DIR`` reads the stage outputs a ``bpmid run`` (or single commands) left in DIR, with the names
of CLI.md, and writes

- ``DIR/report.html``: one self-contained file (figures embedded: PNG as base64 or SVG inlined; inline CSS;
  no scripts, no external links or fonts; equations in MathML), and
- ``DIR/report.md``: the same content in Markdown, figures referenced as files next to it.

Layout of the package:

- :mod:`~bpmid.report.inputs`: typed records of every stage file, read once by one loader each; partial or
  unreadable files become :class:`~bpmid.report.inputs.Problem` entries, stale stages are detected from
  ``run.yaml`` and from each stage file's provenance (the run's id);
- :mod:`~bpmid.report.doc`: the document model (sections of blocks, numbered figures);
- :mod:`~bpmid.report.sections`: one module per section, in a registry (summary first, provenance last);
- :mod:`~bpmid.report.render`: the HTML and Markdown renderers (CSS in ``report.css``);
- :mod:`~bpmid.report.paper`: the source paper's quoted numbers, kept apart;
- :mod:`~bpmid.report.figures`: the figures the report draws itself.
"""
from __future__ import annotations

import contextlib
import dataclasses
from pathlib import Path

from bpmid.errors import InputError
from bpmid.report.doc import Doc, fmt, pm
from bpmid.report.figures import FIGURE_DIR, make_figures
from bpmid.report.inputs import Problem, Study, read_study
from bpmid.report.paper import PAPER_CONTROL, PAPER_RELAX, PAPER_ROWS, PAPER_SOURCE
from bpmid.report.render import render_html, render_markdown
from bpmid.report.sections.residuals import residual_table


def build_report(st: Study, figs: dict[str, str]) -> Doc:
    """The document: every registered section, in order."""
    from bpmid.report.sections import registry

    doc = Doc()
    for key, title, build in registry():
        try:
            build(doc, st, figs)
        except (TypeError, ValueError, KeyError, AttributeError, IndexError) as exc:
            # a value of an unexpected type in a stage file: say so in the section, keep the rest of the report
            if not doc.sections or doc.sections[-1].key != key:
                doc.section(key, title)
            msg = f"section {title!r} could not be built from its files ({type(exc).__name__}: {exc})"
            doc.p("Not available: " + msg, css="warn")
            st.problems.append(Problem(key, msg))
    return doc


@dataclasses.dataclass
class ReportResult:
    html: Path
    markdown: Path
    problems: list[Problem]
    stale: dict[str, str]
    missing: list[str] = dataclasses.field(default_factory=list)

    def warnings(self) -> list[str]:
        return ([f"{p.path}: {p.what}" for p in self.problems]
                + [f"{f}: missing, though run.yaml records its stage as done (deleted or moved?): rerun bpmid run "
                   f"into this folder" for f in self.missing]
                + [f"stage {s}: {why}" for s, why in self.stale.items()])


def report_study(out_dir: str | Path, *, title: str = "bpmid study report", figures: str | None = None,
                 drawn: dict[str, str] | None = None) -> ReportResult:
    """Write ``out_dir/report.html`` and ``out_dir/report.md``; ``figures``: 'png', 'svg' or 'pdf' for the
    figures the report draws (default: the current format, PNG); ``drawn``: those of its figures already drawn
    from the same files (:func:`bpmid.report.figures.stage_figures`: ``bpmid run`` draws them beside its stages).

    InputError when the folder holds no readable stage output at all (the message names the unusable files).
    """
    from bpmid.io import atomic

    # one writer per folder: a command still writing DIR (bpmid run holds it for the whole run) is waited for,
    # then refused, so the report is never built from a half-written folder nor written beside its files (the
    # run's own report stage already holds the folder)
    held = (atomic.folder_lock(out_dir, wait_s=atomic.COMMIT_WAIT_S, advice="wait for it to finish, then report again")
            if Path(out_dir).is_dir() else contextlib.nullcontext())
    with held:
        return _report_study(out_dir, title, figures, drawn)


def _report_study(out_dir, title: str, figures: str | None, drawn: dict[str, str] | None) -> ReportResult:
    from bpmid.io.atomic import write_text
    from bpmid.plots.common import figure_format_as

    st = read_study(out_dir)
    if not st.any():
        what = "; ".join(f"{p.where(Path(out_dir))}: {p.what}" for p in st.problems)
        raise InputError("no stage outputs found that can be used (expected run.yaml, relax_fit.yaml, vbmm_fit.yaml, "
                         "compare/, history_modes.yaml, discover/discovery.yaml or control/)"
                         + (f"; {what}" if what else ""), path=out_dir)
    with figure_format_as(figures) if figures else contextlib.nullcontext():
        figs = make_figures(st, drawn)
        doc = build_report(st, figs)
    root = Path(out_dir)
    md = write_text(root / "report.md", render_markdown(doc, title))
    page = write_text(root / "report.html", render_html(doc, title, root))
    return ReportResult(page, md, st.problems, st.stale, list(st.missing))


def write_report(out_dir: str | Path, *, title: str = "bpmid study report", figures: str | None = None,
                 drawn: dict[str, str] | None = None) -> tuple[Path, Path]:
    """:func:`report_study`, returning the two paths."""
    r = report_study(out_dir, title=title, figures=figures, drawn=drawn)
    return r.html, r.markdown


__all__ = ["write_report", "report_study", "read_study", "build_report", "make_figures", "render_html",
           "render_markdown", "Doc", "fmt", "pm", "PAPER_ROWS", "PAPER_RELAX", "PAPER_CONTROL", "PAPER_SOURCE",
           "FIGURE_DIR", "residual_table", "ReportResult", "Study"]
