"""`jaxsdp montecarlo`: Monte Carlo robustness studies on the built-in EMPS plant.

- `--study identification`: n noisy closed-loop experiments, each identified
  by the whole EMPS study (IDIM-LS, IDIM-IV, SDP, IDIM-SDP): bias, spread,
  honesty of the stated standard errors (coverage of the 95 % intervals);
- `--study control`: n plants drawn around the nominal model (uniform
  +-`--spread`, or from the IDIM-LS covariance), linear PD, SDP-PD and
  PIP-SDP step responses designed on the nominal model;
- `--study robot`: n robots drawn around a description (`--urdf`, default
  the built-in TX40), each simulated on an exciting trajectory and
  identified by IDIM-LS (and by IDIM-IV with `--iv`; `--disturbance` puts
  the closed-loop case in the experiment): bias, spread and coverage of the
  base parameters.

Writes `report.md`, `summary.json` and the figures to `--out` (staged, moved
in at the end, as the other commands).
"""

import argparse
import sys

from .common import CLIError, int_at_least, nonnegative_float, run_study, seed

NAME = "montecarlo"
DEFAULT_OUT = "jaxsdp-montecarlo-out"
STUDIES = ("identification", "control", "robot")


def fraction(text):
    v = nonnegative_float(text)
    if not v < 1.0:
        raise argparse.ArgumentTypeError(f"must be a number in [0, 1); got {text!r}")
    return v


def add_parser(sub) -> None:
    """Register the `montecarlo` subcommand on the subparsers `sub`."""
    p = sub.add_parser(
        NAME,
        help="Monte Carlo robustness of the identification (EMPS, robots) or of the SDP controllers",
        description=(
            "Monte Carlo robustness studies on the built-in EMPS plant, vectorised and sharded over the devices: "
            "'identification' repeats the EMPS identification study over noisy experiments (bias, spread, coverage "
            "of the stated 95 % intervals of IDIM-LS, IDIM-IV and IDIM-SDP); 'control' draws plants around the "
            "nominal model and runs the linear PD, SDP-PD and PIP-SDP steps designed on it; 'robot' draws robots "
            "around a description (--urdf, default the built-in TX40), simulates each on an exciting trajectory and "
            "identifies it (bias, spread and coverage of the base parameters). Writes report.md, summary.json and "
            "the figures to --out."
        ),
        epilog="Example: jaxsdp montecarlo --study control --runs 10000 --out mc-control",
    )
    p.add_argument("--study", choices=STUDIES, required=True, help="which study")
    p.add_argument("--runs", metavar="N", type=int_at_least(1), default=1000, help="Monte Carlo runs (default: 1000)")
    p.add_argument("--out", metavar="DIR", default=DEFAULT_OUT, help=f"output directory (default: ./{DEFAULT_OUT})")
    p.add_argument("--seed", metavar="S", type=seed, default=0, help="seed of the draws (default: 0)")
    p.add_argument(
        "--chunk",
        metavar="C",
        type=int_at_least(1),
        default=None,
        help="runs per compiled chunk, rounded up to a multiple of 16 x devices (default: min(runs, 1024))",
    )
    p.add_argument(
        "--draws",
        choices=("uniform", "covariance"),
        default="uniform",
        help="control: plants uniform within +-spread, or from the asymmetric IDIM-LS covariance (default: uniform)",
    )
    p.add_argument(
        "--drive",
        choices=("ideal", "real"),
        default="ideal",
        help="control: ideal drive (no delay, no saturation; the paper's setting) or the real drive (one-sample "
        "delay, force saturation; SDP-PD at the largest wn the delay allows) (default: ideal)",
    )
    p.add_argument(
        "--spread",
        metavar="FRACTION",
        type=fraction,
        default=None,
        help="control: half-width of the uniform draws (default 0.2); identification: plants drawn uniform within "
        "+-FRACTION of the truth (default 0: the truth in every run); robot: robots drawn within +-FRACTION of the "
        "description (default 0.1)",
    )
    p.add_argument(
        "--force-noise",
        metavar="N",
        type=nonnegative_float,
        default=None,
        help="identification: white force-measurement noise, std in N (default: 0.5)",
    )
    p.add_argument("--no-iv", action="store_true", help="identification: skip IDIM-IV")
    p.add_argument(
        "--iv",
        action="store_true",
        help="robot: also the iterated IDIM-IV of every run (instruments from the identified robot simulated in the "
        "same loop; several simulations per run)",
    )
    p.add_argument(
        "--disturbance",
        metavar="FRACTION",
        type=nonnegative_float,
        default=None,
        help="robot: a white torque on the plant that the log does not show, as a fraction of each joint's torque "
        "spread (default 0: none; the closed-loop case where least squares is biased)",
    )
    p.add_argument("--urdf", metavar="FILE", default=None, help="robot: the robot's URDF (default: the built-in TX40)")
    p.add_argument("--no-sdp", action="store_true", help="identification: skip the SDP and IDIM-SDP stages")
    p.set_defaults(run=run_montecarlo)


