"""What importing spaceopt sets for the process: float64, and XLA's CPU fusion emitters off
unless the caller chose (spaceopt/__init__)."""
import os
import subprocess
import sys

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
