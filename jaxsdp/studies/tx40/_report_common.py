"""Pieces both TX40 output modules use: named estimates and the whiteness record.

`_report` (the paper's one-joint outputs) and `_report_full` (the full
six-joint model's section) both import from here, and `_report` imports
`_report_full`: the helpers live below both so that no import goes in a circle.
"""

import numpy as np


def whiteness_summary(w) -> dict:
    """summary.json's record of a `jaxsdp.Whiteness` test of the decimated residuals.

    Keys: `lag1` (the residual's lag-1 autocorrelation), `band` (the band
    of lag 1 at the test's level, around `null_lag1`: the lag-1 value that
    decimated white noise has by itself), `ljung_box_q` and `p_value` (the
    Ljung-Box test over `lags` lags), `white` (`p_value` at or above the
    test's level), `outside` (how many of the `lags` autocorrelations lie
    outside their band).
    """
    return {
        "lag1": float(w.lag1),
        "band": [float(w.null[0] - w.band[0]), float(w.null[0] + w.band[0])],
        "null_lag1": float(w.null[0]),
        "ljung_box_q": float(w.q),
        "p_value": float(w.p_value),
        "white": bool(w.white),
        "lags": int(np.shape(w.lags)[0]),
        "outside": int(w.outside),
    }


def named_estimates(res) -> tuple[dict, dict]:
    """`({name: estimate}, {name: relative standard deviation in %})` of a result with `names`,
    `theta` and `rel_std` (an IDIM-LS result or a multi-SDP curve's parametric projection)."""
    names = list(res.names)
    return (
        dict(zip(names, np.asarray(res.theta, dtype=float).tolist())),
        dict(zip(names, np.asarray(res.rel_std, dtype=float).tolist())),
    )
