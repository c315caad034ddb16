"""The Monte Carlo runner under `jax.distributed` (issue 27, item 5), for real on one machine.

The tests start 2 and 4 Python processes (tests/_multihost_worker.py) that
join a `jax.distributed` group on a localhost coordinator with the CPU
(gloo) collectives and each run `jaxsdp.monte_carlo` with the same
arguments: every process's copy of the results must be bit-identical to
the one-process run. Then one process fails inside the run (raises, or is
killed) while the others wait for it in a collective: they must exit with
an error within a bounded time, never hang. Leftover processes are always
killed.
"""

import os
import pathlib
import signal
import socket
import subprocess
import sys
import time
import types

import jax
import numpy as np
import pytest

import jaxsdp

TESTS = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(TESTS))
import _multihost_worker as worker  # noqa: E402

#: seconds: the longest a healthy group may take (start-up of P processes on 2 shared cores included)
RUN_TIMEOUT = 180
#: seconds: the longest any process may take to exit after one failed (the workers: heartbeat 5 s, shutdown 10 s)
FAIL_TIMEOUT = 60


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _launch(tmp_path, P, *, fail=None, devices=False, cpu_devices=1):
    """Start P worker processes; `fail` = (process id, "raise" | "kill"). Returns [(Popen, log path, out path)]."""
    coordinator = f"127.0.0.1:{_free_port()}"
    env = dict(os.environ, JAX_PLATFORMS="cpu", JAX_NUM_CPU_DEVICES=str(cpu_devices), PYTHONUNBUFFERED="1")
    env.pop("XLA_FLAGS", None)  # no forced host device count from the parent
    tmp_path.mkdir(parents=True, exist_ok=True)
    procs = []
    for i in range(P):
        out, log = tmp_path / f"p{i}.npz", tmp_path / f"p{i}.log"
        cmd = [sys.executable, str(TESTS / "_multihost_worker.py"), coordinator, str(P), str(i), str(out)]
        if fail is not None:
            cmd += ["--fail", fail[1] if fail[0] == i else "none"]
        if devices:
            cmd += ["--devices"]
        with open(log, "w") as f:
            procs.append((subprocess.Popen(cmd, env=env, stdout=f, stderr=subprocess.STDOUT), log, out))
    return procs


def _wait(procs, timeout):
    """Exit codes and exit times (`time.time()`) of every process, None where it still ran after `timeout` s."""
    t0 = time.monotonic()
    codes, times = [None] * len(procs), [None] * len(procs)
    while time.monotonic() - t0 < timeout and None in codes:
        for i, (p, _, _) in enumerate(procs):
            if codes[i] is None and p.poll() is not None:
                codes[i], times[i] = p.returncode, time.time()
        time.sleep(0.1)
    return codes, times


def _kill(procs):
    for p, _, _ in procs:
        if p.poll() is None:
            p.kill()
        p.wait()


def _logs(procs, tail=3000):
    return "\n".join(f"--- process {i}:\n{log.read_text()[-tail:]}" for i, (_, log, _) in enumerate(procs))


@pytest.fixture(scope="module")
def reference():
    with jax.enable_x64(True):
        return worker.run().values


def _equal(values, npz, prefix=""):
    return all(np.array_equal(v, npz[prefix + k]) and npz[prefix + k].dtype == v.dtype for k, v in values.items())


