"""Argument checks shared by `jaxsdp.dlr`, `jaxsdp.dlr_loglik` and `jaxsdp.ml_nvr`.

The regression y (N,), z (N, p), the flat NVR vector of the parameter models
and the filter's start (P0, x0, burn-in) are checked here once; the value
checks (NaN, inf, sign) stay traceable (see `jaxsdp._checks.check_values`),
so the same code checks numpy arrays and arrays under `jax.jit`.
"""

import jax.numpy as jnp
import numpy as np

from .._checks import any_nonfinite, as_float_array, check_nonnegative, check_value, check_values
from .models import as_models, n_hyper, state_dim


def validate_regression(y, z, *, min_samples: int, carrier):
    """Check y (N,) and z (N, p); returns float64 (y, z) and `carrier` (a small array the
    caller goes on to use) carrying the traced value checks (see `check_values`)."""
    y = as_float_array("y", y, ndim=1)
    z = as_float_array("z", z, ndim=2)
    if z.shape[0] != y.shape[0]:
        raise ValueError(
            f"`z` must have one row per sample of `y`: y has shape {tuple(y.shape)}, z has shape {tuple(z.shape)}"
        )
    if y.shape[0] < min_samples:
        raise ValueError(f"`y` has {y.shape[0]} samples; the model needs at least {min_samples} (state dimension + 2)")
    # one pass over each array (operators only: the same code checks numpy and traced arrays)
    carrier = check_values(
        [
            ("z", z, any_nonfinite, f"contains NaN or inf (shape {tuple(z.shape)})"),
            ("y", y, lambda a: _y_code(a) == 0, "all values are NaN (nothing to estimate)"),
            ("y", y, lambda a: _y_code(a) >= 2, "contains inf (use NaN for missing samples)"),
        ],
        carrier=carrier,
    )
    return y, z, carrier


def _y_code(y):
    """max over samples of (observed) + 2 (inf): 0 if all NaN, >= 2 if any inf. One reduction.

    (A max of small integers, not a sum of floats: XLA-CPU fuses it with the
    elementwise part instead of materialising a full-size array first.)
    """
    return ((y == y).astype(np.int8) + 2 * (abs(y) == np.inf).astype(np.int8)).max()


def estimate_name(nvr, n_nvr: int, *, estimates=("ml",), unit: str = "block"):
    """The estimate `nvr` names (one of `estimates`, e.g. "ml") or None when it gives NVR values.

    A ValueError for any other string, and for an estimate when there is no
    NVR to estimate (`n_nvr` 0: every block, or coefficient, is `Constant`).
    """
    if not isinstance(nvr, str):
        return None
    if nvr not in estimates:
        options = ["NVR values"] + [f'"{e}"' for e in estimates]
        raise ValueError(f"`nvr` must be {', '.join(options[:-1])} or {options[-1]} (estimate them); got {nvr!r}")
    if n_nvr == 0:
        raise ValueError(f'`nvr="{nvr}"`: every {unit} is Constant, there is no NVR to estimate')
    return nvr


def nvr_vector(name: str, value, size: int, what: str):
    """A flat NVR vector of `size` from a scalar or a vector (ValueError naming `what` the entries are), >= 0."""
    v = as_float_array(name, value)
    if v.ndim == 0:
        v = jnp.full((size,), v)
    if v.shape != (size,):
        raise ValueError(f"`{name}` must be a scalar or have shape ({size},) ({what}); got shape {tuple(v.shape)}")
    return check_nonnegative(name, v)


def validate_nvr(nvr, models, name="nvr"):
    """Broadcast/check the flat NVR vector for `models` (finite, >= 0).

    `None` is an error (the NVRs are required) unless every block is
    `Constant` (no NVR); `jaxsdp.dlr` handles "ml" before these checks.
    """
    k = n_hyper(models)
    if nvr is None:
        if k == 0:
            return jnp.zeros((0,))
        raise ValueError(
            f"`{name}` is required: give the NVR(s) of the {[m.name for m in models]} blocks "
            '(e.g. nvr=1e-3), or nvr="ml" to estimate them by maximum likelihood'
        )
    what = f"one NVR per RW/IRW/SRW block, two per LLT, none for Constant; models {[m.name for m in models]}"
    return nvr_vector(name, nvr, k, what)


def validate_dlr_args(y, z, model, nvr, P0, x0, burn_in):
    """The checks of `jaxsdp.dlr`'s arguments (shared with `jaxsdp.dlr_loglik`): arrays, models, int burn-in."""
    y = as_float_array("y", y, ndim=1)
    z = as_float_array("z", z, ndim=2)
    models = as_models(model, z.shape[1])
    n = state_dim(models)
    nvr = validate_nvr(nvr, models)
    P0 = as_float_array("P0", P0, ndim=0)
    P0 = check_value("P0", P0, lambda a: ~(a > 0), "must be positive")
    y, z, P0 = validate_regression(y, z, min_samples=n + 2, carrier=P0)
    x0 = jnp.zeros(n) if x0 is None else as_float_array("x0", x0, ndim=1)
    if x0.shape != (n,):
        raise ValueError(f"`x0` must have shape ({n},) (the state dimension); got {tuple(x0.shape)}")
    return y, z, nvr, P0, x0, models, int(n + 1 if burn_in is None else burn_in)
