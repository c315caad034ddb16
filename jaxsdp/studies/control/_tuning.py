"""The control study's gradient tuning of the PIP-SDP cascade on the real drive, and its convergence test.

**What is tuned:** the SDP-PD inner loop's `wn` (rad/s) and `eta`, the loop
gain LG and the PIP-LQ weights `ew`, `xw` (`uw` sets the weights' scale),
to minimise the study's step cost on the real drive (one-sample delay,
+-351.5 N): the integrated absolute error plus the velocity-limit penalty.

**Scaling:** the cost is divided by the hand-tuned design's (1 at that
design, dimensionless), and each parameter's logarithm u is mapped onto its
range by a logistic function, u = lo + (hi - lo) sigmoid(z), so that BFGS
moves the unconstrained z and every parameter stays within its bounds
(`tuning_bounds`): `wn` from wn_real / 100 to `WN_HEADROOM` wn_real (wn_real:
the largest wn whose overshoot stays under 2 % with the drive's delay),
`eta` in `ETA_RANGE`, LG, `ew` and `xw` within a factor `RANGE_FACTOR` of
the hand-tuned design's. With only a factor-100 box on every parameter,
BFGS strayed into inner loops the delay makes unstable and stopped there
(built-in data, start 30 rad/s: wn 922 rad/s, eta 60, the drive saturated,
a gradient of 3e29).

**Solver:** `optimistix.BFGS` (backtracking Armijo line search), from the
hand-tuned design and from each `ControlSettings.tune_starts` inner wn, at
most `tune_iterations` steps per run (rejected line-search steps count).

**Convergence test** (`CONVERGENCE_TEST`), both of:

1. optimistix's Cauchy test on an accepted step: every z changes by less
   than `TUNE_TOL` (1 + |z|) and the scaled cost by less than
   `TUNE_TOL` (1 + cost);
2. a probe: no change of one parameter by +-`PROBE_STEP` (1 %, within its
   bounds) lowers the scaled cost by more than `TUNE_TOL`.

Test 2 is there because the cost is only piecewise smooth: with the inner
reference's acceleration limit the axis creeps to the target, the true
plant's Coulomb friction makes it stick there, and where it sticks moves
with the design by jumps of the cost's slope. Measured on the built-in data
(401 points within +-0.2 % of LG around wn 24.1 rad/s, eta 1.36, LG 0.0288;
cost 0.0166 m s): the slope along log LG swings between -1.0 and +1.1 m s,
with 52 jumps. BFGS can stop on such a kink (test 1 met) where a 1 % move
still pays; such a run restarts from the probe's better point, at most
`TUNE_RESTARTS` times. For the same reason the gradient's norm at the end is
reported, not tested: at a kink it does not vanish.
"""

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from ..._checks import checked_call

#: The tuned parameters, in the order of the cost's argument.
NAMES = ("wn", "eta", "loop_gain", "ew", "xw")
#: Tolerance of the Cauchy test and of the probe (relative, on the scaled variables and cost).
TUNE_TOL = 1e-4
#: The probe's change of one parameter (in its logarithm: 1 %).
PROBE_STEP = 0.01
#: Restarts from a better probe point before a run is called unconverged.
TUNE_RESTARTS = 4
#: Upper bound of the inner wn, as a multiple of the largest wn the drive's delay allows (2 % overshoot).
WN_HEADROOM = 1.25
#: Bounds of the inner loop's damping eta (widened to hold the settings' eta).
ETA_RANGE = (0.5, 2.0)
#: LG, ew, xw (and the lowest wn) stay within this factor of the hand-tuned design's.
RANGE_FACTOR = 100.0
#: The convergence test, in words (summary.json, report.md).
CONVERGENCE_TEST = (
    f"an accepted BFGS step changes every scaled parameter z by less than {TUNE_TOL:g} (1 + |z|) and the cost "
    f"(divided by the hand-tuned design's) by less than {TUNE_TOL:g} (1 + cost), and no {100 * PROBE_STEP:g} % "
    f"change of one parameter lowers that cost by more than {TUNE_TOL:g}"
)
#: How the warnings name the fix for a run out of steps (the command line says --tune-iterations).
MORE_STEPS = "raise `tune_iterations` of ControlSettings"