def test_processes_return_the_one_process_results_bit_for_bit(tmp_path, reference):
    # two groups at once: 4 processes with one CPU device each; 2 processes with two devices each,
    # which also run with `devices` a list spanning both and are refused a number of process 0's alone
    groups = {4: _launch(tmp_path / "four", 4), 2: _launch(tmp_path / "two", 2, devices=True, cpu_devices=2)}
    try:
        codes, _ = _wait([p for procs in groups.values() for p in procs], RUN_TIMEOUT)
    finally:
        for procs in groups.values():
            _kill(procs)
    assert codes[:4] == [0] * 4, f"4 processes: exit codes {codes[:4]}\n{_logs(groups[4])}"
    assert codes[4:] == [0] * 2, f"2 processes: exit codes {codes[4:]}\n{_logs(groups[2])}"
    assert reference["mean"].dtype == np.float64 and reference["head"].shape == (worker.N, 3)
    for P, procs in groups.items():
        for i, (_, _, out) in enumerate(procs):
            res, name = np.load(out), f"{P} processes, process {i}"
            assert int(res["devices"]) == 4, name
            assert int(res["chunk_size"]) == 64, name  # CHUNK: a multiple of 16 x 4 devices
            assert _equal(reference, res), f"{name}: differs from the one-process run"
            if P == 2:
                assert int(res["span_devices"]) == 2, name
                assert _equal(reference, res, "span_"), f"{name}, devices=[...]: differs from the one-process run"
                assert "every process must own at least one of `devices`" in str(res["refused"]), name


#: (failing process, how): a worker raises (it then waits for the others at exit: the shutdown timeout),
#: a worker is killed (the others see its heartbeats stop), the coordinator is killed (its service goes)
FAILURES = ((1, "raise"), (1, "kill"), (0, "kill"))


def test_a_failing_process_is_an_error_not_a_hang(tmp_path):
    # three groups of 2 processes at once; in each, one process fails in the third chunk's computation
    # while the other waits for it in the chunk's gather
    groups = [_launch(tmp_path / f"{how}{i}", 2, fail=(i, how)) for i, how in FAILURES]
    try:
        codes, times = _wait([p for procs in groups for p in procs], RUN_TIMEOUT)  # all at once: exit times
        ends = [(codes[2 * g : 2 * g + 2], times[2 * g : 2 * g + 2]) for g in range(len(groups))]
    finally:
        for procs in groups:
            _kill(procs)
    for (failing, how), procs, (codes, times) in zip(FAILURES, groups, ends):
        name = f"process {failing} {'raising' if how == 'raise' else 'killed'}"
        assert None not in codes, f"{name}: still running after {RUN_TIMEOUT} s, a hang\n{_logs(procs)}"
        mark = procs[failing][2].with_suffix(".npz.failed")
        assert mark.exists(), f"{name}: it did not reach its failure\n{_logs(procs)}"
        failed_at = float(mark.read_text())
        if how == "raise":
            assert "RuntimeError: process 1: deliberate failure within the run" in procs[failing][1].read_text()
        else:
            assert codes[failing] == -signal.SIGKILL
        for i, ((_, log, out), code, t) in enumerate(zip(procs, codes, times)):
            assert code != 0 and not out.exists(), f"{name}: process {i} exited normally\n{_logs(procs)}"
            # every process, the failing one included, exits soon after the failure
            print(f"{name}: process {i} exited (code {code}) {t - failed_at:.1f} s after the failure")
            assert t - failed_at < FAIL_TIMEOUT, f"{name}: process {i} exited {t - failed_at:.1f} s after it"
            if i != failing:  # with an error reported by jax's distributed service
                assert "JAX distributed service detected fatal errors" in log.read_text(), _logs(procs)


def test_runner_checks_a_multiprocess_mesh(monkeypatch):
    # the checks themselves, in one process posing as one of two
    monkeypatch.setattr(jax, "process_count", lambda: 2)
    f = lambda k: jax.random.normal(k)
    with pytest.raises(ValueError, match=r"processes \[1\] own none of"):
        jaxsdp.monte_carlo(f, 0, 4, devices=1, progress=False)
    two = [types.SimpleNamespace(process_index=0), types.SimpleNamespace(process_index=1)]
    old = jax.config.jax_cpu_collectives_implementation
    try:
        jax.config.update("jax_cpu_collectives_implementation", None)
        with pytest.raises(ValueError, match="jax_cpu_collectives_implementation"):
            jaxsdp.monte_carlo(f, 0, 4, devices=two, progress=False)
    finally:
        jax.config.update("jax_cpu_collectives_implementation", old)
