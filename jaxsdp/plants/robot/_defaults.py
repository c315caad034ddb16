"""Processing defaults of the robot study that follow from the logs: cut-off, decimation, dropped ends, rest threshold.

The TX40 papers process 5 kHz logs with a zero-phase Butterworth of order 4
at 100 Hz, central differences, 100 samples dropped (at both ends: the
filter's transients) and a decimation by 10. Those are one sampling rate's
numbers; `processing_defaults` derives them from the logs' sampling rate `fs`
and the motion (and gives the TX40's back on the TX40 logs), with the reason
of each:

- **cut-off** fc = min(`CUTOFF_CAP_HZ` = 100 Hz, `CUTOFF_SHARE` fs = fs / 5),
  raised to `BAND_FACTOR` (5) x the motion's band B where the motion is that
  fast (up to `CUTOFF_SHARE_MAX` fs = 0.3 fs, with a warning beyond). B is
  the frequency below which 99 % of a joint's velocity power lies
  (`motion_spectrum`), the largest over the joints that move. fs / 5 is 40 %
  of the Nyquist frequency, half the limit `check_processing` refuses (80 %);
  central differences lose 1 - sin(x) / x of a derivative at f, x = 2 pi f / fs:
  24 % at fs / 5, where the filter has halved it anyway, 0.3 % at fs / 50. At
  5 B the filter passes the motion's band unchanged (1 / (1 + 0.2^8) in
  power). The cap keeps the TX40 value at 5 kHz and every faster rate: a
  higher cut-off passes more encoder noise to the acceleration (its rms grows
  as fc^2.5) and nothing of a robot's motion. With `noise_limited=True` the
  cut-off is lowered to where the encoder noise in the acceleration reaches
  `NOISE_SHARE` (1 %) of the motion's (`motion_spectrum`; not below 5 B).
- **decimation** D = floor(fs / (`DECIMATED_RATE` fc)): the decimated rate
  fs / D is at least 5 fc, so that its anti-alias filter (Chebyshev, pass band
  to 80 % of the decimated Nyquist frequency) passes twice the cut-off band;
  lowered so that at least `TARGET_ROWS` rows stay where the record allows.
- **dropped ends** where the zero-phase filter's start-up in the acceleration
  has decayed below `EDGE_TOL` (1 %) of the motion's rms acceleration
  (`edge_transient`), at least `SETTLE_PERIODS` (2) periods of the cut-off,
  2 fs / fc samples (4.8 time constants of the Butterworth's slowest pole,
  decay rate sigma = 2 pi fc sin(pi / 8)). MATLAB's `filtfilt` pads 3 (n - 1)
  samples and starts from the steady state of the first one: a record that
  begins in motion meets a velocity step v, whose transient in the
  acceleration starts near v 2 pi fc and decays as exp(-sigma t); a record
  that starts at rest has none (the TX40 logs), and the floor holds. Without
  the rule, a 2 kHz record starting at speed with a 40 Hz cut-off and 25 ms
  dropped biased a link's inertia by 9 standard errors.
- **rest threshold** "auto" (`rest_threshold`: 1 % of each joint's peak
  speed), relative to the motion already.

TX40 logs (fs = 5 kHz, B = 3.3 Hz): 100 Hz, 10, 100 samples, as published.
At 100 Hz: 20 Hz, 1, 10; 500 Hz: 100 Hz, 1, 10; 1 kHz: 100 Hz, 2, 20
(`benchmarks/robot_defaults.py` measures them and the alternatives).

`check_processing` refuses, before any work, the choices that cannot work:
a cut-off at or above 80 % of the Nyquist frequency, a decimation whose
Nyquist frequency is at or below the cut-off or that leaves fewer than
`MIN_ROWS` rows, dropped ends that leave fewer than `MIN_ROWS` samples, a
fixed rest threshold at or above a moving joint's peak speed. Host-side
NumPy; the messages name the Python arguments in backquotes (the command
line maps them to its options) and suggest the default's value.
"""

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import equinox as eqx
import numpy as np

