"""The paper's rules for a figure, as checks on a drawn matplotlib figure.

The PDF sets a figure 0.88 of the 16.4 cm text width wide, or at most 16 cm high
(``workflows/scripts/paper_pdf.py``), so a figure saved ``w`` inches wide (tight bounding box)
prints scaled by ``min(PRINT_WIDTH_IN / w, PRINT_HEIGHT_IN / h)``. ``smallest_print_font`` is
the smallest text at that scale (the rule: at least ``MIN_FONT_PT``); ``legends_on_data`` lists
the legends drawn inside an axes that cover a plotted point of a line of that axes.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from matplotlib.legend import Legend
from matplotlib.lines import Line2D
from matplotlib.text import Text

PRINT_WIDTH_IN = 0.88 * 16.4 / 2.54  # the PDF's figure width
PRINT_HEIGHT_IN = 16.0 / 2.54  # the PDF's height cap
MIN_FONT_PT = 7.0


def print_scale(fig: Figure) -> float:
    """The factor by which the PDF scales ``fig`` as saved with ``bbox_inches="tight"``."""
    renderer = fig.canvas.get_renderer()
    box = fig.get_tightbbox(renderer)  # inches
    return min(PRINT_WIDTH_IN / box.width, PRINT_HEIGHT_IN / box.height)


def _texts(fig: Figure) -> list[Text]:
    return [t for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip() and t.get_alpha() != 0]


def print_fonts(fig: Figure) -> list[tuple[float, str]]:
    """(size at print in pt, text) of every visible text of ``fig``, smallest first."""
    fig.canvas.draw()
    scale = print_scale(fig)
    return sorted((t.get_fontsize() * scale, t.get_text()) for t in _texts(fig))


def smallest_print_font(fig: Figure) -> float:
    """The smallest visible text of ``fig`` at print size (pt); infinity for a figure without text."""
    sizes = print_fonts(fig)
    return sizes[0][0] if sizes else float("inf")


def _line_points(line: Line2D) -> np.ndarray:
    xy = np.column_stack([np.asarray(v, float) for v in line.get_data()]) if len(line.get_xdata()) else np.empty((0, 2))
    xy = xy[np.isfinite(xy).all(axis=1)]
    if len(xy) < 2:
        return line.get_transform().transform(xy) if len(xy) else xy
    pts = line.get_transform().transform(xy)
    if line.get_linestyle() in ("None", "", " "):
        return pts  # markers only
    steps = np.linspace(0.0, 1.0, 8, endpoint=False)[:, None, None]  # points along each segment, in pixels
    dense = pts[:-1][None] + steps * (pts[1:] - pts[:-1])[None]
    return np.vstack([dense.reshape(-1, 2), pts[-1:]])


def legends_on_data(fig: Figure) -> list[str]:
    """The axes (by title or label) whose legend, drawn inside the axes, covers a point of one of its lines."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    covered = []
    for ax in fig.axes:
        legend = ax.get_legend()
        if not isinstance(legend, Legend) or not legend.get_visible():
            continue
        box = legend.get_window_extent(renderer)
        if not ax.bbox.overlaps(box):
            continue  # a legend outside the axes covers nothing
        lines = [ln for ln in ax.get_lines() if ln.get_visible() and ln.get_alpha() != 0]
        if any(box.contains(*p) for ln in lines for p in _line_points(ln)):
            covered.append(ax.get_title() or ax.get_ylabel() or "axes")
    return covered


def narrowest_axes(fig: Figure) -> float:
    """The width (in) of the narrowest visible axes after layout: a legend wider than its axes under
    constrained layout squeezes the axes, down to nothing."""
    fig.canvas.draw()
    widths = [ax.get_position().width * fig.get_figwidth() for ax in fig.axes if ax.get_visible()]
    return min(widths, default=0.0)
