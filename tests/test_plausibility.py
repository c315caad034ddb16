"""Scales checked against physics (issue 41, deliverable 3): wrong units and a wrong sampling period are warned.

The real EMPS record with its position in millimetres and the real TX40 logs read with `--dt 2e-3` (ten times
the true 0.2 ms) fit as well as the right ones; only the parameters scale. Each study compares what it identified
and read with what physics and the description allow, warns naming the cause (units, time scale) and the option
that fixes it, and sets `plausible` false. No false alarm on the real records and the built-in ones.

The study runs are the session's (`tests/conftest.py`) or each study's cached example; the new runs are one EMPS
study on the millimetre record, the two commands and one robot study on the example arm's logs.
"""

import json
import re

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from helpers import EMPS_MAT, TX40_CURRENTS, TX40_POSITIONS, check_quoted, requires_emps, requires_tx40
from jaxsdp._cli import main
from jaxsdp._idim.trust import CAVEAT
from jaxsdp.plants._plausibility import (
    MAX_FRICTION_RATIO,
    MAX_INERTIA_FACTOR,
    inertia_warning,
    linear_axis_checks,
    linear_axis_warnings,
    scale_cause,
)

# one worker runs the file (`--dist loadgroup`), so that its module and session fixtures run once
pytestmark = pytest.mark.xdist_group("tx40-real-study")

jax.config.update("jax_enable_x64", True)


def _quiet(study):
    """No scale warning, every scale check passed (or not applicable), plausible."""
    assert not [w for w in study.warnings if w.startswith("scale check")], study.warnings
    assert study.scale_checks and all(r["passed"] is not False for r in study.scale_checks), study.scale_checks
    assert study.plausible


# --------------------------------------------------------------------------- #
# The rules, on their own
# --------------------------------------------------------------------------- #


@pytest.mark.parametrize(
    "k,c",
    [(10.0, 1.0), (0.1, 1.0), (1.0, 20.0), (1.0, 0.05), (7.0, 1.3)],
    ids=["dt10", "dt0.1", "tau20", "tau0.05", "dt7"],
)
def test_scale_cause_reads_the_pattern(k, c):
    # dt k times too large: inertia k^2 c, viscous k c, static c; a torque c times too large: all c
    rng = np.random.default_rng(0)
    noise = np.exp(rng.uniform(-0.3, 0.3, 3))  # CAD values within 35 %
    cause, f = scale_cause(k * k * c * noise[0], viscous=k * c * noise[1], static=c * noise[2])
    if k != 1.0:
        assert cause == "time scale" and abs(np.log(f / k)) < 0.4
    else:
        assert cause == "torque scale" and abs(np.log(f / c)) < 0.4


def test_scale_cause_blames_the_description_when_no_pattern_fits():
    assert scale_cause(60.0, viscous=1.0, static=8.0)[0] == "load"


def test_inertia_warning_names_the_time_scale_and_the_option():
    opts = {"time scale": "dt= (--dt)", "torque scale": "torque_constants= (--torque-constants)"}
    assert inertia_warning("ZZ", 1.5, 1.0, "the CAD", viscous=1.0, static=1.0, dt=1e-3, options=opts) is None
    w = inertia_warning("ZZ", 100.0, 1.0, "the CAD", viscous=10.0, static=1.0, dt=2e-3, options=opts)
    assert "sampling period about 10 times too large" in w and "about 0.0002 s" in w and "--dt" in w
    w = inertia_warning("ZZ", 0.02, 1.0, "the CAD", viscous=0.02, static=0.02, dt=2e-3, options=opts)
    assert "torque" in w and "--torque-constants" in w


class _Axis(eqx.Module):
    q_full: jax.Array
    dq_full: jax.Array
    ddq_full: jax.Array
    y_full: jax.Array


