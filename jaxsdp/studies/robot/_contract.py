"""The robot study's four presentation functions (the study contract, `jaxsdp.studies._contract`)."""

from typing import TYPE_CHECKING

from .._contract import figure_links
from ._figures import robot_figures
from ._report import report_markdown, study_summary, text_output
from ._study import RobotStudy

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def _check(result) -> None:
    if not isinstance(result, RobotStudy):
        raise ValueError(f"`result` must be a RobotStudy (from robot_study); got {type(result).__name__}")


def summary(result: RobotStudy) -> dict:
    """The JSON-ready summary of a robot study (`summary.json` of `jaxsdp robot`).

    Example:
        >>> from jaxsdp.studies.robot import example_study, summary
        >>> sorted(summary(example_study())["joints"])
        ['joint1', 'joint2']
    """
    _check(result)
    return study_summary(result)


def report(result: RobotStudy, *, figures=None) -> str:
    """The markdown report (`report.md` of `jaxsdp robot`).

    Example:
        >>> from jaxsdp.studies.robot import example_study, report
        >>> report(example_study()).splitlines()[0]
        '# Robot study: all joints at once'
    """
    _check(result)
    return report_markdown(result, list(figure_links(figures).values()))


def text(result: RobotStudy) -> str:
    """What `jaxsdp robot` prints on stdout.

    Example:
        >>> from jaxsdp.studies.robot import example_study, text
        >>> "Stacked" in text(example_study())
        True
    """
    _check(result)
    return text_output(result)


def figures(result: RobotStudy) -> dict[str, "Figure"]:
    """Every figure of a robot study, keyed by its file stem.

    Example:
        >>> from jaxsdp.studies.robot import example_study, figures
        >>> list(figures(example_study()))
        ['joints', 'sdp_curves']
    """
    _check(result)
    return robot_figures(result)
