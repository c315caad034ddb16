"""`jaxsdp emps`: the complete EMPS study on the built-in simulated plant or on a measurement file.

1. data: the built-in closed-loop simulation (`jaxsdp.data.emps_builtin_data`),
   or a benchmark-format `.mat` file (`jaxsdp.data.load_emps`) or a CSV file
   with columns `t`, `q`, `force` (`jaxsdp.data.load_measurements`);
2. derivatives, IDIM-LS (linear and asymmetric friction), SDP stage with ML
   NVRs, IDIM-SDP (`jaxsdp.studies.emps.emps_study`);
3. the closed-loop simulation check (`jaxsdp.studies.emps.simulation_check`,
   skipped for CSV files: no reference);
4. prints the tables and writes `report.md`, the figures (PNG, PDF or SVG),
   `summary.json` and the whole study as `study.npz` (reload it with
   `jaxsdp.load`) to `--out`.

Everything checkable is checked first, in well under a second: the options,
the output folder (created, probed with a file), the data (read, uniform
sampling, `jaxsdp.plants.emps._checks.check_emps_data`). The outputs are
written to a staging folder beside `--out` and moved into it only at the
end, so a failed run leaves `--out` as it was. Library warnings are printed
as one line each, without source paths.
"""

import json
import pathlib
import sys
import time

import jax
import numpy as np

from .._io import save
from .._runtime import fast_loops_status
from .._version import __version__
from ..data._emps_builtin import BUILTIN_DT, BUILTIN_SAMPLES, emps_builtin_data
from ..data._loaders import IrregularSamplingError, load_emps, load_measurements
from ..plants.emps._checks import MIN_DECIMATED, check_emps_data, check_length
from ..plants.emps._preprocess import DROP
from ..studies._output import finite_or_none, one_line
from ..studies.emps._figures import FIGURE_NAMES, save_emps_figures
from ..studies.emps._report import recovery, report_markdown, text_output
from ..studies.emps._simulation_check import simulation_check
from ..studies.emps._study import emps_study
from .common import PROG, CLIError, OutputFolder, Progress, WarningLines, data_file, int_at_least, positive_float, seed