def test_linear_axis_checks_scale_with_the_unit():
    t = np.arange(0.0, 10.0, 1e-3)
    w = 2 * np.pi * 0.2
    q, dq, ddq = 0.1 * np.sin(w * t), 0.1 * w * np.cos(w * t), -0.1 * w * w * np.sin(w * t)
    force = 95.0 * ddq + 20.0 * np.sign(dq)
    fits = {"LS": (95.0, 20.0)}
    ok = linear_axis_checks(_Axis(*map(jnp.asarray, (q, dq, ddq, force))), fits)
    assert all(r["passed"] for r in ok) and not linear_axis_warnings(ok, fits)
    mm = {"LS": (0.095, 20.0)}  # the same record in millimetres: M / 1000, Fc unchanged
    bad = linear_axis_checks(_Axis(*map(jnp.asarray, (1e3 * q, 1e3 * dq, 1e3 * ddq, force))), mm)
    failed = {r["check"] for r in bad if not r["passed"]}
    assert {"position range", "peak speed", "Coulomb friction / weight M g"} <= failed
    (text,) = linear_axis_warnings(bad, mm)
    assert "not in metres" in text and "divide it by 1000" in text and f"at most {MAX_FRICTION_RATIO:g}" in text


# --------------------------------------------------------------------------- #
# EMPS
# --------------------------------------------------------------------------- #


@requires_emps
def test_real_emps_record_no_false_alarm(emps_real_study):
    _quiet(emps_real_study)
    rows = {r["check"]: r["value"] for r in emps_real_study.summary()["scale_checks"]}
    assert 0.2 < rows["position range"] < 0.3 and rows["Coulomb friction / weight M g"] < 0.05


def test_builtin_emps_no_false_alarm(emps_builtin_study):
    _quiet(emps_builtin_study)


@requires_emps
def test_emps_record_in_millimetres_is_warned():
    from jaxsdp.data import load_emps
    from jaxsdp.studies.emps import emps_study, report

    data = load_emps(EMPS_MAT)
    mm = eqx.tree_at(lambda d: d.qm, data, data.qm * 1000.0)  # the position channel in mm
    study = emps_study(mm, check_decimation=False, check_simulation=False)
    assert study.idim["M"] < 0.1 and study.idim["Fc"] > 20.0  # kg, N: the wrong-unit estimates of the issue
    (w,) = [w for w in study.warnings if w.startswith("scale check")]
    assert "not in metres" in w and "millimetres" in w and "divide it by 1000" in w
    assert "Coulomb friction / weight M g 2" in w
    assert not study.plausible and study.findings[0] == CAVEAT
    s = study.summary()
    assert s["plausible"] is False and w in s["warnings"]
    assert w in report(study)
    (ratio,) = [r["value"] for r in s["scale_checks"] if r["check"] == "Coulomb friction / weight M g"]
    check_quoted("docs/trust.md", "millimetres (M = {} kg,", study.idim["M"], ".3g")  # issue 43: the page's quotes
    check_quoted("docs/trust.md", "kg, Fc = {} N,", study.idim["Fc"], ".2f")
    check_quoted("docs/trust.md", "N, {} times the weight)", ratio, ".0f")


