"""SDP-PD control of the EMPS (paper section 4.2, eqs. 28-29) and the benchmark's linear PD.

With the SDP model ddq + a_sdp(dq) dq = c4 tau (eq. 27) and the control law

    tau = Kp (r - q) - Kv(dq) dq,    Kp = wn^2 / c4,    Kv(dq) = (2 eta wn - a_sdp(dq)) / c4   (eq. 29)

the closed loop is linear, x = wn^2 / (p^2 + 2 eta wn p + wn^2) r: the
velocity gain cancels the state-dependent friction and places both poles.
Built on the product a_sdp(dq) dq = c4 f(dq) (no division by dq), the law is

    tau = Kp (r - q) - (2 eta wn / c4) dq + f(dq),

a PD with friction compensation by the controller's friction law f. The
velocity feedback acts on the measured output (as in the benchmark's
controller), so the reference enters through Kp only and the closed loop
has no zero. The paper's eq. (28) writes the PD as a pre-compensator on the
error, Kp + Kv p, which adds a zero at -Kp/Kv (about -wn/2) and some 13 %
overshoot at eta = 1; `derivative="error"` gives that form.

Digital implementation at period dt: q is the measured position qm(k), dq
the velocity estimate of `velocity` ("fir": the benchmark's FIR + backward
difference; "difference"; "state": the true velocity, for checks).
"""

import equinox as eqx
import jax
import jax.numpy as jnp

from .._checks import POSITIVE
from .._runtime import x64
from ..plants._parameters import parameter
from ..plants.emps._plant import BENCHMARK_GAINS
from ._closed_loop import GTAU, VELOCITY_MODES, AbstractController, velocity_estimate, velocity_init
from ._model import SDPControlModel

DERIVATIVE = ("output", "error")


class SDPPD(AbstractController):
    r"""SDP-PD controller (eq. 29): $\tau = K_p (r - q) - (2 \eta \omega_n / c_4) \dot q + f(\dot q)$.

    The position gain is $K_p = \omega_n^2 / c_4$.

    **Fields:** `model` (an `SDPControlModel`: $c_4$ and the friction $f$ it
    compensates), `wn` ($\omega_n$, rad/s), `eta` ($\eta$, dimensionless), `velocity` (static:
    "fir", "difference" or "state"), `derivative` (static: "output", the
    default, or "error" for the paper's pre-compensator form of eq. 28).
    `gains(dq)` returns ($K_p$ N/m, $K_v(\dot q)$ N/(m/s)) as in eq. (29) ($K_v$ is NaN
    at $\dot q = 0$, where only the product $K_v \dot q$ is defined).

    Example:
        >>> from jaxsdp.control import SDPPD, control_model
        >>> ctrl = SDPPD(control_model(dict(M=95.08, Fv=202.30, Fc=20.53, offset=-3.19)), wn=250.0)
        >>> kp, kv = ctrl.gains(0.1)
        >>> round(float(kp)), round(float(kv), 1)  # N/m, N/(m/s)
        (5942500, 47164.3)
    """

    model: SDPControlModel
    wn: jax.Array
    eta: jax.Array
    velocity: str = eqx.field(static=True, default="fir")
    derivative: str = eqx.field(static=True, default="output")

    @x64
    def __init__(self, model: SDPControlModel, *, wn=250.0, eta=1.0, velocity="fir", derivative="output"):
        if not isinstance(model, SDPControlModel):
            raise ValueError(f"`model` must be an SDPControlModel (see control_model); got {type(model).__name__}")
        if velocity not in VELOCITY_MODES:
            raise ValueError(f"`velocity` must be one of {VELOCITY_MODES}; got {velocity!r}")
        if derivative not in DERIVATIVE:
            raise ValueError(f"`derivative` must be one of {DERIVATIVE}; got {derivative!r}")
        self.model = model
        self.wn = parameter("wn", wn, POSITIVE)
        self.eta = parameter("eta", eta, POSITIVE)
        self.velocity = velocity
        self.derivative = derivative

    @x64
    def gains(self, dq):
        """(Kp, Kv(dq)) of eq. (29): Kp = wn^2 / c4 (N/m), Kv = (2 eta wn - a_sdp(dq)) / c4 (N/(m/s))."""
        c4 = self.model.c4
        return self.wn**2 / c4, (2 * self.eta * self.wn - self.model.a_sdp(dq)) / c4

    @x64
    def init(self, q0):
        return (velocity_init(q0), jnp.asarray(q0, dtype=jnp.float64))

    @x64
    def step(self, state, r, qm, v, dt):
        vstate, r_prev = state
        dq, vstate = velocity_estimate(self.velocity, vstate, qm, v, dt)
        c4 = self.model.c4
        kd = 2 * self.eta * self.wn / c4
        cmd = self.wn**2 / c4 * (r - qm) - kd * dq + self.model.friction(dq)
        if self.derivative == "error":
            cmd = cmd + kd * (r - r_prev) / dt  # Kv p acting on r too: the pre-compensator Kp + Kv p on r - q
        return cmd, (vstate, jnp.asarray(r, dtype=jnp.float64))


class LinearPD(AbstractController):
    r"""The EMPS benchmark's linear controller (the one that produced DATA_EMPS.mat), as a force command.

    $\tau(k) = g_\tau k_v (k_p (r(k) - q_m(k)) - \dot q_f(k))$, $\dot q_f$ from the FIR position
    filter $(q_m(k) + q_m(k-1)) / 2$ and a backward difference; `kp` (1/s),
    `kv` (V/(m/s)), `gtau` (N/V). The drive's delay and +-10 V saturation are
    the `Drive`'s business (`REAL_DRIVE`), not the controller's.

    Example:
        >>> from jaxsdp.control import LinearPD
        >>> pd = LinearPD()
        >>> round(float(pd.kp), 2), round(float(pd.kv), 2)
        (160.18, 243.45)
    """

    kp: jax.Array
    kv: jax.Array
    gtau: jax.Array

    @x64
    def __init__(self, kp=BENCHMARK_GAINS["kp"], kv=BENCHMARK_GAINS["kv"], gtau=GTAU):
        self.kp = parameter("kp", kp, POSITIVE)
        self.kv = parameter("kv", kv, POSITIVE)
        self.gtau = parameter("gtau", gtau, POSITIVE)

    @x64
    def init(self, q0):
        return velocity_init(q0)

    @x64
    def step(self, state, r, qm, v, dt):
        dq, state = velocity_estimate("fir", state, qm, v, dt)
        return self.gtau * self.kv * (self.kp * (r - qm) - dq), state
