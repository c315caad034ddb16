"""`jaxsdp._checks.checked_call`: a top-level program's value checks as outputs, so that it holds no host callback
(JAX's persistent compilation cache never keeps a program with one; issue 46 item 3)."""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxsdp._checks import (
    POSITIVE,
    _checked_map,
    _collecting_call,
    any_nonfinite,
    check_finite,
    check_positive,
    checked_call,
    checked_map,
    nonfinite_handled,
)
from jaxsdp.plants._parameters import check_parameters


def pipeline(x, scale):
    """Checks at the program's level (an input, an intermediate, a model parameter) and inside a vmap."""
    x = check_finite("x", x)
    s = check_positive("scale", scale)
    z = check_finite("z", jnp.log(x) * s)
    z = check_parameters(z, [("k", z[0], POSITIVE)])
    w = jax.vmap(lambda r: check_finite("row", r))(jnp.ones((2, 3)) * scale)  # an error_if: see below
    return z + w.sum(axis=0)


X = np.array([2.0, 3.0, 4.0])


def test_same_result_as_the_plain_call():
    np.testing.assert_allclose(checked_call(pipeline, X, 2.0), pipeline(jnp.asarray(X), jnp.asarray(2.0)), rtol=1e-15)


@pytest.mark.parametrize(
    "x,scale,match",
    [
        (np.array([2.0, np.nan, 4.0]), 2.0, "`x`: contains NaN or inf"),
        (X, -1.0, "`scale`: must be finite and positive"),
        (np.array([2.0, 0.0, 4.0]), 2.0, "`z`: contains NaN or inf"),  # log(0): an intermediate
        (np.array([0.5, 3.0, 4.0]), 2.0, "`k` must be > 0"),  # a model parameter's rule (plants._parameters)
    ],
)
def test_failed_checks_raise_value_error_with_the_checks_message(x, scale, match):
    """The first failed check in program order, as the concrete check's ValueError (not XLA's runtime error).
    (A check left as an `eqx.error_if`, inside a vmap, raises first if its own value is bad: it runs with the
    program, the collected ones after it.)"""
    with pytest.raises(ValueError, match=match):
        checked_call(pipeline, x, scale)


def test_checks_inside_a_vmap_stay_error_if():
    """A check whose value lives in a vmap (or a loop's body, an inner jit) cannot reach the program's outputs:
    it stays an `eqx.error_if`, and still raises."""

    def inner(x):
        return jax.vmap(lambda r: check_finite("row", r))(x).sum()

    with pytest.raises(eqx.EquinoxRuntimeError, match="`row`: contains NaN or inf"):
        checked_call(inner, np.array([[1.0, np.nan]]))


def test_the_program_holds_no_host_callback():
    """What keeps it out of JAX's persistent cache: the plain jit of the same function has a callback."""

    def f(x):
        return check_finite("x", x).sum()

    assert "callback" not in _collecting_call.lower(f, (X,), {}).as_text()
    assert "callback" in jax.jit(f).lower(X).as_text()


def test_inside_a_callers_transformation_it_is_the_plain_call():
    """Traced arguments (the caller's jit, grad or vmap): the checks are error_if, as in any entry point."""
    f = lambda x: checked_call(pipeline, x, 2.0).sum()  # noqa: E731
    g = jax.grad(f)(jnp.asarray(X))
    np.testing.assert_allclose(g, jax.grad(lambda x: pipeline(x, 2.0).sum())(jnp.asarray(X)), rtol=1e-14)
    np.testing.assert_allclose(jax.jit(f)(X), f(X), rtol=1e-15)
    with pytest.raises(eqx.EquinoxRuntimeError, match="`x`: contains NaN or inf"):
        eqx.filter_jit(f)(np.array([2.0, np.nan, 4.0])).block_until_ready()
    batch = jax.vmap(lambda x: checked_call(pipeline, x, 2.0))(np.stack([X, X + 1]))
    np.testing.assert_allclose(batch[1], checked_call(pipeline, X + 1, 2.0), rtol=1e-15)


def test_a_module_is_compiled_once_for_its_static_structure():
    """An eqx.Module callable: its arrays are traced, so another value of the same shape reuses the program."""

    class Scale(eqx.Module):
        k: jax.Array

        def __call__(self, x):
            return check_finite("x", x) * self.k

    checked_call(Scale(jnp.asarray(2.0)), X)
    before = _collecting_call._cached._cache_size()
    np.testing.assert_allclose(checked_call(Scale(jnp.asarray(3.0)), X), 3 * X)
    assert _collecting_call._cached._cache_size() == before


