"""Transfer functions: conventions, validation, state-space realisation, characteristic polynomials.

Conventions used throughout `jaxsdp.control`:

- **Continuous time** `G(s) = B(s)/A(s)`: `num = [b0, ..., bm]` and
  `den = [1, a1, ..., an]`, highest power of `s` first, `den` monic, `m <= n`.
- **Discrete time** `G(z) = B(z^-1)/A(z^-1)`: `den = [1, a1, ..., an]` and
  `num = [b0, b1, ..., bm]`, coefficients of `z^0, z^-1, ...` (so the
  paper's model (30) is `num = [0, 0.0107, -0.0088, 0.0025]`,
  `den = [1, -1.8660, 0.8706]`). For a proper TF of equal lengths this is
  also scipy's positive-power convention.

Small polynomials are handled in closed form (no batched LAPACK over time):
`charpoly` is the Faddeev-LeVerrier recursion, exact and differentiable for
the orders used here (n <= 10).
"""

import jax.numpy as jnp
import numpy as np

from .._checks import is_concrete

MAX_ORDER = 10


def _as_poly(name, p):
    try:
        arr = jnp.asarray(p, dtype=jnp.float64)
    except (TypeError, ValueError) as e:
        raise ValueError(f"`{name}` must be a 1-D array of coefficients; got {type(p).__name__}: {e}") from None
    if arr.ndim != 1 or arr.shape[0] < 1:
        raise ValueError(f"`{name}` must be a non-empty 1-D array of coefficients; got shape {tuple(arr.shape)}")
    if is_concrete(arr) and not np.all(np.isfinite(np.asarray(arr))):
        raise ValueError(f"`{name}` contains NaN or inf: {np.asarray(arr).tolist()}")
    return arr


def check_tf(num, den, *, kind: str = "continuous"):
    """Validate a transfer function; return `(num, den)` as float64 arrays.

    Continuous: `den` monic of degree n >= 1 (leading coefficient exactly 1),
    `num` of degree m <= n (given as m + 1 coefficients). Discrete: `den[0] == 1`
    and `num` any length >= 1. A leading zero in `den` (a degree given too
    high) and a non-monic `den` are errors, not silently normalised: the
    parameter covariances and gains of the caller refer to that normalisation.
    """
    if kind not in ("continuous", "discrete"):
        raise ValueError(f"`kind` must be 'continuous' or 'discrete'; got {kind!r}")
    num, den = _as_poly("num", num), _as_poly("den", den)
    n = den.shape[0] - 1
    if n < 1:
        raise ValueError(f"`den` must have degree >= 1 (at least 2 coefficients); got {den.shape[0]}")
    if n > MAX_ORDER:
        raise ValueError(f"`den` has degree {n}; at most {MAX_ORDER} is supported")
    if is_concrete(den):
        lead = float(np.asarray(den)[0])
        if lead == 0.0:
            raise ValueError(f"`den` has a zero leading coefficient ({np.asarray(den).tolist()}): drop it")
        if lead != 1.0:
            raise ValueError(f"`den` must be monic (leading coefficient 1); got {lead:g}: divide num and den by it")
    if kind == "continuous" and num.shape[0] - 1 > n:
        raise ValueError(f"numerator degree m = {num.shape[0] - 1} exceeds denominator degree n = {n} (need m <= n)")
    return num, den


def charpoly(a):
    """Coefficients `[1, c1, ..., cn]` of `det(zI - a)` (Faddeev-LeVerrier, closed form for small n)."""
    a = jnp.asarray(a)
    n = a.shape[-1]
    eye = jnp.eye(n, dtype=a.dtype)
    coeffs = [jnp.ones(a.shape[:-2], dtype=a.dtype)]
    m = jnp.zeros_like(a)
    c = coeffs[0]
    for k in range(1, n + 1):
        m = a @ m + c[..., None, None] * eye
        c = -jnp.trace(a @ m, axis1=-2, axis2=-1) / k
        coeffs.append(c)
    return jnp.stack(coeffs, axis=-1)


def tf2ss(num, den):
    """Controllable canonical realisation `(A, B, C, D)` of a continuous `num/den` (den monic).

    State x = [x1..xn] with x1^(n) + a1 x1^(n-1) + ... + an x1 = u, x_i = x1^(i-1):
    `A` is the companion matrix (last row `-a_n ... -a_1`), `B = e_n`, and the
    output `y = C x + D u` after removing the direct term of a biproper TF.
    """
    n = den.shape[-1] - 1
    num = jnp.concatenate([jnp.zeros(n + 1 - num.shape[-1], dtype=num.dtype), num])  # pad to degree n
    d = num[0]
    rest = num[1:] - d * den[1:]  # coefficients of s^(n-1) .. s^0 after removing D
    a = jnp.zeros((n, n), dtype=den.dtype).at[:-1, 1:].set(jnp.eye(n - 1, dtype=den.dtype))
    a = a.at[-1, :].set(-den[1:][::-1])
    b = jnp.zeros((n,), dtype=den.dtype).at[-1].set(1.0)
    c = rest[::-1]
    return a, b, c, d


def ss2tf(a, b, c, d):
    """`(num, den)` of `c (zI - a)^-1 b + d` for a SISO system, both of length n + 1.

    Uses det(zI - a + b c) = det(zI - a) (1 + c (zI - a)^-1 b), so
    num = charpoly(a - b c) - charpoly(a) + d charpoly(a). In discrete time
    the arrays read as coefficients of z^0, z^-1, ..., z^-n.
    """
    den = charpoly(a)
    num = charpoly(a - jnp.outer(b, c)) - den + d * den
    return num, den
