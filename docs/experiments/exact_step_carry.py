"""The exact map with each piece of a pass started from the step carried from the piece before,
against diffrax's initial-step rule, side by side in one process (exact_switching.CARRY_STEPS).

The exact map (spaceopt.indirect.exact_switching) restarts the integrator at every switch, every
segment end of pass 1 (32 steps) and for every y(K_s) restep: about 3 500 restarts at E8 500 rev.
The case is the profile's J2 -> full model blend at tau 0.5 from the exact profile's J2 artifact
(results/perturbed/e8/j2_n<N>.json, made by
``snakemake --cores 2 results/perturbed/e8/j2_n<N>.json ...`` (E8 on the exact map, the study config's)
with <N> in the run counts). Both programs are compiled first (the flag is read when a pass is
traced, so each variant gets jits of its own), then ``rounds`` rounds in alternating order, the
first dropped: wall time of pass 1 alone and of the Jacobian (shoot), steps, the paired median
ratios, and how far the two maps are apart (|df|, ||J^-1 dJ||, |d f_tau|).

``stage``: the whole J2 -> full blend instead (perturbed.warm_start with the profile's model step,
as the exact route's stage), once per variant named, in that order (carried, rule).

Usage (repository root; SPACEOPT_THREADS=2 as the route's benchmark):
    python docs/experiments/exact_step_carry.py N [rounds]
    python docs/experiments/exact_step_carry.py N stage carried rule
"""
import dataclasses
import sys
import time
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from spaceopt.indirect import chain, exact_switching as X
from spaceopt.indirect.shooting import shoot
from spaceopt.studies import perturbed as P

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import perturbed as B  # noqa: E402

PASS1, PASS2 = X._pass1.__wrapped__, X.propagate_with_sensitivities    # the library's, before any swap


def blend_at(n_rev):
    """(layout, z, data, path tolerances) of the J2 -> full blend from the exact profile's J2 artifact."""
    B.CONFIGFILES[:] = []       # the study config: E8 on the exact map
    pc = B._perturbed_config()
    start = P.load(B.ROOT / "results" / "perturbed" / "e8" / f"j2_n{n_rev:g}.json")
    tr = dataclasses.replace(P.transfer_from_config(
        pc, "e8", "g44_moon_sun", n_rev=n_rev,
        ephemeris=P.ephemeris_path(B.ROOT / "results", pc["cases"]["e8"]["ephemeris"])), path_arcs=1)
    sh, prm, _ = chain.model_blend(P.warm_start_integration(start, tr), tr.params(thrust=start.thrust_N))
    return sh, jnp.asarray(start.z), prm, chain._path_tolerances(sh)


def passes(carry, sh, z, prm, tol):
    """Jits of both passes of their own, traced with CARRY_STEPS = ``carry`` (new function objects:
    JAX reuses a trace of the same function under another jit)."""
    X.CARRY_STEPS = carry
    p1 = jax.jit(lambda *a: PASS1(*a), static_argnums=0)
    p2 = jax.jit(lambda *a: PASS2(*a), static_argnums=0)
    X._pass1, X._pass2_block = p1, p2
    jax.block_until_ready(p1(sh, z, 0.5, prm, tol[0], tol[1], sh.max_steps))   # both calls traced here
    jax.block_until_ready(shoot(sh, z, 0.5, prm, *tol))
    X.CARRY_STEPS = True
    return p1, p2


def main(n_rev, rounds):
    sh, z, prm, tol = blend_at(n_rev)
    kept = X._pass1, X._pass2_block
    variants = {"carried": passes(True, sh, z, prm, tol), "initial-step rule": passes(False, sh, z, prm, tol)}
    times = {k: {"pass1": [], "shoot": []} for k in variants}
    out = {}
    try:
        for r in range(rounds):
            for name in (variants if r % 2 == 0 else list(variants)[::-1]):
                X._pass1, X._pass2_block = variants[name]
                t0 = time.perf_counter()
                p1 = jax.block_until_ready(X._pass1(sh, z, 0.5, prm, tol[0], tol[1], sh.max_steps))
                t1 = time.perf_counter()
                o = jax.block_until_ready(shoot(sh, z, 0.5, prm, *tol))
                t2 = time.perf_counter()
                out[name] = (p1, o)
                if r:
                    times[name]["pass1"].append(t1 - t0)
                    times[name]["shoot"].append(t2 - t1)
                print(f"{name:18s} pass 1 {t1 - t0:6.2f} s {int(p1['steps']):6d} steps | Jacobian {t2 - t1:6.2f} s "
                      f"{int(o[3]):6d} steps", flush=True)
    finally:
        X._pass1, X._pass2_block = kept
    new, old = (times[k] for k in variants)
    for part in ("pass1", "shoot"):
        a, b = np.array(old[part]), np.array(new[part])
        print(f"{part}: min {a.min():.2f} s / {b.min():.2f} s, paired median ratio {np.median(a / b):.3f}")
    (p_new, o_new), (p_old, o_old) = (out[k] for k in variants)
    J0, J1 = np.asarray(o_old[1]), np.asarray(o_new[1])
    print(f"switches {int(p_old['n_switches'])} / {int(p_new['n_switches'])}; "
          f"|df| {float(jnp.abs(o_new[0] - o_old[0]).max()):.2e}, ||J^-1 dJ|| "
          f"{np.linalg.norm(np.linalg.solve(J0, J1 - J0), 2):.3f}, |d f_tau| {float(jnp.abs(o_new[2] - o_old[2]).max()):.2e}")


def stage(n_rev, order):
    """The blend stage with each variant in ``order`` ('carried' | 'rule'): wall time, Jacobians, t_f."""
    sh, z, prm, tol = blend_at(n_rev)
    variants = {"carried": passes(True, sh, z, prm, tol), "rule": passes(False, sh, z, prm, tol)}
    pc = B._perturbed_config()
    start = P.load(B.ROOT / "results" / "perturbed" / "e8" / f"j2_n{n_rev:g}.json")
    tr = P.transfer_from_config(pc, "e8", "g44_moon_sun", n_rev=n_rev,
                                ephemeris=P.ephemeris_path(B.ROOT / "results", pc["cases"]["e8"]["ephemeris"]))
    kept = X._pass1, X._pass2_block
    try:
        for name in order:
            X._pass1, X._pass2_block = variants[name]
            t0 = time.perf_counter()
            kwargs = P.warm_start_kwargs(pc, "e8", "g44_moon_sun", n_rev=n_rev)
            sol = P.warm_start(start, tr, f"stage/{name}", **kwargs)
            sol.transfer = tr
            print(f"{name}: {time.perf_counter() - t0:.1f} s, {B._jacobians(sol.stats)} Jacobians, "
                  f"{B._propellant_and_time(sol)}", flush=True)
    finally:
        X._pass1, X._pass2_block = kept


if __name__ == "__main__":
    if len(sys.argv) > 2 and sys.argv[2] == "stage":
        stage(float(sys.argv[1]), sys.argv[3:] or ["carried", "rule"])
    else:
        main(float(sys.argv[1]), int(sys.argv[2]) if len(sys.argv) > 2 else 7)
