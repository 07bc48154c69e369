"""E8 route B on the exact map (thirty-sixth session): every step at the smoothing ε₁, one jump.

The exact route of ``benchmarks/perturbed.py --exact-route`` jumps to ε = 0 right after the
unperturbed chain and follows every later step on the exact map; at 500 revolutions its
4×4 → 4×4 + Moon + Sun blend crawls (a grazing switch near τ 0.17). This route keeps the steps
where a switch's birth is smooth: the unperturbed chain to ε₁ (eps_blend), J2 switched on at ε₁,
the force-model blends at ε₁, and only then Newton to the exact problem (``chain.to_exact``) and
the free-time end game on the exact map. Each stage's solution is pickled under /tmp, so a rerun
resumes after the last finished stage.

Usage (from the project root, results/ephemeris/jan2000.* built):
    python docs/experiments/e8_exact_route_b.py N_REV
Measured: docs/perturbed-e6-e7-e8.md, "thirty-sixth session".
"""
import dataclasses
import os
import pickle
import sys
import time

import jax.numpy as jnp
import yaml

from spaceopt.indirect import chain, hamiltonians as hm
from spaceopt.indirect.free_time import MaximumOptions, maximise_final_mass
from spaceopt.indirect.shooting import final_state
from spaceopt.studies import perturbed as P


def main(n: float):
    pc = yaml.safe_load(open("config/studies/perturbed.yaml"))["perturbed"]
    eph = P.ephemeris_path("results", pc["cases"]["e8"]["ephemeris"])

    def transfer(model):           # at ε₁: the chain stops there, the paths run there
        tr = P.transfer_from_config(pc, "e8", model, n_rev=n, ephemeris=eph)
        return dataclasses.replace(tr, eps_final=tr.eps_blend, path_arcs=1)

    def report(name, sol, t0, jacobians):
        yf, _ = final_state(sol.shooting, jnp.asarray(sol.z), 1.0, sol.prm)
        u = sol.transfer.units()
        print(f"### {name}: {time.time() - t0:.0f} s, {jacobians} Jacobians, m_p "
              f"{(1 - float(yf[hm.MASS])) * u['mass_kg']:.5f} kg, Δt {float(yf[hm.TIME]) * u['time_s'] / 86400:.5f} d",
              flush=True)

    def stage(name, step):
        path = f"/tmp/e8_route_b_n{n:g}_{name}.pkl"
        if os.path.exists(path):
            return pickle.load(open(path, "rb"))
        t0 = time.time()
        sol = step()
        report(name, sol, t0, sol.stats.get("jacobian_evaluations"))
        pickle.dump(sol, open(path, "wb"))
        return sol

    sol = stage("unperturbed", lambda: P.solve_for(transfer("unperturbed"), "unperturbed", path="arclength")[1])
    sol = stage("j2", lambda: P.perturb_from_unperturbed(sol, transfer("j2"), "j2 on", path="tau"))
    for model in ("g44", "g44_moon_sun"):
        def blend(prev=sol, tr=transfer(model)):
            out = chain.continue_in_model(P.warm_start_integration(prev, tr), tr.params(thrust=prev.thrust_N),
                                          label=model)
            out.transfer = tr
            return out
        sol = stage(model, blend)
    exact = stage("exact", lambda: chain.to_exact(sol, label="exact"))
    t0 = time.time()
    best, rec = maximise_final_mass(exact, MaximumOptions(label="end game", lift_eps=0.0))
    report(f"end game ({rec['status']})", best, t0, rec.get("jacobian_evaluations"))


if __name__ == "__main__":
    main(float(sys.argv[1]))
