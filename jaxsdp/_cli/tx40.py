"""`jaxsdp tx40`: the TX40 study (paper section 3) on the built-in experiment or on real joint logs.

1. the data: the built-in "only link 2 moving" experiment (simulated from
   the paper's Table 4, written as real TX40 logs into --out and read back),
   the built-in "all joints moving" experiment (`--case all`: the nominal
   six-joint TX40, the paper's section 3.4.2),
   or real logs (`--positions POS.csv --torques TAU.csv`, the TX40 log
   format: motor-side angles and motor torques, header Joint_1..Joint_6);
2. one joint's IDIM-LS (eq. 22), multi-SDP with the inertia fixed and its
   parametric projections (`jaxsdp.studies.tx40.tx40_study`); with
   `--model full`, also the full six-joint rigid-body model (base
   parameters) and the multi-SDP of its residual, the logs brought to the
   model's convention (`--joint-offsets`, `--wrist-coupling`, the TX40's by default);
3. prints the tables, writes `report.md`, `summary.json` and the figures.

Options and the output folder are checked first; outputs go to a staging
folder moved into `--out` only at the end (as `jaxsdp emps`).
"""

import argparse
import functools
import math
import time

from ..plants.robot._tx40_link2 import TX40_GEAR_RATIOS
from ..studies._output import one_line
from .common import CLIError, data_file, int_at_least, nonnegative_float, positive_float, run_study, seed

NAME = "tx40"
DEFAULT_OUT = "jaxsdp-tx40-out"
TX40_RATIOS = ",".join(f"{r:g}" for r in TX40_GEAR_RATIOS)  # as the option is written
LABELS = {
    "simulate": "Simulating the built-in experiment and writing its logs",
    "load": "Reading the joint logs",
    "derivatives": "Derivatives and decimation",
    "idim_ls": "IDIM-LS (eq. 22)",
    "sdp": "Multi-SDP and parametric projections",
    "settings_check": "Shape test and IDIM-LS at neighbouring settings",
    "full_model": "Full six-joint model: base parameters and IDIM-LS",
    "full_model_sdp": "Multi-SDP of the full model's residual",
    "figures": "Figures",
    "report": "Writing report.md and summary.json",
}


def _numbers(what):
    def parse(text):
        try:
            values = tuple(float(v) for v in text.split(","))
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be comma-separated numbers ({what}); got {text!r}") from None
        if not all(math.isfinite(v) for v in values):
            raise argparse.ArgumentTypeError(f"must be finite numbers; got {text!r}")
        return values

    return parse


def _models(text):
    parts = [p.strip().upper() for p in text.split(",")]
    if len(parts) not in (1, 2) or any(p not in ("RW", "IRW") for p in parts):
        raise argparse.ArgumentTypeError(f"must be RW, IRW, or two of them (gravity,friction); got {text!r}")
    return tuple(parts * 2 if len(parts) == 1 else parts)


