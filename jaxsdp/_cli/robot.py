"""`jaxsdp robot`: every joint of a serial robot identified at once from its URDF and its joint logs.

1. the robot: `--urdf FILE` (`SerialRobot.from_urdf`, `--base-link`,
   `--tip-link`); its drives: `--drives FILE.toml` or a built-in name
   (`tx40`), else the logs are taken as joint side;
2. the logs: `--positions`, `--torques` (CSV or .mat, header Joint_1..Joint_n,
   no time column: `--dt`);
3. the stacked IDIM-LS of every joint and the multi-SDP of each joint's
   residual (`jaxsdp.studies.robot.robot_study`); prints the per-joint table,
   writes `report.md`, `summary.json` and the figures.
"""

import functools

from ..studies._output import one_line
from .common import CLIError, data_file, int_at_least, nonnegative_float, positive_float, run_study

NAME = "robot"
DEFAULT_OUT = "jaxsdp-robot-out"
LABELS = {
    "model": "The stacked full model and its base parameters",
    "idim_ls": "IDIM-LS of every joint",
    "sdp": "Multi-SDP of each joint's residual",
    "figures": "Figures",
    "report": "Writing report.md and summary.json",
}


def _joints(text):
    try:
        out = [int(v) for v in text.split(",")]
    except ValueError:
        import argparse

        raise argparse.ArgumentTypeError(f"must be joint numbers J1,J2,...; got {text!r}") from None
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
        epilog="Example: jaxsdp robot --urdf tx40.urdf --drives tx40 --positions POS.csv --torques CURR.csv "
        "--dt 2e-4 --out tx40-robot",
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
    d.add_argument("--positions", metavar="FILE", required=True, help="joint-log positions, CSV or .mat")
    d.add_argument("--torques", metavar="FILE", required=True, help="joint-log torques or currents, CSV or .mat")
    d.add_argument("--dt", metavar="S", type=positive_float, required=True, help="sample time (s; the logs have none)")
    a = p.add_argument_group("processing and identification")
    a.add_argument("--joints", metavar="J1,..", type=_joints, default=None, help="joints to identify (default: all)")
    a.add_argument("--decimate", metavar="R", type=int_at_least(1), default=10, help="decimation (default: 10)")
    a.add_argument("--cutoff", metavar="HZ", type=positive_float, default=100.0, help="Butterworth (default: 100)")
    a.add_argument(
        "--min-speed",
        metavar="RAD_S",
        type=_min_speed,
        default="auto",
        help="rows slower than this are at rest and left out (rad/s; default: auto, 1 %% of each joint's peak speed)",
    )
    a.add_argument("--no-sdp", action="store_true", help="skip the multi-SDP of each joint's residual")
    o = p.add_argument_group("output")
    o.add_argument("--out", metavar="DIR", default=DEFAULT_OUT, help=f"output directory (default: ./{DEFAULT_OUT})")
    o.add_argument("--format", choices=("png", "pdf", "svg"), default="png", help="figure format (default: png)")
    o.add_argument("--dpi", metavar="DPI", type=positive_float, default=150.0, help="raster resolution (default: 150)")
    o.add_argument("--quiet", action="store_true", help="no progress display (tables are still printed on stdout)")
    p.set_defaults(run=run_robot)


def _call(args, progress, staging):
    from ..data._drives import Drives
    from ..data._joint_logs import load_joint_logs
    from ..plants.robot._serial import SerialRobot
    from ..studies.robot._study import robot_study

    progress.start("load")
    try:
        robot = SerialRobot.from_urdf(data_file(args.urdf, "--urdf"), base_link=args.base_link, tip_link=args.tip_link)
    except ValueError as e:
        raise CLIError(f"--urdf {args.urdf}: {one_line(e)}") from None
    drives = None
    if args.drives is not None:
        try:
            drives = Drives.from_toml(args.drives)
        except ValueError as e:
            raise CLIError(f"--drives: {one_line(e)}") from None
        if drives.n != robot.n:
            raise CLIError(f"--drives describes {drives.n} motors; the robot of --urdf has {robot.n} joints")
    pos, trq = data_file(args.positions, "--positions"), data_file(args.torques, "--torques")
    try:
        logs = load_joint_logs(pos, trq, dt=args.dt)
    except (ValueError, OSError) as e:
        raise CLIError(one_line(e)) from None
    if len(logs.joints) != robot.n:
        raise CLIError(f"the logs hold {len(logs.joints)} joints; the robot of --urdf has {robot.n} ({robot.names})")
    return robot_study(
        logs,
        robot=robot,
        drives=drives,
        joints=args.joints,
        cutoff_hz=args.cutoff,
        decimate=args.decimate,
        min_speed=args.min_speed,
        sdp=not args.no_sdp,
        source=f"{args.positions} + {args.torques} ({args.urdf})",
        progress=progress.start,
    )


def run_robot(args) -> int:
    """Run the robot study and write what it returns; returns the exit code."""
    from ..studies import robot
    from ..studies.robot._study import STAGES

    stages = ["load", *STAGES[:2]] + ([STAGES[2]] if not args.no_sdp else [])
    labels = {"load": "Reading the description and the logs", **LABELS}
    return run_study(args, name=NAME, stages=stages, labels=labels, call=functools.partial(_call, args), contract=robot)
