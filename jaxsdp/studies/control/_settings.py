"""The control study's result (`ControlStudy`); its options are `jaxsdp.control.ControlSettings`."""

from typing import TYPE_CHECKING

import equinox as eqx

from ..._runtime import x64
from ...control._nominal import ControlSettings
from .._contract import Study
from ._figures import control_figures
from ._report import control_summary, report_markdown, text_output

if TYPE_CHECKING:
    from matplotlib.figure import Figure


class ControlStudy(Study):
    """Everything `control_study` computed: settings, identified models, designs, simulations, figures of merit.

    Dict fields hold the per-section results as plain numbers (the summary's
    sections) and the simulations (`jaxsdp.control.ControlSimulation`) for
    the figures; `srivc` holds the closed-loop identification by whichever
    estimator `settings.estimator` chose (named in its `estimator` key: the
    field keeps its name); `warnings` (tuple of one-line messages) lists what
    a user must know (e.g. an unstable cascade with the paper's loop gain);
    `timings` the seconds per stage; `versions` (jaxsdp, jax) and
    `fast_loops` what it ran with.

    **Methods:** `summary()`, `report(figures=None)`, `text()`, `figures()`
    (the study contract, `jaxsdp.studies.control.summary` and the others), and
    `with_timings(timings)`. A result is immutable.
    """

    settings: ControlSettings
    source: str = eqx.field(static=True)
    friction: dict
    sdp_pd: dict
    linear_pd: dict
    real_drive: dict
    srivc: dict
    pip: dict
    pip_paper_model: dict
    pip_sdp: dict
    gradients: dict
    sims: dict
    warnings: tuple = eqx.field(static=True)
    timings: dict
    versions: dict = eqx.field(static=True, default_factory=dict)
    fast_loops: str | None = eqx.field(static=True, default=None)

    @x64
    def summary(self) -> dict:
        """JSON-ready dict (`summary.json` of `jaxsdp control`, `control_summary`): the step responses' figures
        of merit (settling time s, overshoot %, peak velocity m/s, peak force N), the SRIVC (or RIVCBJ) model,
        the PIP-LQ designs, the cascade, the gradients, the friction used, `settings`, `warnings`, `timings`
        (s), `fast_loops`, `versions`; inf and NaN as null."""
        return control_summary(self)

    @x64
    def report(self, figures: dict[str, str] | None = None) -> str:
        """The markdown report (`report.md` of `jaxsdp control`): warnings, the Fig. 14 table (settling s,
        overshoot %, peaks m/s and N), the real drive, SRIVC against the paper's eq. (30), PIP, the cascade, the
        gradients, the figures (name -> file name, embedded when given) and the timings (s)."""
        return report_markdown(self, list(dict(figures or {}).values()))

    @x64
    def text(self) -> str:
        """What `jaxsdp control` prints: the step-response table (settling s, overshoot %, peak m/s and N), the
        SRIVC (or RIVCBJ) model and the cascade (the warnings are printed once, on stderr, by the command)."""
        return text_output(self)

    @x64
    def figures(self) -> dict[str, "Figure"]:
        """Every figure, keyed by its file stem (`control_figures`): the paper's Figs. 13 (friction forms, N
        against m/s) and 14 (step responses, mm against s), the PIP-SDP cascade and the SRIVC fit."""
        return control_figures(self)
