r"""Friction laws beyond viscous + Coulomb, estimated jointly with the linear parameters (issue 45, item 4).

The SDP curve of a joint's friction, $d(\dot q)$, shows its shape; these laws put a parametric form on it:

- `ViscousCoulomb`: $f(v) = F_v v + F_c sign(v)$ (the papers' eq. 20);
- `AsymmetricCoulomb`: $f(v) = F_{v\pm} v + F_c sign(v)$, the viscous coefficient per direction (with an
  offset, eq. 17: each direction its own Coulomb level);
- `Stribeck`: $f(v) = sign(v) (F_c + (F_s - F_c) e^{-(v / v_s)^2}) + F_v v$, the friction falling from
  the static level $F_s$ to the Coulomb one $F_c$ over the Stribeck velocity $v_s$;
- `SmoothCoulomb`: $f(v) = F_c \tanh(v / v_\epsilon) + F_v v$, Coulomb friction rounded over $v_\epsilon$ (a
  velocity estimate's noise, a compliant contact).

`fit_friction(y, X, v, law)` estimates $y = X\theta + f(v; p) + e$ by nonlinear least squares (optimistix's
Levenberg-Marquardt; the scale parameters $v_s$, $v_\epsilon$ by their logarithms, so positive), started from
the least squares of the linear laws; standard errors $\sigma^2 (J^T J)^{-1}$ from the Jacobian at the
minimum (QR, triangular solves). `select_friction` fits every candidate and chooses by the Bayesian
information criterion on the torque rows, $BIC = N \log(RSS / N) + k \log N$: a richer law is chosen only when
it lowers the residual by more than its parameters cost ($\log N$ each), the criterion consistent for the
true law among nested ones. `cross_validate_friction` gives the held-out relative error in blocks of time.
Velocities in m/s or rad/s, forces in N or N m.
"""

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array, Float

from .._linalg import qr_r, solve_upper
from .._runtime import x64

__all__ = [
    "AsymmetricCoulomb",
    "FrictionFit",
    "FrictionLaw",
    "SmoothCoulomb",
    "Stribeck",
    "ViscousCoulomb",
    "cross_validate_friction",
    "fit_friction",
    "select_friction",
]


class FrictionLaw(eqx.Module):
    """A friction law $f(v; p)$ (base class): `names` its parameters, `law(v, p)` the force (N or N m at m/s or
    rad/s), `linear` whether $f$ is linear in $p$. Subclasses: `ViscousCoulomb`, `AsymmetricCoulomb`,
    `SmoothCoulomb`, `Stribeck`."""

    names: tuple = ()
    linear: bool = True

    @x64
    def __call__(self, v, p):
        """The friction force (N or N m) at velocities `v` for the parameters `p` (scale parameters by their
        logarithms, as `FrictionFit.raw`)."""
        return self._f(jnp.asarray(v, dtype=jnp.float64), jnp.asarray(p, dtype=jnp.float64))

    def _f(self, v, p):
        raise NotImplementedError

    def _values(self, p) -> jax.Array:
        """The parameters in SI units (scale parameters from their logarithms)."""
        return p

    def _start(self, v, r) -> np.ndarray:
        """The starting parameters: the least squares of the viscous + Coulomb law on (v, r)."""
        A = np.c_[v, np.sign(v)]
        Fv, Fc = np.linalg.lstsq(A, r, rcond=None)[0]
        return np.array([Fv, Fc])


class ViscousCoulomb(FrictionLaw):
    """$f(v) = F_v v + F_c sign(v)$ (N or N m; $v$ in m/s or rad/s): viscous and Coulomb friction, the same
    both ways (the papers' eq. 20); parameters `("Fv", "Fc")`."""

    names: tuple = ("Fv", "Fc")

    def _f(self, v, p):
        return p[0] * v + p[1] * jnp.sign(v)


class AsymmetricCoulomb(FrictionLaw):
    r"""$f(v) = F_{v+} v$ for $v > 0$, $F_{v-} v$ for $v < 0$, plus $F_c sign(v)$: each direction its own viscous
    coefficient. With the offset $o$ of the linear regressors (a column of ones in `X`, as the EMPS and robot models
    have) this is the paper's eq. 17, each direction its own Coulomb level too: $F_{c+} = F_c + o$,
    $F_{c-} = F_c - o$ (the three constants of eq. 17 with an offset are one too many)."""

    names: tuple = ("Fv+", "Fv-", "Fc")

    def _f(self, v, p):
        return p[0] * jnp.maximum(v, 0.0) + p[1] * jnp.minimum(v, 0.0) + p[2] * jnp.sign(v)

    def _start(self, v, r):
        Fv, Fc = super()._start(v, r)
        return np.array([Fv, Fv, Fc])


