"""Benchmark: jaxsdp's Kalman filter + fixed-interval smoother against the per-core limit and dynamax.

Model: an integrated random walk (IRW) for one parameter, y_k = theta_k + e_k,
i.e. `jaxsdp.dlr(y, z, model="IRW", nvr=NVR)` with z = ones((N, 1)): state
[theta, slope], F = [[1, 1], [0, 1]], Q = diag(0, NVR), observation variance 1
(concentrated out), x0 = 0, P0 = 1e5 * I. The data are a sinusoid plus white
noise (no missing samples).

Cases: one series of N = 25,000 and of N = 250,000, and a `jax.vmap` batch of
1,000 series of 25,000 (`--quick`: a tenth of each length and 20 series;
`--batch B` sets the number of series, 0 skips the batch).

For each case, measured in the same process:

- jaxsdp: `jax.jit` of the public call `dlr(...)` (vmapped for the batch),
  returning what the numba loop computes (the smoothed parameter, its
  standard error, sigma2 and the log-likelihood); then again returning every
  field of `DLRResult` (filtered and smoothed states and their SEs, fit,
  residuals, innovations and their variances), which is mostly memory
  traffic: twelve arrays of N values per series.
  Compile time is the `.lower(...).compile()` time; run time is the median
  wall time of the compiled function (outputs blocked on) after one untimed
  call. jaxsdp and the two numba loops run in turn, one call each per round,
  up to 51 rounds or until the calls add up to 10 s (2 s with --quick), so
  that the load of these shared machines (it drifts by tens of percent)
  falls on all of them alike; the minimum is printed beside the median. The
  full result and dynamax are timed the same way on their own. Page faults
  and system time per call are printed too: XLA allocates its buffers afresh
  on every call, and on these machines faulting in a fresh 200 MB buffer
  costs about 0.1 s (`--keep-freed-memory` re-runs the script with glibc
  keeping freed memory, which removes that cost).
- numba, same recursions: a scalar loop specialised to the IRW model with
  jaxsdp's closed-form recursions (`jaxsdp/_kalman/closed_form.py`): predict,
  standard update, smoother gain by an LDL^T solve of P_{k+1|k}, smoothed
  covariance by the Joseph-like form; also sigma2, the standard errors and
  the concentrated log-likelihood with CAPTAIN's burn-in conventions, as
  `jaxsdp/_kalman/dlr.py`. This is the per-core limit for the same computation.
- numba, textbook RTS: the same with the cheapest covariance recursion,
  P_{k|N} = P_{k|k} + G (P_{k+1|N} - P_{k+1|k}) G^T (less work per step;
  jaxsdp keeps the Joseph-like form, a sum of two positive semi-definite
  terms, for robustness). The batch loops over the series on one core.
- dynamax: `lgssm_smoother` (sequential RTS) with H = [1, 0], R = 1 and the
  same F, Q. dynamax's initial distribution is for the first observed
  state, so it gets mean F x0 and covariance F P0 F^T + Q (jaxsdp predicts
  from time 0 before its first update). dynamax's `psd_solve` adds 1e-9 * I
  before every Cholesky factorisation; the agreement of its smoothed means is
  also checked (untimed) with that boost set to 0.

The batch (1,000 series sharing the regressor and NVR, none with missing
samples) runs `dlr`'s shared-covariance batching rule: the covariances and
gains are computed once and only the mean recursions run over the batch
(see `jaxsdp/_kalman/dlr_block.py`).

Finally the concentrated log-likelihood (`jaxsdp.dlr_loglik`, the filter
alone) and its derivative w.r.t. log10 NVR at N = 25,000, forward
(`jax.jvp`) and reverse (`jax.grad`) mode, checked against central
differences of `dlr(...).loglik`.

Agreement is max|a - b| / max|b| with b from jaxsdp; the numba loops should
agree to ~1e-8. Before each jax run, XLA's own memory analysis of the compiled
function (arguments + outputs + temporaries) is compared with the memory
available; a case that would not fit is skipped and says so.

By default jaxsdp runs with its XLA-CPU fast-loop option
(`xla_cpu_small_while_loop_byte_threshold`, see `jaxsdp._runtime`), which
lets larger `lax.scan` bodies compile into a single kernel; `--no-fast-loops`
runs with default XLA-CPU settings. Run both to compare.

    python benchmarks/smoother.py [--quick] [--batch B] [--no-fast-loops] [--keep-freed-memory] [--json PATH]

`--json PATH` also writes every case as a row (key `one-series`,
`long-series`, `batch`, `loglik-jvp`, `loglik-grad`: seconds per call, minima,
page faults, agreements) with the machine and the date (`benchmarks/_record.py`).
"""

