"""A robot's identified model and its logs against its description: inertia, speeds, accelerations.

The scale rules, thresholds and wording are `jaxsdp.plants._plausibility`'s
(see there why each threshold); this module computes the quantities of a
serial robot, host-side, from finished results:

- `nominal_joint`: one joint seen as a one-link arm by the description
  (`SerialRobot`): inertia Ia_j + M_jj(q), gravity torque, friction, over
  the logged configurations;
- `one_joint_checks`: the one-joint study's identified inertia against it,
  with the viscous, Coulomb and gravity ratios naming the likely cause;
- `robot_checks`: the stacked model's identified joint-space inertia and
  gravity against the description's nominal base parameters, and the peak
  speeds and accelerations against the description's velocity and effort
  limits.
"""

import math

import jax.numpy as jnp
import numpy as np

from ..._runtime import x64
from .._plausibility import (
    LABEL,
    MAX_INERTIA_FACTOR,
    MAX_LIMIT_FACTOR,
    inertia_warning,
    ratio,
    row,
    static_ratio,
)
from ._joint import BASE_STATES

_INERTIA_LIMIT = f"{1 / MAX_INERTIA_FACTOR:g} to {MAX_INERTIA_FACTOR:g}"


def _rms(x) -> float:
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(x**2))) if x.size else 0.0


@x64
def nominal_joint(robot, q, joint: int) -> dict:
    """Joint `joint` of `robot` seen as a one-link arm at the configurations `q` ((K, n), the model's convention).

    **Returns** `{"ZZ", "Fv", "Fc", "gravity"}`: the median of Ia_j + M_jj(q)
    (kg m^2), the drive's friction, the RMS of the gravity torque G_j(q) (N m).
    """
    j = joint - 1
    q = jnp.asarray(q)
    d = np.asarray(robot.mass_matrix(q))[:, j, j] + float(np.asarray(robot.Ia)[j])
    g = np.asarray(robot.gravity_torques(q))[:, j]
    return {"ZZ": float(np.median(d)), "Fv": float(robot.Fv[j]), "Fc": float(robot.Fc[j]), "gravity": _rms(g)}


def one_link_gravity(MX: float, MY: float, q, g: float) -> float:
    """RMS over the angles `q` of eq. (20)'s gravity torque -g MX cos q + g MY sin q (N m)."""
    q = np.asarray(q, dtype=float)
    return _rms(-g * MX * np.cos(q) + g * MY * np.sin(q))


def one_joint_checks(
    identified: dict, nominal: dict, *, joint: int, basis: str, dt: float, options: dict
) -> tuple[list[dict], list[str]]:
    """One joint's identified inertia against the description's, and a warning naming the likely cause.

    `identified`, `nominal`: `{"ZZ", "Fv", "Fc", "gravity"}` (the gravity
    torque's RMS over the record, N m; a nominal value of None or 0 is not
    compared); `basis`: where `nominal` comes from, in words; `dt`: the
    record's sampling period (s); `options`: cause -> what fixes it
    (`jaxsdp.plants._plausibility.inertia_warning`).

    **Returns** `(rows, warnings)`: the inertia ratio's row, the viscous and
    static ratios' rows (for the diagnosis, `passed` None), and at most one
    warning.
    """
    zz, nz = identified["ZZ"], nominal.get("ZZ")
    r = None if nz is None else ratio(zz, nz)
    viscous = None if not nominal.get("Fv") else ratio(identified["Fv"], nominal["Fv"])
    static = static_ratio(
        [(identified[k], nominal[k]) for k in ("Fc", "gravity") if nominal.get(k) is not None and identified[k] > 0]
    )
    rows = [
        row(
            f"ZZ{joint} / {basis}",
            r,
            _INERTIA_LIMIT,
            "",
            None if r is None else 1 / MAX_INERTIA_FACTOR <= r <= MAX_INERTIA_FACTOR,
        ),
        row(f"Fv{joint} / {basis} (for the cause)", viscous, "-", "", None),
        row(f"Coulomb friction and gravity / {basis} (for the cause)", static, "-", "", None),
    ]
    if r is None:
        return rows, []
    w = inertia_warning(
        f"the identified inertia ZZ{joint}", zz, nz, basis, viscous=viscous, static=static, dt=dt, options=options
    )
    return rows, [] if w is None else [w]


#: What fixes each cause in `jaxsdp robot` / `robot_study`.
ROBOT_OPTIONS = {
    "time scale": "the logs' time column or `dt` of load_joint_logs",
    "torque scale": "the drives' torque constants and ratios (`drives`)",
    "angles": "the angles' units and the drives' ratios (`drives`)",
}


