"""The Gaussian Box-Jenkins likelihood in JAX: prediction errors, the exact likelihood, the Cramer-Rao bound, PEM.

Model (one or several inputs, delays d_i in samples):
y_k = sum_i G_i u_i(k - d_i) + xi_k, xi = C(z^-1)/D(z^-1) e, e ~ N(0, sigma2) white.
G_i is simulated exactly at the samples (continuous G_i(s) for the held
input: one matrix exponential and a scan; discrete G_i(z^-1): a scan).

- Conditional prediction errors (zero initial conditions): eps = (D/C) xi.
  sum eps_k^2 is the criterion whose stationary point RIVCBJ/RIVBJ reach.
- Exact likelihood: the ARMA noise in innovations state-space form,
  x[k+1] = Phi x[k] + K e_k, xi_k = h x[k] + e_k (Phi the companion matrix of
  D, K = c - d padded, h = e_1), started from its stationary distribution
  (P0 solves P0 = Phi P0 Phi^T + K K^T), run through the Kalman filter:
  innovations v_k with variances sigma2 F_k, and
  -log L = (N/2) log(2 pi sigma2) + (1/2) sum log F_k + sum v_k^2 / (2 sigma2 F_k).
- Fisher information of the system parameters theta: the Kalman gains do not
  depend on theta and v is affine in y - sum G_i u_i, so
  d v / d theta = -(whitening of d yhat / d theta) is the same for every
  noise realisation and I_theta = (1/sigma2) sum_k (dv_k/dtheta)(dv_k/dtheta)^T / F_k
  exactly, by forward-mode differentiation. In open loop (u independent of
  e) the theta-eta block of the expected information is zero, so the
  Cramer-Rao bound of theta is I_theta^-1.
"""

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import jax.scipy.linalg as jsl
import numpy as np
import optimistix as optx
from jax import lax

from .._checks import as_float_array, positive_float
from .._runtime import x64
from .._signal.filtering import lfilter_scan
from ._rivcore import Structure, delayed, evaluate_at
from ._tf import check_tf, tf2ss
from ._zoh import expm_taylor


def lfilter(b, a, x):
    """y = B(z^-1)/A(z^-1) x with zero initial conditions (a[0] = 1), 1-D x (`jaxsdp.lfilter`'s kernel)."""
    L = max(b.shape[0], a.shape[0])
    b = jnp.concatenate([b, jnp.zeros((L - b.shape[0],))])
    a = jnp.concatenate([a, jnp.zeros((L - a.shape[0],))])
    return lfilter_scan(x, b, a, jnp.zeros((L - 1,)))[0]


def simulate_ct(num, den, u, dt):
    """Samples of B(s)/A(s) driven by the held input u (exact, zero initial state)."""
    A, B, C, D = tf2ss(num, den)
    n = A.shape[0]
    aug = jnp.zeros((n + 1, n + 1)).at[:n, :n].set(A).at[:n, n].set(B)
    ex = expm_taylor(aug * dt)
    phi, gam = ex[:n, :n], ex[:n, n]

    def step(x, uk):
        return phi @ x + gam * uk, C @ x + D * uk

    _, y = lax.scan(step, jnp.zeros((n,)), u, unroll=4)
    return y


def model_output(theta, us_delayed, dt, st):
    """sum_i G_i u_i at the samples for the parameters theta (`Structure` layout)."""
    sl, _ = st.slices()
    out = 0.0
    for i, (a_sl, b_sl) in enumerate(sl):
        a = jnp.concatenate([jnp.ones((1,)), theta[a_sl]])
        if st.continuous:
            out = out + simulate_ct(theta[b_sl], a, us_delayed[i], dt)
        else:
            out = out + lfilter(theta[b_sl], a, us_delayed[i])
    return out


def prediction_errors(theta, eta, y, us_delayed, dt, st):
    """Conditional one-step prediction errors eps = (D/C)(y - sum_i G_i u_i), zero initial conditions."""
    xi = y - model_output(theta, us_delayed, dt, st)
    one = jnp.ones((1,))
    return lfilter(jnp.concatenate([one, eta[st.nc :]]), jnp.concatenate([one, eta[: st.nc]]), xi)


