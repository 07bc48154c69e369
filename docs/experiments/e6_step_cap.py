"""E6 14 May from the unperturbed E5 OT (the pipeline's route), timed: the integration-step cap's
measurement in docs/perturbed-e6-e7-e8.md.

Run it once with a checkout before the cap and once with one after, at the same time, each with
its own environment; both read the artifacts of ``RESULTS`` (the ephemeris window and the
unperturbed E5 solve of a full run). Prints one JSON line: the cap, wall time, Jacobians,
integration steps and the converged unknowns z (compare them between the two runs).

Usage: TREE/.venv/bin/python docs/experiments/e6_step_cap.py TREE [RESULTS]
"""
import json
import sys
import time
from pathlib import Path

tree = Path(sys.argv[1]).resolve()
results = Path(sys.argv[2] if len(sys.argv) > 2 else "results").resolve()
sys.path.insert(0, str(tree / "src"))
from spaceopt.config import load_yaml  # noqa: E402
from spaceopt.studies import perturbed as P  # noqa: E402

pc = load_yaml(tree / "config/studies/perturbed.yaml")["perturbed"]
tr = P.transfer_from_config(pc, "e5", "g44_moon_sun", ephemeris=str(results / "ephemeris/may2021.json"),
                            epoch_utc="2021-05-14T12:00:00")
t0 = time.perf_counter()
sol = P.warm_start(P.load(results / "perturbed/e5/unperturbed.json"), tr, f"e6/2021-05-14 ({tree.name})")
# a tree before the cap has no Transfer.max_steps: every propagation then had Shooting's 400 000
print(json.dumps({"tree": str(tree), "max_steps": getattr(tr, "max_steps", 400_000),
                  "wall_s": time.perf_counter() - t0, "jacobians": sol.stats["jacobian_evaluations"],
                  "integration_steps": sol.stats["integration_steps_total"], "z": [float(x) for x in sol.z]}))