from ..._checks import OptionError
from ._joint_stages import MIN_REST_SPEED, MIN_SPEED, REST_FRACTION
from ._motion import EDGE_TOL, MOVING_RANGE, edge_transient, joint_angles

#: The TX40 papers' cut-off (Hz, at 5 kHz): the default's cap.
CUTOFF_CAP_HZ = 100.0
#: The default cut-off is at most this share of the sampling rate (0.2: 40 % of the Nyquist frequency)...
CUTOFF_SHARE = 0.2
#: ...unless the motion's band needs more: at least this many times the motion's band...
BAND_FACTOR = 5.0
#: ...up to this share of the sampling rate (60 % of the Nyquist frequency).
CUTOFF_SHARE_MAX = 0.3
#: A cut-off at or above this share of the Nyquist frequency is refused.
NYQUIST_LIMIT = 0.8
#: Share of the velocity power below the motion's band.
BAND_SHARE = 0.99
#: The decimated rate is at least this many times the cut-off.
DECIMATED_RATE = 5.0
#: Relative tolerance of the rules on the sampling rate: a rate read from time stamps rounded to nanoseconds, or
#: from a logger whose clock is off by parts per million, falls on the same side of a boundary as the nominal rate
#: (1 kHz gave decimation 1 from a bag's stamps and 2 from the same record's CSV).
RATE_TOLERANCE = 1e-6
#: Periods of the cut-off dropped at each end of the record at least (the zero-phase filter's transients).
SETTLE_PERIODS = 2.0
#: `motion_spectrum`'s noise limit: the acceleration's encoder noise (rms) at most this share of the motion's.
NOISE_SHARE = 0.01
#: Fewest rows (decimated samples) or samples left that `check_processing` accepts.
MIN_ROWS = 200
#: The default decimation keeps at least this many rows where the record allows.
TARGET_ROWS = 1000

_GIVEN = "given"
#: int_0^inf x^4 / (1 + x^8)^2 dx: the acceleration noise power through a zero-phase Butterworth of order 4.
_BUTTER_NOISE = 0.15939540865975704


class RobotProcessing(eqx.Module):
    """The processing options of the robot study, each None (or "auto") for the value that suits the logs.

    `cutoff_hz` (Hz: the zero-phase Butterworth of order 4 on the joint angles before central differences),
    `decimate` (factor of the parallel decimation), `drop` (samples removed at each end), `min_speed` (the rest
    threshold, rad/s or m/s, or "auto": 1 % of each joint's peak speed). The defaults follow from the sampling
    rate, the motion and the encoders' noise (`processing_defaults`, this module's docstring); a given value that
    cannot work on the logs is refused before any work.
    """

    cutoff_hz: float | None = eqx.field(static=True, default=None)
    decimate: int | None = eqx.field(static=True, default=None)
    drop: int | None = eqx.field(static=True, default=None)
    min_speed: float | str = eqx.field(static=True, default=MIN_SPEED)

    def __check_init__(self):
        if self.cutoff_hz is not None and (
            isinstance(self.cutoff_hz, bool) or not isinstance(self.cutoff_hz, (int, float)) or not self.cutoff_hz > 0
        ):
            raise ValueError(f"`cutoff_hz` must be None or a frequency > 0 (Hz); got {self.cutoff_hz!r}")
        if self.decimate is not None:
            _as_int("decimate", self.decimate, 1)
        if self.drop is not None:
            _as_int("drop", self.drop, 0)
        _check_min_speed(self.min_speed, None, None)


