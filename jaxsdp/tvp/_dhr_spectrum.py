"""The frequency-domain NVR estimate of a DHR (the toolbox's `dhropt` default): a fast start for the ML search.

Young, Pedregal & Tych (1999), "Dynamic harmonic regression", J. Forecasting 18: the DHR's pseudo-spectrum

    f(w) = sigma2 (1 + sum_j NVR_j g_j(w)),

white noise plus each component's spectrum, is fitted by least squares on the log scale to the AR spectrum of
the data. Here, host-side NumPy (no compilation):

- a block s_k = F s_{k-1} + eta_k, var(eta) = sigma2 Q(NVR), has theta = e1' (I - F L)^-1 eta, so its
  (pseudo-)spectrum per unit NVR is g(w) = e1' (I - F e^-iw)^-1 Q_1 (I - F e^-iw)^-H e1 (Q_1: Q at NVR 1 for that
  NVR, 0 for the others). Closed forms, with D(w) = 2 - 2 cos w = |1 - e^-iw|^2: RW 1/D; IRW 1/D^2;
  SRW(alpha) 1/(D (1 - 2 alpha cos w + alpha^2)); LLT 1/D for the level NVR, 1/D^2 for the slope NVR.
- a harmonic a_k cos(w_i k) + b_k sin(w_i k), a and b independent with the block's spectrum g, has the
  autocovariance r(tau) cos(w_i tau) whatever k, so its spectrum is (g(w - w_i) + g(w + w_i)) / 2 (the same at
  the Nyquist period 2, where only the cosine is there).
- the series is differenced once (the trend's pole at 0 left aside) and the AR spectrum of the differences
  (Burg, order by AIC) is compared with D(w) f(w) on a grid of frequencies in (0, pi) that keeps off the
  components' poles; sigma2 drops out of the centred log residuals; the log10 NVRs by bounded least squares.
"""

import numpy as np
from scipy.optimize import least_squares

#: Bounds of the spectral estimate's log10 NVRs (a start for ML, whose own bounds are wider).
SPECTRAL_LOG10_BOUNDS = (-10.0, 3.0)


def block_spectra(model, w) -> np.ndarray:
    """(n_nvr, len(w)) spectrum of a block's first state per unit NVR, one row per NVR of the block."""
    w = np.asarray(w, dtype=np.float64)
    F = np.asarray(model.transition(), dtype=np.float64)
    d = F.shape[0]
    rows = []
    for j in range(model.n_nvr):
        Q = np.asarray(model.noise(np.eye(model.n_nvr)[j]), dtype=np.float64)
        A = np.eye(d)[None] - F[None] * np.exp(-1j * w)[:, None, None]  # (I - F e^-iw)
        u = np.linalg.solve(np.swapaxes(A, 1, 2), np.broadcast_to(np.eye(d)[0], (len(w), d))[..., None])[..., 0]
        # u' = e1' A^-1; the spectrum is u' Q conj(u)
        rows.append(np.real(np.einsum("ki,ij,kj->k", u, Q, np.conj(u))))
    return np.array(rows).reshape(model.n_nvr, len(w))


def harmonic_spectra(model, w, omega) -> np.ndarray:
    """(n_nvr, len(w)) spectrum of a harmonic at frequency `omega` (rad/sample) whose amplitudes follow `model`."""
    w = np.asarray(w, dtype=np.float64)
    return 0.5 * (block_spectra(model, w - omega) + block_spectra(model, w + omega))


def burg_ar(x, max_order: int):
    """Burg AR fit of every order 0..max_order: (list of [1, a1..ap], prediction error variances)."""
    x = np.asarray(x, dtype=np.float64) - np.mean(x)
    n = len(x)
    f, b = x[1:].copy(), x[:-1].copy()
    a = np.array([1.0])
    E = float(np.dot(x, x) / n)
    coefs, errs = [a], [E]
    for _ in range(max_order):
        den = float(np.dot(f, f) + np.dot(b, b))
        k = -2.0 * float(np.dot(f, b)) / den if den > 0 else 0.0
        ext = np.concatenate([a, [0.0]])
        a = ext + k * ext[::-1]
        E *= 1.0 - k * k
        f, b = (f + k * b)[1:], (b + k * f)[:-1]
        coefs.append(a)
        errs.append(E)
        if len(f) < 2:
            break
    return coefs, np.array(errs)


