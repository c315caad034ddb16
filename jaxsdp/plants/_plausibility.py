"""Scales checked against physics: do a record and the model identified from it describe a real machine?

Wrong units and a wrong sampling period pass every statistical test: the
regression fits exactly as well, only the parameters scale, each class by
its own power:

| the record's error | velocity, acceleration | inertia / mass | viscous friction | Coulomb, gravity |
|---|---|---|---|---|
| position u times too large (mm for m) | u, u | 1/u | 1/u | 1 |
| sampling period dt k times too large | 1/k, 1/k^2 | k^2 | k | 1 |
| torque c times too large (torque constant, gear ratio) | 1, 1 | c | c | c |
| a load the description lacks | 1, 1 | > 1 | about 1 | gravity > 1 |

So the checks compare what was identified and what was read with what
physics and the description allow, and the pattern of the ratios names the
likely cause (`scale_cause`). Every function here is host-side NumPy on
finished results, separate from the jitted kernels. Each check is a row
`{"check", "value", "limit", "unit", "passed"}` (`summary.json["scale_checks"]`).

**A linear axis** (`linear_axis_checks`; physics alone, no description).
The thresholds are generous: a real positioning axis lies far inside them
(the EMPS record, real and built-in, by a factor of 90 to 400).

- position range at most `MAX_TRAVEL` = 100 m: the longest positioning
  axes (gantries, rail-guided stages) travel tens of metres (EMPS 0.25 m);
- peak speed at most `MAX_SPEED` = 20 m/s: the fastest linear motors reach
  5-10 m/s (EMPS 0.13 m/s);
- peak acceleration at most `MAX_ACCELERATION` = 500 m/s^2, about 50 g: the
  fastest linear-motor stages reach 10-20 g (EMPS 1.3 m/s^2);
- the identified mass: the peak force would accelerate it at most at
  `MAX_ACCELERATION` (a mass too small for the force it takes; EMPS
  1.6 m/s^2);
- Coulomb friction at most `MAX_FRICTION_RATIO` = 2 times the weight M g of
  the identified mass: a friction coefficient of 2, beyond any guide
  (rolling guides 0.001-0.01, plain slides 0.05-0.3, rubber on steel about
  1). M is the equivalent mass, rotor inertia included, which only lowers the
  ratio (EMPS 0.022).

**A robot against its description** (CAD: URDF or built-in values):

- identified inertia within `MAX_INERTIA_FACTOR` = 10 of the description's,
  either way: CAD values are good to tens of per cent, a payload or a rotor
  inertia missing from a URDF adds a few times at most (real TX40: 0.36 to
  1.2 per joint against the nominal TX40, 1.9 for the whole arm against its
  URDF, which has no rotor inertias);
- peak joint speed at most `MAX_LIMIT_FACTOR` = 2 times the description's
  velocity limit (the real TX40 reaches 0.92 to 1.0 of its limits), and peak
  acceleration at most 2 times what the effort limit gives the description's
  smallest diagonal inertia of the joint (real TX40 at most 0.11 of it).

The likely cause (`scale_cause`) is the pattern of the table that fits the
inertia, viscous and static ratios within `AGREE_FACTOR` = 2 (root mean
square of the log misfit); none fitting, the description itself is blamed.
"""

import math

import numpy as np

#: Standard gravity (m/s^2) for the weight M g.
G = 9.81
#: Longest plausible travel of a linear positioning axis (m).
MAX_TRAVEL = 100.0
#: Fastest plausible speed of a linear axis (m/s).
MAX_SPEED = 20.0
#: Largest plausible acceleration of a linear axis (m/s^2, about 50 g).
MAX_ACCELERATION = 500.0
#: Largest plausible Coulomb friction over the weight M g of the identified mass.
MAX_FRICTION_RATIO = 2.0
#: Identified inertia over the description's: at most this factor either way.
MAX_INERTIA_FACTOR = 10.0
#: Peak joint speed and acceleration over the description's limits: at most this factor.
MAX_LIMIT_FACTOR = 2.0
#: A cause's pattern fits the scale ratios within this factor (root mean square of the log misfit).
AGREE_FACTOR = 2.0

#: The label every scale warning starts with.
LABEL = "scale check"


