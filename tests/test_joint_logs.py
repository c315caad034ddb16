"""Joint logs: reading and writing positions/torques files, motor side to joint side, and every refusal."""

import re

import jax.numpy as jnp
import numpy as np
import pytest
import scipy.io

from jaxsdp.data import JointLogs, load_joint_logs, write_joint_logs

TX40_RATIOS = (32, 32, 45, -48, 45, 32)
HEADER = "Joint_1,Joint_2,Joint_3,Joint_4,Joint_5,Joint_6"


def _joint_side(n=200, joints=6, seed=0):
    rng = np.random.default_rng(seed)
    q = np.cumsum(rng.standard_normal((n, joints)), axis=0) * 1e-2  # rad
    tau = rng.standard_normal((n, joints)) * 10.0  # N m
    return q, tau


def _csv(path, values, header=HEADER):
    np.savetxt(path, values, fmt="%.17g", delimiter=",", header=header or "", comments="")
    return path


def _pair(tmp_path, n=20, joints=6, header=HEADER):
    """Valid joint-side files (ratios 1) with `n` rows: (positions, torques)."""
    q, tau = _joint_side(n, joints)
    return _csv(tmp_path / "pos.csv", q, header), _csv(tmp_path / "tau.csv", tau, header)


def _lines(path, edit):
    """Rewrite a text file: `edit` maps the list of lines (without newlines) to a new list."""
    lines = path.read_text().splitlines()
    path.write_text("\n".join(edit(lines)) + "\n")
    return path


def _set_cell(line, column, text):
    cells = line.split(",")
    cells[column] = text
    return ",".join(cells)


# ---------------------------------------------------------------------------------------------- round trips


@pytest.mark.parametrize("header", [True, False], ids=["header", "headerless"])
def test_csv_round_trip_with_tx40_ratios(tmp_path, header):
    q, tau = _joint_side(300)
    pos, cur = tmp_path / "positions.csv", tmp_path / "torques.csv"
    write_joint_logs(pos, cur, q, tau, ratios=TX40_RATIOS, header=header)
    # The files hold motor-side values: pos = N q, value = tau / N (an independent reading).
    first = pos.read_text().splitlines()[0]
    assert (first == HEADER) == header
    raw_pos = np.loadtxt(pos, delimiter=",", skiprows=int(header))
    raw_cur = np.loadtxt(cur, delimiter=",", skiprows=int(header))
    np.testing.assert_allclose(raw_pos, q * np.array(TX40_RATIOS), rtol=1e-15)
    np.testing.assert_allclose(raw_cur, tau / np.array(TX40_RATIOS), rtol=1e-15)

    logs = load_joint_logs(pos, cur, dt=2e-4, ratios=TX40_RATIOS)
    assert isinstance(logs, JointLogs)
    assert logs.q.dtype == jnp.float64 and logs.q.shape == (300, 6) and logs.tau.shape == (300, 6)
    np.testing.assert_allclose(np.asarray(logs.q), q, rtol=1e-15, atol=0)
    np.testing.assert_allclose(np.asarray(logs.tau), tau, rtol=1e-15, atol=0)
    np.testing.assert_allclose(np.asarray(logs.t), np.arange(300) * 2e-4, rtol=1e-15)
    assert logs.dt == 2e-4 and logs.fs == pytest.approx(5000.0, rel=1e-15)
    assert logs.joints == (1, 2, 3, 4, 5, 6)
    assert logs.source == "positions.csv + torques.csv"
    assert "ratios 32, 32, 45, -48, 45, 32" in logs.converted and "values are torques" in logs.converted


