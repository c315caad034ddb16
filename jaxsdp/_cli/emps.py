"""`jaxsdp emps`: the complete EMPS study on the built-in simulated plant or on a measurement file.

1. data: the built-in closed-loop simulation (`jaxsdp.data.emps_builtin_data`),
   or a benchmark-format `.mat` file (`jaxsdp.data.load_emps`) or a CSV file
   with columns `t`, `q`, `force` (`jaxsdp.data.load_measurements`);
2. derivatives, IDIM-LS (linear and asymmetric friction), SDP stage with ML
   NVRs, IDIM-SDP (`jaxsdp.studies.emps.emps_study`);
3. the closed-loop simulation check (`jaxsdp.studies.emps.simulation_check`,
   skipped for CSV files: no reference);
4. prints the tables and writes `report.md`, the figures (PNG) and
   `summary.json` to `--out`.
"""

import json
import os
import pathlib
import sys
import time

import jax
import numpy as np

from .._runtime import fast_loops_status
from .._version import __version__
from ..data._emps_builtin import BUILTIN_DT, BUILTIN_SAMPLES, emps_builtin_data
from ..data._loaders import load_emps, load_measurements
from ..studies._output import finite_or_none, one_line
from ..studies.emps._figures import FIGURE_NAMES, save_emps_figures
from ..studies.emps._preprocess import DROP
from ..studies.emps._report import recovery, report_markdown, text_output
from ..studies.emps._simulation_check import simulation_check
from ..studies.emps._study import emps_study
from .common import PROG, CLIError, Progress, check_out, int_at_least, positive_float, seed

STAGES = {
    "simulate_plant": "Simulating the built-in EMPS plant",
    "load": "Reading the data file",
    "derivatives": "Derivatives (Butterworth + central differences, decimation)",
    "idim_ls": "IDIM-LS, linear friction (Table 1)",
    "idim_ls_asym": "IDIM-LS, asymmetric friction",
    "sdp": "SDP stage, ML NVRs",
    "idim_sdp": "IDIM-SDP (Table 2)",
    "simulation": "Closed-loop simulation check",
    "figures": "Figures",
    "report": "Writing report.md and summary.json",
}


DEFAULT_OUT = "jaxsdp-emps-out"


NAME = "emps"


