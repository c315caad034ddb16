"""The robot study's processing defaults follow from the logs (issue 42, item 2): the TX40's 100 Hz / 10 / 100 at
5 kHz, a cut-off below Nyquist at 100 Hz, impossible choices refused before any work with a suggested value."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from helpers import TX40_CURRENTS, TX40_POSITIONS, requires_tx40
from jaxsdp._checks import OptionError
from jaxsdp.data import JointLogs
from jaxsdp.plants import SerialRobot
from jaxsdp.plants.robot import RobotProcessing
from jaxsdp.plants.robot._defaults import check_processing, motion_spectrum, processing_defaults
from jaxsdp.studies.robot import robot_study

jax.config.update("jax_enable_x64", True)

FREQS = np.array([[0.13, 0.47, 1.3, 1.9], [0.17, 0.61, 1.1, 1.7]])  # Hz
AMPS = np.array([[0.6, 0.25, 0.08, 0.04], [0.4, 0.2, 0.07, 0.04]])  # rad


def _motion(t):
    """Two joints' multi-sines (0.13-1.9 Hz): angles, rates, accelerations, each (N, 2)."""
    w = 2 * np.pi * FREQS
    arg = w[None] * t[:, None, None] + np.random.default_rng(1).uniform(0, 2 * np.pi, FREQS.shape)[None]
    return (
        np.sum(AMPS * np.sin(arg), -1),
        np.sum(AMPS * w * np.cos(arg), -1),
        -np.sum(AMPS * w**2 * np.sin(arg), -1),
    )


def _taper(t):
    """1 in the middle, 0 with its first two derivatives at both ends (a quintic ramp over 1 s)."""
    s = np.clip(np.minimum(t - t[0], t[-1] - t), 0.0, 1.0)
    return (10 * s**3 - 15 * s**4 + 6 * s**5)[:, None]


def _angles(fs, seconds=20.0, quant=1e-5, rest=True):
    """Two joints' quantised angles; `rest`: the robot at rest at both ends (as the TX40 logs), else in motion."""
    t = np.arange(0.0, seconds, 1.0 / fs)
    q = _motion(t)[0] * (_taper(t) if rest else 1.0)
    return t, np.round(q / quant) * quant


def test_tx40_rate_gives_the_published_processing():
    t, q = _angles(5000.0, seconds=9.0)  # the TX40 logs' rate and length
    p = processing_defaults(2e-4, q)
    assert (p.cutoff_hz, p.decimate, p.drop) == (100.0, 10, 100)
    assert p.preprocessing == {"cutoff_hz": 100.0, "decimate": 10, "drop": 100}
    assert p.fs == pytest.approx(5000.0) and p.samples == 45_000 and p.warnings == ()
    assert p.reasons["cutoff_hz"].startswith("cut-off 100 Hz: the TX40 papers' value")
    assert p.reasons["cutoff_hz"].endswith(
        "below 20 % of the 5000 Hz sampling rate, 50 x the motion's 99 % velocity band 2 Hz"
    )
    assert p.reasons["decimate"] == "decimation 10: the decimated rate 500 Hz is at least 5 x the cut-off"
    assert p.reasons["drop"].startswith("100 samples (20 ms) dropped at each end: 2 periods")
    assert processing_defaults(t, q).preprocessing == p.preprocessing  # time stamps or the sample time


@requires_tx40
def test_tx40_logs_give_the_published_processing():
    from jaxsdp.data import Drives, load_joint_logs

    logs = Drives.builtin("tx40").convert(load_joint_logs(TX40_POSITIONS, TX40_CURRENTS, dt=2e-4))
    p = processing_defaults(logs.dt, logs.q)
    assert (p.cutoff_hz, p.decimate, p.drop) == (100.0, 10, 100)
    assert 2.0 < p.bandwidth_hz < 5.0 and all(np.isfinite(p.bands))  # all six joints move, 2.6-3.3 Hz
    assert p.warnings == ()


