"""Physical parameters of the plant models: stored as float64, checked eagerly or under `jit`.

A constraint is `(name, value, kind)` with kind one of "positive",
"nonnegative", "finite" (scalar parameters), "finite[]" (array parameters) or
"flag:<message>" (then `value` is a boolean that is True when invalid).
Concrete values are checked eagerly and raise ValueError naming the argument;
traced values are all guarded together by a single `eqx.branched_error_if`.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._checks import is_concrete

_DESCRIPTION = {
    "positive": "must be > 0 and finite",
    "nonnegative": "must be >= 0 and finite",
    "finite": "must be finite",
    "finite[]": "must be finite",
}


def _bad(value, kind, xnp=jnp):
    """True if `value` violates `kind` (`xnp`: numpy for concrete values, so
    that no tracer is created inside a caller's `jit`)."""
    if kind.startswith("flag:"):
        return xnp.asarray(value, dtype=bool)
    v = xnp.asarray(value)
    bad = ~xnp.isfinite(v)
    if kind == "positive":
        bad = bad | ~(v > 0)
    elif kind == "nonnegative":
        bad = bad | ~(v >= 0)
    return xnp.any(bad)


def _message(name, kind):
    msg = kind[5:] if kind.startswith("flag:") else _DESCRIPTION[kind]
    return f"`{name}` {msg}"


def _check_concrete(name, value, kind):
    value = np.asarray(value) if kind.startswith("flag:") else np.asarray(value, dtype=np.float64)
    if bool(_bad(value, kind, np)):
        shown = "" if kind.startswith("flag:") else f"; got {np.asarray(value)}"
        raise ValueError(_message(name, kind) + shown)


def parameter(name: str, value, kind: str = "finite"):
    """Store a model parameter: concrete values are checked now (ValueError) and
    kept as NumPy float64 (no precision loss outside `jax.enable_x64`); traced
    values are stored as they are and checked when a simulator uses them."""
    if is_concrete(value):
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise ValueError(f"`{name}` must be numeric; got {type(value).__name__}: {e}") from None
        _check_concrete(name, arr, kind)
        return arr
    return value


def check_parameters(x, constraints):
    """Validate constraints; return `x` guarded by one error_if for the traced ones.

    Scalar kinds also require a 0-d value (vmap over batches of parameters).
    """
    traced = []
    for name, value, kind in constraints:
        if kind in ("positive", "nonnegative", "finite") and jnp.ndim(value) != 0:
            raise ValueError(
                f"`{name}` must be a scalar inside the simulation (vmap over batches); "
                f"got shape {tuple(jnp.shape(value))}"
            )
        if is_concrete(value):
            _check_concrete(name, value, kind)
        else:
            traced.append((name, value, kind))
    if not traced:
        return x
    flags = jnp.stack([_bad(v, k) for _, v, k in traced])
    msgs = [_message(n, k) for n, _, k in traced]
    return eqx.branched_error_if(x, jnp.any(flags), jnp.argmax(flags), msgs)


def to64(tree):
    """Convert the array leaves of a model to float64 JAX arrays."""
    return jax.tree_util.tree_map(lambda x: jnp.asarray(x, dtype=jnp.float64) if eqx.is_array_like(x) else x, tree)