def _coupling(text):
    if text.strip().lower() == "none":
        return None
    try:
        a, b = (int(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"must be two joint numbers A,B (motor B turns with joint A) or none; got {text!r}"
        ) from None
    return a, b


def _fraction(text):
    v = positive_float(text)
    if not v < 1:
        raise argparse.ArgumentTypeError(f"must lie in (0, 1); got {text!r}")
    return v


def add_parser(sub) -> None:
    """Register the `tx40` subcommand on the subparsers `sub`."""
    p = sub.add_parser(
        NAME,
        help="the TX40 robot study: one joint's IDIM-LS and multi-SDP (Tables 4-5, Figs. 7-11)",
        description=(
            "The TX40 study (paper section 3): one joint seen as a one-degree-of-freedom arm (eq. 20), identified "
            "by IDIM-LS (eq. 22) and by multi-SDP back-fitting of gravity and friction curves with the inertia "
            "fixed, with the curves' parametric projections, residual whiteness and the paper's Table 4/5 layout. "
            "Without --positions/--torques it runs on the built-in 'only link 2 moving' experiment."
        ),
        epilog="Examples: jaxsdp tx40 --out tx40-report;  jaxsdp tx40 --case all --model full --out tx40-all;  "
        "jaxsdp tx40 --positions POS.csv --torques TAU.csv --reference table5 --out tx40-real",
    )
    d = p.add_argument_group("data")
    d.add_argument("--positions", metavar="FILE", help="joint-log positions (motor side, rad), CSV or .mat")
    d.add_argument("--torques", metavar="FILE", help="joint-log torques (motor side, N m; or currents, A)")
    d.add_argument("--dt", metavar="S", type=positive_float, default=2e-4, help="sample time (s, default: 2e-4)")
    d.add_argument(
        "--ratios",
        metavar="N1,..",
        type=_numbers("gear ratios"),
        default=None,
        help=f"gear ratios motor/joint, one per log column (default: the TX40's {TX40_RATIOS})",
    )
    d.add_argument(
        "--torque-constants",
        metavar="K1,..",
        type=_numbers("N m/A"),
        default=None,
        help="motor torque constants (N m/A) when the torque file holds currents",
    )
    d.add_argument("--joint", metavar="J", type=int_at_least(1), default=2, help="joint to identify (default: 2)")
    d.add_argument("--seed", metavar="K", type=seed, default=None, help="noise seed of the built-in data (default 0)")
    d.add_argument(
        "--case",
        choices=("link2", "all"),
        default=None,
        help="built-in experiment: only link 2 moving (default) or all six joints moving (the six-joint TX40)",
    )
    a = p.add_argument_group("processing and identification")
    a.add_argument("--decimate", metavar="R", type=int_at_least(1), default=10, help="decimation (default: 10)")
    a.add_argument("--cutoff", metavar="HZ", type=positive_float, default=100.0, help="Butterworth (default: 100)")
    a.add_argument(
        "--derivatives",
        choices=("butterworth", "smooth"),
        default="butterworth",
        help="Butterworth + central differences (default) or smoothing derivatives",
    )
    a.add_argument(
        "--min-speed",
        metavar="RAD_S",
        type=_min_speed,
        default="auto",
        help="samples slower than this are at rest, left out of IDIM-LS and of the curves' projections (rad/s; "
        "default: auto, 1 %% of the joint's peak speed)",
    )
    a.add_argument(
        "--inertia", metavar="KG_M2", type=positive_float, default=None, help="fixed inertia (default: IDIM-LS)"
    )
    a.add_argument(
        "--model",
        choices=("link2", "full"),
        default="link2",
        help="the joint's model: eq. (20) alone (link2, the paper's; default) or also the full six-joint "
        "rigid-body model and the SDP of its residual (full; needs the logs of all six joints)",
    )
    a.add_argument(
        "--sdp-model", metavar="M", type=_models, default=("RW", "RW"), help="RW or IRW per SDP (default RW)"
    )
    a.add_argument(
        "--joint-offsets",
        metavar="Q1,..",
        type=_numbers("rad"),
        default=None,
        help="--model full: added to the logs' joint angles to get the model's (rad; default the TX40's "
        "0,-pi/2,pi/2,0,0,0)",
    )
    a.add_argument(
        "--wrist-coupling",
        metavar="A,B",
        type=_coupling,
        default=(5, 6),
        help="--model full: motor B also turns with joint A (default the TX40's 5,6; none for no coupling)",
    )
    a.add_argument("--tol", metavar="TOL", type=_fraction, default=0.01, help="back-fitting tolerance (default: 0.01)")
    a.add_argument(
        "--reference",
        choices=("auto", "table4", "table5", "none"),
        default="auto",
        help="reference column of the tables: the paper's Table 4 or 5 values (default: auto, the table of the "
        "experiment the logs come from: Table 5 when other joints move besides the identified one, else Table 4)",
    )
    a.add_argument(
        "--no-settings-check",
        action="store_true",
        help="skip re-running the shape test and IDIM-LS at neighbouring settings (saves 10-20 s; the shape "
        "verdict is then not checked for fragility)",
    )
    o = p.add_argument_group("output")
    o.add_argument("--out", metavar="DIR", default=DEFAULT_OUT, help=f"output directory (default: ./{DEFAULT_OUT})")
    p.set_defaults(run=run_tx40)


def _check(args):
    if (args.positions is None) != (args.torques is None):
        raise CLIError("--positions and --torques go together: give both files of a joint log, or neither")
    real = args.positions is not None
    if not real:
        for opt, v in (("--ratios", args.ratios), ("--torque-constants", args.torque_constants)):
            if v is not None:
                raise CLIError(f"{opt} applies to real logs (--positions/--torques); the built-in data are the TX40's")
    elif args.seed is not None or args.case is not None:
        raise CLIError("--seed and --case apply to the built-in data only")
    if args.model != "full" and (args.joint_offsets is not None or args.wrist_coupling != (5, 6)):
        raise CLIError("--joint-offsets and --wrist-coupling apply to --model full")
    if args.model == "full" and not real and args.case != "all":
        raise CLIError("--model full needs every joint moving: use --case all (or real logs of all six joints)")
    if args.ratios is not None and any(r == 0 for r in args.ratios):
        raise CLIError(f"--ratios: a gear ratio of 0 is impossible; got {args.ratios}")
    return real


def _min_speed(text):
    if text.strip().lower() == "auto":
        return "auto"
    return nonnegative_float(text)


def _load(args):
    from ..data._joint_logs import load_joint_logs

    pos = data_file(args.positions, "--positions")
    trq = data_file(args.torques, "--torques")
    ratios = args.ratios
    if ratios is None:
        ratios = TX40_GEAR_RATIOS
    try:
        return load_joint_logs(pos, trq, dt=args.dt, ratios=ratios, torque_constants=args.torque_constants)
    except (ValueError, OSError) as e:
        message = one_line(e)
        if "ratios" in message and args.ratios is None:
            message += f" (the default --ratios are the TX40's six {TX40_RATIOS}; give one per column)"
        raise CLIError(message) from None


def _call(args, progress, staging):
    """The study `tx40_study` with the options of `args`: real logs read here, the built-in ones written to --out."""
    from ..data._model_convention import TX40_JOINT_OFFSETS
    from ..studies.tx40._study import tx40_study

    real = args.positions is not None
    load_time = None
    if real:
        progress.start("load")
        t0 = time.perf_counter()
        logs = _load(args)
        load_time = time.perf_counter() - t0
    study = tx40_study(
        logs if real else None,
        case=None if real else (args.case or "link2"),
        seed=None if real else args.seed,
        logs_dir=None if real else staging,
        joint=args.joint,
        derivatives=args.derivatives,
        cutoff_hz=args.cutoff,
        decimate=args.decimate,
        min_speed=args.min_speed,
        inertia=args.inertia,
        model=args.sdp_model,
        tol=args.tol,
        reference=args.reference,
        settings_check=not args.no_settings_check,
        source=f"{args.positions} + {args.torques}" if real else None,
        full_model=args.model == "full",
        joint_offsets=TX40_JOINT_OFFSETS if args.joint_offsets is None else args.joint_offsets,
        wrist_coupling=args.wrist_coupling,
        progress=lambda stage: stage != "load" and progress.start(stage),
    )
    if load_time is not None:
        study.timings["load"] = load_time  # the logs were read here, before the study
    return study


def run_tx40(args) -> int:
    """Check the options and --out, run the study, write what it returns; returns the exit code."""
    from ..studies import tx40
    from ..studies.tx40._study import CHECK_STAGE, FULL_STAGES, STAGES

    real = _check(args)
    stages = ["load" if real else "simulate"] + [s for s in STAGES if s != "load"]
    stages += [CHECK_STAGE] * (not args.no_settings_check)
    stages += list(FULL_STAGES) * (args.model == "full")
    return run_study(args, name=NAME, stages=stages, labels=LABELS, call=functools.partial(_call, args), contract=tx40)