@x64
def _inertia_and_gravity(idim, states: int = BASE_STATES):
    """The diagonal of the joint-space inertia (K, rows) and the gravity torques (K, rows) at K logged
    configurations, from the identified and from the nominal base parameters: one call of the model's regressor
    on `states` states (the shape its base parameters were found on, compiled already)."""
    model = idim.model
    n, rows = model.robot.n, model.rows
    q = np.stack([np.asarray(p.q, dtype=float) for p in idim.inputs], axis=1)  # (M, n), model convention
    k = max(states // (len(rows) + 1), 1)
    pick = np.linspace(0, q.shape[0] - 1, k).round().astype(int)
    blocks = [np.zeros((k, n))] + [np.tile(np.eye(n)[j - 1], (k, 1)) for j in rows]
    ddq = np.concatenate(blocks)
    qq = np.tile(q[pick], (len(blocks), 1))
    pad = states - ddq.shape[0]
    if pad > 0:
        ddq, qq = np.concatenate([ddq, np.zeros((pad, n))]), np.concatenate([qq, np.zeros((pad, n))])
    W = np.array(model.regressor(jnp.asarray(qq), jnp.zeros_like(jnp.asarray(qq)), jnp.asarray(ddq)))
    W[:, :, [i for i, name in enumerate(model.names) if name.startswith("offset")]] = 0.0
    out = {}
    for label, theta in (("identified", np.asarray(idim.result.theta, dtype=float)), ("nominal", model.nominal)):
        tau = W @ np.asarray(theta, dtype=float)  # (states, rows)
        grav = tau[:k]
        diag = np.stack([tau[(i + 1) * k : (i + 2) * k, i] - grav[:, i] for i in range(len(rows))], axis=1)
        out[label] = (diag, grav)
    return out


def robot_checks(idim, *, robot, dt: float) -> tuple[list[dict], list[str]]:
    """The stacked model's scales against the description `robot` (see the module); `(rows, warnings)`.

    Inertia: the identified joint-space inertia's trace (summed over the
    joints modelled and the logged configurations) over the nominal one's,
    within `MAX_INERTIA_FACTOR` either way; for the cause, the viscous
    friction's ratio and that of Coulomb friction and the gravity torques'
    RMS (geometric means over the terms the description gives). Limits: each joint's peak speed over its velocity
    limit, and its peak acceleration over the effort limit divided by the
    joint's smallest nominal diagonal inertia, at most `MAX_LIMIT_FACTOR`
    (joints whose description gives them).
    """
    terms = _inertia_and_gravity(idim)
    (d_id, g_id), (d_nom, g_nom) = terms["identified"], terms["nominal"]
    nominal_trace = float(np.sum(d_nom))
    r = ratio(float(np.sum(d_id)), nominal_trace) if nominal_trace > 0 else None
    pairs = list(zip(np.asarray(idim.result.theta, dtype=float), idim.model.nominal))
    named = dict(zip(idim.model.names, pairs))
    viscous = static_ratio([v for k, v in named.items() if k.startswith("Fv")])  # None: a URDF gives no friction
    static = static_ratio([v for k, v in named.items() if k.startswith("Fc")] + [(_rms(g_id), _rms(g_nom))])
    passed = None if r is None else 1 / MAX_INERTIA_FACTOR <= r <= MAX_INERTIA_FACTOR
    rows = [
        row("joint-space inertia (trace) / the description's", r, _INERTIA_LIMIT, "", passed),
        row("viscous friction / the description's (for the cause)", viscous, "-", "", None),
        row("Coulomb friction and gravity torques (RMS) / the description's (for the cause)", static, "-", "", None),
    ]
    warnings = []
    if r is not None:
        k = d_id.shape[0] * d_id.shape[1]
        w = inertia_warning(
            "the identified joint-space inertia (mean diagonal)",
            float(np.sum(d_id)) / k,
            nominal_trace / k,
            "the description's",
            viscous=viscous,
            static=static,
            dt=dt,
            options=ROBOT_OPTIONS,
        )
        warnings += [] if w is None else [w]
    names = robot.names or tuple(f"joint{j}" for j in range(1, robot.n + 1))
    over = []
    for i, j in enumerate(idim.model.rows):
        lim = robot.limits.get(names[j - 1])
        if lim is None:
            continue
        p = idim.inputs[j - 1]
        speed, acc = float(np.max(np.abs(np.asarray(p.dq)))), float(np.max(np.abs(np.asarray(p.ddq))))
        low = float(np.min(d_nom[:, i]))
        linear = bool(robot.prismatic[j - 1]) if robot.prismatic else False  # m/s, m/s^2 for a prismatic joint
        checks = [("peak speed / velocity limit", speed, lim[2], "m/s" if linear else "rad/s")]
        if low > 0 and math.isfinite(lim[3]) and lim[3] > 0:
            checks.append(
                ("peak acceleration / (effort limit / inertia)", acc, lim[3] / low, "m/s^2" if linear else "rad/s^2")
            )
        for what, value, bound, unit in checks:
            if not (math.isfinite(bound) and bound > 0):
                continue
            f = value / bound
            rows.append(row(f"{names[j - 1]} {what}", f, f"at most {MAX_LIMIT_FACTOR:g}", "", f <= MAX_LIMIT_FACTOR))
            if f > MAX_LIMIT_FACTOR:
                over.append(f"{names[j - 1]} {what.split(' / ')[0]} {value:.4g} {unit} is {f:.3g} times {bound:.4g}")
    if over:
        warnings.append(
            f"{LABEL}: the logs move faster than the description's limits allow ({'; '.join(over)}; at most "
            f"{MAX_LIMIT_FACTOR:g} times): the sampling period dt = {dt:.4g} s is probably too small, or the angles "
            f"are not in rad or the gear ratios are off; check {ROBOT_OPTIONS['time scale']} and "
            f"{ROBOT_OPTIONS['angles']}"
        )
    return rows, warnings