def tuning_bounds(hand: dict, wn_real: float) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi): the logarithms of the tuned parameters' bounds (`NAMES` order) around the hand-tuned design.

    `hand`: wn (rad/s), eta, loop_gain, ew, xw of the hand-tuned design; `wn_real` the largest inner wn the
    drive's delay allows (rad/s).
    """
    h = np.array([hand[k] for k in NAMES], dtype=float)
    lo, hi = h / RANGE_FACTOR, h * RANGE_FACTOR
    lo[0], hi[0] = wn_real / RANGE_FACTOR, wn_real * WN_HEADROOM
    lo[1], hi[1] = min(ETA_RANGE[0], h[1] / 2), max(ETA_RANGE[1], 2 * h[1])
    return np.log(lo), np.log(hi)


def _z(u, lo, hi, margin=1e-9):
    """The logistic variable of the log-parameters u, kept `margin` (a fraction of the range) inside the bounds."""
    frac = np.clip((np.asarray(u, dtype=float) - lo) / (hi - lo), margin, 1 - margin)
    return np.log(frac / (1 - frac))


def _u(z, lo, hi):
    return lo + (hi - lo) / (1 + np.exp(-np.asarray(z, dtype=float)))


def tune_cascade(cost, hand: dict, *, wn_real: float, starts, max_steps: int) -> dict:
    """Minimise `cost` (a JAX function of (wn, eta, LG, ew, xw) -> scalar) from the hand-tuned design `hand`
    and from each inner wn in `starts` (rad/s); BFGS with the convergence test of the module's docstring.

    Returns a dict of plain numbers: the best run's parameters (`NAMES`), `cost` (unscaled) and
    `hand_tuned_cost`, `start_wn`, `steps` (BFGS steps of all its runs), `restarts`, `converged`, `reason`
    (None, "steps": a run used all `max_steps`, "probe": a 1 % change still paid after `TUNE_RESTARTS`
    restarts, "nonfinite"), `probe` (the parameter and the scaled cost decrease of the probe's best change),
    `gradient` (d (cost / hand-tuned cost) / d log p per parameter) and `gradient_norm` (its largest
    absolute value over the parameters not at a bound), `at_bounds` (parameter -> "lower"/"upper"), `bounds`,
    `runs` (one dict per start), `max_steps` and `convergence_test`.
    """
    lo, hi = tuning_bounds(hand, wn_real)
    lo_j, hi_j = jnp.asarray(lo), jnp.asarray(hi)

    def unscaled(z):
        return cost(jnp.exp(lo_j + (hi_j - lo_j) * jax.nn.sigmoid(z)))

    def unscaled_jit(z):  # values only: a gradient would cost a compilation 3 times as long
        return checked_call(unscaled, z)  # one program whose checks are outputs: cached across runs

    u_hand = np.log([hand[k] for k in NAMES])
    f_hand = float(unscaled_jit(jnp.asarray(_z(u_hand, lo, hi))))

    def scaled(z, _):
        return unscaled(z) / f_hand

    def value(u):
        return float(unscaled_jit(jnp.asarray(_z(u, lo, hi)))) / f_hand

    solver = optx.BFGS(rtol=TUNE_TOL, atol=TUNE_TOL)
    runs = []
    for wn0 in dict.fromkeys(float(w) for w in starts):  # in order, once each
        u0 = u_hand.copy()
        u0[0] = np.log(wn0)
        z = _z(u0, lo, hi, margin=0.01)  # a start outside the bounds moves just inside
        steps = restarts = 0
        probe = None
        while True:
            sol = optx.minimise(scaled, solver, jnp.asarray(z), max_steps=max_steps, throw=False)
            steps += int(sol.stats["num_steps"])
            z, grad_z = np.asarray(sol.value), _solver_gradient(sol)
            u = _u(z, lo, hi)
            f = value(u)
            if not np.isfinite(f) or sol.result == optx.RESULTS.nonfinite:
                reason = "nonfinite"
                break
            if sol.result != optx.RESULTS.successful:
                reason = "steps"
                break
            probe = _probe(value, u, f, lo, hi)
            if probe["decrease"] <= TUNE_TOL:
                reason = None
                break
            if restarts == TUNE_RESTARTS:
                reason = "probe"
                break
            restarts += 1
            z = _z(probe["u"], lo, hi)
        runs.append(
            dict(
                start_wn=wn0,
                steps=steps,
                restarts=restarts,
                converged=reason is None,
                reason=reason,
                cost=f * f_hand,
                z=z,
                grad_z=grad_z,
                probe=None if probe is None else {k: v for k, v in probe.items() if k != "u"},
            )
        )
    finite = [r for r in runs if np.isfinite(r["cost"])]
    if finite:
        best = min(finite, key=lambda r: r["cost"])
    else:  # no run ended finite: the hand-tuned design stands
        best = dict(runs[0], z=_z(u_hand, lo, hi), grad_z=None, cost=f_hand)
    z, grad_z = best["z"], best["grad_z"]
    for r in runs:
        del r["z"], r["grad_z"]
    u = _u(z, lo, hi)
    if grad_z is None:  # an optimistix without the quasi-Newton state's gradient
        grad_z = np.asarray(jax.grad(scaled)(jnp.asarray(z), None))
    s = 1 / (1 + np.exp(-z))
    du_dz = (hi - lo) * s * (1 - s)
    grad = np.divide(grad_z, du_dz, out=np.full(5, np.inf), where=du_dz > 0)
    at_bounds = {}
    for n, a, b in zip(NAMES, u - lo, hi - u):
        if a < PROBE_STEP:
            at_bounds[n] = "lower"
        elif b < PROBE_STEP:
            at_bounds[n] = "upper"
    free = [i for i, n in enumerate(NAMES) if n not in at_bounds]
    return dict(
        **{n: float(v) for n, v in zip(NAMES, np.exp(u))},
        cost=best["cost"],
        hand_tuned_cost=f_hand,
        start_wn=best["start_wn"],
        steps=best["steps"],
        restarts=best["restarts"],
        converged=best["converged"],
        reason=best["reason"],
        probe=best["probe"],
        gradient=dict(zip(NAMES, grad.tolist())),
        gradient_norm=float(np.max(np.abs(grad[free]))) if free else 0.0,
        at_bounds=at_bounds,
        bounds={n: [float(np.exp(a)), float(np.exp(b))] for n, a, b in zip(NAMES, lo, hi)},
        runs=runs,
        max_steps=int(max_steps),
        convergence_test=CONVERGENCE_TEST,
    )


def _solver_gradient(sol):
    """The gradient (scaled cost, z) at a BFGS solution, from the solver's state (None where it is not kept)."""
    grad = getattr(getattr(sol.state, "f_info", None), "grad", None)
    return None if grad is None else np.asarray(grad)


def _probe(value, u, f, lo, hi) -> dict:
    """The best change of one log-parameter by +-PROBE_STEP within the bounds: its `u`, `parameter`, `change`
    (+1 or -1) and `decrease` of the scaled cost (negative: none lowers it)."""
    best = dict(u=u, parameter=None, change=0, decrease=-np.inf)
    for i, name in enumerate(NAMES):
        for sign in (1, -1):
            v = u.copy()
            v[i] += sign * PROBE_STEP
            if not lo[i] < v[i] < hi[i]:
                continue
            d = f - value(v)
            if d > best["decrease"]:
                best = dict(u=v, parameter=name, change=sign, decrease=d)
    best["decrease"] = float(best["decrease"])
    return best


def tuning_warnings(tuned: dict) -> list[str]:
    """The warning of a gradient tuning (`tune_cascade`'s dict) that did not converge: what, and what to change."""
    if tuned["converged"]:
        return []
    head = (
        f"the gradient tuning did not converge (its best run, from wn {tuned['start_wn']:g} rad/s, "
        f"{tuned['steps']} BFGS steps): "
    )
    if tuned["reason"] == "steps":
        return [
            head + f"a run used all its {tuned['max_steps']} steps before the convergence test was met; the tuned "
            f"design is the last point reached, not a minimum: {MORE_STEPS} (now {tuned['max_steps']})"
        ]
    if tuned["reason"] == "probe":
        p = tuned["probe"]
        return [
            head + f"after {TUNE_RESTARTS} restarts a {100 * PROBE_STEP:g} % change of {p['parameter']} still lowers "
            f"the cost by {100 * p['decrease']:.2g} % of the hand-tuned design's: the cost is rough there "
            "(stick-slip of the Coulomb friction); try other inner-loop starts (`tune_starts` of ControlSettings)"
        ]
    return [
        head + "the cost became non-finite (an unstable loop); the tuned design is the last finite point: "
        "try other inner-loop starts (`tune_starts` of ControlSettings)"
    ]
