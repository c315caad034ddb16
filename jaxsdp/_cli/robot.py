"""`jaxsdp robot`: every joint of a serial robot identified at once from its URDF and its joint logs.

1. the robot: `--urdf FILE` (`SerialRobot.from_urdf`, `--base-link`,
   `--tip-link`); its drives: `--drives FILE.toml` or a built-in name
   (`tx40`), else the logs are taken as joint side;
2. the logs: `--positions`, `--torques` (CSV or .mat; columns named after the
   URDF's joints, in any order, or Joint_1..Joint_n; other columns ignored
   with a note; optionally a time column `t`/`time`, without one `--dt`) and
   `--velocities` (optional), or `--bag` (a ROS 1 or ROS 2 bag's
   sensor_msgs/JointState messages, `--topic` when it has several); time
   stamps that jitter within 0.5-1.5 x the median step are interpolated onto
   a uniform grid with a note, gaps refused unless `--resample`;
3. the stacked IDIM-LS of every joint and the multi-SDP of each joint's
   residual (`jaxsdp.studies.robot.robot_study`), the physically consistent
   estimate (`--export-urdf` writes it), each joint's friction law with
   `--friction`; prints the per-joint table,
   writes `report.md`, `summary.json` and the figures.

With `--excite` (no logs): an exciting trajectory from the URDF alone
(`jaxsdp.studies.robot.excitation_study`), written as `trajectory.csv`, the
`trajectory` figure, `report.md` and `summary.json`.
"""

import argparse
import functools
import pathlib
import re
import sys

from .._checks import OptionError
from .._idim.estimators import IDIMIV
from ..studies._output import one_line
from .common import (
    FRICTION,
    CLIError,
    data_file,
    int_at_least,
    nonnegative_float,
    option_error,
    positive_float,
    run_study,
)

NAME = "robot"
#: Python arguments the library's messages name whose option is named differently (`common.cli_text`).
FLAGS = {"cutoff_hz": "--cutoff", "`dt` of load_joint_logs": "--dt", "path": "--bag", "`iv=None`": "--estimator ls"}
DEFAULT_OUT = "jaxsdp-robot-out"
LABELS = {
    "model": "The stacked full model and its base parameters",
    "idim_ls": "IDIM-LS of every joint",
    "physical": "The physically consistent estimate",
    "sdp": "Multi-SDP of each joint's residual",
    "friction": "Friction laws (BIC, cross-validation, joint fit)",
    "figures": "Figures",
    "report": "Writing report.md and summary.json",
}
EXCITE_LABELS = {
    "optimise": "Optimising the exciting trajectory (BFGS)",
    "simulate": "Simulating the robot on it",
    "identify": "Identifying the simulated robot",
    "figures": "Figures",
    "report": "Writing report.md, summary.json and trajectory.csv",
}


