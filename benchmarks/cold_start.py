"""Cold-start cost of a perturbed chain: this source tree against a base revision, side by side.

Every Snakemake job, every test process and every user session starts a new Python process, and
a clean checkout (CI) starts with an empty JAX compilation cache: it pays JAX's tracing and XLA's
compilation of each shooting program before it computes anything. Measured on the test suite
with a cold cache (29 Nov): XLA compilation was 48 % of its CPU time and tracing 27 %.

The probe: E1 under J2 (2 revolutions) from the zero guess, LP → OT 15 N (ε continuation) →
exact bang-bang map (:func:`spaceopt.indirect.chain.to_exact`) → dense output → residual and
switch list of the exact extremal, each stage timed, in a fresh process with an empty cache;
JAX's own monitoring events give the time spent tracing, lowering and compiling. Then the probe
runs again in a new process on the same, now warm, cache with another integration-step cap
(``--second-cap``, E9's quick-profile cap by default): a process of another study or test whose
programs differ only in the cap (before the cap was traced, .flow.StepCap, each cap compiled them
all again). The base tree
is ``git archive <base> src`` in a temporary directory, put first on ``PYTHONPATH``; the rounds
alternate the two trees (base, this, this, base, …) so that a drift of the machine falls on both.

Usage: python benchmarks/cold_start.py --base <rev> [--rounds 2] [--second-cap 70000]
       [--out results/benchmarks/cold_start.json]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from machine import finish, machine_facts

ROOT = Path(__file__).resolve().parents[1]
EVENTS = {"/jax/core/compile/jaxpr_trace_duration": "trace_s",
          "/jax/core/compile/jaxpr_to_mlir_module_duration": "lower_s",
          "/jax/core/compile/backend_compile_duration": "xla_compile_s"}


def probe(max_steps: int | None = None) -> dict:
    """The chain in this process (its spaceopt is the first on sys.path): stage times, JAX's
    trace/lower/compile totals, and the extremal's m_f and |f| (the trees must agree on them)."""
    import jax.monitoring

    totals = dict.fromkeys(EVENTS.values(), 0.0)

    def listen(event, duration, **_):
        if event in EVENTS:
            totals[EVENTS[event]] += duration
    jax.monitoring.register_event_duration_secs_listener(listen)

    import dataclasses

    import jax.numpy as jnp
    import yaml

    import spaceopt
    from spaceopt.indirect import chain, exact_switching
    from spaceopt.indirect.continuation import ContinuationOptions
    from spaceopt.indirect.shooting import residual
    from spaceopt.studies import multirev_config

    cfg = yaml.safe_load((ROOT / "config" / "studies" / "multirev.yaml").read_text())["multirev"]
    tr = dataclasses.replace(multirev_config.transfer_from_config(cfg, "e1"), perturbations={"geopotential": "j2"},
                             epoch_utc="2021-05-09T12:00:00")
    if max_steps is not None:
        tr = dataclasses.replace(tr, max_steps=max_steps)
    quiet = ContinuationOptions(verbose=False)
    stages, t = {}, time.perf_counter()

    def lap(name):
        nonlocal t
        now = time.perf_counter()
        stages[name] = now - t
        t = now
    lp = chain.solve_lp(tr, quiet, perturbed=True)
    lap("lp")
    ot = chain.solve_ot(lp, 15.0, quiet)
    lap("ot")
    ex = chain.to_exact(ot)
    lap("to_exact")
    _, ys = chain.dense(ex, samples_per_rev=50)
    lap("dense")
    z = jnp.asarray(ex.z)
    f, _ = residual(ex.shooting, z, 1.0, ex.prm)
    n_switches = int(exact_switching.switch_points(ex.shooting, z, 1.0, ex.prm, ex.shooting.rtol,
                                                   ex.shooting.atol)[2])
    lap("residual_and_switches")
    return {"source": str(Path(spaceopt.__file__).parent), "stages_s": stages, "total_s": sum(stages.values()),
            **totals, "m_f": float(ys[-1][6]), "max_abs_f": float(jnp.abs(f).max()), "n_switches": n_switches}


