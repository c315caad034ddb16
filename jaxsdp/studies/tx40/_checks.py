"""The TX40 study at neighbouring processing settings: is the shape verdict robust, which choice moves what.

`settings_check` re-runs the study's stages at the settings a reviewer
would try next to the chosen ones:

- the shape test (`ShapeTest`: do the SDP curves depart from eq. (20)'s
  shapes?) at rest thresholds 0, 0.01, 0.05 rad/s and decimations 5, 10,
  20; the verdict is "mismatch" or "match" when every setting agrees, else
  "fragile";
- IDIM-LS (cheap) at rest thresholds 0, 0.01, 0.2 rad/s, Butterworth
  cut-offs 50 and 200 Hz and decimations 5 and 20: how far each parameter
  moves, in the paper's standard deviations when the paper's table is the
  reference, else in the study's own stated ones.

`scale_checks` compares the identified inertia with the description's
(`jaxsdp.plants.robot._plausibility.one_joint_checks`): a wrong `dt`, torque
unit or angle unit is warned with its likely cause.
"""

import numpy as np

from ...data._model_convention import model_convention
from ...plants.robot._joint_model import GRAVITY
from ...plants.robot._joint_stages import joint_idim_ls, joint_multi_sdp, joint_preprocess
from ...plants.robot._plausibility import nominal_joint, one_joint_checks, one_link_gravity

#: The shape test's neighbouring settings (the issue's and a reviewer's list).
SHAPE_SETTINGS = (
    ("min_speed", 0.0),
    ("min_speed", 0.01),
    ("min_speed", 0.05),
    ("decimate", 5),
    ("decimate", 10),
    ("decimate", 20),
)
#: IDIM-LS's neighbouring settings.
SENSITIVITY_SETTINGS = (
    ("min_speed", 0.0),
    ("min_speed", 0.01),
    ("min_speed", 0.2),
    ("cutoff_hz", 50.0),
    ("cutoff_hz", 200.0),
    ("decimate", 5),
    ("decimate", 20),
)
_UNIT = {"min_speed": "rad/s", "cutoff_hz": "Hz", "decimate": ""}
_LABEL = {"min_speed": "rest threshold", "cutoff_hz": "cut-off", "decimate": "decimation"}


def setting_label(name: str, value) -> str:
    """'rest threshold 0.01 rad/s', 'decimation 20', ..."""
    return f"{_LABEL[name]} {value:g} {_UNIT[name]}".rstrip()


def _same(name, value, settings, idim) -> bool:
    if name == "min_speed":
        return abs(float(value) - idim.min_speed) < 1e-12
    return settings[name] == value


