"""The refined instrumental variable family: RIVCBJ, RIVBJ and SRIV (Young; Young, Garnier and Gilson).

Public entry points over `jaxsdp.tfest._rivcore` (the iteration), with the
input checks, the result container and the optional prediction-error
refinement (`jaxsdp.tfest._bj`).
"""

import warnings

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._checks import as_float_array, is_concrete, positive_float
from .._runtime import x64
from ._rivcore import UNSTABLE, Structure, riv_core
from ._solver import check_solver
from ._srivc import SAMPLES_PER_PARAMETER, check_data_values, int_option, lam_starts, status_reason
from ._tf import MAX_ORDER

#: `RIVResult.status` codes (index) and their reasons (`RIVResult.reason`).
RIV_REASONS = (
    "converged",
    "iteration limit reached before the relative change of theta fell below tol",
    "unstable: an estimated A has roots outside the stability region: either the model structure (orders, delay) "
    "does not fit these data, or the system is open-loop unstable, which the refined IV estimators, output-error "
    "(Box-Jenkins) methods, cannot fit",
    "not finite: the iteration produced NaN or inf: the model structure (orders, delay) does not fit these data, "
    "or the data are degenerate or not exciting",
)
#: Largest noise model orders nc, nd.
MAX_NOISE_ORDER = 10


class RIVResult(eqx.Module):
    r"""Result of `rivcbj`, `rivbj` and `sriv`: the system, the noise model, their uncertainty, the fit.

    Model: $y_k = \sum_i G_i u_i(k - delay_i) + \xi_k$, $\xi_k = C(z^{-1})/D(z^{-1}) e_k$.

    - `num`, `den`: $G$'s polynomials. Continuous: $B(s)$, $A(s)$ highest power of
      $s$ first ($A$ monic; units of $G$: output units per input unit, $s$ in 1/s);
      discrete: $B(z^{-1})$, $A(z^{-1})$ as coefficients of $z^0, z^{-1}, ...$ (the delay
      $z^{-delay}$ is not included: $G = z^{-delay} B/A$). One input: arrays; several:
      tuples of arrays per input (`den` a single array for a common
      denominator).
    - `c`, `d`: the noise model's $C(z^{-1})$ = [1, c1, ...] and $D(z^{-1})$ = [1, d1, ...]
      (both [1.0] for white noise).
    - `theta`: the system parameters (per input [a, b], or [a, b_1, b_2, ...]
      for a common denominator; a without the leading 1); `cov` their
      covariance $\sigma^2 (\sum \zeta_f \zeta_f^T)^{-1}$; `eta` = [c1.., d1..] and
      `noise_cov`. `num_se`, `den_se`, `c_se`, `d_se`: standard errors aligned
      with the polynomials (0 at the monic coefficients).
    - `sigma2`: the variance of the innovations $e$ (prediction errors),
      $\sum \varepsilon^2 / (N - p - nc - nd)$; `y_model`: $\sum_i G_i u_i$ at the samples;
      `residual`: $\xi = y - y_{model}$; `innovations`: $\varepsilon = (D/C) \xi$.
    - Fit statistics: `rt2` = $1 - var(\xi)/var(y)$ (the coefficient of
      determination of the simulated model, $R_T^2$);
      `yic` = $\ln(var(\xi)/var(y)) + \ln((1/p) \sum_i cov_{ii} / \theta_i^2)$ (Young's information criterion:
      more negative is better, it grows when parameters are poorly defined);
      `aic` = $N \ln s^2 + 2 (p + q)$ and `bic` = $N \ln s^2 + (p + q) \ln N$ with
      $s^2 = \sum \varepsilon^2 / N$, $q = nc + nd$.
    - `iterations`, `rel_change`, `converged`, `stable`, `status` (int code)
      and `reason` (a property, outside `jit`: one of `RIV_REASONS`);
      `delay` (whole samples per input); `refined`: the prediction-error
      refinement (`refine="pem"`) replaced the IV estimate.

    Example:
        >>> import numpy as np
        >>> import scipy.signal as sig
        >>> from jaxsdp.tfest import rivbj
        >>> rng = np.random.default_rng(0)
        >>> u = np.repeat(rng.choice([-1.0, 1.0], 400), 5)  # 2000 samples
        >>> x = sig.lfilter([0.0, 0.5], [1.0, -0.8], u)  # 0.5 z^-1 / (1 - 0.8 z^-1)
        >>> y = x + sig.lfilter([1.0], [1.0, -0.9], 0.1 * rng.standard_normal(2000))  # AR(1) noise
        >>> res = rivbj(y, u, n=1, m=0, nc=0, nd=1, delay=1)
        >>> res.reason, np.round(np.asarray(res.den), 2).tolist(), np.round(np.asarray(res.num), 2).tolist()
        ('converged', [1.0, -0.8], [0.5])
        >>> round(float(res.d[1]), 1)
        -0.9
    """

    num: object
    den: object
    c: jnp.ndarray
    d: jnp.ndarray
    theta: jnp.ndarray
    eta: jnp.ndarray
    cov: jnp.ndarray
    noise_cov: jnp.ndarray
    num_se: object
    den_se: object
    c_se: jnp.ndarray
    d_se: jnp.ndarray
    sigma2: jnp.ndarray
    y_model: jnp.ndarray
    residual: jnp.ndarray
    innovations: jnp.ndarray
    rt2: jnp.ndarray
    yic: jnp.ndarray
    aic: jnp.ndarray
    bic: jnp.ndarray
    iterations: jnp.ndarray
    rel_change: jnp.ndarray
    converged: jnp.ndarray
    stable: jnp.ndarray
    status: jnp.ndarray
    delay: jnp.ndarray
    refined: bool = eqx.field(static=True, default=False)

    @property
    @x64
    def reason(self):
        """Why the iteration stopped and whether the model is usable, in words (see `RIV_REASONS`)."""
        return status_reason(self.status, RIV_REASONS)


