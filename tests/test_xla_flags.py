"""The XLA fast-loop option is merged into XLA_FLAGS without clobbering the user's flags; OpenBLAS's thread timeout is
set only where the user left it unset and SciPy's OpenBLAS is not loaded yet."""

import os
import subprocess
import sys

from hypothesis import given
from hypothesis import strategies as st

from jaxsdp._runtime import BLAS_ENV, BLAS_VALUE, OPTION, VALUE, merge_flags

token = st.from_regex(r"[a-z_]{1,12}=[0-9a-z]{1,6}", fullmatch=True)


@given(
    before=st.lists(st.from_regex(r"--xla_[a-z_]{1,12}=[0-9a-z]{1,4}", fullmatch=True), max_size=3),
    extras=st.lists(token, max_size=3),
    with_extras=st.booleans(),
)
def test_merge_keeps_user_flags_and_is_idempotent(before, extras, with_extras):
    parts = list(before)
    if with_extras:
        parts.append("--xla_backend_extra_options=" + ",".join(extras))
    flags = " ".join(parts)
    merged = merge_flags(flags)
    assert merge_flags(merged) == merged
    assert f"{OPTION}={VALUE}" in merged
    for p in before:
        assert p in merged
    for e in extras if with_extras else []:
        assert e in merged
    # one --xla_backend_extra_options flag at most (a second one would override the first)
    assert merged.count("--xla_backend_extra_options=") == 1


def test_user_setting_is_left_alone():
    flags = f"--xla_backend_extra_options={OPTION}=10"
    assert merge_flags(flags) == flags


def _status(env):
    """Status and XLA_FLAGS seen by a fresh interpreter importing jaxsdp with `env` added."""
    code = "import jaxsdp, os; print(jaxsdp.fast_loops_status()); print(os.environ.get('XLA_FLAGS', ''))"
    out = subprocess.run(
        [sys.executable, "-c", code], env={**os.environ, **env}, capture_output=True, text=True, check=True
    )
    return out.stdout.splitlines()


def test_opt_out_and_status():
    status, flags = _status({"JAXSDP_FAST_LOOPS": "0", "XLA_FLAGS": "--xla_cpu_foo=1"})
    assert status.startswith("off") and flags == "--xla_cpu_foo=1"
    status, flags = _status({"JAXSDP_FAST_LOOPS": "1", "XLA_FLAGS": "--xla_backend_extra_options=a=1"})
    assert status.startswith("on") and flags == f"--xla_backend_extra_options=a=1,{OPTION}={VALUE}"


def _blas(env, first=""):
    """(status, OPENBLAS_THREAD_TIMEOUT) in a fresh interpreter that runs `first`, then imports jaxsdp."""
    code = f"{first}import jaxsdp, os; print(jaxsdp.fast_loops_status()); print(os.environ.get('{BLAS_ENV}'))"
    env = {**{k: v for k, v in os.environ.items() if k != BLAS_ENV}, "JAXSDP_FAST_LOOPS": "1", **env}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return out.stdout.splitlines()


def test_openblas_threads_sleep_unless_the_user_decided_or_it_is_too_late():
    status, value = _blas({})
    assert value == BLAS_VALUE and "set by jaxsdp" in status
    status, value = _blas({BLAS_ENV: "12"})
    assert value == "12" and "as set in the user's" in status
    status, value = _blas({}, first="import scipy.linalg; ")  # SciPy's OpenBLAS loaded first: the variable is late
    assert value == "None" and "unchanged" in status
    status, value = _blas({"JAXSDP_FAST_LOOPS": "0"})
    assert value == "None" and "disables" in status
