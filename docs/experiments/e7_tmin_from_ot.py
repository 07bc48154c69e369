"""E7 T_min from the minimum-fuel side (docs/perturbed-e6-e7-e8.md, "thirty-first session").

The scratch of the thirty-first session, now a thin driver of the library route
(``spaceopt.indirect.tmin_from_ot``, in the DAG as ``perturbed.existence.from_ot``, thirty-third
session): the T_min → OT homotopy followed back from a converged E7 OT artifact; where the path
stops short of τ = 0 (E7: a fold near τ 1e-4) its least-thrust point, polished at its own τ,
bounds T_min from above. ``--verify`` saves that point as an artifact and re-propagates it
independently (``studies.verify``, with the recorded throttle 1 − τ + τ δ).

Usage (from the repository root, after ``./dev reproduce`` has built the E7 artifacts):
    python docs/experiments/e7_tmin_from_ot.py [--model unperturbed] [--weight 0] [--decades 8]
        [--h-max 0.05] [--max-steps 120] [--verify PATH.json]
"""
import argparse
import time

from spaceopt.config import load_yaml
from spaceopt.indirect.tmin_from_ot import FromOtOptions, solve_tmin_from_ot
from spaceopt.studies import multirev, verify


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="unperturbed")
    ap.add_argument("--weight", type=float, default=0.0, help="w of p_T(K_f) in the thrust row (0: automatic)")
    ap.add_argument("--decades", type=float, default=8.0, help="k of tau_of (0: tau = 1 - s)")
    ap.add_argument("--h-max", type=float, default=0.05)
    ap.add_argument("--tol", type=float, default=1e-6, help="corrector tolerance on the path")
    ap.add_argument("--max-steps", type=int, default=120)
    ap.add_argument("--verify", help="save the end point as this .json artifact and re-propagate it (studies.verify)")
    a = ap.parse_args()
    t0 = time.perf_counter()
    ot = multirev.load(f"results/perturbed/e7/{a.model}.json")
    tm = solve_tmin_from_ot(ot, FromOtOptions(tau_decades=a.decades, weight=a.weight, h_max=a.h_max,
                                              tol_step=a.tol, max_steps=a.max_steps))
    what = "upper bound on T_min" if tm.extra["bound"] else "T_min"
    print(f"{what}: T = {tm.thrust_N:.6f} N at tau {tm.tau:.3e} (throttle >= {1.0 - tm.tau:.6f}), "
          f"|F| {tm.stats['final_residual']:.1e}, weight {tm.extra['weight']:.3g}; "
          f"{tm.stats['jacobian_evaluations']} path Jacobians, {time.perf_counter() - t0:.0f} s")
    if a.verify:
        multirev.save(tm, a.verify, load_yaml("config/studies/perturbed.yaml"), 0.0, tm.extra, samples_per_rev=2000)
        print("independent re-propagation:", verify.verify_ot(a.verify))


if __name__ == "__main__":
    main()