def _arma_ss(c, d):
    """Innovations form of C/D: (Phi, K), state dimension max(nc, nd, 1)."""
    r = max(c.shape[0], d.shape[0], 1)
    cp = jnp.zeros((r,)).at[: c.shape[0]].set(c)
    dp = jnp.zeros((r,)).at[: d.shape[0]].set(d)
    phi = jnp.zeros((r, r)).at[:, 0].set(-dp).at[:-1, 1:].add(jnp.eye(r - 1))
    return phi, cp - dp


def exact_innovations(xi, c, d):
    """Kalman-filter innovations v_k and relative variances F_k of the stationary ARMA noise xi = C/D e."""
    phi, K = _arma_ss(c, d)
    r = phi.shape[0]
    kron = jnp.eye(r * r) - jnp.kron(phi, phi)
    p0 = jnp.linalg.solve(kron, jnp.outer(K, K).ravel()).reshape(r, r)
    p0 = 0.5 * (p0 + p0.T)

    def step(carry, xk):
        x, P = carry
        F = P[0, 0] + 1.0
        v = xk - x[0]
        G = (phi @ P[:, 0] + K) / F
        x = phi @ x + G * v
        P = phi @ P @ phi.T + jnp.outer(K, K) - F * jnp.outer(G, G)
        return (x, 0.5 * (P + P.T)), (v, F)

    _, (v, F) = lax.scan(step, (jnp.zeros((r,)), p0), xi)
    return v, F


def bj_negloglik(theta, eta, y, us_delayed, dt, st):
    """Exact Gaussian negative log-likelihood, sigma2 concentrated out (stationary noise at k = 0)."""
    N = y.shape[0]
    xi = y - model_output(theta, us_delayed, dt, st)
    v, F = exact_innovations(xi, eta[: st.nc], eta[st.nc :])
    s2 = jnp.mean(v * v / F)
    return 0.5 * N * (jnp.log(2 * jnp.pi * s2) + 1.0) + 0.5 * jnp.sum(jnp.log(F))


class CramerRao(NamedTuple):
    r"""The Cramer-Rao bound of the system parameters $\theta$ = [a1..an, b0..bm].

    `cov`: $I_\theta^{-1}$ (by Cholesky); `se`: its square roots (the smallest
    standard deviations an unbiased estimator can have); `fisher`: $I_\theta$."""

    cov: jnp.ndarray
    se: jnp.ndarray
    fisher: jnp.ndarray


@x64
def cramer_rao(u, dt, *, num, den, c=(1.0,), d=(1.0,), sigma2, delay=0):
    r"""The Cramer-Rao bound of a Box-Jenkins model's system parameters, from the exact Gaussian likelihood.

    Model: $y_k = G u(k - delay) + C(z^{-1})/D(z^{-1}) e_k$, $e_k \sim N(0, \sigma^2)$ ($\sigma^2$ = `sigma2`).
    With `dt` (s) $G = B(s)/A(s)$ (continuous, held input, `num`/`den` in $s$);
    with `dt=None` $G = B(z^{-1})/A(z^{-1})$ (discrete). The Fisher information
    $I_\theta = (1/\sigma^2) \sum_k (d v_k/d \theta)(d v_k/d \theta)^T / F_k$ comes
    from forward-mode differentiation of the exact Kalman-filter innovations
    $v_k$ (stationary noise at the first sample), the same for every noise
    realisation; the bound is $I_\theta^{-1}$ for $\theta$ = [a1..an, b0..bm] (the
    order of `RIVResult.theta`). Open loop: the noise parameters do not
    enter $\theta$'s bound. One input; $D$ must be stable (stationary noise).

    Example:
        >>> import numpy as np
        >>> from jaxsdp.tfest import cramer_rao
        >>> u = np.repeat(np.random.default_rng(0).choice([-1.0, 1.0], 400), 5)
        >>> crb = cramer_rao(u, 0.02, num=[4.0, 20.0], den=[1.0, 3.0, 20.0], c=[1.0, 0.3], d=[1.0, -0.98],
        ...                  sigma2=0.05**2)
        >>> crb.se.shape, bool(np.all(np.asarray(crb.se) > 0))
        ((4,), True)
    """
    u = as_float_array("u", u, ndim=1)
    if dt is not None:
        dt = positive_float("dt", dt)
        num, den = check_tf(num, den, kind="continuous")
    else:
        num, den = check_tf(num, den, kind="discrete")
    c, d = monic("c", c), monic("d", d)
    if d.shape[0] > 1 and np.max(np.abs(np.roots(np.asarray(d)))) >= 1.0:
        raise ValueError(f"`d`: D(z^-1) must have its roots inside the unit circle (stationary noise); got {d}")
    if np.ptp(np.asarray(u)) == 0 or not np.all(np.isfinite(np.asarray(u))):
        raise ValueError("`u` must be finite and not constant (a constant input gives no information)")
    sigma2 = positive_float("sigma2", sigma2)
    if isinstance(delay, bool) or not isinstance(delay, (int, np.integer)) or not 0 <= delay < u.shape[0]:
        raise ValueError(f"`delay` must be a whole number of samples in 0..{u.shape[0] - 1}; got {delay!r}")
    n, m = den.shape[0] - 1, num.shape[0] - 1
    st = Structure(continuous=dt is not None, n=(n,), m=(m,), common=True, nc=c.shape[0] - 1, nd=d.shape[0] - 1)
    fisher = _fisher(jnp.concatenate([den[1:], num]), jnp.concatenate([c[1:], d[1:]]), u, dt, delay, st) / sigma2
    s = 1.0 / jnp.sqrt(jnp.diag(fisher))
    cov = s[:, None] * jsl.cho_solve(jsl.cho_factor(fisher * s[:, None] * s[None, :]), jnp.eye(n + m + 1)) * s
    cov = 0.5 * (cov + cov.T)
    return CramerRao(cov=cov, se=jnp.sqrt(jnp.diag(cov)), fisher=fisher)


