"""Step-response figures: settling time, overshoot, peak velocity; smooth costs for gradients; the drive verdict."""

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from .._runtime import x64


class StepMetrics(NamedTuple):
    r"""Figures of a step response from y0 to `target` starting at `t_step`.

    `settling_time` (s): from the step to the last time the output is outside
    the band $target \pm band \cdot |target - y_0|$ (inf if it is still outside at the
    end: not settled); `overshoot` (%): $100 \max(0, p) / |target - y_0|$ with $p$ the peak past
    target; `rise_time` (s): 10 % to 90 %; `peak_velocity` (m/s) and `peak_force` (N) when given;
    `settled`: bool.
    """

    settling_time: float
    overshoot: float
    rise_time: float
    peak_velocity: float
    peak_force: float
    settled: bool


@x64
def step_metrics(t, y, target, *, y0=None, t_step=0.0, band=0.02, velocity=None, force=None) -> StepMetrics:
    """Settling time (2 % band by default), overshoot and peaks of a sampled step response.

    **Arguments:** `t` (N,) times (s), `y` (N,) output, `target` the final
    value, `y0` the initial value (default y[0]), `t_step` the step time (s),
    `band` the settling band as a fraction of the step, `velocity` and
    `force` optional (N,) signals whose peak absolute values are reported.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.control import step_metrics
        >>> t = np.arange(0, 0.1, 1e-4)
        >>> y = 1 - (1 + 250 * t) * np.exp(-250 * t)  # critically damped, wn = 250 rad/s
        >>> m = step_metrics(t, y, 1.0)
        >>> round(m.settling_time, 4), round(m.overshoot, 3)  # s, %
        (0.0234, 0.0)
    """
    t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    y0 = float(y[0]) if y0 is None else float(y0)
    step = float(target) - y0
    if step == 0:
        raise ValueError("the step is zero (target equals the initial value)")
    e = (y - target) / step  # 0 at the target, -1 at the start
    after = t >= t_step
    outside = after & (np.abs(e) > band)
    if not np.any(after):
        raise ValueError("no samples after the step time")
    if outside[-1]:
        settling, settled = float("inf"), False
    else:
        last = np.nonzero(outside)[0]
        settling = float(t[last[-1] + 1] - t_step) if last.size else 0.0
        settled = True
    overshoot = float(100 * max(0.0, np.max(e[after])))
    n = (y - y0) / step
    i10 = np.argmax(after & (n >= 0.1))
    i90 = np.argmax(after & (n >= 0.9))
    rise = float(t[i90] - t[i10]) if n[i90] >= 0.9 else float("inf")
    pv = float(np.max(np.abs(velocity))) if velocity is not None else float("nan")
    pf = float(np.max(np.abs(force))) if force is not None else float("nan")
    return StepMetrics(settling, overshoot, rise, pv, pf, settled)


@x64
def tracking_cost(t, y, r, *, dq=None, v_max=None, weight=1e3, sharpness=200.0):
    r"""A smooth closed-loop cost for gradients: integrated absolute error plus a velocity-limit penalty.

    $J = \sum |y - r| \Delta t$ (IAE, smoothed: $\sqrt{e^2 + \varepsilon^2}$)
    $+ weight \cdot \sum softplus(s (|\dot q| - v_{max}))^2 / s^2 \Delta t$,
    with $\varepsilon$ = 1e-6 m and $s$ = `sharpness` (s/m). Differentiable everywhere.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.control import tracking_cost
        >>> t = np.arange(100) * 1e-3
        >>> round(float(tracking_cost(t, np.zeros(100), np.full(100, 0.01))), 5)  # m s
        0.001
    """
    t, y, r = jnp.asarray(t), jnp.asarray(y), jnp.asarray(r)
    dt = t[1] - t[0]
    e = y - r
    j = jnp.sum(jnp.sqrt(e**2 + 1e-12)) * dt
    if dq is not None and v_max is not None:
        over = jax.nn.softplus(sharpness * (jnp.abs(jnp.asarray(dq)) - v_max)) / sharpness
        j = j + weight * jnp.sum(over**2) * dt
    return j


#: A design whose peak force lies within this fraction below the drive's limit is "at the limit": it leaves no
#: margin (a heavier load, more friction or a longer step saturates it), so it is not called feasible.
AT_LIMIT_MARGIN = 0.05
#: Relative tolerance of "above the limit": a saturated drive's force equals its limit up to rounding.
LIMIT_RTOL = 1e-9
#: The verdicts of `force_verdict`, from the best to the worst.
FORCE_VERDICTS = ("feasible", "at the limit", "infeasible")


def force_verdict(peak_force, force_limit, *, margin: float = AT_LIMIT_MARGIN) -> str | None:
    """A simulated design's peak force (N) against a drive's limit (N): one of `FORCE_VERDICTS`, None if unknown.

    "infeasible" above the limit (the drive cannot give it), "at the limit" from (1 - `margin`) times the limit
    up to it (a saturated drive's force is exactly its limit), "feasible" below; None for a NaN or None peak
    (e.g. an unstable response).

    Example:
        >>> from jaxsdp.control._metrics import force_verdict
        >>> [force_verdict(f * 351.5, 351.5) for f in (0.9, 0.96, 1.0, 1.01)]
        ['feasible', 'at the limit', 'at the limit', 'infeasible']
    """
    if peak_force is None or np.isnan(float(peak_force)):
        return None
    pf, limit = float(peak_force), float(force_limit)
    if not 0.0 < margin < 1.0:
        raise ValueError(f"`margin` must lie in (0, 1); got {margin!r}")
    if pf > limit * (1 + LIMIT_RTOL):
        return "infeasible"
    return "at the limit" if pf >= (1 - margin) * limit else "feasible"
