"""Would a Taylor integrator (heyoka, the integrator of pykep 3) make E8's Jacobians cheaper?

Issue #3 asks for the perturbed 500-revolution E8 route in <= 10 min on 2 cores; one single-shooting
Jacobian of the full model at 500 revolutions already takes 1-2 min with diffrax's Dopri8. This
spike measures the cheapest case, the unperturbed OT shooting map of E8 at a converged extremal,
with heyoka's adaptive Taylor method and its automatic variational equations
(``heyoka.var_ode_sys``), beside our JAX/diffrax shooting map on the same extremal.

The Hamiltonian is written again here in heyoka's expression system (the same formulas as
``spaceopt.indirect.hamiltonians.h_ot``, δ frozen in the canonical equations and substituted after
differentiation, as ``spaceopt.indirect.flow`` does); the costate equations come from
``heyoka.diff``. Experiment only: heyoka is not a dependency of the project.

Two steps, two environments:

    .venv/bin/python docs/experiments/e8_taylor_spike.py jax 450 OUT.json
    python3.11 -m venv /tmp/hy && /tmp/hy/bin/pip install heyoka==7.13.2 numpy
    /tmp/hy/bin/python docs/experiments/e8_taylor_spike.py heyoka OUT.json TOL [compact] [primal]

``jax`` (after the DAG has written results/perturbed/e8/unperturbed_n<N>.json) times our shooting
Jacobian and residual and writes the start state, K_f, the problem data and our end state;
``heyoka`` builds the same field, times one variational pass (the Jacobian's propagation, the
free costates' 7 directions) and the primal alone, and compares the end state with ours.
Results: docs/perturbed-e6-e7-e8.md, "eighteenth session".
"""
import json
import math
import sys
import time

import numpy as np


def run_jax(n_rev: str, out: str):
    import jax
    import jax.numpy as jnp
    import yaml

    from spaceopt.indirect import chain, flow, shooting as S
    from spaceopt.studies import perturbed as P

    n = float(n_rev)
    art = json.load(open(f"results/perturbed/e8/unperturbed_n{n:g}.json"))
    pc = yaml.safe_load(open("config/studies/perturbed.yaml"))["perturbed"]
    tr = P.transfer_from_config(pc, "e8", "unperturbed", n_rev=n)
    sh = chain.shooting_for("ot", "eps", tr)
    prm = tr.params()
    z = jnp.asarray(art["z"])
    y0 = S.initial_state(sh, z, prm)
    jax.block_until_ready(S.shoot(sh, z, 1.0, prm))                     # compile
    jac, res = [], []
    for _ in range(3):
        t0 = time.perf_counter()
        jax.block_until_ready(S.shoot(sh, z, 1.0, prm))
        jac.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        jax.block_until_ready(S.residual(sh, z, 1.0, prm))
        res.append(time.perf_counter() - t0)
    yf, steps, _ = flow.propagate(sh.model, y0, float(z[-1]), 1.0, prm, sh.rtol, sh.atol, sh.max_steps)
    print(f"JAX/diffrax Dopri8 rtol {sh.rtol:g}: Jacobian {min(jac):.2f} s, residual {min(res):.2f} s, "
          f"{int(steps)} steps")
    json.dump({"y0": np.asarray(y0).tolist(), "K_f": float(z[-1]), "yf": np.asarray(yf).tolist(),
               "thrust": float(prm["thrust"]), "c": float(prm["c"]), "eps": float(prm["eps_final"]),
               "free": list(sh.free_costates), "rtol": sh.rtol, "jacobian_s": min(jac), "residual_s": min(res),
               "steps": int(steps)}, open(out, "w"))


def ot_system(T, c, eps):
    """The OT canonical system of spaceopt.indirect.hamiltonians (μ = 1 units) in heyoka."""
    import heyoka as hy
    X = hy.make_vars("p", "ex", "ey", "ix", "iy", "lk", "t", "m")
    Lam = hy.make_vars("pp", "pex", "pey", "pix", "piy", "plk", "pt", "pm")
    p, ex, ey, ix, iy, lk, _t, m = X
    pp, pex, pey, pix, piy, plk, pt, pm = Lam
    dl = hy.make_vars("dl")
    L = hy.time + lk
    cL, sL = hy.cos(L), hy.sin(L)
    q = 1.0 + ex * cL + ey * sL
    s2 = 1.0 + ix**2 + iy**2
    xi = ix * sL - iy * cL
    k1 = p * hy.sqrt(p) / q**2
    k2 = hy.sqrt(p) / q
    At = 2 * p * pp + ((q + 1) * cL + ex) * pex + ((q + 1) * sL + ey) * pey
    Ar = q * (sL * pex - cL * pey)
    An = xi * (-ey * pex + ex * pey + plk) + 0.5 * s2 * (cL * pix + sL * piy)
    S = k2 * hy.sqrt(At**2 + Ar**2 + An**2) / m - (pm + 1.0) / c
    H = dl * T * k1 * S + k1 * pt
    delta = 0.5 * (1.0 + S / hy.sqrt(S**2 + 2.0 * (math.sqrt(2.0) + 1.0) * eps**2))
    rhs = [hy.subs(hy.diff(H, v), {dl: delta}) for v in Lam] + [hy.subs(-hy.diff(H, v), {dl: delta}) for v in X]
    return list(zip(list(X) + list(Lam), rhs)), Lam


def run_heyoka(ref_path: str, tol: float, compact: bool, primal_only: bool):
    import heyoka as hy
    ref = json.load(open(ref_path))
    system, Lam = ot_system(ref["thrust"], ref["c"], ref["eps"])
    yref = np.asarray(ref["yf"])
    t0 = time.perf_counter()
    ta = hy.taylor_adaptive(system, ref["y0"], tol=tol, compact_mode=compact)
    print(f"heyoka primal, tol {tol:g}: compile {time.perf_counter() - t0:.1f} s, order {ta.order}")
    best = math.inf
    for _ in range(3):
        ta.time, ta.state[:] = 0.0, ref["y0"]
        t0 = time.perf_counter()
        out = ta.propagate_until(ref["K_f"])
        best = min(best, time.perf_counter() - t0)
    print(f"  {out[3]} steps, {best:.2f} s; end state minus ours: max {np.abs(ta.state - yref).max():.2e}")
    if primal_only:
        return
    free = [Lam[i] for i in ref["free"]]
    t0 = time.perf_counter()
    ta = hy.taylor_adaptive(hy.var_ode_sys(system, free, order=1), ref["y0"], tol=tol, compact_mode=compact)
    print(f"heyoka variational ({len(free)} directions), tol {tol:g}: compile {time.perf_counter() - t0:.1f} s")
    best = math.inf
    for _ in range(3):
        ta.time = 0.0
        ta.state[:16] = ref["y0"]
        ta.state[16:] = np.eye(16)[:, ref["free"]].ravel()
        t0 = time.perf_counter()
        out = ta.propagate_until(ref["K_f"])
        best = min(best, time.perf_counter() - t0)
    print(f"  {out[3]} steps, {best:.2f} s (ours: Jacobian {ref['jacobian_s']:.2f} s, {ref['steps']} steps); "
          f"end state minus ours: max {np.abs(np.asarray(ta.state[:16]) - yref).max():.2e}")


if __name__ == "__main__":
    if sys.argv[1] == "jax":
        run_jax(sys.argv[2], sys.argv[3])
    else:
        run_heyoka(sys.argv[2], float(sys.argv[3]), "compact" in sys.argv[4:], "primal" in sys.argv[4:])