class Stribeck(FrictionLaw):
    """$f(v) = sign(v) (F_c + (F_s - F_c) e^{-(v / v_s)^2}) + F_v v$: static friction $F_s$ falling to the Coulomb
    level $F_c$ over the Stribeck velocity $v_s$ (m/s or rad/s; estimated as $\\log v_s$)."""

    names: tuple = ("Fv", "Fc", "Fs", "vs")
    linear: bool = False

    def _f(self, v, p):
        vs = jnp.exp(p[3])
        return jnp.sign(v) * (p[1] + (p[2] - p[1]) * jnp.exp(-((v / vs) ** 2))) + p[0] * v

    def _values(self, p):
        return p.at[3].set(jnp.exp(p[3]))

    def _start(self, v, r):
        Fv, Fc = super()._start(v, r)
        return np.array([Fv, Fc, 1.2 * Fc, math.log(0.05 * float(np.max(np.abs(v))) + 1e-12)])


class SmoothCoulomb(FrictionLaw):
    """$f(v) = F_c \\tanh(v / v_\\epsilon) + F_v v$: Coulomb friction rounded over $v_\\epsilon$ (m/s or rad/s;
    estimated as $\\log v_\\epsilon$)."""

    names: tuple = ("Fv", "Fc", "ve")
    linear: bool = False

    def _f(self, v, p):
        return p[1] * jnp.tanh(v / jnp.exp(p[2])) + p[0] * v

    def _values(self, p):
        return p.at[2].set(jnp.exp(p[2]))

    def _start(self, v, r):
        Fv, Fc = super()._start(v, r)
        return np.array([Fv, Fc, math.log(0.01 * float(np.max(np.abs(v))) + 1e-12)])


#: The candidates of `select_friction`, simplest first.
LAWS = (ViscousCoulomb(), AsymmetricCoulomb(), SmoothCoulomb(), Stribeck())


class FrictionFit(eqx.Module):
    r"""$y = X\theta + f(v; p) + e$ fitted (`fit_friction`).

    **Fields:** `theta` the linear parameters (in `names`' first entries), `p` the law's parameters (SI units),
    `std` (all, in `names` order; the scale parameters' by the delta method), `raw` the law's parameters as
    `law(v, raw)` takes them (the scale parameters' logarithms), `rss` the residual sum of squares,
    `sigma` $\sqrt{RSS / (N - k)}$, `relative_error` $100\|e\|/\|y\|$ (%), `bic` $N\log(RSS/N) + k\log N$, `aic`
    $N\log(RSS/N) + 2k$, `n` rows, `k` parameters, `names`, `law` (its class name), `converged`.
    """

    theta: Float[Array, " m"]
    p: Float[Array, " q"]
    std: Float[Array, " k"]
    raw: Float[Array, " q"]
    rss: Float[Array, ""]
    sigma: Float[Array, ""]
    relative_error: Float[Array, ""]
    bic: Float[Array, ""]
    aic: Float[Array, ""]
    converged: jax.Array
    n: int = eqx.field(static=True)
    k: int = eqx.field(static=True)
    names: tuple = eqx.field(static=True)
    law: str = eqx.field(static=True)

    @x64
    def as_dict(self) -> dict:
        """{name: value} of every parameter."""
        return dict(zip(self.names, np.r_[np.asarray(self.theta), np.asarray(self.p)].tolist()))


def _checked(y, X, v):
    y, X, v = (jnp.asarray(a, dtype=jnp.float64) for a in (y, X, v))
    X = X[:, None] if X.ndim == 1 else X
    if y.ndim != 1 or v.shape != y.shape or X.shape[0] != y.shape[0]:
        raise ValueError(f"`y` (N,), `X` (N, m) and `v` (N,) must agree; got {y.shape}, {X.shape}, {v.shape}")
    return y, X, v


@eqx.filter_jit
def _fit(y, X, v, law: FrictionLaw, start, max_steps: int):
    m = X.shape[1]

    def residual(z, _):
        return y - X @ z[:m] - law._f(v, z[m:])

    sol = optx.least_squares(
        residual, optx.LevenbergMarquardt(rtol=1e-10, atol=1e-12), start, max_steps=max_steps, throw=False
    )
    z = sol.value
    e = residual(z, None)
    n, k = y.shape[0], z.shape[0]
    J = jax.jacfwd(residual)(z, None)
    R = qr_r(J)
    rss = e @ e
    sigma2 = rss / (n - k)
    Ri = solve_upper(R, jnp.eye(k))
    var = sigma2 * jnp.sum(Ri**2, axis=1)  # diag(R^-1 R^-T)
    dvalues = jnp.diag(jax.jacfwd(lambda z: jnp.concatenate([z[:m], law._values(z[m:])]))(z))  # exp(u) for logs
    return dict(
        theta=z[:m],
        p=law._values(z[m:]),
        std=jnp.sqrt(var) * jnp.abs(dvalues),
        raw=z[m:],
        rss=rss,
        sigma=jnp.sqrt(sigma2),
        relative_error=100 * jnp.sqrt(rss) / jnp.linalg.norm(y),
        bic=n * jnp.log(rss / n) + k * math.log(n),
        aic=n * jnp.log(rss / n) + 2 * k,
        converged=sol.result == optx.RESULTS.successful,
    )


