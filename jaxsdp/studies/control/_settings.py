"""The control study's options (`ControlSettings`) and its result (`ControlStudy`)."""

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class ControlSettings:
    """Options of `control_study` (defaults: the paper's section 4).

    `wn` (rad/s), `eta`: SDP-PD design; `velocity`: the controllers' velocity
    estimate ("fir", the benchmark's); `step` (m) and `t_pd` (s): the Fig. 14
    step, `t_real` (s) its horizon
    with the real drive (saturation is slow); `wn_grid`: candidates for the largest wn with the drive's delay;
    `ident_seconds`, `ident_hold` (s), `ident_noise` (fraction of the output
    std), `n`, `m`: the SRIVC experiment and model orders; `ratio`: outer /
    inner period (10: 100 Hz over 1 kHz); `ew`, `uw`, `xw`: PIP weights;
    `paper_lg`: the paper's loop gain; `v_limit` (m/s); `t_cascade` (s);
    `lg_grid`: loop gains tried for the hand tuning; `tune_iterations`: BFGS
    steps of the gradient tuning (0: skip), `tune_starts`: its starting inner
    wn values (rad/s); `seed`: noise and excitation; `dt` (s): inner period.
    """

    wn: float = 250.0
    eta: float = 1.0
    velocity: str = "fir"
    step: float = 0.05
    t_pd: float = 0.4
    t_real: float = 1.0
    wn_grid: tuple = tuple(float(w) for w in np.arange(100.0, 301.0, 5.0))
    ident_seconds: float = 10.0
    ident_hold: float = 0.2
    ident_noise: float = 0.05
    n: int = 2
    m: int = 0
    ratio: int = 10
    ew: float = 10.0
    uw: float = 1.0
    xw: float = 1.0
    paper_lg: float = 5.0
    v_limit: float = 0.15
    t_cascade: float = 3.0
    lg_grid: tuple = tuple(float(g) for g in np.geomspace(1e-3, 10.0, 81))
    tune_iterations: int = 30
    tune_starts: tuple = (10.0, 30.0)
    seed: int = 0
    dt: float = 1e-3


@dataclasses.dataclass
class ControlStudy:
    """Everything `control_study` computed: settings, identified models, designs, simulations, figures of merit.

    Dict fields hold the per-section results as plain numbers (the summary's
    sections) and the simulations (`jaxsdp.control.ControlSimulation`) for
    the figures; `warnings` lists what a user must know (e.g. an unstable
    cascade with the paper's loop gain); `timings` the seconds per stage.
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
