"""Proportional-Integral-Plus (PIP) control: the NMSS model, LQ design (CAPTAIN `pipopt`/`gains`), simulation.

**Model.** A discrete TF y = B(z^-1)/A(z^-1) u (conventions of
`jaxsdp.tfest._tf`): `den = [1, a1, ..., an]`, `num = [b0, b1, ..., bm]`
with b0 = 0 (PIP needs at least one sample of delay; leading zeros in `num`
are further pure delays), i.e.

    y_k = -a1 y_{k-1} - ... - an y_{k-n} + b1 u_{k-1} + ... + bm u_{k-m}.

**Non-minimal state space (NMSS).** The state, of dimension N = n + m, is
made of the measured output, the past inputs and the integral of the error:

    x_k = [y_k, ..., y_{k-n+1}, u_{k-1}, ..., u_{k-m+1}, z_k],
    z_k = z_{k-1} + (r_k - y_k),
    x_{k+1} = F x_k + g u_k + d r_{k+1},    y_k = h x_k.

**Control law and sign conventions** (CAPTAIN's `gains`): u_k = -k x_k with

    k = [f0, ..., f_{n-1}, g1, ..., g_{m-1}, -kI],

that is, with F(z^-1) = f0 + f1 z^-1 + ... + f_{n-1} z^-(n-1) (output
feedback) and G(z^-1) = 1 + g1 z^-1 + ... + g_{m-1} z^-(m-1) (input
feedback),

    G(z^-1) u_k = -F(z^-1) y_k + kI z_k,     z_k = (r_k - y_k) / (1 - z^-1).

The nominal closed loop r -> y is kI B / (D (G A + F B) + kI B), D = 1 - z^-1: type 1,
unity steady-state gain.

**Implementations.** `form="feedback"`: F(z^-1) acts on the measured output
(the law above). `form="forward"` (forward-path PIP): F(z^-1) acts on the
output of the controller's internal model, yhat = B/A u (driven by the
controller's own past outputs), while the integral state still uses the
measured y, so that u = kI A / (D (G A + F B)) (r - y); the two are
identical when the plant is the model and differ under mismatch (the
forward form's controller poles, the roots of G A + F B, are not
constrained by the design; its internal model runs open loop). `pip_step`
is one sample of either form, as a pure function for a `lax.scan`;
`pip_simulate` closes the loop on a TF plant. A loop gain LG can sit inside
the law (u = -LG k x, the controller remembering the applied input) or
after it (u_applied = LG u, the controller unaware of it): see `pip_step`.

**Weights** (CAPTAIN `pipopt`): the LQ cost sum x_k' Q x_k + R u_k^2 with
the total weights spread evenly, Q = diag(xw/n (n times), uw/m (m - 1
times), ew), R = uw/m; the gain is k = (R + g'Pg)^-1 g'PF with P the DARE
solution (`solve_dare`'s doubling algorithm: F is often singular).
"""

from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._checks import as_float_array, check_values, is_concrete
from .._runtime import x64
from ..tfest._tf import check_tf
from ._dare import dare

FORMS = ("feedback", "forward")
LOOP_GAIN_MODES = ("serial", "internal")
INTEGRAL_TOL = 1e-9  # |B(1)| <= INTEGRAL_TOL * sum|b_i|: a zero at z = 1 cancels the integrator


class NMSS(eqx.Module):
    """The NMSS form of a discrete TF $y = B(z^{-1})/A(z^{-1}) u$ with integral-of-error state.

    **Fields:** `F` (N, N), `g` (N,), `d` (N,), `h` (N,) with $N = n + m$, in
    $x_{k+1} = F x_k + g u_k + d r_{k+1}$, $y_k = h x_k$, state
    $x_k = [y_k .. y_{k-n+1}, u_{k-1} .. u_{k-m+1}, z_k]$; `n` (order of A)
    and `m` (order of B), static integers.
    """

    F: jax.Array
    g: jax.Array
    d: jax.Array
    h: jax.Array
    n: int = eqx.field(static=True)
    m: int = eqx.field(static=True)


