"""Input validation shared by all public entry points.

Shape and dtype problems raise `ValueError` at trace time. Value problems
(NaN, negative NVRs, ...) raise `ValueError` immediately when the value is
concrete, and are guarded with `eqx.error_if` when the value is traced
(inside the caller's `jit`/`vmap`/`grad`).

A computation the library compiles itself for a top-level call carries its
checks out as outputs instead (`checked_call`: the control tuning's cost and
gradient; `checked_map`: a grid of designs; `with_flags` in the Monte Carlo
runner's draws): the traced checks at that program's own level become a
vector of flags that the host reads when the program returns (`raise_flagged`),
raising the same `ValueError` as a concrete check. Such a program holds no host callback (an `eqx.error_if` is
one), so JAX's persistent compilation cache keeps it across processes; a
program with a callback is compiled again in every process.
"""

import contextlib
import threading
import warnings
from collections.abc import Callable
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax._src import core as _core

from ._runtime import trace_state_clean

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
    """Whether `a` (numpy or jax) holds a NaN or inf (in either part of a complex number). A real JAX array: one
    boolean reduction (NaN fails both comparisons). A NumPy array is first summed (a finite sum proves every entry
    finite; 8 ms against 24 ms on 16 million entries) and read entry by entry only when the sum is not finite (a
    NaN, an inf, or an overflow); integers and booleans are finite."""
    if isinstance(a, np.ndarray):
        if a.dtype == np.bool_ or np.issubdtype(a.dtype, np.integer):
            return np.False_
        with np.errstate(over="ignore", invalid="ignore"):
            if np.isfinite(a.sum()):
                return np.False_
        return ~np.isfinite(a).all()
    if jnp.iscomplexobj(a):
        return ~jnp.isfinite(a).all()
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
    """Every entry finite: checked now if concrete, else guarded (`guard`); not for a traced value inside
    `nonfinite_handled` at the same trace level."""
    if not is_concrete(x) and _FINITE.here() is not None:
        return x
    return check_value(name, x, any_nonfinite, f"contains NaN or inf (shape {tuple(jnp.shape(x))})")


def nonfinite_handled():
    """Within it, `check_finite` makes no guard for traced values at the current trace level: the caller handles
    non-finite values itself (a simulation inside an iteration: its record made finite and the step marked
    failed, or NaN instruments that stop the iteration as failed), so the check would only stop a computation
    that already copes, and put a host callback in its program. Inner `jit`s, `vmap`s and loop bodies (other
    trace levels) keep their checks."""
    return _FINITE.entered(True)


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
    if not isinstance(a, np.ndarray):
        return ~(jnp.nanmax(a) > jnp.nanmin(a))
    with warnings.catch_warnings():  # all NaN: no spread, and NumPy's "All-NaN slice" warning says nothing more
        warnings.simplefilter("ignore", RuntimeWarning)
        return ~(np.nanmax(a) > np.nanmin(a))


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
            found = _verdict(bad, x)
            if found:
                raise ValueError(f"`{name}`: {message}")
        else:
            preds.append(jnp.asarray(bad(x)).reshape(()))
            messages.append(f"`{name}`: {message}")
    if preds:
        carrier = guard(carrier, jnp.stack(preds), messages)
    return carrier


def _verdict(bad, x) -> bool:
    """`bad(x)` of a concrete `x`, computed where `x` lives: in NumPy for host data (a CPU array is read without a
    copy), on the device for an accelerator's array, so that one boolean crosses to the host and not the array (a
    robot's stacked regressor on a GPU: 2.8 GB, 0.76 s of transfer for a check of 6 million rows, 2026-11-28)."""
    if _on_accelerator(x):
        return bool(bad(x))
    with np.errstate(invalid="ignore"):  # (a check may compute inf * 0 on purpose)
        return bool(np.asarray(bad(np.asarray(x))))


def _on_accelerator(x) -> bool:
    """Whether `x` is a JAX array held (in part) by a device other than the CPU."""
    return isinstance(x, jax.Array) and any(d.platform != "cpu" for d in x.devices())


def guard(carrier, flags, messages):
    """`carrier` guarded by the traced check flags (`flags[i]` True: `messages[i]` is the error): one
    `eqx.branched_error_if`, or, at the level of a program `checked_call` compiles, the flags handed to it."""
    found = _COLLECTING.here()  # at the level of a program whose checks are outputs (not inside its vmaps, loops)
    if found is not None:
        found.flags.append(flags)
        found.messages.extend(messages)
        return carrier
    return eqx.branched_error_if(carrier, flags.any(), jnp.argmax(flags), list(messages))


