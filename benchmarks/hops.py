"""Benchmark of a branch hop (spaceopt.studies.thrust_family.hop): the first arclength step of its
fixed-time path.

From a saved family point (a family artifact or a checkpoint's point.json: its points in the
extra), one hop to the thrust T, t_f predicted on the secant of the family's last two points
(``thrust_family.predicted_tof``), once per first step given, side by side in one process after
a warm-up that compiles the fixed-time and free-time programs. Reported per run: the fixed-time
path's arclength steps, rejected steps and Jacobians, the end game's fixed-time solves and
Jacobians, where the hop landed (t_f, m_f), wall time; per point the wall and Jacobian ratios of
each first step to the first one listed, and whether all landed on one extremal (t_f within
1e-5 d, m_f within 1e-5 kg).

Usage: python benchmarks/hops.py POINT.json T [--first-steps 0.02,0.3] [--out results/benchmarks/hops.json]
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from machine import finish, machine_facts

ROOT = Path(__file__).resolve().parents[1]


def run(sol, thrust_N: float, tof_days: float, first_step: float) -> dict:
    from spaceopt.indirect.continuation import ContinuationOptions
    from spaceopt.studies import thrust_family as TF
    hops = TF.hop_settings({"first_step": first_step}, "hops")
    t = time.perf_counter()
    out = TF.hop(sol, thrust_N, tof_days, ContinuationOptions(verbose=False), hops, "hop")
    wall = time.perf_counter() - t
    game, described = out.stats["end_game"], TF.describe(out)
    return {"first_step": first_step, "wall_s": wall, "path_steps": out.stats["steps"],
            "jacobian_evaluations": out.stats["jacobian_evaluations"],
            "path_jacobians": out.stats["jacobian_evaluations"] - game["jacobian_evaluations"],
            "end_game_solves": game["fixed_time_solves"], "end_game_jacobians": game["jacobian_evaluations"],
            "tof_days": described["tof_days"], "m_f_kg": described["m_f_kg"]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("point", help="a family artifact or checkpoint (its points in extra.family)")
    ap.add_argument("thrust_N", type=float, help="the thrust the hop goes to")
    ap.add_argument("--first-steps", default="0.02,0.3", help="first arclength steps, the first the reference")
    ap.add_argument("--out", default=str(ROOT / "results/benchmarks/hops.json"))
    args = ap.parse_args(argv)
    from spaceopt import artifacts
    from spaceopt.studies import perturbed as P, thrust_family as TF
    machine = machine_facts()
    sol = P.load(args.point)
    points = artifacts.read_json(args.point)["extra"]["family"]["points"]
    eps = float(sol.prm["eps_final"])
    tof = TF.predicted_tof(points, args.thrust_N, eps)
    first_steps = [float(h) for h in args.first_steps.split(",")]
    run(sol, args.thrust_N, tof, first_steps[-1])          # warm-up: every program compiled once
    runs = [run(sol, args.thrust_N, tof, h) for h in first_steps]
    ref = runs[0]
    for r in runs:
        r["wall_ratio"] = r["wall_s"] / ref["wall_s"]
        r["jacobian_ratio"] = r["jacobian_evaluations"] / ref["jacobian_evaluations"]
    same = all(abs(r["tof_days"] - ref["tof_days"]) <= 1e-5 and abs(r["m_f_kg"] - ref["m_f_kg"]) <= 1e-5 for r in runs)
    out = {"provenance": artifacts.provenance({"benchmark": "hops", "point": args.point, "thrust_N": args.thrust_N,
                                               "first_steps": first_steps}),
           "from": {"thrust_N": sol.thrust_N, "eps": eps}, "thrust_N": args.thrust_N, "predicted_tof_days": tof,
           "runs": runs, "same_extremal": bool(same), "machine": finish(machine)}
    print(json.dumps({k: out[k] for k in ("from", "thrust_N", "runs", "same_extremal")}, indent=1), flush=True)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(out, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT / "src"))
    sys.exit(main())
