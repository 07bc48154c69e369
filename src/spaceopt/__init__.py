"""spaceopt: indirect optimisation of perturbed low-thrust transfers and discrete control studies.

float64 is switched on here, once, for the whole package (design.md, "Conventions").
"""
import jax

jax.config.update("jax_enable_x64", True)

__all__ = ["__version__"]
__version__ = "0.1.0"
