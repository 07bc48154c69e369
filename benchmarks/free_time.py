"""Benchmark of the free-time end game (spaceopt.indirect.free_time): chord steps against Newton.

For each perturbed OT artifact given, the end game runs twice in one process, side by side:
``chord_steps`` 0 (Newton: a Jacobian per iteration) and the configured default (a Jacobian
serves further chord steps, each a residual without sensitivities). The compiled functions are
warmed up first, so both runs time the same work. Reported per run: where it landed (t_f, m_f,
status), fixed-time solves, Jacobian and residual evaluations, wall time; per artifact the wall
ratio and whether both landed on the same maximum (within ``tof_tol_days`` and 1e-5 kg).

Usage: python benchmarks/free_time.py ARTIFACT.json[:PROBE_DAYS] ... [--out results/benchmarks/free_time.json]
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def warm_up(sol):
    """Compile the fixed-time shooting map, its residual and the end state once."""
    import jax.numpy as jnp
    from spaceopt.indirect.shooting import final_state, residual, shoot
    sh = dataclasses.replace(sol.shooting, fixed_time=True)
    z, prm = jnp.asarray(sol.z), {**sol.prm, "tf": jnp.asarray(1.0)}
    shoot(sh, z, 1.0, prm)[0].block_until_ready()
    residual(sh, z, 1.0, prm)[0].block_until_ready()
    residual(sol.shooting, z, 1.0, sol.prm)[0].block_until_ready()
    final_state(sh, z, 1.0, prm)[0].block_until_ready()
    final_state(sol.shooting, z, 1.0, sol.prm)[0].block_until_ready()


def run(sol, probe_days: float, chord_steps: int) -> dict:
    from spaceopt.indirect.free_time import MaximumOptions, maximise_final_mass
    opt = MaximumOptions(probe_days=probe_days, chord_steps=chord_steps, verbose=False)
    t = time.perf_counter()
    _, rec = maximise_final_mass(sol, opt)
    return {"chord_steps": chord_steps, "wall_s": time.perf_counter() - t,
            **{k: rec.get(k) for k in ("status", "tof_days", "m_f_kg", "m_f_gain_kg", "fixed_time_solves",
                                       "jacobian_evaluations", "residual_evaluations")}}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("artifacts", nargs="+", help="ARTIFACT.json[:PROBE_DAYS] (default probe 0.05 d)")
    ap.add_argument("--out", default=str(ROOT / "results/benchmarks/free_time.json"))
    args = ap.parse_args(argv)
    from spaceopt import artifacts
    from spaceopt.indirect.free_time import MaximumOptions
    from spaceopt.studies import perturbed as P
    default_chord = MaximumOptions().chord_steps
    out = {"provenance": artifacts.provenance({"benchmark": "free_time", "argv": args.artifacts}), "runs": {}}
    for spec in args.artifacts:
        path, _, probe = spec.partition(":")
        sol = P.load(path)
        warm_up(sol)
        newton, chord = run(sol, float(probe or 0.05), 0), run(sol, float(probe or 0.05), default_chord)
        same = (newton["status"] == chord["status"] == "maximum"
                and abs(newton["tof_days"] - chord["tof_days"]) <= MaximumOptions().tof_tol_days
                and abs(newton["m_f_kg"] - chord["m_f_kg"]) <= 1e-5)
        out["runs"][path] = {"newton": newton, "chord": chord, "same_maximum": bool(same),
                             "wall_ratio_chord_to_newton": chord["wall_s"] / newton["wall_s"]}
        print(json.dumps({path: out["runs"][path]}, indent=1), flush=True)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT / "src"))
    sys.exit(main())
