"""The control study end to end at small settings, and `jaxsdp control`."""

import json

import numpy as np
import pytest

from jaxsdp._cli import main
from jaxsdp.studies.control import (
    ControlSettings,
    FrictionEstimate,
    control_study,
    control_summary,
    report_markdown,
    text_output,
)

SMALL = ControlSettings(
    t_pd=0.3,
    wn_grid=tuple(float(w) for w in range(170, 251, 20)),
    ident_seconds=4.0,
    t_cascade=1.5,
    lg_grid=tuple(float(g) for g in np.geomspace(3e-3, 0.3, 21)),
    tune_iterations=2,
    tune_starts=(30.0,),
)


def friction_estimate():
    """An SDP-like friction curve of the true plant (the identification has its own tests)."""
    rng = np.random.default_rng(0)
    v = np.sort(rng.uniform(-0.13, 0.13, 2000))
    f = np.where(v > 0, 166.7 * v + 20.14, 240.4 * v - 20.63) * (1 - np.exp(-np.abs(v) / 0.004))
    return FrictionEstimate(
        velocity=v,
        friction=f + rng.normal(scale=0.5, size=v.size),
        idim_ls=dict(M=95.11, Fv=203.5, Fc=20.39, offset=-3.16),
        asymmetric=dict(M=95.15, Fv_pos=166.7, Fc_pos=20.14, Fv_neg=240.4, Fc_neg=20.63),
        source="test curve",
    )


@pytest.fixture(scope="module")
def study():
    return control_study(friction=friction_estimate(), settings=SMALL)


def test_study_reproduces_the_papers_findings(study):
    pd, lin, rd = study.sdp_pd, study.linear_pd, study.real_drive
    # Fig. 14: SDP-PD settles in about 0.03 s without overshoot, the linear PD ~3x slower, oscillatory.
    assert pd["settling_time_s"] < 0.04 and pd["overshoot_pct"] < 1
    assert lin["settling_time_s"] > 2.5 * pd["settling_time_s"] and lin["overshoot_pct"] > 20
    assert pd["max_force"] > 100 * rd["saturation"]["force_limit"]  # far beyond the drive
    # The drive's delay makes wn = 250 ring; a smaller wn keeps the overshoot under 2 %.
    assert rd["delay"]["overshoot_pct"] > 10
    assert 170 <= rd["largest_wn_delay"] < 250 and rd["delay_largest_wn"]["overshoot_pct"] < 2
    # SRIVC on the SDP-PD loop: converged, good fit, unity steady-state gain.
    sr = study.srivc
    assert sr["converged"] and sr["fit_pct"] > 99
    assert np.isclose(sum(sr["discrete_num"]) / sum(sr["discrete_den"]), 1.0, atol=0.02)
    assert np.isclose(sr["num"][-1] / sr["den"][-1], 1.0, atol=0.02)
    # The cascade meets the velocity limit; the paper's LG = 5 does not fit this faster model.
    ps = study.pip_sdp
    assert ps["stable"] and ps["max_velocity"] <= SMALL.v_limit
    assert not ps["paper_loop_gain"]["stable"] and any("LG = 5" in w for w in study.warnings)
    # Gradients through design and simulation agree with central differences.
    assert study.gradients["max_rel_diff"] < 1e-4


def test_summary_report_and_text(study):
    summary = control_summary(study)
    json.dumps(summary, allow_nan=False)
    for section, keys in {
        "sdp_pd": ("settling_time_s", "overshoot_pct", "kp", "wn", "eta"),
        "linear_pd": ("settling_time_s", "overshoot_pct"),
        "srivc": ("num", "den", "num_se", "den_se", "discrete_num", "discrete_den"),
        "pip": ("gains", "closed_loop_poles"),
        "pip_paper_model": ("gains", "closed_loop_poles"),
        "pip_sdp": ("settling_time_s", "overshoot_pct", "max_velocity", "loop_gain"),
        "sdp_pd_real_drive": ("delay", "saturation", "largest_wn_delay"),
    }.items():
        assert all(k in summary[section] for k in keys), section
    assert summary["timings"] and summary["warnings"] == list(study.warnings)
    assert set(summary["pip_paper_model"]["gains"]) == {"f0", "f1", "g1", "g2", "kI"}
    report = report_markdown(study)
    assert "## Warnings" in report and "(30)" in report and "Fig. 14" in report
    assert "SRIVC" in text_output(study)