def _per_input(name, v, r, lo, hi=None):
    """An int for every input: one int (all inputs) or a sequence of r ints."""
    if isinstance(v, np.ndarray) and v.ndim == 0:
        v = v.item()
    if isinstance(v, (list, tuple, np.ndarray)):
        vals = list(np.asarray(v).ravel()) if isinstance(v, np.ndarray) else list(v)
        if len(vals) != r:
            raise ValueError(f"`{name}` must be one integer or one per input ({r}); got {len(vals)}: {v!r}")
        return tuple(int_option(name, x, lo, hi) for x in vals)
    return (int_option(name, v, lo, hi),) * r


def inputs(u, N):
    """(r, N) float64 inputs from a 1-D array (one input) or a list/tuple of 1-D arrays (several)."""
    if isinstance(u, (list, tuple)) and u and all(np.ndim(x) == 0 for x in u):
        u = np.asarray(u, dtype=float)  # one input given as a list of numbers
    if isinstance(u, (list, tuple)):
        if not u:
            raise ValueError("`u`: the list of inputs is empty")
        arrs = [as_float_array(f"u[{i}]", x, ndim=1) for i, x in enumerate(u)]
        lens = [a.shape[0] for a in arrs]
        if len(set(lens + [N])) != 1:
            raise ValueError(f"the inputs and `y` must have equal lengths; got y: {N}, inputs: {lens}")
        return jnp.stack(arrs), True
    if np.ndim(u) == 2:
        raise ValueError(
            f"`u` must be 1-D (one input); for several inputs pass a list of 1-D arrays; got shape {np.shape(u)}"
        )
    a = as_float_array("u", u, ndim=1)
    if a.shape[0] != N:
        raise ValueError(f"`y` and `u` must have the same length; got {N} and {a.shape[0]}")
    return a[None], False


def check_problem(y, u, *, continuous, n, m, nc, nd, delay, denominator):
    """Validate data and structure; returns (y, us (r, N), Structure, delays tuple, miso flag)."""
    y = as_float_array("y", y, ndim=1)
    N = y.shape[0]
    us, miso = inputs(u, N)
    r = us.shape[0]
    if denominator not in ("common", "separate"):
        raise ValueError(f"`denominator` must be 'common' or 'separate'; got {denominator!r}")
    common = denominator == "common" or r == 1
    if common:
        ns = (int_option("n", n, 1, MAX_ORDER),) * r
    else:
        ns = _per_input("n", n, r, 1, MAX_ORDER)
    ms = _per_input("m", m, r, 0)
    if continuous:
        for ni, mi in zip(ns, ms):
            if mi > ni:
                raise ValueError(f"`m` = {mi} exceeds `n` = {ni}: B(s)/A(s) must be proper (m <= n)")
    nc = int_option("nc", nc, 0, MAX_NOISE_ORDER)
    nd = int_option("nd", nd, 0, MAX_NOISE_ORDER)
    delays = _per_input("delay", delay, r, 0)
    st = Structure(continuous=continuous, n=ns, m=ms, common=common, nc=nc, nd=nd)
    p = st.slices()[1]
    if max(delays) >= N:
        raise ValueError(f"`delay` {max(delays)} is beyond the record of {N} samples")
    used = N - max(delays)
    need = SAMPLES_PER_PARAMETER * (p + nc + nd)
    if used < need:
        raise ValueError(
            f"too few samples: {N} with a delay of {max(delays)} leaves {used}; {p} system + {nc + nd} noise = "
            f"{p + nc + nd} parameters need at least {need} ({SAMPLES_PER_PARAMETER} per parameter)"
        )
    return y, us, st, delays, miso


