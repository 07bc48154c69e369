"""E7 (GTO → Molniya, unperturbed): the minimum-fuel family followed down in the thrust (sixty-third
session). Does it fold at a least thrust (a regular T_min), or run into a degenerate end?

The DAG's existence check for E7 gives upper bounds on T_min only (docs/perturbed-guide.md §9): the
(3.4.1) homotopy from the LP folds, and the T_min → OT homotopy from the OT (``tmin_from_ot``) folds
where the throttle becomes always on. Below the thrust at which the OT extremal's engine is on
everywhere, each OT extremal of the family is a transfer with the engine always on, so the family
continued down in the thrust bounds T_min from above at every point it reaches. Where a regular
minimum-thrust extremal exists the family folds in the thrust there (two always-on branches, the
shortest and the longest transfer, merge at T_min). Since the sixty-fourth session the DAG follows
E7's family itself (``perturbed.thrust_family``, ``spaceopt.studies.thrust_family``, which this
script now calls for the continuation and the per-point scalars).

  family N T0,T1,… [EPS [MODEL]]
                     the OT at N revolutions and thrust T0 (LP → OT blend, W_ref 1, arclength),
                     moved to the smoothing EPS if given (default: ε_f), MODEL's perturbations
                     (j2: no ephemeris needed) switched on there, then continued in the
                     thrust to T1, T2, … in arclength; prints per point m_f,
                     Δt, the largest apogee radius and eccentricity on the way, the least radius
                     the trajectory reaches (its own, sampled 400 times a revolution), and the
                     throttle's duty (propellant over T·Δt/c: 1 for an engine always on)
  below PATH T1,T2,… [TOL_STEP]
                     the family continued on down from a saved point at its ε (the DAG's
                     results/perturbed/e7/family_<model>.json: its least-thrust point, or a
                     checkpoint's point.json), the path corrector's tolerance TOL_STEP if given
                     (default 1e-4)
  hop PATH T1,T2,… [STEP_N [OUT]]
                     the family continued on down from a saved family point (as ``below``) by
                     branch hops only (``thrust_family.hop_down``, hops of at most STEP_N,
                     default ``HOP_DEFAULTS``; '-' for the default), each t_f predicted from the
                     last two points of the artifact's family; the end games logged; each point
                     reached saved at OUT if given, the family's points in its extra (a ``hop``
                     from OUT goes on from there)
  at PATH T OUT      the point at thrust T of the family saved at PATH (its unknowns from the
                     family's points) saved at OUT, with the family's points down to T (a start
                     for ``hop``)
  model PATH MODEL   that saved point carried to the force model MODEL at its thrust and ε by
                     the model blend (``chain.continue_in_model``; run where results/ has E7's
                     ephemeris window)
  bound N T0         the OT at N revolutions and thrust T0, then the DAG's bound
                     (``tmin_from_ot.solve_tmin_from_ot``) from it

    .venv/bin/python docs/experiments/e7_thrust_family.py family 2 60,35,26,21,18.5,17.6,17,16,15,14.9,14.85
    .venv/bin/python docs/experiments/e7_thrust_family.py bound 2 60
    .venv/bin/python docs/experiments/e7_thrust_family.py below results/perturbed/e7/family_unperturbed.json 0.298,0.296
    .venv/bin/python docs/experiments/e7_thrust_family.py hop results/perturbed/e7/family_g44_moon_sun.json 0.6,0.5
    .venv/bin/python docs/experiments/e7_thrust_family.py family 100 1,0.8,0.6,0.5,0.45,0.4,0.37,0.35,0.33,0.32,0.31,0.3 1e-2
    .venv/bin/python docs/experiments/e7_thrust_family.py family 100 1,0.6,0.45,0.37,0.33,0.32,0.31 1e-2 j2

Measured (docs/perturbed-e6-e7-e8.md, sixty-third session): at 100 revolutions the family reaches
0.30 N unperturbed and 0.31 N with J2, below the DAG's bounds (0.3091, 0.3110 N), its apogee
running away (535 000 km at 0.30 N); at 2 revolutions 14.85 N against the bound's 16.16 N.
``hop`` from the full model's own family at 0.8 N (sixty-ninth session): 0.6 N in ten hops of
0.02 N, past the fold near 0.728 N, onto the point carried from J2 (841.223 kg, 91.034 d); with
``first_step`` 1.2 (seventieth session) on to 0.45 N in 18 hops. From the carried 0.45 N point
(seventy-second session; its unknowns from the artifact's family points, saved with the points
down to 0.45 N) to 0.3225 N, then with the retry at a longer t_f to 0.3175 N; not to 0.31 N.
With the retry's t_f first and the end game's doubling march (seventy-third session; ``at`` the
carried family's 0.32 N point, then ``hop`` from it to 0.31,0.3): 0.315 N, then 0.31 N on the
carried extremal (725.411 kg, 152.874 d); not 0.30 N. With the run-off test in place of the
step caps (seventy-fourth session; the hop to 0.305 N from that 0.31 N point, then ``hop`` from
it to 0.3 at 0.005): 0.305 N (696.942 kg, 171.759 d), 0.30 N (671.069 kg, 190.369 d).
From the carried 0.30 N point (seventy-fifth session, ``at`` then ``hop`` to 0.295 at 0.005): not
0.295 N, its path stopped by ``hops.max_path_steps`` (400) at tau 0.494 while still moving.
"""
import dataclasses
import sys
import time

