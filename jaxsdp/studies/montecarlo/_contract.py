"""The Monte Carlo studies' four presentation functions (the study contract, `jaxsdp.studies._contract`).

This folder holds two studies, `identification_robustness` and
`control_robustness`; each function serves both results (by their type).
"""

import pathlib
from typing import TYPE_CHECKING

from ..._runtime import x64
from .._contract import figure_links
from ._control import ControlRobustness
from ._figures import control_figures, identification_figures
from ._identification import IdentificationRobustness
from ._report import control_report, control_summary, identification_report, identification_summary, text_output

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def _is_identification(result) -> bool:
    if isinstance(result, IdentificationRobustness):
        return True
    if isinstance(result, ControlRobustness):
        return False
    raise ValueError(
        "`result` must be an IdentificationRobustness or a ControlRobustness (from identification_robustness or "
        f"control_robustness); got {type(result).__name__}"
    )


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
    return identification_summary(result) if _is_identification(result) else control_summary(result)


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
    return (identification_report if _is_identification(result) else control_report)(result, paths)


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
    _is_identification(result)
    return text_output(result)


@x64
def figures(result) -> dict[str, "Figure"]:
    """Every figure of either study, keyed by its file stem.

    `identification_figures` or `control_figures` by the result's type.

    Example:
        >>> from jaxsdp.studies.montecarlo import control_robustness, figures
        >>> sorted(figures(control_robustness(16, progress=False)))
        ['mc_envelope', 'mc_settling']
    """
    return identification_figures(result) if _is_identification(result) else control_figures(result)