def _polys(out, st, miso):
    """num, den (and their standard errors) from theta; c, d from eta."""
    theta, se = out["theta"], jnp.sqrt(jnp.diag(out["cov"]))
    sl, _ = st.slices()
    one, zero = jnp.ones((1,)), jnp.zeros((1,))
    nums = [theta[b] for _, b in sl]
    nses = [se[b] for _, b in sl]
    dens = [jnp.concatenate([one, theta[a]]) for a, _ in sl]
    dses = [jnp.concatenate([zero, se[a]]) for a, _ in sl]
    if st.common:
        dens, dses = dens[0], dses[0]
    elif not miso:
        dens, dses = dens[0], dses[0]
    if not miso:
        nums, nses = nums[0], nses[0]
    else:
        nums, nses = tuple(nums), tuple(nses)
        if not st.common:
            dens, dses = tuple(dens), tuple(dses)
    eta = out["eta"]
    nse = jnp.sqrt(jnp.diag(out["noise_cov"])) if eta.shape[0] else jnp.zeros((0,))
    c = jnp.concatenate([one, eta[: st.nc]])
    d = jnp.concatenate([one, eta[st.nc :]])
    c_se = jnp.concatenate([zero, nse[: st.nc]])
    d_se = jnp.concatenate([zero, nse[st.nc :]])
    return nums, dens, nses, dses, c, d, c_se, d_se


def build_result(out, y, st, miso, delays, refined=False):
    nums, dens, nses, dses, c, d, c_se, d_se = _polys(out, st, miso)
    return RIVResult(
        num=nums,
        den=dens,
        c=c,
        d=d,
        theta=out["theta"],
        eta=out["eta"],
        cov=out["cov"],
        noise_cov=out["noise_cov"],
        num_se=nses,
        den_se=dses,
        c_se=c_se,
        d_se=d_se,
        sigma2=out["sigma2"],
        y_model=y - out["xi"],
        residual=out["xi"],
        innovations=out["eps"],
        rt2=out["rt2"],
        yic=out["yic"],
        aic=out["aic"],
        bic=out["bic"],
        iterations=out["iterations"],
        rel_change=out["rel"],
        converged=out["converged"],
        stable=out["stable"],
        status=out["status"],
        delay=jnp.asarray(delays),
        refined=refined,
    )


@eqx.filter_jit
def riv_fit(y, us, dt, delays, lams, st, max_iter, tol):
    return riv_core(y, us, dt, delays, lams, st, max_iter, tol)


def _finish(out, y, us, dt, st, miso, delays, solver, name, stacklevel):
    refined = False
    if solver.pem:
        from ._bj import pem_refine

        out = pem_refine(out, y, us, dt, jnp.asarray(delays), st, solver.pem_steps)
        refined = True
    res = build_result(out, y, st, miso, delays, refined)
    if not is_concrete(res.status):
        return res
    if int(res.status) == UNSTABLE:
        raise ValueError(
            f"{name}: the estimated model is unstable: either the structure (orders, delay, noise orders) does not "
            "fit the data (try `structure_search`) or the data are open-loop unstable, which an output-error "
            "(Box-Jenkins) refined IV method cannot fit (identify such a plant from closed-loop data)"
        )
    if not bool(res.converged):
        message = f"{name} did not converge: {res.reason} (see `converged`, `rel_change`)"
        warnings.warn(message, RuntimeWarning, stacklevel)
    return res


