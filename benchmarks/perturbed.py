"""Benchmark of the perturbed §4.2 studies (issue: E8 500-rev chain ≤ 10 min on 2 cores; whole E6 scan).

Two parts, both written to ``results/benchmarks/perturbed.json``:

1. ``measured``: wall times read from the solve artifacts that exist (provenance wall_time_s of
   results/perturbed/**/<stage>.json): each E5/E7/E9 chain, every E6 date and the scan total,
   every E8 n.
2. ``propagation``: the cost of one shooting evaluation (trajectory + 10 sensitivity columns) of
   the perturbed E8 problem (4×4 + Moon + Sun) over ``--revs`` revolutions at the LP guess,
   measured after compilation, and its per-revolution cost. The 500-revolution chain estimate is
   per-revolution cost × 500 × the Jacobian evaluations of a chain (``--jacobians``, measured on
   the chains that did run, default 120), stated as an extrapolation, not a measurement.

Usage: python benchmarks/perturbed.py [--revs 10] [--results results] [--out results/benchmarks/perturbed.json]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def measured(results: Path) -> dict:
    from spaceopt import artifacts
    base = results / "perturbed"
    out = {"chains": {}, "e6": {}, "e8": {}}
    if not base.exists():
        return out
    for p in sorted(base.glob("*/*.json")):
        if p.name.endswith((".failure.json", ".verify.json")):
            continue
        try:
            d = artifacts.read_json(p)
        except Exception:                                      # noqa: BLE001 — partial results
            continue
        if "provenance" not in d or "solver" not in d:
            continue
        rec = {"wall_time_s": d["provenance"].get("wall_time_s"),
               "jacobian_evaluations": d["solver"].get("jacobian_evaluations"),
               "n_rev": d["transfer"]["n_rev"]}
        group = p.parent.name
        if group == "e6":
            out["e6"][p.stem] = rec
        elif group == "e8":
            out["e8"][p.stem] = rec
        else:
            out["chains"][f"{group}/{p.stem}"] = rec
    if out["e6"]:
        out["e6_scan_total_s"] = sum(r["wall_time_s"] or 0.0 for r in out["e6"].values())
        out["e6_dates"] = len(out["e6"])
    return out


def propagation(revs: float, repeats: int = 2) -> dict:
    import jax
    import jax.numpy as jnp
    import numpy as np
    import yaml
    from spaceopt.indirect import chain
    from spaceopt.indirect.shooting import shoot
    from spaceopt.studies import perturbed as P

    pc = yaml.safe_load((ROOT / "config/studies/perturbed.yaml").read_text())["perturbed"]
    eph = P.ephemeris_path(ROOT / "results", pc["cases"]["e8"]["ephemeris"])
    out = {}
    for model in pc["cases"]["e8"]["models"]:
        tr = P.transfer_from_config(pc, "e8", model, ephemeris=eph, n_rev=revs)
        sh = chain.shooting_for("ot", "eps", tr)
        prm = tr.params()
        z = np.zeros(sh.size)
        z[:5] = 1e-3
        z[sh.kf_index] = tr.delta_L
        z = jnp.asarray(z)
        t0 = time.perf_counter()
        jax.block_until_ready(shoot(sh, z, 1.0, prm))
        compile_s = time.perf_counter() - t0
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            res = jax.block_until_ready(shoot(sh, z, 1.0, prm))
            times.append(time.perf_counter() - t0)
        med = statistics.median(times)
        out[model] = {"revs": revs, "first_call_s": compile_s, "propagation_s": med,
                      "per_rev_s": med / revs, "integration_steps": int(res[3])}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--revs", type=float, default=10.0)
    ap.add_argument("--jacobians", type=int, default=120)
    ap.add_argument("--results", default=str(ROOT / "results"))
    ap.add_argument("--out", default=str(ROOT / "results/benchmarks/perturbed.json"))
    ap.add_argument("--skip-propagation", action="store_true")
    a = ap.parse_args(argv)
    report = {"machine": {"cpu_count": os.cpu_count(), "load_avg": os.getloadavg()},
              "measured": measured(Path(a.results))}
    if not a.skip_propagation:
        prop = propagation(a.revs)
        report["propagation"] = prop
        report["e8_500rev_chain_estimate_s"] = {
            m: v["per_rev_s"] * 500 * a.jacobians for m, v in prop.items()}
        report["e8_estimate_note"] = (f"extrapolated: per-revolution cost of one shooting evaluation "
                                      f"x 500 rev x {a.jacobians} Jacobian evaluations; not measured")
        report["target_s"] = 600.0
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(json.dumps(report, indent=2) + "\n")
    print(json.dumps(report, indent=2), file=sys.stderr)


if __name__ == "__main__":
    main()
