"""E7 (GTO → Molniya, unperturbed): the minimum-fuel family followed down in the thrust (sixty-third
session). Does it fold at a least thrust (a regular T_min), or run into a degenerate end?

The DAG's existence check for E7 gives upper bounds on T_min only (docs/perturbed-guide.md §9): the
(3.4.1) homotopy from the LP folds, and the T_min → OT homotopy from the OT (``tmin_from_ot``) folds
where the throttle becomes always on. Below the thrust at which the OT extremal's engine is on
everywhere, each OT extremal of the family is a transfer with the engine always on, so the family
continued down in the thrust bounds T_min from above at every point it reaches. Where a regular
minimum-thrust extremal exists the family folds in the thrust there (two always-on branches, the
shortest and the longest transfer, merge at T_min).

  family N T0,T1,… [EPS [MODEL]]
                     the OT at N revolutions and thrust T0 (LP → OT blend, W_ref 1, arclength),
                     moved to the smoothing EPS if given (default: ε_f), MODEL's perturbations
                     (j2: no ephemeris needed) switched on there, then continued in the
                     thrust to T1, T2, … in arclength; prints per point m_f,
                     Δt, the largest apogee radius and eccentricity on the way, the least radius
                     the trajectory reaches (its own, sampled 400 times a revolution), and the
                     throttle's duty (propellant over T·Δt/c: 1 for an engine always on)
  bound N T0         the OT at N revolutions and thrust T0, then the DAG's bound
                     (``tmin_from_ot.solve_tmin_from_ot``) from it

    .venv/bin/python docs/experiments/e7_thrust_family.py family 2 60,35,26,21,18.5,17.6,17,16,15,14.9,14.85
    .venv/bin/python docs/experiments/e7_thrust_family.py bound 2 60
    .venv/bin/python docs/experiments/e7_thrust_family.py family 100 1,0.8,0.6,0.5,0.45,0.4,0.37,0.35,0.33,0.32,0.31,0.3 1e-2
    .venv/bin/python docs/experiments/e7_thrust_family.py family 100 1,0.6,0.45,0.37,0.33,0.32,0.31 1e-2 j2

Measured (docs/perturbed-e6-e7-e8.md, sixty-third session): at 100 revolutions the family reaches
0.30 N unperturbed and 0.31 N with J2, below the DAG's bounds (0.3091, 0.3110 N), its apogee
running away (535 000 km at 0.30 N); at 2 revolutions 14.85 N against the bound's 16.16 N.
"""
import dataclasses
import sys
import time

import jax
import numpy as np
import yaml

jax.config.update("jax_enable_x64", True)
from spaceopt.errors import ConvergenceError  # noqa: E402
from spaceopt.indirect import chain  # noqa: E402
from spaceopt.indirect.continuation import ContinuationOptions  # noqa: E402
from spaceopt.indirect.tmin_from_ot import solve_tmin_from_ot  # noqa: E402
from spaceopt.studies import perturbed as P  # noqa: E402
from spaceopt.studies.trajectory import sample  # noqa: E402

QUIET = ContinuationOptions(verbose=False)
PC = yaml.safe_load(open("config/studies/perturbed.yaml"))["perturbed"]
E7 = P.transfer_from_config(PC, "e7", "unperturbed")


def describe(sol, thrust_N):
    """m_f, Δt, the largest apogee radius and eccentricity, the least radius reached and the
    throttle's duty of ``sol``, from its physical samples (``studies.trajectory.sample``)."""
    s = sample(sol, 400)
    apogee_km = np.where(s["e"] < 1, s["a_m"] * (1 + s["e"]), np.inf) / 1e3
    m_f, dt_s = s["mass_kg"][-1], s["t_s"][-1]
    duty = (sol.transfer.m0 - m_f) / (thrust_N * dt_s / sol.transfer.c)
    return (f"m_f {m_f:.3f} kg, dt {dt_s / 86400:.4f} d, max apogee {apogee_km.max():.0f} km, "
            f"max e {s['e'].max():.4f}, least radius {np.linalg.norm(s['r_m'], axis=1).min() / 1e3:.0f} km, "
            f"duty {duty:.4f}")


def ot_at(n_rev, thrust_N):
    tr = dataclasses.replace(E7, n_rev=n_rev, thrust=thrust_N)
    _, ot = P.solve_for(tr, f"n {n_rev:g}", path="arclength", options=QUIET, blend_ref=1.0)
    return ot


def family(n_rev, thrusts, eps=None, model="unperturbed"):
    n_rev, thrusts = float(n_rev), [float(x) for x in thrusts.split(",")]
    t = time.time()
    sol = ot_at(n_rev, thrusts[0])
    if eps is not None:
        sol = chain.smoothing_to(sol, float(eps), QUIET, label=f"eps {eps}")
    if model != "unperturbed":       # switched on at the family's ε, which it keeps (E7's DAG: at 1e-2)
        tr = dataclasses.replace(P.transfer_from_config(PC, "e7", model), n_rev=n_rev, thrust=thrusts[0],
                                 eps_final=float(sol.prm["eps_final"]))
        sol = P.perturb_from_unperturbed(sol, tr, f"{model} on", options=QUIET)
    print(f"T={thrusts[0]:g} N: {describe(sol, thrusts[0])} ({time.time() - t:.0f} s)", flush=True)
    for T in thrusts[1:]:
        t = time.time()
        tr = dataclasses.replace(sol.transfer, thrust=T)
        try:
            prm = {**tr.params(thrust=T), "eps_final": sol.prm["eps_final"]}     # at the family's ε
            sol = dataclasses.replace(chain.continue_in_params(sol, prm, QUIET, label=f"T {T:g}", path="arclength"),
                                      transfer=tr, thrust_N=T)
        except ConvergenceError as exc:
            print(f"T={T:g} N: stopped ({exc}) ({time.time() - t:.0f} s)", flush=True)
            return
        print(f"T={T:g} N: {describe(sol, T)} ({time.time() - t:.0f} s)", flush=True)


def bound(n_rev, thrust_N):
    ot = ot_at(float(n_rev), float(thrust_N))
    t = time.time()
    try:
        b = solve_tmin_from_ot(ot)
    except ConvergenceError as exc:
        print(f"tmin_from_ot: failed ({exc}) ({time.time() - t:.0f} s)", flush=True)
        return
    print(f"tmin_from_ot: T {b.thrust_N:.6f} N at tau {b.tau:.3g} (bound: {bool(b.extra.get('bound'))}), "
          f"{describe(b, b.thrust_N)} ({time.time() - t:.0f} s)", flush=True)


if __name__ == "__main__":
    {"family": family, "bound": bound}[sys.argv[1]](*sys.argv[2:])
