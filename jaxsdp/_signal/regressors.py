"""Named regressor columns and their parallel decimation.

A linear-in-the-parameters model y = X theta + e is decimated *in
parallel*: the output y and every column of X go through the same
low-pass filter and down-sampling (`decimate`), so the model still holds on
the decimated samples while the high-frequency content of nonlinear columns
(e.g. sign(dq)) is filtered like y.
"""

from collections.abc import Mapping, Sequence
from typing import Literal, NamedTuple

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._checks import as_float_array, check_finite
from .._runtime import x64
from .filtering import decimate_each


class Regressors(NamedTuple):
    r"""A regressor matrix with named columns, for the model $y = X \theta + e$.

    **Fields:** `X` of shape `(N, p)` (column j in the units of y divided by
    those of parameter j); `names`, a tuple of `p` column (and parameter)
    names. Made by `regressors` or an identification model such as
    `jaxsdp.plants.emps_regressors`.
    """

    X: Float[Array, "N p"]
    names: tuple[str, ...]


@x64
def regressors(columns: Mapping[str, ArrayLike]) -> Regressors:
    r"""Stack named 1-D columns (in the mapping's order) into a `Regressors`.

    Builds $X = [x_1, ..., x_p]$ of the linear model $y = X \theta + e$, column $j$
    named after parameter $j$ (e.g. `{"M": ddq, "Fv": dq, "Fc": sign(dq)}` for
    $force = M \ddot q + F_v \dot q + F_c sign(\dot q)$). All columns must be 1-D with the
    same length `N`; a scalar is broadcast to a constant column (e.g.
    `{"offset": 1.0}`).

    **Returns:** a `Regressors` with `X` of shape `(N, p)` and the names.

    Example:
        >>> import numpy as np
        >>> from jaxsdp import regressors
        >>> dq = np.array([-0.1, 0.0, 0.2])  # m/s
        >>> reg = regressors({"Fv": dq, "Fc": np.sign(dq), "offset": 1.0})
        >>> reg.names, reg.X.shape
        (('Fv', 'Fc', 'offset'), (3, 3))
        >>> np.asarray(reg.X[0]).tolist()
        [-0.1, -1.0, 1.0]
    """
    if not isinstance(columns, Mapping) or len(columns) == 0:
        raise ValueError("`columns` must be a non-empty mapping of name -> 1-D array")
    arrays = {}
    for name, col in columns.items():
        if not isinstance(name, str):
            raise ValueError(f"`columns`: names must be strings; got {name!r}")
        arr = as_float_array(f"columns[{name!r}]", col)
        if arr.ndim not in (0, 1):
            raise ValueError(f"`columns[{name!r}]` must be 1-D; got shape {tuple(arr.shape)}")
        arrays[name] = arr
    lengths = {k: v.shape[0] for k, v in arrays.items() if v.ndim == 1}
    if not lengths:
        raise ValueError("`columns`: at least one column must be a 1-D array (not all scalars)")
    if len(set(lengths.values())) != 1:
        desc = ", ".join(f"{k!r}: {n}" for k, n in lengths.items())
        raise ValueError(f"`columns` must all have the same length; got {desc}")
    n = next(iter(lengths.values()))
    X = jnp.stack([jnp.broadcast_to(v, (n,)) for v in arrays.values()], axis=1)
    return Regressors(X=X, names=tuple(arrays))


def check_names(names, p: int) -> tuple[str, ...]:
    if names is None:
        return tuple(f"theta{i + 1}" for i in range(p))
    if isinstance(names, str) or not isinstance(names, Sequence):
        raise ValueError(f"`names` must be a sequence of {p} strings; got {names!r}")
    names = tuple(names)
    if len(names) != p or not all(isinstance(n, str) for n in names):
        raise ValueError(f"`names` must be {p} strings (one per column of `X`); got {names!r}")
    return names


def check_regression(y, X):
    y = as_float_array("y", y, ndim=1)
    X = as_float_array("X", X)
    if X.ndim != 2:
        raise ValueError(f"`X` must be 2-D (N, p); got shape {tuple(X.shape)}")
    if X.shape[0] != y.shape[0]:
        raise ValueError(
            f"`X` must have as many rows as `y` has samples; got X shape {tuple(X.shape)} and y shape {tuple(y.shape)}"
        )
    y = check_finite("y", y)
    X = check_finite("X", X)
    return y, X


class Regression(NamedTuple):
    """Observations and regressors ready for `idim_ls(y, X, names=names)`.

    **Fields:** `y` the (decimated) output, shape `(M,)` (e.g. force, N);
    `X` the regressors, shape `(M, p)`, decimated like `y`; `names` the `p`
    parameter names. Made by `parallel_decimate` and
    `Preprocessed.regression`.
    """

    y: Float[Array, " M"]
    X: Float[Array, "M p"]
    names: tuple[str, ...]


@x64
def parallel_decimate(
    y: ArrayLike,
    X: ArrayLike | Regressors,
    r: int,
    *,
    mode: Literal["matlab", "scipy", "octave"] = "matlab",
    names: Sequence[str] | None = None,
) -> Regression:
    r"""Parallel decimation: decimate `y` and each column of `X` separately.

    Each signal goes through `decimate(., r, mode=mode)` (zero-phase
    Chebyshev low-pass, then every `r`-th sample). The filter is linear, so
    the model $y = X \theta$, linear in $\theta$, still holds on the decimated
    samples, while the high-frequency content of the nonlinear columns (e.g.
    `sign(dq)`) is filtered the same way as `y`. `r = 1` returns the data
    unchanged. Units are those of the inputs.

    **Arguments:** `y` output, shape `(N,)`; `X` regressors `(N, p)` or a
    `Regressors` (whose names are used unless `names` is given); `r` integer
    factor `>= 1`; `mode` which samples are kept (see `decimate`); `names`
    parameter names (default `theta1, theta2, ...`).

    **Returns:** a `Regression` with `ceil(N / r)` samples.

    Example:
        >>> import numpy as np
        >>> from jaxsdp import parallel_decimate
        >>> t = np.arange(1000) * 1e-3
        >>> X = np.c_[np.sin(2 * np.pi * t), np.sign(np.sin(2 * np.pi * t)), np.ones(1000)]
        >>> theta = np.array([2.0, 0.5, -1.0])
        >>> reg = parallel_decimate(X @ theta, X, 10, names=("a", "b", "c"))
        >>> reg.y.shape, reg.X.shape
        ((100,), (100, 3))
        >>> bool(np.allclose(reg.y, reg.X @ theta))  # the model still holds
        True
    """
    if isinstance(X, Regressors):
        if names is None:
            names = X.names
        X = X.X
    y, X = check_regression(y, X)
    names = check_names(names, X.shape[1])
    if isinstance(r, (int, np.integer)) and not isinstance(r, bool) and r == 1:
        return Regression(y=y, X=X, names=names)
    # one compiled filter, set up once, for `y` and every column (p is small): `decimate` of each, bit for bit
    both = decimate_each(jnp.concatenate([y[:, None], X], axis=1), r, mode=mode)
    return Regression(y=both[:, 0], X=both[:, 1:], names=names)
