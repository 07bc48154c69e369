"""E8 full model at 450 revolutions from the full model at 400, by continuation in the count
(docs/perturbed-e6-e7-e8.md, "fifty-fourth session").

Question: the thesis has the perturbations shorten the transfer at 200–450 revolutions (by
0.554–1.024 d) and lengthen it at 500; ours shorten it at 200–400 (at 400 by 0.221 d) and
lengthen it at 450 (+2.27 d) and 500. Every route we ran to 450 starts at 450 (unperturbed → J2 →
4×4 or → full) and lands on the family of the 500 extremal. Does the family of the 400 full-model
extremal, carried to 450, give a shorter transfer?

Route, all on the smoothed map at ε₁ = eps_blend (single shooting), with the exact profile's
chain settings (the study config's E8 + ``benchmarks/e8_exact_no_survey.yaml``):

1. unperturbed chain at 400 (LP → OT to ε₁, the profile's corrector: the chord when this was
   run, Broyden's since the fifty-fifth session; path rtol 1e-7);
2. J2 switched on, then the full model from J2 (``perturbed.warm_start``, the case's model steps);
3. the **fixed-time** problem moved from (L_f, t_f) at 400 to L_f at 450 and t_f + ``--shift-days``
   (default: unperturbed 450 − 400, 288.2166 − 257.9145 d), the 'param' homotopy in arclength
   (``chain._run``), resumable (``--out``/ckpt); the free-time problem moved in L_f instead meets
   a fold of its own at τ 0.050 (2.5 revolutions in): the free-time extremals are the stationary
   points of m_f along the fixed-time family, which appear and vanish in pairs as L_f moves;
4. free time at ε₁ by Newton, the exact extremal (``chain.to_exact``), the free-time end game on
   the exact map (the case's settings, no lift).

Each stage's solution is pickled to ``--out`` and loaded when the script is rerun.

Usage (from the repository root, results/ephemeris built):
  PYTHONPATH=src .venv/bin/python docs/experiments/e8_450_from_400.py --out /tmp/e8_450_from_400
"""
from __future__ import annotations

import argparse
import dataclasses
import functools
import pickle
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "benchmarks"))

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import perturbed as bench  # noqa: E402  (benchmarks/perturbed.py: the profile merge, the transfer at ε₁, m_p and Δt)
from spaceopt.indirect import chain  # noqa: E402
from spaceopt.indirect import hamiltonians as hm  # noqa: E402
from spaceopt.indirect.continuation import ArclengthOptions  # noqa: E402
from spaceopt.indirect.free_time import MaximumOptions, maximise_final_mass  # noqa: E402
from spaceopt.indirect.shooting import final_state  # noqa: E402
from spaceopt.indirect.transfer import datum  # noqa: E402
from spaceopt.studies import perturbed as P, perturbed_config as C  # noqa: E402

UNPERTURBED_450_MINUS_400_DAYS = 288.2166 - 257.9145     # the DAG's exact unperturbed extremals


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True, help="directory of the stage pickles and the path checkpoint")
    ap.add_argument("--h-max", type=float, default=12.0, help="the count path's largest arclength step")
    ap.add_argument("--shift-days", type=float, default=UNPERTURBED_450_MINUS_400_DAYS)
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    bench.CONFIGFILES[:] = [str(ROOT / "benchmarks/e8_exact_no_survey.yaml")]
    pc = bench._perturbed_config()

    transfer = functools.partial(bench._e8_at_eps_blend, pc)    # (model, n_rev): single shooting at ε₁

    def stage(name, make):
        path, t0 = out / f"{name}.pkl", time.perf_counter()
        if path.exists():
            sol = pickle.loads(path.read_bytes())
        else:
            sol = make()
            path.write_bytes(pickle.dumps(sol))
        r = bench._propellant_and_time(sol)
        print(f"### {name}: m_p {r['m_p_kg']:.6f} kg, tof {r['tof_days']:.5f} d, "
              f"jacobians {sol.stats.get('jacobian_evaluations')}, {time.perf_counter() - t0:.1f} s", flush=True)
        return sol

    chain_options = chain.ContinuationOptions(corrector=C.case_corrector(pc, "e8"))
    u400 = stage("u400_eps1", lambda: P.solve_for(transfer("unperturbed", 400.0), "e8_450_from_400/u400",
                                                  path="arclength", options=chain_options)[1])
    j2 = stage("j2_400_eps1", lambda: P.warm_start(u400, transfer("j2", 400.0), "e8_450_from_400/j2",
                                                   **P.warm_start_kwargs(pc, "e8", "j2", n_rev=400.0)))
    full = stage("full_400_eps1", lambda: P.warm_start(j2, transfer("g44_moon_sun", 400.0), "e8_450_from_400/full",
                                                       **P.warm_start_kwargs(pc, "e8", "g44_moon_sun", n_rev=400.0)))

    tr450 = transfer("g44_moon_sun", 450.0)
    yf, _ = final_state(full.shooting, jnp.asarray(full.z), 1.0, full.prm)
    tf400 = float(yf[hm.TIME])
    prm_to = {**tr450.params(thrust=full.thrust_N), "tf": datum(tf400 + a.shift_days * 86400.0 / tr450.tu)}
    sh_fixed = dataclasses.replace(full.shooting, fixed_time=True)
    moved = {"Lf": (full.prm["Lf"], prm_to["Lf"]), "tf": (datum(tf400), prm_to["tf"])}
    prm_path = {**prm_to, "path_from": {k: v[0] for k, v in moved.items()}, "path_to": {k: v[1] for k, v in moved.items()}}
    options = ArclengthOptions(corrector="chord", h_max=a.h_max, max_steps=400, checkpoint_dir=str(out / "ckpt"))

    def count_path():
        sh = dataclasses.replace(sh_fixed, model=dataclasses.replace(sh_fixed.model, homotopy="param"))
        z, stats = chain._run(sh, np.asarray(full.z), prm_path, "e8_450_from_400/fixed 400->450", options, path="arclength")
        return chain.Solution("ot", sh_fixed, z, prm_to, tr450, stats, thrust_N=full.thrust_N)

    fixed = stage(f"fixed_450_eps1_shift{a.shift_days:g}", count_path)
    prm_free = {k: v for k, v in prm_to.items() if k != "tf"}

    def free_time():
        z, stats = chain._newton_at_end(full.shooting, np.asarray(fixed.z), prm_free, "e8_450_from_400/free", None)
        return chain.Solution("ot", full.shooting, z, prm_free, tr450, stats, thrust_N=full.thrust_N)

    free = stage(f"free_450_eps1_shift{a.shift_days:g}", free_time)
    exact = stage(f"free_450_exact_shift{a.shift_days:g}", lambda: chain.to_exact(free, label="e8_450_from_400/exact"))
    settings = {**(P.tof_maximum_settings(pc, "e8") or {}), "lift_eps": 0.0}
    best, record = maximise_final_mass(exact, MaximumOptions(label="e8_450_from_400/end game", **settings))
    r = bench._propellant_and_time(best)
    print(f"### end game: m_p {r['m_p_kg']:.6f} kg, tof {r['tof_days']:.5f} d, status {record.get('status')}, "
          f"certified {record.get('certified')}", flush=True)


if __name__ == "__main__":
    main()
