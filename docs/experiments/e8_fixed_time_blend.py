"""E8 full model at a chosen time of flight: the J2 extremal's fixed-time family walked to t_f,
the force model blended J2 → 4×4 + Moon + Sun at that fixed t_f, then the library's end game.

Why: at 450 revolutions every route we ran lands on maxima 2.27–2.80 d *longer* than the
unperturbed transfer, where the thesis has the perturbations shorten it (by 0.554–1.024 d at
200–450). The family through our maximum falls monotonically down to 286.7 d (forty-fourth
session), so a shorter maximum would lie on another branch. The blend here switches on the
perturbations with t_f held at the thesis's shorter time, so the branch it lands on is the one
the J2 transfer of that duration continues into; the end game (``free_time.maximise_final_mass``)
then climbs from there to a local maximum of m_f in t_f, certified by the sign change of p_t(K_f).

Usage (repository root, after the DAG has written results/perturbed/e8/j2_N.json and the
ephemeris; the artifacts' own map, exact or smoothed, is kept):

  python docs/experiments/e8_fixed_time_blend.py N TF_DAYS STEP_DAYS [PATH [DOWNHILL_FOLDS]]

N: the revolution count; TF_DAYS: the fixed time of flight; STEP_DAYS: the J2 family's step on
the way there; PATH: the blend's path, 'tau' (default) or 'arclength'; DOWNHILL_FOLDS: folds with
φ ≠ 0 the end game's walk may pass going downhill (``MaximumOptions.downhill_folds``, default 0),
with up to 40 fixed-time solves.
"""
from __future__ import annotations

import dataclasses
import sys
import time

import numpy as np
import yaml

from spaceopt.indirect import chain
from spaceopt.indirect.free_time import FixedTimeFamily, MaximumOptions, extrapolate, maximise_final_mass
from spaceopt.studies import multirev, perturbed as P

DAY = 86400.0


def walk(fam, z0, tf_to, step):
    """The fixed-time family of ``fam`` from the free-time root z0 to t_f = tf_to, in steps of at
    most ``step`` (time units), each start extrapolated from the trail."""
    t0 = fam.end_time(z0)
    trail = [fam.point(t0, z0)]
    n = max(1, int(np.ceil(abs(tf_to - t0) / step)))
    for tf in np.linspace(t0, tf_to, n + 1)[1:]:
        p = fam.point(tf, extrapolate(trail, tf, fam.e_t))
        if p is None:
            raise RuntimeError(f"the J2 family's Newton failed at t_f {tf:.6f}")
        trail.append(p)
        print(f"J2 fixed time: t_f {tf:.6f}  m_f {p.m_f:.9f}  phi {p.phi:+.3e}  jac {fam.jacobians}", flush=True)
    return trail[-1]


def main(n_rev, tf_days, step_days, path="tau", downhill_folds=0):
    pc = yaml.safe_load(open("config/studies/perturbed.yaml"))["perturbed"]
    j2 = multirev.load(f"results/perturbed/e8/j2_n{n_rev}.json")
    tu = j2.transfer.tu
    start = time.perf_counter()
    fam = FixedTimeFamily(j2.shooting, j2.prm, MaximumOptions())
    p = walk(fam, np.asarray(j2.z), tf_days * DAY / tu, step_days * DAY / tu)
    # the J2 artifact's transfer (its profile's tolerances) under the full force model
    tr = dataclasses.replace(j2.transfer, perturbations=P.model_config(pc, "g44_moon_sun"),
                             ephemeris=P.ephemeris_path("results", pc["cases"]["e8"]["ephemeris"]))
    fixed = dataclasses.replace(j2, shooting=fam.sh, z=p.z, prm={**j2.prm, "tf": p.tf})
    prm_to = {**tr.params(thrust=j2.thrust_N), "tf": p.tf}
    full = chain.continue_in_model(fixed, prm_to, label="J2 -> full at fixed t_f", path=path)
    free = dataclasses.replace(full, shooting=j2.shooting)
    print(f"full model at fixed t_f {tf_days} d: z {np.round(full.z, 9).tolist()} "
          f"({time.perf_counter() - start:.0f} s)", flush=True)
    downhill_folds = int(downhill_folds)
    options = MaximumOptions(label="end game", downhill_folds=downhill_folds, max_arc_step=8.0,
                             max_points=40 if downhill_folds else MaximumOptions.max_points)
    best, record = maximise_final_mass(free, options)
    print(f"end game: {record['status']}, t_f {record.get('tof_days')} d, m_f {record.get('m_f_kg')} kg, "
          f"m_p {tr.m0 - record.get('m_f_kg', np.nan)} kg ({time.perf_counter() - start:.0f} s)", flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3]), *sys.argv[4:])
