"""What every subcommand shares: one-line errors, option types, progress lines, the output folder check."""

import argparse
import math
import os
import pathlib
import sys
import time

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


def positive_float(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a positive number; got {text!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number; got {text!r}")
    return v


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


def check_out(out: str) -> pathlib.Path:
    path = pathlib.Path(out)
    if path.exists():
        if not path.is_dir():
            raise CLIError(f"--out {out}: exists and is not a directory")
        if not os.access(path, os.W_OK):
            raise CLIError(f"--out {out}: directory is not writable")
        return path
    parent = path.absolute().parent
    if not parent.is_dir():
        raise CLIError(f"--out {out}: parent directory {parent} does not exist")
    if not os.access(parent, os.W_OK):
        raise CLIError(f"--out {out}: cannot create it, parent directory {parent} is not writable")
    return path


def command_of(argv):
    args = sys.argv[1:] if argv is None else list(argv)
    return next((a for a in args if not a.startswith("-")), None)