def _check(args):
    if args.study != "robot" and (args.iv or args.disturbance is not None):
        raise CLIError("--iv and --disturbance apply to --study robot only", code=2, usage=True)
    if args.study == "robot":
        if args.no_iv or args.no_sdp or args.force_noise is not None or args.draws != "uniform":
            raise CLIError(
                "--no-iv, --no-sdp, --force-noise and --draws do not apply to --study robot", code=2, usage=True
            )
        if args.drive != "ideal":
            raise CLIError("--drive applies to --study control only", code=2, usage=True)
        return
    if args.urdf is not None:
        raise CLIError("--urdf applies to --study robot only", code=2, usage=True)
    ident = args.study == "identification"
    if not ident and (args.no_iv or args.no_sdp or args.force_noise is not None):
        raise CLIError("--no-iv, --no-sdp and --force-noise apply to --study identification only", code=2, usage=True)
    if ident and (args.draws != "uniform" or args.drive != "ideal"):
        raise CLIError("--draws and --drive apply to --study control only", code=2, usage=True)
    if not ident and args.spread == 0.0:
        raise CLIError("--spread must be > 0 for --study control", code=2, usage=True)


def pathlib_name(path) -> str:
    import pathlib

    return pathlib.Path(path).name


def run_montecarlo(args) -> int:
    """Check the options and --out, run the study, write what it returns; returns the exit code."""
    _check(args)
    from ..studies.montecarlo import IdentificationSettings, control_robustness, identification_robustness

    robot = None
    if args.study == "robot" and args.urdf is not None:
        import pathlib

        from ..plants import SerialRobot

        path = pathlib.Path(args.urdf)
        if not path.is_file():
            raise CLIError(f"--urdf: no such file: {args.urdf}", code=2)
        try:
            robot = SerialRobot.from_urdf(path)
        except ValueError as e:
            raise CLIError(f"--urdf {path.name}: {e}", code=2) from e

    def call(progress, staging):
        show = progress.enabled
        progress.start("study")
        if show:
            sys.stderr.write("\n")  # the runs' progress bar goes on its own line
        kw = dict(seed=args.seed, chunk_size=args.chunk, progress=show)
        if args.study == "robot":
            from ..studies.montecarlo import RobotSettings, robot_robustness

            settings = RobotSettings(
                spread=0.1 if args.spread is None else args.spread, iv=args.iv, disturbance=args.disturbance or 0.0
            )
            source = None if args.urdf is None else pathlib_name(args.urdf)
            return robot_robustness(args.runs, robot=robot, source=source, settings=settings, **kw)
        if args.study == "identification":
            noise = {} if args.force_noise is None else dict(force_noise=args.force_noise)
            settings = IdentificationSettings(
                plant_spread=args.spread or 0.0, iv=not args.no_iv, sdp=not args.no_sdp, **noise
            )
            return identification_robustness(args.runs, settings=settings, **kw)
        spread = 0.2 if args.spread is None else args.spread
        return control_robustness(args.runs, draws=args.draws, spread=spread, drive=args.drive, **kw)

    return run_study(args, name=NAME, stages=["study"], labels={}, call=call)
