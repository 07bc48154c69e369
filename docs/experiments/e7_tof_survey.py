"""E7 full model (4×4 + Moon + Sun, 1 N): the local maxima of m_f(t_f) near the DAG's extremal
(docs/perturbed-e6-e7-e8.md, "sixty-sixth session").

The end game and survey of E7's config (``perturbed.tof_maximum_settings``: since the
sixty-seventh session the DAG surveys E7 as E8), with the window ``--days``, from another start
or on an earlier artifact. Sub-commands:

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
from spaceopt.config import load_yaml
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
    settings = {**P.tof_maximum_settings(load_yaml("config/studies/perturbed.yaml")["perturbed"], "e7"),
                "survey_days": args.days}
    best, rec = maximise_final_mass(sol, MaximumOptions(label=args.start, **settings))
    d = TF.describe(best)
    maxima = [(round(float(t), 5), round(float(m), 6), float(p)) for t, m, p in rec.get("survey", {}).get("maxima", [])]
    print(f"heaviest maximum: {d['m_f_kg']:.6f} kg, {d['tof_days']:.5f} d; maxima (t_f d, m_f kg, phi): {maxima} "
          f"({time.perf_counter() - t0:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