import argparse
import functools
import os
import pathlib
import platform
import resource
import statistics
import sys
import time
from dataclasses import dataclass, field

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from _allocator import MALLOC_KEEP, rerun_with  # noqa: E402

KEPT = rerun_with(sys.argv[1:])  # `--keep-freed-memory` (`_allocator`)


def _select_fast_loops(argv) -> None:
    """`--no-fast-loops` turns off jaxsdp's XLA-CPU fast-loop option (jaxsdp._runtime).

    jaxsdp adds the option on import by default; `JAXSDP_FAST_LOOPS=0` (set
    here before jaxsdp is imported) is the documented way to opt out.
    """
    if "--no-fast-loops" in argv:
        os.environ["JAXSDP_FAST_LOOPS"] = "0"


_select_fast_loops(sys.argv[1:])

# jaxsdp first: it sets XLA_FLAGS (unless opted out) before jax starts its backend.
import jaxsdp  # isort: skip
import jax
import jax.numpy as jnp
import numba
import numpy as np
from _record import Recorder

jax.config.update("jax_enable_x64", True)

try:
    import dynamax
    import dynamax.linear_gaussian_ssm.inference as dynamax_inference
    from dynamax.linear_gaussian_ssm import (
        ParamsLGSSM,
        ParamsLGSSMDynamics,
        ParamsLGSSMEmissions,
        ParamsLGSSMInitial,
        lgssm_smoother,
    )

    DYNAMAX_ERROR = None
except Exception as err:  # noqa: BLE001  (any import failure makes dynamax unavailable)
    DYNAMAX_ERROR = f"{type(err).__name__}: {err}"

NVR = 1e-5
P0 = 1e5
IRW_F = np.array([[1.0, 1.0], [0.0, 1.0]])
IRW_Q = np.diag([0.0, NVR])
GB = 1e9


# --------------------------------------------------------------------------- numba
@numba.njit(inline="always")
def _irw_filter(y, nvr, p0):
    """IRW Kalman filter (standard update, as jaxsdp/_kalman/closed_form.py); filtered moments, likelihood sums."""
    N = y.shape[0]
    x1s, x2s = np.empty(N), np.empty(N)
    P11s, P12s, P22s = np.empty(N), np.empty(N), np.empty(N)
    x1 = x2 = 0.0
    P11, P12, P22 = p0, 0.0, p0
    slogf = se2_lik = se2_sig = 0.0
    for k in range(N):
        # predict: F s, F P F^T + Q
        x1 = x1 + x2
        P11, P12, P22 = P11 + 2.0 * P12 + P22, P12 + P22, P22 + nvr
        # update with h = [1, 0]: f = 1 + P11, K = P h / f
        f = 1.0 + P11
        r = 1.0 / f
        v = y[k] - x1
        vr = v * r
        x1, x2 = x1 + P11 * vr, x2 + P12 * vr
        P22 = max(P22 - P12 * P12 * r, 0.0)
        P11, P12 = P11 * r, P12 * r
        x1s[k], x2s[k] = x1, x2
        P11s[k], P12s[k], P22s[k] = P11, P12, P22
        e2 = v * vr
        if k >= 2:  # sigma2 burn-in = dim(s)
            se2_sig += e2
        if k >= 3:  # likelihood burn-in = dim(s) + 1
            se2_lik += e2
            slogf += np.log(f)
    n_lik = N - 3
    sigma2 = se2_sig / (N - 2)
    loglik = -0.5 * (slogf + n_lik * np.log(se2_lik / n_lik)) - 0.5 * n_lik * (np.log(2.0 * np.pi) + 1.0)
    return x1s, x2s, P11s, P12s, P22s, sigma2, loglik


