"""E8 spike: a cross-branch search for the free-time maximum through a larger smoothing ε
(thirty-second session).

Why: at full model 500 the DAG's end game starts at 319.959 d (φ = p_t(K_f) −9.1e-7) and marches
uphill along the fixed-time family at ε_f = 1e-5, which folds at 320.262 d with φ still
negative: no local maximum of m_f on that branch. Other branches of the ε_f family do have
maxima (321.028 d, the 25 Nov route; 321.52 d, the ninth session), but steps in t_f at ε_f
cannot reach them, and on the exact bang-bang map the walk stalls at the same fold (a burn arc
about to be born). The smoothed problem at a larger ε has fewer, wider switches, so its family
may run on in t_f where the ε_f one folds. This script

1. solves the fixed-time extremal at the start's own t_f (ε_f, :class:`FixedTimeFamily`);
2. lifts ε at that t_f, log-uniform steps up to EPS_LIFT (:meth:`MaximumSearch.move_eps`);
3. marches t_f at EPS_LIFT from there to TF_TO in steps of TF_STEP days (extrapolated starts,
   halved where Newton fails), printing m_f and φ: a crossing of φ from − to + is the lifted
   problem's free-time maximum;
4. descends ε back to ε_f at fixed t_f: at TF_TO, or with ``--at-root`` at the last point of the
   march before the lifted root (linear in φ between the bracketing points);
5. from that ε_f point, the library's own bracket search (:meth:`MaximumSearch.bracket`, then
   Brent in :meth:`MaximumSearch.root`), with the DAG's settings: the local maximum of m_f in
   t_f on the branch the descent landed on, or the reason there is none.

The ε steps and the t_f march are the library's fixed-time corrector (:meth:`FixedTimeFamily.point`)
with its data ε changed; nothing here is a new solver. The library's end game does the same
since this session (``MaximumOptions.lift_eps``, :meth:`MaximumSearch.across_branches`), with its
own bracket search at the lifted ε instead of this fixed-step march; this script keeps the
march, whose points at fixed steps show the lifted family.

    python docs/experiments/e8_eps_lift.py START EPS_LIFT TF_TO [--tf-step D] [--eps-steps N] [--at-root]
    python docs/experiments/e8_eps_lift.py START EPS_LIFT 0 --library      # the library's own lift (TF_TO unused)

START: a saved free-time solution (.json), e.g. the end game's ``free_time_start.json``.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from spaceopt.config import load_yaml
from spaceopt.constants import DAY
from spaceopt.indirect.free_time import FixedTimeFamily, MaximumOptions, MaximumSearch
from spaceopt.studies import perturbed as P


SAVED = "/tmp/e8_eps_lift_march.npz"     # the march's points at the lifted ε: t_f (time units), z


def march_tf(search: MaximumSearch, p, tf_to: float, h: float):
    """Fixed-time points from p to t_f = tf_to (time units) by steps h, each halved where Newton
    fails, down to δ/8 (:meth:`MaximumSearch.advance`; at the lifted ε δ is TF_STEP, so h/8),
    and h again for the next: the trail, or the trail so far where a step fails."""
    trail, direction = [p], float(np.sign(tf_to - p.tf))
    while direction * (tf_to - trail[-1].tf) > 1e-12:
        q, _ = search.advance(trail, direction, min(h, abs(tf_to - trail[-1].tf)))
        if q is None:
            return trail
        trail.append(q)
    return trail


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("start")
    ap.add_argument("eps_lift", type=float)
    ap.add_argument("tf_to", type=float, help="days")
    ap.add_argument("--tf-step", type=float, default=0.1, help="days")
    ap.add_argument("--eps-steps", type=int, default=4)
    ap.add_argument("--at-root", action="store_true")
    ap.add_argument("--library", action="store_true",
                    help="instead of 2.-4.: the library's MaximumSearch.across_branches from the start, with the "
                         "DAG's options (tof_maximum of E8) and eps_lift, tf_step as lift_eps, lift_probe_days")
    args = ap.parse_args()

    t_start = time.perf_counter()
    sol = P.load(args.start)
    tr, prm = sol.transfer, sol.prm
    eps_f = float(prm["eps_final"])
    if args.library:        # the DAG's end-game options (perturbed.numerics.tof_maximum)
        dag = load_yaml("config/studies/perturbed.yaml")["perturbed"]["numerics"]["tof_maximum"]
        opt = MaximumOptions(**dag, lift_eps=args.eps_lift, lift_steps=args.eps_steps,
                             lift_probe_days=args.tf_step, label="across branches")
    else:
        opt = MaximumOptions(probe_days=0.05, tof_tol_days=1e-4, max_points=16, max_newton=6,
                             lift_steps=args.eps_steps, lift_probe_days=args.tf_step, label="eps lift")
    family = FixedTimeFamily(sol.shooting, prm, opt)
    search = MaximumSearch(family, tr.tu, tr.m0)
    tf0 = family.end_time(sol.z)
    p0 = search.solve(tf0, sol.z)
    if p0 is None:
        raise SystemExit("the fixed-time point at the start's own t_f did not converge")

    if args.library:
        found = search.across_branches(p0, "the search at eps_f from here fails (thirty-first session; not repeated)")
        report(search, family, tr, found, t_start)
        return
    search.log(f"1. lift eps {eps_f:g} -> {args.eps_lift:g} at t_f {search.days(tf0):.5f} d")
    lifted = search.move_eps(p0, args.eps_lift)
    if lifted is None:
        raise SystemExit("the lift in eps failed")
    search.at_lift = True           # the march's points are kept (and logged) as lifted ones

    search.log(f"2. march t_f at eps {args.eps_lift:g} to {args.tf_to:.5f} d by {args.tf_step:g} d")
    trail = march_tf(search, lifted, args.tf_to * DAY / tr.tu, args.tf_step * DAY / tr.tu)
    np.savez(SAVED, tf=[q.tf for q in trail], z=np.array([q.z for q in trail]), eps=args.eps_lift)
    crossings = [(a, b) for a, b in zip(trail, trail[1:]) if a.phi < 0.0 < b.phi or b.phi < 0.0 < a.phi]
    for a, b in crossings:
        root = a.tf - a.phi * (b.tf - a.tf) / (b.phi - a.phi)
        search.log(f"   phi changes sign ({'- to +' if a.phi < b.phi else '+ to -'} in t_f) near {search.days(root):.4f} d")
    if abs(trail[-1].tf - args.tf_to * DAY / tr.tu) > 1e-9 and not args.at_root:
        raise SystemExit(f"the march at the lifted eps stopped at {search.days(trail[-1].tf):.5f} d")
    up = [(a, b) for a, b in crossings if a.phi < 0.0 < b.phi]
    descend_from = trail[-1]
    if args.at_root:
        if not up:
            raise SystemExit("--at-root: no crossing of phi from - to + along the lifted march")
        descend_from = up[0][0]

    search.log(f"3. descend eps {args.eps_lift:g} -> {eps_f:g} at t_f {search.days(descend_from.tf):.5f} d")
    landed = search.move_eps(descend_from, eps_f)
    search.at_lift = False
    if landed is None:
        raise SystemExit("the descent in eps failed")

    search.log("4. the end game's bracket search at eps_f from there")
    search.keep(landed)
    report(search, family, tr, search.bracket(landed), t_start)


def report(search, family, tr, found, t_start):
    """The maximum from a bracket (Brent), or the reason there is none; the cost."""
    if isinstance(found, str):
        search.log(f"no maximum: {found}")
    else:
        best = search.root(*found)[0]
        search.log(f"maximum: t_f {search.days(best.tf):.5f} d, m_f {best.m_f * tr.m0:.6f} kg "
                   f"(propellant {tr.m0 * (1 - best.m_f):.4f} kg), phi {best.phi:+.2e}, "
                   f"free-time residual {family.free_time_residual(best.z):.2e}")
    search.log(f"{family.solves} fixed-time solves, {family.jacobians} Jacobians, {family.residuals} residuals, "
               f"{time.perf_counter() - t_start:.0f} s")


if __name__ == "__main__":
    main()