def row(check: str, value, limit: str, unit: str, passed) -> dict:
    """One check as `summary.json` holds it (`passed` None: not checked)."""
    v = None if value is None or not math.isfinite(value) else float(value)
    return {
        "check": check,
        "value": v,
        "limit": limit,
        "unit": unit,
        "passed": None if passed is None else bool(passed),
    }


def unit(r: dict) -> str:
    """The row's unit after a space (for the text), or nothing for a ratio."""
    return f" {r['unit']}" if r["unit"] else ""


def _peak(x) -> float:
    x = np.asarray(x, dtype=float)
    return float(np.max(np.abs(x))) if x.size else 0.0


def linear_axis_checks(inputs, fits: dict) -> list[dict]:
    """The physical checks of a linear axis (see the module): travel, speed, acceleration, mass, friction.

    `inputs`: a `Preprocessed` record (position m, force N; the filtered
    full-rate signals are used); `fits`: label -> `(M, Fc)` of each identified
    model (kg, N; the largest Coulomb coefficient of an asymmetric model).
    A fit with M <= 0 (a sign warning of its own) is not checked here.
    """
    q, dq, ddq, f = (np.asarray(getattr(inputs, k), dtype=float) for k in ("q_full", "dq_full", "ddq_full", "y_full"))
    travel = float(np.ptp(q)) if q.size else 0.0
    speed, acc, force = _peak(dq), _peak(ddq), _peak(f)
    out = [
        row("position range", travel, f"at most {MAX_TRAVEL:g}", "m", travel <= MAX_TRAVEL),
        row("peak speed", speed, f"at most {MAX_SPEED:g}", "m/s", speed <= MAX_SPEED),
        row("peak acceleration", acc, f"at most {MAX_ACCELERATION:g}", "m/s^2", acc <= MAX_ACCELERATION),
    ]
    good = {k: (m, fc) for k, (m, fc) in fits.items() if m > 0}
    if good:
        m = min(m for m, _ in good.values())
        a = force / m
        out.append(
            row("peak force / identified mass", a, f"at most {MAX_ACCELERATION:g}", "m/s^2", a <= MAX_ACCELERATION)
        )
        mu = max(fc / (m * G) for m, fc in good.values())
        out.append(
            row("Coulomb friction / weight M g", mu, f"at most {MAX_FRICTION_RATIO:g}", "", mu <= MAX_FRICTION_RATIO)
        )
    return out


def linear_axis_warnings(checks: list[dict], fits: dict) -> list[str]:
    """One warning naming every failed `linear_axis_checks` row, the likely cause and what to do (or none)."""
    failed = {r["check"]: r for r in checks if r["passed"] is False}
    if not failed:
        return []
    parts = [f"{r['check']} {r['value']:.4g}{unit(r)} ({r['limit']}{unit(r)})" for r in failed.values()]
    m, fc = min(((m, fc) for m, fc in fits.values() if m > 0), default=(None, None))
    what = "" if m is None else f" (identified M = {m:.4g} kg, Coulomb friction {fc:.4g} N)"
    if "position range" in failed:
        cause = (
            "the position is probably not in metres (millimetres give these values: divide it by 1000); mass and "
            "viscous friction scale with the position's unit, Coulomb friction and the force do not"
        )
    else:
        cause = (
            "the position is probably not in metres, or the time not in seconds (a sampling period dt too small "
            "makes speeds and accelerations too large)"
        )
    return [
        f"{LABEL}: the record and the identified model are not a linear axis in metres, newtons and seconds: "
        f"{', '.join(parts)}{what}. Likely cause: {cause}. Give the position in m (the CSV's position column, "
        "qm and qg of a .mat), the time in s and the force in N"
    ]


def rounded(x: float) -> str:
    """Two significant digits, without an exponent: 9.2, 84, 110, 0.00022."""
    return f"{float(f'{x:.2g}'):g}" if 1e-4 <= abs(x) < 1e4 else f"{x:.2g}"


def ratio(identified: float, nominal: float) -> float | None:
    """|identified| / |nominal|, or None when the nominal value is zero or either is not finite."""
    if not (math.isfinite(identified) and math.isfinite(nominal)) or nominal == 0 or identified == 0:
        return None
    return abs(identified) / abs(nominal)