def test_reads_motor_side_files_written_independently(tmp_path):
    # A TX40-like log written by hand: motor angles and motor torques.
    rng = np.random.default_rng(1)
    motor_pos = rng.standard_normal((50, 6)) * 30.0
    motor_tau = rng.standard_normal((50, 6))
    pos = _csv(tmp_path / "positions.csv", motor_pos)
    cur = _csv(tmp_path / "torques.csv", motor_tau)
    logs = load_joint_logs(pos, cur, dt=2e-4, ratios=TX40_RATIOS)
    n = np.array(TX40_RATIOS, dtype=float)
    np.testing.assert_array_equal(np.asarray(logs.q), motor_pos / n)
    np.testing.assert_array_equal(np.asarray(logs.tau), n * motor_tau)
    # No ratios: the files are joint-side already.
    plain = load_joint_logs(pos, cur, dt=2e-4)
    np.testing.assert_array_equal(np.asarray(plain.q), motor_pos)
    np.testing.assert_array_equal(np.asarray(plain.tau), motor_tau)
    assert plain.converted.startswith("none")


def test_torque_constants_convert_currents(tmp_path):
    rng = np.random.default_rng(2)
    kt = (0.4, 0.4, 0.3, 0.2, 0.2, 0.1)  # N m/A
    amps = rng.standard_normal((40, 6))
    pos = _csv(tmp_path / "positions.csv", rng.standard_normal((40, 6)))
    cur = _csv(tmp_path / "currents.csv", amps)
    logs = load_joint_logs(pos, cur, dt=1e-3, ratios=TX40_RATIOS, torque_constants=kt)
    np.testing.assert_allclose(np.asarray(logs.tau), np.array(TX40_RATIOS) * np.array(kt) * amps, rtol=1e-15)
    assert "values are currents" in logs.converted and "0.4, 0.4, 0.3, 0.2, 0.2, 0.1 N m/A" in logs.converted
    # Without ratios: tau = Kt * value.
    direct = load_joint_logs(pos, cur, dt=1e-3, torque_constants=kt)
    np.testing.assert_allclose(np.asarray(direct.tau), np.array(kt) * amps, rtol=1e-15)
    # The writer inverts it.
    q, tau = _joint_side(40)
    write_joint_logs(pos, cur, q, tau, ratios=TX40_RATIOS, torque_constants=kt)
    np.testing.assert_allclose(np.loadtxt(cur, delimiter=",", skiprows=1), tau / (np.array(TX40_RATIOS) * kt))
    back = load_joint_logs(pos, cur, dt=1e-3, ratios=TX40_RATIOS, torque_constants=kt)
    np.testing.assert_allclose(np.asarray(back.q), q, rtol=1e-15)
    np.testing.assert_allclose(np.asarray(back.tau), tau, rtol=1e-15)


def test_mat_round_trip_joint_variables(tmp_path):
    q, tau = _joint_side(100)
    pos, cur = tmp_path / "positions.mat", tmp_path / "torques.mat"
    write_joint_logs(pos, cur, jnp.asarray(q), jnp.asarray(tau), ratios=TX40_RATIOS)
    raw = scipy.io.loadmat(pos)
    assert sorted(k for k in raw if not k.startswith("__")) == [f"Joint_{k}" for k in range(1, 7)]
    np.testing.assert_allclose(raw["Joint_4"].ravel(), -48 * q[:, 3], rtol=1e-15)
    logs = load_joint_logs(pos, cur, dt=2e-4, ratios=TX40_RATIOS)
    np.testing.assert_allclose(np.asarray(logs.q), q, rtol=1e-15)
    np.testing.assert_allclose(np.asarray(logs.tau), tau, rtol=1e-15)
    assert logs.source == "positions.mat + torques.mat"


def test_mat_single_matrix_and_mixed_formats(tmp_path):
    q, tau = _joint_side(60)
    pos = tmp_path / "positions.mat"
    scipy.io.savemat(pos, {"positions": q * np.array(TX40_RATIOS), "dt": 2e-4})  # a 1 x 1 scalar is ignored
    cur = _csv(tmp_path / "torques.csv", tau / np.array(TX40_RATIOS), header=None)
    logs = load_joint_logs(pos, cur, dt=2e-4, ratios=TX40_RATIOS)
    np.testing.assert_allclose(np.asarray(logs.q), q, rtol=1e-15)
    np.testing.assert_allclose(np.asarray(logs.tau), tau, rtol=1e-15)
    # Vectors saved as rows (MATLAB's default for 1-D arrays) are read too.
    rows = tmp_path / "rows.mat"
    scipy.io.savemat(rows, {f"Joint_{k}": q[:, k - 1] for k in range(1, 7)})
    np.testing.assert_array_equal(np.asarray(load_joint_logs(rows, rows, dt=1.0).q), q)


