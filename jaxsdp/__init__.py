"""jaxsdp: differentiable state-dependent parameter identification in JAX.

Every public entry point computes in float64 (it runs under
`jax.enable_x64(True)`); importing jaxsdp does not change global JAX config.
"""

__version__ = "0.1.0"
