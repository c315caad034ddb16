"""`jaxsdp emps`: the complete EMPS study on the built-in simulated plant or on a measurement file.

1. data: the built-in closed-loop simulation (`jaxsdp.data.emps_builtin_data`),
   or a benchmark-format `.mat` file (`jaxsdp.data.load_emps`) or a CSV file
   with columns `t`, `q`, `force` (`jaxsdp.data.load_measurements`);
2. the study (`jaxsdp.studies.emps.emps_study`): derivatives, IDIM-LS
   (linear and asymmetric friction), SDP stage with ML NVRs, IDIM-SDP, the
   closed-loop simulation check (skipped for CSV files: no reference) and,
   on the built-in plant, the recovery of its truth;
3. `jaxsdp._cli.common.run_study` prints its `text` and writes its `report`,
   `figures` (PNG, PDF or SVG), `summary` and the whole study as `study.npz`
   (reload it with `jaxsdp.load`) to `--out`.

Everything checkable is checked first, in well under a second: the options,
the output folder (created, probed with a file), the data (read, uniform
sampling, `jaxsdp.plants.emps._checks.check_emps_data`). The outputs are
written to a staging folder beside `--out` and moved into it only at the
end, so a failed run leaves `--out` as it was. Library warnings are printed
as one line each, without source paths.
"""

import argparse
import functools
import math
import sys
import time

import numpy as np

from .._idim.estimators import IDIMIV
from .._io import save
from .._sdp.backfit import CONSTANT_NVR
from .._sdp.options import MLNVR, Backfitting, CaptainNVR
from .._signal.preprocess import Butterworth, Preprocessing
from ..data._emps_builtin import BUILTIN_DT, BUILTIN_SAMPLES
from ..data._loaders import IrregularSamplingError, load_emps, load_measurements
from ..plants.emps._checks import MIN_DECIMATED, check_emps_data, check_length
from ..plants.emps._preprocess import DROP
from ..studies._output import one_line
from ..studies.emps._study import emps_study
from .common import FRICTION, PROG, CLIError, data_file, int_at_least, positive_float, run_study, seed

STAGES = {
    "simulate_plant": "Simulating the built-in EMPS plant",
    "load": "Reading the data file",
    "derivatives": "Derivatives (Butterworth + central differences, decimation)",
    "idim_ls": "IDIM-LS, linear friction (Table 1)",
    "idim_ls_asym": "IDIM-LS, asymmetric friction",
    "sdp": "SDP stage, ML NVRs",
    "idim_sdp": "IDIM-SDP (Table 2)",
    "idim_iv": "IDIM-IV (instruments from the closed-loop simulation)",
    "friction": "Friction laws (BIC, cross-validation)",
    "decimation_check": "SDP stage at neighbouring decimation factors",
    "simulation": "Closed-loop simulation check",
    "figures": "Figures",
    "report": "Writing report.md and summary.json",
}


DEFAULT_OUT = "jaxsdp-emps-out"


NAME = "emps"
#: Python arguments the library's messages name whose option is named differently (`common.cli_text`).
FLAGS = {"cutoff_hz": "--cutoff", "`time`, `position`, `force`": "--columns TIME,POSITION,FORCE"}