@dataclass(frozen=True)
class Processing:
    """The processing of a robot study's logs (`processing_defaults`).

    **Fields:** `cutoff_hz` (Hz, the Butterworth's), `decimate`, `drop`
    (samples, at each end), `min_speed` ("auto" or rad/s), `reasons` (field
    -> one sentence: the value and what it follows from, or "given"), `fs`
    (Hz, the sampling rate), `samples`, `bandwidth_hz` (the motion's 99 %
    velocity band, the largest over the moving joints; None when none
    moves), `bands` (Hz per joint, NaN where it does not move),
    `noise_cutoff_hz` (Hz: the highest cut-off at which the encoder noise in
    every moving joint's acceleration stays below 1 % of its motion's,
    `motion_spectrum`; the default follows it only with `noise_limited=True`),
    `peak_speeds` (per joint, rad/s or m/s, of the angle low-passed at the
    cut-off), `warnings` (choices that work but distort: a cut-off close to
    the motion's band).
    """

    cutoff_hz: float
    decimate: int
    drop: int
    reasons: dict
    min_speed: object = MIN_SPEED
    fs: float = math.nan
    samples: int = 0
    bandwidth_hz: float | None = None
    bands: tuple = ()
    noise_cutoff_hz: float | None = None
    peak_speeds: tuple = ()
    warnings: tuple = field(default=())

    @property
    def preprocessing(self) -> dict:
        """The options of `robot_idim_ls`'s `preprocessing`: `cutoff_hz`, `decimate`, `drop`."""
        return {"cutoff_hz": self.cutoff_hz, "decimate": self.decimate, "drop": self.drop}

    def text(self) -> str:
        """The reasons, one line each."""
        return "\n".join(f"{k}: {v}" for k, v in self.reasons.items())


def _g(x) -> str:
    """A number rounded to 3 significant digits, without trailing zeros."""
    v = float(f"{float(x):.3g}")
    return f"{v:.0f}" if 1e3 <= abs(v) < 1e15 else f"{v:g}"


def _sampling_rate(t_or_dt) -> float:
    """fs (Hz) from a sample time (s) or time stamps (the median step)."""
    a = np.asarray(t_or_dt, dtype=float)
    if a.ndim == 0:
        dt = float(a)
    elif a.ndim == 1 and a.size >= 2:
        steps = np.diff(a)
        dt = float(np.median(steps))
        if np.all(np.abs(steps - dt) <= 0.01 * abs(dt)):
            # uniform: the mean step, exact to the end points' rounding over N - 1 (the median step of epoch time
            # stamps, t ~ 1.7e9 s, carries their 2.4e-7 s rounding: 1 kHz read as 1000.07 Hz)
            dt = float((a[-1] - a[0]) / (a.size - 1))
    else:
        raise ValueError(f"`t_or_dt` must be a sample time (s) or the time stamps (N,); got shape {a.shape}")
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"the sample time must be finite and positive (s); got {dt!r}")
    return 1.0 / dt


class Motion(NamedTuple):
    """The motion in a set of joint logs (`motion_spectrum`), per joint: `bands` (Hz: 99 % of the velocity power
    below it; NaN where the joint does not move) and `noise_cutoffs` (Hz: the highest cut-off at which the
    encoder noise in the acceleration stays below `NOISE_SHARE` of the motion's; inf without noise, NaN where
    the joint does not move)."""

    bands: np.ndarray
    noise_cutoffs: np.ndarray


