r"""The EMPS identification pipeline as one pure JAX Module: record in, fit out.

`EMPSPipeline(...)(data)` runs the study's stages on one `EMPSData` record:

1. the processing (`Preprocessing`: derivatives, drop, decimation);
2. IDIM-LS with the linear friction model (M, Fv, Fc, offset) and with the
   asymmetric model of eqs. (17)-(18) (parallel decimation, `emps_regression`),
   the asymmetric one also with the Newey-West covariance;
3. optionally the iterated IDIM-IV (`IDIMIV`), its instruments from the
   model simulated noise-free in the record's closed loop (reference `qg`,
   controller gains `kp`, `kv`, `gtau`, from the first position reading) and
   processed like the measurement (`iv_instruments`);
4. optionally the SDP stage (`Backfitting`, eq. 13: $y = M(\ddot q)\ddot q + d_{fric}(\dot q) + e$),
   its acceleration-weighted mass, and IDIM-SDP (the friction curve regressed
   on the eq. (17) basis).

It is pure: it jits, `jax.vmap`s over records (a batch of records with the same
length and sample time) and differentiates (`jax.grad` of any field of the fit
with respect to the record, or to an experiment that made it). Nothing in it
prints, warns or raises on values: the study's diagnosis reads the fit.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from ..._checks import nonfinite_handled
from ..._idim.estimators import IDIMIV, IDIMLS, IVFit, NeweyWest, iv_iterate
from ..._idim.iv import relative_error
from ..._idim.ls import IDIMResult
from ..._records import EMPSData
from ..._runtime import x64
from ..._sdp.backfit import SDPResult
from ..._sdp.options import Backfitting
from ..._signal.preprocess import Preprocessed, Preprocessing
from .._trajectories import encoder_quantum
from ._diagnosis import EMPSFits, fits_from
from ._idim_iv import asymmetric_plant, closed_loop, iv_instruments
from ._model import emps_regression
from ._plant import EMPSController, simulate_closed_loop
from ._sdp_stage import sdp_regression, stage_options, weighted_mass

__all__ = ["EMPSPipeline", "EMPSFit", "EMPSExperiment", "asymmetric_plant"]


class EMPSFit(eqx.Module):
    r"""What `EMPSPipeline` returns (arrays only; batched under `vmap`).

    **Fields:** `inputs` (the `Preprocessed` record), `idim` (IDIM-LS, linear
    friction: M kg, Fv N s/m, Fc N, offset N), `idim_asym` (IDIM-LS,
    asymmetric: M, Fv_pos, Fc_pos, Fv_neg, Fc_neg, with the pipeline's
    covariance), `idim_asym_hac` (the same estimate with the Newey-West
    covariance, Andrews' automatic bandwidth, whatever `ls` says), `idim_iv`
    (`IVFit`, or None), `sdp` (the `SDPResult`: term 0
    the mass $M(\ddot q)$, term 1 the friction $d_{fric}(\dot q)$; or None),
    `sdp_mass` (kg, $\sum_k M_k \ddot q_k^2 / \sum_k \ddot q_k^2$), `idim_sdp`
    (the friction curve's fit on the eq. (17) basis: Fv_pos, Fc_pos, Fv_neg,
    Fc_neg; the white-residual covariance, as the paper's Table 2),
    `idim_sdp_relative_error` (%, of the IDIM-SDP model on the force).
    """

    inputs: Preprocessed
    idim: IDIMResult
    idim_asym: IDIMResult
    idim_asym_hac: IDIMResult
    idim_iv: IVFit | None
    sdp: SDPResult | None
    sdp_mass: Float[Array, ""] | None
    idim_sdp: IDIMResult | None
    idim_sdp_relative_error: Float[Array, ""] | None

    @property
    @x64
    def idim_sdp_theta(self) -> Array | None:
        """(M, Fv_pos, Fc_pos, Fv_neg, Fc_neg) of IDIM-SDP: the SDP mass and the friction curve's fit."""
        if self.idim_sdp is None:
            return None
        return jnp.concatenate([self.sdp_mass[..., None], self.idim_sdp.theta], axis=-1)


class EMPSPipeline(eqx.Module):
    r"""The EMPS identification study's estimation, pure: `EMPSPipeline(...)(data) -> EMPSFit`.

    **Fields** (option objects; the defaults are the study's):

    - `preprocessing`: a `Preprocessing` (Butterworth order 4 at 100 Hz, 49
      samples dropped, decimation by 10: the benchmark's).
    - `ls`: the IDIM-LS estimator, `IDIMLS(cov=IID())` (the paper's
      $\hat\sigma^2 (X^T X)^{-1}$).
    - `iv`: `IDIMIV(...)` for the iterated bias-compensated IDIM-IV of the
      asymmetric model, or None (default, as the study's `iv=None`: IDIM-LS only).
    - `sdp`: `Backfitting(...)` for the SDP stage and IDIM-SDP (default: RW
      terms, ML NVRs capped at 1), or None.

    `data` is an `EMPSData` (its `dt` static; a batch of records under `vmap`
    shares it). The IV needs its reference `qg` and controller gains.

    Example:
        >>> import jax
        >>> from jaxsdp.data import emps_builtin_data
        >>> from jaxsdp.plants.emps import EMPSPipeline
        >>> data, truth, _ = emps_builtin_data(0)
        >>> fit = jax.jit(EMPSPipeline(sdp=None))(data)
        >>> round(float(fit.idim_asym.theta[0]), 1)  # M, kg; truth 95.15
        95.4
    """

    preprocessing: Preprocessing = Preprocessing()
    ls: IDIMLS = IDIMLS()
    iv: IDIMIV | None = None
    sdp: Backfitting | None = Backfitting()

    def __check_init__(self):
        for name, kind in (("preprocessing", Preprocessing), ("ls", IDIMLS)):
            if not isinstance(getattr(self, name), kind):
                raise ValueError(f"`{name}` must be a jaxsdp.{kind.__name__}; got {getattr(self, name)!r}")
        if self.iv is not None and not isinstance(self.iv, IDIMIV):
            raise ValueError(f"`iv` must be a jaxsdp.IDIMIV or None; got {self.iv!r}")
        if self.sdp is not None and not isinstance(self.sdp, Backfitting):
            raise ValueError(f"`sdp` must be a jaxsdp.Backfitting or None; got {self.sdp!r}")

    @x64
    def diagnose(self, fit: "EMPSFit", *, search_se=None) -> EMPSFits:
        """The host-side reading of one fit of this pipeline (not a batch): `fits_from` on these options. Its
        `EMPSFits` holds the fits rank-checked, the SDP stage (NVR bounds, standard errors, whether the mass is
        constant) and IDIM-SDP; `.checks()` and `.scales(fit.inputs)` give the warnings (signs, conditioning,
        NVRs on a bound, a record that ends in motion, scales against physics). Needs the SDP stage (`sdp` not
        None). After a `CaptainNVR` search (`Backfitting.searched`), the study passes the search's options and its
        standard errors to `fits_from` itself."""
        if self.sdp is None:
            raise ValueError("`diagnose` reads the SDP stage: make the pipeline with `sdp=Backfitting(...)`")
        if not isinstance(fit, EMPSFit) or jnp.ndim(fit.idim.theta) != 1:
            raise ValueError("`fit` must be one EMPSFit (index a batch first: jax.tree.map(lambda x: x[i], fits))")
        return fits_from(fit, search_se=search_se, **stage_options(self.sdp))

    @x64
    def process(self, data: EMPSData) -> Preprocessed:
        """The record's processed signals (`preprocessing` on `qm`, `force` at `dt`)."""
        return self.preprocessing._run(data.qm, data.force, data.dt)

    @x64
    def __call__(self, data: EMPSData) -> EMPSFit:
        if not isinstance(data, EMPSData):
            raise ValueError(f"`data` must be an EMPSData; got {type(data).__name__}")
        return self._estimate(self.preprocessing._run(data.qm, data.force, data.dt), data)

    @x64
    def estimate(self, inputs: Preprocessed, data: EMPSData | None = None) -> EMPSFit:
        """The estimation on processed signals `inputs` (`process(data)`); `data`, the record they came from, is
        needed by the IV only (its closed loop), else it may be None."""
        return self._estimate(inputs, data)

    def _estimate(self, inputs: Preprocessed, data: EMPSData | None) -> EMPSFit:
        if self.iv is not None and not isinstance(data, EMPSData):
            raise ValueError(
                "IDIM-IV simulates the record's closed loop to build its instruments: pass the EMPSData record "
                "(its reference qg and controller gains)"
            )
        lin = emps_regression(inputs, friction="linear")
        asym = emps_regression(inputs, friction="asymmetric")
        idim_asym = self.ls._solve(asym.y, asym.X, asym.names)
        fit = dict(
            inputs=inputs,
            idim=self.ls._solve(lin.y, lin.X, lin.names),
            idim_asym=idim_asym,
            idim_asym_hac=IDIMLS(NeweyWest())._solve(asym.y, asym.X, asym.names),
            idim_iv=None,
            sdp=None,
            sdp_mass=None,
            idim_sdp=None,
            idim_sdp_relative_error=None,
        )
        if self.iv is not None:
            compensate = self.iv.compensate

            def instruments(theta):
                sim = closed_loop(data, asymmetric_plant(theta))
                with nonfinite_handled():  # a diverged loop's NaN instruments stop `iv_iterate` as failed
                    processed = self.process_like(data, sim)
                    return iv_instruments(processed, theta, compensate=compensate)

            fit["idim_iv"] = iv_iterate(asym.y, asym.X, instruments, idim_asym.theta, asym.names, self.iv)
        if self.sdp is not None:
            res = self.sdp._fit(*sdp_regression(inputs))
            mass = weighted_mass(res.par[:, 0], inputs.ddq)
            basis = asym.X[:, 1:]
            curve = IDIMLS()._solve(res.par[:, 1], basis, asym.names[1:])
            fit.update(
                sdp=res,
                sdp_mass=mass,
                idim_sdp=curve,
                idim_sdp_relative_error=relative_error(asym.y, asym.X, jnp.concatenate([mass[None], curve.theta])),
            )
        return EMPSFit(**fit)

    @x64
    def process_like(self, data: EMPSData, sim) -> Preprocessed:
        """A simulation of the record's closed loop processed like the record (for the IV's instruments)."""
        return self.preprocessing._run(sim.q, sim.force, data.dt)


class EMPSExperiment(eqx.Module):
    r"""One noisy closed-loop experiment on an EMPS plant: `EMPSExperiment(reference, dt=...)(key, theta) -> EMPSData`.

    The plant `theta` = (M kg, Fv_pos N s/m, Fc_pos N, Fv_neg N s/m, Fc_neg N)
    (`asymmetric_plant`) runs in the benchmark's closed loop (`controller`,
    one-sample delay) following `reference` (m, sampled every `dt` s), from rest
    at `reference[0]`. The controller reads the position with white noise of
    `position_noise` encoder counts (std) quantised to `quantum` m (one count,
    5e-8 m, by default; 0: no quantisation, which `jax.grad` with respect to the
    experiment needs); the recorded force carries white noise of `force_noise` N
    (std; it does not enter the loop). The noise is drawn from `key`.

    Pure: `jax.vmap` over keys and plants makes a Monte Carlo's records, and
    `jax.grad` passes through it to the reference and the noise levels (the
    design of an experiment). It holds the reference array: jit it with
    `eqx.filter_jit` (or pass it as an argument), not `jax.jit(experiment)`.
    """

    reference: Float[Array, " N"]
    dt: float = eqx.field(static=True)
    controller: EMPSController = EMPSController()
    position_noise: float = 1.0
    force_noise: float = 0.5
    quantum: float = eqx.field(static=True, default=encoder_quantum())

    @x64
    def __call__(self, key, theta) -> EMPSData:
        qg = jnp.asarray(self.reference, dtype=jnp.float64)
        n = qg.shape[0]
        kq, kf = jax.random.split(key)
        t = jnp.arange(n) * self.dt
        noise = self.position_noise * encoder_quantum() * jax.random.normal(kq, (n,))
        ctrl = self.controller
        sim = simulate_closed_loop(
            qg, t, self.dt, asymmetric_plant(theta), ctrl, qg[0], 0.0, 0.0, noise, self.quantum, 1
        )
        force = sim.force + self.force_noise * jax.random.normal(kf, (n,))
        return EMPSData(
            t=t, qm=sim.q_meas, qg=qg, vir=sim.vir, force=force, gtau=ctrl.gtau, kp=ctrl.kp, kv=ctrl.kv, dt=self.dt
        )