@pytest.mark.parametrize("fs, expected", [(100.0, (20.0, 1, 10)), (500.0, (100.0, 1, 10)), (1000.0, (100.0, 2, 20))])
def test_defaults_at_other_rates(fs, expected):
    p = processing_defaults(1.0 / fs, _angles(fs)[1])
    assert (p.cutoff_hz, p.decimate, p.drop) == expected
    assert p.cutoff_hz < 0.8 * fs / 2 and fs / (2 * p.decimate) > p.cutoff_hz


def test_epoch_time_stamps_give_the_rate_of_the_record():
    # a logger's Unix time stamps (t ~ 1.7e9 s) carry a 2.4e-7 s rounding: their median step read 1 kHz as
    # 1000.07 Hz and dropped 21 samples instead of 20 (found by the cookbook's robot page)
    t, q = _angles(1000.0)
    p, epoch = processing_defaults(t, q), processing_defaults(1.7e9 + t, q)
    assert epoch.fs == pytest.approx(1000.0, rel=1e-8)
    assert epoch.preprocessing == p.preprocessing and epoch.drop == 20


def test_the_cutoff_rises_with_a_fast_motion_and_warns_when_sampled_too_slowly():
    t = np.arange(0.0, 20.0, 0.01)
    fast = processing_defaults(0.01, np.sin(2 * np.pi * 5.0 * t))  # 5 Hz at 100 Hz: 5 x 5 Hz > 20 Hz
    assert fast.cutoff_hz == 26.0 and "5 x the motion's 99 % velocity band 5.05 Hz" in fast.reasons["cutoff_hz"]
    assert fast.warnings == ()
    faster = processing_defaults(0.01, np.sin(2 * np.pi * 8.0 * t))
    assert faster.cutoff_hz == 30.0 and "sampled slowly" in faster.warnings[0]


def test_motion_spectrum_band_and_still_joints():
    fs = 1000.0
    t = np.arange(0.0, 20.0, 1 / fs)
    q = np.column_stack([0.5 * np.sin(2 * np.pi * 1.5 * t), 1e-3 * np.sin(2 * np.pi * 0.3 * t)])
    bands, limits = motion_spectrum(fs, np.round(q / 1e-5) * 1e-5)
    assert bands[0] == pytest.approx(1.5, abs=0.1) and np.isnan(bands[1]) and np.isnan(limits[1])
    assert 10.0 < limits[0] < np.inf
    assert motion_spectrum(fs, q).noise_cutoffs[0] > limits[0]  # less encoder noise, a higher limit


def test_noise_limited_lowers_the_cutoff_only_for_a_noisy_encoder():
    t, q = _angles(1000.0)
    p = processing_defaults(1e-3, q, noise_limited=True)
    assert 40.0 <= p.cutoff_hz <= 70.0 and p.cutoff_hz == np.floor(p.noise_cutoff_hz)  # 2 digits, rounded down
    assert "encoder noise" in p.reasons["cutoff_hz"] and p.decimate == 3
    fine = processing_defaults(1e-3, np.round(_motion(t)[0] / 1e-8) * 1e-8, noise_limited=True)
    assert fine.cutoff_hz == 100.0  # the noise limit is above the usual cut-off


def test_given_values_are_kept_and_the_rest_follows():
    q = _angles(5000.0, seconds=9.0)[1]
    p = processing_defaults(2e-4, q, cutoff_hz=50.0)
    assert (p.cutoff_hz, p.decimate, p.drop) == (50.0, 20, 200)
    assert p.reasons["cutoff_hz"] == "given" and p.reasons["decimate"] != "given"
    p = processing_defaults(2e-4, q, cutoff_hz=80.0, decimate=4, drop=125, min_speed=0.02)
    assert (p.cutoff_hz, p.decimate, p.drop, p.min_speed) == (80.0, 4, 125, 0.02)
    assert set(p.reasons.values()) == {"given"} and p.warnings == ()
    low = processing_defaults(2e-4, q, cutoff_hz=3.0)
    assert "distorts the motion" in low.warnings[0] and "(the default for these logs: 100 Hz)" in low.warnings[0]