def run_probe(src: Path, cache: str, max_steps: int | None = None) -> dict:
    """:func:`probe` in a new process with ``src`` first on PYTHONPATH and the JAX cache ``cache``."""
    env = {**os.environ, "PYTHONPATH": str(src), "SPACEOPT_JAX_CACHE": cache}
    cap = [] if max_steps is None else ["--max-steps", str(max_steps)]
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, __file__, "--probe", *cap], env=env, capture_output=True, text=True,
                         check=True)
    result = json.loads(out.stdout.strip().splitlines()[-1])
    result["process_wall_s"] = time.perf_counter() - t0
    return result


def run_pair(src: Path, second_cap: int) -> dict:
    """The probe with an empty cache, then again with ``second_cap`` on the cache it filled."""
    with tempfile.TemporaryDirectory(prefix="spaceopt-cold-") as cache:
        cold = run_probe(src, cache)
        cold["second_cap"] = run_probe(src, cache, second_cap)
        return cold


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--base", help="git revision to compare with (e.g. the commit before an optimisation)")
    ap.add_argument("--rounds", type=int, default=2, help="probes of each tree (alternated)")
    ap.add_argument("--out", default=str(ROOT / "results" / "benchmarks" / "cold_start.json"))
    ap.add_argument("--second-cap", type=int, default=70_000,
                    help="integration-step cap of the second probe on the warm cache (E9 quick: 70 000)")
    ap.add_argument("--probe", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--max-steps", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.probe:
        print(json.dumps(probe(args.max_steps)))
        return
    if not args.base:
        ap.error("--base: the git revision to compare this tree with is required")
    from spaceopt import artifacts
    machine = machine_facts()
    base_rev = subprocess.run(["git", "rev-parse", args.base], cwd=ROOT, capture_output=True, text=True,
                              check=True).stdout.strip()
    with tempfile.TemporaryDirectory(prefix="spaceopt-base-") as base_dir:
        archive = subprocess.run(["git", "archive", base_rev, "src"], cwd=ROOT, capture_output=True, check=True)
        subprocess.run(["tar", "-x", "-C", base_dir], input=archive.stdout, check=True)
        trees = {"base": Path(base_dir) / "src", "this": ROOT / "src"}
        runs = {"base": [], "this": []}
        order = [("base", "this") if i % 2 == 0 else ("this", "base") for i in range(args.rounds)]
        for pair in order:
            for name in pair:
                runs[name].append(run_pair(trees[name], args.second_cap))
                print(name, json.dumps(runs[name][-1]), file=sys.stderr, flush=True)

    def median(name, key, second=False):
        return statistics.median((r["second_cap"] if second else r)[key] for r in runs[name])
    keys = ("process_wall_s", "total_s", "trace_s", "lower_s", "xla_compile_s")
    summary = {name: {k: median(name, k) for k in keys} for name in runs}
    second = {name: {k: median(name, k, True) for k in keys} for name in runs}
    out = {"base_revision": base_rev, "rounds": args.rounds, "order": order, "second_cap": args.second_cap,
           "summary_median": summary, "second_cap_median": second,
           "ratio_this_to_base": {k: summary["this"][k] / summary["base"][k] for k in keys},
           "second_cap_ratio_this_to_base": {k: second["this"][k] / second["base"][k] for k in keys},
           "same_extremal": all(abs(p["m_f"] - runs["base"][0]["m_f"]) < 1e-9
                                for r in runs["this"] + runs["base"] for p in (r, r["second_cap"])),
           "runs": runs, "machine": finish(machine),
           "provenance": artifacts.provenance({"base": base_rev, "rounds": args.rounds})}
    artifacts.write_json(args.out, out)
    print(json.dumps({k: out[k] for k in ("summary_median", "ratio_this_to_base", "second_cap_median",
                                          "second_cap_ratio_this_to_base", "same_extremal")}, indent=1))


if __name__ == "__main__":
    main()
