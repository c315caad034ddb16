r"""Inverse dynamic identification model, least squares (IDIM-LS).

The inverse dynamic model is linear in the parameters,
$y = X \theta + e$ ($y$: measured force/torque, $X$: regressors built
from filtered position, velocity and acceleration). IDIM-LS is ordinary
least squares on the (parallel-decimated) samples, with the usual
standard deviations $\sigma_{\theta_i} = \hat\sigma \sqrt{[(X^T X)^{-1}]_{ii}}$,
$\hat\sigma^2 = \|y - X\hat\theta\|^2 / (N - p)$.
"""

from collections.abc import Callable, Mapping, Sequence
from typing import Literal, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from ._checks import as_float_array, check_finite, check_value
from ._filtering import _check_factor, butter_derivatives
from ._filtering import decimate as _decimate
from ._x64 import x64

# --------------------------------------------------------------------------- #
# Regressors
# --------------------------------------------------------------------------- #


class Regressors(NamedTuple):
    """A regressor matrix with named columns.

    **Fields:** `X` of shape `(N, p)`; `names`, a tuple of `p` column (and
    parameter) names.
    """

    X: Float[Array, "N p"]
    names: tuple[str, ...]


@x64
def regressors(columns: Mapping[str, ArrayLike]) -> Regressors:
    """Stack named 1-D columns (in the mapping's order) into a `Regressors`.

    Example: `regressors({"M": ddq, "Fv": dq, "Fc": jnp.sign(dq)})`.
    All columns must be 1-D with the same length `N`; a scalar is broadcast
    to a constant column (e.g. `{"offset": 1.0}`).
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


def _motion(dq, ddq):
    dq = as_float_array("dq", dq, ndim=1)
    ddq = as_float_array("ddq", ddq, ndim=1)
    if dq.shape != ddq.shape:
        raise ValueError(
            f"`dq` and `ddq` must have the same shape; got {tuple(dq.shape)} and {tuple(ddq.shape)}"
        )
    return dq, ddq


@x64
def emps_regressors(dq: ArrayLike, ddq: ArrayLike) -> Regressors:
    r"""EMPS inverse dynamic model $\tau = M\ddot q + F_v \dot q + F_c
    \operatorname{sign}(\dot q) + \text{offset}$.

    Columns `[ddq, dq, sign(dq), 1]` named `("M", "Fv", "Fc", "offset")`
    (units kg, N/(m/s), N, N for SI inputs). `sign(0) = 0` as in MATLAB.
    """
    dq, ddq = _motion(dq, ddq)
    X = jnp.stack([ddq, dq, jnp.sign(dq), jnp.ones_like(dq)], axis=1)
    return Regressors(X=X, names=("M", "Fv", "Fc", "offset"))


@x64
def emps_asym_regressors(dq: ArrayLike, ddq: ArrayLike) -> Regressors:
    r"""EMPS model with direction-dependent friction (eqs. 17-18 of the SDP paper).

    $\tau = M\ddot q + F_v^+ O^+(\dot q) + F_c^+ \operatorname{sign}(O^+(\dot q))
    + F_v^- O^-(\dot q) + F_c^- \operatorname{sign}(O^-(\dot q))$, with
    $O^\pm(v) = v (1 \pm \operatorname{sign} v)/2$ (so $O^+(v) = \max(v, 0)$,
    $O^-(v) = \min(v, 0)$). Columns named
    `("M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg")`; no offset column.
    """
    dq, ddq = _motion(dq, ddq)
    s = jnp.sign(dq)
    pos = dq * (1 + s) / 2
    neg = dq * (1 - s) / 2
    X = jnp.stack([ddq, pos, jnp.sign(pos), neg, jnp.sign(neg)], axis=1)
    return Regressors(X=X, names=("M", "Fv_pos", "Fc_pos", "Fv_neg", "Fc_neg"))


# --------------------------------------------------------------------------- #
# Least squares
# --------------------------------------------------------------------------- #


class IDIMResult(eqx.Module):
    r"""Ordinary least-squares estimate of $y = X\theta + e$.

    **Fields:**

    - `theta`: estimate $\hat\theta = \arg\min \|y - X\theta\|$, shape `(p,)`.
    - `std`: standard deviations $\hat\sigma\sqrt{[(X^TX)^{-1}]_{ii}}$.
    - `rel_std`: relative standard deviations $100\,\sigma_i/|\theta_i|$ (%).
    - `sigma`: residual standard deviation $\|e\|/\sqrt{N-p}$.
    - `cov`: covariance $\hat\sigma^2 (X^TX)^{-1}$, shape `(p, p)`.
    - `residuals`: $y - X\hat\theta$; `fit`: $X\hat\theta$.
    - `relative_error`: $100\,\|y - X\hat\theta\| / \|y\|$ (%).
    - `cond`: 2-norm condition number of $X$.
    - `names`: parameter names; `dof`: $N - p$.
    """

    theta: Float[Array, " p"]
    std: Float[Array, " p"]
    rel_std: Float[Array, " p"]
    sigma: Float[Array, ""]
    cov: Float[Array, "p p"]
    residuals: Float[Array, " N"]
    fit: Float[Array, " N"]
    relative_error: Float[Array, ""]
    cond: Float[Array, ""]
    names: tuple[str, ...] = eqx.field(static=True)
    dof: int = eqx.field(static=True)

    def table(self, *, digits: int = 4) -> str:
        """A text table in the style of the paper's Table 1:
        each parameter's value and (relative standard deviation in %)."""
        return idim_table(self, digits=digits)


