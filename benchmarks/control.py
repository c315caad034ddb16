"""Benchmark: the control layer (`jaxsdp.control`): SRIVC, PIP-LQ design, the PIP-SDP cascade, a batch of plants.

Four tasks, each timed after compilation (median of repeated calls; the
first call, compilation included, is printed beside it), with the peers
measured in the same process, in turn with jaxsdp, one call each per round
(these shared machines' load drifts; interleaving puts it on every side
alike). Wall and process CPU time per call are both printed; CPU time above
wall time means more than one core worked, wall time above CPU time that the
process waited (other load: the load average is printed at start and end).

1. SRIVC (`jaxsdp.control.srivc`) on N = 10,000 samples at dt = 1 ms of the closed loop
   G(s) = wn^2 / (s^2 + 2 eta wn s + wn^2), wn = 250 rad/s, eta = 1, driven by
   random steps (levels uniform in [-1, 1]) held 0.2 s, sampled exactly for
   the held input (scipy's ZOH `cont2discrete` + `lfilter`), plus white noise
   of 5 % of the noise-free output's standard deviation; n = 2, m = 0.
   Target <= 0.2 s on 2 cores. Neither python-control nor scipy has a
   continuous-time transfer-function estimator, so the peers are
   (a) a second-order ARX least-squares fit by `numpy.linalg.lstsq`: the
   floor, the cheapest discrete-time estimate (biased by the noise: its fit
   is printed); (b) the output-error estimate SRIVC converges to, built from
   scipy (`scipy.optimize.least_squares`, Levenberg-Marquardt with
   finite-difference Jacobian, residual simulated by `cont2discrete` +
   `lfilter`), started from (s + lam)^2, lam = 0.1 pi/dt (one of SRIVC's
   own starts).
2. PIP-LQ design (`pip_lq`) of the paper's model (30),
   num = [0, 0.0107, -0.0088, 0.0025], den = [1, -1.8660, 0.8706], ew = 10,
   uw = xw = 1, against `control.dlqr` (python-control) and
   `scipy.linalg.solve_discrete_are` + the gain (R + g'Pg)^-1 g'PF on the
   design's own NMSS matrices F, g, Q, R (the gains must agree). No target
   was set; the table's is the peer's: no slower than `control.dlqr` in the
   same run. Also printed: jaxsdp's jitted core alone (private
   `_pip._design`, without the argument checks).
3. One 1 s PIP-SDP cascade simulation (1,000 samples at 1 kHz, PIP at
   100 Hz): `simulate_control(PIPSDP(inner, design, loop_gain=0.016), r,
   q0=0)` with inner = SDPPD(control_model(M 95.15, Fv 200, Fc 20,
   friction = true_plant().friction), wn = 250), design = pip_lq of the inner
   loop's discrete model num = [0, 0.7545, 0.0337], den = [1, -0.2106, 0]
   (0.01 s) with ew = 10, uw = xw = 1, r a 0.05 m step. The whole call is
   jitted (controller and reference as arguments). Target <= 20 ms. For the
   breakdown, the inner SDP-PD loop alone on the same step.
4. `vmap` of 10,000 such cascades (`--runs`), each on a perturbed plant
   `EMPSPlant(M, AsymmetricFriction(Fv+, Fc+, Fv-, Fc-))`, every parameter
   drawn uniformly within +-20 % of `true_plant()`'s (vmap over the plant
   pytree's leaves), 1 s each, returning only per-run statistics (peak
   |velocity|, final error, settling proxy: the time from which |q - r| stays
   within 2 % of the step, the record length if it never does): only one
   chunk's trajectories are ever in memory. Target <= 30 s on 2 cores. The
   batch runs in chunks of `--chunk` plants (default 500 on CPU, where it
   takes less CPU time and memory than one big vmap, whose (B, N)
   trajectories stream through memory; the whole batch at once on an
   accelerator), one compiled function reused
   for every chunk and both batch sizes; 1,000 runs for scaling, per-run cost,
   XLA's buffer sizes and the process's peak RSS (`resource.getrusage`). On
   CPU without --quick, one unchunked vmap of the full batch is timed too.

A table closes the run (task, time, compile + first call, target,
time/target, pass). `--json PATH` also writes every timing as a row (key
`srivc`, `srivc-arx-floor`, `srivc-scipy-oe`, `pip-lq`, `pip-lq-core`,
`pip-dlqr`, `pip-scipy`, `cascade`, `cascade-inner`, `batch-scaling`, `batch`,
`batch-unchunked`, `summary`: seconds after compile, minimum, CPU seconds,
first call, target, the process's peak RSS for the batches) with the machine and the date (`benchmarks/_record.py`).
OpenBLAS runs one thread (`--blas-threads`, see `_select_blas_threads`):
every BLAS/LAPACK call here is tiny, jax's CPU LAPACK calls included.

    python benchmarks/control.py [--quick] [--repeats R] [--budget S] [--samples N] [--runs 10000] [--chunk C]
                                 [--blas-threads 1] [--json PATH]

`--quick`: 2,000 SRIVC samples, 200 and 20 plants (chunks of 20: one
compilation), no inner-loop breakdown, fewer repeats: a smoke run (not the
targets' sizes; compilation, about 20 s of it, dominates).
"""

