"""E8 at n revolutions: the J2 → 4×4 + Moon + Sun model step split in two, J2 → 4×4 → 4×4 + Moon + Sun.

The DAG's route (case e8, models [unperturbed, j2, g44_moon_sun]) makes the step J2 → full model
at once, at ε_f; it converged at 200 and 250 revolutions and crawls from 300 on
(docs/perturbed-e6-e7-e8.md, "third session of 23 Nov"). This runs the split route from the J2
artifact of the DAG (``results/perturbed/e8/j2_n<n>.json``): each half by
``studies.perturbed.warm_start`` at ε_f (Newton homotopy in the force model, τ path, arclength
where it stalls), with the full model's path rtol (1e-11) for both halves, and prints each
half's Jacobian count, wall time, m_p and Δt. Nothing is written under results/.

``--start FILE``: start from another artifact (e.g. a saved 4×4 solution: then only the second
half runs); ``--arcs M``: paths followed by multiple shooting over M arcs (case option
``path_arcs``); ``--checkpoints DIR``: paths resumable (``ContinuationOptions.checkpoint_dir``);
``--step-growth residual --revert``: the step rules of ``ContinuationOptions``; ``--step-rcond C``:
truncated-SVD corrector and polish steps (``ContinuationOptions.step_rcond``; 1e-5 at 450 rev
keeps the accepted residual ~1e-6 where Newton's steps overshoot, "eighth session");
``--flat-step S``: a failed polish seeks the root along the flattest direction
(``ContinuationOptions.flat_step``; 0.005 converged 450 and 500 rev, "ninth session");
``--arclength``: each half by the model blend followed in arclength at once
(``chain.continue_in_model``), not by ``warm_start``'s τ path first; ``--save DIR``: each
half's solution written there as ``<model>_n<n>.json`` (with its .npz and .rrd).

Usage (repository root, after the J2 artifact exists):
    python docs/experiments/e8_split_model_step.py 300
    python docs/experiments/e8_split_model_step.py 500 --start g44_n500.json --arcs 10 \
        --checkpoints /tmp/e8_ck --step-growth residual --revert --step-rcond 1e-5 \
        --flat-step 0.005 --arclength --save /tmp/e8_full
"""
import argparse
import time
from pathlib import Path

from spaceopt.config import load_yaml
from spaceopt.indirect import chain
from spaceopt.indirect.continuation import ContinuationOptions
from spaceopt.studies import perturbed as P, trajectory

SPLIT = ("j2", "g44", "g44_moon_sun")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("n_rev", type=float)
    ap.add_argument("--path-rtol", type=float, default=1e-11)
    ap.add_argument("--start", help="start artifact (default results/perturbed/e8/j2_n<n>.json)")
    ap.add_argument("--arcs", type=int, default=1)
    ap.add_argument("--checkpoints", default="")
    ap.add_argument("--step-growth", default="iterations")
    ap.add_argument("--revert", action="store_true")
    ap.add_argument("--step-rcond", type=float, default=0.0)
    ap.add_argument("--flat-step", type=float, default=0.0)
    ap.add_argument("--arclength", action="store_true")
    ap.add_argument("--save", default="")
    a = ap.parse_args()
    pc = load_yaml("config/studies/perturbed.yaml")["perturbed"]
    pc["cases"]["e8"] = {**pc["cases"]["e8"], "models": ["unperturbed", *SPLIT], "path_rtol": a.path_rtol,
                         "path_arcs": a.arcs}
    eph = P.ephemeris_path("results", pc["cases"]["e8"]["ephemeris"])
    sol = P.load(a.start or f"results/perturbed/e8/j2_n{a.n_rev:g}.json")
    options = ContinuationOptions(step_growth=a.step_growth, checkpoint_dir=a.checkpoints,
                                  accepted_update="revert" if a.revert else "always", step_rcond=a.step_rcond,
                                  flat_step=a.flat_step)
    m0 = sol.transfer.m0
    start_model = next(m for m in SPLIT if pc["models"][m] == (sol.transfer.perturbations or None))
    for model in SPLIT[SPLIT.index(start_model) + 1:]:
        tr = P.transfer_from_config(pc, "e8", model, ephemeris=eph, n_rev=a.n_rev)
        t0 = time.perf_counter()
        label = f"e8 split -> {model} n{a.n_rev:g}"
        if a.arclength:
            start = P.warm_start_integration(sol, tr)
            sol = chain.continue_in_model(start, tr.params(thrust=start.thrust_N), options=options, label=label,
                                          path="arclength")
            sol.transfer = tr                       # continue_in_model keeps thrust_N
        else:
            sol = P.warm_start(sol, tr, label, options=options)
        if a.save:
            Path(a.save).mkdir(parents=True, exist_ok=True)
            P.save(sol, Path(a.save) / f"{model}_n{a.n_rev:g}.json", pc, time.perf_counter() - t0,
                   {"experiment": "docs/experiments/e8_split_model_step.py"})
        s = P.multirev.scalars(sol, trajectory.sample(sol, 20))
        print(f"{model}: {sol.stats.get('jacobian_evaluations')} Jacobians, {time.perf_counter() - t0:.0f} s, "
              f"path {sol.stats.get('warm_path')}, m_p = {m0 - s['m_f_kg']:.4f} kg, "
              f"dt = {float(s['tof_days']):.4f} d", flush=True)


if __name__ == "__main__":
    main()