def static_ratio(pairs) -> float | None:
    """Geometric mean of |identified| / |nominal| over the `(identified, nominal)` pairs whose nominal value is at
    least 1 % of the largest nominal one (terms that are not negligible in the description)."""
    pairs = [(float(a), float(b)) for a, b in pairs if math.isfinite(b)]
    top = max((abs(b) for _, b in pairs), default=0.0)
    logs = [math.log(r) for a, b in pairs if abs(b) >= 0.01 * top and (r := ratio(a, b)) is not None]
    return math.exp(sum(logs) / len(logs)) if logs and top > 0 else None


def scale_cause(inertia: float, *, viscous: float | None = None, static: float | None = None) -> tuple[str, float]:
    """The likely cause of an inertia ratio (identified / description) off by more than `MAX_INERTIA_FACTOR`.

    `viscous`, `static`: the same ratio (identified / description) for the
    viscous friction and for the terms that depend neither on time nor on
    the position's unit (Coulomb friction, gravity), None where the
    description has none. Two patterns (the module's table) are fitted to
    the log-ratios by least squares:

    - a sampling period k times too large: inertia k^2, viscous k, static 1;
    - a torque c times too large: inertia, viscous and static all c.

    Returns `("time scale", k)` or `("torque scale", c)`, the better fit
    (the time scale on a tie: with the inertia alone both fit), or
    `("load", ratio)` when neither fits within `AGREE_FACTOR` (root mean
    square of the log-ratios' misfit): a load or part the description lacks,
    or a description of another machine.
    """
    obs = [(2.0, math.log(inertia))]
    obs += [] if viscous is None else [(1.0, math.log(viscous))]
    obs += [] if static is None else [(0.0, math.log(static))]
    t = sum(e * v for e, v in obs) / sum(e * e for e, _ in obs)
    c = sum(v for _, v in obs) / len(obs)
    miss_t = math.sqrt(sum((v - e * t) ** 2 for e, v in obs) / len(obs))
    miss_c = math.sqrt(sum((v - c) ** 2 for _, v in obs) / len(obs))
    if min(miss_t, miss_c) > math.log(AGREE_FACTOR):
        return "load", inertia
    return ("time scale", math.exp(t)) if miss_t <= miss_c else ("torque scale", math.exp(c))


def inertia_warning(
    what: str, identified: float, nominal: float, basis: str, *, viscous=None, static=None, dt=None, options: dict
) -> str | None:
    """The warning for an inertia `identified` off its description's `nominal` by more than `MAX_INERTIA_FACTOR`.

    `what`: the parameter ("the identified inertia ZZ2"); `basis`: where `nominal` comes from; `viscous`,
    `static`: ratios for `scale_cause`; `dt`: the record's sampling period (s); `options`: cause -> the argument
    (and flag) that fixes it, for "time scale" and "torque scale". None when within the factor.
    """
    r = ratio(identified, nominal)
    if r is None or 1 / MAX_INERTIA_FACTOR <= r <= MAX_INERTIA_FACTOR:
        return None
    cause, f = scale_cause(r, viscous=viscous, static=static)
    head = (
        f"{LABEL}: {what} = {identified:.4g} kg m^2 is {r:.3g} times {basis} ({nominal:.4g} kg m^2), beyond the "
        f"factor {MAX_INERTIA_FACTOR:g} a CAD value, a payload or a missing rotor inertia explains"
    )
    seen = []
    if viscous is not None:
        seen.append(f"viscous friction {viscous:.3g} times the description's")
    if static is not None:
        seen.append(f"Coulomb friction and gravity {static:.3g} times")
    seen = f" ({', '.join(seen)})" if seen else ""
    if cause == "time scale":
        k = max(f, 1 / f)
        big, small = ("large", "small") if f > 1 else ("small", "large")
        fix = "" if dt is None else f": dt = {dt:.4g} s is probably about {rounded(dt / f)} s"
        return (
            f"{head}{seen}: the pattern of a sampling period about {rounded(k)} times too {big} (velocities "
            f"{rounded(k)} and accelerations {rounded(k**2)} times too {small}, inertia {rounded(k**2)} times too "
            f"{big}){fix}; set {options['time scale']}"
        )
    if cause == "torque scale":
        return (
            f"{head}{seen}: every torque term is off alike, about {rounded(f)} times: the torques are probably in "
            f"other units; check {options['torque scale']}"
        )
    return (
        f"{head}{seen}: neither a time scale nor a torque unit fits the pattern; a load or part the description "
        "lacks, or a description of another robot: check the description and the payload"
    )