def idim_table(result: IDIMResult, *, digits: int = 4) -> str:
    """Format an `IDIMResult` as text: `name  value  (rel. std %)` per line,
    then the residual standard deviation and relative error."""
    theta = np.asarray(result.theta)
    rel = np.asarray(result.rel_std)
    width = max([len("parameter")] + [len(n) for n in result.names])
    values = [f"{v:.{digits}f}" for v in theta]
    vwidth = max(len("estimate"), *(len(v) for v in values))
    lines = [f"{'parameter':<{width}}  {'estimate':>{vwidth}}  (rel. std %)"]
    for name, v, r in zip(result.names, values, rel):
        lines.append(f"{name:<{width}}  {v:>{vwidth}}  ({r:.2f} %)")
    lines.append(f"sigma = {float(result.sigma):.{digits}g}, dof = {result.dof}")
    lines.append(f"relative error 100*||y - X theta||/||y|| = {float(result.relative_error):.{digits}f} %")
    lines.append(f"cond(X) = {float(result.cond):.3g}")
    return "\n".join(lines)


def _check_names(names, p: int) -> tuple[str, ...]:
    if names is None:
        return tuple(f"theta{i + 1}" for i in range(p))
    if isinstance(names, str) or not isinstance(names, Sequence):
        raise ValueError(f"`names` must be a sequence of {p} strings; got {names!r}")
    names = tuple(names)
    if len(names) != p or not all(isinstance(n, str) for n in names):
        raise ValueError(f"`names` must be {p} strings (one per column of `X`); got {names!r}")
    return names


def _check_regression(y, X):
    y = as_float_array("y", y, ndim=1)
    X = as_float_array("X", X)
    if X.ndim != 2:
        raise ValueError(f"`X` must be 2-D (N, p); got shape {tuple(X.shape)}")
    if X.shape[0] != y.shape[0]:
        raise ValueError(
            f"`X` must have as many rows as `y` has samples; got X shape {tuple(X.shape)} "
            f"and y shape {tuple(y.shape)}"
        )
    y = check_finite("y", y)
    X = check_finite("X", X)
    return y, X


@jax.jit
def _ls(y, X):
    n, p = X.shape
    q, r = jnp.linalg.qr(X, mode="reduced")
    theta = jsl.solve_triangular(r, q.T @ y, lower=False)
    fit = X @ theta
    residuals = y - fit
    rss = residuals @ residuals
    sigma2 = rss / (n - p)
    r_inv = jsl.solve_triangular(r, jnp.eye(p, dtype=X.dtype), lower=False)
    std = jnp.sqrt(sigma2) * jnp.linalg.norm(r_inv, axis=1)
    s = jnp.linalg.svd(r, compute_uv=False)  # singular values of X
    return dict(
        theta=theta,
        std=std,
        rel_std=100 * std / jnp.abs(theta),
        sigma=jnp.sqrt(sigma2),
        cov=sigma2 * (r_inv @ r_inv.T),
        residuals=residuals,
        fit=fit,
        relative_error=100 * jnp.sqrt(rss) / jnp.linalg.norm(y),
        cond=s[0] / s[-1],
    )