@numba.njit
def irw_smoother_numba(y, nvr, p0):
    """IRW filter + RTS smoother with jaxsdp's closed-form recursions, as a scalar loop.

    y_k = theta_k + e_k, F = [[1, 1], [0, 1]], Q = diag(0, nvr), x0 = 0,
    P0 = p0 * I. The smoother gain comes from an LDL^T solve of
    A = P_{k+1|k} and the smoothed covariance from the Joseph-like form
    (I - G F) P_{k|k} (I - G F)^T + G (Q + P_{k+1|N}) G^T, as in
    jaxsdp/_kalman/closed_form.py. Returns (par, parse, sigma2, loglik) as
    `jaxsdp.dlr` defines them.
    """
    N = y.shape[0]
    xf1, xf2, Pf11, Pf12, Pf22, sigma2, loglik = _irw_filter(y, nvr, p0)
    par, parse = np.empty(N), np.empty(N)
    # start one step beyond the data: x_{N+1|N}, P_{N+1|N}
    s1, s2 = xf1[N - 1] + xf2[N - 1], xf2[N - 1]
    S11 = Pf11[N - 1] + 2.0 * Pf12[N - 1] + Pf22[N - 1]
    S12, S22 = Pf12[N - 1] + Pf22[N - 1], Pf22[N - 1] + nvr
    for k in range(N - 1, -1, -1):
        P11, P12, P22, x1, x2 = Pf11[k], Pf12[k], Pf22[k], xf1[k], xf2[k]
        B11, B12, B21, B22 = P11 + P12, P12 + P22, P12, P22  # B = F P
        A11, A12, A22 = B11 + B12, B12, B22 + nvr  # A = B F^T + Q
        d1 = 1.0 / A11
        rdet = 1.0 / max(A11 * A22 - A12 * A12, 1e-300)
        G12 = (A11 * B21 - A12 * B11) * rdet
        G22 = (A11 * B22 - A12 * B12) * rdet
        G11, G21 = (B11 - A12 * G12) * d1, (B12 - A12 * G22) * d1
        e1, e2 = s1 - (x1 + x2), s2 - x2
        s1, s2 = x1 + G11 * e1 + G12 * e2, x2 + G21 * e1 + G22 * e2
        M11, M12, M21, M22 = 1.0 - G11, -(G11 + G12), -G21, 1.0 - (G21 + G22)  # I - G F
        t11, t12 = M11 * P11 + M12 * P12, M11 * P12 + M12 * P22
        t21, t22 = M21 * P11 + M22 * P12, M21 * P12 + M22 * P22
        R11, R12, R22 = S11, S12, S22 + nvr
        u11, u12 = G11 * R11 + G12 * R12, G11 * R12 + G12 * R22
        u21, u22 = G21 * R11 + G22 * R12, G21 * R12 + G22 * R22
        S11 = t11 * M11 + t12 * M12 + u11 * G11 + u12 * G12
        S12 = t11 * M21 + t12 * M22 + u11 * G21 + u12 * G22
        S22 = t21 * M21 + t22 * M22 + u21 * G21 + u22 * G22
        par[k], parse[k] = s1, np.sqrt(sigma2 * max(S11, 0.0))
    return par, parse, sigma2, loglik


@numba.njit
def irw_smoother_numba_rts(y, nvr, p0):
    """As `irw_smoother_numba` with the cheapest covariance recursion, the textbook RTS form.

    P_{k|N} = P_{k|k} + G (P_{k+1|N} - P_{k+1|k}) G^T and G by the 2x2
    adjugate: about a third less work per step than the Joseph-like form,
    which jaxsdp keeps because its two terms are positive semi-definite
    whatever the rounding.
    """
    N = y.shape[0]
    xf1, xf2, Pf11, Pf12, Pf22, sigma2, loglik = _irw_filter(y, nvr, p0)
    par, parse = np.empty(N), np.empty(N)
    s1, s2 = xf1[N - 1], xf2[N - 1]
    S11, S12, S22 = Pf11[N - 1], Pf12[N - 1], Pf22[N - 1]
    par[N - 1], parse[N - 1] = s1, np.sqrt(sigma2 * max(S11, 0.0))
    for k in range(N - 2, -1, -1):
        P11, P12, P22, x1, x2 = Pf11[k], Pf12[k], Pf22[k], xf1[k], xf2[k]
        B11, B12, B21, B22 = P11 + P12, P12 + P22, P12, P22
        A11, A12, A22 = B11 + B12, B12, B22 + nvr
        rdet = 1.0 / (A11 * A22 - A12 * A12)
        G11, G12 = (B11 * A22 - B21 * A12) * rdet, (B21 * A11 - B11 * A12) * rdet
        G21, G22 = (B12 * A22 - B22 * A12) * rdet, (B22 * A11 - B12 * A12) * rdet
        e1, e2 = s1 - (x1 + x2), s2 - x2
        s1, s2 = x1 + G11 * e1 + G12 * e2, x2 + G21 * e1 + G22 * e2
        D11, D12, D22 = S11 - A11, S12 - A12, S22 - A22
        t11, t12 = G11 * D11 + G12 * D12, G11 * D12 + G12 * D22
        t21, t22 = G21 * D11 + G22 * D12, G21 * D12 + G22 * D22
        S11 = P11 + t11 * G11 + t12 * G12
        S12 = P12 + t11 * G21 + t12 * G22
        S22 = P22 + t21 * G21 + t22 * G22
        par[k], parse[k] = s1, np.sqrt(sigma2 * max(S11, 0.0))
    return par, parse, sigma2, loglik