def check_plant(num, den, what: str = "model"):
    """A discrete TF with b0 = 0 and at least one numerator term after it; float64 arrays (num, den)."""
    num, den = check_tf(num, den, kind="discrete")
    if num.shape[0] < 2:
        raise ValueError(f"{what}: `num` must be [0, b1, ..., bm] (b0 = 0, m >= 1); got {num.shape[0]} coefficient(s)")
    num = check_values(
        [("num", num, lambda a: a[0] != 0, f"{what}: b0 = num[0] must be 0 (PIP needs at least one sample delay)")],
        carrier=num,
    )
    return num, den


def nmss_matrices(num, den) -> NMSS:
    """The NMSS matrices of `num`/`den` (traceable, no checks; no scatters: cheap to compile)."""
    n, m = den.shape[0] - 1, num.shape[0] - 1
    size = n + m
    e = np.eye(size)
    shifts = np.zeros((size, size))  # the constant part: state shifts and the integrator's 1
    for i in list(range(1, n)) + list(range(n + 1, n + m - 1)):
        shifts[i, i - 1] = 1.0
    shifts[-1, -1] = 1.0
    first = e[0] - e[-1]  # y_{k+1} enters the first row, and the integral with a minus sign
    row = jnp.concatenate([-den[1:], num[2:], jnp.zeros(1, den.dtype)])  # y_{k+1} without the b1 u_k term
    f = shifts + first[:, None] * row[None, :]
    g = num[1] * first + (e[n] if m > 1 else 0.0)
    return NMSS(F=f, g=g, d=jnp.asarray(e[-1]), h=jnp.asarray(e[0]), n=n, m=m)


_nmss_jit = jax.jit(nmss_matrices)


@x64
def nmss(num, den) -> NMSS:
    r"""The non-minimal state-space (NMSS) model of a discrete TF $y = B(z^{-1})/A(z^{-1}) u$, for PIP control.

    `den = [1, a1, ..., an]`, `num = [0, b1, ..., bm]` ($b_0$ must be 0). State
    ($N = n + m$ entries) $x_k = [y_k, ..., y_{k-n+1}, u_{k-1}, ..., u_{k-m+1}, z_k]$
    with $z_k = z_{k-1} + r_k - y_k$, and

    $$ x_{k+1} = F x_k + g u_k + d r_{k+1}, \quad y_k = h x_k, $$

    $F$'s first row $[-a_1 .. -a_n, b_2 .. b_m, 0]$, $g$ = [b1, 0.., 1 (at $u_k$'s place
    when $m > 1$), .., -b1], $d$ = [0, .., 0, 1], $h$ = [1, 0, .., 0]. Returns an
    `NMSS` (F, g, d, h, n, m). Errors: a non-monic `den`, $b_0 \ne 0$, `num`
    shorter than 2 (ValueError).

    Example:
        >>> from jaxsdp.control import nmss
        >>> s = nmss([0.0, 0.5, 0.25], [1.0, -0.9])
        >>> print(s.F); print(s.g); print(s.n, s.m)
        [[ 0.9   0.25  0.  ]
         [ 0.    0.    0.  ]
         [-0.9  -0.25  1.  ]]
        [ 0.5  1.  -0.5]
        1 2
    """
    return _nmss_jit(*check_plant(num, den))