import jax
import yaml

jax.config.update("jax_enable_x64", True)
from spaceopt import artifacts  # noqa: E402
from spaceopt.errors import ConvergenceError  # noqa: E402
from spaceopt.indirect import chain  # noqa: E402
from spaceopt.indirect.continuation import ContinuationOptions  # noqa: E402
from spaceopt.indirect.tmin_from_ot import solve_tmin_from_ot  # noqa: E402
from spaceopt.studies import perturbed as P  # noqa: E402
from spaceopt.studies import thrust_family as TF  # noqa: E402

QUIET = ContinuationOptions(verbose=False)
PC = yaml.safe_load(open("config/studies/perturbed.yaml"))["perturbed"]
E7 = P.transfer_from_config(PC, "e7", "unperturbed")


def show(sol, point):
    print(f"T={point['thrust_N']:g} N, eps {point['eps']:g}: m_f {point['m_f_kg']:.3f} kg, dt {point['tof_days']:.4f} d, "
          f"max apogee {point['max_apogee_km']:.0f} km, max e {point['max_e']:.4f}, least radius "
          f"{point['least_radius_km']:.0f} km, duty {point['duty']:.4f} ({point['wall_s']:.0f} s)", flush=True)


def ot_at(n_rev, thrust_N):
    tr = dataclasses.replace(E7, n_rev=n_rev, thrust=thrust_N)
    _, ot = P.solve_for(tr, f"n {n_rev:g}", path="arclength", options=QUIET, blend_ref=1.0)
    return ot


def follow(sol, thrusts, eps, label, options=QUIET):
    _, _, stop = TF.follow(sol, thrusts, eps, options, label, on_point=lambda s, pts: show(s, pts[-1]))
    if stop:
        print(f"stopped: {stop}", flush=True)


def family(n_rev, thrusts, eps=None, model="unperturbed"):
    n_rev, thrusts = float(n_rev), [float(x) for x in thrusts.split(",")]
    sol = ot_at(n_rev, thrusts[0])
    eps = float(sol.prm["eps_final"]) if eps is None else float(eps)
    if model != "unperturbed":       # switched on at the family's ε, which it keeps (E7's DAG: at 1e-2)
        sol = TF.at_thrust(chain.smoothing_to(sol, eps, QUIET), thrusts[0], eps)
        tr = dataclasses.replace(P.transfer_from_config(PC, "e7", model), n_rev=n_rev, thrust=thrusts[0],
                                 eps_final=eps)
        sol = P.perturb_from_unperturbed(sol, tr, f"{model} on", options=QUIET)
    follow(sol, thrusts[1:], eps, f"n {n_rev:g}")


def below(path, thrusts, tol_step=None):
    sol = P.load(path)
    options = QUIET if tol_step is None else dataclasses.replace(QUIET, tol_step=float(tol_step))
    follow(sol, [float(x) for x in thrusts.split(",")], float(sol.prm["eps_final"]), "below", options)