def _numba_batch(kernel):
    @numba.njit
    def batch(Y, nvr, p0):
        """`kernel` over the rows of Y (B, N), one after another on one core."""
        B, N = Y.shape
        par, parse = np.empty((B, N)), np.empty((B, N))
        sigma2, loglik = np.empty(B), np.empty(B)
        for b in range(B):
            par[b], parse[b], sigma2[b], loglik[b] = kernel(Y[b], nvr, p0)
        return par, parse, sigma2, loglik

    return batch


irw_smoother_numba_batch = _numba_batch(irw_smoother_numba)
irw_smoother_numba_rts_batch = _numba_batch(irw_smoother_numba_rts)


# --------------------------------------------------------------------------- jax sides
def jaxsdp_full(y, z):
    """Every field of `DLRResult` (filtered and smoothed states, SEs, fit, innovations, ...)."""
    return jaxsdp.dlr(y, z, model="IRW", nvr=NVR, P0=P0)


def jaxsdp_single(y, z):
    """What the numba loop computes: smoothed parameter, its standard error, sigma2, loglik."""
    r = jaxsdp_full(y, z)
    return r.par, r.parse, r.sigma2, r.loglik


jaxsdp_batch = jax.vmap(jaxsdp_single, in_axes=(0, None))
jaxsdp_full_batch = jax.vmap(jaxsdp_full, in_axes=(0, None))


def loglik_value_and_grad(y, z, log10_nvr, *, forward: bool):
    """Concentrated log-likelihood (`dlr_loglik`) and its derivative w.r.t. log10 NVR (jvp or grad)."""
    f = lambda b: jaxsdp.dlr_loglik(y, z, model="IRW", nvr=10.0**b, P0=P0).loglik
    if forward:
        return jax.jvp(f, (log10_nvr,), (jnp.ones_like(log10_nvr),))
    return jax.value_and_grad(f)(log10_nvr)


def dynamax_params():
    """dynamax parameters equal to jaxsdp's IRW model (initial distribution at time 1)."""
    F, Q = jnp.asarray(IRW_F), jnp.asarray(IRW_Q)
    x0, P0m = jnp.zeros(2), P0 * jnp.eye(2)
    return ParamsLGSSM(
        initial=ParamsLGSSMInitial(mean=F @ x0, cov=F @ P0m @ F.T + Q),
        dynamics=ParamsLGSSMDynamics(weights=F, bias=jnp.zeros(2), input_weights=jnp.zeros((2, 0)), cov=Q),
        emissions=ParamsLGSSMEmissions(
            weights=jnp.array([[1.0, 0.0]]), bias=jnp.zeros(1), input_weights=jnp.zeros((1, 0)), cov=jnp.eye(1)
        ),
    )


def dynamax_single(y):
    return lgssm_smoother(dynamax_params(), y[:, None])


dynamax_batch = jax.vmap(dynamax_single)


def dynamax_unboosted_means(fn, *args):
    """Smoothed means from `fn` traced with dynamax's psd_solve diagonal boost (1e-9 I) set to 0."""
    shipped = dynamax_inference.psd_solve
    dynamax_inference.psd_solve = functools.partial(shipped, diagonal_boost=0.0)
    try:
        return jax.jit(lambda *a: fn(*a).smoothed_means)(*args)
    finally:
        dynamax_inference.psd_solve = shipped


# --------------------------------------------------------------------------- measurement
def mem_available() -> float:
    """MemAvailable from /proc/meminfo, in bytes."""
    with open("/proc/meminfo") as fh:
        for line in fh:
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024.0
    raise RuntimeError("MemAvailable not found in /proc/meminfo")


