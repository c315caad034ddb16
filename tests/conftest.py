# Import jaxsdp first so that its XLA-CPU fast-loop option (see jaxsdp._runtime)
# is in place before anything initialises JAX's backend.
import jaxsdp  # noqa: F401  isort: skip
import jax

jax.config.update("jax_enable_x64", True)