def test_joint_selection(tmp_path):
    q, tau = _joint_side(30)
    pos, cur = tmp_path / "p.csv", tmp_path / "t.csv"
    write_joint_logs(pos, cur, q, tau, ratios=TX40_RATIOS)
    logs = load_joint_logs(pos, cur, dt=2e-4, ratios=TX40_RATIOS, joints=(5, 2))
    assert logs.joints == (5, 2) and logs.q.shape == (30, 2)
    np.testing.assert_allclose(np.asarray(logs.q), q[:, [4, 1]], rtol=1e-15)
    np.testing.assert_allclose(np.asarray(logs.tau), tau[:, [4, 1]], rtol=1e-15)
    assert "ratios 45, 32" in logs.converted
    q2, tau2 = logs.joint(2)
    np.testing.assert_allclose(np.asarray(q2), q[:, 1], rtol=1e-15)
    np.testing.assert_allclose(np.asarray(tau2), tau[:, 1], rtol=1e-15)
    with pytest.raises(ValueError, match=r"joint 3 is not in these logs .*available joints: 5, 2"):
        logs.joint(3)
    with pytest.raises(ValueError, match="available joints"):
        logs.joint(True)


def test_single_joint_file_and_lenient_header(tmp_path):
    # One joint (number 2), header with spaces and other case, CRLF line ends, a byte-order mark, blank lines.
    rng = np.random.default_rng(3)
    values = rng.standard_normal(15)
    body = "\r\n".join(f" {float(v)!r} " for v in values)
    (tmp_path / "pos.csv").write_bytes(("\ufeff joint_2 \r\n" + body + "\r\n\r\n").encode("utf-8"))
    (tmp_path / "tau.csv").write_text("JOINT_2\n\n" + "\n".join(repr(float(2 * v)) for v in values) + "\n")
    logs = load_joint_logs(tmp_path / "pos.csv", tmp_path / "tau.csv", dt=0.01, ratios=[-48])
    assert logs.joints == (2,)
    np.testing.assert_array_equal(np.asarray(logs.q[:, 0]), values / -48)
    np.testing.assert_array_equal(np.asarray(logs.tau[:, 0]), -48 * 2 * values)


def test_columns_are_matched_by_name(tmp_path):
    q, tau = _joint_side(20, joints=3)
    pos = _csv(tmp_path / "pos.csv", q[:, [2, 0, 1]], header="Joint_3,Joint_1,Joint_2")
    cur = _csv(tmp_path / "tau.csv", tau, header="Joint_1,Joint_2,Joint_3")
    logs = load_joint_logs(pos, cur, dt=1e-3, ratios=(1, 2, 4))  # in increasing joint number
    np.testing.assert_allclose(np.asarray(logs.q), q / np.array([1, 2, 4]), rtol=1e-15)
    np.testing.assert_allclose(np.asarray(logs.tau), tau * np.array([1, 2, 4]), rtol=1e-15)