def peak_rss() -> float:
    """Peak resident set size of this process so far, in bytes (Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0


@dataclass
class Timing:
    median: float  # seconds per call
    minimum: float
    reps: int
    faults: float  # minor page faults per call
    system: float  # system time per call, seconds
    out: object = None  # last output

    def note(self) -> str:
        return (
            f"median of {self.reps}, min {fmt_time(self.minimum)}; "
            f"{self.faults:,.0f} page faults, {self.system * 1e3:.3g} ms system time per call"
        )


def run_interleaved(fns: dict, *, budget: float, max_rounds: int = 51) -> dict:
    """Time several functions in turn, round after round, so that they share the machine's load.

    `fns` maps a label to (fn, args). One untimed call of each first, then
    rounds of one timed call each (outputs blocked on) until `max_rounds`
    rounds or until all calls add up to `budget` seconds. Returns label ->
    `Timing`. On these shared machines the load drifts by tens of percent
    over seconds; interleaving keeps the ratios between the functions honest.
    """
    outs = {k: jax.block_until_ready(fn(*args)) for k, (fn, args) in fns.items()}
    times = {k: [] for k in fns}
    faults = dict.fromkeys(fns, 0.0)
    system = dict.fromkeys(fns, 0.0)
    total = 0.0
    for _ in range(max_rounds):
        for k, (fn, args) in fns.items():
            outs[k] = None
            r0 = resource.getrusage(resource.RUSAGE_SELF)
            t0 = time.perf_counter()
            outs[k] = jax.block_until_ready(fn(*args))
            dt = time.perf_counter() - t0
            r1 = resource.getrusage(resource.RUSAGE_SELF)
            times[k].append(dt)
            faults[k] += r1.ru_minflt - r0.ru_minflt
            system[k] += r1.ru_stime - r0.ru_stime
            total += dt
        if total >= budget:
            break
    return {
        k: Timing(statistics.median(v), min(v), len(v), faults[k] / len(v), system[k] / len(v), outs[k])
        for k, v in times.items()
    }


def compile_checked(fn, *args, label: str):
    """(compiled fn, compile seconds) or (None, reason) if XLA's buffers would not fit in memory."""
    t0 = time.perf_counter()
    compiled = jax.jit(fn).lower(*args).compile()
    seconds = time.perf_counter() - t0
    mem = compiled.memory_analysis()
    need = mem.argument_size_in_bytes + mem.output_size_in_bytes + mem.temp_size_in_bytes
    avail = mem_available()
    print(
        f"    {label}: compile {seconds:.2f} s; XLA buffers {need / GB:.2f} GB "
        f"(args {mem.argument_size_in_bytes / GB:.2f}, outputs {mem.output_size_in_bytes / GB:.2f}, "
        f"temporaries {mem.temp_size_in_bytes / GB:.2f}); {avail / GB:.1f} GB available"
    )
    if need > 0.8 * avail:
        return None, f"needs {need / GB:.1f} GB, {avail / GB:.1f} GB available"
    return compiled, seconds


def rel_diff(a, b) -> float:
    a, b = np.asarray(a), np.asarray(b)
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def add_with_ms(rec: Recorder, **fields):
    """`rec.add(**fields)`, every `NAME_s` figure also as `NAME_ms` and `seconds` as `ms` (milliseconds, as the
    docs quote them)."""
    ms = {
        ("ms" if k == "seconds" else k[:-2] + "_ms"): 1e3 * v
        for k, v in fields.items()
        if (k == "seconds" or k.endswith("_s")) and isinstance(v, float)
    }
    rec.add(**fields, **ms)


@dataclass
class Row:
    case: str
    jax_run: float | None = None
    jax_full: float | None = None
    jax_compile: float | None = None
    numba: float | None = None
    numba_rts: float | None = None
    dynamax: float | None = None
    agreement: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)
    extra: dict = field(default_factory=dict)  # minima, page faults, system time: for the JSON only

    def record(self, rec: Recorder, key: str, **fields):
        """This case as one row of `rec` (seconds per call; agreement figures as `agree_...`)."""
        agree = {
            "agree_" + k.lower().replace(" vs ", "_").replace(", ", "_").replace(" ", "_"): v
            for k, v in self.agreement.items()
        }
        add_with_ms(
            rec,
            key=key,
            case=self.case,
            jaxsdp_s=self.jax_run,
            jaxsdp_full_s=self.jax_full,
            jaxsdp_compile_s=self.jax_compile,
            numba_s=self.numba,
            numba_rts_s=self.numba_rts,
            dynamax_s=self.dynamax,
            ratio_numba=None if None in (self.jax_run, self.numba) else self.jax_run / self.numba,
            **self.extra,
            **agree,
            notes="; ".join(self.notes) or None,
            **fields,
        )