class PIPDesign(eqx.Module):
    r"""A PIP-LQ design (CAPTAIN `pipopt` + `gains`): the gains, the NMSS model and weights, the closed loop.

    **Fields:** `gains` (N,), the vector $k$ of $u_k = -k x_k$,
    $k = [f_0 .. f_{n-1}, g_1 .. g_{m-1}, -k_I]$ (see `named_gains()`); the model
    `num`, `den`; its NMSS `F`, `g`, `d`, `h`; the LQ weights `Q` (N, N),
    `R` (1, 1) and the totals `ew`, `uw`, `xw`; `P`, the DARE solution;
    `dare_residual`, max |DARE residual| / max(1, max |P|) (about 1e-15 when
    converged); `cl_num`, `cl_den`, the nominal closed loop $r \to y$
    (`cl_num` $= k_I B$, length $m + 1$; `cl_den` $= D (G A + F B) + k_I B$, length
    $n + m + 1$, $D = 1 - z^{-1}$); static `n`, `m`, `form` ("feedback" or
    "forward"). Property `closed_loop_poles`: the $N$ eigenvalues of $F - g k$
    (complex, largest modulus first; not differentiable on every backend,
    use `cl_den` in a differentiable path).
    """

    num: jax.Array
    den: jax.Array
    F: jax.Array
    g: jax.Array
    d: jax.Array
    h: jax.Array
    Q: jax.Array
    R: jax.Array
    P: jax.Array
    gains: jax.Array
    cl_num: jax.Array
    cl_den: jax.Array
    ew: jax.Array
    uw: jax.Array
    xw: jax.Array
    dare_residual: jax.Array
    n: int = eqx.field(static=True)
    m: int = eqx.field(static=True)
    form: str = eqx.field(static=True)

    @x64
    def named_gains(self) -> dict:
        """CAPTAIN's names: {"f0": .., "f{n-1}": .., "g1": .., "g{m-1}": .., "kI": ..} (arrays).

        F(z^-1) = f0 + f1 z^-1 + .. acts on the output, G(z^-1) = 1 + g1 z^-1
        + .. on the input, kI on the integral of the error.

        Example:
            >>> from jaxsdp.control import pip_lq
            >>> d = pip_lq([0.0, 0.5], [1.0, -0.9])
            >>> sorted(d.named_gains())
            ['f0', 'kI']
        """
        k = _columns(self.gains)
        out = {f"f{i}": k[i] for i in range(self.n)}
        out.update({f"g{j}": k[self.n + j - 1] for j in range(1, self.m)})
        out["kI"] = -k[-1]
        return out

    @property
    @x64
    def closed_loop_poles(self):
        """Eigenvalues of F - g k (complex, largest modulus first)."""
        return _poles(self.F, self.g, self.gains)


@jax.jit
def _columns(k):
    return tuple(jnp.moveaxis(k, -1, 0))


@jax.jit
def _poles(f, g, k):
    poles = jnp.linalg.eigvals(f - g[..., :, None] * k[..., None, :])
    order = jnp.argsort(-jnp.abs(poles), axis=-1)
    return jnp.take_along_axis(poles, order, axis=-1)


def polymul(p, q):
    """Product of two polynomials given by coefficients (np.convolve), as one small matrix product."""
    lp, lq = p.shape[-1], q.shape[-1]
    sums = np.zeros((lp + lq - 1, lp * lq))  # sums[k, i * lq + j] = 1 where i + j = k
    i, j = np.divmod(np.arange(lp * lq), lq)
    sums[i + j, np.arange(lp * lq)] = 1.0
    return sums @ (p[:, None] * q[None, :]).reshape(-1)


def closed_loop_tf(num, den, gains, n: int, m: int):
    """(cl_num, cl_den) of the nominal PIP loop r -> y from the gain vector (traceable)."""
    fpoly = gains[:n]
    gpoly = jnp.concatenate([jnp.ones(1, gains.dtype), gains[n : n + m - 1]])
    k_i = -gains[-1]
    delta = jnp.array([1.0, -1.0], gains.dtype)
    cl_num = k_i * num
    cl_den = polymul(delta, polymul(gpoly, den) + polymul(fpoly, num))  # D (G A + F B), length n + m + 1
    return cl_num, cl_den + jnp.concatenate([cl_num, jnp.zeros(n, gains.dtype)])


