"""PIP-SDP cascade (paper section 4.3): a PIP outer loop at a slow rate setting the reference of the SDP-PD loop.

The SDP-PD loop (`SDPPD`, fast rate dt, e.g. 1 kHz) is effectively linear,
so the outer loop treats it as a linear system r_in -> q, identified from
closed-loop data (`srivc`) and discretised at the outer period
T = ratio dt (`c2d`, e.g. 0.01 s). The PIP-LQ controller (`pip_lq`) designed
on that model runs every `ratio` samples:

    at k = 0, ratio, 2 ratio, ...:   z = z + r(k) - qm(k),   r_in = LG (-k_PIP x)
    in between:                     r_in held (zero-order hold)
    every sample:                   tau = SDPPD(r_in, qm)

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

from ..plants._parameters import parameter
from ._closed_loop import AbstractController
from ._pip import PIPDesign, init_state, step
from ._sdp_pd import SDPPD


class PIPSDP(AbstractController):
    """PIP-SDP cascade controller: PIP every `ratio` samples -> loop gain -> SDP-PD every sample.

    **Fields:** `inner` (an `SDPPD`), `design` (a `PIPDesign` for the inner
    loop's model at period ratio * dt), `loop_gain` (LG, dimensionless),
    `ratio` (static int, outer period / inner period, 10 for 100 Hz over
    1 kHz), `loop_gain_mode` (static): "internal" (default) feeds the PIP's NMSS
    input states with what the inner loop received, LG u; "serial" with the
    PIP's own u (LG after the controller). `aux` records the inner reference r_in (m).

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

    def __init__(
        self, inner: SDPPD, design: PIPDesign, *, loop_gain=1.0, ratio: int = 10, loop_gain_mode: str = "internal"
    ):
        if not isinstance(inner, SDPPD):
            raise ValueError(f"`inner` must be an SDPPD controller; got {type(inner).__name__}")
        if not isinstance(design, PIPDesign):
            raise ValueError(f"`design` must be a PIPDesign (see pip_lq); got {type(design).__name__}")
        if not (isinstance(ratio, int) and ratio >= 1):
            raise ValueError(f"`ratio` must be a positive int (outer period / inner period); got {ratio!r}")
        if loop_gain_mode not in ("internal", "serial"):
            raise ValueError(f"`loop_gain_mode` must be 'internal' or 'serial'; got {loop_gain_mode!r}")
        self.inner, self.design, self.ratio, self.loop_gain_mode = inner, design, ratio, loop_gain_mode
        self.loop_gain = parameter("loop_gain", loop_gain, "positive")

    def init(self, q0):
        q0 = jnp.asarray(q0, dtype=jnp.float64)
        internal = self.loop_gain_mode == "internal"
        pstate = init_state(self.design, q0, loop_gain=self.loop_gain, internal=internal)
        return (self.inner.init(q0), pstate, q0, jnp.zeros((), jnp.int32))

    def step(self, state, r, qm, v, dt):
        istate, pstate, r_in, k = state
        internal = self.loop_gain_mode == "internal"
        applied, pnew = step(self.design, pstate, r, qm, loop_gain=self.loop_gain, internal=internal)
        outer = k % self.ratio == 0
        pstate = jax.tree_util.tree_map(lambda a, b: jnp.where(outer, a, b), pnew, pstate)
        r_in = jnp.where(outer, applied, r_in)
        cmd, istate = self.inner.step(istate, r_in, qm, v, dt)
        return cmd, (istate, pstate, r_in, k + 1)

    def aux(self, state):
        return state[2]
