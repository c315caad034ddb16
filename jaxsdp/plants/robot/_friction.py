r"""Each robot joint's friction law read off its residual, estimated with the rigid body (issue 45, item 4).

The paper's programme carried to the end for a robot. For each motor $k$ whose viscous and Coulomb coefficients
are base parameters, on its own joint's rows in motion, the partial residual

$$r_k = y_k - X_k \hat\beta + G_{kk} (\hat F_{v,k} \dot u_k + \hat F_{c,k} sign \dot u_k),$$

the torque less the IDIM-LS model without the motor's own friction (what the joint's SDP curve in $\dot u_k$
estimates; $\dot u = C^{-1} \dot q$ the motor's velocity, $G = C^{-T}$), is fitted by each candidate law
(`jaxsdp.plants.ViscousCoulomb`, `AsymmetricCoulomb`, `SmoothCoulomb`, `Stribeck`) and the law of least BIC is
proposed. The proposed laws are then estimated jointly with every other base parameter by nonlinear least squares
on all joints' rows in motion, as IDIM-LS weighs them (so that the linear model is IDIM-LS's own), by variable
projection: optimistix's Levenberg-Marquardt over the laws' parameters $p$ alone, $\beta'$ at its least squares
for each $p$ (one QR of the fixed columns), so that each Jacobian pushes a few directions through the decimation
filter instead of one per base parameter:

$$\min_{\beta', p} \sum_j \|y_j - X'_j \beta' - \sum_k G_{jk} f_k(\dot u_k; p_k)\|^2,$$

$X'$ the base regressor without the friction columns of the motors given a law. Each law is evaluated at the full
rate on the processed motor velocity and decimated by the same filter as the torques and the regressor (the
parallel filtering of IDIM): a law evaluated on the decimated velocity would be sharp where the filtered torque is
not, and a smooth law would be chosen for the filter's smear around each reversal (measured: the smooth Coulomb
law on a two-link arm whose friction is linear). A proposal is kept only if it
lowers its joint's error held out in `folds` blocks of time (each block predicted by the fit on the others)
by at least `min_gain` (2 %) of the linear model's; otherwise that motor goes back to viscous + Coulomb and the
rest is fitted again. So every law reported lowers its joint's cross-validated error, or is linear. (The margin:
around each reversal the filtered acceleration is smooth where the torque steps, a structure a smooth law fits a
little of: on a simulated arm whose friction is linear the smooth Coulomb law lowered a joint's held-out error by
1.1 %.)
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx

from ..._linalg import qr_r, qr_thin, solve_upper
from ..._runtime import x64
from ..._signal.filtering import decimate_columns
from .._friction_laws import LAWS, FrictionFit, FrictionLaw
from ._joint import drive_matrix
from ._robot_idim import RobotIDIM

LINEAR = "ViscousCoulomb"

#: The fraction of its joint's held-out error a law must remove to be kept: the filter's smear at reversals lets
#: a smooth law lower a linear friction's held-out error by about 1 % (a simulated two-link arm: 1.1 %).
MIN_GAIN = 0.02


class RobotFriction(eqx.Module):
    """Each motor's friction law (`robot_friction`).

    **Fields:** `chosen` (motor -> the law's class name kept), `proposed` (motor -> the law of least BIC on its
    partial residual), `candidates` (motor -> the `FrictionFit` of every law on that residual, the intercept
    `shift` first), `curve_mismatch` (motor -> law -> rms of the law minus the joint's SDP friction curve over the
    curve's rms, %; empty without the SDP), `names` and `theta`, `std` the joint fit's parameters (the base
    parameters kept, then each law's parameters named `<name><motor>`), `relative_error` (joint -> % in sample,
    `linear` and `chosen`), `cross_validated` (joint -> held-out %, `linear` and `chosen`), `reverted` (motors
    whose proposed law did not lower the held-out error by `min_gain`: linear), `converged`, `folds`, `min_gain`.
    """

    chosen: dict = eqx.field(static=True)
    proposed: dict = eqx.field(static=True)
    candidates: dict
    curve_mismatch: dict = eqx.field(static=True)
    names: tuple = eqx.field(static=True)
    theta: np.ndarray
    std: np.ndarray
    relative_error: dict = eqx.field(static=True)
    cross_validated: dict = eqx.field(static=True)
    reverted: tuple = eqx.field(static=True)
    converged: bool = eqx.field(static=True)
    folds: int = eqx.field(static=True)
    min_gain: float = eqx.field(static=True, default=MIN_GAIN)

    @x64
    def summary(self) -> dict:
        """JSON-ready: per motor `chosen`, `proposed`, the candidates' `bic` and `relative_error` %, the chosen
        law's parameters {name: {value, std}}; per joint `relative_error` and `cross_validated` (`linear`,
        `chosen`, %); `reverted`, `converged`, `folds`."""
        values = dict(zip(self.names, np.asarray(self.theta, dtype=float).tolist()))
        std = dict(zip(self.names, np.asarray(self.std, dtype=float).tolist()))
        motors = {}
        for k, law in self.chosen.items():
            own = [n for n in self.names if _motor_of(n) == k]
            motors[f"motor_{k}"] = dict(
                chosen=law,
                proposed=self.proposed[k],
                parameters={n: dict(value=values[n], std=std[n]) for n in own},
                candidates={
                    f.law: dict(bic=float(f.bic), relative_error=float(f.relative_error), converged=bool(f.converged))
                    for f in self.candidates[k]
                },
                curve_mismatch=self.curve_mismatch.get(k),
            )
        return dict(
            motors=motors,
            joints={
                f"joint_{j}": dict(relative_error=self.relative_error[j], cross_validated=self.cross_validated[j])
                for j in self.relative_error
            },
            reverted=list(self.reverted),
            converged=self.converged,
            folds=self.folds,
            min_gain=self.min_gain,
        )


def _motor_of(name: str):
    """The motor a law parameter `Fv3`, `vs3`... belongs to (None for a base parameter name like `ZZ3`)."""
    for prefix in ("Fv+", "Fv-", "Fs", "vs", "veps", "Fv", "Fc"):
        if name.startswith(prefix) and name[len(prefix) :].isdigit():
            return int(name[len(prefix) :])
    return None


class _Problem(eqx.Module):
    """The joint fit's residual: rows (M, J) weighted, the linear columns kept, one law per nonlinear motor, each
    law evaluated at the full rate and decimated like the torques."""

    laws: tuple = eqx.field(static=True)  # ((motor index k0, law), ...)
    keep: tuple = eqx.field(static=True)  # base columns kept
    G: tuple = eqx.field(static=True)  # (J, n) as nested tuples (hashable)
    decimate: int = eqx.field(static=True)
    mode: str = eqx.field(static=True)
    motors: tuple = eqx.field(static=True, default=())  # the motor number of each law

    def laws_by_motor(self):
        return tuple(zip(self.motors, (law for _, law in self.laws)))

    def laws_part(self, p, du_full):
        """The laws' torques on the rows (M, J): each law at the full rate, decimated, through the drives."""
        out, at = 0.0, 0
        for k0, law in self.laws:
            q = len(law.names)
            f = _decimated(law._f(du_full[:, k0], p[at : at + q]), self.decimate, self.mode)  # (M,)
            out = out + f[:, None] * jnp.asarray([row[k0] for row in self.G])[None, :]
            at += q
        return out

    def torque(self, z, X, du_full):
        """The model's torques (M, J) at z = (the base parameters kept, the laws' parameters)."""
        m = len(self.keep)
        return X[:, :, np.asarray(self.keep)] @ z[:m] + self.laws_part(z[m:], du_full)

    def residual(self, p, args):
        """Variable projection: the weighted residual at the laws' parameters `p` with the base parameters at their
        least squares, (I - Q Q^T) w (y - g(p)), Q an orthonormal basis of the weighted linear columns."""
        y, _, du_full, w, Q = args
        r = ((y - self.laws_part(p, du_full)) * w).reshape(-1)
        return r - Q @ (Q.T @ r)