def signal(rng, B: int, N: int):
    """B series of N samples: sinusoids (random phase) plus N(0, 0.1^2) noise."""
    t = np.arange(N)
    phase = rng.uniform(0, 2 * np.pi, size=(B, 1))
    return np.sin(2 * np.pi * t / 5000.0 + phase) + 0.1 * rng.standard_normal((B, N))


def bench_case(label: str, Y, *, budget: float, unboosted_check: bool) -> Row:
    """Measure one case; Y is (N,) for a single series or (B, N) for a batch."""
    print(f"\n== {label}")
    row = Row(label)
    batch = Y.ndim == 2
    N = Y.shape[-1]
    y, z = jnp.asarray(Y), jnp.ones((N, 1))

    compiled, info = compile_checked(jaxsdp_batch if batch else jaxsdp_single, y, z, label="jaxsdp")
    if compiled is None:
        row.notes.append(f"jaxsdp skipped: {info}")
        print(f"    jaxsdp skipped: {info}")
        return row
    row.jax_compile = info
    # jaxsdp and both numba loops in turn (see run_interleaved)
    numba_fns = (
        (irw_smoother_numba_batch, irw_smoother_numba_rts_batch)
        if batch
        else (irw_smoother_numba, irw_smoother_numba_rts)
    )
    t = run_interleaved(
        {
            "jaxsdp (par, parse, sigma2, loglik)": (compiled, (y, z)),
            "numba, same recursions": (numba_fns[0], (Y, NVR, P0)),
            "numba, textbook RTS covariance": (numba_fns[1], (Y, NVR, P0)),
        },
        budget=budget,
    )
    for k, v in t.items():
        print(f"    {k}: {fmt_time(v.median)} ({v.note()})")
    jx, nb, nb_rts = t.values()
    row.jax_run, row.numba, row.numba_rts = jx.median, nb.median, nb_rts.median
    row.extra.update(
        jaxsdp_min_s=jx.minimum,
        jaxsdp_reps=jx.reps,
        jaxsdp_page_faults=jx.faults,
        jaxsdp_system_s=jx.system,
        numba_min_s=nb.minimum,
        numba_rts_min_s=nb_rts.minimum,
    )
    par, parse, sigma2, loglik = jx.out
    par, parse = np.asarray(par[..., 0]), np.asarray(parse[..., 0])
    loglik, sigma2 = np.asarray(loglik), np.asarray(sigma2)
    nb_par, nb_parse, nb_sigma2, nb_loglik = nb.out
    row.agreement["par vs numba"] = rel_diff(nb_par, par)
    row.agreement["se vs numba"] = rel_diff(nb_parse, parse)
    row.agreement["loglik vs numba"] = rel_diff(nb_loglik, loglik)
    row.agreement["sigma2 vs numba"] = rel_diff(nb_sigma2, sigma2)
    row.agreement["se vs numba RTS"] = rel_diff(nb_rts.out[1], parse)
    del t, jx, nb, nb_rts, nb_par, nb_parse, compiled

    compiled, info = compile_checked(jaxsdp_full_batch if batch else jaxsdp_full, y, z, label="jaxsdp, full DLRResult")
    if compiled is None:
        row.notes.append(f"jaxsdp full result skipped: {info}")
    else:
        (full,) = run_interleaved({"full": (compiled, (y, z))}, budget=budget).values()
        row.jax_full = full.median
        row.extra.update(jaxsdp_full_min_s=full.minimum, jaxsdp_full_system_s=full.system)
        print(f"    jaxsdp (every DLRResult field): {fmt_time(full.median)} ({full.note()})")
        row.agreement["full vs 4 fields"] = rel_diff(full.out.par[..., 0], par)
        del full, compiled

    if DYNAMAX_ERROR is None:
        dyn_fn = dynamax_batch if batch else dynamax_single
        dcompiled, dinfo = compile_checked(dyn_fn, y, label="dynamax")
        if dcompiled is None:
            row.notes.append(f"dynamax skipped: {dinfo}")
            print(f"    dynamax skipped: {dinfo}")
        else:
            (dyn,) = run_interleaved({"dynamax": (dcompiled, (y,))}, budget=budget).values()
            row.dynamax = dyn.median
            row.extra.update(dynamax_min_s=dyn.minimum)
            print(f"    dynamax: {fmt_time(dyn.median)} ({dyn.note()})")
            row.agreement["mean vs dynamax"] = rel_diff(dyn.out.smoothed_means[..., 0], par)
            del dyn, dcompiled
            if unboosted_check:
                exact = dynamax_unboosted_means(dyn_fn, y)[..., 0]
                row.agreement["mean vs dynamax, boost 0"] = rel_diff(exact, par)
    print(f"    peak RSS so far {peak_rss() / GB:.2f} GB")
    return row


