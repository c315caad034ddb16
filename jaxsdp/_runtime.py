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
machine (`benchmarks/numerics.py`, section 5, 2026-11-26; an earlier
measurement of "little gain" had left the option on in both arms): 25x for a
one-block IRW `dlr` of 25,000 samples, 99x for its `ml_nvr`, 7x for a
three-block `dlr`.

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

**Idle BLAS threads.** XLA-CPU runs its LAPACK calls (QR, Cholesky, triangular
solves, SVD) through SciPy's OpenBLAS, whose worker threads keep spinning for
about 2^28 cycles after each call and so take the cores from XLA's own
threads in the operations that follow. On the same import, if SciPy's
OpenBLAS is not yet loaded and `OPENBLAS_THREAD_TIMEOUT` is not set, jaxsdp
sets it to 4 (the threads sleep at once; one thread instead would halve the
speed of a large QR). `benchmarks/robot_stacked.py` measures `idim_ls` on
the stacked TX40 regressor with and without it. The variable holds for the
whole process and its children: the user's own SciPy calls too, whose idle
threads then also sleep at once. Also skipped with `JAXSDP_FAST_LOOPS=0`,
and reported by `jaxsdp.fast_loops_status()`.
"""

import contextlib
import contextvars
import functools
import os
import re
import sys
import warnings

import jax
import numpy as np
from jax._src import core as _jax_core

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
    _status = f"{_status}; {quiet_blas_threads()}"
    return _status


BLAS_ENV = "OPENBLAS_THREAD_TIMEOUT"
BLAS_VALUE = "4"


def _scipy_blas_loaded() -> bool:
    """Whether the OpenBLAS that XLA-CPU's LAPACK calls use (SciPy's) may be loaded already: SciPy's LAPACK module
    imported, or any OpenBLAS mapped other than the one bundled with NumPy's wheel (a system or conda OpenBLAS
    that NumPy and SciPy share was loaded with NumPy)."""
    if "scipy.linalg.cython_lapack" in sys.modules:
        return True
    try:
        with open("/proc/self/maps") as f:
            return any("openblas" in line.lower() and "numpy.libs" not in line for line in f)
    except OSError:  # not Linux: the module check above is what there is
        return False


def quiet_blas_threads() -> str:
    """Set `OPENBLAS_THREAD_TIMEOUT` before SciPy's OpenBLAS loads (module docstring); returns a status line."""
    if _disabled():
        return "OpenBLAS thread timeout as configured (JAXSDP_FAST_LOOPS disables the change)"
    if BLAS_ENV in os.environ:
        return f"OpenBLAS thread timeout as set in the user's {BLAS_ENV}"
    if _scipy_blas_loaded():
        return "OpenBLAS thread timeout unchanged (SciPy's BLAS was loaded before jaxsdp was imported)"
    os.environ[BLAS_ENV] = BLAS_VALUE
    return f"{BLAS_ENV}={BLAS_VALUE} set by jaxsdp before SciPy's OpenBLAS loads (idle threads sleep at once)"


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
    it changes speed only, never results. It also sets `OPENBLAS_THREAD_TIMEOUT=4`
    (idle BLAS threads sleep instead of spinning) when SciPy's BLAS is not yet
    loaded. `JAXSDP_FAST_LOOPS=0` opts out of both; if JAX ran before jaxsdp was
    imported the option cannot apply and this says so.

    Example:
        >>> import jaxsdp
        >>> isinstance(jaxsdp.fast_loops_status(), str)
        True
    """
    return _status


X64_LINE = 'jax.config.update("jax_enable_x64", True)'


class Float64Error(TypeError):
    """A jaxsdp entry point was traced (`jax.jit`, `jax.grad`, `jax.vmap`, ...) with JAX's 64-bit mode off.

    jaxsdp computes in float64; a caller's trace with 64-bit mode off is a float32 trace, into which a
    float64 result cannot be returned. The fix is one line at the top of the notebook or script, before any
    array is created: `jax.config.update("jax_enable_x64", True)`.
    """


def _traced_call_refused(fn) -> Float64Error:
    name = getattr(fn, "__qualname__", getattr(fn, "__name__", "this function"))
    return Float64Error(
        f"jaxsdp computes in float64, but JAX's 64-bit mode is off: `{name}` was called inside jax.jit, "
        "jax.grad, jax.vmap or another transformation, whose float32 trace cannot receive float64 results. "
        f"Enable 64-bit mode once, at the top of the notebook or script, before creating arrays: {X64_LINE}"
    )


def _float32_inputs(args, kwargs) -> bool:
    return any(
        isinstance(x, jax.Array) and x.dtype in (np.float32, np.float16, np.complex64)
        for x in jax.tree.leaves((args, kwargs))
    )


def x64(fn):
    """Run `fn` under `jax.enable_x64(True)` (the decorator of every public entry point).

    The results are float64. For a caller who has not enabled x64 itself,
    float64 JAX arrays would be a trap (its next JAX operation on them runs in
    float32, with a warning for each), so concrete results come back to it as
    NumPy arrays (float64 kept); inside `jit`, `vmap` or `grad` (traced
    results) and with x64 enabled, they stay JAX arrays.

    With 64-bit mode off, a call from inside the caller's own transformation
    (any traced argument, or JAX's trace state not clean) raises
    `Float64Error` at trace time, naming the one line that enables 64-bit mode:
    a float32 trace cannot receive float64 results, and a silent float32
    answer is what jaxsdp never returns. Inputs that are float32 JAX arrays
    (made by JAX with 64-bit mode off) are computed on in float64 with a
    warning: the digits they lost cannot be restored.
    """

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        enabled = bool(jax.config.jax_enable_x64)  # the caller's setting (True inside another entry point)
        if not enabled:
            leaves = jax.tree.leaves((args, kwargs))
            if not trace_state_clean() or any(isinstance(x, jax.core.Tracer) for x in leaves):
                raise _traced_call_refused(fn)
            if _float32_inputs(args, kwargs):
                warnings.warn(
                    f"`{getattr(fn, '__qualname__', fn)}` received float32 JAX arrays (JAX's 64-bit mode is off): "
                    "jaxsdp computes in float64 but cannot restore the digits lost. Pass NumPy arrays, or enable "
                    f"64-bit mode at the top of the notebook: {X64_LINE}",
                    Float64Warning,
                    stacklevel=2,
                )
        with jax.enable_x64(True):
            out = fn(*args, **kwargs)
        return out if enabled else _concrete_to_numpy(out)

    wrapper.__jaxsdp_x64__ = True
    return wrapper


def trace_state_clean() -> bool:
    clean = getattr(_jax_core, "trace_state_clean", None)
    return True if clean is None else bool(clean())  # pragma: no branch - JAX 0.8-0.10 have it


class Float64Warning(UserWarning):
    """float32 inputs reached a float64 jaxsdp entry point (JAX's 64-bit mode was off when they were made).

    jaxsdp computes on them in float64, but the digits they lost when `jax.numpy` made them in float32
    (about 7 significant digits) cannot be restored. Pass NumPy arrays, or enable 64-bit mode at the top of
    the notebook: `jax.config.update("jax_enable_x64", True)`.
    """


def is_x64(fn) -> bool:
    """Whether `fn` (a function, or a classmethod/staticmethod/property) runs under the `x64` decorator."""
    if isinstance(fn, (classmethod, staticmethod)):
        fn = fn.__func__
    if isinstance(fn, property):
        fn = fn.fget
    while fn is not None:
        if getattr(fn, "__jaxsdp_x64__", False):
            return True
        fn = getattr(fn, "__wrapped__", None)
    return False


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