@jax.jit
def _design(num, den, w):
    model = nmss_matrices(num, den)
    n, m = model.n, model.m
    ew, uw, xw = w[0], w[1], w[2]
    q = jnp.diag(jnp.concatenate([jnp.full(n, xw / n), jnp.full(m - 1, uw / m), ew[None]]))
    r = (uw / m).reshape(1, 1)
    p = dare(model.F, model.g[:, None], q, r)
    pg, pf = p @ model.g, p @ model.F
    k = (pg @ model.F) / (r[0, 0] + model.g @ pg)
    res = model.F.T @ pf - jnp.outer(pf.T @ model.g, k) + q - p  # the DARE residual, SISO form
    res = jnp.max(jnp.abs(res)) / jnp.maximum(1.0, jnp.max(jnp.abs(p)))
    cl_num, cl_den = closed_loop_tf(num, den, k, n, m)
    return dict(
        num=num,
        den=den,
        F=model.F,
        g=model.g,
        d=model.d,
        h=model.h,
        Q=q,
        R=r,
        P=p,
        gains=k,
        cl_num=cl_num,
        cl_den=cl_den,
        ew=ew,
        uw=uw,
        xw=xw,
        dare_residual=res,
    )


def _weight(name, x):
    x = as_float_array(name, x)
    if x.ndim != 0:
        raise ValueError(f"`{name}` must be a scalar weight; got shape {tuple(x.shape)}")
    return x


@x64
def pip_lq(num, den, *, ew=1.0, uw=1.0, xw=1.0, form: str = "feedback") -> PIPDesign:
    r"""PIP-LQ design for a discrete TF $y = B(z^{-1})/A(z^{-1}) u$ (CAPTAIN `pipopt` + `gains`).

    Builds the NMSS model (see `nmss`), the weights spread as CAPTAIN does,

    $$ Q = diag(xw/n, .., xw/n, uw/m, .., uw/m, ew), \quad R = uw/m $$

    ($n$ output states, $m - 1$ past-input states, the integral state), solves the
    DARE for $P$ and returns the LQ gain $k = (R + g'Pg)^{-1} g'PF$ of $u_k = -k x_k$,
    $k = [f_0 .. f_{n-1}, g_1 .. g_{m-1}, -k_I]$, i.e.

    $$ (1 + g_1 z^{-1} + ..) u_k = -(f_0 + f_1 z^{-1} + ..) y_k + k_I z_k, \quad z_k = z_{k-1} + r_k - y_k. $$

    **Arguments:** `num = [0, b1, .., bm]`, `den = [1, a1, .., an]` (monic,
    $b_0 = 0$: at least one sample delay); `ew` (integral-of-error weight), `uw`
    (input weight), `xw` (output-state weight): finite and positive; `form`:
    "feedback" or "forward" (forward-path PIP; the same gains, used by
    `pip_step`/`pip_simulate`). The model must admit integral action:
    $B(1) = b_1 + .. + b_m \ne 0$ (a zero at $z = 1$ would cancel the integrator).

    **Returns** a `PIPDesign` (gains, `named_gains()`, F, g, d, h, Q, R, P,
    `closed_loop_poles`, the nominal closed loop `cl_num`/`cl_den`).
    Differentiable w.r.t. num, den, ew, uw, xw; works under `jax.jit` and
    `jax.vmap` (value checks then become runtime guards). Errors
    (ValueError): bad shapes, non-monic or zero-leading `den`, $b_0 \ne 0$,
    non-positive or NaN weights, $B(1) = 0$, no stabilising solution.

    Example (the paper's model (30), dt = 0.01 s, ew = 10, uw = xw = 1):

    >>> import numpy as np
    >>> from jaxsdp.control import pip_lq
    >>> d = pip_lq([0, 0.0107, -0.0088, 0.0025], [1, -1.8660, 0.8706], ew=10.0)
    >>> print({k: round(float(v), 4) for k, v in d.named_gains().items()})
    {'f0': 69.3047, 'f1': -51.7142, 'g1': -0.4034, 'g2': 0.1485, 'kI': 2.6299}
    >>> print(np.round(np.abs(d.closed_loop_poles), 4))
    [0.8795 0.8795 0.7784 0.     0.    ]
    >>> float(np.round(np.sum(d.cl_num) / np.sum(d.cl_den), 12))  # unity steady-state gain
    1.0
    """
    if form not in FORMS:
        raise ValueError(f"`form` must be one of {FORMS}; got {form!r}")
    num, den = check_plant(num, den)
    weights = [_weight("ew", ew), _weight("uw", uw), _weight("xw", xw)]
    positive = lambda a: ~((a > 0) & (a < np.inf))
    w = check_values(
        [(name, x, positive, "must be finite and positive") for name, x in zip(("ew", "uw", "xw"), weights)],
        carrier=jnp.stack(weights),
    )
    no_integral = lambda a: ~(abs(a[1:].sum()) > INTEGRAL_TOL * abs(a[1:]).sum())
    num = check_values(
        [
            (
                "num",
                num,
                no_integral,
                "B(1) = b1 + .. + bm is 0: a zero at z = 1 cancels the integrator, integral action is impossible",
            )
        ],
        carrier=num,
    )
    model_order = dict(n=den.shape[0] - 1, m=num.shape[0] - 1, form=form)
    design = PIPDesign(**_design(num, den, w), **model_order)
    if is_concrete(design.gains) and not np.all(np.isfinite(np.asarray(design.gains))):
        raise ValueError(
            "no stabilising LQ solution: the NMSS model is not stabilisable "
            "(do A(z^-1) and B(z^-1) share a root on or outside the unit circle?)"
        )
    return design


