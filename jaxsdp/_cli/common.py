"""What every subcommand shares: one-line errors, option types, progress lines, the output folder, warnings,
and `run_study`, the one runner every command calls."""

import argparse
import contextlib
import json
import math
import os
import pathlib
import re
import shutil
import sys
import tempfile
import time
import warnings

from .._checks import OptionError
from ..plants._friction_laws import AsymmetricCoulomb, SmoothCoulomb, Stribeck, ViscousCoulomb
from ..studies._contract import report as study_report
from ..studies._contract import save_figures
from ..studies._contract import summary as study_summary
from ..studies._contract import text as study_text
from ..studies._output import finite_or_none, one_line

#: --friction's choices (`jaxsdp emps`, `jaxsdp robot`): the laws of `jaxsdp.plants` they stand for (auto: all
#: four, chosen by BIC).
FRICTION = {
    "auto": (ViscousCoulomb(), AsymmetricCoulomb(), SmoothCoulomb(), Stribeck()),
    "viscous-coulomb": ViscousCoulomb(),
    "asymmetric": AsymmetricCoulomb(),
    "smooth-coulomb": SmoothCoulomb(),
    "stribeck": Stribeck(),
}

PROG = "jaxsdp"


class CLIError(Exception):
    """An error reported to the user as one line (exit code `code`)."""

    def __init__(self, message, code=1, usage=False):
        super().__init__(message)
        self.code = code
        self.usage = usage  # an argparse error: add a --help hint


class Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, no usage block (main() adds a --help hint)
        raise CLIError(message, code=2, usage=True)


def int_at_least(lo):
    def parse(text):
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an integer >= {lo}; got {text!r}") from None
        if v < lo:
            raise argparse.ArgumentTypeError(f"must be an integer >= {lo}; got {v}")
        return v

    return parse


def seed(text):
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer in [0, 2**32); got {text!r}") from None
    if not 0 <= v < 2**32:
        raise argparse.ArgumentTypeError(f"must be an integer in [0, 2**32); got {v}")
    return v


