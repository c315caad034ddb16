"""The SDP control model of the EMPS (paper eqs. 26-27) and the friction forms its controllers use.

Direct dynamic model (eq. 26), position q (m), drive force tau (N):

    ddq = c1 dq + c2 sign(dq) + c3 + c4 tau,
    c1 = -Fv/M (1/s), c2 = -Fc/M (m/s^2), c3 = -offset/M (m/s^2), c4 = 1/M (1/kg).

Written as an SDP model (eq. 27), x = c4 / (p (p + a_sdp)) u, i.e.

    ddq + a_sdp(dq) dq = c4 tau,       a_sdp(dq) dq = f(dq) / M,

where f is the friction force (N, including Coulomb and offset terms). The
product a_sdp(dq) dq is finite at dq = 0 while a_sdp itself is not (Coulomb
friction gives a_sdp ~ Fc / (M |dq|)), so everything here is built on the
product `SDPControlModel.a_dq(dq) = c4 f(dq)`; nothing divides by dq.

**The friction the controller uses** is any `jaxsdp.plants.AbstractFriction`,
the interface the plant simulators also accept. `sdp_friction` builds the
three forms of the paper's section 4.1 from a friction SDP estimate (the
sorted velocities and the SDP friction curve):

- `form="tabulated"`: non-parametric, the SDP curve itself (bin means on
  equal-count velocity bins, linear interpolation), held constant beyond
  the data (extrapolating the end slopes of an SDP curve, its noisiest part,
  can give friction that falls, even changes sign, at high speed);
- `form="hybrid"` (Fig. 13): the SDP curve inside the measured velocity
  range and, beyond it, straight lines fitted by least squares to the outer
  `fit_fraction` of each side of the curve (the end knots are moved onto
  the lines, so the curve is continuous);
- parametric (eq. 17): `jaxsdp.plants.AsymmetricFriction` from the IDIM-SDP
  estimates, used as it is.

Note on the paper's c2: its Table 1 (Fc 20.53 N, M 95.08 kg) gives
c2 = -0.2159, not the printed -0.2123 (which is Fc+ of Table 2 over M);
c1, c3 and c4 match the printed values.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._checks import POSITIVE, is_concrete
from .._runtime import x64
from ..plants._friction import AbstractFriction, LinearFriction, TabulatedFriction
from ..plants._parameters import parameter

FRICTION_FORMS = ("tabulated", "hybrid")


class SDPControlModel(eqx.Module):
    r"""The EMPS control model $\ddot q = c_1 \dot q + c_2 sign(\dot q) + c_3 + c_4 \tau$, in SDP form.

    In SDP form the model reads $\ddot q + a_{sdp}(\dot q) \dot q = c_4 \tau$.

    **Fields:** `c1` (1/s), `c2`, `c3` (m/s^2), `c4` (1/kg) from a linear
    IDIM-LS model ($c_1 = -F_v/M$, $c_2 = -F_c/M$, $c_3 = -offset/M$, $c_4 = 1/M$), and
    `friction`, the friction law $f$ (N) the controller compensates: by default
    the linear law of the same IDIM-LS model (then `a_dq` reproduces eq. 26
    exactly), or an SDP-based form from `sdp_friction`.

    `a_dq(dq)` is the product $a_{sdp}(\dot q) \dot q = c_4 f(\dot q)$ (m/s^2), finite at
    $\dot q = 0$; `a_sdp(dq)` (1/s) divides by $\dot q$ and is for plots only (NaN at 0).

    Example:
        >>> from jaxsdp.control import control_model
        >>> mdl = control_model(dict(M=95.08, Fv=202.30, Fc=20.53, offset=-3.19))
        >>> [round(float(c), 4) for c in (mdl.c1, mdl.c2, mdl.c3, mdl.c4)]
        [-2.1277, -0.2159, 0.0336, 0.0105]
        >>> round(float(mdl.a_dq(0.1)), 4)  # a_sdp(0.1) * 0.1, m/s^2
        0.3951
    """

    c1: jax.Array
    c2: jax.Array
    c3: jax.Array
    c4: jax.Array
    friction: AbstractFriction

    @property
    @x64
    def mass(self):
        """1 / c4 (kg)."""
        return 1.0 / self.c4

    @x64
    def a_dq(self, dq):
        """a_sdp(dq) dq = c4 f(dq) (m/s^2): the friction deceleration, finite at dq = 0."""
        return self.c4 * self.friction(dq)

    @x64
    def a_sdp(self, dq):
        """a_sdp(dq) = c4 f(dq) / dq (1/s), for plots; NaN at dq = 0."""
        dq = jnp.asarray(dq)
        safe = jnp.where(dq == 0, 1.0, dq)
        return jnp.where(dq == 0, jnp.nan, self.a_dq(dq) / safe)


def _linear_params(idim):
    names = ("M", "Fv", "Fc", "offset")
    if isinstance(idim, dict):
        missing = [n for n in names if n not in idim]
        if missing:
            raise ValueError(f"the IDIM-LS parameters need {list(names)}; missing {missing}")
        return [idim[n] for n in names]
    try:
        return [idim[n] for n in names]
    except (KeyError, TypeError):
        raise ValueError(
            "`idim` must be a linear-friction IDIM-LS result (parameters M, Fv, Fc, offset) or a dict of them"
        ) from None


@x64
def control_model(idim, *, friction: AbstractFriction | None = None) -> SDPControlModel:
    """Build the SDP control model (eqs. 26-27) from an IDIM-LS estimate.

    **Arguments:**

    - `idim`: an `IDIMResult` of the linear friction model (parameters M kg,
      Fv N/(m/s), Fc N, offset N), or a dict with those keys.
    - `friction`: the friction law the controller compensates (N); default
      the linear law of `idim`. Use `sdp_friction` for the SDP forms, or a
      `jaxsdp.plants.AsymmetricFriction` for the parametric eq. (17).

    **Returns:** an `SDPControlModel` with $c_1 = -F_v/M$, $c_2 = -F_c/M$,
    $c_3 = -offset/M$, $c_4 = 1/M$.

    Example:
        >>> from jaxsdp.control import control_model
        >>> mdl = control_model(dict(M=95.08, Fv=202.30, Fc=20.53, offset=-3.19))
        >>> round(float(mdl.mass), 2)  # kg
        95.08
    """
    m, fv, fc, off = _linear_params(idim)
    m = parameter("M", m, POSITIVE)
    fv, fc, off = parameter("Fv", fv), parameter("Fc", fc), parameter("offset", off)
    if friction is None:
        try:  # LinearFriction checks Fv >= 0 and Fc >= 0 itself; say which model is at fault
            friction = LinearFriction(fv, fc, off)
        except ValueError:
            raise ValueError(
                f"IDIM-LS friction must have Fv >= 0 and Fc >= 0 (got Fv {fv}, Fc {fc}): check the model"
            ) from None
    if not isinstance(friction, AbstractFriction):
        raise ValueError(f"`friction` must be a friction law (AbstractFriction); got {type(friction).__name__}")
    return SDPControlModel(c1=-fv / m, c2=-fc / m, c3=-off / m, c4=1.0 / m, friction=friction)


def _bin_means(v, f, n_bins):
    """Means of (v, f) over `n_bins` equal-count bins of the sorted `v`."""
    edges = np.linspace(0, v.size, min(n_bins, v.size) + 1).round().astype(int)
    vm = np.array([v[a:b].mean() for a, b in zip(edges[:-1], edges[1:]) if b > a])
    fm = np.array([f[a:b].mean() for a, b in zip(edges[:-1], edges[1:]) if b > a])
    return vm, fm


def _line_fit(v, f):
    """Least-squares line f ~ c + k v (numpy lstsq: two columns, well scaled)."""
    x = np.c_[np.ones_like(v), v]
    (c, k), *_ = np.linalg.lstsq(x, f, rcond=None)
    return c, k


@x64
def sdp_friction(
    velocity, friction, *, form: str = "hybrid", knots: int = 40, fit_fraction: float = 0.4, max_gap: float = 0.1
) -> TabulatedFriction:
    """A friction law for control and simulation from an SDP friction curve (paper section 4.1, Fig. 13).

    **Arguments:**

    - `velocity`: (N,) velocities (m/s) at which the SDP curve is known, e.g.
      `SDPResult.x_sorted[j]` for the friction term j (any order).
    - `friction`: (N,) the SDP friction estimate there (N), e.g.
      `SDPResult.par_sorted[j]`.
    - `form`: `"hybrid"` (default, the paper's Fig. 13: the SDP curve inside
      the measured range, straight lines fitted on each side beyond it) or
      `"tabulated"` (the SDP curve alone, held constant beyond the data).
    - `knots`: knots per side of zero (bin means over equal-count bins of the
      sorted velocities; averages out the SDP curve's sample noise).
    - `fit_fraction`: for `"hybrid"`, the outer fraction of each side's
      velocity range used for the line fit.
    - `max_gap`: the largest allowed gap between consecutive velocities, as a
      fraction of the velocity range: a curve with a gap has no estimate there,
      and interpolating across it would be a guess (ValueError).

    **Returns:** a `jaxsdp.plants.TabulatedFriction` (continuous, no Coulomb
    jump: the SDP curve crosses zero velocity continuously).

    Both sides of zero need data (at least `2 * knots` samples each).

    Example:
        >>> import numpy as np
        >>> from jaxsdp.control import sdp_friction
        >>> v = np.linspace(-0.2, 0.2, 801)
        >>> f = np.where(v > 0, 170 * v + 20, 240 * v - 20) * (1 - np.exp(-np.abs(v) / 0.005))
        >>> law = sdp_friction(v, f)
        >>> round(float(law(0.5)), 1), round(float(law(-0.5)), 1)  # N, beyond the data: fitted lines
        (105.0, -140.0)
    """
    if form not in FRICTION_FORMS:
        raise ValueError(f"`form` must be one of {FRICTION_FORMS}; got {form!r}")
    if not is_concrete(velocity) or not is_concrete(friction):
        raise ValueError("`sdp_friction` builds a table from concrete data; call it outside jit/vmap")
    v = np.asarray(velocity, dtype=np.float64)
    f = np.asarray(friction, dtype=np.float64)
    if v.ndim != 1 or f.shape != v.shape:
        raise ValueError(f"`velocity` and `friction` must be 1-D of equal length; got {v.shape} and {f.shape}")
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(f))):
        raise ValueError("the SDP friction curve contains NaN or inf")
    if not (isinstance(knots, int) and knots >= 2):
        raise ValueError(f"`knots` must be an int >= 2; got {knots!r}")
    if not (0 < fit_fraction <= 1) or not (0 < max_gap < 1):
        raise ValueError(f"`fit_fraction` must be in (0, 1] and `max_gap` in (0, 1); got {fit_fraction}, {max_gap}")
    order = np.argsort(v, kind="stable")
    v, f = v[order], f[order]
    span = v[-1] - v[0]
    neg, pos = v < 0, v > 0
    if neg.sum() < 2 * knots or pos.sum() < 2 * knots:
        raise ValueError(
            f"the SDP friction curve needs at least {2 * knots} samples on each side of zero velocity "
            f"(got {int(neg.sum())} negative, {int(pos.sum())} positive): the controller would extrapolate blindly"
        )
    gaps = np.diff(v)
    i = int(np.argmax(gaps))
    if gaps[i] > max_gap * span:
        raise ValueError(
            f"the SDP friction curve has a gap from {v[i]:.4g} to {v[i + 1]:.4g} m/s "
            f"({100 * gaps[i] / span:.0f} % of its range, more than max_gap = {100 * max_gap:.0f} %): "
            "no friction estimate there; use data that cover the velocities, or raise max_gap knowingly"
        )
    vn, fn = _bin_means(v[neg], f[neg], knots)
    vp, fp = _bin_means(v[pos], f[pos], knots)
    if form == "hybrid":
        lo, hi = v[0], v[-1]
        wn = v[neg] <= (1 - fit_fraction) * lo
        wp = v[pos] >= (1 - fit_fraction) * hi
        cn, kn = _line_fit(v[neg][wn], f[neg][wn])
        cp, kp = _line_fit(v[pos][wp], f[pos][wp])
        far = 10 * span  # far knots on the lines: the end segments then have exactly the fitted slopes
        vn = np.r_[lo - far, lo, vn[1:]]
        fn = np.r_[cn + kn * (lo - far), cn + kn * lo, fn[1:]]
        vp = np.r_[vp[:-1], hi, hi + far]
        fp = np.r_[fp[:-1], cp + kp * hi, cp + kp * (hi + far)]
    else:  # held constant beyond the data: the end segments of an SDP curve are its noisiest part
        far = 10 * span
        vn, fn = np.r_[vn[0] - far, vn], np.r_[fn[0], fn]
        vp, fp = np.r_[vp, vp[-1] + far], np.r_[fp, fp[-1]]
    return TabulatedFriction(np.r_[vn, vp], np.r_[fn, fp])
