"""spaceopt: indirect optimisation of perturbed low-thrust transfers and discrete control studies.

float64 is switched on here, once, for the whole package (design.md, "Conventions").
"""
import os

import jax

jax.config.update("jax_enable_x64", True)
# Persistent XLA compilation cache: every Snakemake job is a new process, and the shooting maps
# take ~10 s each to compile; the cache makes that a one-time cost per machine.
jax.config.update("jax_compilation_cache_dir",
                  os.environ.get("SPACEOPT_JAX_CACHE", os.path.expanduser("~/.cache/spaceopt/jax")))
jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)

from . import artifacts  # noqa: E402,F401  (fixes the code version of every artifact at import)

__all__ = ["__version__"]
__version__ = "0.1.0"
