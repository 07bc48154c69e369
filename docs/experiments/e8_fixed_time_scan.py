"""The free-time condition of a perturbed OT extremal as a 1-D function of the time of flight.

At the E8 full-model extremals the weakest residual direction is p_t(K_f) = 0, the free-final-time
condition (docs/perturbed-e6-e7-e8.md, second session of 23 Nov; twentieth session: u_min is the
p_t(K_f) row). This script splits the problem in two:

* inner: the **fixed-time** OT problem (1.1.11), the same unknowns z with the row p_t(K_f) = 0
  replaced by t(K_f) = t_f, solved by Newton at each t_f of a scan, each start predicted from the
  last solutions (the tangent dz/dt_f = J⁻¹ e_t from the first, ∂f/∂t_f = −e_t);
* outer: φ(t_f) = p_t(K_f) of the fixed-time extremal. Its roots are exactly the free-time
  extremals. By the envelope theorem dm_f/dt_f = −m₀ φ (t_f in time units; checked to 1–2 % by
  finite differences on E5), so the free-time extremals are the stationary points of the final
  mass m_f(t_f) of the fixed-time family: a scan shows all of them in its range, and which are
  local maxima (docs/perturbed-e6-e7-e8.md, "twenty-first session").

Usage (repository root; OUT gets one JSON line per fixed-time point: t_f, m_f, φ, |f|, z, …):

  python docs/experiments/e8_fixed_time_scan.py artifact ARTIFACT.json OUT STEP_DAYS UP DOWN
  python docs/experiments/e8_fixed_time_scan.py job MODEL N START OUT STEP_DAYS UP DOWN
  python docs/experiments/e8_fixed_time_scan.py artifact ARTIFACT.json refine OUT DAYS_TOL

``artifact``: the family through a converged free-time OT artifact (an unperturbed one too: p_t
joins the unknowns at 0), started at its Δt, UP steps of STEP_DAYS upwards, then DOWN downwards.
``job``: the DAG's E8 job (MODEL, N) as ``e8_valley_scan.job_problem`` builds it, started at a
failed end point: a failure JSON's z, or an .npz whose x0 is a valley point there.
``refine``: closes the first bracket in OUT where φ turns from − to + (a local maximum of m_f).
The library's end game (``spaceopt.indirect.free_time``, twenty-second session) does the
search of a local maximum itself; this script scans a range and keeps every point.
One fixed-time point costs 2–5 Jacobians: 7 s on E5, ~2 min at 250 revolutions.
"""
from __future__ import annotations

import dataclasses
import json
import sys
import time

import numpy as np
import yaml

from spaceopt.errors import ArtifactError
from spaceopt.indirect import hamiltonians as hm
from spaceopt.indirect.free_time import FixedTimeFamily, MaximumOptions, extrapolate
from spaceopt.studies import multirev

DAY = 86400.0
PHI_TOL = 1e-8       # |φ| that ends a refinement (the free-time polish accepts |F| 1e-8 … 4e-8)


class Family:
    """The fixed-time problems of one free-time problem (sh_free, prm0): solve one t_f, log it.
    The solves are the library's (``free_time.FixedTimeFamily``, its default tolerances)."""

    def __init__(self, sh_free, prm0, z0, tu, m0, out):
        z0 = np.asarray(z0, float)
        if hm.TIME not in sh_free.free_costates:
            # an unperturbed layout (p_t ≡ 0 there, not an unknown): p_t(0) joins, starting at 0
            free = tuple(sorted((*sh_free.free_costates, hm.TIME)))
            z0 = np.insert(z0, free.index(hm.TIME), 0.0)
            sh_free = dataclasses.replace(sh_free, free_costates=free)
        self.family = FixedTimeFamily(sh_free, prm0, MaximumOptions())
        self.sh_free, self.prm0 = sh_free, prm0
        self.z0, self.tu, self.m0, self.out = z0, tu, m0, out
        self.t0 = self.family.end_time(z0)
        self.e_t = self.family.e_t

    def point(self, z, tf):
        """The fixed-time extremal at t_f from the start z: (the library's point, its record)."""
        w, jac = time.perf_counter(), self.family.jacobians
        p = self.family.point(tf, z)
        if p is None:
            raise RuntimeError(f"fixed-time Newton failed at t_f {tf * self.tu / DAY:.5f} d")
        rec = {"tf_days": tf * self.tu / DAY, "m_f_kg": p.m_f * self.m0, "phi_pt_Kf": p.phi,
               "K_f_deg": float(np.degrees(p.z[self.sh_free.kf_index])),
               "jacobians": self.family.jacobians - jac, "wall_s": time.perf_counter() - w, "z": p.z.tolist()}
        with open(self.out, "a") as fh:
            fh.write(json.dumps(rec) + "\n")
        print(f"t_f {rec['tf_days']:.4f} d  m_f {rec['m_f_kg']:.6f} kg  phi {rec['phi_pt_Kf']:+.4e}  "
              f"jac {rec['jacobians']}  {rec['wall_s']:.0f} s", flush=True)
        return p, rec


