"""The EMPS friction law read off the SDP curve (issue 45, item 4): candidates fitted with the mass and the offset,
chosen by BIC, cross-validated against the paper's asymmetric linear law, compared with the SDP curve."""

import equinox as eqx
import numpy as np

from ..._runtime import x64
from ..._signal.preprocess import Preprocessed
from .._friction_laws import LAWS, AsymmetricCoulomb, FrictionLaw, cross_validate_friction, fit_friction

#: Rows slower than this fraction of the peak speed are left out (as the robot study's rest rule).
REST_FRACTION = 0.01

#: The linear law the chosen one is cross-validated against: the paper's eq. 17 (with the offset).
REFERENCE_LAW = AsymmetricCoulomb()


class EMPSFriction(eqx.Module):
    """The EMPS friction law (`emps_friction`).

    **Fields:** `chosen` (the law's class name), `fits` (`FrictionFit` per candidate, `M` kg and `offset` N first),
    `cross_validated` (law -> held-out relative error %, two blocks of time: the chosen law and the asymmetric
    linear one), on the rows in motion, `curve_mismatch` (law -> rms of law + offset minus the SDP friction curve
    over the rms of the curve, %: how well the law reads Fig. 4's curve; None without a curve), `criterion` ("BIC",
    or "given" for one law).
    """

    chosen: str = eqx.field(static=True)
    fits: tuple
    cross_validated: dict = eqx.field(static=True)
    curve_mismatch: dict = eqx.field(static=True)
    criterion: str = eqx.field(static=True, default="BIC")

    @x64
    def summary(self) -> dict:
        """JSON-ready: `chosen`, `criterion`, `laws` (law -> `parameters` {name: {value, std}}, `bic`,
        `relative_error` %, `curve_mismatch` %, `converged`), `cross_validated` (law -> held-out relative error %)."""
        laws = {}
        for f in self.fits:
            values, std = f.as_dict(), np.asarray(f.std, dtype=float)
            laws[f.law] = {
                "parameters": {k: {"value": v, "std": float(s)} for (k, v), s in zip(values.items(), std)},
                "bic": float(f.bic),
                "relative_error": float(f.relative_error),
                "curve_mismatch": self.curve_mismatch.get(f.law),
                "converged": bool(f.converged),
            }
        cross = self.cross_validated
        return {"chosen": self.chosen, "criterion": self.criterion, "laws": laws, "cross_validated": cross}

    @x64
    def fit(self, law: str | None = None):
        """The `FrictionFit` of `law` (a class name; default the chosen one)."""
        name = self.chosen if law is None else law
        for f in self.fits:
            if f.law == name:
                return f
        raise KeyError(f"no fit of {name!r}; fitted: {[f.law for f in self.fits]}")


@x64
def emps_friction(
    inputs: Preprocessed, *, laws=LAWS, curve=None, folds: int = 2, rest_fraction: float = REST_FRACTION
) -> EMPSFriction:
    r"""The EMPS axis's friction law: $y = M \ddot q + o + f(\dot q; p) + e$ on the decimated rows in motion, for each
    law of `laws` (a tuple of `FrictionLaw`s: the one of least BIC is chosen; one law: that law), then the held-out
    error of the chosen law and of the asymmetric linear law (eq. 17, `AsymmetricCoulomb` with the offset) in
    `folds` blocks of time. `curve`: the SDP stage's friction curve $d(\dot q_k)$ (N, time order) to compare each
    law with.
    Rows with $|\dot q|$ below `rest_fraction` of its peak are left out (1 %, the robot study's rest rule): the
    zero-phase filter smears each Coulomb step around a reversal, where the processed velocity's sign is not the
    friction's, and a smooth law fits that smear (measured: with those rows BIC chose Stribeck's law on the built-in
    plant, whose friction is linear; without them the asymmetric linear law, and Stribeck's on a Stribeck plant).

    **Returns:** an `EMPSFriction` (`summary()` its JSON-ready dict).

    Example:
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.plants.emps import emps_friction, emps_preprocess
        >>> data, truth, _ = emps_builtin_data(0)  # the built-in plant: asymmetric linear friction
        >>> out = emps_friction(emps_preprocess(data))
        >>> out.chosen, round(out.fit().as_dict()["M"], 1)
        ('AsymmetricCoulomb', 95.4)
    """
    if not isinstance(inputs, Preprocessed):
        raise ValueError(f"`inputs` must be a Preprocessed (emps_preprocess); got {type(inputs).__name__}")
    laws = (laws,) if isinstance(laws, FrictionLaw) else tuple(laws)
    if not laws or not all(isinstance(law, FrictionLaw) for law in laws):
        raise ValueError(f"`laws` must be a FrictionLaw or a tuple of them; got {laws!r}")
    if isinstance(rest_fraction, bool) or not isinstance(rest_fraction, (int, float)) or not 0 <= rest_fraction < 1:
        raise ValueError(f"`rest_fraction` must be a fraction in [0, 1); got {rest_fraction!r}")
    y, dq, ddq = (np.asarray(a, dtype=float) for a in (inputs.y, inputs.dq, inputs.ddq))
    moving = np.abs(dq) >= rest_fraction * np.max(np.abs(dq))
    y, dq, ddq = y[moving], dq[moving], ddq[moving]
    X = np.c_[ddq, np.ones_like(ddq)]
    fits = tuple(fit_friction(y, X, dq, law, names=("M", "offset")) for law in laws)
    best = min(range(len(fits)), key=lambda k: float(fits[k].bic))
    chosen = fits[best].law
    cross = {chosen: cross_validate_friction(y, X, dq, laws[best], folds=folds)}
    if type(REFERENCE_LAW).__name__ not in cross:
        cross[type(REFERENCE_LAW).__name__] = cross_validate_friction(y, X, dq, REFERENCE_LAW, folds=folds)
    mismatch = {}
    for law, fit in zip(laws, fits):
        if curve is None:
            mismatch[fit.law] = None
            continue
        d = np.asarray(curve, dtype=float)[moving]
        f = np.asarray(law(dq, fit.raw)) + float(fit.theta[1])
        mismatch[fit.law] = float(100 * np.sqrt(np.mean((f - d) ** 2)) / np.sqrt(np.mean(d**2)))
    return EMPSFriction(
        chosen=chosen,
        fits=fits,
        cross_validated=cross,
        curve_mismatch=mismatch,
        criterion="BIC" if len(laws) > 1 else "given",
    )