def _joints(text):
    try:
        out = [int(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be joint numbers J1,J2,...; got {text!r}") from None
    if min(out) < 1 or len(set(out)) < len(out):
        raise argparse.ArgumentTypeError(f"must be distinct joint numbers >= 1; got {text!r}")
    return out


def _min_speed(text):
    return "auto" if text.strip().lower() == "auto" else nonnegative_float(text)


def add_parser(sub) -> None:
    """Register the `robot` subcommand on the subparsers `sub`."""
    p = sub.add_parser(
        NAME,
        help="any serial robot from its URDF: all joints identified at once, the SDP of each residual",
        description=(
            "Identify every joint of a serial robot at once from its description (URDF) and joint logs: the stacked "
            "full rigid-body model with each motor's inertia and friction (through the drives' coupling), its base "
            "parameters, one IDIM-LS on every joint's rows, then the multi-SDP of each joint's residual."
        ),
        epilog="Examples: jaxsdp robot --urdf tx40.urdf --drives tx40 --positions POS.csv --torques CURR.csv "
        "--dt 2e-4 --out tx40-robot;  jaxsdp robot --urdf arm.urdf --bag run1.mcap --topic /joint_states;  "
        "jaxsdp robot --urdf tx40.urdf --excite --out tx40-excite",
    )
    d = p.add_argument_group("robot and data")
    d.add_argument("--urdf", metavar="FILE", required=True, help="the robot's description (URDF)")
    d.add_argument("--base-link", metavar="LINK", default=None, help="the chain's first link (default: the root)")
    d.add_argument(
        "--tip-link", metavar="LINK", default=None, help="the chain's last link (default: after the last joint)"
    )
    d.add_argument(
        "--drives",
        metavar="FILE|NAME",
        default=None,
        help="drive description: a TOML file (ratios, torque_constants, signs, offsets, coupling) or a built-in "
        "name (tx40); default: the logs are joint side",
    )
    d.add_argument(
        "--positions",
        metavar="FILE",
        help="joint-log positions, CSV or .mat: one column per joint named after the URDF's joint or Joint_<k>, "
        "optionally a time column t or time and velocity columns <joint>_vel (other columns are ignored, with a note)",
    )
    d.add_argument(
        "--torques", metavar="FILE", help="joint-log torques or currents, CSV or .mat, columns as --positions"
    )
    d.add_argument(
        "--velocities", metavar="FILE", help="joint-log velocities, CSV or .mat, columns as --positions (optional)"
    )
    d.add_argument(
        "--bag",
        metavar="FILE",
        help="a ROS 1 .bag file, a ROS 2 bag folder or its .db3/.mcap file: the sensor_msgs/JointState messages "
        "(position, velocity, effort; joints matched to the URDF by name) instead of --positions/--torques",
    )
    d.add_argument("--topic", metavar="NAME", help="the bag's JointState topic (default: its only one)")
    d.add_argument(
        "--dt",
        metavar="S",
        type=positive_float,
        default=None,
        help="sample time (s); needed when the logs have no time column (`t` or `time`), checked against it otherwise",
    )
    d.add_argument(
        "--resample",
        action="store_true",
        help="accept a time column with gaps (steps beyond 0.5-1.5 x the median step): interpolate the logs linearly "
        "onto a uniform grid at the median step, recorded in summary.json (default: time stamps that jitter within "
        "that band are interpolated so, with a note; gaps are refused, naming the first)",
    )
    a = p.add_argument_group("processing and identification")
    a.add_argument("--joints", metavar="J1,..", type=_joints, default=None, help="joints to identify (default: all)")
    a.add_argument(
        "--decimate",
        metavar="R",
        type=int_at_least(1),
        default=None,
        help="decimation (default: from the sampling rate, the decimated rate at least 5 x the cut-off; 10 at 5 kHz)",
    )
    a.add_argument(
        "--cutoff",
        metavar="HZ",
        type=positive_float,
        default=None,
        help="Butterworth cut-off (default: from the logs: fs / 5 up to 100 Hz, lowered to where the encoders' noise "
        "in the acceleration reaches 1 %% of the motion's, raised for fast motion; stated in report.md)",
    )
    a.add_argument(
        "--min-speed",
        metavar="RAD_S",
        type=_min_speed,
        default=None,
        help="rows slower than this are at rest and left out (rad/s; default: auto, 1 %% of each joint's peak speed)",
    )
    a.add_argument("--no-sdp", action="store_true", help="skip the multi-SDP of each joint's residual")
    a.add_argument(
        "--no-physical", action="store_true", help="skip the physically consistent estimate (every link a rigid body)"
    )
    a.add_argument(
        "--estimator",
        choices=("ls", "iv"),
        default="ls",
        help="ls: IDIM-LS; iv: the iterated bias-compensated IDIM-IV started from it, its instruments the identified "
        "robot simulated following the logged angles (joint-side or uncoupled drives; default: ls)",
    )
    a.add_argument(
        "--friction",
        choices=tuple(FRICTION),
        default=None,
        help=(
            "also read each joint's friction law off its residual: auto (per motor, the one of least BIC among "
            "viscous-coulomb, asymmetric, smooth-coulomb and stribeck), or one of them; a law is kept only where it "
            "lowers its joint's cross-validated error, and is estimated with the rigid body (default: viscous + "
            "Coulomb only)"
        ),
    )
    e = p.add_argument_group("exciting trajectory (--excite: no logs needed)")
    e.add_argument(
        "--excite",
        action="store_true",
        help="design an exciting trajectory instead: Fourier series per joint minimising the condition number of "
        "the stacked base regressor within the URDF's joint limits, checked by identifying the simulated robot on it",
    )
    e.add_argument(
        "--harmonics", metavar="L", type=int_at_least(1), default=None, help="harmonics per joint (default 5)"
    )
    e.add_argument("--f0", metavar="HZ", type=positive_float, default=None, help="fundamental (Hz; default 0.1)")
    e.add_argument(
        "--max-accel", metavar="RAD_S2", type=positive_float, default=None, help="acceleration limit (default 10)"
    )
    e.add_argument("--max-steps", metavar="K", type=int_at_least(1), default=None, help="BFGS steps (default 100)")
    e.add_argument("--seed", metavar="S", type=int_at_least(0), default=None, help="random start and check noise")
    e.add_argument("--no-check", action="store_true", help="skip the simulated identification check")
    o = p.add_argument_group("output")
    o.add_argument("--out", metavar="DIR", default=DEFAULT_OUT, help=f"output directory (default: ./{DEFAULT_OUT})")
    o.add_argument(
        "--export-urdf",
        metavar="FILE",
        default=None,
        help="write the physically consistent robot as FILE (.urdf) and its drives as FILE's .drives.json",
    )
    p.set_defaults(run=run_robot)


def _link_options(message: str) -> str:
    """The description's errors in the command's words: --base-link, --tip-link (never a quoted link name); the
    command has no way to list the chain's joints (its --joints picks the joints to identify)."""
    message = re.sub(r",?\s+or joints=", "", message)
    flag = lambda m: f"--{m.group(1)}-link" + " " * bool(m.group(2))  # tip_link='x' -> --tip-link 'x'
    return re.sub(r"(?<!')\b(base|tip)_link\b(?!')(=?)", flag, message)


def _robot(args):
    from ..plants.robot._serial import SerialRobot

    try:
        robot = SerialRobot.from_urdf(data_file(args.urdf, "--urdf"), base_link=args.base_link, tip_link=args.tip_link)
    except OptionError as e:  # a --base-link or --tip-link the description does not have: a usage error
        raise CLIError(_link_options(one_line(e)), code=2) from None
    except ValueError as e:
        raise CLIError(f"--urdf {args.urdf}: {_link_options(one_line(e))}") from None
    outside = [j for j in args.joints or () if j > robot.n]
    if outside:
        raise CLIError(
            f"--joints {','.join(map(str, args.joints))}: the robot of --urdf has joints 1..{robot.n} "
            f"({', '.join(robot.names)}); drop {','.join(map(str, outside))}",
            code=2,
        )
    return robot


#: Options of one mode only, with their defaults (None on the command line means "not given").
#: decimate and cutoff None: the study derives them from the logs.
LOG_OPTIONS = {"dt": None, "resample": False, "decimate": None, "cutoff": None, "min_speed": "auto"}
EXCITE_OPTIONS = {"harmonics": 5, "f0": 0.1, "max_accel": 10.0, "max_steps": 100, "seed": 0, "no_check": False}


def _given(args, names):
    return ["--" + k.replace("_", "-") for k in names if getattr(args, k) not in (None, False)]


def _check_mode(args) -> None:
    """Refuse options that the chosen mode would ignore (exit 2), then fill in the defaults of the mode."""
    files = _given(args, ("positions", "torques", "velocities"))
    bag = _given(args, ("bag", "topic"))
    if args.export_urdf is not None:
        target = pathlib.Path(args.export_urdf)
        if args.excite or args.no_physical:
            raise CLIError("--export-urdf writes the physically consistent estimate of logs: drop --excite and "
                           "--no-physical", code=2)  # fmt: skip
        if target.suffix != ".urdf" or not target.parent.is_dir():
            raise CLIError(f"--export-urdf: {target} must end in .urdf, in a folder that exists", code=2)
    if args.excite:
        extra = files + bag + (["--drives"] if args.drives is not None else [])
        extra += [f for f, on in (("--no-sdp", args.no_sdp), ("--no-physical", args.no_physical)) if on]
        extra += _given(args, ("friction",)) + (["--estimator"] if args.estimator != "ls" else [])
        extra += _given(args, LOG_OPTIONS)
        if extra:
            raise CLIError(f"--excite designs a trajectory from the URDF alone; drop {', '.join(extra)}", code=2)
    elif args.bag is not None:
        extra = files + _given(args, ("dt",))
        if extra:
            raise CLIError(f"--bag holds the logs and their time stamps; drop {', '.join(extra)}", code=2)
    else:
        if "--topic" in bag:
            raise CLIError("--topic names a topic of --bag; give --bag FILE or drop --topic", code=2)
        logs = [o for o in files if o != "--velocities"]
        if len(logs) < 2:
            missing = [o for o in ("--positions", "--torques") if o not in logs]
            raise CLIError(
                f"{' and '.join(missing)} required, or --bag FILE (or --excite to design an exciting trajectory)",
                code=2,
            )
        extra = _given(args, EXCITE_OPTIONS)
        if extra:
            raise CLIError(f"{', '.join(extra)} only apply with --excite (the exciting trajectory's design)", code=2)
    for k, v in {**LOG_OPTIONS, **EXCITE_OPTIONS}.items():
        if getattr(args, k) is None:
            setattr(args, k, v)


def _excite(args, progress):
    from ..studies.robot._excite import ExcitationDesign, excitation_study

    progress.start("load")
    robot = _robot(args)
    design = ExcitationDesign(
        harmonics=args.harmonics, f0=args.f0, max_steps=args.max_steps, acceleration_limits=args.max_accel
    )
    return excitation_study(
        robot,
        joints=args.joints,
        design=design,
        check=not args.no_check,
        seed=args.seed,
        source=args.urdf,
        progress=progress.start,
    )


#: The library's argument names in its messages, as the command line spells them.
LOG_FLAGS = {
    "dt": "--dt",
    "velocities": "--velocities",
    "topic": "--topic",
    "path": "--bag",
    "positions": "--positions",
    "torques": "--torques",
    "names": "the joint names of --urdf",
}


def _load_logs(args, robot):
    """The joint logs of --bag or --positions/--torques (--velocities), their columns matched to the URDF's joint
    names; (logs, the source named in the report)."""
    from ..data._bags import load_joint_bag
    from ..data._joint_logs import load_joint_logs
    from ..data._loaders import IrregularSamplingError
    from ..data._log_tables import MissingJointsError

    irregular = "resample" if args.resample else "jitter"
    try:
        if args.bag is not None:
            if not pathlib.Path(args.bag).exists():
                raise CLIError(f"--bag {args.bag}: no such file or folder")
            logs = load_joint_bag(args.bag, topic=args.topic, names=robot.names, irregular=irregular)
            source = f"{args.bag}, topic {logs.source.rsplit(' ', 1)[-1]} ({args.urdf})"
        else:
            pos, trq = data_file(args.positions, "--positions"), data_file(args.torques, "--torques")
            vel = None if args.velocities is None else data_file(args.velocities, "--velocities")
            logs = load_joint_logs(pos, trq, dt=args.dt, names=robot.names, velocities=vel, irregular=irregular)
            source = f"{args.positions} + {args.torques} ({args.urdf})"
    except IrregularSamplingError as e:
        advice = "pass --resample to interpolate them linearly onto a uniform grid, or split them into uniform records"
        raise CLIError(f"{e.detail}; {advice}") from None
    except OptionError as e:  # --dt missing (no time column) or disagreeing with the time column: a usage error
        raise option_error(e, LOG_FLAGS) from None
    except MissingJointsError as e:
        raise CLIError(_flags(one_line(e)) + _tip_advice(args.urdf, robot, e.missing)) from None
    except (ValueError, OSError) as e:
        raise CLIError(_flags(one_line(e))) from None
    return logs, source


def _tip_advice(urdf, robot, missing) -> str:
    """When the logs lack only the chain's last joints (a gripper or tool joint they do not log): the --tip-link
    that leaves them out of the robot; else nothing."""
    import xml.etree.ElementTree as ET

    names, missing = list(robot.names), list(missing)
    k = len(names) - len(missing)
    if k < 1 or names[k:] != missing:
        return ""
    try:
        parents = {el.get("name"): el.find("parent").get("link") for el in ET.parse(urdf).getroot().findall("joint")}
    except (ET.ParseError, OSError, AttributeError):
        return ""
    link = parents.get(names[k])
    if link is None:
        return ""
    last = names[k - 1]
    return f"; if the logs end at joint '{last}' (the rest a gripper or tool they do not log), pass --tip-link {link}"


def _flags(message: str) -> str:
    for name, flag in LOG_FLAGS.items():
        message = message.replace(f"`{name}`", flag)
    return message


#: The study's processing arguments and their options, for its messages.
PROCESSING_FLAGS = {"cutoff_hz": "--cutoff", "decimate": "--decimate", "min_speed": "--min-speed"}


def _call(args, progress, staging):
    from ..data._drives import Drives
    from ..plants.robot._defaults import RobotProcessing
    from ..studies.robot._study import robot_study

    if args.excite:
        return _excite(args, progress)
    progress.start("load")
    robot = _robot(args)
    drives = None
    if args.drives is not None:
        try:
            drives = Drives.from_toml(args.drives)
        except ValueError as e:
            raise CLIError(f"--drives: {one_line(e)}") from None
        if drives.n != robot.n:
            raise CLIError(f"--drives describes {drives.n} motors; the robot of --urdf has {robot.n} joints")
    logs, source = _load_logs(args, robot)
    if not args.quiet:
        for note in (logs.resampled, *logs.notes):
            if note is not None:
                print(f"jaxsdp {NAME}: note: {_flags(note)}", file=sys.stderr)
    if len(logs.joints) != robot.n:
        raise CLIError(f"the logs hold {len(logs.joints)} joints; the robot of --urdf has {robot.n} ({robot.names})")
    try:
        return robot_study(
            logs,
            robot=robot,
            drives=drives,
            joints=args.joints,
            processing=RobotProcessing(cutoff_hz=args.cutoff, decimate=args.decimate, min_speed=args.min_speed),
            sdp=not args.no_sdp,
            physical=not args.no_physical,
            friction=None if args.friction is None else FRICTION[args.friction],
            iv=IDIMIV() if args.estimator == "iv" else None,
            source=source,
            progress=progress.start,
        )
    except OptionError as e:  # a processing option that cannot work on these logs: checked before any work
        raise option_error(e, PROCESSING_FLAGS) from None


def run_robot(args) -> int:
    """Run the robot study (or, with --excite, the excitation study) and write what it returns; the exit code."""
    from ..studies.robot._excite import EXCITE_STAGES
    from ..studies.robot._excite_report import write_trajectory
    from ..studies.robot._study import STAGES

    _check_mode(args)
    if args.excite:
        stages = ["load", "optimise"] + ([] if args.no_check else list(EXCITE_STAGES[1:]))
        labels = {"load": "Reading the description", **EXCITE_LABELS}
        return run_study(
            args,
            name=NAME,
            stages=stages,
            labels=labels,
            call=functools.partial(_call, args),
            extra_files=write_trajectory,
        )
    skipped = {"physical": args.no_physical, "sdp": args.no_sdp, "friction": args.friction is None}
    skipped["validation"] = True  # not announced
    stages = ["load"] + [s for s in STAGES if not skipped.get(s, False)]
    labels = {"load": "Reading the description and the logs", **LABELS}
    export = None if args.export_urdf is None else functools.partial(_export_urdf, args.export_urdf)
    return run_study(
        args, name=NAME, stages=stages, labels=labels, call=functools.partial(_call, args), extra_files=export
    )


def _export_urdf(path, result, staging) -> list:
    """--export-urdf: the physically consistent robot as a URDF and its drives beside it (outside --out)."""
    from ..plants.robot._urdf_export import write_urdf

    robot = result.physical.robot(result.idim.model.robot)
    urdf, drives = write_urdf(robot, path, transmission=result.idim.model.transmission)
    print(f"jaxsdp {NAME}: wrote {urdf} and {drives.name} (the physically consistent robot)", file=sys.stderr)
    return []