class PIPState(NamedTuple):
    """The PIP controller's memory between samples (all float64 arrays).

    **Fields:** `y_past` (n,): y_{k-1} .. y_{k-n}, the past measured outputs
    (feedback form) or the internal model's past outputs yhat (forward
    form); `u_past` (m,): the controller's own past outputs u_{k-1} .. u_{k-m};
    `z` (): the integral state z_{k-1}.
    """

    y_past: jax.Array
    u_past: jax.Array
    z: jax.Array


def _shift(past, new):
    return jnp.concatenate([new[None], past[:-1]])


def step(design: PIPDesign, state: PIPState, r, y, loop_gain=1.0, internal=False):
    """One controller sample (traceable, no checks): (u_applied, new state).

    u_PIP = -k x_k, u_applied = loop_gain u_PIP; the state remembers u_applied
    if `internal` (a bool, traced or not) else u_PIP.
    """
    n, m = design.n, design.m
    z = state.z + r - y
    if design.form == "feedback":
        yk = y
    else:  # the internal model's output, from its past outputs and the controller's past inputs
        yk = -design.den[1:] @ state.y_past + design.num[1:] @ state.u_past
    x = jnp.concatenate([yk[None], state.y_past[: n - 1], state.u_past[: m - 1], z[None]])
    u = -(design.gains @ x)
    applied = loop_gain * u
    return applied, PIPState(_shift(state.y_past, yk), _shift(state.u_past, jnp.where(internal, applied, u)), z)


def init_state(design: PIPDesign, y0, loop_gain=1.0, internal=False):
    """Equilibrium state at output y0 (traceable), for the loop gain placement of `step`.

    The plant's equilibrium input is u0 = y0 A(1)/B(1), the law's own output
    u0 / LG; the state remembers u0 (`internal`) or u0 / LG, and the integral
    state makes the law return u0 / LG: z = (u0 / LG + (G(1) - 1) u_mem + F(1) y0) / kI.
    """
    n, m = design.n, design.m
    k = design.gains
    u0 = y0 * jnp.sum(design.den) / jnp.sum(design.num)
    remembered = jnp.where(internal, u0, u0 / loop_gain)
    f1, g1, k_i = jnp.sum(k[:n]), jnp.sum(k[n : n + m - 1]), -k[-1]
    z = (u0 / loop_gain + g1 * remembered + f1 * y0) / k_i
    return PIPState(jnp.full(n, y0), jnp.full(m, remembered), z)


