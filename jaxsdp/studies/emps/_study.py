r"""The EMPS identification study (paper section 2): IDIM-LS, SDP stage, IDIM-SDP.

Workflow on an EMPS-type record (position + force of one linear axis):

1. **Preprocessing** (`emps_preprocess`: the generic `jaxsdp.preprocess`
   with the benchmark's settings): velocity and acceleration by Butterworth
   filtering and central differences (or smoothing), first samples dropped,
   decimation.
2. **IDIM-LS** with the symmetric model `[ddq, dq, sign(dq), 1]` and the
   asymmetric model of eqs. (17)-(18) (`emps_regression` + `jaxsdp.idim_ls`:
   parallel decimation of the regressors, the published procedure).
3. **SDP stage** (`emps_sdp_stage`, eq. 13): $y_k = M(\ddot q_k)\,\ddot q_k +
   d_{fric}(\dot q_k)\cdot 1 + e_k$ with ML NVRs (regressors
   $z = [\ddot q, 1]$, states $x = [\ddot q, \dot q]$) on the decimated
   signals. A mass NVR below `constant_nvr` flags the mass as
   acceleration-independent.
4. **IDIM-SDP** (`emps_idim_sdp`, eq. 17, Table 2): the friction SDP curve
   regressed on $[O^+(\dot q), \operatorname{sign}O^+(\dot q), O^-(\dot q),
   \operatorname{sign}O^-(\dot q)]$, and the final IDIM-LS with the
   asymmetric model.

`emps_study` runs all stages with per-stage timings and returns an
`EMPSStudy` (tables, a JSON-ready `summary()`), the back end of the
`jaxsdp emps` command; `emps_figures` draws the paper's figures from it
and `report_markdown` its report.
"""

import os
import pathlib
import time
from collections.abc import Callable
from typing import Literal

import equinox as eqx
import jax
import numpy as np

from ..._idim.ls import IDIMResult, idim_ls
from ..._runtime import x64
from ..._sdp.backfit import CONSTANT_NVR
from ..._signal.preprocess import Preprocessed
from ...data._loaders import EMPSData, Measurements, load_emps, load_measurements
from ._idim_sdp import EMPSIDIMSDP, emps_idim_sdp
from ._preprocess import DROP, emps_preprocess, emps_regression
from ._sdp_stage import EMPSSDPStage, emps_sdp_stage


class EMPSStudy(eqx.Module):
    """All results of `emps_study`.

    **Fields:** `inputs` (`Preprocessed`), `idim` (IDIM-LS, symmetric model
    `M, Fv, Fc, offset`), `idim_asym` (IDIM-LS, asymmetric model), `sdp`
    (`EMPSSDPStage`), `idim_sdp` (`EMPSIDIMSDP`), `timings` (stage ->
    seconds: `load`, `derivatives`, `idim_ls`, `idim_ls_asym`, `sdp`,
    `idim_sdp`, `total`), `source` (file name or description), `samples`
    (raw samples), `sample_time` (raw sample time, s), `preprocessing`
    (description), `derivatives` ("butterworth" or "smooth").
    """

    inputs: Preprocessed
    idim: IDIMResult
    idim_asym: IDIMResult
    sdp: EMPSSDPStage
    idim_sdp: EMPSIDIMSDP
    timings: dict
    source: str = eqx.field(static=True)
    samples: int = eqx.field(static=True)
    sample_time: float = eqx.field(static=True)
    preprocessing: str = eqx.field(static=True)
    derivatives: str = eqx.field(static=True)

    def summary(self) -> dict:
        """JSON-ready dict: `idim_ls`, `idim_ls_asym`, `sdp`, `idim_sdp`, `timings`, `data`."""
        return study_summary(self)

    def tables(self) -> str:
        """The paper's Table 1 (IDIM-LS), the SDP stage and Table 2 (IDIM-SDP) as text."""
        return study_tables(self)


def _theta(r: IDIMResult) -> dict:
    return {n: float(v) for n, v in zip(r.names, np.asarray(r.theta, dtype=float))}


def study_summary(study: EMPSStudy) -> dict:
    """Plain-Python summary of an `EMPSStudy` (keys of the CLI's `summary.json`
    except `simulation`)."""
    i, a, s, p = study.idim, study.idim_asym, study.sdp, study.idim_sdp
    se = [None if not np.isfinite(v) else float(v) for v in np.asarray(s.log10_nvr_se, dtype=float)]
    return {
        "idim_ls": {**_theta(i), "relative_error": float(i.relative_error)},
        "idim_ls_asym": {
            **_theta(a),
            "relative_error": float(a.relative_error),
        },
        "sdp": {
            "nvr_mass": s.nvr_mass,
            "nvr_friction": s.nvr_friction,
            "log10_nvr_se": se,
            "mass_constant": bool(s.mass_constant),
            "mass": s.mass,
            "relative_error": s.relative_error,
            "model": s.model,
            "nvr_search": s.nvr_search,
            "sweeps": int(s.result.sweeps),
        },
        "idim_sdp": {
            **p.theta,
            "fv_ratio": p.fv_ratio,
            "relative_error": p.relative_error,
            "curve_fit_relative_error": float(p.friction.relative_error),
        },
        "timings": {k: float(v) for k, v in study.timings.items()},
        "data": {
            "source": study.source,
            "samples": int(study.samples),
            "sample_time": float(study.sample_time),
            "preprocessing": study.preprocessing,
            "decimated_samples": int(study.inputs.y.shape[0]),
            "decimated_sample_time": float(study.inputs.dt),
        },
    }