def _decimated(f, decimate: int, mode: str):
    """A full-rate column decimated as the pipeline decimates the torques and the regressor."""
    return f if decimate == 1 else decimate_columns(f[:, None], decimate, mode=mode)[:, 0]


@eqx.filter_jit
def _solve(problem, z0, args):
    """Levenberg-Marquardt on `problem.residual`; (z, std, converged, rss, rows): std from the Jacobian (QR,
    triangular solves, sigma^2 over the rows weighted in)."""
    sol = optx.least_squares(
        problem.residual, optx.LevenbergMarquardt(rtol=1e-10, atol=1e-12), z0, args=args, max_steps=500, throw=False
    )
    z = sol.value
    e = problem.residual(z, args)
    J = jax.jacfwd(problem.residual)(z, args)
    k = z.shape[0]
    Ri = solve_upper(qr_r(J), jnp.eye(k))
    n = jnp.sum(args[-1] > 0)
    rss = e @ e
    return z, jnp.sqrt(rss / (n - k) * jnp.sum(Ri**2, axis=1)), sol.result == optx.RESULTS.successful, rss, n


@eqx.filter_jit
def _solve_joint(problem: _Problem, p0, args):
    """The joint fit by variable projection: Levenberg-Marquardt on the laws' parameters only (the base parameters
    eliminated by least squares, so the Jacobian pushes a few directions through the decimation filter, not one
    per base parameter), then the base parameters by QR. (z, std, converged): z = (base parameters kept, laws'
    parameters), std from the whole Jacobian [X', dg/dp] (QR, triangular solves, sigma^2 over the rows weighted
    in)."""
    y, X, du_full, w = args
    m = len(problem.keep)
    A = (X[:, :, np.asarray(problem.keep)] * w[:, :, None]).reshape(-1, m)
    Q, R = qr_thin(A)
    if p0.shape[0]:
        solver = optx.LevenbergMarquardt(rtol=1e-10, atol=1e-12)
        sol = optx.least_squares(problem.residual, solver, p0, args=(y, X, du_full, w, Q), max_steps=500, throw=False)
        p, converged = sol.value, sol.result == optx.RESULTS.successful
    else:
        p, converged = p0, jnp.asarray(True)
    beta = solve_upper(R, Q.T @ ((y - problem.laws_part(p, du_full)) * w).reshape(-1))
    z = jnp.concatenate([beta, p])
    e = ((y - problem.torque(z, X, du_full)) * w).reshape(-1)
    if p0.shape[0]:
        Jp = jax.jacfwd(lambda pp: (problem.laws_part(pp, du_full) * w).reshape(-1))(p)
        A = jnp.concatenate([A, Jp], axis=1)
    k = z.shape[0]
    Ri = solve_upper(qr_r(A), jnp.eye(k))
    n = jnp.sum(w > 0)
    return z, jnp.sqrt(e @ e / (n - k) * jnp.sum(Ri**2, axis=1)), converged