def settings_check(logs, *, inputs, idim, sdp, settings: dict, pre_kw: dict, sdp_kw: dict, scales: dict) -> dict:
    """The shape verdict and the IDIM-LS parameters at neighbouring settings (see the module).

    `inputs`, `idim`, `sdp`: the study's own stages (reused, not re-run);
    `settings`: the study's settings (`joint`, `min_speed`, `decimate`,
    `cutoff_hz`, `inertia`); `pre_kw`: its `joint_preprocess` options;
    `sdp_kw`: its `joint_multi_sdp` options; `scales`: name -> the standard
    deviation a parameter's move is measured in.

    **Returns** `{"shape": [{"setting", "statistic", "mismatch"}],
    "verdict": "mismatch" | "match" | "fragile", "sensitivity": [{"setting",
    name: move, ...}]}` (moves in `scales`' units), the study's own setting
    first in "shape".
    """
    joint = settings["joint"]
    pre_cache = {(settings["decimate"], settings["cutoff_hz"]): inputs}

    def pre(decimate, cutoff_hz):
        key = (decimate, cutoff_hz)
        if key not in pre_cache:
            options = pre_kw | {"decimate": decimate, "cutoff_hz": cutoff_hz}
            pre_cache[key] = joint_preprocess(logs, joint=joint, **options)
        return pre_cache[key]

    ls_cache = {}

    def ls(name, value):
        if (name, value) not in ls_cache:
            kw = {k: settings[k] for k in ("min_speed", "decimate", "cutoff_hz")} | {name: value}
            p = pre(kw["decimate"], kw["cutoff_hz"])
            ls_cache[(name, value)] = (p, joint_idim_ls(p, joint=joint, min_speed=kw["min_speed"]))
        return ls_cache[(name, value)]

    own = idim.min_speed
    shape = [
        {
            "setting": f"as run (rest threshold {own:.3g} rad/s, decimation {settings['decimate']})",
            "statistic": sdp.shape.statistic,
            "mismatch": sdp.shape.mismatch,
        }
    ]
    for name, value in SHAPE_SETTINGS:
        if _same(name, value, settings, idim):
            continue
        p, i = ls(name, value)
        zz = i.result[f"ZZ{joint}"] if settings["inertia"] == "IDIM-LS" else float(settings["inertia"])
        if not zz > 0:
            continue
        s = joint_multi_sdp(p, inertia=zz, moving=i.moving, joint=joint, **sdp_kw)
        shape.append(
            {"setting": setting_label(name, value), "statistic": s.shape.statistic, "mismatch": s.shape.mismatch}
        )
    verdicts = {row["mismatch"] for row in shape}
    verdict = "fragile" if len(verdicts) > 1 else ("mismatch" if verdicts.pop() else "match")
    base = idim.result
    sensitivity = []
    for name, value in SENSITIVITY_SETTINGS:
        if _same(name, value, settings, idim):
            continue
        _, i = ls(name, value)
        row = {"setting": setting_label(name, value)}
        for k, sd in scales.items():
            row[k] = (i.result[k] - base[k]) / sd if sd and np.isfinite(sd) else None
        sensitivity.append(row)
    return {"shape": shape, "verdict": verdict, "sensitivity": sensitivity}


#: What fixes each cause of a failed scale check in `tx40_study` / `jaxsdp tx40`.
SCALE_OPTIONS = {
    "time scale": "`dt` of load_joint_logs",
    "torque scale": "`torque_constants` and `ratios` of load_joint_logs",
}
#: Configurations the nominal robot is evaluated at (evenly spaced over the record).
SCALE_CONFIGURATIONS = 64


def scale_checks(logs, inputs, idim, *, joint: int, reference, basis: str, robot, offsets, coupling):
    """The identified inertia of `joint` against the description: `(rows, warnings)` of `one_joint_checks`.

    The description is the reference table (`reference`, named `basis`) when it
    gives ZZ of the joint, else the nominal robot (`robot`, default
    `tx40_robot()`) as a one-link arm over the logged configurations brought
    to its convention (`offsets`, `coupling`), when the logs hold all its
    joints; else nothing is compared (the rows say so, `passed` None).
    """
    n = {k: f"{k}{joint}" for k in ("ZZ", "Fv", "Fc", "MX", "MY")}
    est = {k: idim.result[v] for k, v in n.items()}
    q = np.asarray(inputs.q, dtype=float)
    identified = {k: est[k] for k in ("ZZ", "Fv", "Fc")} | {
        "gravity": one_link_gravity(est["MX"], est["MY"], q, GRAVITY)
    }
    nominal = {}
    if reference and n["ZZ"] in reference:
        get = {k: reference.get(v) for k, v in n.items()}
        nominal = {k: get[k] for k in ("ZZ", "Fv", "Fc")}
        if get["MX"] is not None and get["MY"] is not None:
            nominal["gravity"] = one_link_gravity(get["MX"], get["MY"], q, GRAVITY)
    else:
        from ...plants.robot._tx40 import tx40_robot

        robot = tx40_robot() if robot is None else robot
        if tuple(logs.joints) == tuple(range(1, robot.n + 1)):
            qm = np.asarray(model_convention(logs, offsets=offsets, coupling=coupling).q, dtype=float)
            pick = np.linspace(0, qm.shape[0] - 1, SCALE_CONFIGURATIONS).round().astype(int)
            nominal = nominal_joint(robot, qm[pick], joint)
            basis = "the nominal robot's"
    return one_joint_checks(identified, nominal, joint=joint, basis=basis, dt=float(logs.dt), options=SCALE_OPTIONS)
