"""E7 T_min from the minimum-fuel side: the T_min → OT homotopy followed backwards (docs/perturbed-e6-e7-e8.md).

The (3.4.1) homotopy LP → T_min of E7 folds at τ 0.473 and runs back (twenty-ninth session).
The pipeline also has the homotopy T_min → OT (``flow.Model('tmin', 'ot')``, used by the route
LP → T_min → OT): at τ = 0 it is the T_min problem, at τ = 1 the OT problem at ε₁ with the thrust
a state pinned at T_OT. E7's OT at 1 N converges (LP → OT blend with the printed weights), so here
that homotopy is followed from τ = 1 down to τ = 0, in arclength, starting on the converged OT:

  1. the E7 unperturbed OT (``results/perturbed/e7/unperturbed.json``, ε_f) is moved up to
     ε₁ = ``--eps`` by the ε homotopy (``chain.smoothing_to``);
  2. z_T = (its costates, K_f, T_OT) in the T_min layout (p_T(0) = 0, T free);
  3. the path s ∈ [0, 1] with τ = 1 − s (``reverse``: the follower runs from 0 to 1, so ∂f/∂s = −∂f/∂τ).

At s = 1 the unknowns solve the T_min problem; the result is compared with the LP → T_min route
where that converges (E5, E9 in ``results/perturbed/existence.csv``).

Usage: python docs/experiments/e7_tmin_from_ot.py [--eps 1e-2] [--h-max 0.05] [--case e7]
(from the repository root, after ``./dev reproduce`` has built the E7 artifacts).
"""
import argparse
import time

import jax.numpy as jnp
import numpy as np

from spaceopt.indirect import chain
from spaceopt.indirect.continuation import ArclengthContinuation, ArclengthOptions
from spaceopt.indirect import hamiltonians as hm
from spaceopt.indirect.shooting import final_state, shoot
from spaceopt.studies import multirev


def tau_of(s, decades):
    """τ(s) from 1 (s = 0) to 0 (s = 1), and dτ/ds: linear for ``decades`` = 0, else
    τ = (10^(−k s) − 10^(−k)) / (1 − 10^(−k)), k = decades (geometric down to ~10^(−k), then to 0):
    near τ = 0 the path's natural measure is log τ (the propellant weight τ in S is
    measured against costates of the size of T)."""
    if decades == 0:
        return 1.0 - s, -1.0
    k = decades
    q = 10.0 ** (-k * s)
    den = 1.0 - 10.0 ** (-k)
    return (q - 10.0 ** (-k)) / den, -k * np.log(10.0) * q / den


def reverse(fn, weight, T_ot, decades, trace=None):
    """f(z, s) = f(z, τ(s)) (:func:`tau_of`), with the thrust row (1 − τ) p_T(K_f) + τ (T − T_OT)
    replaced by (1 − τ) w p_T(K_f) + τ (T − T_OT) = w row + (1 − w) τ (T − T_OT): p_T(K_f) is
    10⁵ times T in E7's units."""
    def at(z, s):
        tau, dtau = tau_of(s, decades)
        f, J, ftau, nsteps, ok = fn(z, tau)
        dT = z[-1] - T_ot
        f = f.at[-1].set(weight * f[-1] + (1.0 - weight) * tau * dT)
        J = J.at[-1].set(weight * J[-1]).at[-1, -1].add((1.0 - weight) * tau)
        ftau = ftau.at[-1].set(weight * ftau[-1] + (1.0 - weight) * dT)
        if trace is not None:
            trace.append((float(tau), np.asarray(z).tolist()))
        return f, J, ftau * dtau, nsteps, ok
    return at


TRACE = []      # (τ, z) of every path evaluation, for --trace


def tmin_from_ot(ot, eps, weight, decades, options, trace_path=None):
    """T_min solution from the converged OT ``ot`` by the T_min → OT homotopy, τ from 1 to 0."""
    tr = ot.transfer
    up = chain.smoothing_to(ot, eps, label="eps up") if eps != float(ot.prm["eps_final"]) else ot
    sh = chain.shooting_for("tmin", "ot", tr)
    prm = {**tr.params(thrust=ot.thrust_N), "eps_blend": jnp.asarray(eps)}
    z0 = chain.start_vector(sh, up.costates(), up.K_f, ot.thrust_N / tr.force_unit)
    rtol, atol = chain._path_tolerances(sh)
    T_ot = z0[-1]
    cont = ArclengthContinuation(
        reverse(lambda z, tau: shoot(sh, jnp.asarray(z), tau, prm, rtol, atol), weight, T_ot, decades, TRACE), options,
        polish=reverse(lambda z, tau: shoot(sh, jnp.asarray(z), tau, prm), weight, T_ot, decades))
    try:
        z, _ = cont.run(z0)
    finally:
        if trace_path:
            np.savez(trace_path, tau=[t for t, _ in TRACE], z=[z for _, z in TRACE],
                     force_unit=tr.force_unit)
    sol = chain.Solution("tmin", sh, z, prm, tr, cont.stats.as_dict())
    sol.thrust_N = float(z[-1]) * tr.force_unit
    return up, sol


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="e7")
    ap.add_argument("--model", default="unperturbed")
    ap.add_argument("--eps", type=float, default=1e-2, help="ε₁ of the homotopy's OT end")
    ap.add_argument("--h-max", type=float, default=0.05)
    ap.add_argument("--weight", type=float, default=1e-5, help="w of p_T(K_f) in the thrust row")
    ap.add_argument("--decades", type=float, default=8.0, help="k of tau_of (0: tau = 1 - s)")
    ap.add_argument("--max-steps", type=int, default=400)
    ap.add_argument("--trace", help="write the path's (tau, z) to this .npz")
    ap.add_argument("--tol", type=float, default=1e-6, help="corrector tolerance on the path")
    a = ap.parse_args()
    ot = multirev.load(f"results/perturbed/{a.case}/{a.model}.json")
    opt = ArclengthOptions(h_max=a.h_max, tol_step=a.tol, max_steps=a.max_steps, label=f"{a.case} OT->T_min")
    t0 = time.perf_counter()
    up, tm = tmin_from_ot(ot, a.eps, a.weight, a.decades, opt, a.trace)
    wall = time.perf_counter() - t0
    yf, _ = final_state(tm.shooting, jnp.asarray(tm.z), 0.0, tm.prm)
    tr = tm.transfer
    print(f"OT {ot.thrust_N:g} N at eps {a.eps:g}: K_f {np.degrees(up.K_f):.4f} deg")
    print(f"T_min = {tm.thrust_N:.8f} N  K_f {np.degrees(tm.K_f):.4f} deg  "
          f"dt {float(yf[hm.TIME]) * tr.tu / 86400:.4f} d  m_f {float(yf[hm.MASS]) * tr.m0:.3f} kg  "
          f"|F| {tm.stats['residual']:.2e}  {tm.stats['jacobians']} Jacobians  {wall:.0f} s")
    print("z =", np.asarray(tm.z).tolist())


if __name__ == "__main__":
    main()