class _One(eqx.Module):
    """One motor's law on its partial residual: r = shift + D f(du; p) on the rows weighted in."""

    law: FrictionLaw = eqx.field(static=True)
    decimate: int = eqx.field(static=True)
    mode: str = eqx.field(static=True)

    def residual(self, z, args):
        r, du_full, w = args
        return (r - z[0] - _decimated(self.law._f(du_full, z[1:]), self.decimate, self.mode)) * w


def _candidate(law, r, v, du_full, ok, pre) -> FrictionFit:
    """`law` fitted to the partial residual `r` (M,) on the rows `ok`, through the decimation filter; started from
    the law's start on the decimated velocity `v`; a `FrictionFit` (the intercept `shift` first)."""
    start = np.r_[0.0, law._start(v[ok], r[ok])]
    one = _One(law, pre.decimate, pre.mode)
    args = (jnp.asarray(r), jnp.asarray(du_full), jnp.asarray(ok, dtype=float))
    z, std, converged, rss, n = _solve(one, jnp.asarray(start), args)
    n, k = int(n), int(start.shape[0])
    raw = z[1:]
    d = np.diag(np.asarray(jax.jacfwd(law._values)(raw)))
    rss = float(rss)
    return FrictionFit(
        theta=z[:1],
        p=law._values(raw),
        std=jnp.concatenate([std[:1], std[1:] * jnp.abs(jnp.asarray(d))]),
        raw=raw,
        rss=jnp.asarray(rss),
        sigma=jnp.asarray(np.sqrt(rss / (n - k))),
        relative_error=jnp.asarray(100 * np.sqrt(rss) / np.linalg.norm(r[ok])),
        bic=jnp.asarray(n * np.log(rss / n) + k * np.log(n)),
        aic=jnp.asarray(n * np.log(rss / n) + 2 * k),
        converged=converged,
        n=n,
        k=k,
        names=("shift",) + law.names,
        law=type(law).__name__,
    )