STAGES = {
    "simulate_plant": "Simulating the built-in EMPS plant",
    "load": "Reading the data file",
    "derivatives": "Derivatives (Butterworth + central differences, decimation)",
    "idim_ls": "IDIM-LS, linear friction (Table 1)",
    "idim_ls_asym": "IDIM-LS, asymmetric friction",
    "sdp": "SDP stage, ML NVRs",
    "idim_sdp": "IDIM-SDP (Table 2)",
    "idim_iv": "IDIM-IV (instruments from the closed-loop simulation)",
    "decimation_check": "SDP stage at neighbouring decimation factors",
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
        help="seed of the built-in plant's measurement noise (default: 0; not used with --data)",
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
        "--no-decimation-check",
        action="store_true",
        help="do not re-run the SDP stage at half and twice --decimate to check the mass-constancy finding",
    )
    emps.add_argument(
        "--format",
        choices=("png", "pdf", "svg"),
        default="png",
        help="file format of the figures (default: png)",
    )
    emps.add_argument(
        "--dpi",
        metavar="DPI",
        type=positive_float,
        default=150.0,
        help="resolution of raster (png) figures in dots per inch (default: 150)",
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
    # enough decimated samples for the regressions and the SDP stage (jaxsdp.plants.emps._checks)
    try:
        check_length(n, drop=DROP, decimate=decimate, advice="use a smaller --decimate or a longer record")
    except ValueError as e:
        raise CLIError(one_line(e), code=2 if n - DROP >= MIN_DECIMATED else 1) from None


def _load(path: str, resample: bool):
    p = data_file(path)
    loader = load_emps if p.suffix.lower() == ".mat" else load_measurements
    try:
        return loader(p, irregular="resample" if resample else "error")
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


def run_emps(args) -> int:
    """Check the options, the output folder and the data up front; run the study; move the outputs into --out.

    Outputs are written into a staging folder beside --out and moved in only
    when everything succeeded, so a failed run leaves --out as it was (a
    folder this run created is removed again). Library warnings are printed
    as one line each (`jaxsdp emps: warning: ...`), without source paths.
    """
    start = time.perf_counter()
    builtin = args.data is None
    if builtin:
        _check_cutoff(args.cutoff, BUILTIN_DT)
        _check_length(BUILTIN_SAMPLES, args.decimate)
    with OutputFolder(args.out) as out, WarningLines(f"{PROG} {NAME}"):
        figures, timings, text, warnings = _run(args, out.staging, start)
        out.commit()
    print(text)
    names = ", ".join(figures[n].name for n in FIGURE_NAMES if n in figures)
    print(f"\nWrote {out.path}/: report.md, summary.json, study.npz, {names}  ({timings['total']:.1f} s)")
    for w in warnings:
        print(f"{PROG} {NAME}: warning: {w}", file=sys.stderr)
    return 0


def _run(args, staging: pathlib.Path, start: float):
    """The study, writing every output into `staging`; returns (figures, timings, text output, warnings)."""
    builtin = args.data is None
    if not args.quiet and not builtin and args.seed is not None:
        print(f"{PROG} {NAME}: note: --seed is only used by the built-in plant; ignored with --data", file=sys.stderr)
    if not args.quiet and builtin and args.resample:
        print(
            f"{PROG} {NAME}: note: --resample is only used with --data; ignored for the built-in plant", file=sys.stderr
        )
    first = "simulate_plant" if builtin else "load"
    stages = [first, "derivatives", "idim_ls", "idim_ls_asym", "sdp", "idim_sdp"]
    stages += [] if args.estimator == "ls" else ["idim_iv"]
    stages += [] if args.no_decimation_check else ["decimation_check"]
    stages += ["simulation", "figures", "report"]
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
            noise_seed = 0 if args.seed is None else args.seed
            data, truth, desc = stage("simulate_plant", lambda: emps_builtin_data(noise_seed))
            source = f"built-in EMPS plant (seed {noise_seed})"
        else:
            data = stage("load", lambda: _load(args.data, args.resample))
            truth, desc = None, {"path": str(pathlib.Path(args.data).resolve())}
            source = pathlib.Path(args.data).name
            if data.resampled is not None:
                desc["resampled"] = data.resampled
                if not args.quiet:
                    progress.done()
                    print(f"{PROG} {NAME}: note: {data.resampled}", file=sys.stderr)
        _check_data(data, args)

        def note(st):
            if st != "load":  # the study's "load" is a no-op here (data already in memory)
                progress.start(st)

        try:
            study = emps_study(
                data,
                cutoff_hz=args.cutoff,
                decimate=args.decimate,
                estimator=args.estimator,
                nvr_search=args.nvr_search,
                max_nvr=args.max_nvr,
                check_decimation=not args.no_decimation_check,
                source=source,
                progress=note,
            )
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
            summary["warnings"] += summary["recovery"]["warnings"]

        figures = stage("figures", lambda: save_emps_figures(study, staging, fmt=args.format, dpi=args.dpi))
        progress.start("report")
        t0 = time.perf_counter()
        timings["report"] = 0.0
        timings["total"] = time.perf_counter() - start
        summary["timings"] = timings
        summary["fast_loops"] = fast_loops_status()
        summary["versions"] = {"jaxsdp": __version__, "jax": jax.__version__}
        text = text_output(study, summary)
        (staging / "report.md").write_text(report_markdown(study, summary, figures))
        timings["report"] = time.perf_counter() - t0
        timings["total"] = time.perf_counter() - start
        (staging / "summary.json").write_text(json.dumps(finite_or_none(summary), indent=2, allow_nan=False) + "\n")
        save(staging / "study.npz", study)  # the whole EMPSStudy: jaxsdp.load("<out>/study.npz")
        progress.done()
    except BaseException:
        progress.abort()
        raise
    return figures, timings, text, summary["warnings"]
