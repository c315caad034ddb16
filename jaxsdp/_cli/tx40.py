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

from .._checks import OptionError
from ..plants.robot._tx40_link2 import TX40_GEAR_RATIOS
from ..studies._output import one_line
from .common import (
    CLIError,
    data_file,
    fraction,
    int_at_least,
    nonnegative_float,
    option_error,
    positive_float,
    run_study,
    seed,
)

NAME = "tx40"
#: Python arguments the library's messages name whose option is named differently (`common.cli_text`).
FLAGS = {
    "cutoff_hz": "--cutoff",
    "`dt` of load_joint_logs": "--dt",
    "`torque_constants` and `ratios` of load_joint_logs": "--torque-constants and --ratios",
    "`full_model=FullModel()`": "--model full",
    "run tx40_study(..., `full_model=FullModel()`)": "use --model full",
    "model": "--sdp-model",
}
DEFAULT_OUT = "jaxsdp-tx40-out"
TX40_RATIOS = ",".join(f"{r:g}" for r in TX40_GEAR_RATIOS)  # as the option is written
#: The TX40's joints (the built-in data's, and the full model's).
TX40_JOINTS = len(TX40_GEAR_RATIOS)
#: Sample time of the real logs when --dt is not given (s): the TX40 logs', 5 kHz.
DEFAULT_DT = 2e-4
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
        return ()  # no coupling (None: the option not given)
    try:
        a, b = (int(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"must be two joint numbers A,B (motor B turns with joint A) or none; got {text!r}"
        ) from None
    return a, b


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
    d.add_argument(
        "--dt", metavar="S", type=positive_float, default=None, help="sample time of the logs (s, default: 2e-4)"
    )
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
        default=None,
        help="--model full: motor B also turns with joint A (default the TX40's 5,6; none for no coupling)",
    )
    a.add_argument("--tol", metavar="TOL", type=fraction, default=0.01, help="back-fitting tolerance (default: 0.01)")
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


def _given(args, options) -> list[str]:
    """The flags among `options` given on the command line (their value not None)."""
    return [o for o in options if getattr(args, o[2:].replace("-", "_")) is not None]


def _check(args):
    """Refuse the usage mistakes before any work (exit 2): a missing companion option, an option the chosen data
    or model ignores, a value out of range, a wrong count of values. Returns whether the logs are real."""
    if (args.positions is None) != (args.torques is None):
        missing = "--torques" if args.torques is None else "--positions"
        raise CLIError(
            f"{missing} missing: --positions and --torques go together (both files of a joint log, or neither for "
            "the built-in data)",
            code=2,
        )
    real = args.positions is not None
    full = args.model == "full"
    if not real and (extra := _given(args, ("--ratios", "--torque-constants", "--dt"))):
        verb = _verb(extra, "describes", "describe")
        raise CLIError(
            f"{_and(extra)} {verb} real logs (--positions/--torques); the built-in data are the TX40's: "
            f"drop {_it(extra)}",
            code=2,
        )
    if real and (extra := _given(args, ("--seed", "--case"))):
        verb = _verb(extra, "chooses", "choose")
        raise CLIError(f"{_and(extra)} {verb} the built-in data; drop {_it(extra)} with --positions/--torques", 2)
    if not full and (extra := _given(args, ("--joint-offsets", "--wrist-coupling"))):
        verb = _verb(extra, "applies", "apply")
        raise CLIError(f"{_and(extra)} {verb} to --model full only; add --model full or drop {_it(extra)}", code=2)
    if full and not real and args.case != "all":
        raise CLIError("--model full needs every joint moving: add --case all (or give real logs of all six joints)", 2)
    columns = TX40_JOINTS if args.ratios is None else len(args.ratios)  # the logs' joint columns
    if args.ratios is not None and any(r == 0 for r in args.ratios):
        raise CLIError(f"--ratios: a gear ratio of 0 is impossible; got {_join(args.ratios)}", code=2)
    constants = args.torque_constants
    if constants is not None and not all(k > 0 for k in constants):
        raise CLIError(f"--torque-constants must be positive (N m/A); got {_join(constants)}", code=2)
    if constants is not None and len(constants) != columns:
        ratios = "--ratios has" if args.ratios is not None else "the default --ratios (the TX40's) have"
        raise CLIError(
            f"--torque-constants has {len(constants)} values but {ratios} {columns}: give one per log column", 2
        )
    if full and columns != TX40_JOINTS:
        raise CLIError(
            f"--model full needs the logs of all {TX40_JOINTS} joints; --ratios has {columns} values", code=2
        )
    if full and args.joint_offsets is not None and len(args.joint_offsets) != TX40_JOINTS:
        raise CLIError(
            f"--joint-offsets has {len(args.joint_offsets)} values: give {TX40_JOINTS}, one per joint (rad)", code=2
        )
    pair = args.wrist_coupling
    if pair and (pair[0] == pair[1] or not all(1 <= j <= TX40_JOINTS for j in pair)):
        raise CLIError(
            f"--wrist-coupling {_join(pair)}: name two different joints in 1..{TX40_JOINTS} (or none)", code=2
        )
    if not real and args.joint > TX40_JOINTS:
        raise CLIError(f"--joint {args.joint}: the TX40 has joints 1..{TX40_JOINTS}; choose one of them", code=2)
    return real