def _values_std(problem: _Problem, z, std):
    """Each law's parameters in SI units (scale parameters from their logarithms, std by the delta method)."""
    m = len(problem.keep)
    values, sd = [np.asarray(z[:m])], [np.asarray(std[:m])]
    at = m
    for _, law in problem.laws:
        q = len(law.names)
        raw = jnp.asarray(z[at : at + q])
        d = np.diag(np.asarray(jax.jacfwd(law._values)(raw)))
        values.append(np.asarray(law._values(raw)))
        sd.append(np.asarray(std[at : at + q]) * np.abs(d))
        at += q
    return np.concatenate(values), np.concatenate(sd)


@x64
def robot_friction(
    res: RobotIDIM, *, laws=LAWS, folds: int = 2, min_gain: float = MIN_GAIN, sdp: dict | None = None
) -> RobotFriction:
    r"""Each motor's friction law, proposed by BIC on its partial residual and kept where it lowers its joint's
    cross-validated error; the laws estimated jointly with the rigid body.

    `res` the robot's IDIM-LS (`robot_idim_ls`: its rows in motion, regressor and estimate); `laws` the candidates
    (a tuple of `FrictionLaw`s; one law: that law for every motor, still subject to the cross-validation); `folds`
    blocks of time for the held-out errors; `min_gain` the fraction of its joint's held-out error a law must remove
    to be kept (0.02); `sdp` the study's residual SDP (joint -> `JointSDP`) to compare each
    law with the joint's SDP friction curve. Motors whose `Fv`, `Fc` are not both base parameters keep the linear
    law.

    For motor k the partial residual r_k = y_k - X_k beta + G_kk (Fv_k du_k + Fc_k sign du_k) (the torque less the
    IDIM-LS model without the motor's own friction; du the motor speed) is fitted by each law through the
    decimation filter (each law evaluated at the full rate, decimated like the torques), and the law of least
    BIC = N log(RSS / N) + k log N is proposed. The proposals are estimated jointly with the other base parameters,
    min over (beta', p) of sum_j |y_j - X'_j beta' - sum_k G_jk f_k(du_k; p_k)|^2 on the rows IDIM-LS used, by
    variable projection (Levenberg-Marquardt over p, beta' by least squares); a proposal whose joint's held-out
    error (`folds` blocks of time) is not at least `min_gain` below the linear model's goes back to viscous +
    Coulomb. Torques in N m, speeds in rad/s.

    **Returns:** a `RobotFriction` (`summary()` its JSON-ready dict).

    Example:
        >>> import numpy as np
        >>> from jaxsdp.data import JointLogs
        >>> from jaxsdp.plants import SerialRobot, Stribeck
        >>> from jaxsdp.plants.robot import robot_friction, robot_idim_ls, robot_model
        >>> arm = SerialRobot.from_mdh([[0.0, 0.0, 0.0, 0.0]], inertias=[(2.0, [0.5, 0.0, 0.0], np.zeros(6))],
        ...                            Fv=3.0, Fc=1.0)
        >>> t = np.arange(0, 10, 1e-3)[:, None]
        >>> q, dq, ddq = np.sin(t), np.cos(t), -np.sin(t)  # a horizontal arm: no gravity torque
        >>> hump = 0.8 * np.sign(dq) * np.exp(-((dq / 0.2) ** 2))  # Stribeck: 0.8 N m more at rest, over 0.2 rad/s
        >>> logs = JointLogs(q=q, tau=arm.drive_torques(q, dq, ddq) + hump, t=t[:, 0], dt=1e-3, joints=(1,),
        ...                  source="sim", converted="none")
        >>> out = robot_friction(robot_idim_ls(logs, robot_model(arm)), laws=Stribeck())
        >>> out.chosen, {k: round(v, 1) for k, v in out.cross_validated[1].items()}  # held-out error, %
        ({1: 'Stribeck'}, {'linear': 4.5, 'chosen': 0.0})
        >>> {n: round(float(v), 2) for n, v in zip(out.names, out.theta) if n[:2] in ("Fv", "Fc", "Fs", "vs")}
        {'Fv1': 3.0, 'Fc1': 1.0, 'Fs1': 1.8, 'vs1': 0.2}
    """
    if not isinstance(res, RobotIDIM):
        raise ValueError(f"`res` must be a RobotIDIM (robot_idim_ls); got {type(res).__name__}")
    laws = (laws,) if isinstance(laws, FrictionLaw) else tuple(laws)
    if not laws or not all(isinstance(law, FrictionLaw) for law in laws):
        raise ValueError(f"`laws` must be a FrictionLaw or a tuple of them; got {laws!r}")
    if isinstance(min_gain, bool) or not isinstance(min_gain, (int, float)) or not 0 <= min_gain < 1:
        raise ValueError(f"`min_gain` must be a fraction in [0, 1); got {min_gain!r}")
    if isinstance(folds, bool) or not isinstance(folds, int) or folds < 2:
        raise ValueError(f"`folds` must be an int >= 2; got {folds!r}")
    model = res.model
    names = tuple(model.names)
    n = model.robot.n
    rows = tuple(model.rows)
    _, G = drive_matrix(n, model.transmission)
    G = G[np.asarray(rows) - 1]  # (J, n): the rows modelled
    y, X = np.asarray(res.y, dtype=float), np.asarray(res.X, dtype=float)
    moving = np.asarray(res.moving, dtype=bool)
    beta = np.asarray(res.result.theta, dtype=float)
    w = moving.astype(float)  # the rows IDIM-LS used, unweighted as there: the linear model is IDIM-LS's
    pre = res.inputs[0]
    Cinv, _ = drive_matrix(n, model.transmission)
    du_full = np.stack([np.asarray(p.dq_full, dtype=float) for p in res.inputs], axis=1) @ Cinv.T  # motor speeds
    # motors whose viscous and Coulomb coefficients are base parameters, read on their own joint's rows
    motors, du = {}, np.zeros((y.shape[0], n))
    for k in range(1, n + 1):
        iv, ic = (names.index(f"{p}{k}") if f"{p}{k}" in names else None for p in ("Fv", "Fc"))
        if iv is None or ic is None or k not in rows:
            continue
        i = rows.index(k)
        g = G[i, k - 1]
        if g == 0:
            continue
        du[:, k - 1] = X[:, i, iv] / g  # the decimated motor velocity the regressor holds (for the start only)
        motors[k] = (i, iv, ic, g)
    candidates, proposed, mismatch = {}, {}, {}
    for k, (i, iv, ic, g) in motors.items():
        ok = moving[:, i]
        r = (y[:, i] - X[:, i] @ beta + X[:, i, iv] * beta[iv] + X[:, i, ic] * beta[ic]) / g
        fits = tuple(_candidate(law, r, du[:, k - 1], du_full[:, k - 1], ok, pre) for law in laws)
        candidates[k] = fits
        best = min(range(len(fits)), key=lambda a: float(fits[a].bic))
        proposed[k] = (laws[best], fits[best])
        if sdp is not None and k in sdp:
            mismatch[k] = _curve_mismatch(sdp[k], laws, fits)
    linear = {k: None for k in motors}
    chosen = {k: law for k, (law, _) in proposed.items() if type(law).__name__ != LINEAR}
    args = (y, X, du_full, w)
    base_cv, base_in, _ = _held_out(_make(names, motors, {}, G, pre), np.zeros(0), args, folds, rows)
    reverted = []
    while True:
        problem = _make(names, motors, chosen, G, pre)
        p0 = _start(problem, proposed)
        cv, within, fitted = _held_out(problem, p0, args, folds, rows)
        worse = [k for k in chosen if cv[rows[motors[k][0]]] > (1 - min_gain) * base_cv[rows[motors[k][0]]]]
        if not worse:
            break
        for k in worse:  # back to the linear law, and fit the rest again
            chosen.pop(k)
            reverted.append(k)
    z, std, converged = fitted
    theta, sd = _values_std(problem, z, std)
    law_names = tuple(f"{p}{k}" for k, law in problem.laws_by_motor() for p in law.names)
    return RobotFriction(
        chosen={k: type(chosen[k]).__name__ if k in chosen else LINEAR for k in linear},
        proposed={k: type(law).__name__ for k, (law, _) in proposed.items()},
        candidates=candidates,
        curve_mismatch=mismatch,
        names=tuple(names[c] for c in problem.keep) + law_names,
        theta=theta,
        std=sd,
        relative_error={j: dict(linear=base_in[j], chosen=within[j]) for j in rows},
        cross_validated={j: dict(linear=base_cv[j], chosen=cv[j]) for j in rows},
        reverted=tuple(sorted(reverted)),
        converged=bool(converged),
        folds=folds,
        min_gain=float(min_gain),
    )