def test_a_full_size_log_reads(tmp_path):
    # The size of the public TX40 logs: 45,000 rows of 6 joints (not timed; reading goes through numpy).
    q, tau = _joint_side(45_000)
    pos, cur = tmp_path / "positions.csv", tmp_path / "torques.csv"
    write_joint_logs(pos, cur, q, tau, ratios=TX40_RATIOS)
    logs = load_joint_logs(pos, cur, dt=2e-4, ratios=TX40_RATIOS)
    assert logs.q.shape == (45_000, 6)
    np.testing.assert_allclose(np.asarray(logs.q), q, rtol=1e-15)
    np.testing.assert_allclose(np.asarray(logs.tau), tau, rtol=1e-15)
    # A bad cell near the end is still located by its line.
    _lines(pos, lambda lines: lines[:44_000] + [_set_cell(lines[44_000], 3, "oops")] + lines[44_001:])
    with pytest.raises(ValueError, match=r"positions file positions.csv: line 44001, column 4 \(Joint_4\).*'oops'"):
        load_joint_logs(pos, cur, dt=2e-4)


# ---------------------------------------------------------------------------------------------- refusals


def test_missing_and_empty_files(tmp_path):
    pos, cur = _pair(tmp_path)
    with pytest.raises(FileNotFoundError, match=r"`torques`: no such file: .*nowhere.csv"):
        load_joint_logs(pos, tmp_path / "nowhere.csv", dt=1e-3)
    (tmp_path / "empty.csv").write_text("")
    with pytest.raises(ValueError, match="torques file empty.csv is empty"):
        load_joint_logs(pos, tmp_path / "empty.csv", dt=1e-3)
    (tmp_path / "blank.csv").write_text("\n  \n")
    with pytest.raises(ValueError, match="positions file blank.csv is empty"):
        load_joint_logs(tmp_path / "blank.csv", cur, dt=1e-3)
    (tmp_path / "header_only.csv").write_text(HEADER + "\n")
    with pytest.raises(ValueError, match=r"positions file header_only.csv has 0 row\(s\); at least 10"):
        load_joint_logs(tmp_path / "header_only.csv", cur, dt=1e-3)


def test_columns_must_match(tmp_path):
    pos, _ = _pair(tmp_path)
    other = _csv(tmp_path / "five.csv", np.zeros((20, 5)), header="Joint_1,Joint_2,Joint_3,Joint_4,Joint_5")
    different = r"positions file pos.csv has joint columns \[1, 2, 3, 4, 5, 6\] but torques file five.csv has \[1, 2, 3"
    with pytest.raises(ValueError, match=different):
        load_joint_logs(pos, other, dt=1e-3)
    absent = r"`joints`: joint\(s\) \[7\] not in positions file pos.csv.*available joints: 1, 2, 3, 4, 5, 6"
    with pytest.raises(ValueError, match=absent):
        load_joint_logs(pos, pos, dt=1e-3, joints=(1, 7))
    bad_name = _csv(tmp_path / "named.csv", np.zeros((20, 2)), header="Joint_1,Torque_2")
    with pytest.raises(ValueError, match=r"torques file named.csv: column 'Torque_2' is not named Joint_<k>"):
        load_joint_logs(pos, bad_name, dt=1e-3)
    twice = _csv(tmp_path / "twice.csv", np.zeros((20, 2)), header="Joint_1,joint_1")
    with pytest.raises(ValueError, match=r"torques file twice.csv: joint\(s\) \[1\] appear in more than one column"):
        load_joint_logs(pos, twice, dt=1e-3)


