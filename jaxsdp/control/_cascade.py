"""PIP-SDP cascade (paper section 4.3): a PIP outer loop at a slow rate setting the reference of the SDP-PD loop.

The SDP-PD loop (`SDPPD`, fast rate dt, e.g. 1 kHz) is effectively linear,
so the outer loop treats it as a linear system r_in -> q, identified from
closed-loop data (`srivc`) and discretised at the outer period
T = ratio dt (`c2d`, e.g. 0.01 s). The PIP-LQ controller (`pip_lq`) designed
on that model runs every `ratio` samples:

    at k = 0, ratio, 2 ratio, ...:   z = z + r(k) - qm(k),   u = LG (-k_PIP x)
    in between:                     r_in ramps from where it is to u over the
                                    outer period (hold="linear", the default),
                                    or is held at u (hold="zoh", the paper's)
    every sample:                   tau = SDPPD(r_in, qm)

Held, the inner reference jumps every outer period and the fast SDP-PD loop
answers each jump with a force spike (a 0.05 m step: +-5 kN at 100 Hz on the
ideal drive, 14 times the EMPS drive's 351.5 N); ramped, as a practical
cascade feeds its inner loop, the force stays within a few hundred newtons.

with LG the loop gain of the paper (LG = 5 there). Where it sits matters:
with `loop_gain_mode="internal"` (default) the NMSS past-input states are
the inputs the inner loop actually received, LG u (the NMSS states are the
plant's past inputs); with `"serial"` they are the PIP's own outputs u and
LG is a gain after the controller. On the paper's model (30) with ew = 10,
uw = xw = 1, the internal placement is stable up to LG = 5.9 and the serial
one only up to LG = 2.15: the paper's LG = 5 implies the internal one.
"""

import equinox as eqx
import jax
import jax.numpy as jnp

from .._checks import POSITIVE
from .._runtime import x64
from ..plants._parameters import parameter
from ._closed_loop import AbstractController
from ._pip import PIPDesign, init_state, step
from ._sdp_pd import SDPPD

#: How the inner reference follows the outer loop's output between outer samples.
HOLDS = ("linear", "zoh")
#: With `max_accel`, the inner reference closes its gap to the ramp in about this many samples.
TRACK_SAMPLES = 20


class PIPSDP(AbstractController):
    r"""PIP-SDP cascade controller: PIP every `ratio` samples -> loop gain -> SDP-PD every sample.

    **Fields:** `inner` (an `SDPPD`), `design` (a `PIPDesign` for the inner
    loop's model at period ratio * dt), `loop_gain` (LG, dimensionless),
    `ratio` (static int, outer period / inner period, 10 for 100 Hz over
    1 kHz), `loop_gain_mode` (static): "internal" (default) feeds the PIP's NMSS
    input states with what the inner loop received, $LG \cdot u$; "serial" with the
    PIP's own $u$ (LG after the controller), `hold` (static): "linear" (default:
    the inner reference ramps to each new outer output over the outer period)
    or "zoh" (held, the paper's). `aux` records the inner reference $r_{in}$ (m).

    Example:
        >>> import numpy as np
        >>> from jaxsdp.control import PIPSDP, SDPPD, control_model, pip_lq, simulate_control
        >>> inner = SDPPD(control_model(dict(M=95.15, Fv=200.0, Fc=20.0, offset=0.0)), wn=250.0)
        >>> design = pip_lq([0, 0.7545, 0.0337], [1, -0.2106, 0.0], ew=10.0)  # the inner loop at 0.01 s
        >>> sim = simulate_control(PIPSDP(inner, design, loop_gain=0.05), np.full(3000, 0.05), q0=0.0)
        >>> round(float(sim.q[-1]), 3), bool(np.max(np.abs(sim.dq)) < 0.5)  # m after 3 s; peak speed m/s
        (0.05, True)
    """

    inner: SDPPD
    design: PIPDesign
    loop_gain: jax.Array
    ratio: int = eqx.field(static=True, default=10)
    loop_gain_mode: str = eqx.field(static=True, default="internal")
    hold: str = eqx.field(static=True, default="linear")
    max_accel: jax.Array | None = None

    @x64
    def __init__(
        self,
        inner: SDPPD,
        design: PIPDesign,
        *,
        loop_gain=1.0,
        ratio: int = 10,
        loop_gain_mode: str = "internal",
        hold: str = "linear",
        max_accel=None,
    ):
        if not isinstance(inner, SDPPD):
            raise ValueError(f"`inner` must be an SDPPD controller; got {type(inner).__name__}")
        if not isinstance(design, PIPDesign):
            raise ValueError(f"`design` must be a PIPDesign (see pip_lq); got {type(design).__name__}")
        if not (isinstance(ratio, int) and ratio >= 1):
            raise ValueError(f"`ratio` must be a positive int (outer period / inner period); got {ratio!r}")
        if loop_gain_mode not in ("internal", "serial"):
            raise ValueError(f"`loop_gain_mode` must be 'internal' or 'serial'; got {loop_gain_mode!r}")
        if hold not in HOLDS:
            raise ValueError(f"`hold` must be one of {HOLDS}; got {hold!r}")
        self.inner, self.design, self.ratio, self.loop_gain_mode = inner, design, ratio, loop_gain_mode
        self.hold = hold
        self.max_accel = None if max_accel is None else parameter("max_accel", max_accel, POSITIVE)
        self.loop_gain = parameter("loop_gain", loop_gain, POSITIVE)

    @x64
    def init(self, q0):
        q0 = jnp.asarray(q0, dtype=jnp.float64)
        internal = self.loop_gain_mode == "internal"
        pstate = init_state(self.design, q0, loop_gain=self.loop_gain, internal=internal)
        # inner loop, PIP, inner reference r_in and its rate, the ramp's start and end, sample counter
        zero = jnp.zeros_like(q0)
        return (self.inner.init(q0), pstate, q0, zero, q0, q0, jnp.zeros((), jnp.int32))

    @x64
    def step(self, state, r, qm, v, dt):
        istate, pstate, r_in, v_in, r_from, r_to, k = state
        internal = self.loop_gain_mode == "internal"
        applied, pnew = step(self.design, pstate, r, qm, loop_gain=self.loop_gain, internal=internal)
        outer = k % self.ratio == 0
        pstate = jax.tree_util.tree_map(lambda a, b: jnp.where(outer, a, b), pnew, pstate)
        r_from = jnp.where(outer, r_in, r_from)
        r_to = jnp.where(outer, applied, r_to)
        if self.hold == "zoh":
            target = r_to
        else:  # reaches the new output at the end of the outer period
            target = r_from + (r_to - r_from) * ((k % self.ratio + 1) / self.ratio)
        if self.max_accel is None:
            v_in, r_in = (target - r_in) / dt, target
        else:  # follow the target with the rate changing by at most max_accel dt per sample
            slope = (r_to - r_from) / (self.ratio * dt)
            wanted = slope + (target - r_in - slope * dt) / (TRACK_SAMPLES * dt)
            v_in = jnp.clip(wanted, v_in - self.max_accel * dt, v_in + self.max_accel * dt)
            r_in = r_in + v_in * dt
        cmd, istate = self.inner.step(istate, r_in, qm, v, dt)
        return cmd, (istate, pstate, r_in, v_in, r_from, r_to, k + 1)

    @x64
    def aux(self, state):
        return state[2]
