"""How accurate is the propagated Jacobian at a path tolerance? (perturbed.numerics.path_rtol)

The integrator's step control sees the state y only (flow._primal_rms), not the sensitivities
Φ, so ∂f/∂z is less accurate than f at the same rtol. For each converged solution artifact given,
this evaluates f and J at several rtol and compares them with rtol 1e-13, printing the residual
difference, the worst relative error of each Jacobian column, and the Newton contraction factor
ρ = ‖J⁻¹ (J − J_ref)‖₂: a Newton corrector with this J converges at best linearly with rate ρ,
and the continuation corrector rejects a step unless |F| halves per iteration (ρ < ½).

Usage (repository root, after the artifacts exist):
    python docs/experiments/path_jacobian_accuracy.py results/perturbed/e6/2021-05-27.json [...] \
        [--rtol 1e-9 1e-10 1e-11]
"""
import argparse

import jax.numpy as jnp
import numpy as np

from spaceopt.indirect.shooting import shoot
from spaceopt.studies import perturbed as P


def accuracy(sol, rtols):
    sh, z, prm = sol.shooting, jnp.asarray(sol.z), sol.prm
    f_ref, J_ref = (np.asarray(a) for a in shoot(sh, z, 1.0, prm, 1e-13, 1e-14)[:2])
    rows = []
    for rtol in rtols:
        f, J, _, steps, _ = shoot(sh, z, 1.0, prm, rtol, 0.1 * rtol)
        f, J = np.asarray(f), np.asarray(J)
        rows.append({"rtol": rtol, "steps": int(steps), "df": float(np.abs(f - f_ref).max()),
                     "column_error": np.abs(J - J_ref).max(0) / np.abs(J_ref).max(0),
                     "rho": float(np.linalg.norm(np.linalg.solve(J, J - J_ref), 2))})
    return np.linalg.cond(J_ref), rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("artifacts", nargs="+")
    ap.add_argument("--rtol", type=float, nargs="+", default=[1e-9, 1e-10, 1e-11])
    a = ap.parse_args()
    for path in a.artifacts:
        cond, rows = accuracy(P.load(path), a.rtol)
        print(f"{path}: cond J = {cond:.2e}")
        for r in rows:
            cols = np.array2string(r["column_error"], precision=1)
            print(f"  rtol {r['rtol']:g}: {r['steps']} steps, |f - f_ref| {r['df']:.1e}, "
                  f"column errors {cols}, rho {r['rho']:.2e}")


if __name__ == "__main__":
    main()