def test_lengths_must_match(tmp_path):
    pos, _ = _pair(tmp_path, n=20)
    short = _csv(tmp_path / "short.csv", np.zeros((12, 6)))
    with pytest.raises(ValueError, match="positions file pos.csv has 20 rows but torques file short.csv has 12"):
        load_joint_logs(pos, short, dt=1e-3)
    tiny = _csv(tmp_path / "tiny.csv", np.zeros((9, 6)))
    with pytest.raises(ValueError, match=r"torques file tiny.csv has 9 row\(s\); at least 10 are needed"):
        load_joint_logs(pos, tiny, dt=1e-3)


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda ls: ls[:5] + [ls[5] + ",1.0"] + ls[6:], r"line 6 has 7 field\(s\), expected 6"),
        (lambda ls: ls[:7] + [_set_cell(ls[7], 2, "nan")] + ls[8:], r"line 8, column 3 \(Joint_3\) is not finite"),
        (lambda ls: ls[:3] + [_set_cell(ls[3], 0, "-inf")] + ls[4:], r"line 4, column 1 \(Joint_1\) is not finite"),
        (lambda ls: ls[:9] + [_set_cell(ls[9], 5, " 1.2.3")] + ls[10:], r"line 10, column 6 \(Joint_6\) is not a "),
        (lambda ls: ls[:9] + [_set_cell(ls[9], 1, "")] + ls[10:], r"line 10, column 2 \(Joint_2\) is not a number: ''"),
    ],
    ids=["fields", "nan", "inf", "text", "blank-cell"],
)
def test_bad_rows_are_located(tmp_path, edit, message):
    pos, cur = _pair(tmp_path)
    _lines(cur, edit)
    with pytest.raises(ValueError, match="torques file tau.csv: " + message):
        load_joint_logs(pos, cur, dt=1e-3)


def test_bad_cells_of_headerless_and_mat_files(tmp_path):
    pos, cur = _pair(tmp_path, header=None)
    _lines(pos, lambda ls: ls[:2] + [_set_cell(ls[2], 4, "x")] + ls[3:])
    with pytest.raises(ValueError, match=r"positions file pos.csv: line 3, column 5 is not a number: 'x'"):
        load_joint_logs(pos, cur, dt=1e-3)
    q, tau = _joint_side(20)
    q[11, 3] = np.nan
    scipy.io.savemat(tmp_path / "p.mat", {f"Joint_{k}": q[:, k - 1 : k] for k in range(1, 7)})
    with pytest.raises(ValueError, match=r"positions file p.mat: row 12, column `Joint_4` is not finite \(nan\)"):
        load_joint_logs(tmp_path / "p.mat", cur, dt=1e-3)
    scipy.io.savemat(tmp_path / "m.mat", {"q": q})
    with pytest.raises(ValueError, match=r"torques file m.mat: row 12, column 4 of `q` is not finite"):
        load_joint_logs(cur, tmp_path / "m.mat", dt=1e-3)


def test_ambiguous_or_unreadable_mat(tmp_path):
    pos, _ = _pair(tmp_path)
    q, tau = _joint_side(20)
    scipy.io.savemat(tmp_path / "two.mat", {"q": q, "tau": tau})
    with pytest.raises(ValueError, match=r"torques file two.mat: expected variables Joint_1.*found 2 .*`q` \(20, 6\)"):
        load_joint_logs(pos, tmp_path / "two.mat", dt=1e-3)
    scipy.io.savemat(tmp_path / "ragged.mat", {"Joint_1": q[:, 0], "Joint_2": q[:15, 1]})
    with pytest.raises(ValueError, match=r"ragged.mat: the joint variables have different lengths \(`Joint_1`: 20"):
        load_joint_logs(pos, tmp_path / "ragged.mat", dt=1e-3)
    (tmp_path / "junk.mat").write_bytes(b"not a mat file at all, just some bytes" * 4)
    with pytest.raises(ValueError, match="torques file junk.mat: could not read it as a MATLAB .mat file"):
        load_joint_logs(pos, tmp_path / "junk.mat", dt=1e-3)