@x64
def fit_friction(y, X, v, law: FrictionLaw = ViscousCoulomb(), *, names=None, max_steps: int = 500) -> FrictionFit:
    r"""$y = X\theta + f(v; p) + e$ by nonlinear least squares (Levenberg-Marquardt, optimistix).

    `y` (N,) forces or torques; `X` (N, m) the linear regressors (inertia, gravity, an offset: a column of ones);
    `v` (N,) the velocities the friction depends on; `law` a `FrictionLaw`; `names` the m linear parameters'
    names (default `theta1..`). Started from the linear least squares with viscous + Coulomb friction.

    **Returns:** a `FrictionFit`.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import Stribeck, fit_friction
        >>> v = np.linspace(-1, 1, 401)
        >>> y = 0.5 + np.sign(v) * (2.0 + 1.0 * np.exp(-(v / 0.1) ** 2)) + 3.0 * v
        >>> fit = fit_friction(y, np.ones((401, 1)), v, Stribeck(), names=("offset",))
        >>> {k: round(x, 3) for k, x in fit.as_dict().items()}
        {'offset': 0.5, 'Fv': 3.0, 'Fc': 2.0, 'Fs': 3.0, 'vs': 0.1}
    """
    if not isinstance(law, FrictionLaw):
        raise ValueError(f"`law` must be a FrictionLaw (ViscousCoulomb(), Stribeck(), ...); got {law!r}")
    y, X, v = _checked(y, X, v)
    m = X.shape[1]
    names = tuple(f"theta{i + 1}" for i in range(m)) if names is None else tuple(names)
    if len(names) != m:
        raise ValueError(f"`names` must have {m} entries (one per column of `X`); got {len(names)}")
    yn, Xn, vn = np.asarray(y), np.asarray(X), np.asarray(v)
    A = np.c_[Xn, vn, np.sign(vn)]
    ls = np.linalg.lstsq(A, yn, rcond=None)[0]
    start = np.r_[ls[:m], law._start(vn, yn - Xn @ ls[:m])]
    out = _fit(y, X, v, law, jnp.asarray(start), max_steps)
    return FrictionFit(**out, n=int(y.shape[0]), k=len(start), names=names + law.names, law=type(law).__name__)


@x64
def select_friction(y, X, v, *, laws=LAWS, names=None) -> tuple[str, tuple]:
    """Every law of `laws` fitted (`fit_friction`), and the one of least BIC: (its class name, the `FrictionFit`s in
    the order of `laws`, each naming its law in `.law`).

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import select_friction
        >>> v = np.sin(np.linspace(0, 20, 2000))
        >>> y = 2.0 * np.sign(v) + 3.0 * v + 0.05 * np.random.default_rng(0).normal(size=2000)
        >>> select_friction(y, np.ones((2000, 1)), v)[0]
        'ViscousCoulomb'
    """
    fits = tuple(fit_friction(y, X, v, law, names=names) for law in laws)
    if not fits:
        raise ValueError("`laws` must hold at least one FrictionLaw")
    return min(fits, key=lambda f: float(f.bic)).law, fits


@x64
def cross_validate_friction(y, X, v, law: FrictionLaw, *, folds: int = 2) -> float:
    """The held-out relative error (%) of `law` in `folds` blocks of time: each block predicted by the fit on the
    others, $100 \\|y - \\hat y\\| / \\|y\\|$ over all blocks.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants import ViscousCoulomb, cross_validate_friction
        >>> v = np.sin(np.linspace(0, 20, 2000))
        >>> y = 2.0 * np.sign(v) + 3.0 * v + 0.05 * np.random.default_rng(0).normal(size=2000)
        >>> round(cross_validate_friction(y, np.ones((2000, 1)), v, ViscousCoulomb()), 1)
        1.3
    """
    if isinstance(folds, bool) or not isinstance(folds, int) or folds < 2:
        raise ValueError(f"`folds` must be an int >= 2; got {folds!r}")
    y, X, v = (np.asarray(a, dtype=float) for a in _checked(y, X, v))
    edges = np.linspace(0, y.shape[0], folds + 1).astype(int)
    err = np.zeros_like(y)
    for a, b in zip(edges[:-1], edges[1:]):
        keep = np.r_[0:a, b : y.shape[0]]
        fit = fit_friction(y[keep], X[keep], v[keep], law)
        err[a:b] = y[a:b] - X[a:b] @ np.asarray(fit.theta) - np.asarray(law._f(jnp.asarray(v[a:b]), fit.raw))
    return float(100 * np.linalg.norm(err) / np.linalg.norm(y))
