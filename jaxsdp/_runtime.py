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

import contextlib
import contextvars
import functools
import os
import re

import jax
import numpy as np

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
    """Run `fn` under `jax.enable_x64(True)` (the decorator of every public entry point).

    The results are float64. For a caller who has not enabled x64 itself,
    float64 JAX arrays would be a trap (its next JAX operation on them runs in
    float32, with a warning for each), so concrete results come back to it as
    NumPy arrays (float64 kept); inside `jit`, `vmap` or `grad` (traced
    results) and with x64 enabled, they stay JAX arrays.
    """

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        enabled = bool(jax.config.jax_enable_x64)  # the caller's setting (True inside another entry point)
        with jax.enable_x64(True):
            out = fn(*args, **kwargs)
        return out if enabled else _concrete_to_numpy(out)

    return wrapper


def _concrete_to_numpy(tree):
    leaves = jax.tree.leaves(tree)
    if any(isinstance(x, jax.core.Tracer) for x in leaves) or not any(isinstance(x, jax.Array) for x in leaves):
        return tree
    return jax.tree.map(lambda x: np.asarray(x) if isinstance(x, jax.Array) else x, tree)


# --------------------------------------------------------------------------- #
# Kernel method: sequential scans or parallel-in-time associative scans
# --------------------------------------------------------------------------- #

KERNEL_METHODS = ("auto", "sequential", "parallel")
#: Backends on which `method="auto"` picks the parallel-in-time kernels.
PARALLEL_BACKENDS = ("gpu", "cuda", "rocm", "tpu")
_method_setting = contextvars.ContextVar("jaxsdp_kernel_method", default="auto")


def _check_method(method) -> str:
    if method not in KERNEL_METHODS:
        raise ValueError(f"`method` must be one of {KERNEL_METHODS} (or None for the current setting); got {method!r}")
    return method


def _platform() -> str:
    dev = jax.config.jax_default_device
    if dev is not None:
        return dev if isinstance(dev, str) else dev.platform
    return jax.default_backend()


def resolve_method(method: str | None = None) -> str:
    """The kernel method that runs: "sequential" or "parallel".

    `method` None takes the current setting (`set_kernel_method`,
    `kernel_method`; "auto" unless changed). "auto" picks the parallel-in-time
    kernels on a GPU or TPU (the default device's platform) and the sequential
    ones on the CPU, where they are the faster (4-100x on 2 cores,
    `benchmarks/gpu.py`).

    Example:
        >>> import jaxsdp
        >>> jaxsdp.resolve_method("parallel"), jaxsdp.resolve_method("auto")  # on a CPU machine
        ('parallel', 'sequential')
    """
    m = _check_method(_method_setting.get() if method is None else method)
    if m == "auto":
        return "parallel" if _platform().lower() in PARALLEL_BACKENDS else "sequential"
    return m


def set_kernel_method(method: str) -> str:
    """Set the kernel method used when an entry point's `method` is None; returns the previous setting.

    One of "auto" (default: parallel-in-time on GPU/TPU, sequential on CPU),
    "sequential" (one `lax.scan` per pass) or "parallel" (associative
    scans, O(log N) depth). Results agree to rounding (1e-8 relative or
    better); only speed differs by device. Applies to `dlr`, `dlr_loglik`,
    `ml_nvr`, `sdp`, `multi_sdp`, `smooth_derivatives`, the zero-phase IIR
    filters (`filtfilt`, `decimate`, `butter_derivatives`) and the studies.
    `lfilter` (a causal filter, MATLAB's `filter`) has one form only.
    Within a thread or task, `kernel_method` sets it temporarily.

    Example:
        >>> import jaxsdp
        >>> old = jaxsdp.set_kernel_method("sequential")
        >>> jaxsdp.resolve_method()
        'sequential'
        >>> _ = jaxsdp.set_kernel_method(old)
    """
    old = _method_setting.get()
    _method_setting.set(_check_method(method))
    return old


@contextlib.contextmanager
def kernel_method(method: str):
    """Context manager: run the enclosed jaxsdp calls with this kernel method (see `set_kernel_method`).

    Example:
        >>> import numpy as np, jaxsdp
        >>> y = np.sin(np.linspace(0.0, 3.0, 300))
        >>> with jaxsdp.kernel_method("parallel"):
        ...     res = jaxsdp.dlr(y, np.ones((300, 1)), model="IRW", nvr=1e-5)
        >>> bool(res.definite)
        True
    """
    token = _method_setting.set(_check_method(method))
    try:
        yield
    finally:
        _method_setting.reset(token)


def method_scope(method: str | None):
    """`kernel_method(method)`, or no change when `method` is None (the studies' `method` option)."""
    return contextlib.nullcontext() if method is None else kernel_method(method)


def follows_method(fn):
    """Decorator of the studies: their keyword `method` sets the kernel method for the whole run."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with method_scope(kwargs.get("method")):
            return fn(*args, **kwargs)

    return wrapper
