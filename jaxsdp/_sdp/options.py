r"""How the SDP back-fitting finds its NVRs, as option objects (the optimistix way, not strings).

- `MLNVR(nvr0, max_nvr, optimise_on)`: maximum likelihood by gradient (BFGS on
  $\log_{10} NVR$, exact gradients), from `nvr0`, capped at `max_nvr`
  (`jaxsdp.sdp`'s default search). Pure: it jits, vmaps and differentiates.
- `FixedNVR(nvr)`: the NVRs given, one per term (no search).
- `CaptainNVR(nvr0, max_nvr)`: the CAPTAIN toolbox's search (Nelder-Mead on
  $\log_{10} NVR$ of the first sweep's concentrated likelihood, term by term,
  `captain_nvrs`), run on the host before the back-fitting, which then fixes
  the NVRs it found. Eager only: not jittable.

- `Backfitting(model, nvr, ...)`: the whole back-fitting as one object,
  `Backfitting(...)(y, z, x)` = `jaxsdp.sdp(y, z, x, ...)`, the SDP stage
  of a pipeline.
"""

import equinox as eqx
import jax
import numpy as np

from .._kalman.models import RW, ParameterModel, as_models
from .._runtime import x64
from .backfit import CONSTANT_NVR, SDPResult, sdp
from .captain import captain_nvrs

__all__ = ["MLNVR", "FixedNVR", "CaptainNVR", "Backfitting"]


def _fixed_nvrs(v) -> tuple | None:
    """`fixed` of an NVR search as a tuple of floats (NaN where searched), or None."""
    return None if v is None else tuple(float(x) for x in np.atleast_1d(v))


def _check_search(search) -> None:
    """The fields an NVR search shares (`MLNVR`, `CaptainNVR`): `nvr0` > 0, `max_nvr` None or > 0, `fixed` NaN
    or finite NVRs >= 0; a ValueError naming the field."""
    if not (isinstance(search.nvr0, (int, float)) and 0 < search.nvr0 < np.inf):
        raise ValueError(f"`nvr0` must be a finite number > 0; got {search.nvr0!r}")
    if search.max_nvr is not None and not (isinstance(search.max_nvr, (int, float)) and 0 < search.max_nvr < np.inf):
        raise ValueError(f"`max_nvr` must be None or a finite number > 0; got {search.max_nvr!r}")
    if search.fixed is not None and not all(np.isnan(v) or 0 <= v < np.inf for v in search.fixed):
        raise ValueError(f"`fixed` must hold NaN (searched) or finite NVRs >= 0; got {search.fixed!r}")


class MLNVR(eqx.Module):
    r"""NVRs by maximum likelihood: a gradient search on $\log_{10} NVR$ from `nvr0`, capped at `max_nvr` (None:
    no cap); `optimise_on` "first" (on the first back-fitting sweep, CAPTAIN's procedure) or "all" (every sweep);
    `fixed`: None (every NVR searched), or one value per term with NaN where the NVR is searched. The `nvr` of
    `Backfitting`, `jaxsdp.sdp` and `jaxsdp.multi_sdp`."""

    nvr0: float = eqx.field(static=True, default=1e-4)
    max_nvr: float | None = eqx.field(static=True, default=1.0)
    optimise_on: str = eqx.field(static=True, default="first")
    fixed: tuple | None = eqx.field(static=True, default=None, converter=_fixed_nvrs)

    def __check_init__(self):
        _check_search(self)
        if self.optimise_on not in ("first", "all"):
            raise ValueError(f"`optimise_on` must be 'first' or 'all'; got {self.optimise_on!r}")

    def _sdp_options(self, y=None, z=None, x=None, *, model=None, P0=None) -> dict:
        """The search's settings as `sdp`'s check takes them (the data are not needed)."""
        nvr = None if self.fixed is None else np.asarray(self.fixed)
        return dict(nvr=nvr, nvr0=float(self.nvr0), max_nvr=self.max_nvr, optimise_on=self.optimise_on)


class FixedNVR(eqx.Module):
    """NVRs fixed at `nvr` (one per term, each >= 0, dimensionless: the parameter's random-walk variance over the
    observation noise variance); no search."""

    nvr: tuple = eqx.field(static=True, converter=lambda v: tuple(float(x) for x in np.atleast_1d(v)))

    def __check_init__(self):
        if not all(0 <= v < np.inf for v in self.nvr):
            raise ValueError(f"`nvr` must hold finite numbers >= 0; got {self.nvr!r}")

    def _sdp_options(self, y=None, z=None, x=None, *, model=None, P0=None) -> dict:
        """The fixed NVRs as `sdp`'s check takes them."""
        return dict(nvr=np.asarray(self.nvr), max_nvr=None)


