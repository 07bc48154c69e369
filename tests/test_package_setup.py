"""What importing spaceopt sets for the process: float64, and XLA's CPU fusion emitters off
unless the caller chose (spaceopt/__init__)."""
import os
import re
import subprocess
import sys
from pathlib import Path

SHOW = "import os, jax, spaceopt; print(os.environ['XLA_FLAGS']); print(jax.config.jax_enable_x64)"


def _import_spaceopt(xla_flags=None):
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    if xla_flags is not None:
        env["XLA_FLAGS"] = xla_flags
    out = subprocess.run([sys.executable, "-c", SHOW], env=env, capture_output=True, text=True, check=True)
    return out.stdout.split("\n")[:2]


def test_importing_spaceopt_turns_the_fusion_emitters_off_and_float64_on():
    from spaceopt import XLA_CPU_FLAG
    assert _import_spaceopt() == [XLA_CPU_FLAG, "True"]
    assert _import_spaceopt("--xla_cpu_enable_fast_math=false") == [
        f"--xla_cpu_enable_fast_math=false {XLA_CPU_FLAG}", "True"]


def test_a_fusion_emitter_flag_the_caller_set_wins():
    assert _import_spaceopt("--xla_cpu_use_fusion_emitters=true")[0] == "--xla_cpu_use_fusion_emitters=true"


SETTINGS = ("import sys, spaceopt; imported = 'jax' in sys.modules; import jax, jax.numpy as jnp; "
            "print(imported, jnp.zeros(1).dtype, jax.config.jax_compilation_cache_dir, "
            "jax.config.jax_persistent_cache_min_compile_time_secs)")


def test_spaceopt_does_not_import_jax_and_jax_imported_after_it_has_its_settings(tmp_path):
    """The Snakefile's planning and the report jobs import spaceopt without JAX (0.5-0.6 s of CPU
    per process); JAX imported later reads float64 and the compilation cache from the environment."""
    env = {**os.environ, "SPACEOPT_JAX_CACHE": str(tmp_path / "cache")}
    env = {k: v for k, v in env.items() if not k.startswith("JAX_")}
    out = subprocess.run([sys.executable, "-c", SETTINGS], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "float64", str(tmp_path / "cache"), "1.0"]


def test_planning_the_workflow_imports_no_solver():
    """The spaceopt modules the Snakefile and its rules import to plan the DAG leave diffrax,
    optimistix and the chain out: every Snakemake run (and every workflow test) parses them."""
    root = Path(__file__).resolve().parents[1]
    texts = [(root / "Snakefile").read_text(), *(f.read_text() for f in sorted((root / "workflow/rules").glob("*.smk")))]
    modules = sorted({m for t in texts for m in re.findall(r"^\s*from (spaceopt[\w.]*) import", t, re.M)})
    assert "spaceopt.studies.perturbed_config" in modules
    code = (f"import sys; import {', '.join(modules)}; "
            "print(sorted(m for m in ('diffrax', 'optimistix', 'spaceopt.indirect.chain') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"

