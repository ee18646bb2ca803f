"""Shared figure style and the one atomic figure writer.

- the house style is a matplotlib style file shipped in the package (``bpmid/plots/bpmid.mplstyle``): a
  colour-blind-safe palette with line styles, small fonts, no layout engine; :func:`style` applies it;
- :func:`new_figure` lays axes out with margins given in inches (explicit layout: no constrained layout,
  whose repeated text measurements were half of the figure cost), with room for a legend beside the axes
  (``legend="right"``) or above them (``legend="top"``), and a footer strip for the synthetic-data stamp,
  so that the stamp (:func:`label_synthetic`) never meets an axis label;
- one pressure convention for every figure: gauge pressure in bar (:data:`PRESSURE_LABEL`);
- :func:`save_figure` writes PNG, SVG or PDF (:func:`set_figure_format`, the ``--figures`` option) atomically.
"""
from __future__ import annotations

from importlib import resources
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt  # noqa: E402  (colour maps, closing; figures are made without pyplot)
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from bpmid.io.atomic import staged_file  # noqa: E402
from bpmid.plots.options import (FORMATS, figure_format, figure_format_as, figure_path,  # noqa: E402,F401
                                 set_figure_format)

#: Okabe-Ito colours (colour-blind safe); one per model family, stable across every figure
OKABE_ITO = {"blue": "#0072B2", "vermillion": "#D55E00", "green": "#009E73", "purple": "#CC79A7",
             "orange": "#E69F00", "sky": "#56B4E9", "yellow": "#F0E442", "black": "#000000"}
MODEL_COLORS = {
    "measured": "black", "vbmm-mat": OKABE_ITO["sky"], "vbmm-fit": OKABE_ITO["blue"], "gpi": OKABE_ITO["green"],
    "maxwell-slip": OKABE_ITO["purple"], "three-element": OKABE_ITO["orange"], "two-branch": OKABE_ITO["vermillion"],
    # the eight Okabe-Ito colours are taken (yellow reads poorly on white): Paul Tol's wine, also colour-blind safe,
    # so that a discovered model never shares the two-branch model's colour
    "vbmm+effects": "#882255",
}
#: a line style per model family, so that lines lying on each other stay distinguishable
MODEL_STYLES = {"measured": "-", "vbmm-mat": (0, (5, 2)), "vbmm-fit": "-", "gpi": "-.", "maxwell-slip": (0, (1, 1.5)),
                "three-element": (0, (6, 2, 1, 2, 1, 2)), "two-branch": "--", "vbmm+effects": (0, (4, 2))}
FALLBACK = list(OKABE_ITO.values())
FALLBACK_STYLES = ["-", "--", "-.", ":", (0, (6, 2, 1, 2)), (0, (3, 1))]

#: the pressure convention of every figure (the model's input; VBMM.md section 6)
PRESSURE_LABEL = "gauge pressure (bar, above atmosphere)"
PRESSURE_RATE_LABEL = "pressure rate (bar/s)"
from bpmid.units import PA_PER_BAR  # noqa: E402,F401  (the one home of unit factors)

from bpmid.io.motion_logs import TWIN_NOTE as SYNTHETIC_NOTE  # noqa: E402  (one wording for io and plots)

FOOTER_IN = 0.24  # the strip at the bottom that holds the synthetic stamp

def style_path() -> Path:
    return Path(str(resources.files("bpmid.plots").joinpath("bpmid.mplstyle")))


_STYLE: dict | None = None


def style() -> None:
    """Apply the house style to matplotlib's rcParams (idempotent). Every figure bpmid draws applies it
    (:func:`new_figure`); a library call that draws (``Result.plot``, ``Result.save``) restores the caller's
    rcParams afterwards (:func:`kept_rc`), so a notebook keeps its own style and backend."""
    global _STYLE
    if _STYLE is None:
        _STYLE = dict(matplotlib.rc_params_from_file(str(style_path()), use_default_template=False))
    matplotlib.rcParams.update(_STYLE)


def kept_rc():
    """A context in which bpmid may apply its house style; the caller's rcParams come back after it."""
    return matplotlib.rc_context()


