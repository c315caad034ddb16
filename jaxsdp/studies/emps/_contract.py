"""The EMPS study's four presentation functions (the study contract, `jaxsdp.studies._contract`)."""

from typing import TYPE_CHECKING

from ..._runtime import x64
from .._contract import figure_links
from ._figures import emps_figures
from ._report import report_markdown, text_output
from ._study import EMPSStudy, study_summary

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def _check(result) -> None:
    if not isinstance(result, EMPSStudy):
        raise ValueError(f"`result` must be an EMPSStudy (from emps_study); got {type(result).__name__}")


@x64
def summary(result: EMPSStudy) -> dict:
    """The JSON-ready summary of an EMPS study (`summary.json` of `jaxsdp emps`).

    Estimates per stage (kg, N s/m, N) with their standard deviations,
    relative standard deviations (%), covariances and relative errors (%); the
    SDP stage (NVRs, mass constancy), the simulation check (%), the truth and
    its recovery (built-in plant, error %), `warnings`, `timings` (s), `versions`.

    Example:
        >>> from jaxsdp.studies.emps import emps_study, summary
        >>> s = summary(emps_study(check_decimation=False))
        >>> round(s["idim_ls_asym"]["M"], 1), s["simulation"]["position"] < 0.01  # kg, %
        (95.4, True)
    """
    _check(result)
    return study_summary(result)


@x64
def report(result: EMPSStudy, *, figures=None) -> str:
    """The markdown report (`report.md` of `jaxsdp emps`).

    Warnings, findings, the paper's Tables 1 and 2, the SDP stage, the
    checks, the figures (name -> file in `figures`, linked when given) and the
    timings.

    Example:
        >>> from jaxsdp.studies.emps import emps_study, report
        >>> report(emps_study(check_decimation=False)).splitlines()[0]
        '# EMPS identification report'
    """
    _check(result)
    return report_markdown(result, study_summary(result), figure_links(figures))


@x64
def text(result: EMPSStudy) -> str:
    """What `jaxsdp emps` prints on stdout.

    The paper's tables, the simulation check (relative errors %), the recovery
    of the built-in plant's truth and the findings; the warnings are printed
    once, on stderr, by the command (`result.warnings`).

    Example:
        >>> from jaxsdp.studies.emps import emps_study, text
        >>> "Table 1. IDIM-LS" in text(emps_study(check_decimation=False))
        True
    """
    _check(result)
    return text_output(result, study_summary(result))


@x64
def figures(result: EMPSStudy) -> dict[str, "Figure"]:
    """Every figure of an EMPS study (`emps_figures`), keyed by its file stem.

    The paper's Figs. 3-5 (SDP mass, linear and asymmetric friction) and the
    force reconstruction.

    Example:
        >>> from jaxsdp.studies.emps import emps_study, figures
        >>> sorted(figures(emps_study(check_decimation=False)))
        ['fig3_sdp_mass', 'fig4_friction_linear', 'fig5_friction_asym', 'force_reconstruction']
    """
    _check(result)
    return emps_figures(result)