def motion_spectrum(fs: float, q, *, min_range: float = MOVING_RANGE) -> Motion:
    """The motion's band and the encoder noise's limit on the cut-off, per joint of `q` sampled at `fs` Hz.

    Each angle (rad or m) is detrended (a straight line) and Hann-windowed,
    its periodogram P(f) taken, and the encoder's white noise level P0 (the
    median of P over the upper half of the band, where a robot's motion has
    no power, / ln 2: the mean of an exponential variable) subtracted. The
    band B is where the velocity power (2 pi f)^2 (P - P0) reaches
    `BAND_SHARE` (99 %) of its total. The noise limit fc_n solves
    noise(fc) = `NOISE_SHARE`^2 motion: the acceleration's noise power
    through the zero-phase Butterworth of order 4, P0 (2 pi)^4 c fc^5 / df
    (c = int x^4 / (1 + x^8)^2 dx = 0.1594, df the bin width), against the
    motion's acceleration power up to `BAND_FACTOR` B. A joint moves when
    its angle spans at least `min_range`.
    """
    import scipy.signal

    q = joint_angles(q)
    n = q.shape[0]
    x = scipy.signal.detrend(q, axis=0) * scipy.signal.get_window("hann", n)[:, None]
    p = np.abs(np.fft.rfft(x, axis=0)) ** 2
    f = np.fft.rfftfreq(n, 1.0 / fs)
    upper = f > f[-1] / 2
    floor = np.median(p[upper], axis=0) / np.log(2) if upper.sum() >= 8 else np.zeros(q.shape[1])
    motion = p - floor
    bands, limits = np.full(q.shape[1], np.nan), np.full(q.shape[1], np.nan)
    for k in range(q.shape[1]):
        v = np.cumsum(motion[:, k] * f**2)
        if np.ptp(q[:, k]) < min_range or not v[-1] > 0:
            continue
        bands[k] = f[int(np.argmax(v >= BAND_SHARE * v[-1]))]
        inside = f <= BAND_FACTOR * bands[k]
        acc = float(np.sum(motion[inside, k] * (2 * np.pi * f[inside]) ** 4))
        noise = floor[k] * (2 * np.pi) ** 4 * _BUTTER_NOISE / f[1]
        limits[k] = (NOISE_SHARE**2 * max(acc, 0.0) / noise) ** 0.2 if noise > 0 else np.inf
    return Motion(bands=bands, noise_cutoffs=limits)


def _peak_speeds(fs: float, q: np.ndarray, cutoff_hz: float) -> np.ndarray:
    """max |dq| per joint of the angle low-passed at `cutoff_hz` (zero-phase Butterworth of order 4)."""
    import scipy.signal

    wn = 2.0 * cutoff_hz / fs
    if 0 < wn < 1 and q.shape[0] > 30:
        q = scipy.signal.filtfilt(*scipy.signal.butter(4, wn), q, axis=0)
    return np.max(np.abs(np.gradient(q, 1.0 / fs, axis=0)), axis=0)


def _down2(x: float) -> float:
    """`x` rounded down to 2 significant digits."""
    step = 10.0 ** (math.floor(math.log10(x)) - 1)
    return math.floor(x / step * (1 + 1e-12)) * step


def _up2(x: float) -> float:
    """`x` rounded up to 2 significant digits."""
    step = 10.0 ** (math.floor(math.log10(x)) - 1)
    return math.ceil(x / step * (1 - 1e-12)) * step


