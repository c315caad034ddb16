"""Issue 42, item 7: a gallery of robots, each simulated as its logs would come and identified by `jaxsdp robot`
with no processing option.

The arms of `example-robot-data` (UR5, Panda, Z1, Kinova Jaco 2) and a lift-and-arm robot with a prismatic joint
(`robot_gallery.py`), at 100 Hz (20 s) and 1 kHz (10 s) with jittered stamps, friction and motor inertias, 1 %
torque noise, quantised positions and one dead torque channel, logs headed by the URDF's joint names in a shuffled
order with an extra column. Checks: the command runs on its defaults; the dead joint is judged not identifiable
and every other joint identifiable; the live joints' well-excited base parameters (relative standard deviation
below 10 %) lie within 10 % of the truth plus 3 standard deviations; no warning but the dead joint's.

Every test id starts with `gallery-` (`-k "not gallery"` deselects the module). One CLI run per case, shared by
its tests (`_run`); the SDP of the residuals is skipped (`--no-sdp`: not a processing option, and half of a
case's time).
"""

import contextlib
import io
import json

import numpy as np
import pytest
from robot_gallery import GALLERY, dead_joint, gallery_robot, true_base, write_gallery_logs

from helpers import EXAMPLE_ROBOTS

#: (rate Hz, seconds) of the two records of each robot.
RATES = {100: 20.0, 1000: 10.0}
#: Well-excited base parameters: relative standard deviation below this (%).
WELL_EXCITED = 10.0
#: Their tolerance: |estimate - truth| <= REL_TOL |truth| + N_STD standard deviations.
REL_TOL, N_STD = 0.10, 3.0
#: A live joint's relative error (%, in motion) stays below this (1 % torque noise; up to 6.9 % measured).
MAX_RELATIVE_ERROR = 10.0
#: Warnings that are statements about the test's trajectory (random sines, not designed: a few base parameters
#: poorly determined) or about the residual's statistics (serially correlated beyond a factor 2 of the standard
#: deviations: Coulomb friction at velocity reversals and the interpolation of jittered stamps leave structure
#: against 1 % white noise on thousands of rows), never a judgement on one joint's data or estimates. Measured
#: 2026-11-25: 4 of the 10 cases have no warning at all but the dead joint's; the others have one of these.
TRAJECTORY_OR_RESIDUAL = ("are not excited by this trajectory", "is serially correlated")


def _cases():
    out = []
    for name in GALLERY:
        marks = []
        if name != "prismatic" and EXAMPLE_ROBOTS is None:
            marks.append(pytest.mark.skip(reason="example-robot-data not installed (pip install example-robot-data)"))
        for rate in RATES:
            out.append(pytest.param(name, rate, id=f"gallery-{name}-{rate}hz", marks=marks))
    return out


CASES = _cases()
_RUNS = {}


def _run(name, rate, tmp_path_factory):
    """Simulate gallery robot `name` at `rate` Hz, run `jaxsdp robot` on the logs once: (exit code, stderr,
    summary or None, the generator's record)."""
    key = (name, rate)
    if key not in _RUNS:
        from jaxsdp._cli import main

        folder = tmp_path_factory.mktemp(f"gallery-{name}-{rate}hz")
        urdf, robot, tip = gallery_robot(name, folder=folder)
        logs = write_gallery_logs(
            folder, robot, rate_hz=rate, seconds=RATES[rate], dead_joint=dead_joint(name), seed=rate
        )
        logs["robot"] = robot
        out = folder / "out"
        argv = ["robot", "--urdf", str(urdf), "--positions", str(logs["positions"]), "--torques", str(logs["torques"])]
        argv += (["--tip-link", tip] if tip else []) + ["--no-sdp", "--out", str(out)]
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(argv)
        summary = json.loads((out / "summary.json").read_text()) if code == 0 else None
        _RUNS[key] = (code, err.getvalue(), summary, logs)
    return _RUNS[key]


def _summary(name, rate, tmp_path_factory):
    code, err, summary, logs = _run(name, rate, tmp_path_factory)
    assert code == 0, f"jaxsdp robot exited {code} on the defaults: {err[-2000:]}"
    return summary, logs


@pytest.mark.parametrize("name, rate", CASES)
def test_gallery_runs_on_defaults(name, rate, tmp_path_factory):
    summary, logs = _summary(name, rate, tmp_path_factory)
    assert set(summary["joints"]) == set(logs["names"])  # mapped by name, `temperature` ignored
    assert np.all(logs["peak_speed"] > 0.1)  # the motion moves every joint


@pytest.mark.parametrize("name, rate", CASES)
def test_gallery_dead_joint_flagged(name, rate, tmp_path_factory):
    summary, logs = _summary(name, rate, tmp_path_factory)
    judged = {k: j.get("identifiable") for k, j in summary["joints"].items()}
    assert judged == {k: k != logs["dead"] for k in logs["names"]}, judged
    for k in logs["live"]:
        assert summary["joints"][k]["relative_error"] < MAX_RELATIVE_ERROR, (k, summary["joints"][k])


@pytest.mark.parametrize("name, rate", CASES)
def test_gallery_base_parameters(name, rate, tmp_path_factory):
    summary, logs = _summary(name, rate, tmp_path_factory)
    good = [b for b in summary["base_parameters"] if b["rel_std"] is not None and b["rel_std"] < WELL_EXCITED]
    assert len(good) >= 5, f"only {len(good)} well-excited base parameters"
    if any(b["combination"] not in logs["truth"] for b in good):  # a study whose base keeps the dead joint's rows
        logs.setdefault("truth_all", true_base(logs["robot"], None))
    bad, unknown = [], []
    for b in good:
        truth = logs["truth"].get(b["combination"]) or logs.get("truth_all", {}).get(b["combination"])
        if truth is None:
            unknown.append(b["name"])
            continue
        sigma = b["rel_std"] / 100.0 * abs(b["value"])
        if abs(b["value"] - truth[1]) > REL_TOL * abs(truth[1]) + N_STD * sigma:
            bad.append(f"{b['name']} = {b['value']:.4g} (truth {truth[1]:.4g}, rel std {b['rel_std']:.3g} %)")
    assert not unknown, f"combinations not in the truth: {unknown}"
    assert not bad, bad


@pytest.mark.parametrize("name, rate", CASES)
def test_gallery_flags_only_the_dead_joint(name, rate, tmp_path_factory):
    """Nothing else flagged: every warning is the dead joint's or one about the trajectory or the residual's
    statistics (`TRAJECTORY_OR_RESIDUAL`); no description mismatch, sign or gravity warning on a live joint; the
    result plausible."""
    summary, logs = _summary(name, rate, tmp_path_factory)
    others = [w for w in summary["warnings"] if logs["dead"] not in w]
    flags = [w for w in others if not any(k in w for k in TRAJECTORY_OR_RESIDUAL)]
    assert not flags, flags
    assert summary["plausible"] is True
    assert not [r["name"] for r in summary["description"] if r["flag"]], summary["description"]