@x64
def idim_ls(
    y: ArrayLike,
    X: ArrayLike | Regressors,
    *,
    names: Sequence[str] | None = None,
) -> IDIMResult:
    r"""Ordinary least squares $\hat\theta = \arg\min_\theta \|y - X\theta\|_2$.

    Solved through the thin QR factorisation $X = QR$:
    $\hat\theta = R^{-1} Q^T y$ and $(X^TX)^{-1} = R^{-1}R^{-T}$ with
    triangular solves (no normal equations, no explicit inverse of $X^TX$).

    **Arguments:**

    - `y`: measured force/torque, shape `(N,)`.
    - `X`: regressors, shape `(N, p)` with `N > p` and full column rank, or a
      `Regressors` (its names are used unless `names` is given).
    - `names`: parameter names (default `theta1, theta2, ...`).

    **Returns:** an `IDIMResult`.
    """
    if isinstance(X, Regressors):
        if names is None:
            names = X.names
        X = X.X
    y, X = _check_regression(y, X)
    n, p = X.shape
    if n <= p:
        raise ValueError(f"`X` needs more rows than columns; got shape {(n, p)}")
    names = _check_names(names, p)

    out = _ls(y, X)
    out["cond"] = check_value(
        "X", out["cond"], lambda c: ~(c < 1 / (max(n, p) * np.finfo(np.float64).eps)),
        f"is rank deficient (shape {(n, p)}); the parameters are not identifiable",
    )
    return IDIMResult(**out, names=names, dof=n - p)


# --------------------------------------------------------------------------- #
# Parallel decimation and the EMPS standard processing
# --------------------------------------------------------------------------- #