class CaptainNVR(eqx.Module):
    r"""NVRs by the CAPTAIN toolbox's search (`captain_nvrs`): for each term in order, the concentrated likelihood
    of its sorted partial residual on the first back-fitting sweep minimised over $\log_{10} NVR$ by Nelder-Mead
    (MATLAB `fminsearch`'s simplex, from `nvr0`, tolerance 0.01), capped at `max_nvr` (None: no cap); `fixed`:
    None (every NVR searched), or one value per term with NaN where the NVR is searched.

    The search runs on the host (scipy), before the back-fitting, which then runs with the NVRs it found fixed
    (`Backfitting.searched`): eager only, it neither jits nor differentiates. It finds the local optimum the
    toolbox (and the EMPS paper) finds, where `MLNVR`'s gradient search may go elsewhere.

    Example:
        >>> import numpy as np, jaxsdp
        >>> rng = np.random.default_rng(0)
        >>> x = rng.uniform(-2, 2, (300, 1))
        >>> y = 1.0 + 0.5 * x[:, 0] ** 2 + 0.05 * rng.normal(size=300)  # c(x) = 1 + x^2 / 2, z = 1
        >>> res = jaxsdp.Backfitting(nvr=jaxsdp.CaptainNVR())(y, np.ones((300, 1)), x)
        >>> bool(res.nvr[0] > 1e-6)
        True
    """

    nvr0: float = eqx.field(static=True, default=1e-4)
    max_nvr: float | None = eqx.field(static=True, default=1.0)
    fixed: tuple | None = eqx.field(static=True, default=None, converter=_fixed_nvrs)

    def __check_init__(self):
        _check_search(self)

    def _sdp_options(self, y, z, x, *, model, P0) -> dict:
        """The search run on the host (eager only), its NVRs as fixed NVRs for `sdp`."""
        if any(isinstance(a, jax.core.Tracer) for a in (y, z, x)):
            raise ValueError(
                "CaptainNVR searches on the host and cannot be traced (jit, vmap, grad): run "
                "Backfitting.searched(y, z, x) outside the transformation and use the options it returns"
            )
        return self._search(y, z, x, model=model, P0=P0)[0]._sdp_options()

    def _search(self, y, z, x, *, model, P0) -> tuple[FixedNVR, np.ndarray]:
        """(`FixedNVR` of the NVRs found, their curvature standard errors of log10 NVR), on the host."""
        nvr = None if self.fixed is None else np.asarray(self.fixed)
        nvrs, se = captain_nvrs(y, z, x, model=model, nvr=nvr, nvr0=self.nvr0, max_nvr=self.max_nvr, P0=P0)
        return FixedNVR(nvrs), se


class Backfitting(eqx.Module):
    r"""SDP back-fitting options (`jaxsdp.sdp`): `model` (a `ParameterModel`, e.g. `jaxsdp.RW()`, or one per
    term), `nvr` (`MLNVR()`, `FixedNVR(...)` or `CaptainNVR()`), `max_sweeps`, `tol` (the $R^2$ convergence
    test), `P0` (the initial state variance), `constant_nvr` (NVRs below it call a term constant).

    `Backfitting(...)(y, z, x)` returns the `SDPResult` of
    $y_k = \sum_j c_j(x_{jk}) z_{jk} + e_k$; pure (jit, vmap, grad), except with `CaptainNVR`, whose search runs
    on the host first (`searched`).
    """

    model: ParameterModel | tuple = RW()
    nvr: MLNVR | FixedNVR | CaptainNVR = MLNVR()
    max_sweeps: int = eqx.field(static=True, default=10)
    tol: float = eqx.field(static=True, default=1e-3)
    P0: float = eqx.field(static=True, default=1e5)
    constant_nvr: float = eqx.field(static=True, default=CONSTANT_NVR)

    def __check_init__(self):
        as_models(self.model, 1 if isinstance(self.model, ParameterModel) else len(self.model))
        if not isinstance(self.nvr, (MLNVR, FixedNVR, CaptainNVR)):
            raise ValueError(
                f"`nvr` must be jaxsdp.MLNVR(...), jaxsdp.FixedNVR(...) or jaxsdp.CaptainNVR(...); got {self.nvr!r}"
            )

    @property
    @x64
    def max_nvr(self) -> float | None:
        """The cap on the NVRs (None: none, or fixed NVRs)."""
        return self.nvr.max_nvr if isinstance(self.nvr, (MLNVR, CaptainNVR)) else None

    @x64
    def searched(self, y, z, x) -> tuple["Backfitting", np.ndarray | None]:
        r"""With `CaptainNVR`: its host-side search on (y, z, x), and these options with the NVRs found fixed
        (`FixedNVR`) and the search's curvature standard errors of $\log_{10} NVR$; otherwise `(self, None)`."""
        if not isinstance(self.nvr, CaptainNVR):
            return self, None
        fixed, se = self.nvr._search(y, z, x, model=self.model, P0=self.P0)
        return eqx.tree_at(lambda b: b.nvr, self, fixed), se

    @x64
    def __call__(self, y, z, x) -> SDPResult:
        return self._fit(y, z, x)

    def _fit(self, y, z, x) -> SDPResult:
        """`__call__` without the float64 entry wrapper, for pipelines (already inside it)."""
        if isinstance(self.nvr, CaptainNVR):
            if any(isinstance(a, jax.core.Tracer) for a in (y, z, x)):
                raise ValueError(
                    "CaptainNVR searches on the host and cannot be traced (jit, vmap, grad): run "
                    "Backfitting.searched(y, z, x) outside the transformation and use the options it returns"
                )
            return self.searched(y, z, x)[0]._fit(y, z, x)
        return sdp.__wrapped__(
            y,
            z,
            x,
            model=self.model,
            max_sweeps=self.max_sweeps,
            tol=self.tol,
            P0=self.P0,
            constant_nvr=self.constant_nvr,
            nvr=self.nvr,
        )
