"""`jaxsdp control --estimator srivc|rivcbj`: the loop's identification by SRIVC (default, unchanged) or RIVCBJ.

The study runs at the small settings of `test_control_study` on its ready friction estimate; one command run
(RIVCBJ under AR(1) measurement noise) checks what reaches summary.json, report.md and the console, the rest
works on `srivc_experiment` and the figure function directly.
"""

import dataclasses
import json
import warnings

import numpy as np
import pytest
from test_control_study import SMALL, friction_estimate

from jaxsdp._cli import main
from jaxsdp.control._nominal import ControlSettings, friction_forms, ident_warning, srivc_experiment
from jaxsdp.studies.control._report import noise_gains
from jaxsdp.tfest import srivc

#: The identification's keys before the estimator option (summary.json's `srivc` section).
SRIVC_KEYS = {
    "num",
    "den",
    "num_se",
    "den_se",
    "discrete_num",
    "discrete_den",
    "discrete_dt",
    "iterations",
    "converged",
    "noise_pct",
    "fit_pct",
    "n",
    "m",
}
RIVCBJ_KEYS = {"nc", "nd", "c", "d", "c_se", "d_se", "rt2", "yic", "reason", "compare_srivc"}
AR = 0.95  # the AR(1) measurement noise of the RIVCBJ command run


def _patch_cli(monkeypatch):
    """Small settings and a ready friction estimate for `jaxsdp control` (as test_control_study does)."""
    import jaxsdp._cli.control as cli
    import jaxsdp.studies.control._study as study_module

    monkeypatch.setattr(cli, "ControlSettings", lambda **kw: SMALL.__class__(**{**vars(SMALL), **kw}))
    monkeypatch.setattr(study_module, "identify_friction", lambda data, seed: (friction_estimate(), []))
    return cli


@pytest.fixture(scope="module")
def model():
    return friction_forms(friction_estimate())[1]


# --------------------------------------------------------------------------- #
# Options
# --------------------------------------------------------------------------- #