def likelihood_case(y, *, budget: float, rec: Recorder) -> str:
    """Log-likelihood and its derivative w.r.t. log10 NVR (forward and reverse mode), checked by differences."""
    N = y.shape[0]
    print(f"\n== log-likelihood + derivative w.r.t. log10 NVR, 1 x {N:,}")
    y, z, b = jnp.asarray(y), jnp.ones((N, 1)), jnp.asarray(np.log10(NVR))
    out = []
    for forward in (True, False):
        fn = jax.jit(functools.partial(loglik_value_and_grad, forward=forward))
        t0 = time.perf_counter()
        fn = fn.lower(y, z, b).compile()
        comp = time.perf_counter() - t0
        (tm,) = run_interleaved({"lik": (fn, (y, z, b))}, budget=budget).values()
        _, der = tm.out
        h = 1e-4
        f = jax.jit(lambda bb: jaxsdp.dlr(y, z, model="IRW", nvr=10.0**bb, P0=P0).loglik)
        fd = (f(b + h) - f(b - h)) / (2 * h)
        mode = "forward (jvp)" if forward else "reverse (grad)"
        line = (
            f"{mode}: {fmt_time(tm.median)} ({tm.note()}; compile {comp:.2f} s); "
            f"derivative {float(der):.6g}, central difference {float(fd):.6g}"
        )
        print("    " + line)
        out.append(line)
        add_with_ms(
            rec,
            key="loglik-jvp" if forward else "loglik-grad",
            samples=N,
            seconds=tm.median,
            min_s=tm.minimum,
            compile_s=comp,
            derivative=float(der),
            central_difference=float(fd),
        )
    return f"log-likelihood + derivative w.r.t. log10 NVR, 1 x {N:,}:\n" + "\n".join("- " + o for o in out)


def fmt_time(t):
    if t is None:
        return "n/a"
    return f"{t * 1e3:.3g} ms" if t < 1.0 else f"{t:.3g} s"


def fmt_ratio(a, b):
    return "n/a" if a is None or b is None else f"{a / b:.3g}"


def print_tables(rows):
    head = [
        "case",
        "jaxsdp run",
        "jaxsdp, full DLRResult",
        "jaxsdp compile",
        "numba, same recursions",
        "numba, textbook RTS",
        "dynamax",
        "jaxsdp/numba",
        "jaxsdp/numba RTS",
        "jaxsdp/dynamax",
    ]
    body = [
        [
            r.case,
            fmt_time(r.jax_run),
            fmt_time(r.jax_full),
            fmt_time(r.jax_compile),
            fmt_time(r.numba),
            fmt_time(r.numba_rts),
            fmt_time(r.dynamax),
            fmt_ratio(r.jax_run, r.numba),
            fmt_ratio(r.jax_run, r.numba_rts),
            fmt_ratio(r.jax_run, r.dynamax),
        ]
        for r in rows
    ]
    print_markdown(head, body)
    keys = list(dict.fromkeys(k for r in rows for k in r.agreement))
    print("\nAgreement with jaxsdp, max|a - b| / max|b| (numba should be ~1e-8 or better):")
    print_markdown(
        ["case", *keys],
        [[r.case, *(f"{r.agreement[k]:.1e}" if k in r.agreement else "n/a" for k in keys)] for r in rows],
    )
    for r in rows:
        for note in r.notes:
            print(f"note ({r.case}): {note}")


