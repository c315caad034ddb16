"""`jaxsdp robot` on a robot it has never seen, first try (issue 42): the command's messages name its options
with a value to use, before any work."""

import pytest
from robot_gallery import dead_joint, gallery_robot, write_gallery_logs

from helpers import EXAMPLE_ROBOTS, requires_example_robots
from jaxsdp._cli import main


@pytest.fixture(scope="module")
def lift_logs(tmp_path_factory):
    """The gallery's prismatic lift arm at 100 Hz (jittered stamps, URDF-named columns, one dead channel)."""
    folder = tmp_path_factory.mktemp("lift")
    urdf, robot, _ = gallery_robot("prismatic", folder=folder)
    logs = write_gallery_logs(folder, robot, rate_hz=100.0, seconds=8.0, dead_joint=dead_joint("prismatic"))
    return urdf, logs


def test_a_cutoff_the_logs_cannot_take_is_refused_with_a_value(lift_logs, tmp_path, capsys):
    urdf, logs = lift_logs
    argv = ["robot", "--urdf", str(urdf), "--positions", str(logs["positions"]), "--torques", str(logs["torques"])]
    argv += ["--out", str(tmp_path / "out"), "--cutoff", "100", "--quiet"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--cutoff" in err and "Nyquist frequency 50" in err and "--cutoff=" in err, err
    assert "cutoff_hz" not in err and not (tmp_path / "out").exists()


@requires_example_robots
def test_a_tree_names_the_tip_link_to_pass(lift_logs, tmp_path, capsys):
    _, logs = lift_logs
    panda = EXAMPLE_ROBOTS / "panda_description" / "urdf" / "panda.urdf"
    argv = ["robot", "--urdf", str(panda), "--positions", str(logs["positions"]), "--torques", str(logs["torques"])]
    assert main([*argv, "--out", str(tmp_path / "out"), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "--tip-link 'panda_hand'" in err and "tip_link" not in err and "joints=" not in err, err


@requires_example_robots
def test_logs_without_the_gripper_joint_name_the_tip_link(tmp_path, capsys):
    urdf, robot, tip = gallery_robot("z1", folder=tmp_path)  # the arm's six joints, as the logs hold them
    logs = write_gallery_logs(tmp_path, robot, rate_hz=100.0, seconds=4.0, dead_joint=dead_joint("z1"))
    argv = ["robot", "--urdf", str(urdf), "--positions", str(logs["positions"]), "--torques", str(logs["torques"])]
    assert main([*argv, "--out", str(tmp_path / "out"), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "no column for joint(s) 'jointGripper'" in err and "pass --tip-link gripperStator" in err, err