def color_of(name: str, i: int = 0) -> str:
    return MODEL_COLORS.get(name, FALLBACK[i % len(FALLBACK)])


def style_of(name: str, i: int = 0):
    return MODEL_STYLES.get(name, FALLBACK_STYLES[i % len(FALLBACK_STYLES)])


def new_figure(nrows: int = 1, ncols: int = 1, *, width: float = 7.0, height: float = 4.0, legend: str | None = None,
               legend_size: float = 1.7, left: float = 0.75, right: float = 0.2, top: float = 0.45,
               bottom: float = 0.55, hgap: float = 0.75, wgap: float = 0.8, suptitle: bool = False,
               gridspec_kw: dict | None = None, **kw):
    """Figure with an explicit layout: margins and gaps in inches (no layout engine).

    legend : None, "right" (a column ``legend_size`` inches wide beside the axes) or "top" (a band
        ``legend_size`` inches high above them); :func:`outside_legend` fills it
    suptitle : reserve 0.3 in at the top for a figure title
    """
    top_in = top + (0.3 if suptitle else 0.0) + (legend_size if legend == "top" else 0.0)
    right_in = right + (legend_size if legend == "right" else 0.0)
    bottom_in = bottom + FOOTER_IN
    ax_h = (height - top_in - bottom_in - (nrows - 1) * hgap) / nrows
    ax_w = (width - left - right_in - (ncols - 1) * wgap) / ncols
    if ax_h <= 0.3 or ax_w <= 0.3:  # too small for the margins: grow the canvas rather than squeeze text
        height = max(height, top_in + bottom_in + (nrows - 1) * hgap + 0.6 * nrows)
        width = max(width, left + right_in + (ncols - 1) * wgap + 0.6 * ncols)
        ax_h = (height - top_in - bottom_in - (nrows - 1) * hgap) / nrows
        ax_w = (width - left - right_in - (ncols - 1) * wgap) / ncols
    gs = dict(gridspec_kw or {})
    gs.update(left=left / width, right=1 - right_in / width, bottom=bottom_in / height, top=1 - top_in / height,
              hspace=hgap / ax_h if nrows > 1 else 0.0, wspace=wgap / ax_w if ncols > 1 else 0.0)
    style()
    # a Figure of its own (not pyplot's): nothing is kept open, no backend is chosen or changed
    fig = Figure(figsize=(width, height), layout=None)
    FigureCanvasAgg(fig)   # a canvas that measures text (the legend's room), whatever the session's backend
    sub_kw = {k: kw.pop(k) for k in ("sharex", "sharey", "squeeze", "subplot_kw") if k in kw}
    axes = fig.subplots(nrows, ncols, gridspec_kw=gs, **sub_kw)
    if kw:
        raise TypeError(f"new_figure: unexpected arguments {sorted(kw)}")
    fig._bpmid_legend = (legend, legend_size, top_in, right_in)
    return fig, axes


def outside_legend(fig, handles=None, labels=None, *, ncol: int | None = None, ax=None, title: str | None = None):
    """A legend in the space :func:`new_figure` reserved beside or above the axes (never over data)."""
    where, size, top_in, right_in = getattr(fig, "_bpmid_legend", ("right", 1.7, 0.45, 1.9))
    if handles is None:
        src = [ax] if ax is not None else fig.axes
        handles, labels, seen = [], [], set()
        for a in src:
            for h, lab in zip(*a.get_legend_handles_labels()):
                if lab not in seen and not lab.startswith("_"):
                    seen.add(lab)
                    handles.append(h)
                    labels.append(lab)
    if not handles:
        return None
    w, h = fig.get_size_inches()
    if where == "top":  # fewer columns when the labels are too long for one row
        n = ncol or min(len(handles), 4)
        while True:
            leg = fig.legend(handles, labels, loc="upper left", bbox_to_anchor=(0.02, 1 - 0.05 / h), ncol=n,
                             title=title, borderaxespad=0.0)
            if n == 1 or leg.get_window_extent(fig.canvas.get_renderer()).x1 <= fig.bbox.width - 4:
                return leg
            leg.remove()
            n -= 1
    x0_in = w - (right_in - 0.05)
    y1 = 1 - top_in / h
    leg = fig.legend(handles, labels, loc="upper left", bbox_to_anchor=(x0_in / w, y1), ncol=ncol or 1, title=title,
                     borderaxespad=0.0)
    _widen_for(fig, leg, x0_in, y1)
    return leg