def print_markdown(head, body):
    widths = [max(len(str(x)) for x in col) for col in zip(head, *body)]

    def line(cells):
        return "| " + " | ".join(str(c).ljust(w) for c, w in zip(cells, widths)) + " |"

    print(line(head))
    print("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    for cells in body:
        print(line(cells))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    parser.add_argument("--quick", action="store_true", help="lengths / 10 and a batch of 20: a smoke run")
    parser.add_argument(
        "--batch", type=int, default=None, help="series in the vmap batch (default 1000, 20 with --quick; 0 skips)"
    )
    parser.add_argument(
        "--keep-freed-memory",
        action="store_true",
        help="re-run with MALLOC_MMAP_MAX_=0 MALLOC_TRIM_THRESHOLD_=1e11 (glibc keeps freed memory: no page faults)",
    )
    parser.add_argument(
        "--no-fast-loops",
        action="store_true",
        help="run with default XLA-CPU loop settings (JAXSDP_FAST_LOOPS=0) instead of jaxsdp's fast path",
    )
    parser.add_argument("--json", type=pathlib.Path, default=None, help="also write the rows, machine and date here")
    args = parser.parse_args()
    scale = 10 if args.quick else 1
    n_short, n_long = 25_000 // scale, 250_000 // scale
    n_batch = args.batch if args.batch is not None else (20 if args.quick else 1000)
    budget = 2.0 if args.quick else 10.0
    rec = Recorder(
        "benchmarks/smoother.py",
        args.json,
        quick=args.quick,
        batch=n_batch,
        keep_freed_memory=KEPT,
        fast_loops=os.environ.get("JAXSDP_FAST_LOOPS", "1") != "0",
        numba=numba.__version__,
        dynamax=None if DYNAMAX_ERROR else dynamax.__version__,
    )

    print(f"IRW Kalman filter + fixed-interval smoother (float64, NVR = {NVR:g}, P0 = {P0:g})")
    print(
        f"jax {jax.__version__}, numba {numba.__version__}, "
        f"dynamax {'unavailable (' + DYNAMAX_ERROR + ')' if DYNAMAX_ERROR else dynamax.__version__}; "
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cpus, "
        f"{mem_available() / GB:.1f} GB available"
    )
    print(f"XLA fast loops: {jaxsdp.fast_loops_status()}; XLA_FLAGS={os.environ.get('XLA_FLAGS', '')!r}")
    settings = " ".join(f"{k}={v}" for k, v in MALLOC_KEEP.items())
    allocator = f"keeps freed memory ({settings})" if KEPT else "default (large buffers page-fault in on every call)"
    print(f"allocator: glibc {allocator}")
    if n_batch:
        cov = n_batch * n_short * 4 * 8
        print(
            f"memory: for the batch of {n_batch:,} x {n_short:,}, one (B, N, 2, 2) float64 covariance array is "
            f"{cov / GB:.1f} GB; jaxsdp's batch rule keeps one shared set (no per-series covariances), "
            "dynamax filtered, smoothed and cross-covariances; XLA's own figures are printed per case"
        )

    t0 = time.perf_counter()
    probe = np.zeros((1, 8))
    irw_smoother_numba_batch(probe, NVR, P0)
    irw_smoother_numba_rts_batch(probe, NVR, P0)
    print(f"numba compile: {time.perf_counter() - t0:.2f} s")

    rng = np.random.default_rng(0)
    rows = [
        bench_case(f"1 x {n_short:,}", signal(rng, 1, n_short)[0], budget=budget, unboosted_check=True),
    ]
    rows[-1].record(rec, "one-series", series=1, samples=n_short)
    rows.append(bench_case(f"1 x {n_long:,}", signal(rng, 1, n_long)[0], budget=budget, unboosted_check=False))
    rows[-1].record(rec, "long-series", series=1, samples=n_long)
    if n_batch:
        rows.append(
            bench_case(
                f"vmap {n_batch:,} x {n_short:,}", signal(rng, n_batch, n_short), budget=budget, unboosted_check=False
            )
        )
        rows[-1].record(rec, "batch", series=n_batch, samples=n_short, peak_rss_gb=peak_rss() / GB)
    lik = likelihood_case(signal(rng, 1, n_short)[0], budget=budget, rec=rec)
    print()
    print_tables(rows)
    print()
    print(lik)


if __name__ == "__main__":
    main()
