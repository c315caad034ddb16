"""The study contract: what every study returns and the four functions that present it.

Each study folder (`jaxsdp.studies.emps`, `.tx40`, `.control`, `.montecarlo`)
exports its study function, which returns a result holding everything the
run produced (estimates, `warnings`, `findings` where the study draws any,
`timings` in seconds per stage, `versions`), and the same four functions of
that result:

- `summary(result) -> dict`: the JSON-ready summary (`summary.json`);
- `report(result, *, figures=None) -> str`: the markdown report
  (`report.md`), linking `figures` (figure name -> file) when given;
- `text(result) -> str`: what the command prints;
- `figures(result) -> dict[str, Figure]`: every figure, keyed by its file stem.

The command line (`jaxsdp._cli.common.run_study`) does nothing else than call
them and write what they return, so a study gives the same numbers, report
and figures from Python as from the command.
"""

import os
import pathlib

import jax

from .._runtime import fast_loops_status
from .._version import __version__
from ._figure_style import figure_output

#: The four functions every study folder exports besides its study function.
CONTRACT = ("summary", "report", "text", "figures")


def versions() -> dict:
    """The versions a result was computed with: `{"jaxsdp": ..., "jax": ...}`."""
    return {"jaxsdp": __version__, "jax": jax.__version__}


def fast_loops() -> str:
    """Whether the compiled fast loops were used (`jaxsdp._runtime.fast_loops_status`)."""
    return fast_loops_status()


def figure_links(figures) -> dict[str, str]:
    """`figures` (name -> path or file name, or None) as name -> file name, for a report's links."""
    return {} if not figures else {name: pathlib.Path(path).name for name, path in dict(figures).items()}


def save_figures(figures: dict, folder: str | os.PathLike, *, fmt: str = "png", dpi: float = 150) -> dict:
    """Write `figures` (name -> Figure) into the existing directory `folder` as `<name>.<fmt>`, clearing
    each once written (its memory freed); returns name -> path in the same order.

    `fmt`: "png", "pdf" or "svg"; `dpi`: resolution (dots per inch, > 0) of
    raster output (PDF and SVG are vector graphics). ValueError otherwise.

    Example:
        >>> import tempfile
        >>> from jaxsdp.studies._figure_style import new_figure
        >>> fig = new_figure()
        >>> paths = save_figures({"blank": fig}, tempfile.mkdtemp(), fmt="svg")
        >>> paths["blank"].name
        'blank.svg'
    """
    out = figure_output(fmt, dpi, folder, option="folder")
    paths = {}
    for name, fig in figures.items():
        path = out / f"{name}.{fmt}"
        try:
            fig.savefig(path, format=fmt, dpi=float(dpi))
        finally:
            fig.clear()
        paths[name] = path
    return paths
