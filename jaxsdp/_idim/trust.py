"""Checks every study runs before it states a finding, shared so that all studies word them alike.

Each check returns a list of warning strings (empty when nothing is wrong). A
study collects them in its `warnings` list; the command line prints each as
`jaxsdp <study>: warning: ...` on stderr, `report.md` lists them at the top,
and `summary.json` carries them under `"warnings"`. A study whose identified
model fails a physical check words its findings as statements about the fit,
not about the machine (`CAVEAT`).

- `sign_warnings`: parameters that must be positive (mass, inertia) or
  non-negative (viscous and Coulomb friction coefficients).
- `conditioning_warnings`: nearly collinear regressors (condition number of
  the column-normalised regressor matrix) and poorly determined parameters
  (relative standard deviation above `max_rel_std` %).
- `asymmetry_test`: is the viscous friction asymmetric (Fv-/Fv+ away from 1)?
- `nvr_text`: one wording for an NVR with its standard error, used on the
  console and in the report alike (an NVR on a bound has no standard error).
"""

import math

import jax.numpy as jnp
import numpy as np

#: Prefix of findings stated while a physical check failed.
CAVEAT = (
    "Caution: the identified model is physically implausible (see the warnings); "
    "the findings below describe the fit, not the machine."
)

#: Condition number of the column-normalised regressors above which a warning is given.
MAX_COND = 1e3

#: Relative standard deviation (%) above which a physical parameter is called poorly determined.
MAX_REL_STD = 10.0

#: log10-NVR standard errors above this many decades are reported as a flat likelihood.
FLAT_SE = 3.0


def _named(result) -> dict:
    th = np.asarray(result.theta, dtype=float)
    sd = np.asarray(result.std, dtype=float)
    return {n: (float(v), float(s)) for n, v, s in zip(result.names, th, sd)}


def sign_warnings(result, *, label: str, positive=(), nonnegative=(), units=None) -> list[str]:
    """Physically impossible signs in an `IDIMResult`-like result (fields `names`, `theta`, `std`).

    `positive`: names that must be > 0 (mass, inertia); `nonnegative`: names
    that must be >= 0 (friction coefficients); `units`: name -> unit string.
    Returns at most one warning for the model, listing every offending parameter.
    """
    units = {} if units is None else units
    named = _named(result)

    def show(name):
        v, s = named[name]
        return f"{name} = {v:.4g} {units.get(name, '')}".rstrip()

    bad_pos = [show(n) for n in positive if not named[n][0] > 0]
    bad_neg = [show(n) for n in nonnegative if named[n][0] < 0]
    if not bad_pos and not bad_neg:
        return []
    parts = []
    if bad_pos:
        parts.append(", ".join(bad_pos) + " (must be > 0)")
    if bad_neg:
        parts.append(", ".join(bad_neg) + " (friction must be >= 0)")
    checked = len(positive) + len(nonnegative)
    hint = (
        "every sign is inverted: check the sign of the force/torque signal (e.g. the drive gain `gtau`) "
        "against the position direction"
        if len(bad_pos) + len(bad_neg) == checked and checked > 1
        else "a model or data problem (unmodelled effects, poor excitation, wrong units)"
    )
    return [f"{label}: physically impossible parameters: {'; '.join(parts)}; {hint}"]


def normalised_cond(X) -> float:
    """Condition number of `X` with each column scaled to unit norm (scale-free collinearity)."""
    X = np.asarray(X, dtype=float)
    norms = np.linalg.norm(X, axis=0)
    if not np.all(norms > 0):
        return math.inf
    s = np.linalg.svd(X / norms, compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0 else math.inf


def conditioning_warnings(result, X, *, label: str, check=(), max_cond=MAX_COND, max_rel_std=MAX_REL_STD):
    """Nearly collinear regressors `X` and poorly determined parameters among `check`."""
    out = []
    c = normalised_cond(X)
    if not c <= max_cond:
        out.append(
            f"{label}: the regressors are nearly collinear (condition number {c:.3g} after scaling the columns, "
            f"above {max_cond:g}): the parameters are poorly identifiable; excite the system more richly"
        )
    rel = dict(zip(result.names, np.asarray(result.rel_std, dtype=float)))
    for name in check:
        if not rel[name] <= max_rel_std:
            out.append(
                f"{label}: {name} is poorly determined (relative standard deviation {rel[name]:.3g} % > "
                f"{max_rel_std:g} %)"
            )
    return out


def nvr_bound(nvr: float, *, max_nvr, lower_log10: float) -> str | None:
    """ "upper", "lower" or None: is `nvr` on the cap `max_nvr` or the search's lower bound?"""
    if max_nvr is not None and nvr >= max_nvr * (1 - 1e-9):
        return "upper"
    if nvr > 0 and math.log10(nvr) <= lower_log10 + 1e-6:
        return "lower"
    return None


def nvr_text(nvr: float, se: float, bound: str | None, *, max_nvr=None) -> str:
    """One wording of an NVR and its log10 standard error, for the console and the report."""
    v = f"{nvr:.3g}"
    if bound == "upper":
        return f"{v} (at its cap max_nvr = {max_nvr:g}: the likelihood still rises, so no standard error)"
    if bound == "lower":
        return f"{v} (at the search's lower bound: no standard error)"
    if se is None or (isinstance(se, float) and math.isnan(se)):
        return f"{v} (fixed)"
    if not se <= FLAT_SE:
        return f"{v} (flat likelihood: log10 s.e. over {FLAT_SE:g} decades)"
    return f"{v} (log10 s.e. {se:.2f})"


def bound_advice(term: str, bound: str, *, option: str = "`max_nvr`") -> str:
    """What a user can do about an NVR on a bound; `option`: where the cap is set for the study at hand (an
    argument in backquotes, which the command line writes as its option)."""
    if bound == "upper":
        return (
            f"NVR of {term} is at its cap: the likelihood would take it higher (the curve follows the data as "
            f"closely as allowed); raise the cap ({option}) to see where it goes, or use an IRW model for a "
            "smoother curve"
        )
    return f"NVR of {term} is at the lower search bound: the parameter is constant in its state"


#: |Fv-/Fv+ - 1| must exceed this many standard errors, and `ASYMMETRY_MIN`, to call the friction asymmetric.
ASYMMETRY_Z = 3.0
ASYMMETRY_MIN = 0.05


def asymmetry_test(theta, cov, *, i: int = 1, j: int = 3):
    """Fv-/Fv+ of the asymmetric friction model with its delta-method standard error, and the verdict.

    r = theta_j / theta_i (Fv_neg / Fv_pos at indices `j`, `i` of eq. 17's
    M, Fv_pos, Fc_pos, Fv_neg, Fc_neg), var r = r^2 (C_jj / theta_j^2 +
    C_ii / theta_i^2 - 2 C_ij / (theta_i theta_j)); asymmetric when
    |r - 1| > max(3 se, 0.05). Works on numpy and JAX arrays (under jit and vmap).

    Returns `(r, se, asymmetric)`.
    """
    a, b = theta[i], theta[j]
    r = b / a
    var = r**2 * (cov[j, j] / b**2 + cov[i, i] / a**2 - 2 * cov[i, j] / (a * b))
    se = jnp.sqrt(jnp.maximum(var, 0.0))
    return r, se, jnp.abs(r - 1.0) > jnp.maximum(ASYMMETRY_Z * se, ASYMMETRY_MIN)