def hop(path, thrusts, step_N=None, out=None):
    """The family point saved at ``path`` (a family artifact or checkpoint, its points in the extra)
    hopped on down through ``thrusts`` (:func:`thrust_family.hop_down`), each point reached saved
    at ``out`` if given."""
    sol = P.load(path)
    points = list(artifacts.read_json(path)["extra"]["family"]["points"])
    hops = TF.hop_settings({} if step_N in (None, "-") else {"step_N": float(step_N)}, "hops")
    eps = float(sol.prm["eps_final"])

    def reached(s, stats, wall_s):
        points.append(TF.point(s, stats, wall_s))
        show(s, points[-1])
        print(f"  the hop's end game: from {stats['end_game']['t0_days']:.5f} d to {stats['end_game']['tof_days']:.5f} d, "
              f"{stats['end_game']['fixed_time_solves']} solves; {stats['jacobian_evaluations']} Jacobians", flush=True)
        if out is not None:
            P.save(s, out, {"experiment": "e7_thrust_family hop", "from": path}, wall_s,
                   {"family": {"points": points}}, samples_per_rev=20)
    for T in (float(x) for x in thrusts.split(",")):
        sol, stop = TF.hop_down(sol, T, eps, ContinuationOptions(), hops, "hop", points, reached)
        if stop:
            print(f"stopped: {stop}", flush=True)
            return


def at(path, thrust_N, out):
    """The point at ``thrust_N`` of the family saved at ``path`` (its unknowns from the points in
    the extra, ``thrust_family.seeds``) saved at ``out``, with the family's points down to it."""
    sol = P.load(path)
    points = list(artifacts.read_json(path)["extra"]["family"]["points"])
    T, eps = float(thrust_N), float(sol.prm["eps_final"])
    seed = next(s for s in TF.seeds(sol, points, eps) if abs(s.thrust_N - T) < 1e-12)
    kept = [p for p in points if p["thrust_N"] >= T - 1e-12]
    P.save(seed, out, {"experiment": "e7_thrust_family at", "from": path}, 0.0, {"family": {"points": kept}},
           samples_per_rev=20)
    show(seed, {**kept[-1], "wall_s": 0.0})


def model(path, name):
    """The family point saved at ``path`` carried to the force model ``name`` at its thrust and ε by
    the model blend (``chain.continue_in_model``, arclength)."""
    sol = P.load(path)
    T, eps = sol.thrust_N, float(sol.prm["eps_final"])
    tr = P.transfer_from_config(PC, "e7", name, ephemeris=P.ephemeris_path("results", PC["cases"]["e7"]["ephemeris"]))
    tr = dataclasses.replace(tr, thrust=T, eps_final=eps)
    t = time.time()
    try:
        moved = chain.continue_in_model(sol, tr.params(thrust=T), QUIET, label=f"to {name}", path="arclength")
    except ConvergenceError as exc:
        print(f"{name} at {T:g} N: failed ({exc}) ({time.time() - t:.0f} s)", flush=True)
        return
    moved = TF.at_thrust(dataclasses.replace(moved, transfer=tr), T, eps)
    show(moved, {"thrust_N": T, "eps": eps, **TF.describe(moved), "wall_s": time.time() - t})


def bound(n_rev, thrust_N):
    ot = ot_at(float(n_rev), float(thrust_N))
    t = time.time()
    try:
        b = solve_tmin_from_ot(ot)
    except ConvergenceError as exc:
        print(f"tmin_from_ot: failed ({exc}) ({time.time() - t:.0f} s)", flush=True)
        return
    print(f"tmin_from_ot: T {b.thrust_N:.6f} N at tau {b.tau:.3g} (bound: {bool(b.extra.get('bound'))}), "
          f"{TF.describe(b)} ({time.time() - t:.0f} s)", flush=True)


if __name__ == "__main__":
    {"family": family, "below": below, "hop": hop, "at": at, "model": model, "bound": bound}[sys.argv[1]](*sys.argv[2:])
