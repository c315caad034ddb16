"""Pieces both TX40 output modules use: named estimates, the whiteness record, a plain-text table.

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
    test's level).
    """
    return {
        "lag1": float(w.lag1),
        "band": [float(w.null[0] - w.band[0]), float(w.null[0] + w.band[0])],
        "null_lag1": float(w.null[0]),
        "ljung_box_q": float(w.q),
        "p_value": float(w.p_value),
        "white": bool(w.white),
        "lags": int(np.shape(w.lags)[0]),
    }


def named_estimates(res) -> tuple[dict, dict]:
    """`({name: estimate}, {name: relative standard deviation in %})` of a result with `names`,
    `theta` and `rel_std` (an IDIM-LS result or a multi-SDP curve's parametric projection)."""
    names = list(res.names)
    return (
        dict(zip(names, np.asarray(res.theta, dtype=float).tolist())),
        dict(zip(names, np.asarray(res.rel_std, dtype=float).tolist())),
    )


def text_table(header, rows) -> str:
    """A console table: `header` and `rows` (tuples of the same length) in left-aligned columns."""
    widths = [max(len(str(r[c])) for r in [header, *rows]) for c in range(len(header))]
    fmt = lambda r: "  ".join(str(v).ljust(w) for v, w in zip(r, widths)).rstrip()
    return "\n".join([fmt(header)] + [fmt(r) for r in rows])
