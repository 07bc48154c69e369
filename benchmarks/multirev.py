"""Benchmark of the §4.1 chains: wall time with and without JIT compilation, continuation
statistics, and the ratio of a chain's solve time to one sensitivity propagation of its final
trajectory, all measured in one process, side by side.

Usage: python benchmarks/multirev.py [--cases e1 e2] [--out results/benchmarks/multirev.json]

"Cold" runs use a fresh, empty persistent compilation cache (so they include XLA compilation);
"warm" runs repeat the same chain in the same process (compiled functions reused).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from machine import finish, machine_facts

ROOT = Path(__file__).resolve().parents[1]


def run_chain(tr, thrust):
    from spaceopt.indirect import chain
    from spaceopt.indirect.continuation import ContinuationOptions
    opts = ContinuationOptions(verbose=False)
    t0 = time.perf_counter()
    lp = chain.solve_lp(tr, opts)
    t1 = time.perf_counter()
    tmin = chain.solve_tmin(lp, opts)
    t2 = time.perf_counter()
    ot = chain.solve_ot(lp, thrust, opts)
    t3 = time.perf_counter()
    stages = {"lp": (lp, t1 - t0), "tmin": (tmin, t2 - t1), "ot": (ot, t3 - t2)}
    return stages, t3 - t0


def propagation_time(sol, repeats=3):
    """Median wall time of one shooting evaluation (trajectory + sensitivities) at the solution."""
    import jax
    import jax.numpy as jnp
    from spaceopt.indirect.shooting import shoot
    z = jnp.asarray(sol.z)
    jax.block_until_ready(shoot(sol.shooting, z, 1.0, sol.prm))
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = jax.block_until_ready(shoot(sol.shooting, z, 1.0, sol.prm))
        times.append(time.perf_counter() - t0)
    return statistics.median(times), int(out[3])


def stats_of(sol):
    s = sol.stats
    return {k: s.get(k) for k in ("steps", "rejected_steps", "jacobian_evaluations",
                                  "integration_steps_total", "final_residual")}


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--cases", nargs="+", default=["e1", "e2"])
    ap.add_argument("--out", default=str(ROOT / "results" / "benchmarks" / "multirev.json"))
    args = ap.parse_args(argv)
    os.environ["SPACEOPT_JAX_CACHE"] = tempfile.mkdtemp(prefix="spaceopt-bench-cache-")
    import yaml
    from spaceopt import artifacts
    from spaceopt.studies import multirev_config

    cfg = yaml.safe_load((ROOT / "config" / "studies" / "multirev.yaml").read_text())["multirev"]
    out = {"machine": machine_facts(), "cases": {}}
    for case in args.cases:
        cc = cfg["cases"][case]
        thrust = cc["ot_thrust_N"][0]
        tr = multirev_config.transfer_from_config(cfg, case)
        cold, cold_total = run_chain(tr, thrust)      # includes JIT compilation
        warm, warm_total = run_chain(tr, thrust)      # compiled functions reused
        prop_s, prop_steps = propagation_time(warm["ot"][0])
        out["cases"][case] = {
            "n_rev": tr.n_rev, "ot_thrust_N": thrust,
            "cold_wall_s": cold_total, "warm_wall_s": warm_total,
            "compile_overhead_s": cold_total - warm_total,
            "stages": {k: {"cold_wall_s": cold[k][1], "warm_wall_s": warm[k][1], **stats_of(warm[k][0])}
                       for k in cold},
            "one_propagation_final_ot_s": prop_s, "one_propagation_integration_steps": prop_steps,
            "ratio_chain_to_one_propagation": warm_total / prop_s,
            "targets": {"e2_chain_warm_s_max": 60.0, "ratio_max": 30.0},
        }
        print(case, json.dumps(out["cases"][case], indent=1), file=sys.stderr, flush=True)
    finish(out["machine"])
    out["provenance"] = artifacts.provenance(cfg)
    artifacts.write_json(args.out, out)


if __name__ == "__main__":
    main()