def study_tables(study: EMPSStudy) -> str:
    """Text tables of an `EMPSStudy`."""
    return "\n\n".join(
        [
            f"Data: {study.source}, {study.samples} samples, dt = {study.sample_time:g} s; {study.preprocessing}",
            "Table 1. IDIM-LS, linear friction model\n" + study.idim.table(),
            "IDIM-LS, asymmetric friction model (eq. 18)\n" + study.idim_asym.table(),
            study.sdp.table(),
            "Table 2. IDIM-SDP, asymmetric friction model (eq. 17)\n" + study.idim_sdp.table(),
        ]
    )


def _ready(tree):
    jax.block_until_ready(jax.tree.leaves(eqx.filter(tree, eqx.is_array)))
    return tree


def _load(data):
    if isinstance(data, (str, os.PathLike)):
        path = pathlib.Path(data)
        if path.suffix.lower() == ".mat":
            return load_emps(path), path.name
        return load_measurements(path), path.name
    if isinstance(data, (EMPSData, Measurements)):
        return data, type(data).__name__
    raise ValueError(f"`data` must be a path, an EMPSData or a Measurements; got {type(data).__name__}")


@x64
def emps_study(
    data,
    *,
    derivatives: Literal["butterworth", "smooth"] = "butterworth",
    cutoff_hz: float | None = 100.0,
    order: int = 4,
    smooth_nvr: float | None = None,
    drop: int = DROP,
    decimate: int = 10,
    mode: Literal["matlab", "scipy", "octave"] = "matlab",
    model="RW",
    nvr_search: Literal["captain", "sdp"] = "sdp",
    max_nvr: float | None = 1.0,
    constant_nvr: float = CONSTANT_NVR,
    source: str | None = None,
    progress: Callable[[str], None] | None = None,
) -> EMPSStudy:
    """Run the whole EMPS study with per-stage timings.

    **Arguments:**

    - `data`: a path (`.mat`: `jaxsdp.data.load_emps`; otherwise the CSV format of
      `jaxsdp.data.load_measurements`), an `EMPSData` or a `Measurements`.
    - `derivatives`: `"butterworth"` (standard: zero-phase Butterworth of
      `order` at `cutoff_hz`, central differences) or `"smooth"` (smoothing
      derivatives: `cutoff_hz`, or `smooth_nvr`,
      or ML if both are None).
    - `drop`, `decimate`, `mode`: border removal and decimation.
    - `model`, `nvr_search`, `max_nvr`, `constant_nvr`: the SDP stage
      (`emps_sdp_stage`).
    - `source`: description for the summary (default: file name or type).
    - `progress`: optional callback called with each stage name before it runs.

    Stages (keys of `timings`): `load` (0 unless `data` is a path),
    `derivatives`, `idim_ls`, `idim_ls_asym`, `sdp`, `idim_sdp`, and `total`.
    Times include JAX compilation the first time a shape is seen.
    """
    if derivatives not in ("butterworth", "smooth"):
        raise ValueError(f"`derivatives` must be 'butterworth' or 'smooth'; got {derivatives!r}")
    timings = {}
    note = progress if progress is not None else (lambda stage: None)

    def timed(stage, fn):
        note(stage)
        t0 = time.perf_counter()
        out = _ready(fn())
        timings[stage] = time.perf_counter() - t0
        return out

    start = time.perf_counter()
    data, name = timed("load", lambda: _load(data))
    inputs = timed(
        "derivatives",
        lambda: emps_preprocess(
            data,
            derivatives=derivatives,
            cutoff_hz=cutoff_hz,
            order=order,
            nvr=smooth_nvr if derivatives == "smooth" else None,
            drop=drop,
            decimate=decimate,
            mode=mode,
        ),
    )

    def ls(friction):
        reg = emps_regression(inputs, friction=friction)
        return idim_ls(reg.y, reg.X, names=reg.names)

    idim = timed("idim_ls", lambda: ls("linear"))
    idim_asym = timed("idim_ls_asym", lambda: ls("asymmetric"))
    stage = timed(
        "sdp",
        lambda: emps_sdp_stage(inputs, model=model, nvr_search=nvr_search, max_nvr=max_nvr, constant_nvr=constant_nvr),
    )
    idim_sdp = timed("idim_sdp", lambda: emps_idim_sdp(stage, inputs, asym=idim_asym))
    timings["total"] = time.perf_counter() - start
    return EMPSStudy(
        inputs=inputs,
        idim=idim,
        idim_asym=idim_asym,
        sdp=stage,
        idim_sdp=idim_sdp,
        timings=timings,
        source=name if source is None else source,
        samples=int(np.shape(data.force)[0]),
        sample_time=float(data.dt),
        preprocessing=inputs.description,
        derivatives=derivatives,
    )
