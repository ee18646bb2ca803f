"""Shared figure style and the one atomic figure writer."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from bpmid.io.atomic import staged_file  # noqa: E402

#: one colour per model family, stable across every figure
MODEL_COLORS = {
    "measured": "black", "vbmm-mat": "#1f77b4", "vbmm-fit": "#d62728", "gpi": "#2ca02c",
    "maxwell-slip": "#9467bd", "three-element": "#ff7f0e", "two-branch": "#8c564b", "vbmm+effects": "#e377c2",
}

SYNTHETIC_NOTE = "synthetic data (bpmid digital twin)"


def new_figure(nrows: int = 1, ncols: int = 1, *, width: float = 7.0, height: float = 4.0, **kw):
    fig, axes = plt.subplots(nrows, ncols, figsize=(width, height), constrained_layout=True, **kw)
    return fig, axes


def label_synthetic(fig, note: str = SYNTHETIC_NOTE) -> None:
    """Mark a figure made from synthetic data, in its corner."""
    # bottom-left: under the y-axis labels, the one corner no x-label or legend of ours reaches
    fig.text(0.005, 0.005, note, ha="left", va="bottom", fontsize=7, color="0.4")


def save_figure(fig, path: str | Path, *, dpi: int = 120) -> Path:
    """Write ``fig`` to ``path`` (PNG or SVG by suffix) atomically and close it."""
    path = Path(path)
    try:
        with staged_file(path) as tmp:
            fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip(".") or "png")
    finally:
        plt.close(fig)
    return path
