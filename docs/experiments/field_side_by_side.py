"""Two optimisations of the perturbed field, each against its old form, side by side in one process.

The cost of the integrator's right-hand side (field + sensitivity columns, compiled in a loop by
benchmarks/perturbed.py's compiled_field_loop, as for --profile), min per evaluation over interleaved
rounds. The old forms are rebuilt here from public pieces and swapped in while a loop is traced:

* ``j2``: J2 about the frozen pole (forces.acceleration_terms) against r rotated to the
  Earth-fixed frame, the printed formula, rotated back (Earth angle + two rotations);
* ``blend``: the force-model blend J2 → 4×4 + Moon + Sun (flow.Model('ot', 'model')) as H_p of
  the blended acceleration, orbital frame computed once, against τ H_p[to] + (1 − τ) H_p[from].

The unperturbed field is the control. The equality of the forms is unit-tested
(tests/test_forces.py, tests/test_hamiltonians.py).

Usage (repository root, after the ephemeris window exists):
    python docs/experiments/field_side_by_side.py [rounds]
Measured 23 Nov 2026 on 2 cores with other solves running (load 5-7): j2 old/new 1.32, 1.11,
1.26, 1.12, 1.15, 1.17 in six runs (e.g. old 136.0, new 102.8, unperturbed 26.4 us/eval);
blend (with the new J2 in both) old/new 1.29, 1.34 (244.6 against 189.0 us/eval).
On the idle machine (nothing else running): j2 40.3 against 36.4 us/eval (1.11), blend 97.1
against 80.6 (1.21), unperturbed 10.9: the load inflates the perturbed fields more than the
unperturbed one, so the loaded ratios above overstate the gain somewhat.
"""
import dataclasses
import math
import sys
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import yaml

from spaceopt import forces as Fo
from spaceopt.indirect import chain, flow
from spaceopt.indirect import hamiltonians as hm
from spaceopt.studies import perturbed as P

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from perturbed import PROFILE_EVALS, compiled_field_loop  # noqa: E402


def old_j2_terms(r, t, model):
    """J2 as before: r rotated to the Earth-fixed frame, the printed formula, rotated back."""
    r, t = jnp.asarray(r, dtype=jnp.float64), jnp.asarray(t, dtype=jnp.float64)
    theta = Fo.earth_angle(t, model.rot)
    a_f = Fo.j2_acceleration(Fo.to_itrs(r, theta, model.rot), model.gm, model.j2, model.radius)
    return {"j2": Fo.to_icrs(a_f, theta, model.rot)}


def old_h_perturbation(model, K, x, lam, tau, prm, shift):
    """The model blend as before: the perturbation term of each model, weighted."""
    if model.homotopy == "model":
        return (tau * hm.h_pert(K, x, lam, prm, shift)
                + (1.0 - tau) * hm.h_pert(K, x, lam, {**prm, "pert": prm["pert_from"]}, shift))
    return flow._pert_weight(model, tau) * hm.h_pert(K, x, lam, prm, shift)


OLD = {"j2": (Fo, "acceleration_terms", old_j2_terms), "blend": (flow, "_h_perturbation", old_h_perturbation)}


def build(pc, eph, model_name, homotopy="eps", pert_from=None, old=None):
    """The compiled field loop (benchmarks/perturbed.py) at τ 0.6 (``old``: a key of OLD swapped
    in while tracing)."""
    module, attr, replacement = OLD[old] if old else (None, None, None)
    kept = getattr(module, attr) if old else None
    if old:
        setattr(module, attr, replacement)
    try:
        tr = P.transfer_from_config(pc, "e8", model_name, ephemeris=eph, n_rev=5.0)
        sh = chain.shooting_for("ot", "eps", tr)
        prm = tr.params()
        if pert_from:
            prm["pert_from"] = P.transfer_from_config(pc, "e8", pert_from, ephemeris=eph, n_rev=5.0).params()["pert"]
        return compiled_field_loop(dataclasses.replace(sh.model, homotopy=homotopy), prm, sh.size, tau=0.6)
    finally:
        if old:
            setattr(module, attr, kept)


def main(rounds):
    pc = yaml.safe_load(open("config/studies/perturbed.yaml"))["perturbed"]
    eph = P.ephemeris_path("results", pc["cases"]["e8"]["ephemeris"])
    blend = {"homotopy": "model", "pert_from": "j2"}
    built = {"j2 old (rotated)": build(pc, eph, "j2", old="j2"), "j2 new (pole)": build(pc, eph, "j2"),
             "blend old (two H_p)": build(pc, eph, "g44_moon_sun", **blend, old="blend"),
             "blend new (one H_p)": build(pc, eph, "g44_moon_sun", **blend),
             "unperturbed": build(pc, eph, "unperturbed")}
    best = {k: math.inf for k in built}
    for _ in range(rounds):
        for k, (f, args) in built.items():
            t0 = time.perf_counter()
            jax.block_until_ready(f(*args))
            best[k] = min(best[k], (time.perf_counter() - t0) / PROFILE_EVALS * 1e6)
    for k, v in best.items():
        print(f"{k:22s} {v:8.1f} us/eval")
    for what in ("j2", "blend"):
        old, new = (v for k, v in best.items() if k.startswith(what))
        print(f"{what} old/new: {old / new:.2f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 10)
