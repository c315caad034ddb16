"""What the Monte Carlo studies and their presentation share: names, constants and the SDP-PD's wn.

The result modules (`_identification`, `_control`, `_robot`) import their
presentation modules (`_report`, `_figures`, `_robot_report`); those take
what they need from here, never from the result modules, so that the
imports form no circle.
"""

from ...plants.emps._model import EMPS_ASYM_NAMES, EMPS_LINEAR_NAMES
from .._contract import fast_loops, versions

# --- identification ---------------------------------------------------------
ASYM_NAMES = EMPS_ASYM_NAMES
LINEAR_NAMES = EMPS_LINEAR_NAMES
#: Estimators compared, with their parameter names and covariance.
ESTIMATORS = {
    "idim_ls": ("IDIM-LS, linear friction (iid)", LINEAR_NAMES),
    "idim_ls_asym": ("IDIM-LS, asymmetric (iid, the paper's)", ASYM_NAMES),
    "idim_ls_asym_hac": ("IDIM-LS, asymmetric (Newey-West)", ASYM_NAMES),
    "idim_iv": ("IDIM-IV, bias-compensated (Newey-West)", ASYM_NAMES),
    "idim_sdp": ("IDIM-SDP (curve fit)", ASYM_NAMES),
}
Z95 = 1.959963984540054
#: Coverage of the stated 95 % intervals below which an estimator's intervals are called dishonest.
MIN_COVERAGE = 0.90

# --- control ----------------------------------------------------------------
PARAMETERS = EMPS_ASYM_NAMES  # the drawn plant (M, Fv+, Fc+, Fv-, Fc-), the order of the IDIM-LS covariance
CONTROLLERS = ("linear_pd", "sdp_pd", "pip_sdp")
METRICS = ("settling_time_s", "overshoot_pct", "peak_velocity", "peak_force")
#: Samples of each PIP-SDP step response kept for the envelope figure (every `ENVELOPE_STRIDE`-th).
ENVELOPE_STRIDE = 10
#: How the warnings name the controllers.
LABELS = {"linear_pd": "linear PD", "sdp_pd": "SDP-PD", "pip_sdp": "PIP-SDP"}


def sdp_pd_wn(nominal, settings, drive: str) -> float:
    """The SDP-PD's wn (rad/s) under `drive`: the settings' (ideal drive) or `nominal.wn_real` (real drive)."""
    return float(nominal.wn_real) if drive == "real" else settings.wn


def run_record(out, seed: int) -> dict:
    """The fields every Monte Carlo result shares, from the runner's output `out` (`jaxsdp.monte_carlo`): the
    seed, runs, devices, chunk size, seconds and runs per second, the study's timing (s), the versions and the
    fast-loop status."""
    return dict(
        seed=int(seed),
        runs=out.runs,
        devices=out.devices,
        chunk_size=out.chunk_size,
        seconds=out.seconds,
        runs_per_second=out.runs_per_second,
        timings={"study": float(out.seconds)},
        versions=versions(),
        fast_loops=fast_loops(),
    )
