"""The control study's result (`ControlStudy`); its options are `jaxsdp.control.ControlSettings`."""

import dataclasses

from ...control._nominal import ControlSettings


@dataclasses.dataclass
class ControlStudy:
    """Everything `control_study` computed: settings, identified models, designs, simulations, figures of merit.

    Dict fields hold the per-section results as plain numbers (the summary's
    sections) and the simulations (`jaxsdp.control.ControlSimulation`) for
    the figures; `srivc` holds the closed-loop identification by whichever
    estimator `settings.estimator` chose (named in its `estimator` key: the
    field keeps its name); `warnings` lists what a user must know (e.g. an
    unstable cascade with the paper's loop gain); `timings` the seconds per
    stage; `versions` (jaxsdp, jax) and `fast_loops` what it ran with.
    """

    settings: ControlSettings
    source: str
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
    warnings: list
    timings: dict
    versions: dict = dataclasses.field(default_factory=dict)
    fast_loops: str | None = None