class Regression(NamedTuple):
    """Observations and regressors ready for `idim_ls(y, X, names=names)`."""

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
    Chebyshev low-pass, then every `r`-th sample), so the model
    $y = X\theta$, linear in $\theta$, still holds on the decimated samples
    while the high-frequency content of the nonlinear columns (e.g.
    `sign(dq)`) is filtered the same way as `y`. `r = 1` returns the data
    unchanged.
    """
    if isinstance(X, Regressors):
        if names is None:
            names = X.names
        X = X.X
    y, X = _check_regression(y, X)
    names = _check_names(names, X.shape[1])
    if isinstance(r, (int, np.integer)) and not isinstance(r, bool) and r == 1:
        return Regression(y=y, X=X, names=names)
    r = _check_factor(r)
    dec = lambda v: _decimate(v, r, mode=mode)  # noqa: E731
    # A loop (p is small) reuses the compiled filter of `y` for every column.
    X_dec = jnp.stack([dec(X[:, j]) for j in range(X.shape[1])], axis=1)
    return Regression(y=dec(y), X=X_dec, names=names)


def position_force(data):
    """(position, force, dt) of an `EMPSData` (`qm`) or `Measurements` (`q`), checked."""
    q = getattr(data, "qm", None)
    if q is None:
        q = getattr(data, "q", None)
    if q is None or not hasattr(data, "force") or not hasattr(data, "dt"):
        raise ValueError(
            "`data` must be an EMPSData or Measurements (with `qm`/`q`, `force` and `dt`); "
            f"got {type(data).__name__}"
        )
    q = as_float_array("data.q", q, ndim=1)
    force = as_float_array("data.force", data.force, ndim=1)
    if force.shape != q.shape:
        raise ValueError(
            f"`data.force` and the position must have the same shape; got {tuple(force.shape)} "
            f"and {tuple(q.shape)}"
        )
    return q, force, float(data.dt)


class EMPSInputs(eqx.Module):
    """EMPS signals after the benchmark's standard processing.

    **Fields** (decimated, `M = ceil((N - drop) / decimate)` samples):
    `y` force (N), `q` filtered position (m), `dq` velocity (m/s),
    `ddq` acceleration (m/s²), `dt` their sampling period (s).

    **Fields** (filtered and with the first `drop` samples removed, not
    decimated, `N - drop` samples): `y_full`, `q_full`, `dq_full`,
    `ddq_full`, `dt_full` — the inputs of `regression`.

    `decimate` and `mode` record the decimation used.
    """

    y: Float[Array, " M"]
    q: Float[Array, " M"]
    dq: Float[Array, " M"]
    ddq: Float[Array, " M"]
    dt: float
    y_full: Float[Array, " L"]
    q_full: Float[Array, " L"]
    dq_full: Float[Array, " L"]
    ddq_full: Float[Array, " L"]
    dt_full: float
    decimate: int = eqx.field(static=True)
    mode: str = eqx.field(static=True)

    def regression(
        self, builder: Callable[[Array, Array], Regressors] = emps_regressors
    ) -> Regression:
        """Build regressors with `builder(dq, ddq)` on the undecimated
        signals, then parallel-decimate them with the force.

        This is the published IDIM-LS procedure: `idim_ls(*reg[:2],
        names=reg.names)` with `reg = inputs.regression()` (or
        `emps_asym_regressors`).
        """
        regs = builder(self.dq_full, self.ddq_full)
        if not isinstance(regs, Regressors):
            raise ValueError(f"`builder` must return a Regressors; got {type(regs).__name__}")
        return parallel_decimate(self.y_full, regs, self.decimate, mode=self.mode)


@x64
def emps_preprocess(
    data,
    *,
    cutoff_hz: float = 100.0,
    order: int = 4,
    drop: int = 49,
    decimate: int = 10,
    mode: Literal["matlab", "scipy", "octave"] = "matlab",
) -> EMPSInputs:
    """The EMPS benchmark's standard IDIM processing.

    1. Zero-phase Butterworth (`order`, `cutoff_hz`, MATLAB `filtfilt`
       padding) on the whole position record, then central differences for
       the velocity and again for the acceleration (`butter_derivatives`).
    2. Drop the first `drop` samples of position, velocity, acceleration and
       force.
    3. Decimate each signal by `decimate` (`decimate(., r, mode=mode)`); use
       `EMPSInputs.regression` for the parallel decimation of regressors.

    With the defaults (100 Hz, order 4, drop 49, factor 10, MATLAB mode) the
    IDIM-LS estimates reproduce the published reference results
    (M = 95.1089, Fv = 203.5034, Fc = 20.3935, offset = -3.1648, relative
    error 4.083 %). `mode="octave"` (same as `"scipy"`: keep the first sample
    of each block) reproduces the Octave-generated reference inputs.

    **Arguments:**

    - `data`: an `EMPSData` (uses `qm`, `force`, `dt`) or a `Measurements`
      (uses `q`, `force`, `dt`).
    - `cutoff_hz`, `order`: Butterworth low-pass.
    - `drop`: number of initial samples discarded (>= 0).
    - `decimate`: integer factor >= 1 (1: no decimation).
    - `mode`: decimation phase convention, see `decimate`.
    """
    q, force, _ = position_force(data)
    if isinstance(drop, bool) or not isinstance(drop, (int, np.integer)) or drop < 0:
        raise ValueError(f"`drop` must be a non-negative integer; got {drop!r}")
    if drop >= q.shape[0]:
        raise ValueError(f"`drop` = {drop} must be smaller than the number of samples {q.shape[0]}")
    if isinstance(decimate, bool) or not isinstance(decimate, (int, np.integer)) or decimate < 1:
        raise ValueError(f"`decimate` must be an integer >= 1; got {decimate!r}")
    if mode not in ("matlab", "scipy", "octave"):
        raise ValueError(f"`mode` must be one of ('matlab', 'scipy', 'octave'); got {mode!r}")
    force = check_finite("data.force", force)
    dt = float(data.dt)
    deriv = butter_derivatives(q, dt, cutoff_hz=cutoff_hz, order=order, padding="matlab")
    full = [v[drop:] for v in (force, deriv.q, deriv.dq, deriv.ddq)]
    if decimate == 1:
        dec = full
    else:
        dec = [_decimate(v, int(decimate), mode=mode) for v in full]
    return EMPSInputs(
        y=dec[0],
        q=dec[1],
        dq=dec[2],
        ddq=dec[3],
        dt=dt * int(decimate),
        y_full=full[0],
        q_full=full[1],
        dq_full=full[2],
        ddq_full=full[3],
        dt_full=dt,
        decimate=int(decimate),
        mode=mode,
    )
