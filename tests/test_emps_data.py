import numpy as np
import pytest
import scipy.io

from helpers import EMPS_MAT, requires_emps
from jaxsdp.data import EMPSData, Measurements, load_emps, load_measurements


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