import argparse
import importlib.util
import os
import pathlib
import platform
import resource
import statistics
import sys
import time
from dataclasses import dataclass


def _select_blas_threads(argv) -> None:
    """`--blas-threads N` (default 1; 0: the library's default): OpenBLAS/MKL threads, set before numpy loads.

    Every LAPACK/BLAS call here is tiny (a 5 x 5 DARE, a 10,000 x 4 least
    squares, jax's own small solves and eigenvalues, which go to the same
    OpenBLAS through scipy); with the default one thread per core, OpenBLAS's
    waiting threads make python-control's and scipy's DARE several times
    slower on a loaded 2-core machine (and jaxsdp's LAPACK calls too). A
    variable the user set is left as it is.
    """
    n = "1"
    for i, a in enumerate(argv):
        if a == "--blas-threads" and i + 1 < len(argv):
            n = argv[i + 1]
        elif a.startswith("--blas-threads="):
            n = a.split("=", 1)[1]
    if n.strip() != "0":
        for var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
            os.environ.setdefault(var, n.strip())


_select_blas_threads(sys.argv[1:])

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent
# This file is control.py: without its own folder on the path, `import control` is python-control, not itself.
sys.path[:] = [p for p in sys.path if pathlib.Path(p or os.getcwd()).resolve() != HERE]
sys.path.insert(0, str(ROOT))

# jaxsdp first: it sets XLA_FLAGS (its fast-loop option) before jax starts its backend.
import jaxsdp  # isort: skip
import control
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import scipy
import scipy.linalg as sla
import scipy.optimize as sopt
import scipy.signal as sig

import jaxsdp.control as jc
from jaxsdp.control import PIPSDP, _pip, pip_lq, srivc
from jaxsdp.plants import AsymmetricFriction, EMPSPlant

jax.config.update("jax_enable_x64", True)

# benchmarks/_record.py by its path (this folder is off sys.path, see above)
_spec = importlib.util.spec_from_file_location("_record", HERE / "_record.py")
_record = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_record)
REC = _record.Recorder("benchmarks/control.py", None)  # replaced in main() (with --json, a file)

MB = 2.0**20
# 1. SRIVC
DT = 1e-3
WN, ETA = 250.0, 1.0
HOLD_S = 0.2
NOISE = 0.05
SRIVC_TARGET_S = 0.2
# 2. PIP design, the paper's model (30)
PAPER_NUM, PAPER_DEN = [0.0, 0.0107, -0.0088, 0.0025], [1.0, -1.8660, 0.8706]
WEIGHTS = dict(ew=10.0, uw=1.0, xw=1.0)
# 3-4. PIP-SDP cascade
INNER_IDIM = dict(M=95.15, Fv=200.0, Fc=20.0, offset=0.0)
INNER_WN = 250.0
INNER_NUM, INNER_DEN = [0.0, 0.7545, 0.0337], [1.0, -0.2106, 0.0]
LOOP_GAIN = 0.016
STEP_M = 0.05
SIM_SAMPLES = 1000
CASCADE_TARGET_S = 0.020
BATCH_TARGET_S = 30.0
SPREAD = 0.2  # +-20 % uniform
BAND = 0.02  # settling band, fraction of the step


# --------------------------------------------------------------------------- timing
@dataclass
class Timing:
    first: float  # s, the first call (compilation included for jax)
    median: float  # s per call after it
    minimum: float
    cpu: float  # s of process CPU time per call (median)
    reps: int