def _edge_error(fs, q, dq, ddq, drop, cutoff_hz=100.0):
    """max |acceleration error| beyond `drop` samples at each end, over the rms acceleration, worst joint."""
    from jaxsdp._signal.butterworth import butter_derivatives

    est = np.stack([np.asarray(butter_derivatives(q[:, j], 1 / fs, cutoff_hz=cutoff_hz).ddq) for j in range(2)], 1)
    return float(np.max(np.abs(est - ddq)[drop:-drop] / np.sqrt(np.mean(ddq**2, axis=0))))


@pytest.mark.parametrize("fs", [1000.0, 5000.0])
def test_logs_that_start_in_motion_drop_the_filter_start_up(fs):
    # a record cut out of a longer run starts at speed: MATLAB's filtfilt padding starts the filter from the
    # first sample's steady state, a velocity step whose transient in the acceleration is ~100 x the motion's
    # and lasts ~100 ms at 100 Hz; two periods of the cut-off (the at-rest floor) leave errors above 5 %
    t = np.arange(0.0, 20.0, 1.0 / fs)
    q, dq, ddq = _motion(t)
    p = processing_defaults(1.0 / fs, q)
    floor = round(2 * fs / p.cutoff_hz)
    assert p.drop > 1.5 * floor and "start or end in motion" in p.reasons["drop"]
    assert _edge_error(fs, q, dq, ddq, p.drop) < 1e-2 < 0.05 < _edge_error(fs, q, dq, ddq, floor)
    rest = _motion(t)[0] * _taper(t)
    assert processing_defaults(1.0 / fs, rest).drop == floor  # at rest at both ends: the floor
    given = processing_defaults(1.0 / fs, q, drop=floor)  # a given drop kept, and said to be short
    assert given.drop == floor and f"use `drop`={p.drop}" in given.warnings[0]


def test_impossible_cutoff_refused_with_rounded_numbers_and_a_suggestion():
    fs = 2 * 50.01674560642517  # the jittered 100 Hz logs
    q = _angles(fs)[1]
    with pytest.raises(OptionError) as e:
        processing_defaults(1 / fs, q, cutoff_hz=100.0)
    assert str(e.value) == (
        "`cutoff_hz` = 100 Hz is at or above 80 % of the Nyquist frequency 50 Hz of these logs (100 Hz sampling); "
        "use `cutoff_hz`=20 (the default for these logs, 100 Hz sampling) or leave it unset"
    )
    with pytest.raises(OptionError, match=r"at or above 80 % of the Nyquist frequency 50 Hz"):
        check_processing(fs, 2000, cutoff_hz=40.02, decimate=1, drop=10)  # 80 % of Nyquist: 40.013 Hz
    check_processing(fs, 2000, cutoff_hz=40.0, decimate=1, drop=10)
    for bad in (0.0, -5.0, float("nan"), "fast"):
        with pytest.raises(OptionError, match="`cutoff_hz` must be"):
            check_processing(fs, 2000, cutoff_hz=bad, decimate=1, drop=10)


