"""Shared test helpers."""

import os
import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
_NUMBER = r"([-+]?\d[\d,]*(?:\.\d+)?(?:e[-+]?\d+)?)"


def check_quoted(page: str, template: str, values, fmt: str) -> None:
    """Fail, naming the page, the quoted numbers and the fresh ones, unless `page` (relative to the repository,
    e.g. "docs/trust.md") prints `values` formatted with `fmt` where `template` says: the page's text with `{}`
    for each number, e.g. `check_quoted("docs/trust.md", "IDIM-LS | {} % | {} %", (a, b), ".3f")`.

    For numbers that a test computes and no saved result holds (issue 43): the test that measures them checks the
    page. Whitespace in the template matches any run of whitespace (line breaks included).
    """
    values = values if isinstance(values, (tuple, list)) else (values,)
    parts = [r"\s+".join(re.escape(w) for w in re.split(r"\s+", piece)) for piece in template.split("{}")]
    if len(parts) - 1 != len(values):
        raise ValueError(f"{template!r} has {len(parts) - 1} slots for {len(values)} values")
    pattern = _NUMBER.join(parts)
    text = (ROOT / page).read_text()
    found = [m.groups() for m in re.finditer(pattern, text)]
    fresh = tuple(format(v, fmt) for v in values)
    assert found, f"{page} no longer holds {template!r} (fresh values {', '.join(fresh)})"
    stale = [g for g in found if g != fresh]
    assert not stale, (
        f"{page} quotes {', '.join(stale[0])} where this test measures {', '.join(fresh)} ({template!r}); "
        "update the page"
    )


SHARED = pathlib.Path(
    os.environ.get("JAXSDP_SHARED", pathlib.Path(__file__).resolve().parents[1] / ".." / "shared")
).resolve()
EMPS_MAT = SHARED / "data" / "emps" / "DATA_EMPS.mat"
EMPS_DEC10_CSV = SHARED / "reference" / "emps_inputs_dec10.csv"

requires_emps = pytest.mark.skipif(
    not EMPS_MAT.exists(),
    reason=f"EMPS benchmark data not found at {EMPS_MAT} (set JAXSDP_SHARED to the shared/ folder)",
)
requires_emps_csv = pytest.mark.skipif(
    not EMPS_DEC10_CSV.exists(),
    reason=f"reference EMPS inputs not found at {EMPS_DEC10_CSV} (set JAXSDP_SHARED to the shared/ folder)",
)
TX40_DIR = SHARED / "data" / "tx40"
TX40_POSITIONS = TX40_DIR / "pos_read_data.csv"
TX40_CURRENTS = TX40_DIR / "curr_data.csv"

requires_tx40 = pytest.mark.skipif(
    not (TX40_POSITIONS.exists() and TX40_CURRENTS.exists()),
    reason=f"real TX40 joint logs not found in {TX40_DIR} (set JAXSDP_SHARED to the shared/ folder)",
)


def _example_robots():
    """The robots folder of the `example-robot-data` package (installed by pip under cmeel.prefix), or None."""
    import sys

    for entry in sys.path:
        for up in (pathlib.Path(entry), *pathlib.Path(entry).parents[:4]):
            cand = up / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
            if cand.is_dir():
                return cand
            cand = up / "share" / "example-robot-data" / "robots"
            if cand.is_dir():
                return cand
    return None


EXAMPLE_ROBOTS = _example_robots()
requires_example_robots = pytest.mark.skipif(
    EXAMPLE_ROBOTS is None, reason="example-robot-data not installed (pip install example-robot-data)"
)
TX40_URDF = TX40_DIR / "tx40_mdh_modified.urdf"
requires_tx40_urdf = pytest.mark.skipif(
    not TX40_URDF.exists(), reason=f"TX40 description not found at {TX40_URDF} (set JAXSDP_SHARED)"
)


def zoh_simulate(num, den, u, dt, delay=0):
    """Exact samples of num/den driven by the held input u (zero initial state), u delayed by `delay` samples.

    scipy's state-space ZOH discretisation (`dlsim`), independent of jaxsdp's
    filters: rounding stays near 1e-15 relative, where a high-order discrete
    transfer function with poles clustered near z = 1 would lose digits.
    """
    import numpy as np
    import scipy.signal as sig

    sys_d = sig.cont2discrete(sig.tf2ss(num, den), dt, method="zoh")
    u = np.r_[np.zeros(delay), u[: len(u) - delay]]
    return sig.dlsim((*sys_d[:4], dt), u)[1][:, 0]


def prbs(n_samples, hold, seed):
    """A random binary +-1 sequence held for `hold` samples (PRBS-like), ZOH between samples."""
    import numpy as np

    levels = np.random.default_rng(seed).choice([-1.0, 1.0], n_samples // hold + 1)
    return np.repeat(levels, hold)[:n_samples]


#: A two-joint planar arm (joint axes along z: no gravity torque) as a URDF, for command-line tests of robots.
ARM_URDF = """<robot name="arm">
  <link name="base"/>
  <link name="l1"><inertial><origin xyz="0.2 0 0"/><mass value="3.0"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.02"/></inertial></link>
  <link name="l2"><inertial><origin xyz="0.15 0.01 0"/><mass value="1.5"/>
    <inertia ixx="0.005" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
  <joint name="joint1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" velocity="2" effort="100"/></joint>
  <joint name="joint2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0.4 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-2" upper="2" velocity="2" effort="100"/></joint>
</robot>
"""


def two_link_arm(*, Fv=1.0, Fc=0.5, Ia=0.05):
    """The two-link planar arm of the robot tests (modified DH, under gravity): link 1 a point-like 3 kg at 0.2 m,
    link 2 1.5 kg with a small inertia; viscous `Fv`, Coulomb `Fc` friction and armature `Ia` on both joints."""
    import numpy as np

    from jaxsdp.plants import SerialRobot

    inertias = [(3.0, [0.2, 0, 0], np.zeros(6)), (1.5, [0.15, 0.02, 0], [0.01, 0, 0, 0.01, 0, 0.01])]
    return SerialRobot.from_mdh([[0, 0, 0, 0], [0, 0.4, 0, 0]], inertias=inertias, Fv=Fv, Fc=Fc, Ia=Ia)


def seasonal_series(n=144, *, seed=0, gaps=(40, 41, 97), noise=0.1):
    """A monthly-like series for the forecast tests: a trend, an annual cycle whose amplitude grows and its
    second harmonic, white noise of std `noise`, NaN at the samples `gaps` (those below n)."""
    import numpy as np

    k = np.arange(n, dtype=float)
    y = 10.0 + 0.05 * k + (1.0 + k / n) * np.cos(2 * np.pi * k / 12) + 0.3 * np.sin(2 * np.pi * k / 6)
    y = y + noise * np.random.default_rng(seed).standard_normal(n)
    y[[g for g in gaps if g < n]] = np.nan
    return y


def write_series_csv(path, y, *, start="2000-01", time="time", column="y", extra=None):
    """`y` as a CSV file with a monthly date column `time` from `start` (None: no time column), missing values as
    empty cells, and the columns of `extra` (name -> list of cells) after it; returns the path as a str."""
    import numpy as np

    cols = {} if time is None else {time: np.arange(np.datetime64(start, "M"), np.datetime64(start, "M") + len(y))}
    cols[column] = ["" if np.isnan(v) else repr(float(v)) for v in y]
    cols.update(extra or {})
    lines = [",".join(cols)] + [",".join(str(c[i]) for c in cols.values()) for i in range(len(y))]
    pathlib.Path(path).write_text("\n".join(lines) + "\n")
    return str(path)
