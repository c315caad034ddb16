"""The TX40 study's four presentation functions (the study contract, `jaxsdp.studies._contract`)."""

from typing import TYPE_CHECKING

from ..._runtime import x64
from .._contract import figure_links
from ._figures import tx40_figures
from ._report import report_markdown, study_summary, text_output
from ._study import TX40Study

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def _check(result) -> None:
    if not isinstance(result, TX40Study):
        raise ValueError(f"`result` must be a TX40Study (from tx40_study); got {type(result).__name__}")


@x64
def summary(result: TX40Study) -> dict:
    """The JSON-ready summary of a TX40 study (`summary.json` of `jaxsdp tx40`).

    IDIM-LS and multi-SDP estimates (kg m^2, kg m, N m s/rad, N m) with their
    relative standard deviations (%), relative errors (%), residual whiteness,
    the reference table, the recovery of a known truth, the full model when
    run, `warnings`, `timings` (s), `versions`.

    Example:
        >>> from jaxsdp.studies.tx40 import example_study, summary
        >>> summary(example_study())["sdp"]["converged"]
        True
    """
    _check(result)
    return study_summary(result)


@x64
def report(result: TX40Study, *, figures=None) -> str:
    """The markdown report (`report.md` of `jaxsdp tx40`).

    Warnings, data and settings, the Table 4/5 layout, recovery, whiteness,
    the paper's estimates, findings, the figures (name -> file in `figures`,
    embedded when given) and the timings.

    Example:
        >>> from jaxsdp.studies.tx40 import example_study, report
        >>> report(example_study()).splitlines()[0]
        '# TX40 study, joint 2 (paper section 3)'
    """
    _check(result)
    return report_markdown(result, list(figure_links(figures).values()))


@x64
def text(result: TX40Study) -> str:
    """What `jaxsdp tx40` prints on stdout.

    The data line, the Table 4/5 layout, the multi-SDP outcome and the
    residual whiteness (the warnings go to stderr).

    Example:
        >>> from jaxsdp.studies.tx40 import example_study, text
        >>> "IDIM-SDP" in text(example_study())
        True
    """
    _check(result)
    return text_output(result)


@x64
def figures(result: TX40Study) -> dict[str, "Figure"]:
    """Every figure of a TX40 study (`tx40_figures`), keyed by its file stem.

    The paper's Figs. 7-9 (10-11 when all links move), the residual
    autocorrelation, and the full model's figure when it ran.

    Example:
        >>> from jaxsdp.studies.tx40 import example_study, figures
        >>> list(figures(example_study()))[:2]
        ['fig7_shapes', 'fig8_sdp_reconstruction']
    """
    _check(result)
    return tx40_figures(result)
