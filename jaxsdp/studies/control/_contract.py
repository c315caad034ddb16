"""The control study's four presentation functions (the study contract, `jaxsdp.studies._contract`)."""

from typing import TYPE_CHECKING

from ..._runtime import x64
from .._contract import figure_links
from ._figures import control_figures
from ._report import control_summary, report_markdown, text_output
from ._settings import ControlStudy

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def _check(result) -> None:
    if not isinstance(result, ControlStudy):
        raise ValueError(f"`result` must be a ControlStudy (from control_study); got {type(result).__name__}")


@x64
def summary(result: ControlStudy) -> dict:
    """The JSON-ready summary of the control study (`summary.json` of `jaxsdp control`).

    `control_summary`: the step responses' figures of merit (settling time s,
    overshoot %, peak velocity m/s, peak force N), the SRIVC model, the PIP-LQ
    designs, the cascade, the gradients, the friction used, `warnings`,
    `timings` (s), `versions`. A `ControlStudy` from `control_study` only.

    Example:
        >>> from jaxsdp.studies.control import ControlSettings, control_study, summary
        >>> study = control_study(settings=ControlSettings(tune_iterations=0))  # the built-in data
        >>> s = summary(study)
        >>> s["sdp_pd"]["settling_time_s"] < 0.05, s["linear_pd"]["settling_time_s"] > 0.05  # s
        (True, True)
    """
    _check(result)
    return control_summary(result)


@x64
def report(result: ControlStudy, *, figures=None) -> str:
    """The markdown report (`report.md` of `jaxsdp control`).

    Warnings, the Fig. 14 table, the real drive, SRIVC against the paper's
    eq. (30), PIP, the cascade, the gradients, the figures (name -> file in
    `figures`, embedded when given) and the timings.

    Example:
        >>> from jaxsdp.studies.control import ControlSettings, control_study, report
        >>> study = control_study(settings=ControlSettings(tune_iterations=0))
        >>> report(study).splitlines()[0]
        '# SDP control of the EMPS (paper section 4)'
    """
    _check(result)
    return report_markdown(result, list(figure_links(figures).values()))


@x64
def text(result: ControlStudy) -> str:
    """What `jaxsdp control` prints on stdout.

    The step-response table (settling s, overshoot %, peak m/s), the SRIVC
    model, the PIP designs and the cascade.

    Example:
        >>> from jaxsdp.studies.control import ControlSettings, control_study, text
        >>> "SDP-PD" in text(control_study(settings=ControlSettings(tune_iterations=0)))
        True
    """
    _check(result)
    return text_output(result)


@x64
def figures(result: ControlStudy) -> dict[str, "Figure"]:
    """Every figure of the control study (`control_figures`), keyed by its file stem.

    The paper's Figs. 13 (friction forms) and 14 (step responses), the PIP-SDP
    cascade and the SRIVC fit.

    Example:
        >>> from jaxsdp.studies.control import ControlSettings, control_study, figures
        >>> sorted(figures(control_study(settings=ControlSettings(tune_iterations=0))))
        ['fig13_friction_forms', 'fig14_step_responses', 'pip_sdp_cascade', 'srivc_fit']
    """
    _check(result)
    return control_figures(result)
