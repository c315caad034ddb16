"""`jaxsdp control`: the SDP control study of the EMPS (paper section 4) on the built-in plant or real data.

1. the friction SDP: identified from the built-in closed-loop data set (as
   the paper identified it from its PD-controlled experiment), or from a
   benchmark-format `.mat` file (`--data`);
2. SDP-PD against the benchmark's linear PD (Fig. 14), the real drive's
   delay and saturation, SRIVC (or, `--estimator rivcbj`, RIVCBJ with a
   noise model, beside SRIVC on the same data) identification of the SDP-PD
   loop, PIP-LQ, the PIP-SDP cascade, gradients and gradient tuning
   (`jaxsdp.studies.control.control_study`);
3. prints the tables, writes `report.md`, `summary.json` and the figures.

The options and the output folder are checked first; outputs go to a
staging folder moved into `--out` only at the end (as `jaxsdp emps`).
"""

import argparse

from ..data._loaders import IrregularSamplingError, load_emps
from ..studies._output import one_line
from ..studies.control._study import STAGES, ControlSettings, control_study
from ..tfest._riv import MAX_NOISE_ORDER
from .common import CLIError, data_file, int_at_least, positive_float, run_study, seed

NAME = "control"
DEFAULT_OUT = "jaxsdp-control-out"
TUNE_ITERATIONS = ControlSettings.tune_iterations  # the library's default
LABELS = {
    "friction": "Friction SDP (EMPS identification study)",
    "design": "Nominal design: largest wn under the delay, SRIVC of the SDP-PD loop, PIP-LQ, loop gain",
    "sdp_pd": "SDP-PD and linear PD step responses (Fig. 14)",
    "real_drive": "Real drive: delay and saturation",
    "pip": "PIP-LQ designs",
    "cascade": "PIP-SDP cascade",
    "gradients": "Gradients and gradient-based tuning",
    "figures": "Figures",
    "report": "Writing report.md and summary.json",
}


def add_parser(sub) -> None:
    """Register the `control` subcommand on the subparsers `sub`."""
    p = sub.add_parser(
        NAME,
        help="the SDP control study: SDP-PD, SRIVC or RIVCBJ, PIP-LQ, PIP-SDP cascade, gradients",
        description=(
            "The SDP control study of the EMPS (paper section 4): SDP-PD against the benchmark's linear PD, "
            "the real drive's delay and saturation, SRIVC (or RIVCBJ, --estimator) identification of the SDP-PD "
            "loop, PIP-LQ design, "
            "the PIP-SDP cascade under a velocity limit, gradients through design and simulation. Writes "
            "report.md, summary.json and the figures to --out."
        ),
        epilog="Example: jaxsdp control --out control-report   (or --data DATA_EMPS.mat)",
    )
    p.add_argument(
        "--data",
        metavar="FILE",
        help="EMPS benchmark .mat file to identify the friction SDP from (default: the built-in closed-loop data)",
    )
    p.add_argument("--out", metavar="DIR", default=DEFAULT_OUT, help=f"output directory (default: ./{DEFAULT_OUT})")
    p.add_argument("--wn", metavar="RAD_S", type=positive_float, default=250.0, help="SDP-PD wn (default: 250)")
    p.add_argument("--eta", metavar="ETA", type=positive_float, default=1.0, help="SDP-PD damping (default: 1)")
    p.add_argument(
        "--v-limit", metavar="M_S", type=positive_float, default=0.15, help="velocity limit (m/s, default: 0.15)"
    )
    p.add_argument(
        "--tune-iterations",
        metavar="N",
        type=int_at_least(0),
        default=TUNE_ITERATIONS,
        help=(
            "the most BFGS steps of one run of the gradient-based cascade tuning (a run from each start, and each "
            f"restart), 0 to skip (default: {TUNE_ITERATIONS})"
        ),
    )
    p.add_argument("--seed", metavar="K", type=seed, default=None, help="noise and excitation seed (default: 0)")
    p.add_argument(
        "--estimator",
        choices=("srivc", "rivcbj"),
        default="srivc",
        help=(
            "identification of the SDP-PD loop: srivc (white-noise output error) or rivcbj (hybrid Box-Jenkins: "
            "also a discrete ARMA noise model C/D; SRIVC is run on the same data and reported beside it) "
            "(default: srivc)"
        ),
    )
    p.add_argument(
        "--noise-orders",
        metavar=("NC", "ND"),
        nargs=2,
        type=_noise_order,
        default=None,
        help=f"orders of C and D of the rivcbj noise model, 0..{MAX_NOISE_ORDER} (default: 1 1; rivcbj only)",
    )
    p.add_argument(
        "--ident-noise-ar",
        metavar="A",
        type=_ar_coefficient,
        default=0.0,
        help=(
            "colour the identification experiment's measurement noise by 1/(1 - A z^-1), -1 < A < 1, rescaled to "
            "the same std (default: 0, white)"
        ),
    )
    p.set_defaults(run=run_control)


def _noise_order(text):
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer in 0..{MAX_NOISE_ORDER}; got {text!r}") from None
    if not 0 <= v <= MAX_NOISE_ORDER:
        raise argparse.ArgumentTypeError(f"must be an integer in 0..{MAX_NOISE_ORDER}; got {v}")
    return v


def _ar_coefficient(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number in (-1, 1); got {text!r}") from None
    if not -1 < v < 1:  # also refuses nan
        raise argparse.ArgumentTypeError(f"must be a number in (-1, 1) (a stable AR(1) noise); got {text!r}")
    return v


#: The settings the library's warnings name, as this command's options (or as Python-only settings): the
#: extra entries of its option table (`common.option_table`, `common.cli_text`).
FLAGS = {
    "`tune_iterations` of ControlSettings": "--tune-iterations",
}


def _load(path: str):
    f = data_file(path)
    try:
        return load_emps(f)
    except IrregularSamplingError as e:
        raise CLIError(f"--data: {e.detail}") from None
    except (ValueError, OSError) as e:
        raise CLIError(f"--data {path}: {one_line(e).removeprefix('`path`: ')}") from None


def run_control(args) -> int:
    """Check the options and --out, run the study, write what it returns; returns the exit code."""

    if args.data is not None and not args.data.lower().endswith(".mat"):
        raise CLIError(
            f"--data {args.data}: the control study reads the EMPS benchmark .mat format (t, qm, qg, vir, ...); "
            "give a .mat record, or no --data for the built-in one",
            code=2,
        )
    if args.noise_orders is not None and args.estimator != "rivcbj":
        raise CLIError(
            f"--noise-orders sets the noise model of --estimator rivcbj; {args.estimator} assumes white noise "
            "(give --estimator rivcbj, or drop --noise-orders)",
            code=2,
        )
    settings = ControlSettings(
        wn=args.wn,
        eta=args.eta,
        v_limit=args.v_limit,
        tune_iterations=args.tune_iterations,
        seed=0 if args.seed is None else args.seed,
        estimator=args.estimator,
        noise_orders=(1, 1) if args.noise_orders is None else tuple(args.noise_orders),
        ident_noise_colour=None if args.ident_noise_ar == 0 else ((1.0,), (1.0, -args.ident_noise_ar)),
    )
    labels = LABELS
    if args.estimator != "srivc":
        labels = dict(LABELS, design=LABELS["design"].replace("SRIVC", f"{args.estimator.upper()} (and SRIVC)"))

    def call(progress, staging):
        data = None if args.data is None else _load(args.data)
        return control_study(data, settings=settings, progress=progress.start)

    return run_study(args, name=NAME, stages=STAGES, labels=labels, call=call)
