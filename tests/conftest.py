# Import jaxsdp first so that its XLA-CPU fast-loop option (see jaxsdp._runtime)
# is in place before anything initialises JAX's backend.
import jaxsdp  # noqa: F401  isort: skip
import os
import pathlib

import jax
import pytest

from helpers import EMPS_MAT

jax.config.update("jax_enable_x64", True)

# JAX's persistent compilation cache. Most of the suite's time is XLA
# compilation (tests/test_parallel.py: 211 s of CPU with an empty cache, 45 s
# with a filled one), and the same programs are compiled again by every
# process the suite starts: pytest-xdist workers, the notebooks' kernels, the
# CLI and multi-process tests. One cache folder, shared through the
# environment, lets each program be compiled once per run, and once per
# machine across runs (keys hold the program, jaxlib version, flags and
# device, so a stale entry is never used; a cold run wrote 98 MB with the 0.2 s threshold, 2026-11-27).
# No size cap: JAX's least-recently-used eviction races between processes
# (a worker's eviction deletes files another is stamping: a UserWarning that
# the CLI rightly reports). JAXSDP_TEST_JAX_CACHE=0 turns it off; a path
# chooses the folder (default: ~/.cache/jaxsdp/jax-tests); delete the folder
# to reclaim its space.
# Issue 41: a worker's segmentation fault on a fresh machine was first seen inside the cache write;
# with the cache off (2026-11-25, 2 workers, 25 min) a worker died the same way inside XLA's compilation
# itself (`backend_compile_and_load`, compiling idim_ls for tests/test_tx40_full.py), so the cache is not
# the cause, and without it the suite takes 25 min instead of about 11: it stays on.
_cache = os.environ.get("JAXSDP_TEST_JAX_CACHE", "")
if _cache != "0":
    if not _cache:
        base = os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache"
        _cache = str(pathlib.Path(base) / "jaxsdp" / "jax-tests")
    os.environ["JAXSDP_TEST_JAX_CACHE"] = _cache  # xdist workers resolve it alike
    # the environment reaches the subprocesses (notebook kernels, CLI runs)
    os.environ["JAX_COMPILATION_CACHE_DIR"] = _cache
    # Every program, however quick to compile (JAX's default keeps those over 1 s; this suite kept those over
    # 0.2 s until 2026-11-27): the suite's eager operations on JAX arrays are some 23,000 compilations of about
    # 40 ms each per run (1,000 s of the workers' time in a cold full run), repeated in every process and every
    # test file (`jax.clear_caches()` below). Measured on tests/test_plausibility.py + test_tx40.py, the second
    # run of a fresh cache: 36 s of CPU instead of 67 s (the first run: 107 s either way; the folder 7 MB
    # instead of 3). JAXSDP_TEST_CACHE_MIN=seconds sets another threshold.
    _min = os.environ.get("JAXSDP_TEST_CACHE_MIN", "0")
    os.environ["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"] = _min
    jax.config.update("jax_compilation_cache_dir", _cache)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", float(_min))


def _cache_entries():
    folder = pathlib.Path(_cache)
    return sum(1 for _ in folder.iterdir()) if _cache != "0" and folder.is_dir() else 0


# before any worker writes to it; only the controlling process prints the summary, so the workers skip the count
_CACHE_AT_START = 0 if os.environ.get("PYTEST_XDIST_WORKER") else _cache_entries()


def pytest_terminal_summary(terminalreporter):
    """Whether this run started from an empty compilation cache (a cold run: every program compiled), so that the
    time in `.ci/run`'s output says which kind of run it was."""
    if _cache == "0":
        line = "off (JAXSDP_TEST_JAX_CACHE=0): every program compiled"
    elif _CACHE_AT_START:
        line = f"{_CACHE_AT_START} entries at the start, {_cache_entries()} at the end"
    else:
        line = f"empty at the start (a cold run: every program compiled), {_cache_entries()} entries at the end"
    terminalreporter.write_line(f"JAX compilation cache: {line}")