def _ready(x):
    jax.block_until_ready(jax.tree.leaves(eqx.filter(x, eqx.is_array)))
    return x


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def interleaved(fns: dict, *, budget: float, min_rounds: int, max_rounds: int = 201) -> tuple[dict, dict]:
    """Time the callables of `fns` (label -> fn()) in turn, one call each per round.

    One timed first call of each, then rounds until at least `min_rounds` and
    the calls add up to `budget` seconds (or `max_rounds`). Returns
    (label -> Timing, label -> last output).
    """
    outs, first = {}, {}
    for k, fn in fns.items():
        t0 = time.perf_counter()
        outs[k] = _ready(fn())
        first[k] = time.perf_counter() - t0
    wall = {k: [] for k in fns}
    cpu = {k: [] for k in fns}
    total, rounds = 0.0, 0
    while rounds < max_rounds and (rounds < min_rounds or total < budget):
        for k, fn in fns.items():
            outs[k] = None
            c0, t0 = _cpu(), time.perf_counter()
            outs[k] = _ready(fn())
            dt = time.perf_counter() - t0
            wall[k].append(dt)
            cpu[k].append(_cpu() - c0)
            total += dt
        rounds += 1
    timings = {
        k: Timing(first[k], statistics.median(wall[k]), min(wall[k]), statistics.median(cpu[k]), rounds) for k in fns
    }
    return timings, outs


def fmt_t(s: float) -> str:
    if s >= 1.0:
        return f"{s:.2f} s"
    if s >= 1e-3:
        return f"{s * 1e3:.3g} ms"
    return f"{s * 1e6:.3g} us"


def record(key: str, t: Timing, **fields) -> None:
    """One timing as a row of the JSON output (seconds after compile: the median; first call: compilation included;
    the times also in milliseconds, as the docs quote them)."""
    REC.add(
        key=key,
        seconds=t.median,
        min_s=t.minimum,
        cpu_s=t.cpu,
        first_s=t.first,
        reps=t.reps,
        ms=1e3 * t.median,
        min_ms=1e3 * t.minimum,
        cpu_ms=1e3 * t.cpu,
        **fields,
    )


def show(label: str, t: Timing, width: int = 46) -> None:
    print(
        f"  {label:{width}s} {fmt_t(t.median):>9s}  (min {fmt_t(t.minimum)}, CPU {fmt_t(t.cpu)}; "
        f"first call {fmt_t(t.first)}; {t.reps} calls)"
    )


