"""Physical parameters of the plant models: stored as float64, checked eagerly or under `jit`.

A constraint is `(name, value, rule)` with `rule` a `jaxsdp._checks.Rule`:
`FINITE`, `POSITIVE`, `NONNEGATIVE` (scalar parameters), `FINITE_ARRAY`
(array parameters) or `flag(message)` (then `value` is a boolean that is True
when invalid): the same rules as every other check of the library.
Concrete values are checked eagerly and raise ValueError naming the argument;
traced values are all guarded together by a single `eqx.branched_error_if`.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._checks import FINITE, Rule, guard, is_concrete


def _bad(value, rule: Rule, xnp=jnp):
    """True if `value` breaks `rule` (`xnp`: numpy for concrete values, so that no tracer is created inside a
    caller's `jit`)."""
    return xnp.asarray(rule.bad(xnp.asarray(value)))


def _message(name, rule: Rule):
    return f"`{name}` {rule.message}"


def _check_concrete(name, value, rule: Rule):
    value = np.asarray(value)
    value = value if value.dtype == bool else value.astype(np.float64)  # a flag's verdict stays boolean
    with np.errstate(invalid="ignore"):
        if bool(_bad(value, rule, np)):
            shown = "" if value.dtype == bool else f"; got {value}"
            raise ValueError(_message(name, rule) + shown)


def parameter(name: str, value, rule: Rule = FINITE):
    """Store a model parameter: concrete values are checked now (ValueError) and
    kept as NumPy float64 (no precision loss outside `jax.enable_x64`); traced
    values are stored as they are and checked when a simulator uses them."""
    if is_concrete(value):
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise ValueError(f"`{name}` must be numeric; got {type(value).__name__}: {e}") from None
        _check_concrete(name, arr, rule)
        return arr
    return value


def check_parameters(x, constraints):
    """Validate constraints `(name, value, rule)`; return `x` guarded by one error_if for the traced ones.

    A scalar rule also requires a 0-d value (vmap over batches of parameters).
    """
    traced = []
    for name, value, rule in constraints:
        if rule.scalar and jnp.ndim(value) != 0:
            raise ValueError(
                f"`{name}` must be a scalar inside the simulation (vmap over batches); "
                f"got shape {tuple(jnp.shape(value))}"
            )
        if is_concrete(value):
            _check_concrete(name, value, rule)
        else:
            traced.append((name, value, rule))
    if not traced:
        return x
    flags = jnp.stack([_bad(v, r).reshape(()) for _, v, r in traced])
    return guard(x, flags, [_message(n, r) for n, _, r in traced])


def to64(tree):
    """Convert the array leaves of a model to float64 JAX arrays."""
    return jax.tree_util.tree_map(lambda x: jnp.asarray(x, dtype=jnp.float64) if eqx.is_array_like(x) else x, tree)
