"""The robot study's four presentation functions (the study contract, `jaxsdp.studies._contract`), for a
`RobotStudy` (identification) and an `ExcitationStudy` (exciting trajectory) alike."""

from typing import TYPE_CHECKING

from ..._runtime import x64
from .._contract import figure_links
from ._excite import ExcitationStudy
from ._excite_report import excitation_markdown, excitation_summary, excitation_text, fig_trajectory
from ._figures import robot_figures
from ._report import report_markdown, study_summary, text_output
from ._study import RobotStudy

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def _check(result) -> bool:
    """True for an `ExcitationStudy`, False for a `RobotStudy`."""
    if not isinstance(result, (RobotStudy, ExcitationStudy)):
        raise ValueError(
            f"`result` must be a RobotStudy (robot_study) or an ExcitationStudy (excitation_study); "
            f"got {type(result).__name__}"
        )
    return isinstance(result, ExcitationStudy)


@x64
def summary(result: RobotStudy) -> dict:
    """The JSON-ready summary of a robot study (`summary.json` of `jaxsdp robot`).

    Example:
        >>> from jaxsdp.studies.robot import example_study, summary
        >>> sorted(summary(example_study())["joints"])
        ['joint1', 'joint2']
    """
    return excitation_summary(result) if _check(result) else study_summary(result)


@x64
def report(result: RobotStudy, *, figures=None) -> str:
    """The markdown report (`report.md` of `jaxsdp robot`).

    Example:
        >>> from jaxsdp.studies.robot import example_study, report
        >>> report(example_study()).splitlines()[0]
        '# Robot study: all joints at once'
    """
    links = list(figure_links(figures).values())
    return excitation_markdown(result, links) if _check(result) else report_markdown(result, links)


@x64
def text(result: RobotStudy) -> str:
    """What `jaxsdp robot` prints on stdout.

    Example:
        >>> from jaxsdp.studies.robot import example_study, text
        >>> "Stacked" in text(example_study())
        True
    """
    return excitation_text(result) if _check(result) else text_output(result)


@x64
def figures(result: RobotStudy) -> dict[str, "Figure"]:
    """Every figure of a robot study, keyed by its file stem.

    Example:
        >>> from jaxsdp.studies.robot import example_study, figures
        >>> list(figures(example_study()))
        ['joints', 'sdp_curves']
    """
    return {"trajectory": fig_trajectory(result)} if _check(result) else robot_figures(result)