def test_monte_carlo_draws_return_their_checks_and_the_failed_draw_is_named():
    """The runner's program carries each draw's checks as flags (no callback): a failed check raises ValueError
    naming the draw, and a passing study returns what it did before."""
    from jaxsdp import monte_carlo

    def draw(key, p):
        return check_finite("x", jnp.log(p) + jax.random.normal(key, (2,))).sum()

    ok = monte_carlo(draw, 0, 8, params=np.arange(1.0, 9.0), chunk_size=4, progress=False)
    assert ok.values.shape == (8,) and np.all(np.isfinite(ok.values))
    with pytest.raises(ValueError, match=r"Monte Carlo draw 5 of 8: `x`: contains NaN or inf"):
        monte_carlo(draw, 0, 8, params=np.r_[np.ones(5), -1.0, np.ones(2)], chunk_size=4, progress=False)


def test_checked_map_is_jit_of_vmap_with_the_failed_element_named():
    def f(x):
        return check_positive("gain", x) * 2.0

    np.testing.assert_allclose(checked_map(f, jnp.asarray([1.0, 2.0])), [2.0, 4.0])
    with pytest.raises(ValueError, match=r"element 1 of the batch: `gain`: must be finite and positive"):
        checked_map(f, jnp.asarray([1.0, -2.0, 3.0]))
    assert "callback" not in _checked_map.lower(f, jnp.ones(2)).as_text()


def test_nonfinite_handled_drops_the_finite_checks_at_its_own_level_only():
    """An iteration that copes with a diverged simulation itself (NaN instruments stop it as failed): its own
    finite checks go, those of inner levels and concrete values stay."""

    def f(x):
        with nonfinite_handled():
            y = check_finite("x", x)  # this level: no guard
            z = jax.vmap(lambda r: check_finite("row", r))(x[None])  # a vmap inside: guarded
        return y.sum() + z.sum()

    assert "callback" in jax.jit(f).lower(X).as_text()  # the vmap's guard
    assert "callback" not in jax.jit(nonfinite_check_free).lower(X).as_text()
    assert np.isnan(jax.jit(nonfinite_check_free)(np.array([np.nan])))
    with nonfinite_handled(), pytest.raises(ValueError, match="`x`: contains NaN or inf"):
        check_finite("x", np.array([np.nan]))  # a concrete value is always checked


def nonfinite_check_free(x):
    with nonfinite_handled():
        return check_finite("x", x).sum()


def test_concrete_checks_of_an_accelerators_array_run_there(monkeypatch):
    """A concrete JAX array on an accelerator is checked on its device, one boolean coming back instead of the array
    (`_verdict`): the verdicts and the errors equal the host path's. CI has no accelerator, so the device path is
    forced for CPU arrays here; measured on an H200 in `benchmarks/ls_device.py`."""
    import jaxsdp
    import jaxsdp._checks as checks

    cases = [[1.0, 2.0], [1.0, np.nan], [np.inf, 1.0], [-1.0, 2.0], [0.0, 0.0], [3.0, 3.0], [np.nan, np.nan]]
    rules = [checks.FINITE_ARRAY.bad, checks.POSITIVE.bad, checks.NONNEGATIVE.bad, checks.no_spread]
    arrays = [jnp.asarray(c) for c in cases]
    host = [[checks._verdict(bad, a) for bad in rules] for a in arrays]
    assert any(map(any, host)) and not all(map(all, host))
    monkeypatch.setattr(checks, "_on_accelerator", lambda x: isinstance(x, jax.Array))
    assert [[checks._verdict(bad, a) for bad in rules] for a in arrays] == host
    X = jnp.ones((12, 2)).at[3, 1].set(jnp.nan)
    with pytest.raises(ValueError, match="`X`: contains NaN or inf"):
        jaxsdp.idim_ls(jnp.ones(12), X)
    with pytest.raises(ValueError, match="must be non-negative"):
        checks.check_nonnegative("nvr", jnp.asarray([1e-3, -1.0]))


@pytest.mark.parametrize(
    "a, bad",
    [
        (np.ones((300, 7)), False),
        (np.full((300, 7), 1e308), False),  # the sum overflows: read entry by entry, all finite
        (np.r_[np.ones(50), np.nan], True),
        (np.r_[np.ones(50), -np.inf], True),
        (np.r_[np.inf, -np.inf], True),  # (their sum is NaN)
        (np.arange(10), False),  # integers are finite
        (np.ones(4, np.float32), False),
        (np.array([1.0 + 1j, np.nan]), True),
        (np.array([1.0 + 1j, complex(1.0, np.nan)]), True),  # NaN in the imaginary part only
        (np.array([1.0, np.nan], dtype=jnp.bfloat16), True),  # an ml_dtypes float: not np.inexact, still a float
        (np.array([1.0, 2.0], dtype=jnp.bfloat16), False),
    ],
)
def test_any_nonfinite_of_a_numpy_array_is_the_entrywise_answer(a, bad):
    # a NumPy array is summed first (a finite sum proves every entry finite); the answer is np.isfinite's
    assert bool(any_nonfinite(a)) is bad is bool(~np.isfinite(a).all())
    assert bool(any_nonfinite(jnp.asarray(a))) is bad  # and the JAX path's