def _widen_for(fig, leg, x0_in: float, y1: float, pad_in: float = 0.06) -> None:
    """Widen the canvas when a legend beside the axes is wider than the column reserved for it (long labels),
    keeping every axes where it is in inches: nothing is squeezed and nothing leaves the canvas."""
    w, h = fig.get_size_inches()
    bb = leg.get_window_extent(fig.canvas.get_renderer())
    need = bb.x1 / fig.dpi + pad_in - w
    if need <= 0:
        return
    new_w = w + need
    for ax in fig.axes:
        p = ax.get_position()
        ax.set_position([p.x0 * w / new_w, p.y0, p.width * w / new_w, p.height])
    for t in fig.texts:  # figure texts in figure fractions (stamp, notes) keep their place from the right edge
        x, y = t.get_position()
        if t.get_transform() == fig.transFigure:
            t.set_x(1 - (1 - x) * w / new_w if x > 0.5 else x * w / new_w)
    fig.set_size_inches(new_w, h)
    leg.set_bbox_to_anchor((x0_in / new_w, y1), transform=fig.transFigure)


def label_synthetic(fig, note: str = SYNTHETIC_NOTE) -> None:
    """Mark a figure made from synthetic data: in the footer strip :func:`new_figure` reserves below every
    axis label, at the right (page numbers and captions sit left)."""
    w, h = fig.get_size_inches()
    fig.text(1 - 0.05 / w, 0.05 / h, note, ha="right", va="bottom", fontsize=7, color="0.35", style="italic")


def finish(fig, synthetic: "bool | str | None"):
    """Stamp ``fig`` when ``synthetic``: True for the twin's wording, a text (:func:`bpmid.io.motion_logs.synthetic_note`)
    for its own."""
    if synthetic:
        label_synthetic(fig, synthetic if isinstance(synthetic, str) else SYNTHETIC_NOTE)
    return fig


#: a marker-only layer with more points than this is drawn as an image inside a vector figure (SVG, PDF): tens of
#: thousands of residual dots as vector paths make a file of megabytes that editors and browsers crawl through
DENSE_POINTS = 2000


def rasterize_dense(fig) -> None:
    """Rasterize the dense marker-only layers of ``fig`` (lines, axes, text and sparse markers stay vector)."""
    for ax in fig.axes:
        for line in ax.get_lines():
            if line.get_linestyle() in ("None", "none", "", " ") and len(line.get_xdata()) > DENSE_POINTS:
                line.set_rasterized(True)
        for coll in ax.collections:
            if len(getattr(coll, "get_offsets", lambda: [])()) > DENSE_POINTS:
                coll.set_rasterized(True)


def save_figure(fig, path: str | Path, *, dpi: int = 120, png_twin: bool = False) -> Path:
    """Write ``fig`` atomically and close it; returns the path written.

    The format is the one chosen with :func:`set_figure_format` (the suffix of ``path`` is changed to match),
    else the suffix of ``path``. ``png_twin``: a PDF also gets a PNG beside it (browsers cannot show a PDF in a
    page; the HTML report embeds the twin of the figures it draws itself)."""
    path = figure_path(path)
    fmt = path.suffix.lstrip(".").lower() or "png"
    if fmt in ("svg", "pdf"):
        rasterize_dense(fig)
    try:
        with staged_file(path) as tmp:
            # a vector figure's rasterized layers at print resolution (the dpi sets nothing else there)
            fig.savefig(tmp, dpi=max(dpi, 300) if fmt in ("svg", "pdf") else dpi, format=fmt,
                        metadata={"Date": None} if fmt == "svg" else None)
        if fmt == "pdf" and png_twin:
            with staged_file(path.with_suffix(".png")) as tmp:
                fig.savefig(tmp, dpi=dpi, format="png")
    finally:
        plt.close(fig)
    return path
