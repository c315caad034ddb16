import numpy as np
import pytest
import scipy.io

from helpers import EMPS_MAT, requires_emps
from jaxsdp.data import EMPSData, IrregularSamplingError, Measurements, load_emps, load_measurements
from jaxsdp.data._loaders import MAX_JITTER


def _emps_like(n=200, seed=0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 1e-3
    return {
        "t": t[:, None],
        "qm": np.cumsum(rng.standard_normal(n))[:, None] * 1e-4,
        "qg": np.cumsum(rng.standard_normal(n))[:, None] * 1e-4,
        "vir": rng.standard_normal(n)[:, None],
        "gtau": np.array([[35.15]]),
        "kp": np.array([[160.18]]),
        "kv": np.array([[243.45]]),
    }


def _save(tmp_path, contents, name="data.mat"):
    path = tmp_path / name
    scipy.io.savemat(path, contents)
    return path


@requires_emps
def test_load_real_emps_file():
    data = load_emps(EMPS_MAT)
    raw = scipy.io.loadmat(EMPS_MAT)
    assert isinstance(data, EMPSData)
    for name in ["t", "qm", "qg", "vir"]:
        arr = np.asarray(getattr(data, name))
        assert arr.shape == (24841,) and arr.dtype == np.float64
        np.testing.assert_array_equal(arr, raw[name].ravel())
    np.testing.assert_allclose(data.gtau, 35.15065188, rtol=1e-9)
    np.testing.assert_allclose(data.kp, 160.18)
    np.testing.assert_allclose(data.kv, 243.45)
    np.testing.assert_allclose(np.asarray(data.force), raw["gtau"].item() * raw["vir"].ravel(), rtol=1e-15)
    np.testing.assert_allclose(data.dt, 1e-3, rtol=1e-12)
    assert np.all(np.diff(np.asarray(data.t)) > 0)
    # Closed loop, saturated at +-10 V.
    assert np.max(np.abs(np.asarray(data.vir))) <= 10.0


def test_load_synthetic_emps_file(tmp_path):
    contents = _emps_like()
    data = load_emps(_save(tmp_path, contents))
    np.testing.assert_array_equal(np.asarray(data.qm), contents["qm"].ravel())
    np.testing.assert_allclose(np.asarray(data.force), 35.15 * contents["vir"].ravel(), rtol=1e-15)
    assert data.gtau == 35.15 and data.kp == 160.18 and data.kv == 243.45
    np.testing.assert_allclose(data.dt, 1e-3, rtol=1e-12)
    # Row vectors are accepted too.
    row = {k: (v.T if v.size > 1 else v) for k, v in contents.items()}
    assert load_emps(_save(tmp_path, row, "row.mat")).t.shape == (200,)


@pytest.mark.parametrize("missing", ["vir", "gtau", "t"])
def test_missing_variable(tmp_path, missing):
    contents = _emps_like()
    del contents[missing]
    with pytest.raises(ValueError, match=rf"not an EMPS data set: missing variable\(s\) \['{missing}'\]"):
        load_emps(_save(tmp_path, contents))


def test_non_emps_file(tmp_path):
    path = _save(tmp_path, {"foo": np.arange(10.0)})
    with pytest.raises(ValueError, match=r"not an EMPS data set.*'qm'.*found \['foo'\]"):
        load_emps(path)


def test_truncated_and_garbage_files(tmp_path):
    path = _save(tmp_path, _emps_like(2000))
    raw = path.read_bytes()
    truncated = tmp_path / "truncated.mat"
    truncated.write_bytes(raw[: len(raw) // 2])
    with pytest.raises(ValueError, match="could not read .*truncated.mat"):
        load_emps(truncated)
    garbage = tmp_path / "garbage.mat"
    garbage.write_bytes(b"this is not a MATLAB file at all" * 10)
    with pytest.raises(ValueError, match="could not read .*garbage.mat"):
        load_emps(garbage)
    with pytest.raises(FileNotFoundError, match="no such file"):
        load_emps(tmp_path / "absent.mat")
    with pytest.raises(ValueError, match="not a regular file"):
        load_emps(tmp_path)
    with pytest.raises(ValueError, match="`path` must be a str"):
        load_emps(123)


def test_bad_variables(tmp_path):
    c = _emps_like()
    c["qm"] = c["qm"][:150]
    with pytest.raises(ValueError, match=r"different lengths.*`qm`: 150"):
        load_emps(_save(tmp_path, c))

    c = _emps_like()
    c["vir"][17, 0] = np.nan
    with pytest.raises(ValueError, match=r"`vir` contains 1 NaN/inf"):
        load_emps(_save(tmp_path, c))

    c = _emps_like()
    c["t"][50, 0] = c["t"][49, 0]
    with pytest.raises(ValueError, match=r"`t` must be strictly increasing \(t\[50\]"):
        load_emps(_save(tmp_path, c))

    c = _emps_like()
    c["gtau"] = np.array([[1.0, 2.0]])
    with pytest.raises(ValueError, match=r"`gtau` must be a scalar; got shape \(1, 2\)"):
        load_emps(_save(tmp_path, c))

    c = _emps_like()
    c["qg"] = np.ones((200, 2))
    with pytest.raises(ValueError, match=r"`qg` must be a vector; got shape \(200, 2\)"):
        load_emps(_save(tmp_path, c))

    c = _emps_like()
    c["qm"] = "text"
    with pytest.raises(ValueError, match="`qm` is not numeric"):
        load_emps(_save(tmp_path, c))


def _write_csv(path, header, rows):
    lines = [",".join(header)] + [",".join(str(v) for v in r) for r in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_load_measurements_csv(tmp_path):
    rng = np.random.default_rng(1)
    t = np.arange(100) * 0.002
    q, f = rng.standard_normal(100), rng.standard_normal(100)
    path = _write_csv(tmp_path / "m.csv", ["time", "pos", "tau"], zip(t, q, f))
    m = load_measurements(path, time="time", position="pos", force="tau")
    assert isinstance(m, Measurements)
    np.testing.assert_array_equal(np.asarray(m.t), t)
    np.testing.assert_array_equal(np.asarray(m.q), q)
    np.testing.assert_array_equal(np.asarray(m.force), f)
    np.testing.assert_allclose(m.dt, 0.002, rtol=1e-12)
    # Semicolon separated, default names, extra columns ignored.
    path = tmp_path / "m2.csv"
    path.write_text("t;q;force;other\n" + "\n".join(f"{a};{b};{c};0" for a, b, c in zip(t, q, f)))
    np.testing.assert_array_equal(np.asarray(load_measurements(path, delimiter=";").q), q)


def test_load_measurements_mat(tmp_path):
    contents = _emps_like()
    m = load_measurements(_save(tmp_path, contents), position="qm", force="vir")
    np.testing.assert_array_equal(np.asarray(m.q), contents["qm"].ravel())
    np.testing.assert_array_equal(np.asarray(m.force), contents["vir"].ravel())


def test_load_measurements_errors(tmp_path):
    t = np.arange(10) * 0.1
    good = list(zip(t, t, t))
    with pytest.raises(ValueError, match=r"missing column\(s\) 'tau' \(force\)"):
        load_measurements(_write_csv(tmp_path / "a.csv", ["t", "q", "force"], good), force="tau")
    with pytest.raises(ValueError, match=r"missing variable\(s\) 'q' \(position\)"):
        load_measurements(_save(tmp_path, _emps_like()), force="vir")
    bad = [list(r) for r in good]
    bad[3][1] = "abc"
    with pytest.raises(ValueError, match=r"row 5, column `q`.*'abc'"):
        load_measurements(_write_csv(tmp_path / "b.csv", ["t", "q", "force"], bad))
    bad = [list(r) for r in good]
    bad[4][2] = "nan"
    with pytest.raises(ValueError, match=r"`force` contains 1 NaN/inf"):
        load_measurements(_write_csv(tmp_path / "c.csv", ["t", "q", "force"], bad))
    bad = [list(r) for r in good]
    bad[6][0] = 0.0
    with pytest.raises(ValueError, match="strictly increasing"):
        load_measurements(_write_csv(tmp_path / "d.csv", ["t", "q", "force"], bad))
    ragged = tmp_path / "e.csv"
    ragged.write_text("t,q,force\n0,1,2\n1,2\n")
    with pytest.raises(ValueError, match="row 3 .* 2 fields"):
        load_measurements(ragged)
    empty = tmp_path / "f.csv"
    empty.write_text("")
    with pytest.raises(ValueError, match="empty"):
        load_measurements(empty)
    c = _emps_like()
    c["qg"] = c["qg"][:20]
    with pytest.raises(ValueError, match="different lengths"):
        load_measurements(_save(tmp_path, c), position="qg", force="vir")
    with pytest.raises(ValueError, match="`time` must be a non-empty column name"):
        load_measurements(tmp_path / "a.csv", time="")


# --------------------------------------------------------------------------- #
# Sampling: uniform within max_jitter of the median step, or refused / resampled
# --------------------------------------------------------------------------- #


@requires_emps
def test_real_emps_file_time_jitter_is_within_tolerance():
    # The benchmark's t is rounded to single precision: steps of 0.99998 and 1.00002 ms.
    t = scipy.io.loadmat(EMPS_MAT)["t"].ravel()
    steps = np.diff(t)
    jitter = np.abs(steps / np.median(steps) - 1).max()
    assert 1e-5 < jitter < MAX_JITTER / 10
    data = load_emps(EMPS_MAT)
    assert data.resampled is None and data.dt == pytest.approx(1e-3, rel=1e-12)  # the mean step, not the median
    assert load_emps(EMPS_MAT, irregular="resample").resampled is None  # nothing to resample


def test_jitter_within_tolerance_is_accepted(tmp_path):
    rng = np.random.default_rng(2)
    n, dt = 500, 2e-3
    t = np.arange(n) * dt + rng.uniform(-1, 1, n) * 0.2 * MAX_JITTER * dt  # steps within 0.4 x tolerance
    q, f = rng.standard_normal(n), rng.standard_normal(n)
    m = load_measurements(_write_csv(tmp_path / "j.csv", ["t", "q", "force"], zip(t, q, f)))
    median = np.median(np.diff(t))
    assert m.resampled is None
    assert m.dt == pytest.approx((t[-1] - t[0]) / (n - 1), rel=1e-12)
    assert abs(m.dt / median - 1) < MAX_JITTER
    np.testing.assert_array_equal(np.asarray(m.t), t)


def test_irregular_time_is_refused_naming_the_first_bad_sample(tmp_path):
    n = 300
    t = np.arange(n) * 1e-3
    t[101:] += 1.0  # a 1 s gap between samples 100 and 101 (0-based)
    t[201:] += 3e-6  # and a 0.3 % slip at sample 201
    rows = list(zip(t, np.sin(t), np.cos(t)))
    with pytest.raises(IrregularSamplingError) as info:
        load_measurements(_write_csv(tmp_path / "g.csv", ["t", "q", "force"], rows))
    e = info.value
    assert isinstance(e, ValueError)
    assert (e.index, e.count) == (101, 2)
    assert e.time == pytest.approx(1.101) and e.step == pytest.approx(1.001) and e.median == pytest.approx(1e-3)
    msg = str(e)
    assert "g.csv" in msg and "sample 101 (0-based, t = 1.101 s)" in msg and "median step is 0.001 s" in msg
    assert "irregular='resample'" in msg and "\n" not in msg
    # a looser tolerance lets the 0.3 % slip through, not the gap
    with pytest.raises(IrregularSamplingError, match=r"1 of 299 steps"):
        load_measurements(tmp_path / "g.csv", max_jitter=0.01)
    # the benchmark format too
    c = _emps_like()
    c["t"][150:, 0] += 0.5
    with pytest.raises(IrregularSamplingError, match=r"EMPS file data.mat: time `t` is not uniformly.*sample 150"):
        load_emps(_save(tmp_path, c))


def test_resample_onto_a_uniform_grid(tmp_path):
    n = 300
    t = np.arange(n) * 1e-3
    t[101:] += 0.05  # a 50 ms gap
    q, f = 2.0 * t + 1.0, -3.0 * t  # linear: interpolation is exact
    m = load_measurements(_write_csv(tmp_path / "g.csv", ["t", "q", "force"], zip(t, q, f)), irregular="resample")
    assert m.dt == pytest.approx(1e-3)
    n_new = round((t[-1] - t[0]) / 1e-3) + 1
    assert m.t.shape == m.q.shape == m.force.shape == (n_new,)
    np.testing.assert_allclose(np.diff(np.asarray(m.t)), 1e-3, rtol=1e-9)
    np.testing.assert_allclose(np.asarray(m.q), 2.0 * np.asarray(m.t) + 1.0, rtol=1e-12)
    np.testing.assert_allclose(np.asarray(m.force), -3.0 * np.asarray(m.t), atol=1e-12)
    assert m.resampled.startswith(f"resampled {n} irregular samples") and f"onto {n_new} samples" in m.resampled
    c = _emps_like()
    c["t"][150:, 0] += 0.01
    d = load_emps(_save(tmp_path, c), irregular="resample")
    assert d.t.shape == (210,) and d.resampled is not None
    np.testing.assert_allclose(np.asarray(d.force), 35.15 * np.asarray(d.vir), rtol=1e-15)
    np.testing.assert_allclose(np.asarray(d.qm)[:150], c["qm"].ravel()[:150])  # unchanged before the gap


@pytest.mark.parametrize(
    "kw",
    [
        dict(max_jitter=0),
        dict(max_jitter=-1e-3),
        dict(max_jitter=float("nan")),
        dict(max_jitter="x"),
        dict(irregular="split"),
    ],
)
def test_sampling_options_are_checked(tmp_path, kw):
    path = _save(tmp_path, _emps_like())
    with pytest.raises(ValueError, match="`max_jitter`|`irregular`"):
        load_emps(path, **kw)
    with pytest.raises(ValueError, match="`max_jitter`|`irregular`"):
        load_measurements(path, position="qm", force="vir", **kw)


def test_load_measurements_scale_to_si(tmp_path):
    """`scale` brings ms, mm and volts (with the gain) to s, m and N before the sampling checks."""
    t = np.arange(200) * 1e-3
    path = tmp_path / "units.csv"
    np.savetxt(path, np.c_[1e3 * t, 1e3 * 0.1 * t, np.full(200, 2.0)], delimiter=",", header="t,q,force", comments="")
    m = load_measurements(path, scale={"time": 1e-3, "position": 1e-3, "force": 35.15})
    np.testing.assert_allclose(np.asarray(m.t), t, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(np.asarray(m.q), 0.1 * t, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(np.asarray(m.force), 70.3, rtol=1e-12)
    assert m.dt == pytest.approx(1e-3, rel=1e-12)
    for bad in ({"speed": 2.0}, {"time": 0.0}, {"time": -1e-3}, {"force": float("nan")}, {"force": True}, [1e-3]):
        with pytest.raises(ValueError, match="scale"):
            load_measurements(path, scale=bad)


def test_a_cutoff_above_nyquist_names_milliseconds():
    """A record whose time is in ms (dt = 1 s) fails the cut-off check with the conversion named."""
    from jaxsdp.data import Measurements
    from jaxsdp.plants.emps import check_emps_data

    t = np.arange(3000.0)
    q = np.sin(2 * np.pi * t / 500)
    m = Measurements(t=t, q=q, force=np.cos(2 * np.pi * t / 500), dt=1.0)
    with pytest.raises(ValueError, match=r"scale=\{'time': 1e-3\}"):
        check_emps_data(m, cutoff_hz=100.0)
    check_emps_data(m, cutoff_hz=0.1)
