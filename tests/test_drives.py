"""Drives as data (issue 31, item 2): ratios, torque constants, signs, offsets and the transmission matrix."""

import jax
import numpy as np
import pytest

from helpers import TX40_CURRENTS, TX40_POSITIONS, requires_tx40
from jaxsdp.data import Drives, load_joint_logs, model_convention

jax.config.update("jax_enable_x64", True)


def test_round_trip_motor_to_joint_and_back():
    rng = np.random.default_rng(0)
    d = Drives(
        [10.0, -20.0, 30.0, 7.0],
        torque_constants=[0.5, 0.8, 1.2, 0.3],
        signs=[1, -1, 1, 1],
        offsets=[0.1, 0.0, -0.3, 0.2],
        transmission=np.eye(4) + np.diag([0.0, 0.0, 0.0], -1) + np.triu(rng.normal(size=(4, 4)) * 0.2, 1),
    )
    pos, val = rng.normal(size=(2, 50, 4))
    np.testing.assert_allclose(d.motor_positions(d.joint_positions(pos)), pos, atol=1e-12)
    np.testing.assert_allclose(d.motor_values(d.joint_torques(val)), val, atol=1e-12)
    # the same power on both sides: tau . dq = tau_u . du, tau_u = s N K value, du = s dpos / N
    dpos = rng.normal(size=(50, 4))
    dq = d.joint_positions(dpos) - d.offsets
    tau_u = d.signs * d.ratios * d.torque_constants * val
    du = d.signs * dpos / d.ratios
    np.testing.assert_allclose(np.sum(d.joint_torques(val) * dq, axis=1), np.sum(tau_u * du, axis=1), atol=1e-10)


def test_tx40_wrist_coupling():
    d = Drives.builtin("tx40")
    assert d.coupled() == [(6, [5, 6])]
    u = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    q = d.joint_positions(u * d.ratios)
    np.testing.assert_allclose(q, [0.1, 0.2 - np.pi / 2, 0.3 + np.pi / 2, 0.4, 0.5, 0.1], atol=1e-15)
    tau = d.joint_torques(np.ones(6))
    np.testing.assert_allclose(tau, [32, 32, 45, -48, 45 + 32, 32])  # tau_5 = N5 curr5 + N6 curr6
    # motor 6's inertia and friction columns enter joints 5 and 6, in its coordinate du6 = dq5 + dq6
    dq, ddq = np.arange(1.0, 7.0), np.arange(2.0, 8.0)
    Y = d.motor_regressor(dq, ddq)
    names = d.motor_parameter_names()
    fv6 = Y[:, names.index("Fv_m6")]
    np.testing.assert_allclose(fv6, [0, 0, 0, 0, dq[4] + dq[5], dq[4] + dq[5]])
    fv2 = Y[:, names.index("Fv_m2")]
    np.testing.assert_allclose(fv2, [0, dq[1], 0, 0, 0, 0])


def test_toml_file(tmp_path):
    f = tmp_path / "arm.toml"
    f.write_text("[drives]\nratios = [50, -100]\ntorque_constants = [0.1, 0.2]\ncoupling = [[1, 2]]\n")
    d = Drives.from_toml(f)
    np.testing.assert_allclose(d.transmission, [[1, 0], [-1, 1]])
    assert Drives.from_toml("tx40").coupled() == [(6, [5, 6])]
    bad = tmp_path / "bad.toml"
    bad.write_text("ratios = [1, 2]\ngear = 3\n")
    with pytest.raises(ValueError, match="unknown keys \\['gear'\\]"):
        Drives.from_toml(bad)
    with pytest.raises(ValueError, match="singular"):
        Drives([1, 1], transmission=[[1, 1], [1, 1]])
    with pytest.raises(ValueError, match="non-zero"):
        Drives([1, 0])
    with pytest.raises(ValueError, match="no built-in drives named 'ur5'"):
        Drives.builtin("ur5")


@requires_tx40
def test_tx40_logs_through_the_drives_equal_model_convention():
    raw = load_joint_logs(TX40_POSITIONS, TX40_CURRENTS, dt=2e-4)
    logs = load_joint_logs(TX40_POSITIONS, TX40_CURRENTS, dt=2e-4, ratios=Drives.builtin("tx40").ratios)
    a, b = Drives.builtin("tx40").convert(raw), model_convention(logs)
    np.testing.assert_allclose(a.q, b.q, atol=1e-12)
    np.testing.assert_allclose(a.tau, b.tau, atol=1e-9)


def test_repr_names_every_conversion_it_applies():
    # the report's "Data:" line and summary.json show this text: currents converted with K must say so
    d = Drives([100.0, 120.0, 80.0], torque_constants=[0.11, 0.11, 0.07], signs=[1, -1, 1])
    text = repr(d)
    assert "torque_constants=[0.11, 0.11, 0.07]" in text and "signs=[1, -1, 1]" in text
    assert "torque_constants" not in repr(Drives([2.0, 3.0])) and "signs" not in repr(Drives([2.0, 3.0]))