def _join(values) -> str:
    return ",".join(f"{v:g}" for v in values)


def _and(flags) -> str:
    return ", ".join(flags[:-1]) + " and " + flags[-1] if len(flags) > 1 else flags[0]


def _verb(flags, one: str, many: str) -> str:
    return many if len(flags) > 1 else one


def _it(flags) -> str:
    return "them" if len(flags) > 1 else "it"


def _min_speed(text):
    if text.strip().lower() == "auto":
        return "auto"
    return nonnegative_float(text)


def _load(args):
    """The real logs; a --ratios, --torque-constants or --dt that does not fit the files, or a --joint they do not
    hold, is a usage error (exit 2), a file that cannot be used a data error (exit 1)."""
    from ..data._joint_logs import load_joint_logs

    pos = data_file(args.positions, "--positions")
    trq = data_file(args.torques, "--torques")
    ratios = TX40_GEAR_RATIOS if args.ratios is None else args.ratios
    dt = DEFAULT_DT if args.dt is None else args.dt
    try:
        logs = load_joint_logs(pos, trq, dt=dt, ratios=ratios, torque_constants=args.torque_constants)
    except OptionError as e:  # an option that does not fit the files (read up to the header where it can)
        message = str(option_error(e, {"ratios": "--ratios", "torque_constants": "--torque-constants", "dt": "--dt"}))
        if "--ratios" in message and args.ratios is None:
            message += f" (the default --ratios are the TX40's six {TX40_RATIOS}; give one per column)"
        if "--dt" in message and args.dt is None:
            message += f" (without --dt the TX40 logs' {DEFAULT_DT:g} s is assumed)"
        raise CLIError(message, code=2) from None
    except (ValueError, OSError) as e:
        raise CLIError(one_line(e)) from None
    if args.joint not in logs.joints:
        held = ", ".join(map(str, logs.joints))
        raise CLIError(f"--joint {args.joint}: the logs hold joints {held}; choose one of them", code=2)
    return logs


def _call(args, progress, staging):
    """The study `tx40_study` with the options of `args`: real logs read here, the built-in ones written to --out."""
    import dataclasses

    from .._sdp.multi import MultiBackfitting
    from .._signal.preprocess import Butterworth, Smoothing
    from ..plants.robot._joint_stages import JOINT_PREPROCESSING
    from ..studies.tx40._options import FullModel, TX40Builtin
    from ..studies.tx40._study import tx40_study

    real = args.positions is not None
    load_time = None
    if real:
        progress.start("load")
        t0 = time.perf_counter()
        logs = dataclasses.replace(_load(args), source=f"{args.positions} + {args.torques}")
        load_time = time.perf_counter() - t0
    else:
        seed = 0 if args.seed is None else args.seed
        logs = TX40Builtin(case=args.case or "link2", seed=seed, logs_dir=staging)
    derivatives = Butterworth(args.cutoff, 4) if args.derivatives == "butterworth" else Smoothing(args.cutoff)
    full = None
    if args.model == "full":
        offsets = args.joint_offsets
        full = FullModel(
            **({} if offsets is None else {"joint_offsets": offsets}),
            **({} if args.wrist_coupling is None else {"wrist_coupling": args.wrist_coupling or None}),
        )
    study = tx40_study(
        logs,
        joint=args.joint,
        preprocessing=dataclasses.replace(JOINT_PREPROCESSING, derivatives=derivatives, decimate=args.decimate),
        min_speed=args.min_speed,
        inertia=args.inertia,
        sdp=MultiBackfitting(model=args.sdp_model, tol=args.tol),
        full_model=full,
        reference=args.reference,
        settings_check=not args.no_settings_check,
        progress=lambda stage: stage != "load" and progress.start(stage),
    )
    if load_time is not None:
        study = study.with_timings({**study.timings, "load": load_time})  # the logs were read here, before the study
    return study


def run_tx40(args) -> int:
    """Check the options and --out, run the study, write what it returns; returns the exit code."""
    from ..studies.tx40._study import CHECK_STAGE, FULL_STAGES, STAGES

    real = _check(args)
    stages = ["load" if real else "simulate"] + [s for s in STAGES if s != "load"]
    stages += [CHECK_STAGE] * (not args.no_settings_check)
    stages += list(FULL_STAGES) * (args.model == "full")
    return run_study(args, name=NAME, stages=stages, labels=LABELS, call=functools.partial(_call, args))