def add_parser(sub) -> None:
    """Register the `emps` subcommand on the subparsers `sub`."""
    emps = sub.add_parser(
        NAME,
        help="the complete EMPS study: IDIM-LS, SDP, IDIM-SDP, simulation check, report",
        description=(
            "The complete EMPS identification study (IDIM-LS with linear and asymmetric friction, "
            "optionally IDIM-IV, SDP stage with ML NVRs checked at neighbouring decimation factors, "
            "IDIM-SDP, closed-loop simulation check) on the built-in simulated plant or on a "
            "measurement file. Checks the data and --out first; prints warnings, the tables and the "
            "findings, and writes report.md, the figures, summary.json and study.npz to --out."
        ),
        epilog=(
            "Built-in plant (no --data): the benchmark's closed loop with asymmetric friction "
            "M=95.15 kg, Fv+=166.7, Fc+=20.14, Fv-=240.4, Fc-=20.63 (the published asymmetric "
            "IDIM-LS model of the real machine), bang-bang reference like the benchmark's "
            "(24.84 s at 1 kHz), position read with one encoder count of noise and quantised "
            "to the encoder count. Example: jaxsdp emps --data DATA_EMPS.mat --out emps-report"
        ),
    )
    emps.add_argument(
        "--data",
        metavar="FILE",
        help=(
            "measurement file: the EMPS benchmark .mat format (t, qm, qg, vir, gtau, kp, kv), "
            "or CSV with a header and columns t, q, force (no simulation check: no reference). "
            "Default: simulate the built-in plant"
        ),
    )
    emps.add_argument(
        "--out",
        metavar="DIR",
        default=DEFAULT_OUT,
        help=f"output directory, created if its parent exists (default: ./{DEFAULT_OUT})",
    )
    emps.add_argument(
        "--decimate",
        metavar="N",
        type=int_at_least(1),
        default=10,
        help="decimation factor of the IDIM and SDP stages, integer >= 1 (default: 10)",
    )
    emps.add_argument(
        "--cutoff",
        metavar="HZ",
        type=positive_float,
        default=100.0,
        help="cut-off of the zero-phase Butterworth filter on the position, below the Nyquist frequency (default: 100)",
    )
    emps.add_argument(
        "--seed",
        metavar="K",
        type=seed,
        default=None,
        help="seed of the built-in plant's measurement noise (default: 0; built-in plant only)",
    )
    emps.add_argument(
        "--columns",
        metavar="TIME,POSITION,FORCE",
        type=_names(3, "TIME,POSITION,FORCE"),
        default=None,
        help="the --data file's names of the time (s), position (m) and force (N) columns of a CSV file, or "
        "variables of a .mat file holding those three (default: t,q,force)",
    )
    emps.add_argument(
        "--scale",
        metavar="ROLE=FACTOR,..",
        type=_scale,
        default=None,
        help="factors bringing a t, q, force file's columns to SI units, by role time, position, force; e.g. "
        "time=1e-3,position=1e-3,force=35.15 for ms, mm and a drive voltage times its gain in N/V",
    )
    emps.add_argument(
        "--variables",
        metavar="NAME=VAR,..",
        type=_mapping,
        default=None,
        help="the --data .mat file's names of the benchmark variables t, qm, qg, vir, gtau, kp, kv, e.g. "
        "t=time,qm=position (the others keep their names)",
    )
    emps.add_argument(
        "--resample",
        action="store_true",
        help=(
            "accept a --data record whose time steps are not uniform (beyond 0.1 %% of the median step): "
            "interpolate it linearly onto a uniform grid at the median step, recorded in summary.json "
            "(default: refuse it, naming the first irregular sample)"
        ),
    )
    emps.add_argument(
        "--estimator",
        choices=("ls", "iv", "iv-plain"),
        default="ls",
        help=(
            "ls: IDIM-LS only; iv: also the bias-compensated IDIM-IV (instruments from the identified model "
            "simulated in the data's closed loop, HAC standard deviations; needs a .mat record or the built-in "
            "plant); iv-plain: the plain IDIM-IV of Janot et al. 2014 (default: ls)"
        ),
    )
    emps.add_argument(
        "--nvr-search",
        choices=("sdp", "captain"),
        default="sdp",
        help=(
            "NVR search of the SDP stage: sdp (gradient ML, BFGS) or captain (Nelder-Mead on log10 NVR from 1e-4 "
            "on the first sweep, as the CAPTAIN toolbox and the paper) (default: sdp)"
        ),
    )
    emps.add_argument(
        "--max-nvr",
        metavar="V",
        type=positive_float,
        default=1.0,
        help="cap on the SDP stage's NVRs; an NVR on the cap is reported as such (default: 1)",
    )
    emps.add_argument(
        "--friction",
        choices=tuple(FRICTION),
        default=None,
        help=(
            "also fit a friction law with the mass and the offset: auto (the one of least BIC among viscous-coulomb, "
            "asymmetric, smooth-coulomb and stribeck), or one of them; reported with its held-out error beside the "
            "asymmetric linear law's and its distance to the SDP friction curve (default: none)"
        ),
    )
    emps.add_argument(
        "--no-decimation-check",
        action="store_true",
        help="do not re-run the SDP stage at half and twice --decimate to check the mass-constancy finding",
    )
    emps.set_defaults(run=run_emps)