def test_cli_control_writes_outputs(tmp_path, monkeypatch, capsys):
    import jaxsdp._cli.control as cli
    import jaxsdp.studies.control._study as study_module

    # Small settings and a ready friction estimate: this tests the command, not the study.
    monkeypatch.setattr(cli, "ControlSettings", lambda **kw: SMALL.__class__(**{**vars(SMALL), **kw}))
    monkeypatch.setattr(study_module, "identify_friction", lambda data, seed: (friction_estimate(), ["test note"]))
    out = tmp_path / "out"
    assert main(["control", "--out", str(out), "--quiet", "--tune-iterations", "1"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["sdp_pd"]["wn"] == 250.0 and summary["settings"]["tune_iterations"] == 1
    assert (out / "report.md").exists() and any(out.glob("*.png"))
    captured = capsys.readouterr()
    assert "PIP-SDP cascade" in captured.out and "warning:" in captured.err
    # the library names the setting, the command its option (issue 41)
    assert "did not converge" in captured.err and "raise --tune-iterations (now 1)" in captured.err
    assert "`tune_iterations`" not in captured.err + (out / "report.md").read_text()


def test_an_unconverged_tuning_says_so_and_names_the_fix(study):
    """Issue 41: SMALL allows 2 BFGS steps per run, too few to converge; the warning says so and what to raise."""
    t = study.gradients["tuned"]
    assert not t["converged"] and t["reason"] == "steps" and t["steps"] == t["max_steps"] == 2
    (w,) = [w for w in study.warnings if w.startswith("the gradient tuning did not converge")]
    assert "raise `tune_iterations` of ControlSettings (now 2)" in w and "--" not in w
    assert "converged: no" in report_markdown(study) and w in report_markdown(study)


@pytest.mark.parametrize("args, message", [(["--wn", "-3"], "wn"), (["--data", "nope.mat"], "no such file")])
def test_cli_control_bad_options(tmp_path, capsys, args, message):
    assert main(["control", "--out", str(tmp_path / "o"), *args]) != 0
    assert message in capsys.readouterr().err


def test_the_study_designs_with_nominal_design(study):
    """One design pipeline: the study's loop gain, largest wn, SRIVC model and PIP design are `nominal_design`'s
    on the same friction and settings (what the Monte Carlo control study holds fixed)."""
    from jaxsdp.control import nominal_design

    nominal = nominal_design(friction_estimate(), settings=SMALL)
    assert study.pip_sdp["loop_gain"] == nominal.loop_gain
    assert study.real_drive["largest_wn_delay"] == nominal.wn_real
    assert study.real_drive["overshoot_grid"] == nominal.overshoots.tolist()
    assert study.srivc == nominal.srivc
    np.testing.assert_array_equal(study.sims["ident"]["y"], nominal.experiment["y"])


def test_designs_are_judged_against_the_drive(study):
    """Issue 29: every simulated design carries its peak force against the EMPS drive's 351.5 N; the default
    cascade (inner reference ramped, its acceleration limited to what the drive gives) stays within it, the
    paper's held reference does not (+-kN spikes at the outer rate), and the infeasible designs are named in a
    warning and marked in the tables."""
    import dataclasses

    from jaxsdp.control import nominal_design
    from jaxsdp.control._nominal import cascade_simulation, step_input
    from jaxsdp.studies.control import text
    from jaxsdp.studies.control._study import DRIVE_LIMIT

    cascade = study.pip_sdp
    assert cascade["stable"] and cascade["within_drive_limit"] and cascade["max_force"] <= DRIVE_LIMIT
    assert study.sdp_pd["within_drive_limit"] is False and study.sdp_pd["max_force"] > 100 * DRIVE_LIMIT
    (warning,) = [w for w in study.warnings if w.startswith("infeasible on the EMPS drive")]
    assert "SDP-PD wn 250 (ideal drive)" in warning and "PIP-SDP" not in warning
    printed = text(study)
    assert "INFEASIBLE" in printed and "feasible" in printed and "limit just met" not in printed
    held = dataclasses.replace(SMALL, hold="zoh", max_accel=None)  # the paper's cascade
    r = step_input(SMALL, int(round(SMALL.t_cascade / SMALL.dt)))
    nominal = nominal_design(friction_estimate(), settings=SMALL)
    sim = cascade_simulation(held, nominal.model, nominal.design, cascade["loop_gain"], r)
    assert float(np.max(np.abs(sim.force))) > 5 * DRIVE_LIMIT
