"""The `jaxsdp` command line (`jaxsdp emps ...`, also `python -m jaxsdp emps ...`).

One module per subcommand (`emps`, `control`, `tx40`, `robot`, `montecarlo`, `forecast`), sharing `common` (errors,
option types, progress, and `run_study`, the one runner). A subcommand declares its options and maps them to its
study's arguments; the runner writes the study's `figures`, `report` and `summary` and prints its `text` (the study
contract, `jaxsdp.studies._contract`).
"""

import argparse
import os
import signal
import sys
import threading

from .._runtime import KERNEL_METHODS, method_scope
from .._version import __version__
from ..studies._output import one_line
from . import control, emps, forecast, montecarlo, robot, tx40
from .common import PROG, CLIError, Parser, abandon_open_folders, cli_text, command_of, option_table, positive_float

SUBCOMMANDS = (emps, control, tx40, robot, montecarlo, forecast)
#: Exit code after Ctrl-C (128 + SIGINT, the shell's convention).
INTERRUPTED = 130
COMMANDS = tuple(m.NAME for m in SUBCOMMANDS)
#: Seconds the main thread has to handle Ctrl-C before the watchdog ends the process.
INTERRUPT_GRACE = 2.0
_HANDLING = threading.Event()  # set once the main thread is handling Ctrl-C itself
_CONSOLE = threading.Event()  # set by `run`: the console command, which ends the process itself after Ctrl-C


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog=PROG,
        description="Differentiable state-dependent parameter (SDP) identification of electromechanical systems.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for command in SUBCOMMANDS:
        command.add_parser(sub)
    for p in sub.choices.values():
        p.add_argument("--format", choices=("png", "pdf", "svg"), default="png", help="figure format (default: png)")
        p.add_argument(
            "--dpi",
            metavar="DPI",
            type=positive_float,
            default=150.0,
            help="resolution of raster (png) figures in dots per inch (default: 150)",
        )
        p.add_argument("--quiet", action="store_true", help="no progress display (tables are still printed on stdout)")
        p.add_argument(
            "--overwrite",
            action="store_true",
            help="write into a non-empty --out folder, replacing the files an earlier jaxsdp run wrote there "
            "(other files are kept; default: refuse a non-empty folder)",
        )
        p.add_argument(
            "--method",
            choices=KERNEL_METHODS,
            default=None,
            help="Kalman-filter and IIR kernels: sequential scans, parallel-in-time scans (for GPUs), "
            "or auto (parallel on GPU/TPU, sequential on CPU; the default)",
        )
    for command in SUBCOMMANDS:  # the options the library's messages are translated to (common.cli_text)
        p = sub.choices[command.NAME]
        p.set_defaults(flags=option_table(p, getattr(command, "FLAGS", None)))
    return parser


def flags_of(command) -> dict:
    """The option table of `command` (`common.option_table`: argument -> option; empty for an unknown command),
    which `common.cli_text` writes the library's messages with."""
    if command not in COMMANDS:
        return {}
    parser = build_parser()
    return parser._subparsers._group_actions[0].choices[command].get_default("flags")


def main(argv=None) -> int:
    """Entry point of the `jaxsdp` command; returns the exit code (130 after Ctrl-C)."""
    try:
        import jax

        # An entry point may set global configuration (library code never does).
        jax.config.update("jax_enable_x64", True)
        parser = build_parser()
        try:
            args = parser.parse_args(argv)
        except SystemExit as e:  # --help, --version
            return int(e.code or 0) if not isinstance(e.code, str) else 2
        with method_scope(args.method):
            return args.run(args)
    except CLIError as e:
        command = command_of(argv)
        cmd = f"{PROG} {command}" if command in COMMANDS else PROG
        hint = f" (see '{cmd} --help')" if e.usage else ""
        print(f"{cmd}: error: {cli_text(one_line(e), flags_of(command))}{hint}", file=sys.stderr)
        return e.code
    except KeyboardInterrupt:
        _HANDLING.set()
        print(f"{PROG}: interrupted", file=sys.stderr)
        if _CONSOLE.is_set():  # the console command: end here, while the interrupted frames still hold their arrays
            _exit_interrupted()
        return INTERRUPTED
    except Exception as e:  # noqa: BLE001  one line for the user, no traceback
        print(f"{PROG}: error: {type(e).__name__}: {one_line(e)}", file=sys.stderr)
        return 1


def _watch_interrupts(grace: float = INTERRUPT_GRACE) -> None:
    """End the process within `grace` seconds of Ctrl-C, even inside a compiled computation.

    Python runs its SIGINT handler in the main thread between bytecodes, so a
    KeyboardInterrupt waits for the XLA call under way (a Monte Carlo chunk can
    take minutes on a laptop). The C-level handler also writes the signal to
    the wake-up pipe at once; this thread reads it and, if the main thread has
    not ended the process within `grace`, removes the staged outputs and exits
    with 130 itself."""
    r, w = os.pipe()
    os.set_blocking(w, False)
    try:
        signal.set_wakeup_fd(w, warn_on_full_buffer=False)
    except ValueError:  # not the main thread (an embedding application): keep Python's handling only
        os.close(r)
        os.close(w)
        return

    def watch():
        while signal.SIGINT not in os.read(r, 64):
            pass
        if _HANDLING.wait(grace):  # the main thread is cleaning up: give it time, then end regardless
            threading.Event().wait(10 * grace)
            os._exit(INTERRUPTED)
        abandon_open_folders()
        os.write(2, f"{PROG}: interrupted\n".encode())
        os._exit(INTERRUPTED)

    threading.Thread(target=watch, name="jaxsdp-interrupt-watchdog", daemon=True).start()


def run() -> None:
    """The console command (`jaxsdp`, `python -m jaxsdp`): `main()`, then exit with its code.

    After Ctrl-C (`main` has removed what the run had staged and printed
    "interrupted") the process ends at once with 130, without the interpreter's
    teardown: XLA's worker threads may still be running a computation then,
    and tearing the runtime down under them crashed the process (SIGSEGV).
    When the main thread is inside a long compiled computation, a watchdog
    thread does the same within `INTERRUPT_GRACE` seconds.
    """
    _watch_interrupts()
    _CONSOLE.set()
    code = main()
    if code == INTERRUPTED:
        _exit_interrupted()
    sys.exit(code)


def _exit_interrupted() -> None:
    """End the process with 130 at once (the staging already removed by the runner's `finally`): no interpreter
    teardown, and no release of the interrupted frames' device arrays while XLA may still be computing into them
    (issue 45: a SIGSEGV after "interrupted" when the frames were released first, under load)."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(INTERRUPTED)