_init_jit = jax.jit(init_state)
_step_jit = jax.jit(step)


@x64
def pip_init(design: PIPDesign, y0=0.0) -> PIPState:
    """The controller state at rest at output y0 (bumpless start): a `PIPState` for `pip_step`.

    Past outputs (measured, or the internal model's in forward form) are $y_0$;
    past inputs the model's equilibrium input $u_0 = y_0 A(1)/B(1)$ (0 for an
    integrating plant, $A(1) = 0$); the integral state is chosen so that with
    $r = y = y_0$ the controller keeps returning $u_0$:
    $z = (G(1) u_0 + F(1) y_0) / k_I$. With $y_0 = 0$ (default) everything is 0.
    Bumpless as it is for a loop gain of 1, and for any loop gain when $y_0 = 0$
    or the model integrates ($A(1) = 0$, so $u_0 = 0$).

    Example:
        >>> from jaxsdp.control import pip_lq, pip_init
        >>> s = pip_init(pip_lq([0.0, 0.5], [1.0, -0.9]))
        >>> print(s.y_past, s.u_past, s.z)
        [0.] [0.] 0.0
    """
    y0 = as_float_array("y0", y0, ndim=0)
    return _init_jit(design, y0)


@x64
def pip_step(design: PIPDesign, state: PIPState, r, y, *, loop_gain=1.0, loop_gain_mode: str = "internal"):
    r"""One sample of the PIP controller: returns ($u_k$, new state); pure, for a `lax.scan`.

    At sample $k$, with reference $r_k$ and measured output $y_k$:

    $$ z_k = z_{k-1} + r_k - y_k $$

    $$ v_k = -k [\tilde y_k .. \tilde y_{k-n+1}, u_{k-1} .. u_{k-m+1}, z_k], \quad u_k = LG \cdot v_k $$

    with $\tilde y = y$ (feedback form) or $\tilde y = \hat y$, the internal model
    $\hat y_k = -a_1 \hat y_{k-1} - .. - a_n \hat y_{k-n} + b_1 u_{k-1} + .. + b_m u_{k-m}$
    (forward-path form, `design.form == "forward"`), and $LG$ = `loop_gain`.
    Apply $u_k$ to the plant between samples $k$ and $k+1$. What the state
    remembers as the past inputs $u_{k-1}$ .. (`loop_gain_mode`):

    - "internal" (default): $u_k$, the plant's input, as the NMSS state
      defines it; the law is then the state feedback $-LG \cdot k x_k$ on the
      plant's own past inputs (and the forward form's internal model is
      driven by them);
    - "serial": $v_k$, the PIP law's own output; LG is a gain block after the
      PIP controller, which does not see it (the same as applying LG to the
      output of `pip_step(..., loop_gain=1.0)`).

    With LG = 1 the two coincide. The "internal" loop tolerates larger LG:
    for the paper's model (30) with ew = 10, uw = xw = 1, the nominal loop
    is stable for LG < 2.15 ("serial") against LG < 5.94 ("internal").
    `r`, `y` and `loop_gain` are scalars; start from `pip_init`.

    Example:
        >>> from jaxsdp.control import pip_lq, pip_init, pip_step
        >>> d = pip_lq([0.0, 0.5], [1.0, -0.9])
        >>> u, s = pip_step(d, pip_init(d), 1.0, 0.0)    # step of 1, output still 0
        >>> bool(abs(u - d.named_gains()["kI"]) < 1e-12), float(s.z)
        (True, 1.0)
    """
    r = as_float_array("r", r, ndim=0)
    y = as_float_array("y", y, ndim=0)
    loop_gain = as_float_array("loop_gain", loop_gain, ndim=0)
    if loop_gain_mode not in LOOP_GAIN_MODES:
        raise ValueError(f"`loop_gain_mode` must be one of {LOOP_GAIN_MODES}; got {loop_gain_mode!r}")
    shapes = tuple(tuple(jnp.shape(x)) for x in state)
    if shapes != ((design.n,), (design.m,), ()):
        raise ValueError(
            f"`state` does not fit this design (n = {design.n}, m = {design.m}): y_past, u_past, z have shapes "
            f"{shapes}, expected (({design.n},), ({design.m},), ()); start from `pip_init(design)`"
        )
    return _step_jit(design, state, r, y, loop_gain, jnp.asarray(loop_gain_mode == "internal"))


