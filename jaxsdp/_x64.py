"""float64 for public entry points without mutating global JAX configuration."""

import functools

import jax


def x64(fn):
    """Run `fn` under `jax.enable_x64(True)`.

    Public entry points are decorated with this so that every computation in
    jaxsdp is carried out in float64, whatever the caller's global setting.
    Importing jaxsdp never changes `jax.config`.
    """

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with jax.enable_x64(True):
            return fn(*args, **kwargs)

    return wrapper
