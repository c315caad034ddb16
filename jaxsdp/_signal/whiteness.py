"""Residual whiteness: sample autocorrelation with its confidence band and the Ljung-Box test.

For residuals e_1..e_N with mean e_bar, the sample autocorrelation at lag k is

    r_k = sum_{t=1..N-k} (e_t - e_bar)(e_{t+k} - e_bar) / sum_{t=1..N} (e_t - e_bar)^2 ,

(the biased estimator of Box & Jenkins, as MATLAB's `autocorr` and
statsmodels' `acf`). Under the null hypothesis of white noise each r_k is
approximately N(0, 1/N), so the two-sided band at level alpha is
+-z_{1-alpha/2} / sqrt(N); jointly, the Ljung-Box statistic

    Q = N (N + 2) sum_{k=1..L} r_k^2 / (N - k)

is approximately chi-squared with L degrees of freedom.

**Decimated residuals.** A residual of white measurement noise that went
through the zero-phase anti-aliasing filter of `decimate` (parallel
decimation) is not white: its autocorrelation is that of the filter,
rho_k = c(k r) / c(0) with c the inverse Fourier transform of |H|^4 (about
+0.23 at lag 1 for the default filter). Testing it against white noise
would call every decimated residual "correlated". With `null_acf=rho` the
test asks instead whether the residual is more correlated than filtered
white noise: at lag k the band is +-z sqrt(v_k / N) around rho_k, with
Bartlett's variance for a linear process
v_k = sum_m (rho_m^2 + rho_{m+k} rho_{m-k} - 4 rho_k rho_m rho_{m-k} + 2 rho_m^2 rho_k^2),
and Q = N sum_k (r_k - rho_k)^2 / v_k. The r_k are correlated (Bartlett's
covariance W, diagonal v_k), so Q is compared with c chi-squared(nu)
(Satterthwaite): with R = D^-1/2 W D^-1/2, D = diag(v), E Q = tr R = L and
var Q = 2 tr R^2, so c = tr R^2 / L, nu = L^2 / tr R^2. (W itself is
nearly singular for decimated noise, whose spectrum vanishes above the
filter's cut-off, so Q is not formed with W^-1.)
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.scipy.special import gammaincc
from jax.scipy.stats import norm
from jaxtyping import Array, ArrayLike, Float
from scipy.special import gammaincc as scipy_gammaincc

from .._checks import as_float_array, check_finite, check_value, positive_int
from .._runtime import x64
from .filtering import decimation_filter


class Whiteness(eqx.Module):
    r"""Autocorrelation test of a residual sequence (`whiteness`).

    **Fields:** `lags` (1..L), `acf` (L,) the autocorrelation $r_k$ at those
    lags; `null` (L,) its value under the null hypothesis (0: white noise;
    or the `null_acf` given); `band` (L,): the half-width of the band around
    `null` ($z_{1-\alpha/2} / \sqrt{N}$ for white noise); `lag1`: $r_1$;
    `outside`: how many of the $L$ lags lie outside the band (about $\alpha L$
    under the null); `q`: the Ljung-Box statistic, `p_value` its
    $\chi^2(L)$ upper tail; `white`: `p_value >= alpha` (no evidence of
    more serial correlation than the null at level $\alpha$); `alpha`, `n`.
    """

    lags: Float[Array, " L"]
    acf: Float[Array, " L"]
    null: Float[Array, " L"]
    band: Float[Array, " L"]
    lag1: Float[Array, ""]
    outside: Float[Array, ""]
    q: Float[Array, ""]
    p_value: Float[Array, ""]
    white: Array
    alpha: float = eqx.field(static=True)
    n: int = eqx.field(static=True)

    @x64
    def text(self) -> str:
        """One line: lag-1 autocorrelation against the band, Ljung-Box Q and p-value, verdict."""
        verdict = "white" if bool(self.white) else "serially correlated"
        L = int(np.shape(self.lags)[0])
        null = float(self.null[0])
        band = f"{null:+.3f} +- {float(self.band[0]):.3f}" if null != 0.0 else f"+-{float(self.band[0]):.3f}"
        if null != 0.0:
            verdict = "as filtered white noise" if bool(self.white) else "more correlated than filtered white noise"
        return (
            f"lag-1 autocorrelation {float(self.lag1):+.3f} (band {band}); "
            f"{int(self.outside)}/{L} lags outside; Ljung-Box Q({L}) = {float(self.q):.1f}, "
            f"p = {float(self.p_value):.2g}: {verdict}"
        )


@jax.jit(static_argnames=("max_lag",))
def _acf(e, max_lag: int):
    n = e.shape[0]
    d = e - jnp.mean(e)
    size = 1 << int(2 * n - 1).bit_length()  # zero padding: a linear, not circular, correlation
    f = jnp.fft.rfft(d, size)
    c = jnp.fft.irfft(f * jnp.conj(f), size)[: max_lag + 1]
    return c[1:] / c[0]


def _acf_np(e, max_lag: int):
    """`_acf` in NumPy, for concrete residuals."""
    n = e.shape[0]
    d = e - np.mean(e)
    size = 1 << int(2 * n - 1).bit_length()
    f = np.fft.rfft(d, size)
    c = np.fft.irfft(f * np.conj(f), size)[: max_lag + 1]
    return c[1:] / c[0]


def decimated_noise_acf(r: int, max_lag: int) -> np.ndarray:
    """Autocorrelation at lags 1..`max_lag` of white noise after `decimate(., r)` (the null of decimated residuals).

    rho_k = c(k r) / c(0), c the inverse Fourier transform of |H(e^{jw})|^4,
    H the anti-aliasing filter `decimation_filter(r)` applied forward and
    backward (zero phase); r = 1 gives zeros (white).

    Example:
        >>> from jaxsdp._signal.whiteness import decimated_noise_acf
        >>> decimated_noise_acf(10, 3).round(3).tolist()
        [0.182, -0.158, 0.123]
    """
    r = positive_int("r", r)
    if r == 1:
        return np.zeros(max_lag)
    import scipy.signal

    b, a = decimation_filter(int(r))
    n = 1 << 18  # frequency grid: c(m) for m up to r * max_lag is resolved far beyond 1e-12
    _, h = scipy.signal.freqz(b, a, worN=n // 2 + 1, whole=False, include_nyquist=True)
    c = np.fft.irfft(np.abs(h) ** 4, n)
    return c[r * np.arange(1, max_lag + 1)] / c[0]


def bartlett_covariance(rho, max_lag: int) -> np.ndarray:
    """N cov(r_k, r_l) for k, l = 1..L of a linear process with autocorrelation rho_1..rho_M (Bartlett, 1946).

    W_kl = sum_m (rho_{m+k} rho_{m+l} + rho_{m-k} rho_{m+l} + 2 rho_k rho_l rho_m^2
    - 2 rho_k rho_m rho_{m+l} - 2 rho_l rho_m rho_{m+k}), m over all integers,
    rho_0 = 1, rho_{-m} = rho_m, rho_m = 0 beyond M. White noise: W = I.
    """
    rho = np.asarray(rho, dtype=np.float64)
    M = rho.shape[0]
    span = M + max_lag
    full = np.zeros(2 * span + 1)
    full[span] = 1.0
    full[span + 1 : span + M + 1] = rho
    full[span - M : span] = rho[::-1]
    m = np.arange(-M, M + 1)

    def at(i):
        return full[span + i]

    k = np.arange(1, max_lag + 1)
    rk = at(k)
    a = at(m[None, :] + k[:, None])  # (L, m): rho_{m+k}
    b = at(m[None, :] - k[:, None])  # rho_{m-k}
    rm = at(m)
    return (
        a @ a.T
        + b @ a.T
        + 2 * np.outer(rk, rk) * np.sum(rm**2)
        - 2 * rk[:, None] * (a * rm[None, :]).sum(1)[None, :]
        - 2 * rk[None, :] * (a * rm[None, :]).sum(1)[:, None]
    )


@x64
def whiteness(residuals: ArrayLike, *, max_lag: int = 20, alpha: float = 0.05, null_acf=None) -> Whiteness:
    r"""Is a residual sequence white? Autocorrelation, its band and the Ljung-Box test.

    $r_k = \sum_t (e_t - \bar e)(e_{t+k} - \bar e) / \sum_t (e_t - \bar e)^2$ for
    $k = 1..L$ (`max_lag`); band $\pm z_{1-\alpha/2} / \sqrt{N}$; Ljung-Box
    $Q = N (N + 2) \sum_k r_k^2 / (N - k)$, p-value $P(\chi^2_L > Q)$. Computed by
    FFT ($O(N \log N)$).

    **Arguments:** `residuals` (N,) in any unit, finite, not constant,
    $N \ge \max(10, 2 L)$; `max_lag` $L \ge 1$ (default 20); `alpha` in (0, 1)
    (default 0.05); `null_acf`: None (null hypothesis: white noise), or the
    autocorrelation $\rho_1..\rho_M$ ($M \ge 2 L$) the residual has under the null,
    e.g. `decimated_noise_acf(r, 50 L)` for white noise decimated by r (its
    autocorrelation decays slowly: give many lags): then the band is centred
    on $\rho_k$ with Bartlett's variance $v_k$, and $Q = N \sum_k (r_k - \rho_k)^2 / v_k$
    is compared with $c \chi^2(\nu)$, $c$ and $\nu$ matching its mean and variance under
    the null (Satterthwaite).

    **Returns:** a `Whiteness` (`acf`, `band`, `lag1`, `q`, `p_value`, `white`).

    Example:
        >>> import numpy as np
        >>> from jaxsdp import whiteness
        >>> e = np.random.default_rng(0).normal(size=2000)
        >>> w = whiteness(e)
        >>> bool(w.white), bool(abs(w.lag1) < w.band[0])
        (True, True)
        >>> bool(whiteness(np.convolve(e, np.ones(5), "same")).white)  # moving average: correlated
        False
    """
    concrete = not isinstance(residuals, jax.core.Tracer)
    # host-side for concrete residuals (the studies' diagnosis): NumPy, not eager jnp, whose every operation
    # compiles once per residual length (0.4 s per new length against 0.2 ms); jnp under a trace
    xp = np if concrete else jnp
    e = np.asarray(residuals, dtype=np.float64) if concrete else as_float_array("residuals", residuals)
    if e.ndim != 1:
        raise ValueError(f"`residuals` must be 1-D; got shape {tuple(e.shape)}")
    max_lag = positive_int("max_lag", max_lag)
    if not 0.0 < float(alpha) < 1.0:
        raise ValueError(f"`alpha` must lie in (0, 1); got {alpha!r}")
    n = int(e.shape[0])
    if n < max(10, 2 * max_lag):
        raise ValueError(f"`residuals` has {n} samples; need at least max(10, 2 * max_lag) = {max(10, 2 * max_lag)}")
    e = check_finite("residuals", e)
    e = check_value("residuals", e, lambda a: a.max() == a.min(), "is constant: its autocorrelation is undefined")
    if null_acf is None:
        null, v, scale, dof = np.zeros(max_lag), np.ones(max_lag), 1.0, float(max_lag)
    else:
        rho = np.asarray(null_acf, dtype=np.float64)
        if rho.ndim != 1 or rho.shape[0] < 2 * max_lag or not np.all(np.isfinite(rho)) or np.any(np.abs(rho) > 1):
            raise ValueError(
                f"`null_acf` must be a finite autocorrelation (|rho| <= 1) at lags 1..M, M >= 2 max_lag = "
                f"{2 * max_lag}; got shape {rho.shape}"
            )
        null, W = rho[:max_lag], bartlett_covariance(rho, max_lag)
        v = np.diag(W)
        R = W / np.sqrt(np.outer(v, v))
        tr2 = float(np.sum(R * R))
        scale, dof = tr2 / max_lag, max_lag**2 / tr2
    r = _acf_np(e, max_lag) if concrete else _acf(e, max_lag)
    lags = xp.arange(1, max_lag + 1, dtype=np.float64)
    band = float(norm.ppf(1.0 - float(alpha) / 2.0)) * xp.sqrt(xp.asarray(v) / n)
    if null_acf is None:
        q = n * (n + 2.0) * xp.sum(r**2 / (n - lags))  # Ljung-Box
    else:
        q = n * xp.sum((r - null) ** 2 / xp.asarray(v))
    p = (scipy_gammaincc if concrete else gammaincc)(dof / 2.0, q / (2.0 * scale))
    return Whiteness(
        lags=lags,
        acf=r,
        null=xp.asarray(null),
        band=band,
        lag1=r[0],
        outside=xp.sum(xp.abs(r - null) > band).astype(np.float64),
        q=q,
        p_value=p,
        white=p >= float(alpha),
        alpha=float(alpha),
        n=n,
    )