class PIPSimulation(NamedTuple):
    """A closed-loop PIP simulation (`pip_simulate`'s result).

    **Fields:** `y` (T,), the plant output $y_k$; `u` (T,), the plant input
    $u_{applied,k}$ = `loop_gain * u_k` (after the loop gain).
    """

    y: jax.Array
    u: jax.Array


@jax.jit
def _simulate(design, num, den, r, loop_gain, internal):
    n, m = den.shape[0] - 1, num.shape[0] - 1

    def body(carry, rk):
        yp, up, cs = carry
        yk = -den[1:] @ yp + num[1:] @ up
        ua, cs = step(design, cs, rk, yk, loop_gain, internal)
        return (_shift(yp, yk), _shift(up, ua), cs), (yk, ua)

    zero = jnp.zeros((), r.dtype)
    init = (jnp.zeros(n, r.dtype), jnp.zeros(m, r.dtype), init_state(design, zero))
    _, (y, u) = jax.lax.scan(body, init, r)
    return PIPSimulation(y=y, u=u)


@x64
def pip_simulate(design: PIPDesign, num, den, r, *, loop_gain=1.0, loop_gain_mode: str = "internal") -> PIPSimulation:
    r"""Simulate the PIP loop on a discrete TF plant $y = B(z^{-1})/A(z^{-1}) u_{applied}$, from rest.

    For $k = 0 .. T-1$: the plant gives $y_k$ from its past ($y_0 = 0$), the
    controller (`pip_step`, in `design.form`) gives $u_k$ from $r_k$ and $y_k$,
    and the plant receives $u_{applied,k}$ = `loop_gain * u_k`. With
    `loop_gain_mode="internal"` (default) it remembers $u_{applied,k}$ (the
    state feedback $-LG \cdot k x_k$ on the plant's own past inputs, $LG$ = `loop_gain`); with
    `"serial"` its own $u_k$ (a gain block after the PIP controller; see
    `pip_step`). The plant
    (`num = [0, b1, ..]`, `den = [1, a1, ..]`, $b_0 = 0$) may be the design's
    model or another one (model mismatch). `r` (T,) is the reference.
    Returns `PIPSimulation(y, u)` with u the applied input. One `lax.scan`;
    differentiable w.r.t. the design's fields, the plant, `r` and
    `loop_gain`, and `vmap`-pable.

    Example (unit step on the paper's model (30): zero steady-state error):

    >>> import numpy as np
    >>> from jaxsdp.control import pip_lq, pip_simulate
    >>> num, den = [0, 0.0107, -0.0088, 0.0025], [1, -1.8660, 0.8706]
    >>> sim = pip_simulate(pip_lq(num, den, ew=10.0), num, den, np.ones(200))
    >>> float(np.round(sim.y[-1], 8))
    1.0
    """
    if loop_gain_mode not in LOOP_GAIN_MODES:
        raise ValueError(f"`loop_gain_mode` must be one of {LOOP_GAIN_MODES}; got {loop_gain_mode!r}")
    num, den = check_plant(num, den, what="plant")
    r = as_float_array("r", r, ndim=1)
    loop_gain = as_float_array("loop_gain", loop_gain, ndim=0)
    return _simulate(design, num, den, r, loop_gain, jnp.asarray(loop_gain_mode == "internal"))
