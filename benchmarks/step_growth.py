"""Benchmark of the continuation step-growth rules (ContinuationOptions.step_growth), side by side.

'iterations' grows an accepted step by the number of corrector evaluations it used; 'residual'
grows it by the residual at the predicted point and caps it below the last rejected step
(src/spaceopt/indirect/continuation.py). Each path below is followed with both rules in one
process; the counts (steps, rejected steps, Jacobian evaluations, integration steps) are
deterministic, the wall times are taken after a warm-up run of the same path (compiled functions
reused). The end points are compared: both rules must land on the same extremal.

Paths: the §4.1 chains E1 (2 rev) and E2 (100 rev), LP → T_min → OT; the §4.2 E5 chain
(unperturbed, LP → T_min → OT, τ path) and its perturbations switched on in arclength.

Usage: python benchmarks/step_growth.py [--paths e1 e2 e5] [--out results/benchmarks/step_growth.json]
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from machine import finish, machine_facts

ROOT = Path(__file__).resolve().parents[1]
RULES = ("iterations", "residual")


def multirev_chain(case):
    import yaml
    from spaceopt.indirect import chain
    from spaceopt.studies import multirev_config
    cfg = yaml.safe_load((ROOT / "config" / "studies" / "multirev.yaml").read_text())["multirev"]
    tr = multirev_config.transfer_from_config(cfg, case)

    def run(opts):
        lp = chain.solve_lp(tr, opts)
        tmin = chain.solve_tmin(lp, opts)
        ot = chain.solve_ot(lp, cfg["cases"][case]["ot_thrust_N"][0], opts)
        return {"lp": lp, "tmin": tmin, "ot": ot}
    return run


def perturbed_e5():
    import yaml
    from spaceopt.studies import perturbed as P
    pc = yaml.safe_load((ROOT / "config" / "studies" / "perturbed.yaml").read_text())["perturbed"]
    eph = P.ephemeris_path(ROOT / "results", pc["cases"]["e5"]["ephemeris"])
    unp = P.transfer_from_config(pc, "e5", "unperturbed")
    full = P.transfer_from_config(pc, "e5", "g44_moon_sun", ephemeris=eph)

    def run(opts):
        _, ot = P.solve_for(unp, "e5", path="tau", options=opts, route="lp-tmin-ot")
        return {"ot": ot, "perturbed": P.perturb_from_unperturbed(ot, full, "e5 perturbed", options=opts)}
    return run


PATHS = {"e1": lambda: multirev_chain("e1"), "e2": lambda: multirev_chain("e2"), "e5": perturbed_e5}
COUNTS = ("steps", "rejected_steps", "jacobian_evaluations", "integration_steps_total")


def totals(stats: dict) -> dict:
    return {k: stats.get(k) for k in (*COUNTS, "final_residual")}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--paths", nargs="+", default=list(PATHS), choices=list(PATHS))
    ap.add_argument("--out", default=str(ROOT / "results" / "benchmarks" / "step_growth.json"))
    args = ap.parse_args(argv)
    from spaceopt import artifacts
    from spaceopt.indirect.continuation import ContinuationOptions
    out = {"machine": machine_facts(), "paths": {}}
    for name in args.paths:
        run = PATHS[name]()
        run(ContinuationOptions(verbose=False))                      # warm-up (compilation)
        res, row = {}, {}
        for rule in RULES:
            t0 = time.perf_counter()
            res[rule] = run(ContinuationOptions(verbose=False, step_growth=rule))
            row[rule] = {"wall_s": time.perf_counter() - t0,
                         "stages": {k: totals(s.stats) for k, s in res[rule].items()}}
            row[rule]["jacobian_evaluations"] = sum(s["jacobian_evaluations"] for s in row[rule]["stages"].values())
        row["max_abs_z_difference"] = {k: float(np.max(np.abs(np.asarray(res["iterations"][k].z)
                                                              - np.asarray(res["residual"][k].z))))
                                       for k in res["iterations"]}
        row["jacobian_ratio_residual_to_iterations"] = (row["residual"]["jacobian_evaluations"]
                                                        / row["iterations"]["jacobian_evaluations"])
        row["wall_ratio_residual_to_iterations"] = row["residual"]["wall_s"] / row["iterations"]["wall_s"]
        out["paths"][name] = row
        print(name, {r: (row[r]["jacobian_evaluations"], round(row[r]["wall_s"], 1)) for r in RULES},
              row["max_abs_z_difference"], file=sys.stderr, flush=True)
    finish(out["machine"])
    out["provenance"] = artifacts.provenance({"paths": args.paths})
    artifacts.write_json(args.out, out)


if __name__ == "__main__":
    main()