def peak_rss_mb() -> float:
    """Peak resident set size of this process so far (Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0 / MB


# --------------------------------------------------------------------------- 1. SRIVC
def srivc_data(N: int, seed: int = 0):
    """(y, u, x): random steps held HOLD_S, exact ZOH samples x of wn^2/(s^2 + 2 eta wn s + wn^2), y = x + noise."""
    rng = np.random.default_rng(seed)
    hold = int(round(HOLD_S / DT))
    u = np.repeat(rng.uniform(-1.0, 1.0, N // hold + 1), hold)[:N]
    nd, dd, _ = sig.cont2discrete(([WN**2], [1.0, 2 * ETA * WN, WN**2]), DT, method="zoh")
    x = sig.lfilter(nd.ravel(), dd, u)
    y = x + NOISE * np.std(x) * rng.standard_normal(N)
    return y, u, x


def arx_lstsq(y, u):
    """Second-order ARX y_k = -a1 y_{k-1} - a2 y_{k-2} + b1 u_{k-1} + b2 u_{k-2} by least squares (numpy)."""
    X = np.column_stack([-y[1:-1], -y[:-2], u[1:-1], u[:-2]])
    theta, *_ = np.linalg.lstsq(X, y[2:], rcond=None)
    return theta


def ct_output(theta, u):
    """Exact ZOH samples of b0 / (s^2 + a1 s + a2) driven by u, from rest (scipy)."""
    a1, a2, b0 = theta
    nd, dd, _ = sig.cont2discrete(([b0], [1.0, a1, a2]), DT, method="zoh")
    return sig.lfilter(nd.ravel(), dd, u)


def oe_scipy(y, u):
    """Output-error fit of b0 / (s^2 + a1 s + a2) by scipy.optimize.least_squares (LM), from (s + lam)^2."""
    lam = 0.1 * np.pi / DT
    p0 = np.array([2 * lam, lam**2, 1.0])
    g = ct_output(p0, u)
    p0[2] = (g @ y) / (g @ g)  # b0 by linear least squares at the starting denominator
    res = sopt.least_squares(lambda s: ct_output(s * p0, u) - y, np.ones(3), method="lm", xtol=1e-10)
    return res.x * p0, res.nfev


def wn_eta(a1, a2):
    return np.sqrt(a2), a1 / (2 * np.sqrt(a2))


def section_srivc(N: int, budget: float, min_rounds: int):
    print(
        f"\n1. SRIVC, n = 2, m = 0: {N:,} samples at dt = {DT * 1e3:g} ms of wn^2/(s^2 + 2 eta wn s + wn^2), "
        f"wn = {WN:g} rad/s, eta = {ETA:g};\n   random steps held {HOLD_S:g} s, output noise {100 * NOISE:g} % of "
        f"std(output); `{srivc.__module__}.srivc`"
    )
    y, u, x = srivc_data(N)
    sigma = NOISE * np.std(x)
    fns = {
        "jaxsdp srivc": lambda: srivc(y, u, DT, n=2, m=0),
        "floor: numpy ARX(2,2) lstsq": lambda: arx_lstsq(y, u),
        "scipy least_squares output error": lambda: oe_scipy(y, u),
    }
    t, out = interleaved(fns, budget=budget, min_rounds=min_rounds)
    res = out["jaxsdp srivc"]
    for k, v in t.items():
        show(k, v, 34)
    truth = np.array([2 * ETA * WN, WN**2, WN**2])
    est = np.asarray(res.theta)
    oe, nfev = out["scipy least_squares output error"]
    arx = out["floor: numpy ARX(2,2) lstsq"]
    y_arx = sig.lfilter(np.r_[0.0, arx[2:]], np.r_[1.0, arx[:2]], u)
    rms = lambda e: float(np.sqrt(np.mean(e**2)) / sigma)
    print(
        f"  srivc: den {np.array2string(np.asarray(res.den), precision=6)}, num "
        f"{np.array2string(np.asarray(res.num), precision=6)}; {int(res.iterations)} IV iterations after the "
        f"LSSVF start (lam {float(res.lam):.4g} rad/s), {res.reason}"
    )
    w, e = wn_eta(est[0], est[1])
    print(
        f"         wn {w:.3f} rad/s, eta {e:.5f}, DC gain {est[2] / est[1]:.5f}; (theta - truth) / se = "
        f"{np.array2string((est - truth) / np.r_[np.asarray(res.den_se)[1:], np.asarray(res.num_se)], precision=2)}"
    )
    print(
        f"  scipy output error ({nfev} evaluations): max |theta - srivc| / |srivc| = "
        f"{np.max(np.abs(oe - est) / np.abs(est)):.1e} (the same estimate)"
    )
    print(
        "  output-error RMS / noise std (1 = the noise floor): "
        f"srivc {rms(y - np.asarray(res.y_model)):.4f}, scipy OE {rms(y - ct_output(oe, u)):.4f}, "
        f"ARX floor {rms(y - y_arx):.3f} (equation-error bias: the ARX model is not usable here)"
    )
    ts = t["jaxsdp srivc"]
    ta, to = t["floor: numpy ARX(2,2) lstsq"], t["scipy least_squares output error"]
    print(
        f"  jaxsdp / ARX floor {ts.median / ta.median:.1f}x (min {ts.minimum / ta.minimum:.1f}x), "
        f"jaxsdp / scipy OE {ts.median / to.median:.2f}x (min {ts.minimum / to.minimum:.2f}x); "
        f"target {fmt_t(SRIVC_TARGET_S)}: {ts.median / SRIVC_TARGET_S:.2f} of it"
    )
    err_oe = float(np.max(np.abs(oe - est) / np.abs(est)))
    record(
        "srivc",
        ts,
        samples=N,
        iterations=int(res.iterations),
        reason=str(res.reason),
        den=np.array2string(np.asarray(res.den), precision=6),
        num=np.array2string(np.asarray(res.num), precision=6),
        target_s=SRIVC_TARGET_S,
        ratio=ts.median / SRIVC_TARGET_S,
        passed=bool(ts.median <= SRIVC_TARGET_S),
    )
    record("srivc-arx-floor", ta, rms_over_noise=rms(y - y_arx))
    record("srivc-scipy-oe", to, evaluations=int(nfev), max_rel_difference=err_oe)
    return ts, t["floor: numpy ARX(2,2) lstsq"], t["scipy least_squares output error"]


# --------------------------------------------------------------------------- 2. PIP design
def dare_scipy(F, g, Q, R):
    P = sla.solve_discrete_are(F, g[:, None], Q, R)
    Pg = P @ g
    return (Pg @ F) / (R[0, 0] + g @ Pg)


def section_pip(budget: float, min_rounds: int):
    print(f"\n2. PIP-LQ design of the paper's model (30): num {PAPER_NUM}, den {PAPER_DEN}, {WEIGHTS}")
    t0 = time.perf_counter()
    d = _ready(pip_lq(PAPER_NUM, PAPER_DEN, **WEIGHTS))  # the first call (compilation), timed here
    first = time.perf_counter() - t0
    F, g, Q, R = (np.asarray(a) for a in (d.F, d.g, d.Q, d.R))
    fns = {
        "jaxsdp pip_lq": lambda: pip_lq(PAPER_NUM, PAPER_DEN, **WEIGHTS),
        "python-control dlqr": lambda: control.dlqr(F, g[:, None], Q, R)[0],
        "scipy solve_discrete_are + gain": lambda: dare_scipy(F, g, Q, R),
    }
    core = getattr(_pip, "_design", None)
    if core is not None:
        num, den = jnp.asarray(PAPER_NUM), jnp.asarray(PAPER_DEN)
        w = jnp.asarray([WEIGHTS["ew"], WEIGHTS["uw"], WEIGHTS["xw"]])
        try:
            _ready(core(num, den, w))
            fns["  jaxsdp jitted core only (_pip._design)"] = lambda: core(num, den, w)
        except Exception as err:  # noqa: BLE001  (a private function; its signature may change)
            print(f"  (jitted core not timed: {type(err).__name__}: {err})")
    t, out = interleaved(fns, budget=budget, min_rounds=min_rounds)
    t["jaxsdp pip_lq"].first = first
    for k, v in t.items():
        show(k, v, 42)
    gains = np.asarray(out["jaxsdp pip_lq"].gains)
    rel = lambda k: float(np.max(np.abs(np.ravel(k) - gains)) / np.max(np.abs(gains)))
    print(
        f"  gains {np.array2string(gains, precision=4)}; max relative difference: dlqr "
        f"{rel(out['python-control dlqr']):.1e}, scipy {rel(out['scipy solve_discrete_are + gain']):.1e}; "
        f"DARE residual {float(out['jaxsdp pip_lq'].dare_residual):.1e}"
    )
    tj, tc, tsci = t["jaxsdp pip_lq"], t["python-control dlqr"], t["scipy solve_discrete_are + gain"]
    print(
        f"  jaxsdp / dlqr {tj.median / tc.median:.2f}x (min {tj.minimum / tc.minimum:.2f}x), "
        f"jaxsdp / scipy {tj.median / tsci.median:.2f}x (min {tj.minimum / tsci.minimum:.2f}x)"
    )
    record(
        "pip-lq",
        tj,
        target_s=tc.median,
        ratio=tj.median / tc.median,
        passed=bool(tj.median <= tc.median),
        dare_residual=float(out["jaxsdp pip_lq"].dare_residual),
        gains=np.array2string(gains, precision=4),
    )
    core_key = "  jaxsdp jitted core only (_pip._design)"
    if core_key in t:
        record("pip-lq-core", t[core_key])
    record("pip-dlqr", tc, max_rel_difference=rel(out["python-control dlqr"]))
    record("pip-scipy", tsci, max_rel_difference=rel(out["scipy solve_discrete_are + gain"]))
    return tj, tc


# --------------------------------------------------------------------------- 3-4. cascade
def cascade_parts():
    plant = jc.true_plant()
    model = jc.control_model(INNER_IDIM, friction=plant.friction)
    inner = jc.SDPPD(model, wn=INNER_WN)
    design = pip_lq(INNER_NUM, INNER_DEN, **WEIGHTS)
    return inner, design, PIPSDP(inner, design, loop_gain=LOOP_GAIN)


def run_stats(sim, r):
    """Per-run figures: peak |dq| (m/s), final error (m), settling proxy (s), settled within the record."""
    e = sim.q - r
    outside = jnp.abs(e) > BAND * STEP_M
    k = jnp.arange(r.shape[0])
    last = jnp.max(jnp.where(outside, k, -1))
    return dict(
        peak_velocity=jnp.max(jnp.abs(sim.dq)),
        final_error=e[-1],
        settling=(last + 1) * DT,
        settled=~outside[-1],
    )


def section_cascade(budget: float, min_rounds: int, breakdown: bool = True):
    print(
        f"\n3. One PIP-SDP cascade run: {SIM_SAMPLES:,} samples at 1 kHz (PIP at 100 Hz), "
        f"{STEP_M:g} m step, loop gain {LOOP_GAIN:g}; whole call jitted"
    )
    inner, design, ctrl = cascade_parts()
    r = jnp.full(SIM_SAMPLES, STEP_M)
    sim_fn = jax.jit(lambda c, r: jc.simulate_control(c, r, q0=0.0))
    fns = {"PIP-SDP cascade (simulate_control)": lambda: sim_fn(ctrl, r)}
    if breakdown:
        fns["  inner SDP-PD loop alone, same step"] = lambda: sim_fn(inner, r)
    t, out = interleaved(fns, budget=budget, min_rounds=min_rounds)
    for k, v in t.items():
        show(k, v, 38)
    sim = out["PIP-SDP cascade (simulate_control)"]
    s = {k: float(v) for k, v in run_stats(sim, r).items()}
    tc = t["PIP-SDP cascade (simulate_control)"]
    inner_note = ""
    if breakdown:
        ti = t["  inner SDP-PD loop alone, same step"]
        inner_note = (
            f", inner loop alone {ti.median / SIM_SAMPLES * 1e9:.0f} ns (CPU {ti.cpu / SIM_SAMPLES * 1e9:.0f} ns)"
        )
    print(
        f"  PIP gains {np.array2string(np.asarray(design.gains), precision=4)}; q(1 s) {float(sim.q[-1]):.5f} m, "
        f"peak |dq| {s['peak_velocity']:.4f} m/s, final error {s['final_error']:.2e} m, "
        f"{'settled' if s['settled'] else 'not settled (2 % band) within the record'}"
    )
    print(
        f"  per sample: cascade {tc.median / SIM_SAMPLES * 1e9:.0f} ns (CPU {tc.cpu / SIM_SAMPLES * 1e9:.0f} ns)"
        f"{inner_note}; target {fmt_t(CASCADE_TARGET_S)}: "
        f"{tc.median / CASCADE_TARGET_S:.3f} of it"
    )
    record(
        "cascade",
        tc,
        samples=SIM_SAMPLES,
        target_s=CASCADE_TARGET_S,
        ratio=tc.median / CASCADE_TARGET_S,
        passed=bool(tc.median <= CASCADE_TARGET_S),
        q_end=float(sim.q[-1]),
        **s,
    )
    if breakdown:
        record("cascade-inner", t["  inner SDP-PD loop alone, same step"], samples=SIM_SAMPLES)
    return tc


def perturbed_plants(B: int, seed: int = 1) -> EMPSPlant:
    """B plants, M, Fv+-, Fc+- each uniform within +-SPREAD of true_plant()'s; leaves of shape (B,)."""
    rng = np.random.default_rng(seed)
    tp = jc.true_plant()
    fr = tp.friction
    draw = lambda v: float(v) * rng.uniform(1.0 - SPREAD, 1.0 + SPREAD, B)
    friction = AsymmetricFriction(draw(fr.Fv_pos), draw(fr.Fc_pos), draw(fr.Fv_neg), draw(fr.Fc_neg), np.zeros(B))
    return EMPSPlant(draw(tp.M), friction)