def ar_spectrum(x, w, *, max_order: int | None = None):
    """The AR spectrum E / |A(e^iw)|^2 of `x` (Burg, order by AIC up to `max_order`) and the order chosen."""
    n = len(x)
    max_order = min(max(n // 3, 1), 60) if max_order is None else max_order
    coefs, errs = burg_ar(x, max_order)
    p = np.arange(len(errs))
    aic = n * np.log(np.maximum(errs, 1e-300)) + 2.0 * p
    order = int(np.argmin(aic))
    a = coefs[order]
    A = np.exp(-1j * np.outer(w, np.arange(len(a)))) @ a
    return errs[order] / np.abs(A) ** 2, order


def _fill(y):
    """Linear interpolation over NaN samples (the edges held): the AR spectrum needs every sample."""
    y = np.asarray(y, dtype=np.float64)
    ok = np.isfinite(y)
    k = np.arange(len(y))
    return np.interp(k, k[ok], y[ok])


def spectral_design(models, index, omegas, n_nvr, w) -> np.ndarray:
    """(n_nvr, len(w)) spectrum per unit NVR of the DHR's components (`_dhr._Design`'s blocks), tied as `index`.

    `omegas`: the frequency of each block (0 for the trend); a harmonic's cos/sin pair counts once.
    """
    G = np.zeros((n_nvr, len(w)))
    slot = 0
    seen = set()
    for m, om in zip(models, omegas, strict=True):
        slots = tuple(index[slot : slot + m.n_nvr])
        slot += m.n_nvr
        if not slots or slots in seen:  # the sine block of a harmonic: its spectrum is already in the pair's
            continue
        seen.add(slots)
        g = harmonic_spectra(m, w, om) if om > 0 else block_spectra(m, w)
        for j, s in enumerate(slots):
            G[s] += g[j]
    return G


def spectral_nvr(y, models, index, omegas, n_nvr, *, n_freq: int = 512, max_order: int | None = None):
    """log10 NVRs of a DHR fitted in the frequency domain, and the fit's details (dict).

    Least squares between log S_ar(w) and log(D(w) sigma2 (1 + sum NVR_j g_j(w))) over the grid
    w = pi (j + 1/2) / n_freq, j = 0..n_freq-1, leaving out points within a quarter grid step of a pole.
    """
    x = np.diff(_fill(y))
    w = np.pi * (np.arange(n_freq) + 0.5) / n_freq
    poles = np.array([0.0, *[om for om in omegas if om > 0]])
    keep = np.min(np.abs(w[:, None] - poles[None, :]), axis=1) > 0.25 * np.pi / n_freq
    w = w[keep]
    S, order = ar_spectrum(x, w, max_order=max_order)
    logS = np.log(S)
    D = 2.0 - 2.0 * np.cos(w)
    G = spectral_design(models, index, omegas, n_nvr, w)

    def resid(b):
        r = logS - np.log(D * (1.0 + (10.0**b) @ G))
        return r - np.mean(r)  # log sigma2 concentrated out

    lo, hi = SPECTRAL_LOG10_BOUNDS
    sol = least_squares(resid, np.full(n_nvr, -3.0), bounds=(lo, hi), method="trf", x_scale=1.0)
    r = logS - np.log(D * (1.0 + (10.0**sol.x) @ G))
    info = {"order": order, "sigma2": float(np.exp(np.mean(r))), "cost": float(sol.cost), "nfev": int(sol.nfev)}
    return sol.x, info