@pytest.mark.parametrize(
    "options, message",
    [
        (dict(dt=0.0), "`dt` must be finite and positive"),
        (dict(dt=float("nan")), "`dt` must be finite and positive"),
        (dict(ratios=(32, 0, 45, -48, 45, 32)), r"`ratios`: entry 1 \(0\) must be finite and non-zero"),
        (dict(ratios=(32, 32, float("inf"), -48, 45, 32)), r"`ratios`: entry 2 \(inf\) must be finite"),
        (
            dict(ratios=(32, 32, 45)),
            r"`ratios` has 3 entries but positions file pos.csv and torques file tau.csv have 6",
        ),
        (dict(ratios="32"), "`ratios` must be a sequence of gear ratios"),
        (dict(torque_constants=(0.1,) * 5 + (0.0,)), r"`torque_constants`: entry 5 \(0\) must be finite and positive"),
        (dict(torque_constants=(0.1,) * 5 + (-0.1,)), r"`torque_constants`: entry 5 \(-0.1\) must be finite and pos"),
        (dict(torque_constants=(0.1,) * 5 + (float("nan"),)), r"`torque_constants`: entry 5 \(nan\)"),
        (dict(torque_constants=(0.1,) * 7), "`torque_constants` has 7 entries"),
        (dict(joints=(1, 2, 1)), r"`joints` names joint\(s\) \[1\] more than once"),
        (dict(joints=(1, 2.0)), "`joints` must hold 1-based joint numbers"),
        (dict(joints=(True,)), "`joints` must hold 1-based joint numbers"),
        (dict(joints=(0,)), "`joints` must hold 1-based joint numbers"),
        (dict(joints=()), "`joints` is empty"),
        (dict(joints=3), "`joints` must be None or a sequence"),
    ],
)
def test_invalid_options(tmp_path, options, message):
    pos, cur = _pair(tmp_path)
    options = {"dt": 1e-3, **options}
    with pytest.raises(ValueError, match=message):
        load_joint_logs(pos, cur, **options)


def test_options_are_checked_before_the_files(tmp_path):
    with pytest.raises(ValueError, match="`dt` must be finite and positive"):
        load_joint_logs(tmp_path / "nowhere.csv", tmp_path / "nowhere.csv", dt=-1.0)


def test_writer_refusals_leave_no_files(tmp_path):
    q, tau = _joint_side(20)
    pos, cur = tmp_path / "p.csv", tmp_path / "t.csv"
    bad_tau = tau.copy()
    bad_tau[4, 2] = np.inf
    cases = [
        (dict(q=q, tau=tau[:, :5]), r"`q` and `tau` must have the same shape \(N, n\); got \(20, 6\) and \(20, 5\)"),
        (dict(q=q[:, 0], tau=tau[:, 0]), r"`q` must be a non-empty 2-D \(N, n\) array"),
        (dict(q=q, tau=bad_tau), r"`tau`: row 5, joint 3 is not finite \(inf\)"),
        (dict(q=q, tau=tau, ratios=(1, 2)), "`ratios` has 2 entries but `q` and `tau` have 6 joint column"),
        (dict(q=q, tau=tau, ratios=(1, 2, 3, 0, 5, 6)), r"`ratios`: entry 3 \(0\) must be finite and non-zero"),
        (dict(q=q, tau=tau, torque_constants=(1, 1, 1, 1, 1, -1)), r"`torque_constants`: entry 5 \(-1\)"),
        (dict(q=q, tau=tau, header="yes"), "`header` must be True or False"),
        (dict(q=q, tau=tau, torques=pos), "`positions` and `torques` are the same file"),
        (dict(q=q, tau=tau, torques=tmp_path / "no" / "t.csv"), "`torques`: cannot write .*t.csv: no such folder"),
        (dict(q=q * 1e308, tau=tau, ratios=TX40_RATIOS), r"positions file p.csv: the converted values overflow"),
    ]
    for kwargs, message in cases:
        kwargs = {"positions": pos, "torques": cur, **kwargs}
        with pytest.raises(ValueError, match=message):
            write_joint_logs(**kwargs)
        assert sorted(p.name for p in tmp_path.iterdir()) == [], message


def test_writer_replaces_existing_files_and_leaves_no_temporaries(tmp_path):
    q, tau = _joint_side(20)
    pos, cur = tmp_path / "p.csv", tmp_path / "t.csv"
    pos.write_text("old\n")
    write_joint_logs(pos, cur, q, tau, header=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.csv", "t.csv"]
    np.testing.assert_array_equal(np.loadtxt(pos, delimiter=","), q)
    assert re.fullmatch(r"[-+0-9.e,]+", pos.read_text().splitlines()[0])