def _make(names, motors, chosen, G, pre) -> _Problem:
    drop = {c for k in chosen for c in motors[k][1:3]}
    keep = tuple(c for c in range(len(names)) if c not in drop)
    order = sorted(chosen)
    Gt = tuple(tuple(float(x) for x in row) for row in np.asarray(G))
    laws = tuple((k - 1, chosen[k]) for k in order)
    return _Problem(laws=laws, keep=keep, G=Gt, decimate=pre.decimate, mode=pre.mode, motors=tuple(order))


def _start(problem: _Problem, proposed) -> np.ndarray:
    """The laws' parameters at their fits to the partial residuals."""
    return np.concatenate([np.zeros(0)] + [np.asarray(proposed[k][1].raw) for k in problem.motors])


def _held_out(problem: _Problem, p0, args, folds: int, rows: tuple):
    """(joint -> held-out relative error %, joint -> in-sample %, (z, std, converged) of the fit on every row):
    each block of time predicted by the fit on the others (same shapes: the block's weights set to zero, one
    compiled program)."""
    y, X, du_full, w = args
    edges = np.linspace(0, y.shape[0], folds + 1).astype(int)
    pred = np.zeros_like(y)
    full = tuple(jnp.asarray(a) for a in args)
    for a, b in zip(edges[:-1], edges[1:]):
        wk = w.copy()
        wk[a:b] = 0.0
        z, _, _ = _solve_joint(problem, jnp.asarray(p0), full[:3] + (jnp.asarray(wk),))
        pred[a:b] = np.asarray(_torque(problem, z, full[1], full[2]))[a:b]
    z, std, converged = _solve_joint(problem, jnp.asarray(p0), full)
    fit = np.asarray(_torque(problem, z, full[1], full[2]))
    moving = w > 0
    out_cv, out_in = {}, {}
    for i, j in enumerate(rows):
        m = moving[:, i]
        norm = np.linalg.norm(y[m, i])
        out_cv[j] = float(100 * np.linalg.norm((y - pred)[m, i]) / norm)
        out_in[j] = float(100 * np.linalg.norm((y - fit)[m, i]) / norm)
    return out_cv, out_in, (z, std, converged)


@eqx.filter_jit
def _torque(problem: _Problem, z, X, du_full):
    return problem.torque(z, X, du_full)


def _curve_mismatch(sdp, laws, fits) -> dict:
    """law -> 100 rms(f(dq) + shift - d) / rms(d) on the SDP's samples in motion (d the friction curve)."""
    d = np.asarray(sdp.result.d, dtype=float)[:, 1]
    m = np.asarray(sdp.moving, dtype=bool)
    v = np.asarray(sdp.dq, dtype=float)[m]
    out = {}
    for law, fit in zip(laws, fits):
        f = np.asarray(law(v, fit.raw)) + float(fit.theta[0])
        dd = d[m] - np.mean(d[m])
        out[fit.law] = float(100 * np.sqrt(np.mean((f - np.mean(f) - dd) ** 2)) / np.sqrt(np.mean(dd**2)))
    return out