def default_cutoff(
    fs: float, bandwidth_hz: float | None = None, noise_cutoff_hz: float | None = None
) -> tuple[float, str]:
    """The default cut-off (Hz) for the rate `fs` (Hz) and the motion's band, and why; lowered to
    `noise_cutoff_hz` (`motion_spectrum`; None: not) where that is lower, never below `BAND_FACTOR` x the band."""
    base = min(CUTOFF_CAP_HZ, CUTOFF_SHARE * fs)
    band = None if bandwidth_hz is None or not np.isfinite(bandwidth_hz) else float(bandwidth_hz)
    motion = "" if band is None else f"the motion's 99 % velocity band {_g(band)} Hz"
    if band is not None and BAND_FACTOR * band > base:
        fc = min(_up2(BAND_FACTOR * band), float(_g(CUTOFF_SHARE_MAX * fs)))
        if BAND_FACTOR * band <= CUTOFF_SHARE_MAX * fs:
            why = f"{_g(BAND_FACTOR)} x {motion} (above the usual {_g(base)} Hz)"
        else:
            why = (
                f"{_g(100 * CUTOFF_SHARE_MAX)} % of the {_g(fs)} Hz sampling rate, only {_g(fc / band)} x {motion}: "
                "the logs are sampled slowly for this motion"
            )
        return fc, f"cut-off {_g(fc)} Hz: {why}"
    of = f", {_g(base / band)} x {motion}" if band is not None else " (no joint moves: the rate alone)"
    if CUTOFF_CAP_HZ <= CUTOFF_SHARE * fs:
        usual = f"the TX40 papers' value (the cap), below {_g(100 * CUTOFF_SHARE)} % of the {_g(fs)} Hz sampling rate"
    else:
        usual = (
            f"{_g(100 * CUTOFF_SHARE)} % of the {_g(fs)} Hz sampling rate ({_g(200 * CUTOFF_SHARE)} % of its "
            f"Nyquist frequency {_g(fs / 2)} Hz)"
        )
    noisy = noise_cutoff_hz is not None and np.isfinite(noise_cutoff_hz) and noise_cutoff_hz < base
    if not noisy:
        return float(_g(base)), f"cut-off {_g(base)} Hz: {usual}{of}"
    low = None if band is None else BAND_FACTOR * band
    if low is not None and noise_cutoff_hz < low:
        fc = float(_g(low))
        why = (
            f"{_g(BAND_FACTOR)} x {motion}: at any cut-off that passes the motion the encoder noise in the "
            f"acceleration exceeds {_g(100 * NOISE_SHARE)} % of the motion's"
        )
    else:
        fc = _down2(float(noise_cutoff_hz))
        more = "" if band is None else f", {_g(fc / band)} x {motion}"
        why = (
            f"where the encoder noise in the acceleration reaches {_g(100 * NOISE_SHARE)} % of the motion's, "
            f"below the usual {_g(base)} Hz{more}"
        )
    return fc, f"cut-off {_g(fc)} Hz: {why}"


def default_drop(fs: float, cutoff_hz: float, q=None) -> tuple[int, str]:
    """Samples dropped at each end for the cut-off and the logs' ends `q` (N, joints): where the filter's
    start-up has decayed below `EDGE_TOL` of the motion's acceleration (`edge_transient`), at least
    `SETTLE_PERIODS` of the cut-off's period; and why."""
    floor = SETTLE_PERIODS * fs / cutoff_hz
    size = 0.0 if q is None else edge_transient(fs, q, cutoff_hz)
    sigma = 2 * np.pi * cutoff_hz * math.sin(math.pi / 8)  # the Butterworth's slowest pole's decay rate, 1/s
    settle = fs * math.log(size / EDGE_TOL) / sigma if size > EDGE_TOL else 0.0
    drop = max(1, math.ceil(max(floor, settle) * (1 - RATE_TOLERANCE)))
    why = f"{drop} samples ({_g(1e3 * drop / fs)} ms) dropped at each end: "
    if settle > floor:
        return drop, why + (
            f"the logs start or end in motion, and the {_g(cutoff_hz)} Hz filter's start-up in the acceleration "
            f"({_g(size)} x the motion's rms) takes that long to fall below {_g(100 * EDGE_TOL)} % of it"
        )
    return (
        drop,
        why + f"{_g(SETTLE_PERIODS)} periods of the {_g(cutoff_hz)} Hz cut-off, the zero-phase filter's transients",
    )