def test_impossible_decimation_drop_and_rest_threshold_refused():
    with pytest.raises(OptionError) as e:
        check_processing(5000.0, 45_000, cutoff_hz=100.0, decimate=30, drop=100)
    assert str(e.value) == (
        "`decimate` = 30 brings the sampling rate to 167 Hz, whose Nyquist frequency 83.3 Hz is at or below the "
        "cut-off 100 Hz; use `decimate`=10 (the default for these logs, 5000 Hz sampling) or leave it unset"
    )
    with pytest.raises(OptionError) as e:
        check_processing(5000.0, 45_000, cutoff_hz=10.0, decimate=300, drop=100)
    assert str(e.value).startswith("`decimate` = 300 leaves 149 rows of the 44800 samples kept (at least 200 needed)")
    assert "use `decimate`=44 (" in str(e.value)  # 1000 rows kept
    with pytest.raises(OptionError) as e:
        check_processing(100.0, 2000, cutoff_hz=20.0, decimate=1, drop=950)
    assert str(e.value) == (
        "`drop` = 950 samples at each end leaves 100 of the 2000 samples (at least 200 needed); use `drop`=10 "
        "(the default for these logs, 100 Hz sampling) or leave it unset"
    )
    for name, kw in (("decimate", dict(decimate=0)), ("drop", dict(drop=-1)), ("decimate", dict(decimate=2.5))):
        with pytest.raises(OptionError, match=f"`{name}` must be"):
            check_processing(100.0, 2000, **{"cutoff_hz": 20.0, "decimate": 1, "drop": 10, **kw})
    with pytest.raises(OptionError) as e:
        processing_defaults(0.01, _angles(100.0)[1], min_speed=5.0, names=("shoulder", "slide"), prismatic=(0, 1))
    assert str(e.value) == (
        "`min_speed` = 5 is at or above the peak speed of shoulder (2.04 rad/s) and slide (2.07 m/s): no sample of "
        "them would count as moving; use `min_speed`='auto' (1 % of each joint's peak speed) or leave it unset"
    )
    processing_defaults(0.01, _angles(100.0)[1], min_speed=0.05)
    with pytest.raises(OptionError, match="`min_speed` must be 'auto' or a speed"):
        processing_defaults(0.01, _angles(100.0)[1], min_speed="slow")


def test_short_records_and_bad_inputs():
    with pytest.raises(ValueError, match="too short"):
        processing_defaults(0.01, np.linspace(0, 1, 150))
    p = processing_defaults(2e-4, 0.01 * np.sin(np.linspace(0, 20, 300)))  # 100 samples at each end: 100 left
    assert p.drop == 50 and "the most that keeps 200 samples" in p.reasons["drop"]
    with pytest.raises(ValueError, match="`q` must be"):
        processing_defaults(0.01, np.zeros((3, 2, 2)))
    with pytest.raises(ValueError, match="sample time"):
        processing_defaults(-0.01, np.zeros((300, 2)))


ARM = dict(
    table=[[0.0, 0.0, 0.0, 0.0], [0.0, 0.4, 0.0, 0.0]],
    inertias=[
        (3.0, [0.2, 0.0, 0.0], [0.01, 0, 0, 0.02, 0, 0.02]),
        (1.5, [0.15, 0.01, 0.0], [0.005, 0, 0, 0.01, 0, 0.01]),
    ],
)


def test_100_hz_logs_identified_with_the_defaults():
    arm = SerialRobot.from_mdh(ARM["table"], inertias=ARM["inertias"], Ia=0.1, Fv=[2.0, 1.0], Fc=[1.5, 0.8])
    fs = 100.0
    t = np.arange(0.0, 30.0, 1 / fs)
    q, dq, ddq = _motion(t)
    tau = np.asarray(arm.drive_torques(q, dq, ddq))
    tau = tau + 0.01 * tau.std(axis=0) * np.random.default_rng(0).standard_normal(tau.shape)  # 1 % noise
    qm = np.round(q / 1e-5) * 1e-5
    logs = JointLogs(
        q=jnp.asarray(qm),
        tau=jnp.asarray(tau),
        t=jnp.asarray(t),
        dt=1 / fs,
        joints=(1, 2),
        source="sim",
        converted="none",
    )
    p = processing_defaults(logs.t, logs.q)
    assert p.cutoff_hz == 20.0 < 0.8 * fs / 2
    s = robot_study(logs, robot=arm, sdp=False, processing=RobotProcessing(**p.preprocessing))
    assert all(v < 1.5 for v in s.idim.relative_error.values()), s.idim.relative_error
    est, nom = np.asarray(s.idim.result.theta), np.asarray(s.idim.model.nominal)
    good = (np.asarray(s.idim.result.rel_std) < 5.0) & (np.abs(nom) > 1e-6)
    assert good.sum() >= 6
    assert np.all(np.abs(est - nom)[good] <= 0.03 * np.abs(nom[good])), (est[good], nom[good])
