"""Random-walk family models for time-variable and state-dependent parameters.

Each parameter theta_k is the first element of a small state block that
evolves as

    s_k = F s_{k-1} + eta_k,   eta_k ~ N(0, sigma^2 * Q),

with the observation noise variance sigma^2 concentrated out, so Q is in units
of the noise variance ratio (NVR = parameter-noise variance / sigma^2).

| model | state | F | Q |
|---|---|---|---|
| `RW()` | [theta] | [1] | [NVR] |
| `IRW()` | [theta, slope] | [[1,1],[0,1]] | diag(0, NVR) |
| `SRW(alpha)` | [theta, slope] | [[alpha,1],[0,1]] | diag(0, NVR) |
| `LLT()` | [theta, slope] | [[1,1],[0,1]] | diag(NVR_level, NVR_slope) |
| `Constant()` | [theta] | [1] | [0] |

`RW` with NVR = 0 is also a constant parameter (recursive least squares).
"""

from collections.abc import Sequence

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._runtime import x64


class ParameterModel(eqx.Module):
    r"""Base class of the random-walk-family parameter models (`RW`, `IRW`, `SRW`, `LLT`, `Constant`).

    A model describes how one parameter $\theta_k$ of `jaxsdp.dlr` (or one SDP
    $c_j$ of `jaxsdp.sdp`) evolves: $\theta_k$ is the first element of a small
    state block $s_k = F s_{k-1} + \eta_k$ with $\eta_k \sim N(0, \sigma^2 Q)$, $Q$ in
    units of the noise variance ratio NVR (dimensionless; $\sigma^2$ is the
    observation noise variance). Subclasses define `dim` (the block size),
    `n_nvr` (how many NVRs it takes), `transition()` (F) and `noise(nvr)` (Q).
    Models are given to the estimators as instances or by name ("RW", ...).

    Example:
        >>> import jaxsdp
        >>> m = jaxsdp.IRW()
        >>> m.dim, m.n_nvr, m.transition().tolist()
        (2, 1, [[1.0, 1.0], [0.0, 1.0]])
    """

    @property
    @x64
    def dim(self) -> int:
        raise NotImplementedError

    @property
    @x64
    def n_nvr(self) -> int:
        """Number of NVRs this block takes (0 for `Constant`)."""
        return 1

    @x64
    def transition(self):
        raise NotImplementedError

    @x64
    def noise(self, nvr):
        raise NotImplementedError

    @property
    @x64
    def name(self) -> str:
        return type(self).__name__


class RW(ParameterModel):
    r"""Random walk: $\theta_k = \theta_{k-1} + \eta_k$, $var(\eta_k) = NVR \cdot \sigma^2$.

    One state $[\theta]$, $F = [1]$, $Q = [NVR]$. The default model of `jaxsdp.dlr`
    and `jaxsdp.sdp`: the parameter may step by about $\sqrt{NVR} \sigma$ per
    sample (in the units of $\theta$).

    Example:
        >>> import jax.numpy as jnp, jaxsdp
        >>> jaxsdp.RW().noise(jnp.array([1e-3])).tolist()
        [[0.001]]
    """

    @property
    @x64
    def dim(self) -> int:
        return 1

    @x64
    def transition(self):
        return jnp.ones((1, 1))

    @x64
    def noise(self, nvr):
        return jnp.reshape(nvr[0], (1, 1))


class Constant(ParameterModel):
    r"""Constant parameter: $\theta_k = \theta_{k-1}$ (a random walk with NVR = 0).

    One state, $F = [1]$, $Q = [0]$, no NVR: `jaxsdp.dlr` then computes the
    recursive least-squares estimate (with the diffuse prior P0).

    Example:
        >>> import jaxsdp
        >>> jaxsdp.Constant().n_nvr
        0
    """

    @property
    @x64
    def dim(self) -> int:
        return 1

    @property
    @x64
    def n_nvr(self) -> int:
        return 0

    @x64
    def transition(self):
        return jnp.ones((1, 1))

    @x64
    def noise(self, nvr):
        return jnp.zeros((1, 1))


class IRW(ParameterModel):
    r"""Integrated random walk: $\theta_k = \theta_{k-1} + d_{k-1}$, $d_k = d_{k-1} + \eta_k$.

    State $[\theta, d]$ (slope $d$), $F = [[1, 1], [0, 1]]$, $Q = diag(0, NVR)$: the slope
    is a random walk, so $\theta$ varies smoothly (its smoother is a cubic-spline-
    like fit). A small NVR (1e-6 .. 1e-3) suits slowly varying parameters.

    Example:
        >>> import jax.numpy as jnp, jaxsdp
        >>> jaxsdp.IRW().noise(jnp.array([1e-4])).tolist()
        [[0.0, 0.0], [0.0, 0.0001]]
    """

    @property
    @x64
    def dim(self) -> int:
        return 2

    @x64
    def transition(self):
        return jnp.array([[1.0, 1.0], [0.0, 1.0]])

    @x64
    def noise(self, nvr):
        return jnp.zeros((2, 2)).at[1, 1].set(nvr[0])


