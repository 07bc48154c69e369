"""J2 about the frozen pole against the rotated Earth-fixed form: the cost of the integrator's
right-hand side (field + sensitivity columns, compiled in a loop of 2000 evaluations as in
benchmarks/perturbed.py --profile) with the two forms, side by side in one process (interleaved
rounds, min per evaluation). The old form is rebuilt here from the public pieces (Earth angle,
to_itrs, the printed J2 formula, to_icrs) and swapped in while the loop is traced. The
unperturbed field is the control. The equality of the two forms is a unit test
(tests/test_forces.py).

Usage (repository root, after the ephemeris window exists): python docs/experiments/j2_pole_side_by_side.py [rounds]
Measured 23 Nov 2026 on 2 cores with other solves and the test suite running (load 5-7): four
runs gave old/new 1.32, 1.11, 1.26, 1.12 (e.g. old 136.0, new 102.8, unperturbed 26.4 us/eval).
"""
import math
import sys
import time

import jax
import jax.numpy as jnp
import yaml

from spaceopt import forces as Fo
from spaceopt.indirect import chain, flow
from spaceopt.studies import perturbed as P

EVALS = 2000
NEW_TERMS = Fo.acceleration_terms


def old_terms(r, t, model):
    """J2 as before: r rotated to the Earth-fixed frame, the printed formula, rotated back."""
    r, t = jnp.asarray(r, dtype=jnp.float64), jnp.asarray(t, dtype=jnp.float64)
    theta = Fo.earth_angle(t, model.rot)
    a_f = Fo.j2_acceleration(Fo.to_itrs(r, theta, model.rot), model.gm, model.j2, model.radius)
    return {"j2": Fo.to_icrs(a_f, theta, model.rot)}


def build(pc, eph, model_name, terms):
    """The compiled loop of EVALS field evaluations, traced with ``terms`` as acceleration_terms."""
    Fo.acceleration_terms = terms
    try:
        tr = P.transfer_from_config(pc, "e8", model_name, ephemeris=eph, n_rev=5.0)
        sh = chain.shooting_for("ot", "eps", tr)
        prm, m = tr.params(), sh.model
        y0 = jnp.concatenate([prm["x0"], jnp.array([0.3, 0.01, 1.0]), 1e-3 * jnp.ones(m.n)])
        Phi = jnp.eye(2 * m.n, sh.size) + 0.01
        tt = jnp.zeros(sh.size).at[-1].set(1.0)

        def loop(y, Phi, prm_):
            def body(i, c):
                y, Phi = c
                gy, lin = jax.linearize(lambda yy, t_: flow.field(m, 0.1 * i, yy, t_, prm_), y, 1.0)
                return y + 1e-9 * gy, Phi + 1e-9 * jax.vmap(lin, in_axes=(1, 0), out_axes=1)(Phi, tt)
            return jax.lax.fori_loop(0, EVALS, body, (y, Phi))
        return jax.jit(loop).lower(y0, Phi, prm).compile(), (y0, Phi, prm)
    finally:
        Fo.acceleration_terms = NEW_TERMS


def main(rounds):
    pc = yaml.safe_load(open("config/studies/perturbed.yaml"))["perturbed"]
    eph = P.ephemeris_path("results", pc["cases"]["e8"]["ephemeris"])
    built = {"j2 old (rotated)": build(pc, eph, "j2", old_terms), "j2 new (pole)": build(pc, eph, "j2", NEW_TERMS),
             "unperturbed": build(pc, eph, "unperturbed", NEW_TERMS)}
    best = {k: math.inf for k in built}
    for _ in range(rounds):
        for k, (f, args) in built.items():
            t0 = time.perf_counter()
            jax.block_until_ready(f(*args))
            best[k] = min(best[k], (time.perf_counter() - t0) / EVALS * 1e6)
    for k, v in best.items():
        print(f"{k:20s} {v:8.1f} us/eval")
    print(f"old/new: {best['j2 old (rotated)'] / best['j2 new (pole)']:.2f}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 10)