def take(plants, lo: int, hi: int, size: int):
    """Plants lo..hi-1, padded to `size` by repeating the last one (every chunk has one shape: one compile)."""
    idx = np.minimum(np.arange(lo, lo + size), hi - 1)
    return jax.tree.map(lambda a: np.asarray(a)[idx], plants)


def section_batch(runs_list, chunk: int, budget: float, min_rounds: int, unchunked: bool):
    print(
        f"\n4. vmap of cascades on perturbed plants (M, Fv+-, Fc+- uniform +-{100 * SPREAD:g} %), "
        f"{SIM_SAMPLES:,} samples each, per-run statistics only; "
        + (f"chunks of {chunk:,}" if chunk else "one vmap per batch (no chunks)")
    )
    _, _, ctrl = cascade_parts()
    r = jnp.full(SIM_SAMPLES, STEP_M)

    def one(plant):
        return run_stats(jc.simulate_control(ctrl, r, plant=plant, q0=0.0), r)

    batch_fn = jax.jit(jax.vmap(one))
    print(f"  peak RSS before: {peak_rss_mb():.0f} MB")
    compile_s = {}

    def compile_for(size):
        """Compile `batch_fn` for chunks of `size` plants (timed; `jit` then reuses it); XLA's buffer sizes."""
        if size not in compile_s:
            t0 = time.perf_counter()
            compiled = batch_fn.lower(take(perturbed_plants(1), 0, 1, size)).compile()
            compile_s[size] = time.perf_counter() - t0
            mem = compiled.memory_analysis()
            note = (
                "XLA memory analysis unavailable"
                if mem is None
                else f"temporaries {mem.temp_size_in_bytes / MB:.1f} MB, outputs {mem.output_size_in_bytes / MB:.2f} MB"
            )
            print(f"  compile for {size:,} plants per call: {compile_s[size]:.2f} s; XLA buffers per call: {note}")
        return compile_s[size]

    def batched(plants, B, size):
        outs = [batch_fn(take(plants, lo, B, size)) for lo in range(0, B, size)]
        return jax.tree.map(lambda *a: jnp.concatenate(a)[:B], *outs)

    rows, results, rss = {}, {}, {}
    for B in runs_list:
        plants = perturbed_plants(B)
        size = min(chunk, B) if chunk else B
        compile_for(size)
        t, out = interleaved({B: lambda: batched(plants, B, size)}, budget=budget, min_rounds=min_rounds)
        rows[B] = t[B]
        rss[B] = peak_rss_mb()
        results[B] = out[B]
        s = {k: np.asarray(v) for k, v in out[B].items()}
        show(f"{B:,} runs", t[B], 14)
        print(
            f"    per run {t[B].median / B * 1e6:.0f} us ({t[B].median / B / SIM_SAMPLES * 1e9:.0f} ns per sample, "
            f"CPU {t[B].cpu / B * 1e6:.0f} us per run); peak RSS {peak_rss_mb():.0f} MB"
        )
        print(
            "    peak |dq| {:.4f} .. {:.4f} m/s, final error {:.2e} .. {:.2e} m, settling proxy {:.3f} .. {:.3f} s, "
            "{} of {} settled (2 % band) within {:g} s".format(
                s["peak_velocity"].min(),
                s["peak_velocity"].max(),
                s["final_error"].min(),
                s["final_error"].max(),
                s["settling"].min(),
                s["settling"].max(),
                int(s["settled"].sum()),
                B,
                SIM_SAMPLES * DT,
            )
        )
    big = max(runs_list)
    big_size = min(chunk, big) if chunk else big
    # the table's "compile + first call" of the batch: its compilation (timed apart, shared between sizes) + first call
    rows[big].first += compile_s[big_size]
    if len(runs_list) > 1:
        small = min(runs_list)
        print(
            f"  scaling {small:,} -> {big:,}: wall x{rows[big].median / rows[small].median:.1f}, "
            f"CPU x{rows[big].cpu / rows[small].cpu:.1f} for x{big // small} runs"
        )
    unchunked_t = None
    if unchunked and chunk and chunk < big:
        plants = perturbed_plants(big)
        compile_for(big)
        t, out = interleaved({big: lambda: batch_fn(plants)}, budget=0.0, min_rounds=min(min_rounds, 3))
        unchunked_t = t[big]
        diff = max(
            float(np.max(np.abs(np.asarray(out[big][k], float) - np.asarray(results[big][k], float)))) for k in out[big]
        )
        show(f"{big:,} runs, one vmap (no chunks)", t[big], 14)
        print(
            f"    CPU {t[big].cpu / big * 1e6:.0f} us per run; peak RSS {peak_rss_mb():.0f} MB; "
            f"statistics differ from the chunked run by at most {diff:.1e} (vector-width rounding)"
        )
    for B, tB in rows.items():
        stats = {k: np.asarray(v) for k, v in results[B].items()}
        record(
            "batch" if B == big else "batch-scaling",
            tB,
            runs=B,
            chunk=min(chunk, B) if chunk else B,
            compile_s=compile_s[min(chunk, B) if chunk else B],
            per_run_s=tB.median / B,
            peak_rss_mb=rss[B],
            settled=int(stats["settled"].sum()),
            **{f"{k}_{f.__name__}": float(f(v)) for k, v in stats.items() if k != "settled" for f in (np.min, np.max)},
            **(
                dict(
                    target_s=BATCH_TARGET_S, ratio=tB.median / BATCH_TARGET_S, passed=bool(tB.median <= BATCH_TARGET_S)
                )
                if B == big
                else {}
            ),
        )
    if unchunked_t:
        record("batch-unchunked", unchunked_t, runs=big, peak_rss_mb=peak_rss_mb())
    return rows[big]