class SRW(ParameterModel):
    r"""Smoothed random walk: $\theta_k = \alpha \theta_{k-1} + d_{k-1}$, $d_k = d_{k-1} + \eta_k$.

    State $[\theta, d]$ (slope $d$), $F = [[\alpha, 1], [0, 1]]$ with $0 < \alpha \le 1$
    (default 0.95), $Q = diag(0, NVR)$. $\alpha = 1$ is the `IRW`; $\alpha < 1$ lets
    $\theta$ forget its past, between an RW and an IRW.

    Example:
        >>> import jaxsdp
        >>> jaxsdp.SRW(alpha=0.8).transition().tolist()
        [[0.8, 1.0], [0.0, 1.0]]
    """

    alpha: float = 0.95

    def __check_init__(self):
        a = self.alpha
        if isinstance(a, (int, float, np.floating, np.integer)) and not (0.0 < float(a) <= 1.0):
            raise ValueError(f"SRW `alpha` must lie in (0, 1]; got {a}")

    @property
    @x64
    def dim(self) -> int:
        return 2

    @x64
    def transition(self):
        return jnp.array([[1.0, 1.0], [0.0, 1.0]]).at[0, 0].set(self.alpha)

    @x64
    def noise(self, nvr):
        return jnp.zeros((2, 2)).at[1, 1].set(nvr[0])


class LLT(ParameterModel):
    r"""Local linear trend: $\theta_k = \theta_{k-1} + d_{k-1} + \eta_{1,k}$, $d_k = d_{k-1} + \eta_{2,k}$.

    State $[\theta, d]$ (slope $d$), $F = [[1, 1], [0, 1]]$, $Q = diag(NVR_{level}, NVR_{slope})$:
    two NVRs, given (or estimated) in that order.

    Example:
        >>> import jax.numpy as jnp, jaxsdp
        >>> m = jaxsdp.LLT()
        >>> m.n_nvr, m.noise(jnp.array([1e-2, 1e-4])).tolist()
        (2, [[0.01, 0.0], [0.0, 0.0001]])
    """

    @property
    @x64
    def dim(self) -> int:
        return 2

    @property
    @x64
    def n_nvr(self) -> int:
        return 2

    @x64
    def transition(self):
        return jnp.array([[1.0, 1.0], [0.0, 1.0]])

    @x64
    def noise(self, nvr):
        return jnp.diag(jnp.stack([nvr[0], nvr[1]]))


_BY_NAME = {"RW": RW, "IRW": IRW, "SRW": SRW, "LLT": LLT, "CONST": Constant, "CONSTANT": Constant}


def as_model(spec) -> ParameterModel:
    """A `ParameterModel` from an instance or a name ("RW", "IRW", "SRW", "LLT", "CONST")."""
    if isinstance(spec, ParameterModel):
        return spec
    if isinstance(spec, str) and spec.upper() in _BY_NAME:
        return _BY_NAME[spec.upper()]()
    raise ValueError(f"`model` entries must be a ParameterModel or one of {sorted(_BY_NAME)}; got {spec!r}")


def as_models(model, p: int) -> tuple[ParameterModel, ...]:
    """One model per regressor: a single spec is repeated, a sequence must have length p."""
    if isinstance(model, (str, ParameterModel)):
        return (as_model(model),) * p
    if isinstance(model, Sequence):
        if len(model) != p:
            raise ValueError(f"`model` has {len(model)} entries but there are {p} regressors (columns of `z`)")
        return tuple(as_model(m) for m in model)
    raise ValueError(f"`model` must be a name, a ParameterModel or a sequence of them; got {model!r}")


class StateSpace(eqx.Module):
    """Block-diagonal system assembled from parameter models.

    `F`, `Q`: (n, n); `S`: (p, n) selection so that the observation row is
    h_k = z_k @ S (z_ik on the first state of block i).
    """

    F: jnp.ndarray
    Q: jnp.ndarray
    S: jnp.ndarray


def n_hyper(models) -> int:
    return sum(m.n_nvr for m in models)


def state_dim(models) -> int:
    return sum(m.dim for m in models)


def first_state_index(models) -> np.ndarray:
    return np.cumsum([0] + [m.dim for m in models])[:-1]


def assemble(models, nvr) -> StateSpace:
    """Assemble F, Q, S for `models` with the flat NVR vector `nvr` (length `n_hyper`)."""
    n = state_dim(models)
    F = jnp.zeros((n, n))
    Q = jnp.zeros((n, n))
    S = np.zeros((len(models), n))
    i = j = 0
    for b, m in enumerate(models):
        d = m.dim
        F = F.at[i : i + d, i : i + d].set(m.transition())
        Q = Q.at[i : i + d, i : i + d].set(m.noise(nvr[j : j + m.n_nvr]))
        S[b, i] = 1.0
        i += d
        j += m.n_nvr
    return StateSpace(F=F, Q=Q, S=jnp.asarray(S))
