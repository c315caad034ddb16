"""The study contract: the type every study returns and the four functions that present it.

Each study folder (`jaxsdp.studies.emps`, `.tx40`, `.robot`, `.control`,
`.montecarlo`) exports its study function, which returns a `Study`: a result
holding everything the run produced (estimates, `warnings`, `findings` where
the study draws any, `timings` in seconds per stage, `versions`) and
presenting itself through four methods, which the folder also exports as
functions of the result:

- `summary(result) -> dict`: the JSON-ready summary (`summary.json`);
- `report(result, *, figures=None) -> str`: the markdown report
  (`report.md`), linking `figures` (figure name -> file) when given;
- `text(result) -> str`: what the command prints;
- `figures(result) -> dict[str, Figure]`: every figure, keyed by its file stem.

The command line (`jaxsdp._cli.common.run_study`) does nothing else than call
them and write what they return, so a study gives the same numbers, report
and figures from Python as from the command. A result is never changed after
the study returned it: the command adds its own stages' seconds with
`Study.with_timings`, which returns a new result.
"""

import abc
import dataclasses
import os
import pathlib

import equinox as eqx
import jax

from .._runtime import fast_loops_status, x64
from .._version import __version__
from ._figure_style import figure_output

#: The four functions every study folder exports besides its study function.
CONTRACT = ("summary", "report", "text", "figures")


class Study(eqx.Module):
    """What every study returns: the run's results, and how they are presented (the study contract).

    **Fields every study has:** `warnings` (tuple of one-line messages),
    `timings` (dict: stage -> seconds), `versions` (dict: jaxsdp, jax).

    **Methods:** `summary()` (JSON-ready dict), `report(figures=None)`
    (markdown; `figures`: name -> file name, linked), `text()` (what the
    command prints), `figures()` (name -> matplotlib Figure), and
    `with_timings(timings)`: a copy whose `timings` are these (a result is
    immutable).
    """

    warnings: eqx.AbstractVar[tuple]
    timings: eqx.AbstractVar[dict]
    versions: eqx.AbstractVar[dict]

    @abc.abstractmethod
    def summary(self) -> dict:
        """The JSON-ready summary (`summary.json`)."""

    @abc.abstractmethod
    def report(self, figures: dict[str, str] | None = None) -> str:
        """The markdown report (`report.md`); `figures`: figure name -> file name, linked when given."""

    @abc.abstractmethod
    def text(self) -> str:
        """What the study's command prints on stdout."""

    @abc.abstractmethod
    def figures(self) -> dict:
        """Every figure (name -> matplotlib Figure), keyed by its file stem."""

    @x64
    def with_timings(self, timings: dict) -> "Study":
        """A copy of this result whose `timings` are `timings` (stage -> seconds); this one is unchanged.

        Example:
            >>> from jaxsdp.studies.robot import example_study
            >>> study = example_study()
            >>> later = study.with_timings({**study.timings, "figures": 1.5})
            >>> later.timings["figures"], "figures" in study.timings
            (1.5, False)
        """
        return dataclasses.replace(self, timings=dict(timings))


def check_study(
    result, kind: type | str | None = None, made_by: str | None = None, *, argument: str = "result"
) -> Study:
    """`result` if it is a `Study` (of class `kind`, a class or its name, when given), else a ValueError
    naming the `argument`, what was expected and what it got. A name lets a presentation module check its
    study's type without importing the module that defines it (which imports the presentation)."""
    name = kind if isinstance(kind, str) else getattr(kind, "__name__", None)
    ok = isinstance(result, Study) and (kind is None or type(result).__name__ == name)
    if not ok:
        article = "an" if name and name[0] in "AEIOU" else "a"
        what = "a study's result (EMPSStudy, TX40Study, RobotStudy, ...)" if kind is None else f"{article} {name}"
        source = f" (from {made_by})" if made_by else ""
        raise ValueError(f"`{argument}` must be {what}{source}; got {type(result).__name__}")
    return result


@x64
def summary(result: Study) -> dict:
    """The JSON-ready summary of a study's result: what `summary.json` of its command holds.

    Estimates with their standard deviations, the checks, `warnings`,
    `timings` (s) and `versions`; each study's keys are listed on its result
    type.

    Example:
        >>> from jaxsdp.studies.robot import example_study, summary
        >>> sorted(summary(example_study())["joints"])
        ['joint1', 'joint2']
    """
    return check_study(result).summary()


@x64
def report(result: Study, *, figures: dict | None = None) -> str:
    """The markdown report of a study's result (`report.md` of its command).

    Warnings, findings, tables, checks and timings; `figures` (figure name ->
    path or file name) are linked when given.

    Example:
        >>> from jaxsdp.studies.robot import example_study, report
        >>> report(example_study()).splitlines()[0]
        '# Robot study: all joints at once'
    """
    return check_study(result).report(figure_links(figures))


@x64
def text(result: Study) -> str:
    """What a study's command prints on stdout for this result (its tables and findings; the warnings are
    printed once, on stderr, by the command).

    Example:
        >>> from jaxsdp.studies.robot import example_study, text
        >>> "Stacked" in text(example_study())
        True
    """
    return check_study(result).text()


@x64
def figures(result: Study) -> dict:
    """Every figure of a study's result (name -> matplotlib Figure), keyed by its file stem.

    Example:
        >>> from jaxsdp.studies.robot import example_study, figures
        >>> list(figures(example_study()))
        ['joints', 'sdp_curves']
    """
    return check_study(result).figures()


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