@pytest.mark.parametrize(
    "argv, expected",
    [
        ([], dict(estimator="srivc", noise_orders=(1, 1), ident_noise_colour=None)),
        (["--estimator", "rivcbj"], dict(estimator="rivcbj", noise_orders=(1, 1), ident_noise_colour=None)),
        (
            ["--estimator", "rivcbj", "--noise-orders", "0", "2", "--ident-noise-ar", "0.9"],
            dict(estimator="rivcbj", noise_orders=(0, 2), ident_noise_colour=((1.0,), (1.0, -0.9))),
        ),
        (["--ident-noise-ar", "-0.5"], dict(estimator="srivc", ident_noise_colour=((1.0,), (1.0, 0.5)))),
    ],
)
def test_options_reach_the_settings(tmp_path, monkeypatch, capsys, argv, expected):
    cli = _patch_cli(monkeypatch)
    seen = {}

    def stop(data, *, settings, progress):
        seen["settings"] = settings
        raise ValueError("stopped after the settings")

    monkeypatch.setattr(cli, "control_study", stop)
    assert main(["control", "--out", str(tmp_path / "o"), "--quiet", *argv]) == 1
    assert "stopped after the settings" in capsys.readouterr().err
    s = seen["settings"]
    assert {k: getattr(s, k) for k in expected} == expected


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--noise-orders", "1", "1"], "--noise-orders sets the noise model of --estimator rivcbj"),
        (["--estimator", "srivc", "--noise-orders", "0", "1"], "srivc assumes white noise"),
        (["--estimator", "rivcbj", "--noise-orders", "11", "1"], "0..10"),
        (["--estimator", "rivcbj", "--noise-orders", "1"], "--noise-orders"),
        (["--ident-noise-ar", "1"], "(-1, 1)"),
        (["--ident-noise-ar", "nan"], "(-1, 1)"),
        (["--estimator", "bj"], "invalid choice"),
    ],
)
def test_conflicts_and_bad_values_exit_2(tmp_path, capsys, argv, message):
    out = tmp_path / "o"
    assert main(["control", "--out", str(out), *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert not out.exists()  # refused before anything was made


def test_settings_check_the_new_fields():
    s = ControlSettings(noise_orders=[2, 0], ident_noise_colour=([1, 0.5], np.array([1.0, -0.8])))
    assert s.noise_orders == (2, 0) and s.ident_noise_colour == ((1.0, 0.5), (1.0, -0.8))
    hash(s)  # still a frozen, hashable dataclass
    for bad in (
        dict(estimator="bj"),
        dict(noise_orders=(1,)),
        dict(noise_orders=(1, 11)),
        dict(noise_orders=(1.5, 1)),
        dict(ident_noise_colour=((1.0,), (2.0, -0.5))),  # D not monic
        dict(ident_noise_colour=((1.0,), (1.0, -1.2))),  # D unstable
        dict(ident_noise_colour=(1.0, -0.9)),  # not a pair of polynomials
    ):
        with pytest.raises(ValueError, match=next(iter(bad))):
            ControlSettings(**bad)


# --------------------------------------------------------------------------- #
# The experiment
# --------------------------------------------------------------------------- #


def test_default_is_srivc_and_unchanged(model):
    """The default identification: the same data and SRIVC estimate as before, the same keys plus `estimator`."""
    from jaxsdp.control._closed_loop import simulate_control
    from jaxsdp.control._sdp_pd import SDPPD

    ident, exp = srivc_experiment(model, SMALL)
    assert set(ident) == SRIVC_KEYS | {"estimator"} and ident["estimator"] == "srivc"
    # the noise as before the option: white, the same draws from the same generator
    rng = np.random.default_rng(SMALL.seed)
    hold, n = int(round(SMALL.ident_hold / SMALL.dt)), int(round(SMALL.ident_seconds / SMALL.dt))
    r = np.repeat(rng.uniform(-SMALL.step, SMALL.step, n // hold + 1), hold)[:n]
    ctrl = SDPPD(model, wn=SMALL.wn, eta=SMALL.eta, velocity=SMALL.velocity)
    x = np.asarray(simulate_control(ctrl, r, q0=0.0, dt=SMALL.dt).q)
    y = x + SMALL.ident_noise * np.std(x) * rng.normal(size=n)
    np.testing.assert_array_equal(exp["r"], r)
    np.testing.assert_array_equal(exp["y"], y)
    res = srivc(y, r, SMALL.dt, n=SMALL.n, m=SMALL.m)
    assert ident["num"] == np.asarray(res.num).tolist() and ident["den_se"] == np.asarray(res.den_se).tolist()


def test_rivcbj_on_white_noise_is_srivc_with_a_white_noise_model(model):
    """White measurement noise: RIVCBJ's noise model is near 1 (its zero and pole nearly cancel, so the
    iteration may stop at its limit, with a warning that says why) and its estimate is SRIVC's within a small
    fraction of a standard error, with no smaller standard errors."""
    s = dataclasses.replace(SMALL, estimator="rivcbj")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ident, _ = srivc_experiment(model, s)
    assert set(ident) == SRIVC_KEYS | RIVCBJ_KEYS | {"estimator"} and ident["estimator"] == "rivcbj"
    assert "noise_colour" not in ident
    ref = ident["compare_srivc"]
    theta, se = np.r_[ident["num"], ident["den"][1:]], np.r_[ident["num_se"], ident["den_se"][1:]]
    theta_s, se_s = np.r_[ref["num"], ref["den"][1:]], np.r_[ref["num_se"], ref["den_se"][1:]]
    assert np.all(np.abs(theta - theta_s) < 0.2 * se_s), (theta, theta_s, se_s)
    assert np.all(se > 0.9 * se_s)
    assert all(0.8 < g < 1.25 for g in noise_gains(ident["c"], ident["d"]))
    if not ident["converged"]:
        assert any("rivcbj did not converge" in str(w.message) for w in caught)
        assert ident_warning(ident).startswith("RIVCBJ did not converge") and "nearly cancel" in ident_warning(ident)


# --------------------------------------------------------------------------- #
# The command with RIVCBJ under coloured noise
# --------------------------------------------------------------------------- #


def test_cli_rivcbj_with_coloured_noise(tmp_path, monkeypatch, capsys):
    """`--estimator rivcbj --ident-noise-ar 0.95`: the AR(1) noise model is recovered and reported, SRIVC on the
    same data is reported beside it, and RIVCBJ's standard errors are the smaller."""
    _patch_cli(monkeypatch)
    out = tmp_path / "out"
    argv = ["control", "--out", str(out), "--quiet", "--tune-iterations", "0"]
    assert main([*argv, "--estimator", "rivcbj", "--ident-noise-ar", str(AR)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    sr = summary["srivc"]
    assert set(sr) == SRIVC_KEYS | RIVCBJ_KEYS | {"estimator", "noise_colour"} and sr["estimator"] == "rivcbj"
    assert sr["noise_colour"] == dict(c=[1.0], d=[1.0, -AR]) and sr["converged"]
    assert summary["settings"]["estimator"] == "rivcbj" and summary["settings"]["noise_orders"] == [1, 1]
    # the noise model: D = 1 - 0.95 z^-1 (to a few of its standard errors), C near 1
    assert abs(sr["d"][1] + AR) < 0.03 and abs(sr["c"][1]) < 0.3 and sr["d_se"][1] > 0
    assert noise_gains(sr["c"], sr["d"])[0] > 10  # strongly coloured: |C/D| at 0 Hz
    ref = sr["compare_srivc"]
    assert {"num", "den", "num_se", "den_se"} <= set(ref) and ref["estimator"] == "srivc"
    se, se_s = np.r_[sr["num_se"], sr["den_se"][1:]], np.r_[ref["num_se"], ref["den_se"][1:]]
    assert np.all(se < 0.7 * se_s), (se, se_s)
    report = (out / "report.md").read_text()
    assert "## RIVCBJ model of the SDP-PD loop" in report and "| parameter | SRIVC | SRIVC s.e. | RIVCBJ |" in report
    assert "RIVCBJ's standard errors are" in report and "coloured by 1 / (1 -0.95 z^-1)" in report
    # n = 2, m = 0 only approximates the loop: the two weight that mismatch differently, and SRIVC's standard
    # errors (white noise assumed) are flagged
    assert "does not capture the loop exactly" in report and "do not measure SRIVC's actual spread" in report
    printed = capsys.readouterr().out
    assert "RIVCBJ model of the SDP-PD loop" in printed and "SRIVC on the same data" in printed
    assert "noise model C/D" in printed


# --------------------------------------------------------------------------- #
# The figure names the estimator
# --------------------------------------------------------------------------- #


def test_figure_names_the_estimator():
    from jaxsdp.studies.control._figure_parts import example_study
    from jaxsdp.studies.control._figures_loops import fig_srivc

    study = example_study()
    fig = fig_srivc(study)
    assert fig._suptitle.get_text().startswith("SRIVC model") and "noise model" not in fig._suptitle.get_text()
    study.srivc = dict(
        study.srivc,
        num_se=[3.0],
        den_se=[0.0, 3.0],
        estimator="rivcbj",
        noise_colour=dict(c=[1.0], d=[1.0, -0.95]),
        c=[1.0, 0.1],
        d=[1.0, -0.94],
        compare_srivc=dict(num_se=[6.0], den_se=[0.0, 7.5]),
    )
    fig = fig_srivc(study)
    title = fig._suptitle.get_text()
    assert title.startswith("RIVCBJ model of the SDP-PD loop"), title
    assert "coloured by 1 / (1 - 0.95 z$^{-1}$)" in title and "noise model C/D = (1 + 0.1 z$^{-1}$)" in title
    assert "standard errors 0.4 to 0.5 times SRIVC's" in title, title
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "RIVCBJ model output" in labels