@jax.jit(static_argnums=(5,))
def _fisher(theta, eta, u, dt, delay, st):
    """sum_k (dv_k/dtheta)(dv_k/dtheta)^T / F_k (sigma2 = 1), v the exact innovations."""
    ud = delayed(u[None], jnp.asarray([delay]))
    dt = 1.0 if dt is None else dt

    def whitened(th):
        v, F = exact_innovations(-model_output(th, ud, dt, st), eta[: st.nc], eta[st.nc :])
        return v / jnp.sqrt(F)

    J = jax.jacfwd(whitened)(theta)
    return J.T @ J


def monic(name, p):
    """A noise polynomial [1, p1, ...] as float64, checked: 1-D, finite, leading coefficient 1."""
    arr = np.asarray(p, dtype=float)
    if arr.ndim != 1 or arr.shape[0] < 1 or not np.all(np.isfinite(arr)):
        raise ValueError(f"`{name}` must be a finite 1-D array of coefficients [1, {name}1, ...]; got {p!r}")
    if arr[0] != 1.0:
        raise ValueError(f"`{name}` must be monic (leading coefficient 1); got {arr[0]:g}")
    return jnp.asarray(arr)


@eqx.filter_jit
def pem_refine(out, y, us, dt, delays, st, max_steps=100):
    """Minimise sum eps_k^2 over [theta, eta] by Levenberg-Marquardt (optimistix) from the IV estimate.

    Parameters are optimised in units of their IV standard errors (so the
    problem is well scaled whatever the coefficients' sizes); the result is
    evaluated as an IV estimate is (`evaluate`), its `converged` flag from
    the optimiser.
    """
    ud = delayed(us, delays)
    th0, et0 = out["theta"], out["eta"]
    p = th0.shape[0]
    se = jnp.sqrt(jnp.concatenate([jnp.diag(out["cov"]), jnp.diag(out["noise_cov"])]))
    x0 = jnp.concatenate([th0, et0])
    scale = jnp.where(jnp.isfinite(se) & (se > 0), se, 1e-6 * (jnp.abs(x0) + 1.0))

    def resid(z, _):
        x = x0 + scale * z
        return prediction_errors(x[:p], x[p:], y, ud, dt, st)

    solver = optx.LevenbergMarquardt(rtol=1e-10, atol=1e-10)
    sol = optx.least_squares(resid, solver, jnp.zeros_like(x0), max_steps=max_steps, throw=False)
    x = x0 + scale * sol.value
    ok = sol.result == optx.RESULTS.successful
    steps = sol.stats["num_steps"]
    return evaluate_at(x[:p], x[p:], y, ud, dt, st, out["iterations"] + steps, ok)
