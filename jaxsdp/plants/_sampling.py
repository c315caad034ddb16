"""Sampled signals of the closed-loop simulators: time grids, input checks, encoder quantisation."""

import jax
import jax.numpy as jnp
import numpy as np

from .._checks import FINITE_ARRAY, POSITIVE, as_float_array, flag, is_concrete


def time_grid(name_ref: str, n: int, t, dt):
    """Sample times, nominal controller period, and constraints to check."""
    if t is None:
        return jnp.arange(n) * dt, dt, [("dt", dt, POSITIVE)]
    t = as_float_array("t", t, ndim=1)
    if t.shape[0] != n:
        raise ValueError(f"`t` has {t.shape[0]} samples but `{name_ref}` has {n}")
    if n < 2:
        raise ValueError("`t` needs at least 2 samples")
    if dt is None:
        dt = (t[-1] - t[0]) / (n - 1)
    xnp = np if is_concrete(t) else jnp  # no tracer from concrete times inside a caller's jit
    cons = [
        ("t", t, FINITE_ARRAY),
        ("t", xnp.any(xnp.diff(xnp.asarray(t)) <= 0), flag("must be strictly increasing")),
        ("dt", dt, POSITIVE),
    ]
    return t, dt, cons


def sampled_signal(name: str, x, n: int | None = None, ref: str = "qg"):
    """A 1-D float64 signal of `n` samples (ValueError at trace time otherwise)."""
    x = as_float_array(name, x, ndim=1)
    if n is not None and x.shape[0] != n:
        raise ValueError(f"`{name}` has {x.shape[0]} samples but `{ref}` has {n}")
    if x.shape[0] < 1:
        raise ValueError(f"`{name}` must not be empty")
    return x


def quantise_rounding(x, quantum):
    """Round to the nearest multiple of `quantum` (traced; `quantum = 0`: no rounding).

    Zero-mean quantisation error; the rounding has no gradient.
    """
    on = quantum > 0
    qs = jnp.where(on, quantum, 1.0)
    return jnp.where(on, x + jax.lax.stop_gradient(jnp.round(x / qs) * qs - x), x)
