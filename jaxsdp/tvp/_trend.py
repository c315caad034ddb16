"""The trend alone: the integrated-random-walk smoother, its NVR by maximum likelihood or from a cut-off period."""

import jax.numpy as jnp
import numpy as np

from .._checks import as_float_array, check_value
from .._runtime import x64
from ._dhr import DHRResult, dhr


@x64
def irw_nvr(cutoff_period):
    r"""The NVR of the IRW trend smoother whose gain is 1/2 at the period `cutoff_period` (samples).

    The IRW smoother's gain at frequency $\omega$ (rad/sample) is
    $G(\omega) = NVR / (NVR + (2 - 2\cos\omega)^2)$ (it is the Hodrick-Prescott
    filter with $\lambda = 1 / NVR$), so $G = 1/2$ at $\omega_c = 2\pi / P_c$ for

    $$ NVR = (2 - 2\cos\omega_c)^2 = 16 \sin^4(\pi / P_c): $$

    cycles longer than $P_c$ samples stay in the trend, shorter ones are
    smoothed out (the toolbox's `irwsm` convention). `cutoff_period` > 2.

    Example:
        >>> import jaxsdp.tvp as tvp
        >>> print(f"{float(tvp.irw_nvr(12.0)):.4g}")          # a monthly series' annual cycle out of the trend
        0.0718
    """
    p = as_float_array("cutoff_period", cutoff_period)
    p = check_value("cutoff_period", p, lambda a: ~(a > 2.0).all() | ~(a < np.inf).all(), _ABOVE_NYQUIST)
    return 16.0 * jnp.sin(jnp.pi / p) ** 4


_ABOVE_NYQUIST = "must be finite and above 2 samples (the Nyquist period)"


@x64
def trend(
    y,
    *,
    model="IRW",
    nvr="ml",
    cutoff_period=None,
    horizon: int = 0,
    P0: float = 1e5,
    method: str | None = None,
) -> DHRResult:
    r"""The trend of a series by the fixed-interval smoother of a random-walk-family model (the `irwsm` job).

    Model: $y_k = T_k + e_k$, $T$ an `IRW` by default ($\Delta^2 T_k = \eta_{k-1}$,
    $var(\eta) = NVR \cdot \sigma^2$; `RW`, `LLT` also). The NVR is estimated by
    maximum likelihood (`nvr="ml"`), given, or set by the cut-off period
    (`cutoff_period` $P_c$ in samples, IRW only: `irw_nvr`, the smoother's gain
    1/2 at $P_c$). This is `jaxsdp.tvp.dhr` with no periods: the result is a
    `DHRResult` whose `trend`, `trend_se` and `forecast` (the trend
    extrapolated `horizon` samples, with intervals) are the answer. The IRW
    smoother is the Hodrick-Prescott filter with $\lambda = 1 / NVR$ (the
    tests check it against statsmodels' `hpfilter`).

    Example:
        >>> import numpy as np, jaxsdp.tvp as tvp
        >>> rng = np.random.default_rng(0)
        >>> k = np.arange(300.0)
        >>> y = np.sin(2 * np.pi * k / 150) + np.sin(2 * np.pi * k / 6) + 0.1 * rng.normal(size=300)
        >>> res = tvp.trend(y, cutoff_period=24.0)               # keeps the 150-sample cycle, drops the 6-sample one
        >>> print(np.round(np.std(np.asarray(res.trend) - np.sin(2 * np.pi * k / 150)), 2))
        0.05
    """
    if cutoff_period is not None:
        if not isinstance(nvr, str) or nvr != "ml":
            raise ValueError("give `nvr` or `cutoff_period`, not both")
        if not (isinstance(model, str) and model.upper() == "IRW"):
            raise ValueError(f"`cutoff_period` sets the NVR of the IRW smoother; `model` is {model!r}")
        nvr = irw_nvr(cutoff_period)
    return dhr(y, (), trend=model, nvr=nvr, horizon=horizon, P0=P0, method=method)


__all__ = ["irw_nvr", "trend"]
