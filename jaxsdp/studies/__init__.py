"""Studies: one subpackage per study, each holding its pipeline, figures and report writer.

Every study folder exports its study function and the same four functions of
its result (the study contract, `jaxsdp.studies._contract`): `summary`
(summary.json), `report` (report.md), `text` (what the command prints) and
`figures`. A study stands on the shared stages below it (the plant families'
identification stages in `jaxsdp.plants.emps` and `jaxsdp.plants.robot`, the
nominal designs in `jaxsdp.control`) and never imports another study
(`tests/test_layout.py` checks it).

- `jaxsdp.studies.emps`: the EMPS identification study (paper section 2),
  the back end of `jaxsdp emps`;
- `jaxsdp.studies.control`: the SDP control study (paper section 4), the
  back end of `jaxsdp control`;
- `jaxsdp.studies.tx40`: the TX40 robot study (paper section 3), the back
  end of `jaxsdp tx40`;
- `jaxsdp.studies.robot`: any serial robot from its URDF and joint logs,
  all joints identified at once and the SDP of each residual, the back end
  of `jaxsdp robot`;
- `jaxsdp.studies.montecarlo`: Monte Carlo robustness studies on the
  built-in EMPS, of the identification (IDIM-LS, IDIM-IV, SDP stage,
  IDIM-SDP over noisy experiments) and of the control (the step responses
  of the controllers over plants drawn around the nominal model), the back
  end of `jaxsdp montecarlo`;
- `jaxsdp.studies.forecast`: a series' dynamic harmonic regression, its
  forecasts with intervals and their hold-out check, the back end of
  `jaxsdp forecast`.
"""

from . import control, emps, forecast, montecarlo, robot, tx40

__all__ = [
    "control",
    "emps",
    "forecast",
    "montecarlo",
    "robot",
    "tx40",
]
