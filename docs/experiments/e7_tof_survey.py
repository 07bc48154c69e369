"""E7 full model (4×4 + Moon + Sun, 1 N): the local maxima of m_f(t_f) near the DAG's extremal
(docs/perturbed-e6-e7-e8.md, "sixty-sixth session").

The DAG's E7 end game certifies the local maximum of m_f in t_f next to the OT solution
(``perturbed.numerics.tof_maximum``) but does not survey its neighbours, as E8's does
(``tof_maximum.survey_days``). Sub-commands:

  ot        the survey (``free_time.MaximumSearch.survey``) within ``--days`` of the DAG's
            ``results/perturbed/e7/g44_moon_sun.json``
  carried   the 1 N point of the J2 family carried to the full model
            (``results/perturbed/e7/family_g44_moon_sun_from_j2.json``, ε 1e-2) taken down to
            ε_f by the smoothing homotopy in arclength (``chain.smoothing_to``), then the same end game and survey

Usage: python docs/experiments/e7_tof_survey.py {ot|carried} [--days 1.0]
(from the repository root, after ``./dev reproduce results/perturbed/thrust_family.csv``).
"""
import argparse
import time

from spaceopt import artifacts
from spaceopt.indirect import chain
from spaceopt.indirect.free_time import MaximumOptions, maximise_final_mass
from spaceopt.studies import perturbed as P, thrust_family as TF

E7 = "results/perturbed/e7/"


def carried_at_eps_f() -> chain.Solution:
    """The carried family's 1 N point moved from its ε to the case's ε_f in arclength (in τ it
    stalls at τ 0.576 for step-size underflow)."""
    path = E7 + "family_g44_moon_sun_from_j2.json"
    family = artifacts.read_json(path)["extra"]["family"]
    seed = TF.seeds(P.load(path), family["points"], family["eps"])[0]
    eps_f = float(P.load(E7 + "g44_moon_sun.json").prm["eps_final"])
    return chain.smoothing_to(seed, eps_f, label=f"carried {seed.thrust_N:g} N, eps down", path="arclength")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("start", choices=["ot", "carried"])
    ap.add_argument("--days", type=float, default=1.0, help="the survey's window each way")
    args = ap.parse_args()
    t0 = time.perf_counter()
    sol = P.load(E7 + "g44_moon_sun.json") if args.start == "ot" else carried_at_eps_f()
    d = TF.describe(sol)
    print(f"start: {d['m_f_kg']:.6f} kg, {d['tof_days']:.5f} d ({time.perf_counter() - t0:.0f} s)", flush=True)
    best, rec = maximise_final_mass(sol, MaximumOptions(label=args.start, survey_days=args.days,
                                                        survey_max_points=50, max_arc_step=8.0,
                                                        downhill_folds=1, max_points=40))
    d = TF.describe(best)
    maxima = [(round(float(t), 5), round(float(m), 6), float(p)) for t, m, p in rec.get("survey", {}).get("maxima", [])]
    print(f"heaviest maximum: {d['m_f_kg']:.6f} kg, {d['tof_days']:.5f} d; maxima (t_f d, m_f kg, phi): {maxima} "
          f"({time.perf_counter() - t0:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
