"""The option objects of `tx40_study`: the built-in experiment (`TX40Builtin`) and the full model (`FullModel`).

Checked when made (ValueError naming the field), as `jaxsdp.Preprocessing`
and `jaxsdp.MultiBackfitting`, which give the study's processing and
multi-SDP options.
"""

import math
import os

import equinox as eqx
import numpy as np

from ...data._model_convention import TX40_JOINT_OFFSETS, TX40_WRIST_COUPLING
from ...plants.robot._serial import SerialRobot

#: The built-in experiments (`TX40Builtin.case`).
CASES = ("link2", "all")


def _numbers(v):
    """A sequence of numbers as a tuple of floats (left as given when it is not one: `__check_init__` says why)."""
    if v is None:
        return None
    try:
        return tuple(float(x) for x in np.atleast_1d(np.asarray(v, dtype=float)))
    except (TypeError, ValueError):
        return v


def _pair(v):
    """A pair of joint numbers as a tuple of ints (left as given when it is not one)."""
    if v is None:
        return None
    try:
        values = tuple(v)
    except TypeError:
        return v
    if all(isinstance(x, (int, np.integer)) and not isinstance(x, bool) for x in values):
        return tuple(int(x) for x in values)
    return values


class TX40Builtin(eqx.Module):
    r"""A built-in TX40 experiment, simulated, written as real TX40 logs and read back (`tx40_study`'s data).

    **Fields:** `case`: "link2" (default; only link 2 moving, simulated from
    the paper's Table 4, its truth known: `jaxsdp.data.tx40_builtin_data`) or
    "all" (all six joints moving on the nominal six-joint TX40:
    `jaxsdp.data.tx40_all_joints_data`, its robot known); `seed`: the
    measurement-noise seed, an integer in $[0, 2^{32})$ (default 0);
    `logs_dir`: the folder the log files are written into (default None: a
    temporary folder, removed).

    Example:
        >>> from jaxsdp.studies.tx40 import TX40Builtin
        >>> TX40Builtin(case="all", seed=3).case
        'all'
    """

    case: str = eqx.field(static=True, default="link2")
    seed: int = eqx.field(static=True, default=0)
    logs_dir: str | os.PathLike | None = eqx.field(static=True, default=None)

    def __check_init__(self):
        if self.case not in CASES:
            raise ValueError(f"`case` must be one of {CASES}; got {self.case!r}")
        s = self.seed
        if isinstance(s, bool) or not isinstance(s, (int, np.integer)) or not 0 <= s < 2**32:
            raise ValueError(f"`seed` must be an integer in [0, 2**32); got {s!r}")
        if self.logs_dir is not None and not isinstance(self.logs_dir, (str, os.PathLike)):
            raise ValueError(f"`logs_dir` must be None or a folder (str or path); got {self.logs_dir!r}")


class FullModel(eqx.Module):
    r"""The full rigid-body model `tx40_study` also identifies the joint with (beyond the paper).

    **Fields:** `robot`: a `SerialRobot` (its kinematics, and its nominal
    parameters as the comparison), or None (default) for the nominal TX40
    (`jaxsdp.plants.tx40_robot()`; with the built-in "all" experiment, the
    robot it simulated); `joint_offsets`: added to the logs' joint angles to
    get the model's (rad, one per joint; None: none; default the TX40's
    $(0, -\pi/2, \pi/2, 0, 0, 0)$); `wrist_coupling`: a pair (a, b) of joint
    numbers, motor b also turning with joint a, or None (default the TX40's
    (5, 6)). The logs are brought to the model's convention by
    `jaxsdp.data.model_convention` with the last two.

    Example:
        >>> from jaxsdp.studies.tx40 import FullModel
        >>> FullModel(wrist_coupling=None).joint_offsets[1]  # rad
        -1.5707963267948966
    """

    robot: SerialRobot | None = None
    joint_offsets: tuple | None = eqx.field(static=True, default=TX40_JOINT_OFFSETS, converter=_numbers)
    wrist_coupling: tuple | None = eqx.field(static=True, default=TX40_WRIST_COUPLING, converter=_pair)

    def __check_init__(self):
        if self.robot is not None and not isinstance(self.robot, SerialRobot):
            raise ValueError(f"`robot` must be None or a SerialRobot; got {type(self.robot).__name__}")
        off = self.joint_offsets
        if off is not None and not (
            isinstance(off, tuple) and all(isinstance(v, float) and math.isfinite(v) for v in off)
        ):
            raise ValueError(f"`joint_offsets` must be None or finite angles (rad), one per joint; got {off!r}")
        pair = self.wrist_coupling
        if pair is not None and not (
            isinstance(pair, tuple)
            and len(pair) == 2
            and all(isinstance(j, int) and j >= 1 for j in pair)
            and pair[0] != pair[1]
        ):
            raise ValueError(f"`wrist_coupling` must be None or two different joint numbers (a, b) >= 1; got {pair!r}")