@x64
def rivcbj(y, u, dt, *, n, m, nc, nd, delay=0, denominator="common", lam=None, solver=None):
    r"""Estimate a hybrid Box-Jenkins model: continuous-time system, discrete ARMA noise (RIVCBJ).

    Model, samples $t_k = k \Delta t$ (s; $\Delta t$ = `dt`), inputs held between samples (ZOH), the
    system at rest at $t = 0$:

    $$ y(t_k) = \sum_i B_i(s)/A_i(s) u_i(t_k - delay_i \Delta t) + \xi_k, \quad \xi_k = C(z^{-1})/D(z^{-1}) e_k, $$

    $A_i(s) = s^n + a_1 s^{n-1} + ... + a_n$, $B_i(s) = b_0 s^m + ... + b_m$,
    $C = 1 + c_1 z^{-1} + ... + c_{nc} z^{-nc}$, $D = 1 + d_1 z^{-1} + ... + d_{nd} z^{-nd}$,
    $e_k$ white. Young's refined instrumental variable iteration: prefilters
    $1/\hat A(s)$ (exact for the held input) then $\hat D/\hat C$ (discrete), the
    instrument from the auxiliary model, the noise model re-estimated every
    pass; start values from SRIVC (the same iteration with white noise). The
    fixed point is the Box-Jenkins prediction-error (maximum-likelihood)
    estimate, so the system parameters reach the Cramer-Rao bound when the
    noise is coloured, where SRIVC's do not; noise-free data give the true
    parameters to rounding. Algorithm: `jaxsdp.tfest._rivcore`.

    Args:
      y: (N,) sampled output.
      u: (N,) input, or a list of (N,) inputs (MISO).
      dt: sampling interval (s), > 0.
      n: order of A(s) (1..10); per input (a sequence) with separate denominators.
      m: order of B(s) ($0 \le m \le n$); one for all inputs or one per input.
      nc: order of C (0..10).
      nd: order of D (0..10); $nc = nd = 0$: white noise (SRIVC).
      delay: whole samples of input delay, one or one per input.
      denominator: "common" (one A(s) for every input) or "separate" (one per input).
      lam: prefilter bandwidth(s) (rad/s) of the LSSVF starts, as `srivc`.
      solver: a `RIVSolver` (None: its defaults): the most IV passes per stage
        (white noise, then Box-Jenkins), the stopping tolerance on
        $\|\Delta\theta\| / \|\theta\|$ ($\theta$ in scaled time; after one more pass),
        and `pem`: then minimise the prediction-error criterion
        $\sum \varepsilon_k^2$ by Levenberg-Marquardt (optimistix) from the RIVCBJ
        estimate (`refined` True).

    Returns:
      `RIVResult` (num, den, c, d, cov, noise_cov, standard errors, sigma2,
      rt2, yic, aic, bic, converged, reason, ...).

    Raises:
      ValueError: bad shapes or options, NaN/inf, too few samples for the
        $p + nc + nd$ parameters (10 per parameter), a delay beyond the record,
        inputs of unequal lengths, a constant input or output, an unstable
        estimate (open-loop unstable data or a structure that does not fit). A
        run that did not converge (iteration limit, or a non-finite pass: the
        last finite estimate is kept) returns with `converged` False, its
        `reason` and a `RuntimeWarning`.

    Example:
        >>> import numpy as np
        >>> import scipy.signal as sig
        >>> from jaxsdp.tfest import c2d, rivcbj
        >>> dt, rng = 0.02, np.random.default_rng(1)
        >>> u = np.repeat(rng.choice([-1.0, 1.0], 500), 6)  # 3000 samples
        >>> x = sig.lfilter(*c2d([4.0, 20.0], [1.0, 3.0, 20.0], dt), u)
        >>> xi = sig.lfilter([1.0, 0.3], [1.0, -0.98], 0.01 * rng.standard_normal(3000))  # a slow drift
        >>> res = rivcbj(x + xi, u, dt, n=2, m=1, nc=1, nd=1)
        >>> res.reason, np.round(np.asarray(res.den), 1).tolist(), np.round(np.asarray(res.num), 1).tolist()
        ('converged', [1.0, 3.0, 19.9], [4.0, 19.8])
        >>> err = np.asarray(res.theta) - [3.0, 20.0, 4.0, 20.0]  # within 2 standard errors
        >>> bool(np.all(np.abs(err) < 2 * np.sqrt(np.diag(res.cov))))
        True
        >>> np.round(np.asarray(res.c), 2).tolist(), np.round(np.asarray(res.d), 2).tolist()
        ([1.0, 0.3], [1.0, -0.98])
    """
    y, us, st, delays, miso = check_problem(
        y, u, continuous=True, n=n, m=m, nc=nc, nd=nd, delay=delay, denominator=denominator
    )
    dt = positive_float("dt", dt)
    solver = check_solver(solver, "rivcbj")
    lams = lam_starts(lam, dt)
    carrier = check_data_values(y, us, delays, jnp.asarray(dt))
    iters, tol = jnp.asarray(solver.max_iter), jnp.asarray(solver.tol)
    out = riv_fit(y, us, carrier, jnp.asarray(delays), jnp.asarray(lams), st, iters, tol)
    return _finish(out, y, us, carrier, st, miso, delays, solver, "rivcbj", 4)


