"""What the control study and its presentation both use: the paper's model (30) and the stability test of a
step response (in a module of their own, so that the report and the figures need not import the study)."""

import numpy as np

#: The paper's model (30) of the SDP-PD loop at 0.01 s (its third numerator term is z^-3): `num`, `den` in z^-1.
PAPER_MODEL = dict(num=[0.0, 0.0107, -0.0088, 0.0025], den=[1.0, -1.8660, 0.8706])


def bounded_response(q, y0, target) -> bool:
    """The study's stability test of a step response: finite, and within 10 steps of its start y0."""
    q = np.asarray(q, dtype=float)
    return bool(np.all(np.isfinite(q)) and np.max(np.abs(q - y0)) < 10 * max(abs(float(target) - y0), 1e-12))
