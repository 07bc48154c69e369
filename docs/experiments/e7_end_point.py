"""E7 perturbed: why the final Newton polish of the smoothed switch-on fails (docs/perturbed-e6-e7-e8.md).

Reads the failure point z of ``results/perturbed/e7/g44_moon_sun.failure.json`` (ε = 10⁻²,
perturbation strength τ = 1) and measures, one check per sub-command:

  tolerance   |F| at integration rtol 1e-9, 1e-11, 1e-13 (is the residual resolved?)
  jacobian    the propagated ∂f/∂z against central differences; ``--column J --steps ...``
  line        |F(z + α Δz)|₂ along the Newton direction, α = 1, ½, ..., 1/128
  homotopy    a Newton homotopy at τ = 1 from z: F(z) = (1 − σ) F(z₀)
  path        the smoothed switch-on again from the unperturbed E7 OT (the pipeline's route,
              perturbed.perturb_from_unperturbed) with arclength ``--h-max`` and ``--tol``

Usage: python docs/experiments/e7_end_point.py {tolerance|jacobian|line|homotopy|path} [options]
(from the repository root, after ``./dev reproduce`` has built the E7 artifacts).
"""
import argparse
import json
from pathlib import Path

import jax.numpy as jnp
import numpy as np

from spaceopt.config import load_yaml
from spaceopt.indirect.continuation import ArclengthOptions, Continuation, ContinuationOptions
from spaceopt.indirect.shooting import shoot
from spaceopt.studies import perturbed as P

RESULTS = Path("results")
EPS_SMOOTH = 1e-2


def problem():
    """The E7 switch-on shooting problem at full strength: (Shooting, prm, transfer)."""
    pc = load_yaml("config/studies/perturbed.yaml")["perturbed"]
    tr = P.transfer_from_config(pc, "e7", "g44_moon_sun", ephemeris=P.ephemeris_path(RESULTS, "may2021"))
    sh = P.perturbation_switch(tr)
    prm = tr.params(thrust=tr.thrust)
    prm["eps_final"] = EPS_SMOOTH
    return sh, prm, tr


def failure_point():
    return np.asarray(json.loads((RESULTS / "perturbed/e7/g44_moon_sun.failure.json").read_text())["diagnosis"]["z"])


def residual(sh, prm, z, rtol=None):
    out = shoot(sh, jnp.asarray(z), 1.0, prm, rtol, None if rtol is None else 0.1 * rtol)
    return np.asarray(out[0]), np.asarray(out[1])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("check", choices=["tolerance", "jacobian", "line", "homotopy", "path"])
    ap.add_argument("--column", type=int, default=6, help="jacobian: unknown index (6 = p_t)")
    ap.add_argument("--steps", type=float, nargs="+", default=[1e-6, 1e-7, 1e-8])
    ap.add_argument("--h-max", type=float, default=0.05)
    ap.add_argument("--tol", type=float, default=1e-6)
    a = ap.parse_args()
    np.set_printoptions(precision=4, linewidth=200)
    sh, prm, tr = problem()
    if a.check == "path":
        opt = ArclengthOptions(h_max=a.h_max, tol_step=a.tol)
        sol = P.perturb_from_unperturbed(P.load(RESULTS / "perturbed/e7/unperturbed.json"), tr, "e7 switch",
                                         eps_smooth=EPS_SMOOTH, options=opt)
        print(sol.stats)
        return
    z = failure_point()
    f, J = residual(sh, prm, z)
    if a.check == "tolerance":
        for rtol in (1e-9, 1e-11, 1e-13):
            print(f"rtol {rtol:g}: f =", residual(sh, prm, z, rtol)[0])
    elif a.check == "jacobian":
        print(f"propagated column {a.column}:", J[:, a.column])
        for h in a.steps:
            e = np.eye(z.size)[a.column] * h
            fd = (residual(sh, prm, z + e, 1e-13)[0] - residual(sh, prm, z - e, 1e-13)[0]) / (2 * h)
            print(f"central difference h = {h:g}:", fd)
        print("cond J:", np.linalg.cond(J))
    elif a.check == "line":
        dz = np.linalg.solve(J, -f)
        print(f"alpha 0: |F|2 = {np.linalg.norm(f):.4e}")
        for k in range(8):
            print(f"alpha {0.5 ** k:.4g}: |F|2 = {np.linalg.norm(residual(sh, prm, z + 0.5 ** k * dz)[0]):.4e}")
    else:
        def evaluate(zz, _sigma):
            out = shoot(sh, jnp.asarray(zz), 1.0, prm)
            return out[0], out[1], np.zeros(zz.size), out[3], out[4]
        cont = Continuation(evaluate, ContinuationOptions(tol_step=1e-2 * np.abs(f).max(), h_init=0.1,
                                                          label="homotopy at tau = 1"))
        print(cont.run(z)[0], cont.stats.as_dict())


if __name__ == "__main__":
    main()