# --------------------------------------------------------------------------- table
def table(rows):
    head = ["task", "time", "compile + first call", "target", "time / target", "pass"]
    body = [
        [
            task,
            fmt_t(t.median),
            fmt_t(t.first),
            tgt_label,
            f"{t.median / tgt:.3g}",
            "pass" if t.median <= tgt else "FAIL",
        ]
        for task, t, tgt, tgt_label in rows
    ]
    widths = [max(len(str(x)) for x in col) for col in zip(head, *body)]
    line = lambda cells: "| " + " | ".join(str(c).ljust(w) for c, w in zip(cells, widths)) + " |"
    print(line(head))
    print("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    for cells in body:
        print(line(cells))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--quick", action="store_true", help="small sizes, fewer repeats: a smoke run")
    ap.add_argument("--repeats", type=int, default=None, help="at least this many timed calls (default 7, quick 2)")
    ap.add_argument("--budget", type=float, default=None, help="seconds of timed calls per task (default 3, quick 0)")
    ap.add_argument("--samples", type=int, default=None, help="SRIVC samples (default 10,000, quick 2,000)")
    ap.add_argument("--runs", type=int, default=None, help="plants in the batch (default 10,000, quick 200)")
    ap.add_argument("--chunk", type=int, default=None, help="plants per vmap call (default 500 on CPU; 0: no chunks)")
    ap.add_argument(
        "--blas-threads",
        type=int,
        default=1,
        help="OpenBLAS/MKL threads (default 1, tiny problems; 0: library default)",
    )
    ap.add_argument("--json", type=pathlib.Path, default=None, help="also write the rows, machine and date here")
    args = ap.parse_args()
    quick = args.quick
    min_rounds = args.repeats if args.repeats is not None else (2 if quick else 7)
    budget = args.budget if args.budget is not None else (0.0 if quick else 3.0)
    samples = args.samples if args.samples is not None else (2_000 if quick else 10_000)
    runs = args.runs if args.runs is not None else (200 if quick else 10_000)
    backend = jax.default_backend()
    if args.chunk is not None:
        chunk = args.chunk
    else:  # --quick: chunks of the small batch, so that both sizes share one compilation
        chunk = max(runs // 10, 1) if quick else (500 if backend == "cpu" else 0)
    runs_list = sorted({max(runs // 10, 1), runs})

    global REC
    REC = _record.Recorder(
        "benchmarks/control.py",
        args.json,
        quick=quick,
        repeats=min_rounds,
        budget=budget,
        samples=samples,
        runs=runs,
        chunk=chunk,
        blas_threads=os.environ.get("OPENBLAS_NUM_THREADS", "library default"),
    )
    load0 = os.getloadavg()
    print("jaxsdp control benchmark (float64)")
    print(
        f"jax {jax.__version__}, python-control {control.__version__}, scipy {scipy.__version__}, "
        f"numpy {np.__version__}; backend {backend}, devices {jax.devices()}"
    )
    print(
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cpus, load average "
        f"{load0[0]:.2f} (1 min); XLA fast loops: {jaxsdp.fast_loops_status()}"
    )
    blas = ", ".join(f"{v}={os.environ[v]}" for v in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS") if v in os.environ)
    print(f"BLAS threads: {blas or 'library default'}")
    print(f"timing: median of >= {min_rounds} calls after the first, >= {budget:g} s of calls per task")
    ts, _, _ = section_srivc(samples, budget, min_rounds)
    tp, tdlqr = section_pip(budget, min_rounds)
    tc = section_cascade(budget, min_rounds, breakdown=not quick)
    tb = section_batch(runs_list, chunk, budget, min_rounds, unchunked=not quick and backend == "cpu")
    load1 = os.getloadavg()

    rows = [
        (f"SRIVC, {samples:,} samples, n=2 m=0", ts, SRIVC_TARGET_S, fmt_t(SRIVC_TARGET_S)),
        ("PIP-LQ design, model (30)", tp, tdlqr.median, f"{fmt_t(tdlqr.median)} (peer: control.dlqr, this run)"),
        (f"PIP-SDP cascade, 1 run of {SIM_SAMPLES:,}", tc, CASCADE_TARGET_S, fmt_t(CASCADE_TARGET_S)),
        (f"vmap {max(runs_list):,} cascades (stats only)", tb, BATCH_TARGET_S, fmt_t(BATCH_TARGET_S)),
    ]
    print(f"\nSummary ({backend}, {os.cpu_count()} cpus; load average {load0[0]:.2f} at start, {load1[0]:.2f} at end)")
    table(rows)
    if quick:
        print("(--quick: smaller sizes than the targets are set for)")
    if max(load0[0], load1[0]) > (os.cpu_count() or 1):
        print(
            "note: the load average exceeded the number of cpus: other processes shared the cores "
            "(wall times inflated; compare the CPU times)"
        )
    REC.add(
        key="summary",
        load_average_start=load0[0],
        load_average_end=load1[0],
        fast_loops=jaxsdp.fast_loops_status(),
        passed=all(t.median <= tgt for _, t, tgt, _ in rows),
    )
    if args.json:
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