class _PerTraceLevel(threading.local):
    """A per-thread stack of values, each entered at a JAX trace level (the level at which `jit`, `vmap` or a
    loop's body traces its function): `here()` is the innermost value when the current level is the one it was
    entered at, else None (inside an inner `jit`, `vmap` or loop body)."""

    def __init__(self):
        self.stack: list = []

    @contextlib.contextmanager
    def entered(self, value):
        self.stack.append((_core.trace_ctx.trace, value))
        try:
            yield value
        finally:
            self.stack.pop()

    def here(self):
        if self.stack and self.stack[-1][0] is _core.trace_ctx.trace:
            return self.stack[-1][1]
        return None


#: `nonfinite_handled` levels; the `_Found` of each program whose checks are outputs (`with_flags`).
_FINITE = _PerTraceLevel()
_COLLECTING = _PerTraceLevel()


class _Found:
    """The checks met at one program's own trace level (`with_flags`)."""

    def __init__(self):
        self.flags: list = []
        self.messages: list = []


def with_flags(fn, *args, **kwargs):
    """`(fn(*args, **kwargs), flags, messages)`: the value checks `fn` makes at the caller's own trace level
    returned as a boolean vector (`flags[i]` True: `messages[i]` is the error) instead of `eqx.error_if`s. Inside
    a `vmap` (the Monte Carlo runner's draws) the flags are per draw. The caller raises."""
    with _COLLECTING.entered(_Found()) as found:
        out = fn(*args, **kwargs)
    flags = jnp.concatenate(found.flags) if found.flags else jnp.zeros(0, dtype=bool)
    return out, flags, tuple(found.messages)


@eqx.filter_jit
def _collecting_call(fn, args, kwargs):
    return with_flags(fn, *args, **kwargs)


@eqx.filter_jit
def _checked_map(fn, xs):
    found = []

    def one(x):
        out, flags, messages = with_flags(fn, x)
        found[:] = messages
        return out, flags

    out, flags = jax.vmap(one)(xs)
    return out, flags, tuple(found)


def checked_map(fn, xs):
    """`jax.jit(jax.vmap(fn))(xs)` with each element's value checks as flags (`with_flags`): no host callback in
    the program, and the first failed check raises ValueError naming the element (a grid search's point)."""
    out, flags, messages = _checked_map(fn, xs)
    raise_flagged(flags, messages, element=lambda i: f"element {i} of the batch")
    return out


def checked_call(fn, /, *args, **kwargs):
    """`fn(*args, **kwargs)` compiled as one program whose value checks are outputs, raised here as `ValueError`.

    For the library's own top-level computations (a pipeline on concrete data): the program holds no
    `eqx.error_if` at its own level, so it is written to JAX's persistent compilation cache and read back by
    later processes (a program with a host callback never is). Inside a caller's `jit`/`vmap`/`grad` (a traced
    argument) it is `fn(*args, **kwargs)`, with the checks as `eqx.error_if`. `fn` is static to the compiled
    program (a function, or an `eqx.Module` whose arrays are traced). The host waits for the program's flags
    before returning (a top-level call's results are read at once in the library's uses)."""
    if any(isinstance(x, jax.core.Tracer) for x in jax.tree.leaves((fn, args, kwargs))) or not trace_state_clean():
        return fn(*args, **kwargs)
    out, flags, messages = _collecting_call(fn, args, kwargs)
    raise_flagged(flags, messages)
    return out


def raise_flagged(flags, messages, *, element: Callable[[int], str] | None = None) -> None:
    """Raise `ValueError` for the first failed check of a program's flags (`with_flags`), if any: `flags` of shape
    `(n_checks,)`, or `(n, n_checks)` for a batch, the error then prefixed by `element(i)` for its element `i`
    (a draw, a grid point). Reads the flags to the host (waits for the program)."""
    if not messages:
        return
    bad = np.asarray(flags)
    if not bad.any():
        return
    if element is None:
        raise ValueError(messages[int(np.argmax(bad.reshape(-1)))])
    i, check = np.argwhere(bad.reshape(bad.shape[0], -1))[0]
    raise ValueError(f"{element(int(i))}: {messages[int(check)]}")