def _names(count: int, what: str):
    def parse(text):
        parts = [p.strip() for p in text.split(",")]
        if len(parts) != count or not all(parts):
            raise argparse.ArgumentTypeError(f"must be {count} comma-separated names {what}; got {text!r}")
        return tuple(parts)

    return parse


def _mapping(text):
    try:
        pairs = dict(item.split("=", 1) for item in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be NAME=VAR pairs separated by commas; got {text!r}") from None
    pairs = {k.strip(): v.strip() for k, v in pairs.items()}
    known = ("t", "qm", "qg", "vir", "gtau", "kp", "kv")
    unknown = sorted(set(pairs) - set(known))
    if unknown or not all(pairs.values()):
        raise argparse.ArgumentTypeError(f"names must be among {', '.join(known)}, each =VAR; got {text!r}")
    return pairs


def _scale(text):
    roles = ("time", "position", "force")
    try:
        pairs = {k.strip(): float(v) for k, v in (item.split("=", 1) for item in text.split(","))}
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be ROLE=FACTOR pairs separated by commas; got {text!r}") from None
    unknown = sorted(set(pairs) - set(roles))
    bad = [k for k, v in pairs.items() if not math.isfinite(v) or v == 0 or (k == "time" and v < 0)]
    if unknown or bad:
        raise argparse.ArgumentTypeError(
            f"roles must be among {', '.join(roles)}, each with a finite non-zero factor (positive for time); "
            f"got {text!r}"
        )
    return pairs


def _check_cutoff(cutoff, dt):
    nyquist = 0.5 / dt
    if cutoff >= nyquist:
        units = (
            f"; a sample time of {dt:g} s is long for a servo record: if the time column is in milliseconds, "
            "give it in seconds (--scale time=1e-3)"
            if dt >= 0.1
            else ""
        )
        raise CLIError(
            f"--cutoff {cutoff:g} Hz must be below the Nyquist frequency {nyquist:g} Hz of the data (dt = {dt:g} s)"
            + units,
            code=2,
        )


def _check_length(n, decimate):
    # enough decimated samples for the regressions and the SDP stage (jaxsdp.plants.emps._checks)
    try:
        check_length(n, drop=DROP, decimate=decimate, advice="use a smaller --decimate or a longer record")
    except ValueError as e:
        raise CLIError(one_line(e), code=2 if n - DROP >= MIN_DECIMATED else 1) from None


def _check_usage(args) -> None:
    """Refuse the usage mistakes before any work (exit 2): an option the chosen data ignore, a missing --data, two
    options that exclude each other."""
    if args.data is None:
        given = (("--columns", args.columns), ("--variables", args.variables), ("--scale", args.scale))
        extra = [o for o, v in given if v is not None]
        if extra:
            names = "name" if len(extra) > 1 else "names"
            raise CLIError(f"{' and '.join(extra)} {names} what a --data file holds; give --data FILE", code=2)
        if args.resample:
            raise CLIError("--resample applies to a --data file; drop it for the built-in plant", code=2)
        return
    if args.seed is not None:
        raise CLIError("--seed draws the built-in plant's noise; drop it with --data", code=2)
    mat = args.data.lower().endswith(".mat")
    if args.columns is not None and args.variables is not None:
        raise CLIError("--columns (a t, q, force record) and --variables (a benchmark .mat) exclude each other", 2)
    if args.scale is not None and mat and args.columns is None:
        raise CLIError(
            "--scale converts the columns of a t, q, force record; a benchmark .mat file is read in its own units "
            "(give --columns to read a .mat file's t, q, force vectors)",
            code=2,
        )
    if args.variables is not None and not mat:
        raise CLIError(f"--variables names the variables of a benchmark .mat file; {args.data} is not a .mat", code=2)
    if args.estimator != "ls" and not (mat and args.columns is None):
        raise CLIError(
            f"--estimator {args.estimator} simulates the closed loop for its instruments: it needs a benchmark .mat "
            "record (reference position and controller gains); a t, q, force record allows --estimator ls only",
            code=2,
        )


def _load(path: str, resample: bool, columns=None, variables=None, scale=None):
    p = data_file(path)
    mat = p.suffix.lower() == ".mat"
    irregular = "resample" if resample else "error"
    if mat and columns is None:
        loader = functools.partial(load_emps, variables=variables)
    else:
        names = {} if columns is None else dict(zip(("time", "position", "force"), columns))
        loader = functools.partial(load_measurements, scale=scale, **names)
    try:
        return loader(p, irregular=irregular)
    except IrregularSamplingError as e:
        advice = "pass --resample to interpolate it linearly onto a uniform grid, or split it into uniform records"
        raise CLIError(f"--data: {e.detail}; {advice}") from None
    except (ValueError, OSError) as e:
        msg = one_line(e).removeprefix("`path`: ")
        raise CLIError(f"--data: {msg}" if (str(p) in msg or p.name in msg) else f"--data {path}: {msg}") from None


def _check_data(data, args):
    """Everything that can be checked on the data before any processing (one-line CLIError)."""
    label = "the built-in plant" if args.data is None else f"--data {args.data}"
    try:
        _check_cutoff(args.cutoff, float(data.dt))
        _check_length(int(np.shape(data.force)[0]), args.decimate)
    except CLIError as e:
        raise CLIError(f"{label}: {e}", e.code) from None
    try:
        check_emps_data(data, drop=DROP, decimate=args.decimate)
    except ValueError as e:
        raise CLIError(f"{label}: {one_line(e)}") from None


def _call(args, progress, staging):
    """The study `emps_study` with the options of `args`; the data checked before any processing."""
    builtin = args.data is None
    data, load_time = None, None
    if not builtin:
        progress.start("load")
        t0 = time.perf_counter()
        data = _load(args.data, args.resample, args.columns, args.variables, args.scale)
        load_time = time.perf_counter() - t0
        if data.resampled is not None and not args.quiet:
            progress.done()
            print(f"{PROG} {NAME}: note: {data.resampled}", file=sys.stderr)
        _check_data(data, args)
    study = emps_study(
        data,
        seed=args.seed if builtin else None,
        **study_options(args),
        check_decimation=not args.no_decimation_check,
        friction=None if args.friction is None else FRICTION[args.friction],
        progress=lambda stage: stage != "load" and progress.start(stage),
    )
    if load_time is not None:
        study = study.with_timings({**study.timings, "load": load_time})  # the file was read here, before the study
    return study


def study_options(args) -> dict:
    """The option objects of `emps_study` that the flags stand for: `preprocessing` (--cutoff, --decimate; the
    benchmark's Butterworth order 4, 49 samples dropped, MATLAB decimation), `iv` (--estimator: ls None, iv
    `IDIMIV()`, iv-plain `IDIMIV(compensate=False)`) and `sdp` (--nvr-search sdp `MLNVR`, captain `CaptainNVR`,
    from 1e-4, capped at --max-nvr; random-walk terms)."""
    search = CaptainNVR if args.nvr_search == "captain" else MLNVR
    return dict(
        preprocessing=Preprocessing(Butterworth(args.cutoff, 4), drop=DROP, decimate=args.decimate, mode="matlab"),
        iv={"ls": None, "iv": IDIMIV(), "iv-plain": IDIMIV(compensate=False)}[args.estimator],
        sdp=Backfitting(model="RW", nvr=search(1e-4, args.max_nvr), constant_nvr=CONSTANT_NVR),
    )


def _stages(args) -> list[str]:
    stages = ["simulate_plant" if args.data is None else "load", "derivatives", "idim_ls", "idim_ls_asym", "sdp"]
    stages += ["idim_sdp"] + ([] if args.estimator == "ls" else ["idim_iv"])
    stages += [] if args.friction is None else ["friction"]
    return stages + ([] if args.no_decimation_check else ["decimation_check"]) + ["simulation"]


def run_emps(args) -> int:
    """Check the options, the output folder and the data up front; run the study; write what it returns.

    Outputs are written into a staging folder beside --out and moved in only
    when everything succeeded, so a failed run leaves --out as it was (a
    folder this run created is removed again). Library warnings are printed
    as one line each (`jaxsdp emps: warning: ...`), without source paths.
    """
    _check_usage(args)
    if args.data is None:
        _check_cutoff(args.cutoff, BUILTIN_DT)
        _check_length(BUILTIN_SAMPLES, args.decimate)
    return run_study(
        args,
        name=NAME,
        stages=_stages(args),
        labels=STAGES,
        call=functools.partial(_call, args),
        extra_files=lambda study, folder: save(folder / "study.npz", study) or ["study.npz"],
    )
