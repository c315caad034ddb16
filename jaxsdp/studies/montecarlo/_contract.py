"""The Monte Carlo studies' four presentation functions (the study contract, `jaxsdp.studies._contract`).

This folder holds three studies, `identification_robustness`,
`control_robustness` and `robot_robustness`; each function serves every
result, through one table of each result type's presentation functions.
"""

import pathlib
from typing import TYPE_CHECKING

from ..._runtime import x64
from .._contract import figure_links
from ._control import ControlRobustness
from ._figures import control_figures, identification_figures
from ._identification import IdentificationRobustness
from ._report import control_report, control_summary, identification_report, identification_summary, text_output
from ._robot import RobotRobustness
from ._robot_report import robot_figures, robot_report, robot_summary, robot_text

if TYPE_CHECKING:
    from matplotlib.figure import Figure


#: Each study's result type -> its (summary, report, text, figures) functions.
_PRESENTATION = {
    IdentificationRobustness: (identification_summary, identification_report, text_output, identification_figures),
    ControlRobustness: (control_summary, control_report, text_output, control_figures),
    RobotRobustness: (robot_summary, robot_report, robot_text, robot_figures),
}


def _presentation(result) -> tuple:
    try:
        return _PRESENTATION[type(result)]
    except KeyError:
        raise ValueError(
            "`result` must be an IdentificationRobustness, ControlRobustness or RobotRobustness (from "
            f"identification_robustness, control_robustness or robot_robustness); got {type(result).__name__}"
        ) from None


@x64
def summary(result) -> dict:
    """The JSON-ready summary (`summary.json` of `jaxsdp montecarlo`) of either Monte Carlo study.

    `identification_summary` or `control_summary` by the result's type, with
    the run's figures (runs, devices, seconds), `warnings`, `timings` (s) and
    `versions`.

    Example:
        >>> from jaxsdp.studies.montecarlo import control_robustness, summary
        >>> s = summary(control_robustness(16, progress=False))
        >>> s["study"], s["runs"]
        ('control', 16)
    """
    return _presentation(result)[0](result)


@x64
def report(result, *, figures=None) -> str:
    """The markdown report (`report.md` of `jaxsdp montecarlo`) of either study.

    `identification_report` or `control_report` by the result's type; the
    figures (name -> file in `figures`) are embedded when given.

    Example:
        >>> from jaxsdp.studies.montecarlo import control_robustness, report
        >>> report(control_robustness(16, progress=False)).splitlines()[0]
        '# Monte Carlo: robustness of the SDP controllers (EMPS)'
    """
    paths = [pathlib.Path(name) for name in figure_links(figures).values()]
    return _presentation(result)[1](result, paths)


@x64
def text(result) -> str:
    """What `jaxsdp montecarlo` prints on stdout.

    The run's figures (runs, devices, seconds), then one line per estimator
    (bias %, coverage of the 95 % intervals) or per controller.

    Example:
        >>> from jaxsdp.studies.montecarlo import control_robustness, text
        >>> text(control_robustness(16, progress=False)).splitlines()[1].split(":")[0].strip()
        'linear PD'
    """
    return _presentation(result)[2](result)


@x64
def figures(result) -> dict[str, "Figure"]:
    """Every figure of either study, keyed by its file stem.

    `identification_figures` or `control_figures` by the result's type.

    Example:
        >>> from jaxsdp.studies.montecarlo import control_robustness, figures
        >>> sorted(figures(control_robustness(16, progress=False)))
        ['mc_envelope', 'mc_settling']
    """
    return _presentation(result)[3](result)
