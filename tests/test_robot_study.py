"""`jaxsdp robot` (issue 31, item 6): any robot from its URDF and joint logs, all joints at once."""

import json

import jax

from helpers import TX40_CURRENTS, TX40_POSITIONS, TX40_URDF, requires_tx40, requires_tx40_urdf
from jaxsdp._cli import main
from jaxsdp.studies.robot import RobotStudy, example_study, figures, report, summary, text

jax.config.update("jax_enable_x64", True)


def test_example_study_contract():
    s = example_study()
    assert isinstance(s, RobotStudy)
    out = summary(s)
    assert set(out["joints"]) == {"joint1", "joint2"}
    assert {"relative_error", "sdp_relative_error", "whiteness"} <= set(out["joints"]["joint1"])
    assert out["rank"] == len(out["base_parameters"]) and out["condition_number"] > 0
    assert {"name", "value", "rel_std", "combination", "nominal"} <= set(out["base_parameters"][0])
    # a parametric truth with white noise: the curves follow the parametric shapes, no false finding
    assert not any(j["shape_mismatch"] for j in out["joints"].values())
    assert report(s).startswith("# Robot study") and "Stacked" in text(s)
    assert list(figures(s)) == ["joints", "sdp_curves"]
    json.dumps(out)


@requires_tx40
@requires_tx40_urdf
def test_cli_robot_tx40_six_joints(tmp_path):
    out = tmp_path / "robot"
    argv = ["robot", "--urdf", str(TX40_URDF), "--drives", "tx40", "--positions", str(TX40_POSITIONS)]
    argv += ["--torques", str(TX40_CURRENTS), "--dt", "2e-4", "--out", str(out), "--quiet"]
    assert main(argv) == 0
    s = json.loads((out / "summary.json").read_text())
    assert list(s["joints"]) == [f"joint_{j}" for j in range(1, 7)]
    toolbox = [12.5, 14.2, 21.8, 18.3, 21.3, 21.8]
    for (name, j), limit in zip(s["joints"].items(), toolbox):
        assert j["relative_error"] < limit, (name, j["relative_error"])
        assert j["sdp_relative_error"] < j["relative_error"], name
    assert s["stacked_relative_error"] < 14.6 and s["rank"] == 58
    assert (out / "joints.png").exists() and (out / "sdp_curves.png").exists()


def test_cli_robot_errors(tmp_path):
    bad = tmp_path / "bad.urdf"
    bad.write_text("<notarobot/>")
    csv = tmp_path / "x.csv"
    csv.write_text("Joint_1\n" + "\n".join(str(0.01 * k) for k in range(20)) + "\n")
    argv = ["robot", "--urdf", str(bad), "--positions", str(csv), "--torques", str(csv), "--dt", "1e-3"]
    assert main([*argv, "--out", str(tmp_path / "o")]) == 1
    assert main(["robot", "--positions", str(csv)]) == 2  # --urdf is required: a usage error
