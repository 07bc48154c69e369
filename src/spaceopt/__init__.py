"""spaceopt: indirect optimisation of perturbed low-thrust transfers and discrete control studies.

float64 is switched on here, once, for the whole package (design.md, "Conventions").

XLA's newer CPU fusion emitters are switched off for the process (``XLA_CPU_FLAG``, added to
``XLA_FLAGS`` unless the caller set that flag; XLA reads it when its backend starts, at the first
computation). Measured side by side (``benchmarks/perturbed.py --baseline``, paired medians of 20
rounds): a perturbed shooting evaluation (4×4 + Moon + Sun, trajectory and sensitivities) runs
1.27–1.44× faster with the other core busy, as when the DAG runs two jobs on 2 cores, and
0.94–1.10× on an idle machine; the unperturbed one 0.89–1.00× (the harness's spread). Same
results to round-off: identical step counts, the field to 4e-12 relative
(docs/perturbed-e6-e7-e8.md, "sixteenth session"). A process flag rather than per-function
compile options: jax refuses those on a jit nested in another, so ``jax.jit(jax.vmap(shoot))``
(benchmarks/sweep.py) would fail.
"""
import os
import sys

XLA_CPU_FLAG = "--xla_cpu_use_fusion_emitters=false"
if "xla_cpu_use_fusion_emitters" not in os.environ.get("XLA_FLAGS", ""):
    os.environ["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} {XLA_CPU_FLAG}".strip()

# JAX's settings for the package: float64, and the persistent XLA compilation cache (every
# Snakemake job is a new process, and the shooting maps take ~10 s each to compile; the cache makes
# that a one-time cost per machine). Where JAX is not imported yet they go into the environment
# variables it reads its defaults from when it is, so that importing spaceopt does not import JAX:
# the Snakefile's planning and the report jobs never use it, and JAX's import costs 0.5-0.6 s of
# CPU in each such process.
JAX_SETTINGS = {
    "jax_enable_x64": True,
    "jax_compilation_cache_dir": os.environ.get("SPACEOPT_JAX_CACHE", os.path.expanduser("~/.cache/spaceopt/jax")),
    "jax_persistent_cache_min_compile_time_secs": 1.0,
}
if "jax" in sys.modules:
    for _name, _value in JAX_SETTINGS.items():
        sys.modules["jax"].config.update(_name, _value)
else:
    for _name, _value in JAX_SETTINGS.items():
        os.environ[_name.upper()] = str(_value)

from . import artifacts  # noqa: E402,F401  (fixes the code version of every artifact at import)

__all__ = ["__version__"]
__version__ = "0.1.0"