def add_parser(sub) -> None:
    """Register the `emps` subcommand on the subparsers `sub`."""
    emps = sub.add_parser(
        NAME,
        help="the complete EMPS study: IDIM-LS, SDP, IDIM-SDP, simulation check, report",
        description=(
            "The complete EMPS identification study (IDIM-LS with linear and asymmetric friction, "
            "SDP stage with ML NVRs, IDIM-SDP, closed-loop simulation check) on the built-in "
            "simulated plant or on a measurement file. Prints the tables and writes report.md, "
            "the figures (PNG) and summary.json to --out."
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
        help="seed of the built-in plant's measurement noise (default: 0; not used with --data)",
    )
    emps.add_argument("--quiet", action="store_true", help="no progress display (tables are still printed on stdout)")
    emps.set_defaults(run=run_emps)


def _check_cutoff(cutoff, dt):
    nyquist = 0.5 / dt
    if cutoff >= nyquist:
        raise CLIError(
            f"--cutoff {cutoff:g} Hz must be below the Nyquist frequency {nyquist:g} Hz of the data (dt = {dt:g} s)",
            code=2,
        )


def _check_length(n, decimate):
    # enough decimated samples for the regressions and the SDP stage
    kept = (n - DROP) // decimate
    if kept < 50:
        raise CLIError(
            f"{n} samples leave {max(kept, 0)} after dropping {DROP} and decimating by {decimate}; "
            "need at least 50 (use a smaller --decimate or a longer record)",
            code=2 if n - DROP >= 50 else 1,
        )


def _load(path: str):
    p = pathlib.Path(path)
    if not p.exists():
        raise CLIError(f"--data {path}: no such file")
    if not p.is_file():
        raise CLIError(f"--data {path}: not a regular file")
    if not os.access(p, os.R_OK):
        raise CLIError(f"--data {path}: permission denied")
    loader = load_emps if p.suffix.lower() == ".mat" else load_measurements
    try:
        return loader(p)
    except (ValueError, OSError) as e:
        msg = one_line(e).removeprefix("`path`: ")
        raise CLIError(f"--data: {msg}" if (str(p) in msg or p.name in msg) else f"--data {path}: {msg}") from None


def run_emps(args) -> int:
    start = time.perf_counter()
    out = check_out(args.out)
    builtin = args.data is None
    if not builtin and args.seed is not None and not args.quiet:
        print(f"{PROG} emps: note: --seed is only used by the built-in plant; ignored with --data", file=sys.stderr)
    first = "simulate_plant" if builtin else "load"
    stages = [first, "derivatives", "idim_ls", "idim_ls_asym", "sdp", "idim_sdp", "simulation", "figures", "report"]
    progress = Progress(stages, enabled=not args.quiet and sys.stderr.isatty(), labels=STAGES)
    timings = {}

    def stage(name, fn):
        progress.start(name)
        t0 = time.perf_counter()
        result = fn()
        timings[name] = time.perf_counter() - t0
        return result

    try:
        if builtin:
            _check_cutoff(args.cutoff, BUILTIN_DT)
            _check_length(BUILTIN_SAMPLES, args.decimate)
            noise_seed = 0 if args.seed is None else args.seed
            data, truth, desc = stage("simulate_plant", lambda: emps_builtin_data(noise_seed))
            source = f"built-in EMPS plant (seed {noise_seed})"
        else:
            data = stage("load", lambda: _load(args.data))
            truth, desc = None, {"path": str(pathlib.Path(args.data).resolve())}
            source = pathlib.Path(args.data).name
            try:
                _check_cutoff(args.cutoff, float(data.dt))
                _check_length(int(np.shape(data.force)[0]), args.decimate)
            except CLIError as e:
                raise CLIError(f"--data {args.data}: {e}", e.code) from None

        def note(st):
            if st != "load":  # the study's "load" is a no-op here (data already in memory)
                progress.start(st)

        try:
            study = emps_study(data, cutoff_hz=args.cutoff, decimate=args.decimate, source=source, progress=note)
        except ValueError as e:
            raise CLIError(one_line(e)) from None
        for k, v in study.timings.items():
            if k not in ("load", "total"):
                timings[k] = float(v)
        simulation = stage("simulation", lambda: simulation_check(data, study))

        summary = study.summary()
        summary["simulation"] = simulation
        summary["data"].update(desc)
        summary["truth"] = truth
        if truth is not None:
            summary["recovery"] = recovery(summary, truth)

        def write_figures():
            out.mkdir(exist_ok=True)
            return save_emps_figures(study, out)

        figures = stage("figures", write_figures)
        progress.start("report")
        t0 = time.perf_counter()
        timings["report"] = 0.0
        timings["total"] = time.perf_counter() - start
        summary["timings"] = timings
        summary["fast_loops"] = fast_loops_status()
        summary["versions"] = {"jaxsdp": __version__, "jax": jax.__version__}
        text = text_output(study, summary)
        (out / "report.md").write_text(report_markdown(study, summary, figures))
        timings["report"] = time.perf_counter() - t0
        timings["total"] = time.perf_counter() - start
        (out / "summary.json").write_text(json.dumps(finite_or_none(summary), indent=2, allow_nan=False) + "\n")
        progress.done()
    except BaseException:
        progress.abort()
        raise

    print(text)
    names = ", ".join(f"{n}.png" for n in FIGURE_NAMES if n in figures)
    print(f"\nWrote {out}/: report.md, summary.json, {names}  ({timings['total']:.1f} s)")
    return 0
