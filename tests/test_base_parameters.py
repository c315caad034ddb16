"""`base_parameters`: the first independent columns in the names' order, whatever the rounding; the combinations
exact; the rank rule of QR with column pivoting; Khalil's regrouping on the TX40."""

import warnings

import numpy as np
import pytest

from jaxsdp.data import Drives
from jaxsdp.plants import base_parameters, tx40_robot
from jaxsdp.plants.robot import robot_model


def _regression(seed=0, m=200):
    """(W, names): a, b independent; c = a (a tie: the same column); d = 2 b - a; e zero."""
    rng = np.random.default_rng(seed)
    a, b = rng.normal(size=(2, m))
    return np.c_[a, b, a, 2 * b - a, np.zeros(m)], ("a", "b", "c", "d", "e")


def test_ties_go_to_the_first_column_whatever_the_rounding():
    W, names = _regression()
    for eps in (0.0, 1e-15, -1e-15):  # c a rounding larger or smaller than a: pivoted QR would follow it
        V = W.copy()
        V[:, 2] *= 1 + eps
        b = base_parameters(V, names)
        assert b.rank == 2 and b.independent == ("a", "b") and b.dependent == ("c", "d", "e")
        assert b.names == ("a +1 c -1 d", "b +2 d") and list(b.columns) == [0, 1]


def test_combinations_reproduce_the_dependent_columns():
    W, names = _regression(seed=1)
    b = base_parameters(W, names)
    K = b.combination
    ind, dep = W[:, b.columns], W[:, b.dependent_columns]
    np.testing.assert_allclose(ind @ K, dep, rtol=0, atol=1e-12 * np.abs(W).max())
    assert np.all(K[:, list(b.dependent).index("e")] == 0)  # a zero column: no effect, K = 0
    theta = np.random.default_rng(2).normal(size=5)
    np.testing.assert_allclose(ind @ b.values(theta), W @ theta, rtol=1e-12, atol=1e-12)


def test_the_order_of_the_names_chooses_which_is_kept():
    W, names = _regression()
    order = [2, 1, 0, 3, 4]  # c listed before a: c is kept, a regrouped into it
    b = base_parameters(W[:, order], tuple(names[i] for i in order))
    assert b.independent == ("c", "b") and b.names[0] == "c +1 a -1 d"


def test_rank_is_the_pivoted_rule_and_a_threshold_case_warns():
    W, names = _regression()
    rng = np.random.default_rng(3)
    for p in (4, 7, 12):
        X = rng.normal(size=(50, p)) * np.logspace(0, 3, p)  # columns of very different scales, all independent
        assert base_parameters(X, [f"x{i}" for i in range(p)]).rank == p
    # x3's part off x1, x2 is 1e-7 of its norm, kept at tol = 3e-8 in order; pivoted QR takes x2, x3 first and
    # leaves x1 a last diagonal 0.1 x 1e-7 of R_11, below tol: the rank depends on tol
    e = np.linalg.qr(rng.normal(size=(40, 3)))[0].T
    X = np.c_[e[0], e[0] + 0.1 * e[1], e[1] + 1e-7 * e[2]]
    with pytest.warns(UserWarning) as record:
        assert base_parameters(X, ("x1", "x2", "x3"), tol=3e-8).rank == 3
    messages = [str(w.message) for w in record]
    assert any("rank depends on `tol`" in m for m in messages) and any("nearly dependent" in m for m in messages)
    assert all(w.filename == __file__ for w in record)  # the warnings name the caller's line
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        base_parameters(W, names)  # a clear gap: no warning


def test_nearly_parallel_columns_kept_in_order_warn():
    """In order, x1 and x1 + 1.5e-8 x2 are both kept (independent above tol) and x2 becomes their difference over
    1.5e-8: combinations of 7e7, where pivoting would keep x1 + 1.5e-8 x2, x2, x3. The warning says so."""
    e = np.linalg.qr(np.random.default_rng(4).normal(size=(30, 3)))[0].T
    X = np.c_[e[0], e[0] + 1.5e-8 * e[1], e[1], e[2]]
    with pytest.warns(UserWarning, match="nearly dependent") as record:
        b = base_parameters(X, ("x1", "x2", "x3", "x4"))
    assert b.rank == 3 and np.abs(b.combination).max() > 1e7
    assert record[0].filename == __file__


def test_bad_input_is_a_clear_error():
    W, names = _regression()
    with pytest.raises(ValueError, match="5 names"):
        base_parameters(W[:, :4], names)
    V = W.copy()
    V[0, 0] = np.nan
    with pytest.raises(ValueError, match="finite"):
        base_parameters(V, names)
    assert base_parameters(np.zeros((10, 2)), ("a", "b")).rank == 0
    for tol in (0.0, float("nan"), 1.5, "1e-8"):
        with pytest.raises(ValueError, match="`tol`"):
            base_parameters(W, names, tol=tol)
    # float32: its rounding (1e-7) hides the dependencies (c = a, d = 2 b - a would look independent)
    with pytest.raises(ValueError, match="float32.*64-bit mode"):
        base_parameters(W.astype(np.float32), names)
    assert base_parameters(W.astype(np.float32), names, tol=1e-4).rank == 2  # a tol above its rounding is fine


def test_tx40_full_model_is_khalils_regrouping():
    """The full TX40 with its coupled wrist: XX_j and ZZ_j kept, YY_j regrouped into them, Ia_j into ZZ_j (joints
    2 and 3: motor inertia and link inertia about the same axis); the same base set from other random states."""
    robot = tx40_robot()
    C = Drives.builtin("tx40").transmission
    models = [robot_model(robot, transmission=C, seed=s) for s in (0, 1)]
    assert models[0].names == models[1].names and models[0].rank == 58
    names = set(models[0].names)
    assert not {f"YY{j}" for j in range(1, 7)} & names
    assert {"ZZ1", "XX2", "ZZ2", "XX3", "ZZ3", "MY3", "XX5", "ZZ5"} <= names
    dep = models[0].base.dependent
    assert "Ia2" in dep and "Ia1" in dep  # into ZZ2, ZZ1 (with the links' ZZ about joint 1's axis)