@requires_emps
def test_cli_emps_millimetre_csv(tmp_path, capsys):
    from jaxsdp.data import load_emps

    data = load_emps(EMPS_MAT)
    csv = tmp_path / "emps_mm.csv"
    cols = np.c_[np.asarray(data.t), 1000.0 * np.asarray(data.qm), np.asarray(data.force)]
    np.savetxt(csv, cols, delimiter=",", header="t,q,force", comments="")
    out = tmp_path / "out"
    assert main(["emps", "--data", str(csv), "--no-decimation-check", "--out", str(out), "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "jaxsdp emps: warning: scale check:" in err and "millimetres" in err
    s = json.loads((out / "summary.json").read_text())
    assert s["plausible"] is False and any("millimetres" in w for w in s["warnings"])
    assert "millimetres" in (out / "report.md").read_text()


# --------------------------------------------------------------------------- #
# TX40
# --------------------------------------------------------------------------- #


@requires_tx40
def test_real_tx40_logs_no_false_alarm(tx40_real_study):
    _quiet(tx40_real_study)
    (zz,) = [r for r in tx40_real_study.scale_checks if r["check"].startswith("ZZ2 /")]
    assert 1 / MAX_INERTIA_FACTOR < zz["value"] < MAX_INERTIA_FACTOR  # 0.91 of the paper's Table 5


def test_builtin_tx40_no_false_alarm():
    from jaxsdp.studies.tx40 import example_study

    _quiet(example_study())


@requires_tx40
def test_cli_tx40_dt_ten_times_too_large(tmp_path, capsys):
    out = tmp_path / "out"
    argv = ["tx40", "--positions", str(TX40_POSITIONS), "--torques", str(TX40_CURRENTS), "--dt", "2e-3"]
    assert main([*argv, "--no-settings-check", "--out", str(out), "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "jaxsdp tx40: warning: scale check: the identified inertia ZZ2" in err
    s = json.loads((out / "summary.json").read_text())
    assert s["plausible"] is False and s["idim_ls"]["ZZ2"] > 50
    (w,) = [w for w in s["warnings"] if w.startswith("scale check")]
    assert "sampling period about 9.2 times too large" in w and "about 0.00022 s" in w and "--dt" in w
    assert w in (out / "report.md").read_text()
    # what docs/trust.md quotes of this run (issue 43): ZZ2, the viscous and static ratios, the warning's words
    viscous, static = (s["scale_checks"][i]["value"] for i in (1, 2))
    check_quoted("docs/trust.md", "(ten times the true 0.2 ms), ZZ2 = {}", s["idim_ls"]["ZZ2"], ".2f")
    check_quoted("docs/trust.md", "viscous friction {} times, Coulomb and gravity {} times", (viscous, static), ".1f")
    factor, period = re.search(r"about (\S+) times too large.* probably about (\S+) s", w).groups()
    check_quoted("docs/trust.md", "a sampling period about {} times too large", factor, "")
    check_quoted("docs/trust.md", "is probably about {} s;", period, "")
    robots = 'a sampling period about {} times too large ... dt = 0.002 s is probably about {} s"'
    check_quoted("docs/guides/robots.md", robots, (factor, period), "")  # the robots guide's warnings table


# --------------------------------------------------------------------------- #
# Any robot
# --------------------------------------------------------------------------- #


def test_robot_example_no_false_alarm():
    from jaxsdp.studies.robot import example_study, summary

    s = example_study()
    _quiet(s)
    assert summary(s)["plausible"] is True
    (inertia,) = [r["value"] for r in summary(s)["scale_checks"] if r["check"].startswith("joint-space inertia")]
    check_quoted("docs/trust.md", "example arm {} |", inertia, ".1f")  # issue 43: the page's quote


def _example_arm_study(*, dt_factor=1.0, torque_factor=1.0):
    """The robot example's arm and motion (`jaxsdp.studies.robot.example_study`) with its logs' time or torque
    scaled as a wrong `dt` or torque unit would; the shapes of the example, so its compilation is reused."""
    from jaxsdp.data import JointLogs
    from jaxsdp.studies.robot import example_study, robot_study
    from jaxsdp.studies.robot._example import example_motion

    arm = example_study().idim.model.robot
    t = np.arange(0.0, 20.0, 1e-3)
    q, dq, ddq = example_motion(t)
    tau = np.asarray(arm.drive_torques(q, dq, ddq)) + 2.0 * np.random.default_rng(0).standard_normal(q.shape)
    t = t * dt_factor
    logs = JointLogs(
        q=jnp.asarray(q),
        tau=jnp.asarray(torque_factor * tau),
        t=jnp.asarray(t),
        dt=1e-3 * dt_factor,
        joints=(1, 2),
        source="example arm",
        converted="none",
    )
    return robot_study(logs, robot=arm, sdp=False)


def _robot_cli(message: str) -> str:
    """`message` as `jaxsdp robot` prints it (the library names arguments, the command its options)."""
    from jaxsdp._cli import flags_of
    from jaxsdp._cli.common import cli_text

    return cli_text(message, flags_of("robot"))


def test_robot_dt_ten_times_too_small():
    s = _example_arm_study(dt_factor=0.1)
    (w,) = [w for w in s.warnings if w.startswith("scale check")]
    assert "sampling period about 10 times too small" in w and "about 0.001 s" in w and "`dt` of load_joint_logs" in w
    assert "set the logs' time column or --dt" in _robot_cli(w)  # what `jaxsdp robot` prints
    assert not s.plausible and s.findings[0] == CAVEAT


def test_robot_torque_unit_is_named():
    s = _example_arm_study(torque_factor=20.0)  # e.g. a torque constant 20 times too large
    (w,) = [w for w in s.warnings if w.startswith("scale check")]
    assert "every torque term is off alike, about 20 times" in w and "(`drives`)" in w
    assert "(--drives)" in _robot_cli(w)
    assert not s.plausible
