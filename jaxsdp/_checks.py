"""Input validation shared by all public entry points.

Shape and dtype problems raise `ValueError` at trace time. Value problems
(NaN, negative NVRs, ...) raise `ValueError` immediately when the value is
concrete, and are guarded with `eqx.error_if` when the value is traced
(inside the caller's `jit`/`vmap`/`grad`).
"""

from collections.abc import Callable
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

#: Fewest decimated samples an identification study fits (regressions, SDP stages): fewer make the
#: estimates and their standard deviations meaningless.
MIN_FIT_SAMPLES = 50


class OptionError(ValueError):
    """An option that does not fit the data (a decimation leaving too few samples, a cut-off above the
    Nyquist frequency): the user changes the option, not the data. The command line exits with 2 for it,
    as for any usage error; data errors exit with 1."""


def is_concrete(x) -> bool:
    return not isinstance(x, jax.core.Tracer)


def as_float_array(name: str, x, ndim: int | None = None):
    """Convert to a float64 JAX array and check the number of dimensions."""
    try:
        arr = jnp.asarray(x, dtype=jnp.float64)
    except (TypeError, ValueError) as e:
        raise ValueError(f"`{name}` must be a numeric array; got {type(x).__name__}: {e}") from None
    if ndim is not None and arr.ndim != ndim:
        raise ValueError(f"`{name}` must be {ndim}-D; got shape {tuple(arr.shape)}")
    return arr


class Rule(NamedTuple):
    """A value check: `bad(a)` (numpy or jax array -> boolean scalar) is True when `a` breaks it, `message`
    says what it requires; `scalar`: the value must be 0-d (a model parameter inside a simulation, so that
    a batch of them is a `vmap`). Every check of the library is one: functions here, rules for the plant
    models' parameters (`jaxsdp.plants._parameters`)."""

    bad: Callable
    message: str
    scalar: bool = False


def any_nonfinite(a):
    """Whether `a` (numpy or jax) holds a NaN or inf: one boolean reduction (NaN fails both comparisons)."""
    return ~((a < np.inf) & (a > -np.inf)).all()


#: A finite scalar / a finite array / a finite scalar > 0 / a finite scalar >= 0.
FINITE = Rule(any_nonfinite, "must be finite", scalar=True)
FINITE_ARRAY = Rule(any_nonfinite, "must be finite")
POSITIVE = Rule(lambda a: ~((a > 0) & (a < np.inf)).all(), "must be > 0 and finite", scalar=True)
NONNEGATIVE = Rule(lambda a: ~((a >= 0) & (a < np.inf)).all(), "must be >= 0 and finite", scalar=True)


def flag(message: str) -> Rule:
    """A rule whose value is already the verdict: a boolean (array) that is True where the value is invalid,
    e.g. `flag("must be increasing")` with `any(diff(v) < 0)`."""
    return Rule(lambda a: a.any(), message)


def check_value(name: str, x, bad, message: str):
    """Raise ValueError if `bad(x)` holds for a concrete `x`; else guard with error_if.

    `bad` maps an array (numpy or jax) to a boolean scalar.
    """
    return check_values([(name, x, bad, message)], carrier=x)


def check_finite(name: str, x):
    return check_value(name, x, any_nonfinite, f"contains NaN or inf (shape {tuple(jnp.shape(x))})")


def check_nonnegative(name: str, x):
    """Every entry finite and >= 0 (NaN and inf are errors: an NVR of inf is not a model)."""
    return check_value(name, x, lambda a: ~((a >= 0) & (a < np.inf)).all(), "must be non-negative and finite")


def check_positive(name: str, x):
    """Every entry finite and > 0 (a start value or a bound on a log scale)."""
    return check_value(name, x, lambda a: ~((a > 0) & (a < np.inf)).all(), "must be finite and positive")


def positive_float(name: str, x, *, allow_none: bool = False) -> float | None:
    """A static option (Python float) that must be finite and positive; None passes if allowed.

    For options that fix the compiled program (caps, bounds): they must be
    concrete, so a traced value is an error too.
    """
    if x is None and allow_none:
        return None
    if isinstance(x, jax.core.Tracer):
        raise ValueError(f"`{name}` must be a concrete number (it is a static option), not a traced value")
    try:
        v = float(np.asarray(x, dtype=float).reshape(()))
    except (TypeError, ValueError):
        raise ValueError(f"`{name}` must be a positive number; got {x!r}") from None
    if not (np.isfinite(v) and v > 0):
        extra = " (use None for no cap)" if allow_none else ""
        raise ValueError(f"`{name}` must be finite and positive{extra}; got {x!r}")
    return v


def positive_int(name: str, v) -> int:
    """A static count that must be a Python or numpy integer >= 1 (bool is not); returns it as an int."""
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
        raise ValueError(f"`{name}` must be an integer >= 1; got {v!r}")
    return int(v)


def nonnegative_int(name: str, v) -> int:
    """A static count >= 0 (a Python or NumPy integer; bool is not)."""
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
        raise ValueError(f"`{name}` must be an integer >= 0; got {v!r}")
    return int(v)


def no_spread(a):
    """Whether the observed (non-NaN) values of `a` are all equal: zero variance. One reduction each way."""
    xp = np if isinstance(a, np.ndarray) else jnp
    return ~(xp.nanmax(a) > xp.nanmin(a))


def check_values(checks, *, carrier):
    """Several value checks whose traced guards ride on one small array.

    `checks`: (name, x, bad, message) tuples as for `check_value`. A concrete
    `x` is checked now (ValueError). The traced checks become one
    `eqx.branched_error_if` on `carrier` (a small array the computation goes
    on to use, e.g. a scalar option), not on `x` itself: routing a long array
    through the guard's conditional costs a copy of it on the CPU. Checks
    whose `bad` share a reduction (the same expression of the same array)
    are computed in one pass (XLA merges the common subexpression).
    Returns the guarded carrier.
    """
    preds, messages = [], []
    for name, x, bad, message in checks:
        if is_concrete(x):
            with np.errstate(invalid="ignore"):  # (a check may compute inf * 0 on purpose)
                found = bool(np.asarray(bad(np.asarray(x))))
            if found:
                raise ValueError(f"`{name}`: {message}")
        else:
            preds.append(jnp.asarray(bad(x)).reshape(()))
            messages.append(f"`{name}`: {message}")
    if preds:
        flags = jnp.stack(preds)
        carrier = eqx.branched_error_if(carrier, flags.any(), jnp.argmax(flags), messages)
    return carrier