def default_decimate(fs: float, cutoff_hz: float, samples: int, drop: int) -> tuple[int, str]:
    """The decimation for the cut-off: the decimated rate at least `DECIMATED_RATE` x the cut-off, at least
    `TARGET_ROWS` rows kept where the record allows; and why."""
    by_rate = max(1, math.floor(fs / (DECIMATED_RATE * cutoff_hz) * (1 + RATE_TOLERANCE)))
    by_rows = max(1, (samples - 2 * drop) // TARGET_ROWS)
    d = min(by_rate, by_rows)
    why = f"decimation {d}: the decimated rate {_g(fs / d)} Hz is at least {_g(DECIMATED_RATE)} x the cut-off"
    if by_rows < by_rate:
        why = f"decimation {d}: the most that keeps {TARGET_ROWS} rows of the {samples - 2 * drop} samples"
    elif d == 1:
        why = f"no decimation: the sampling rate {_g(fs)} Hz is below {_g(2 * DECIMATED_RATE)} x the cut-off"
    return d, why


def _as_int(name: str, v, lo: int) -> int:
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
        what = "a non-negative integer" if lo == 0 else f"an integer >= {lo}"
        raise OptionError(f"`{name}` must be {what}; got {v!r}")
    return int(v)


def _suggest(name: str, value, fs: float) -> str:
    return f"use `{name}`={value} (the default for these logs, {_g(fs)} Hz sampling) or leave it unset"


def _check_cutoff(fs: float, cutoff_hz, bandwidth_hz, noise_cutoff_hz=None) -> float:
    try:
        fc = float(cutoff_hz)
    except (TypeError, ValueError):
        raise OptionError(f"`cutoff_hz` must be a frequency (Hz); got {cutoff_hz!r}") from None
    if not (np.isfinite(fc) and fc > 0):
        raise OptionError(f"`cutoff_hz` must be a positive frequency (Hz); got {cutoff_hz!r}")
    nyq = fs / 2
    if fc >= NYQUIST_LIMIT * nyq * (1 - 1e-12):
        ok = default_cutoff(fs, bandwidth_hz, noise_cutoff_hz)[0]
        raise OptionError(
            f"`cutoff_hz` = {_g(fc)} Hz is at or above {_g(100 * NYQUIST_LIMIT)} % of the Nyquist frequency "
            f"{_g(nyq)} Hz of these logs ({_g(fs)} Hz sampling); " + _suggest("cutoff_hz", _g(ok), fs)
        )
    return fc


def _check_drop(fs: float, n: int, fc: float, drop) -> int:
    drop = _as_int("drop", drop, 0)
    if n - 2 * drop < MIN_ROWS:
        ok = default_drop(fs, fc)[0]
        tip = _suggest("drop", ok, fs) if n - 2 * ok >= MIN_ROWS else "the record is too short for this cut-off"
        raise OptionError(
            f"`drop` = {drop} samples at each end leaves {max(n - 2 * drop, 0)} of the {n} samples (at least "
            f"{MIN_ROWS} needed); {tip}"
        )
    return drop


def _check_decimate(fs: float, n: int, fc: float, drop: int, decimate) -> int:
    decimate = _as_int("decimate", decimate, 1)
    rows = -(-(n - drop) // decimate) - -(-drop // decimate)  # robot_idim_ls: the end's drop too
    if rows < MIN_ROWS:
        what = f"leaves {rows} rows of the {n - 2 * drop} samples kept (at least {MIN_ROWS} needed)"
    elif fs / (2 * decimate) <= fc * (1 + 1e-12):
        what = (
            f"brings the sampling rate to {_g(fs / decimate)} Hz, whose Nyquist frequency "
            f"{_g(fs / (2 * decimate))} Hz is at or below the cut-off {_g(fc)} Hz"
        )
    else:
        return decimate
    ok = default_decimate(fs, fc, n, drop)[0]
    raise OptionError(f"`decimate` = {decimate} {what}; " + _suggest("decimate", ok, fs))


def _check_min_speed(min_speed, peak_speeds, speed_units) -> None:
    if isinstance(min_speed, str):
        if min_speed != "auto":
            raise OptionError(f"`min_speed` must be 'auto' or a speed >= 0 (rad/s); got {min_speed!r}")
        return
    try:
        v = float(min_speed)
    except (TypeError, ValueError):
        v = math.nan
    if isinstance(min_speed, bool) or not (np.isfinite(v) and v >= 0):
        raise OptionError(f"`min_speed` must be 'auto' or a speed >= 0 (rad/s); got {min_speed!r}")
    slow = {k: s for k, s in (peak_speeds or {}).items() if np.isfinite(s) and s <= v}
    if slow:
        units = speed_units or {}
        listed = [f"{k} ({_g(s)} {units.get(k, 'rad/s')})" for k, s in slow.items()]
        listed = listed[0] if len(listed) == 1 else ", ".join(listed[:-1]) + " and " + listed[-1]
        raise OptionError(
            f"`min_speed` = {_g(v)} is at or above the peak speed of {listed}: no sample of "
            f"{'it' if len(slow) == 1 else 'them'} would count as moving; use `min_speed`='auto' "
            f"({_g(100 * REST_FRACTION)} % of each joint's peak speed) or leave it unset"
        )


def check_processing(
    fs: float,
    n_samples: int,
    *,
    cutoff_hz,
    decimate,
    drop,
    bandwidth_hz: float | None = None,
    noise_cutoff_hz: float | None = None,
    min_speed=MIN_SPEED,
    peak_speeds: Mapping[str, float] | None = None,
    speed_units: Mapping[str, str] | None = None,
) -> None:
    """Refuse (`OptionError`) processing options that cannot work on `n_samples` samples at `fs` Hz.

    - `cutoff_hz` at or above `NYQUIST_LIMIT` (80 %) of the Nyquist frequency fs / 2;
    - dropped ends (`drop` samples at each end) that leave fewer than `MIN_ROWS` samples;
    - a `decimate` that leaves fewer than `MIN_ROWS` rows, or whose Nyquist frequency fs / (2 decimate) is at
      or below the cut-off;
    - a `min_speed` other than "auto" or a speed >= 0, or at or above a moving joint's peak speed
      (`peak_speeds`: name -> speed, rad/s or the unit in `speed_units`).

    The messages give the numbers to 3 significant digits and the value the
    defaults would take (`processing_defaults`; `bandwidth_hz`: the motion's band, `noise_cutoff_hz`: the
    noise-limited cut-off where the defaults follow it).
    """
    fs, n = float(fs), int(n_samples)
    fc = _check_cutoff(fs, cutoff_hz, bandwidth_hz, noise_cutoff_hz)
    drop = _check_drop(fs, n, fc, drop)
    _check_decimate(fs, n, fc, drop, decimate)
    _check_min_speed(min_speed, peak_speeds, speed_units)


def processing_defaults(
    t_or_dt,
    q,
    *,
    cutoff_hz: float | None = None,
    decimate: int | None = None,
    drop: int | None = None,
    min_speed=MIN_SPEED,
    noise_limited: bool = False,
    names: Sequence[str] | None = None,
    prismatic: Sequence[bool] | None = None,
) -> Processing:
    """The processing of joint logs sampled at `t_or_dt` with joint positions `q`: given values kept, the others
    from the sampling rate and the motion (module docstring), all checked (`check_processing`).

    **Arguments:** `t_or_dt` (the sample time, s, or the time stamps (N,)),
    `q` ((N,) or (N, joints), rad or m); `cutoff_hz` (Hz), `decimate`,
    `drop` (samples at each end), `min_speed` ("auto" or rad/s): None for
    the default; `noise_limited`: lower the default cut-off to where the
    encoder noise in the acceleration reaches 1 % of the motion's
    (`Processing.noise_cutoff_hz`; off by default: it keeps the TX40 papers'
    processing on their logs); `names`, `prismatic` (per joint) label the
    messages.

    **Returns:** a `Processing` (values, reasons). Raises `OptionError` for
    a given value that cannot work on these logs; ValueError for logs too
    short for any processing.

    Example:
        >>> import numpy as np
        >>> from jaxsdp.plants.robot._defaults import processing_defaults
        >>> t = np.arange(0, 30, 0.01)  # 100 Hz
        >>> p = processing_defaults(0.01, np.sin(2 * np.pi * 0.5 * t))
        >>> p.cutoff_hz, p.decimate, p.drop  # the record starts at speed: more than 2 periods of 20 Hz dropped
        (20.0, 1, 18)
    """
    fs = _sampling_rate(t_or_dt)
    qa = joint_angles(q)
    n, m = qa.shape
    names = tuple(f"joint {k}" for k in range(1, m + 1)) if names is None else tuple(names)
    prismatic = (False,) * m if prismatic is None else tuple(bool(v) for v in prismatic)
    if len(names) != m or len(prismatic) != m:
        raise ValueError(f"`names` and `prismatic` must have one entry per joint ({m})")
    _check_min_speed(min_speed, None, None)
    bands, limits = motion_spectrum(fs, qa)
    moving = np.isfinite(bands)
    band = float(bands[moving].max()) if moving.any() else None
    noise_hz = float(limits[moving].min()) if moving.any() else None
    rule = (band, noise_hz if noise_limited else None)
    reasons, warnings = {}, []
    if cutoff_hz is None:
        fc, reasons["cutoff_hz"] = default_cutoff(fs, *rule)
        if band is not None and (fc < BAND_FACTOR * band or (noise_limited and noise_hz < BAND_FACTOR * band)):
            warnings.append(reasons["cutoff_hz"])
    else:
        fc, reasons["cutoff_hz"] = _check_cutoff(fs, cutoff_hz, *rule), _GIVEN
        if band is not None and fc < 0.5 * BAND_FACTOR * band:
            warnings.append(
                f"the cut-off {_g(fc)} Hz is below {_g(0.5 * BAND_FACTOR)} x the motion's 99 % velocity band "
                f"{_g(band)} Hz: the filter distorts the motion (the default for these logs: "
                f"{_g(default_cutoff(fs, *rule)[0])} Hz)"
            )
    if drop is None:
        if n < MIN_ROWS + 2:
            raise ValueError(f"the logs have {n} samples: too short for an identification (at least {MIN_ROWS})")
        settled, reasons["drop"] = default_drop(fs, fc, qa)
        drop = settled
        if n - 2 * drop < MIN_ROWS:
            drop = (n - MIN_ROWS) // 2
            reasons["drop"] = f"{drop} samples dropped at each end: the most that keeps {MIN_ROWS} samples"
    else:
        drop, reasons["drop"] = _check_drop(fs, n, fc, drop), _GIVEN
        settled = default_drop(fs, fc, qa)[0]
    if drop < settled:
        warnings.append(
            f"{drop} samples dropped at each end, fewer than the {settled} ({_g(1e3 * settled / fs)} ms) the "
            f"{_g(fc)} Hz filter's start-up needs at these logs' ends: the acceleration there is wrong and biases "
            "the estimates" + (f" (use `drop`={settled} or leave it unset)" if reasons["drop"] == _GIVEN else "")
        )
    if decimate is None:
        decimate, reasons["decimate"] = default_decimate(fs, fc, n, drop)
    else:
        reasons["decimate"] = _GIVEN
    peaks = _peak_speeds(fs, qa, fc)
    units = {k: "m/s" if p else "rad/s" for k, p in zip(names, prismatic)}
    peak_map = {k: float(v) for k, v, b in zip(names, peaks, bands) if np.isfinite(b)}
    check_processing(
        fs,
        n,
        cutoff_hz=fc,
        decimate=decimate,
        drop=drop,
        bandwidth_hz=band,
        noise_cutoff_hz=rule[1],
        min_speed=min_speed,
        peak_speeds=peak_map,
        speed_units=units,
    )
    reasons["min_speed"] = (
        f"rest threshold 'auto': {_g(100 * REST_FRACTION)} % of each joint's peak speed, at least "
        f"{_g(MIN_REST_SPEED)} rad/s"
        if isinstance(min_speed, str)
        else _GIVEN
    )
    return Processing(
        cutoff_hz=fc,
        decimate=int(decimate),
        drop=int(drop),
        reasons={k: reasons[k] for k in ("cutoff_hz", "decimate", "drop", "min_speed")},
        min_speed=min_speed,
        fs=fs,
        samples=n,
        bandwidth_hz=band,
        bands=tuple(float(b) for b in bands),
        noise_cutoff_hz=noise_hz,
        peak_speeds=tuple(float(v) for v in peaks),
        warnings=tuple(warnings),
    )