def nonnegative_float(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number >= 0; got {text!r}") from None
    if not (math.isfinite(v) and v >= 0):
        raise argparse.ArgumentTypeError(f"must be a number >= 0; got {text!r}")
    return v


def positive_float(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a positive number; got {text!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number; got {text!r}")
    return v


def fraction(text):
    """A number in (0, 1) (a tolerance, an interval's level)."""
    v = positive_float(text)
    if not v < 1:
        raise argparse.ArgumentTypeError(f"must lie in (0, 1); got {text!r}")
    return v


def data_file(path: str, option: str = "--data") -> pathlib.Path:
    """The file of `option` as a Path, after checking it exists, is a regular file and is readable (CLIError)."""
    p = pathlib.Path(path)
    if not p.exists():
        raise CLIError(f"{option} {path}: no such file")
    if not p.is_file():
        raise CLIError(f"{option} {path}: not a regular file")
    if not os.access(p, os.R_OK):
        raise CLIError(f"{option} {path}: permission denied")
    return p


class Progress:
    """One line per stage on stderr, `[k/n] label ... 1.2 s`; silent if disabled."""

    def __init__(self, stages, enabled, stream=None, labels=None):
        self.stages = list(stages)
        self.labels = {} if labels is None else dict(labels)
        self.enabled = enabled
        self.stream = sys.stderr if stream is None else stream
        self.current = None
        self.t0 = None

    def start(self, stage):
        self.done()
        self.current, self.t0 = stage, time.perf_counter()
        if self.enabled:
            k = self.stages.index(stage) + 1 if stage in self.stages else "?"
            self.stream.write(f"[{k}/{len(self.stages)}] {self.labels.get(stage, stage)} ...")
            self.stream.flush()

    def done(self):
        if self.current is not None and self.enabled:
            self.stream.write(f" {time.perf_counter() - self.t0:.1f} s\n")
            self.stream.flush()
        self.current = None

    def abort(self):
        if self.current is not None and self.enabled:
            self.stream.write(" failed\n")
            self.stream.flush()
        self.current = None


def _reason(e: OSError) -> str:
    return e.strerror or type(e).__name__


#: Output folders with a staging folder still open (`abandon_open_folders` removes them).
OPEN_FOLDERS: set = set()


def abandon_open_folders() -> None:
    """Remove every open run's staging folder (and an --out folder it created and left empty).

    Called by the command's interrupt watchdog, from another thread, when Ctrl-C cannot reach the main
    thread because it is inside a compiled computation."""
    for folder in list(OPEN_FOLDERS):
        folder.close(failed=True)


class OutputFolder:
    """The --out folder, checked up front; outputs are staged beside it and moved in at the end.

    `OutputFolder(out)` creates `out` if absent (its parent must exist) and
    writes and deletes a probe file in it, so an unusable folder fails in a
    fraction of a second, before any work. An empty path is refused, and so
    is a folder that is not empty unless `overwrite`: then the files the
    previous run recorded in its manifest (`.jaxsdp-files`) are removed when
    the new ones move in, and other files are kept. `staging` is a fresh hidden
    folder (`.jaxsdp-*`) in the parent of `out` (same file system, so the
    final moves are atomic renames), or inside `out` when the parent is not
    writable or on another file system. Write every output into `staging`;
    `commit()` moves them into `out` (replacing files of an earlier run only
    then); `close()` removes `staging` and, after a failure, `out` itself if
    this run created it and it is still empty. Use it as a context manager.
    An empty path, a path naming a file, a missing parent and a non-empty
    folder are usage errors (`CLIError` code 2); a folder that cannot be
    created or written, code 1.
    """

    PREFIX = ".jaxsdp-"
    #: The list of the files a run wrote, kept in `out` so that `--overwrite` removes exactly those.
    MANIFEST = ".jaxsdp-files"

    def __init__(self, out: str, *, overwrite: bool = False):
        self.label = out
        if not str(out).strip():
            raise CLIError("--out: an empty path; name the output folder (for instance --out results)", code=2)
        self.path = path = pathlib.Path(out)
        self.created = False
        self.overwrite = overwrite
        if path.exists() or path.is_symlink():
            if not path.is_dir():
                raise CLIError(f"--out {out}: exists and is not a directory; name a new or empty folder", code=2)
            present = sorted(p.name for p in path.iterdir() if not p.name.startswith(self.PREFIX))
            if present and not overwrite:
                shown = ", ".join(present[:4]) + (f" and {len(present) - 4} more" if len(present) > 4 else "")
                raise CLIError(
                    f"--out {out}: the folder is not empty ({shown}); choose a new folder, or pass --overwrite "
                    "to replace the files an earlier jaxsdp run wrote there (other files are kept)",
                    code=2,
                )
        else:
            parent = path.absolute().parent
            if not parent.is_dir():
                raise CLIError(
                    f"--out {out}: parent directory {parent} does not exist; create it first or name another folder",
                    code=2,
                )
            try:
                path.mkdir()
            except OSError as e:
                raise CLIError(f"--out {out}: cannot create the directory ({_reason(e)})") from None
            self.created = True
        try:
            self._probe()
            self.staging = self._make_staging()
            OPEN_FOLDERS.add(self)
        except OSError as e:
            self.staging = None
            self.close(failed=True)
            raise CLIError(f"--out {out}: directory is not writable ({_reason(e)})") from None

    def _probe(self):
        fd, probe = tempfile.mkstemp(dir=self.path, prefix=self.PREFIX + "probe-")
        try:
            os.write(fd, b"probe\n")
        finally:
            os.close(fd)
            os.unlink(probe)

    def _make_staging(self) -> pathlib.Path:
        parent = self.path.absolute().parent
        try:
            staging = pathlib.Path(tempfile.mkdtemp(dir=parent, prefix=self.PREFIX))
        except OSError:
            return pathlib.Path(tempfile.mkdtemp(dir=self.path, prefix=self.PREFIX))
        if staging.stat().st_dev != self.path.stat().st_dev:  # --out is a mount point: no atomic rename
            staging.rmdir()
            return pathlib.Path(tempfile.mkdtemp(dir=self.path, prefix=self.PREFIX))
        return staging

    def commit(self) -> list[str]:
        """Move every staged file into `out`, after removing the files an earlier run listed in its manifest
        (`--overwrite`); records the new ones in the manifest. Returns their names."""
        names = sorted(p.name for p in self.staging.iterdir())
        manifest = self.path / self.MANIFEST
        if self.overwrite and manifest.is_file():
            for old in manifest.read_text().splitlines():
                target = self.path / old
                if old and old not in names and "/" not in old and target.is_file():
                    target.unlink()
        for name in names:
            os.replace(self.staging / name, self.path / name)
        manifest.write_text("".join(f"{n}\n" for n in names))
        return names

    def close(self, failed: bool = False):
        OPEN_FOLDERS.discard(self)
        staging, self.staging = self.staging, None
        if staging is not None:
            shutil.rmtree(staging, ignore_errors=True)
        if failed and self.created:
            with contextlib.suppress(OSError):
                self.path.rmdir()  # only if still empty

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        self.close(failed=exc_type is not None)
        return False


class WarningLines:
    """Collect the library warnings of a run (no source paths) and print each distinct one as one line.

    `with WarningLines(prefix) as w:` records `RuntimeWarning`, `UserWarning`
    and the like raised inside (deprecation warnings, meant for developers,
    are dropped); `w.messages` lists the distinct ones in order; on exit each
    is printed to `stream` (stderr) as `<prefix>: warning: <message>
    (<category>)`, also when the block fails (before the error line).
    """

    def __init__(self, prefix: str, stream=None):
        self.prefix = prefix
        self.stream = stream
        self.messages: list[str] = []
        self._cm = None

    def __enter__(self):
        self._cm = warnings.catch_warnings(record=True)
        self._caught = self._cm.__enter__()
        warnings.simplefilter("default")
        for category in (DeprecationWarning, PendingDeprecationWarning):
            warnings.simplefilter("ignore", category)
        return self

    def collect(self) -> list[str]:
        for w in self._caught:
            text = f"{one_line(w.message)} ({w.category.__name__})"
            if text not in self.messages:
                self.messages.append(text)
        self._caught.clear()
        return self.messages

    def __exit__(self, exc_type, exc, tb):
        self.collect()
        self._cm.__exit__(exc_type, exc, tb)
        stream = sys.stderr if self.stream is None else self.stream
        for text in self.messages:
            print(f"{self.prefix}: warning: {text}", file=stream)
        return False


#: An argument as the library's messages write it: `name`, or `name=value` (`estimator="iv"`, `full_model=True`).
_ARGUMENT = re.compile(r"""`(?P<name>[A-Za-z_]\w*)(?:=["']?(?P<value>[\w.-]+)["']?)?`""")


def option_table(parser: argparse.ArgumentParser, extra: dict[str, str] | None = None) -> dict[str, str]:
    """The options of a subcommand for `cli_text`: each option's destination -> its flag (`max_nvr` ->
    `--max-nvr`), then `extra` (an argument name whose option is named differently, `cutoff_hz` -> `--cutoff`, or
    a phrase holding backquotes, "run tx40_study(..., `full_model=True`)" -> "use --model full")."""
    table = {}
    for action in parser._actions:
        flags = [o for o in action.option_strings if o.startswith("--")]
        if flags and action.dest not in ("help", "version"):
            table[action.dest] = flags[0]
    return {**table, **(extra or {})}


def cli_text(text: str, flags: dict[str, str]) -> str:
    """A library message as the command line says it: the Python arguments it names in backquotes replaced by
    the command's options (`flags` from `option_table`); an argument the command has no option for stays as it is.

    The library never names command-line flags (its messages serve Python users too); this is where they appear.
    """
    for key in sorted((k for k in flags if "`" in k), key=len, reverse=True):  # whole phrases first
        text = text.replace(key, flags[key])

    def option(m):
        flag = flags.get(m["name"])
        if flag is None:
            return m[0]
        return flag if m["value"] is None else f"{flag} {m['value']}"

    return _ARGUMENT.sub(option, text)


def cli_tree(tree, flags: dict[str, str]):
    """A summary with every string through `cli_text` (its warnings and notes, as the command printed them)."""
    if isinstance(tree, str):
        return cli_text(tree, flags)
    if isinstance(tree, dict):
        return {k: cli_tree(v, flags) for k, v in tree.items()}
    if isinstance(tree, (list, tuple)):
        return [cli_tree(v, flags) for v in tree]
    return tree


def option_error(e: Exception, flags: dict[str, str]) -> CLIError:
    """A library `OptionError` (an argument that does not fit the data) as a usage error (exit 2), with each
    argument name the library writes in backquotes (`ratios`) replaced by its command-line flag (--ratios)."""
    return CLIError(cli_text(one_line(e), flags), code=2)


def command_of(argv):
    args = sys.argv[1:] if argv is None else list(argv)
    return next((a for a in args if not a.startswith("-")), None)


def run_study(
    args,
    *,
    name: str,
    stages,
    labels: dict,
    call,
    extra_files=None,
) -> int:
    """Run one study for the command `name` and write what it returns; every subcommand ends here.

    `call(progress, staging)` maps the parsed options `args` to the study's
    arguments and returns its result (`progress.start(stage)` announces each
    stage, `Progress`;
    `staging` is the folder whose files end up in `--out`, for data a study
    writes beside its report). The result is a `jaxsdp.studies._contract.Study`:
    its `figures`, `summary`, `report` and `text` are written as `<name>.<fmt>`
    figures, `summary.json` and `report.md`, and printed; `extra_files(result, staging)` writes further
    files (e.g. `study.npz`). `--out` is checked first (`OutputFolder`), the
    outputs move in only when all succeeded, library warnings print as one
    line each, the result's `warnings` print last on stderr. A ValueError of
    the study becomes a one-line error: exit 1 (data), or 2 for an
    `OptionError` (an option that does not fit the data). Every text the
    library wrote goes through `cli_text` with the command's options
    (`args.flags`, set by `build_parser`), so that it names options, not
    Python arguments. Returns 0.
    """
    start = time.perf_counter()
    prefix = f"{PROG} {name}"
    flags = getattr(args, "flags", {})
    with OutputFolder(args.out, overwrite=args.overwrite) as out, WarningLines(prefix):
        progress = Progress(
            [*stages, "figures", "report"], enabled=not args.quiet and sys.stderr.isatty(), labels=labels
        )
        try:
            try:
                result = call(progress, out.staging)
            except OptionError as e:  # an option that does not fit the data: a usage error
                raise CLIError(one_line(e), code=2) from None  # `main` writes it with the command's options
            except ValueError as e:
                raise CLIError(one_line(e)) from None
            # the command's stages come last, after the study's: the figures, the report, the total
            timings = {k: v for k, v in result.timings.items() if k != "total"}
            progress.start("figures")
            t0 = time.perf_counter()
            paths = save_figures(result.figures(), out.staging, fmt=args.format, dpi=args.dpi)
            timings["figures"] = time.perf_counter() - t0
            progress.start("report")
            t0 = time.perf_counter()
            timings.update(report=0.0, total=time.perf_counter() - start)
            report = cli_text(study_report(result.with_timings(timings), figures=paths), flags)
            extra = [] if extra_files is None else list(extra_files(result, out.staging))
            (out.staging / "report.md").write_text(report)
            timings.update(report=time.perf_counter() - t0, total=time.perf_counter() - start)
            result = result.with_timings(timings)
            summary = json.dumps(finite_or_none(cli_tree(study_summary(result), flags)), indent=2, allow_nan=False)
            (out.staging / "summary.json").write_text(summary + "\n")
            progress.done()
        except BaseException:
            progress.abort()
            raise
        written = out.commit()
    print(cli_text(study_text(result), flags).rstrip("\n"))
    figures = [p.name for p in paths.values()]
    others = sorted(set(written) - {"report.md", "summary.json", *figures, *extra, OutputFolder.MANIFEST})
    names = ", ".join(["report.md", "summary.json", *extra, *others, *figures])
    print(f"\nWrote {out.path}/: {names}  ({time.perf_counter() - start:.1f} s)")
    for w in result.warnings:
        print(f"{prefix}: warning: {cli_text(w, flags)}", file=sys.stderr)
    return 0
