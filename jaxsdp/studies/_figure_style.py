"""Figure conventions shared by the studies: styles, figure factory, panel titles, output formats.

Colours follow the paper: SDP estimates as red crosses, parametric models in
blue. Figures use matplotlib's object-oriented API (no `pyplot`, no global
state), imported on first use.
"""

import math
import numbers
import pathlib
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from matplotlib.figure import Figure

SDP_STYLE = dict(color="tab:red", marker="x", linestyle="none", markersize=3.5, markeredgewidth=0.8)
ZOOM_STYLE = dict(color="0.85", alpha=0.5, zorder=0, linewidth=0)
LEGEND = dict(fontsize=8, framealpha=0.9, markerscale=2.0)
#: Output formats of the studies' `save_*_figures`.
FIGURE_FORMATS = ("png", "pdf", "svg")


def new_figure(**kw) -> "Figure":
    """A constrained-layout `matplotlib.figure.Figure` (matplotlib imported on first use: it is slow to import)."""
    from matplotlib.figure import Figure

    return Figure(layout="constrained", **kw)


def as_float(a):
    """`a` as a float64 NumPy array."""
    return np.asarray(a, dtype=float)


def panel(ax, title: str, legend: dict | None = None) -> None:
    """Panel title on the left; the legend above the panel on the right."""
    ax.set_title(title, loc="left", fontsize=10)
    if legend is not None:
        ax.legend(loc="lower right", bbox_to_anchor=(1.0, 1.0), borderaxespad=0.2, **legend, **LEGEND)
    ax.grid(alpha=0.3)


def figure_output(fmt: str, dpi, folder, *, option: str = "out") -> pathlib.Path:
    """Check the figure format (`FIGURE_FORMATS`), the resolution (dpi > 0) and the output folder (must
    exist; `option` names it in the error); returns the folder as a Path. ValueError otherwise."""
    if fmt not in FIGURE_FORMATS:
        raise ValueError(f"`fmt` must be one of {FIGURE_FORMATS}; got {fmt!r}")
    if isinstance(dpi, bool) or not isinstance(dpi, numbers.Real) or not math.isfinite(float(dpi)) or float(dpi) <= 0:
        raise ValueError(f"`dpi` must be a positive number; got {dpi!r}")
    path = pathlib.Path(folder)
    if not path.is_dir():
        raise ValueError(f"`{option}`: not a directory: {path}")
    return path
