"""Runtime settings, in one place: float64 for every entry point, and the opt-out XLA-CPU fast-loop option.

**float64.** Public entry points are decorated with `x64`, which runs them
under `jax.enable_x64(True)`: every computation in jaxsdp is carried out in
float64 whatever the caller's global setting, and importing jaxsdp never
changes `jax.config` (only the command line, an entry point, sets it).

**Fast loops.** By default XLA-CPU compiles only *small* while-loops (a few operations per
iteration) into a single kernel; larger `lax.scan` bodies, such as a Kalman
smoother that stores per-step outputs, then cost ~1 us per step of runtime
overhead. The backend option `xla_cpu_small_while_loop_byte_threshold`
raises that limit. Measured with jaxlib 0.10.2 on the project's 2-core
machines (`benchmarks/numerics.py`, section 5) it now changes little: 1.3x for
a one-block IRW `dlr` of 25,000 samples, 1.0x for its `ml_nvr`, 1.1x for a
three-block `dlr` (earlier jaxlib releases and kernels gained up to ~14x).

On `import jaxsdp`, if JAX's CPU backend is not yet initialised, jaxsdp
*adds* `xla_cpu_small_while_loop_byte_threshold=1000000000` to the
`--xla_backend_extra_options` of the `XLA_FLAGS` environment variable:

- merged into an existing `--xla_backend_extra_options=...` list, never
  replacing anything the user set; if the user already set this option, it is
  left alone;
- skipped when `JAXSDP_FAST_LOOPS=0` (or `false`/`off`/`no`) is in the environment;
- skipped (with the reason reported by `jaxsdp.fast_loops_status()`) if JAX
  has already initialised its backends, since XLA reads the flags only once.

It is an internal XLA-CPU option that may change between jaxlib releases;
results are identical with or without it, only speed differs.
"""

import functools
import os
import re

import jax

OPTION = "xla_cpu_small_while_loop_byte_threshold"
VALUE = "1000000000"
_status = "not attempted"


def _disabled() -> bool:
    return os.environ.get("JAXSDP_FAST_LOOPS", "1").strip().lower() in ("0", "false", "off", "no")


def merge_flags(flags: str) -> str:
    """XLA_FLAGS with the fast-loop option added to --xla_backend_extra_options (idempotent)."""
    if OPTION in flags:
        return flags
    m = re.search(r"--xla_backend_extra_options=(\S*)", flags)
    if m is None:
        return (flags + " " if flags else "") + f"--xla_backend_extra_options={OPTION}={VALUE}"
    existing = m.group(1)
    merged = f"{existing},{OPTION}={VALUE}" if existing else f"{OPTION}={VALUE}"
    return flags[: m.start(1)] + merged + flags[m.end(1) :]


def enable_fast_loops() -> str:
    """Apply the fast path if possible; returns and records a status string."""
    global _status
    flags = os.environ.get("XLA_FLAGS", "")
    if _disabled():
        _status = "off (JAXSDP_FAST_LOOPS disables it)"
    elif OPTION in flags:
        _status = "as set in the user's XLA_FLAGS"
    elif _backends_initialised():
        _status = "off (JAX's backend was initialised before jaxsdp was imported; import jaxsdp first)"
    else:
        os.environ["XLA_FLAGS"] = merge_flags(flags)
        _status = "on (added to XLA_FLAGS by jaxsdp)"
    return _status


def _backends_initialised() -> bool:
    try:
        from jax._src import xla_bridge

        return bool(xla_bridge.backends_are_initialized())
    except (ImportError, AttributeError):  # pragma: no cover - future jax
        return False


def fast_loops_status() -> str:
    """Whether jaxsdp's XLA-CPU fast-loop option is active, and why, as one line of text.

    On `import jaxsdp` (before JAX starts its backend) jaxsdp adds
    `xla_cpu_small_while_loop_byte_threshold` to `--xla_backend_extra_options`
    in `XLA_FLAGS` so that the smoother scans compile into one loop kernel;
    it changes speed only, never results. `JAXSDP_FAST_LOOPS=0` opts out; if
    JAX ran before jaxsdp was imported the option cannot apply and this says so.

    Example:
        >>> import jaxsdp
        >>> isinstance(jaxsdp.fast_loops_status(), str)
        True
    """
    return _status


def x64(fn):
    """Run `fn` under `jax.enable_x64(True)` (the decorator of every public entry point)."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with jax.enable_x64(True):
            return fn(*args, **kwargs)

    return wrapper