@x64
def rivbj(y, u, *, n, m, nc, nd, delay=0, denominator="common", solver=None):
    r"""Estimate a discrete-time Box-Jenkins model by refined instrumental variables (RIVBJ).

    Model: $y_k = \sum_i z^{-delay_i} B_i(z^{-1})/A_i(z^{-1}) u_i(k) + C(z^{-1})/D(z^{-1}) e_k$
    with $A = 1 + a_1 z^{-1} + ... + a_n z^{-n}$, $B = b_0 + b_1 z^{-1} + ... + b_m z^{-m}$,
    $C$, $D$ monic of orders nc, nd, $e_k$ white. The same iteration as `rivcbj`
    with the prefilter $1/\hat A(z^{-1})$ (and $\hat D/\hat C$), started from ARX least
    squares then SRIV; the fixed point is the Box-Jenkins prediction-error
    estimate (zero initial conditions). Options, result and errors as `rivcbj`
    (no `dt`, `lam`; m may exceed n). A strictly proper model sampled from a
    continuous plant has `delay` >= 1 (or $b_0 = 0$).

    Example:
        >>> import numpy as np
        >>> import scipy.signal as sig
        >>> from jaxsdp.tfest import rivbj
        >>> rng = np.random.default_rng(3)
        >>> u = rng.standard_normal(1500)
        >>> x = sig.lfilter([0.0, 1.0, 0.5], [1.0, -1.5, 0.7], u)  # delay 1, B = 1 + 0.5 z^-1
        >>> res = rivbj(x, u, n=2, m=1, nc=1, nd=1, delay=1)  # noise-free: exact
        >>> np.round(np.asarray(res.den), 8).tolist(), np.round(np.asarray(res.num), 8).tolist()
        ([1.0, -1.5, 0.7], [1.0, 0.5])
    """
    return _rivbj(y, u, n, m, nc, nd, delay, denominator, check_solver(solver, "rivbj"), "rivbj", 5)


def _rivbj(y, u, n, m, nc, nd, delay, denominator, solver, name, stacklevel):
    """`rivbj` with the name and warning stack level of the public function that called it."""
    y, us, st, delays, miso = check_problem(
        y, u, continuous=False, n=n, m=m, nc=nc, nd=nd, delay=delay, denominator=denominator
    )
    carrier = check_data_values(y, us, delays, jnp.asarray(1.0))
    iters, tol = jnp.asarray(solver.max_iter), jnp.asarray(solver.tol)
    out = riv_fit(y, us, carrier, jnp.asarray(delays), jnp.ones((1,)), st, iters, tol)
    return _finish(out, y, us, carrier, st, miso, delays, solver, name, stacklevel)


@x64
def sriv(y, u, *, n, m, delay=0, denominator="common", solver=None):
    r"""Estimate a discrete-time output-error model by simplified refined IV (SRIV: `rivbj` with white noise).

    Model: $y_k = \sum_i z^{-delay_i} B_i(z^{-1})/A_i(z^{-1}) u_i(k) + e_k$, $e_k$ white;
    the fixed point is the output-error least-squares estimate. Arguments
    and result as `rivbj` (`c` = `d` = [1.0]).

    Example:
        >>> import numpy as np
        >>> import scipy.signal as sig
        >>> from jaxsdp.tfest import sriv
        >>> u = np.random.default_rng(4).standard_normal(1000)
        >>> y = sig.lfilter([0.0, 0.2], [1.0, -0.9], u)
        >>> res = sriv(y, u, n=1, m=0, delay=1)
        >>> np.round(np.asarray(res.den), 8).tolist(), np.round(np.asarray(res.num), 8).tolist()
        ([1.0, -0.9], [0.2])
    """
    return _rivbj(y, u, n, m, 0, 0, delay, denominator, check_solver(solver, "sriv", pem=False), "sriv", 5)