def scan(fam, step_days, up, down):
    """The family through its start (at the start's own t(K_f)): UP steps of STEP_DAYS upwards,
    then DOWN steps downwards from the start."""
    start, _ = fam.point(fam.z0, fam.t0)
    dtf = step_days * DAY / fam.tu
    for sign, count in ((+1, up), (-1, down)):
        # each start: the library's extrapolation (the tangent from the first point, then the
        # polynomial through the last solutions; the family bends: from the 250-rev extremal
        # the tangent step of 0.1 d misses t_f by 0.29 time units of 0.315)
        trail, tf = [start], fam.t0
        for _ in range(count):
            tf += sign * dtf
            trail.append(fam.point(extrapolate(trail, tf, fam.e_t), tf)[0])


def refine(fam, days_tol):
    """The root of φ(t_f) in the first bracket of OUT where φ turns from − to + as t_f grows
    (dm_f/dt_f = −m₀ φ: a local maximum of m_f), by the Illinois variant of regula falsi, each
    start interpolated between the bracket's solutions; then the free-time residual there."""
    pts = sorted((json.loads(line) for line in open(fam.out)), key=lambda r: r["tf_days"])
    lo, hi = next((a, b) for a, b in zip(pts, pts[1:]) if a["phi_pt_Kf"] <= 0 < b["phi_pt_Kf"])
    fa, fb, last = lo["phi_pt_Kf"], hi["phi_pt_Kf"], None
    while hi["tf_days"] - lo["tf_days"] > days_tol and min(-fa, fb) > 0:
        w = fa / (fa - fb)
        tf_days = lo["tf_days"] + w * (hi["tf_days"] - lo["tf_days"])
        _, rec = fam.point((1 - w) * np.asarray(lo["z"]) + w * np.asarray(hi["z"]), tf_days * DAY / fam.tu)
        if abs(rec["phi_pt_Kf"]) < PHI_TOL:
            lo = hi = rec
            break
        if rec["phi_pt_Kf"] < 0:
            lo, fa = rec, rec["phi_pt_Kf"]
            fb *= 0.5 if last == "lo" else 1.0       # Illinois: the same end kept twice
            last = "lo"
        else:
            hi, fb = rec, rec["phi_pt_Kf"]
            fa *= 0.5 if last == "hi" else 1.0
            last = "hi"
    best = min(lo, hi, key=lambda r: abs(r["phi_pt_Kf"]))
    print(f"free-time extremal: t_f {best['tf_days']:.6f} d, m_f {best['m_f_kg']:.6f} kg "
          f"(m_p {fam.m0 - best['m_f_kg']:.6f} kg), free-time max |F| "
          f"{fam.family.free_time_residual(best['z']):.2e}", flush=True)


def load(path):
    """multirev.load, also for the JSON-only artifacts kept under docs/experiments/e8_full_model
    (their .npz and .rrd companions were not kept: the checksums are then not verified)."""
    try:
        return multirev.load(path)
    except ArtifactError as exc:
        print(f"warning: {exc}; read without its companions", flush=True)
        read_json, multirev.artifacts.read_json = multirev.artifacts.read_json, lambda p: json.load(open(p))
        try:
            return multirev.load(path)
        finally:
            multirev.artifacts.read_json = read_json


def main(args):
    if args[0] == "artifact":
        sol = load(args[1])
        problem = (sol.shooting, sol.prm, np.asarray(sol.z), sol.transfer.tu, sol.transfer.m0)
        rest = args[2:]
    else:                        # job MODEL N START: the DAG job's problem at a failed end point
        sys.path.insert(0, "docs/experiments")
        from e8_valley_scan import job_problem
        sh, prm = job_problem(args[1], float(args[2]))
        # a failure JSON's z (diagnosis), or an .npz whose x0 is a valley point (the twentieth
        # session's frame A, reached by e8_valley_scan's chords): from the 450 failure's z
        # (|f| 0.05) fixed-time Newton diverges (|f| 9 after 4 steps)
        z = json.load(open(args[3]))["diagnosis"]["z"] if args[3].endswith(".json") else np.load(args[3])["x0"]
        m0 = yaml.safe_load(open("config/studies/perturbed.yaml"))["perturbed"]["cases"]["e8"]["m0_kg"]
        problem = (sh, prm, np.asarray(z, float), float(prm["tu"]), float(m0))
        rest = args[4:]
    if rest[0] == "refine":                  # refine OUT DAYS_TOL: the root in OUT's bracket
        refine(Family(*problem, rest[1]), float(rest[2]))
    else:                                    # OUT STEP_DAYS UP DOWN
        out, step, up, down = rest
        scan(Family(*problem, out), float(step), int(up), int(down))


if __name__ == "__main__":
    main(sys.argv[1:])
