"""The refined instrumental variable iteration's options as one object (`RIVSolver`), shared by the family."""

import equinox as eqx
import numpy as np


class RIVSolver(eqx.Module):
    r"""How the refined IV family iterates: at most `max_iter` IV passes per stage (default 50, as CONTSID),
    stopping once $\|\theta_{new} - \theta_{old}\| / \|\theta_{new}\| <$ `tol` ($\theta$ in scaled time; default
    1e-4, as CONTSID) after one more pass (the iteration converges superlinearly on low-noise data: that pass takes
    noise-free estimates from about `tol`$^2$ to rounding); with `pem` (RIVCBJ and RIVBJ only) the IV estimate is
    then refined by minimising the prediction-error criterion $\sum_k \varepsilon_k^2$ by Levenberg-Marquardt
    (optimistix, at most `pem_steps` steps).

    `srivc(..., solver=RIVSolver(max_iter=100))`, `rivcbj(..., solver=RIVSolver(pem=True))`.
    """

    max_iter: int = eqx.field(static=True, default=50)
    tol: float = eqx.field(static=True, default=1e-4)
    pem: bool = eqx.field(static=True, default=False)
    pem_steps: int = eqx.field(static=True, default=100)

    def __check_init__(self):
        for name in ("max_iter", "pem_steps"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ValueError(f"`{name}` must be an integer >= 1; got {v!r}")
        if isinstance(self.tol, bool) or not isinstance(self.tol, (int, float)) or not 0 < self.tol < np.inf:
            raise ValueError(f"`tol` must be a finite number > 0; got {self.tol!r}")
        if not isinstance(self.pem, bool):
            raise ValueError(f"`pem` must be True or False; got {self.pem!r}")


def check_solver(solver, name: str, *, pem: bool = True) -> RIVSolver:
    """`solver` (None: `RIVSolver()`), checked; `pem` False for the white-noise estimators, which have none."""
    solver = RIVSolver() if solver is None else solver
    if not isinstance(solver, RIVSolver):
        raise ValueError(f"`solver` must be a jaxsdp.tfest.RIVSolver; got {type(solver).__name__}")
    if solver.pem and not pem:
        raise ValueError(
            f"`{name}` has no prediction-error refinement (`RIVSolver(pem=True)`); use `rivcbj` or `rivbj` with "
            "`nc` = `nd` = 0 (white noise) for it"
        )
    return solver