# JAXSDP_COMPILE_LOG=folder: every trace, lowering and XLA compilation of the run, with its program's name,
# test and seconds, one JSON line each in folder/<worker>.jsonl (`python benchmarks/compile_profile.py folder`
# sums them: which programs are compiled how often, by which tests; the suite's time is mostly compilation).
_COMPILE_LOG = os.environ.get("JAXSDP_COMPILE_LOG")
_current_test = ["(collection)"]
if _COMPILE_LOG:
    import json

    from jax import monitoring

    _EVENTS = {
        "/jax/core/compile/jaxpr_trace_duration": "trace",
        "/jax/core/compile/jaxpr_to_mlir_module_duration": "lower",
        "/jax/core/compile/backend_compile_duration": "compile",
    }
    pathlib.Path(_COMPILE_LOG).mkdir(parents=True, exist_ok=True)
    _log = open(pathlib.Path(_COMPILE_LOG) / f"{os.environ.get('PYTEST_XDIST_WORKER', 'main')}.jsonl", "a")

    import traceback

    _ROOT = str(pathlib.Path(__file__).resolve().parents[1])

    def _site():
        """The innermost frame in the project's own code (library, tests, benchmarks) that led to this compilation:
        `path:line (function)`, so that many small programs (eager operations on JAX arrays) can be traced to the
        line that runs them."""
        for frame in reversed(traceback.extract_stack()[:-3]):
            rel = frame.filename[len(_ROOT) + 1 :] if frame.filename.startswith(_ROOT + os.sep) else ""
            if rel.split(os.sep, 1)[0] in ("jaxsdp", "tests", "benchmarks") and not rel.endswith("conftest.py"):
                return f"{rel}:{frame.lineno} ({frame.name})"
        return "?"

    def _listener(event, duration, **kwargs):
        kind = _EVENTS.get(event)
        if kind is not None:
            record = {"kind": kind, "fun": kwargs.get("fun_name", "?"), "s": duration, "test": _current_test[0]}
            if kind == "compile":
                record["site"] = _site()
            _log.write(json.dumps(record) + "\n")

    monitoring.register_event_duration_secs_listener(_listener)

    import logging

    class _CacheOutcome(logging.Handler):
        """The persistent cache's verdict on each compiled program (JAX's DEBUG lines): `hit` (read back),
        `callback` (not written: host callbacks, e.g. `eqx.error_if`, so compiled again in every run),
        `fast` (not written: compiled in less than the threshold), `written`."""

        def emit(self, record):
            msg = str(record.msg)
            if "cache hit" in msg:
                kind, seconds = "hit", 0.0
            elif "host callbacks" in msg:
                kind, seconds = "callback", 0.0
            elif "Not writing" in msg and "seconds to compile" in msg:
                kind, seconds = "fast", record.args[-1]
            elif msg.startswith("'%s' took at least"):
                kind, seconds = "written", record.args[-1]
            else:
                return
            out = {"kind": "cache-" + kind, "fun": str(record.args[0]), "s": seconds, "test": _current_test[0]}
            _log.write(json.dumps(out) + "\n")

    _compiler_log = logging.getLogger("jax._src.compiler")
    _compiler_log.setLevel(logging.DEBUG)
    _compiler_log.addHandler(_CacheOutcome(logging.DEBUG))


@pytest.hookimpl(wrapper=True)
def pytest_runtest_protocol(item, nextitem):
    _current_test[0] = item.nodeid
    try:
        return (yield)
    finally:
        _current_test[0] = "(between tests)"


@pytest.fixture(autouse=True, scope="module")
def _release_compiled_programs():
    """Drop every compiled program after each test file (`jax.clear_caches()`).

    Issue 41: a pytest-xdist worker died with a segmentation fault late in 2 of 2 full runs from an empty
    cache (2026-11-25), once inside XLA's compilation and once inside the cache write, both in a worker that
    had compiled the programs of dozens of files (the TX40 files); each file alone passes. Keeping only one
    file's programs alive bounds the compiled code a worker holds; a program another file needs again is
    read back from the persistent cache. `JAXSDP_TEST_KEEP_PROGRAMS=1` keeps them (measured in CONTRIBUTING:
    10 % less CPU at twice the memory).
    """
    yield
    if os.environ.get("JAXSDP_TEST_KEEP_PROGRAMS") != "1":
        jax.clear_caches()


# --------------------------------------------------------------------------- #
# Study runs shared by several test files (computed once per test process)
# --------------------------------------------------------------------------- #


@pytest.fixture(scope="session")
def emps_builtin():
    """`emps_builtin_data(0)`: the built-in EMPS record, its truth and description."""
    from jaxsdp.data import emps_builtin_data

    return emps_builtin_data(0)


@pytest.fixture(scope="session")
def emps_builtin_study(emps_builtin):
    """The EMPS study of the built-in record, without the decimation re-check."""
    from jaxsdp.studies.emps import emps_study

    return emps_study(emps_builtin[0], check_decimation=False)


@pytest.fixture(scope="session")
def emps_real_study():
    """The EMPS study of the real benchmark file with the defaults (tests using it carry `requires_emps`)."""
    from jaxsdp.studies.emps import emps_study

    return emps_study(EMPS_MAT)


@pytest.fixture(scope="session")
def emps_real_study_dec5():
    """The EMPS study of the real benchmark file at decimation 5 (mass flagged acceleration-dependent)."""
    from jaxsdp import Preprocessing
    from jaxsdp.studies.emps import emps_study

    return emps_study(EMPS_MAT, preprocessing=Preprocessing(decimate=5))


@pytest.fixture(scope="session")
def tx40_real_study():
    """The TX40 study of the real all-joints logs with the defaults (tests using it carry `requires_tx40`)."""
    import dataclasses

    from helpers import TX40_CURRENTS, TX40_POSITIONS
    from jaxsdp.data import load_joint_logs
    from jaxsdp.studies.tx40 import tx40_study

    logs = load_joint_logs(TX40_POSITIONS, TX40_CURRENTS, dt=2e-4, ratios=(32, 32, 45, -48, 45, 32))
    return tx40_study(dataclasses.replace(logs, source="real TX40 logs"))


# The files whose tests take longest (compilation mostly), started first so
# that pytest-xdist's workers do not end on a long tail; the rest keep their
# order. Order only: no test is skipped or changed.
SLOW_FIRST = (
    "test_notebooks.py",  # the twelve notebooks in one kernel
    "test_docs_site.py",  # the strict site build draws the guides' figures
    "test_parallel.py",
    "test_montecarlo_multihost.py",
    "test_docs.py",
    "test_montecarlo_identification.py",
    "test_robot_sim_ident.py",
    "test_control_study.py",
    "test_float64_everywhere.py",
)


def pytest_collection_modifyitems(items):
    rank = {name: i for i, name in enumerate(SLOW_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(SLOW_FIRST)))
