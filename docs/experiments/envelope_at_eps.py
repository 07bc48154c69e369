"""Does dm_f/dt_f = −m₀φ hold on the fixed-time family at a larger smoothing ε? (thirty-fourth session)

On the perturbed E1 problem of tests/test_free_time.py (EGM96 4×4 and the Earth rotation angle,
2 revolutions, OT 15 N): the fixed-time point at the free-time extremal's own t_f is moved to ε
(:meth:`MaximumSearch.move_eps`), and the fixed-time points 0.01 d either side are solved at that
ε; the change of m_f is compared with the trapezoid of −m₀φ Δt. The smoothed extremals extremise
a cost that carries the penalty √c ε √(δ(1 − δ)) (the maximiser of δS plus it is δ of (3.3.2)),
so the relation holds for m_f/m₀ plus that penalty's integral, and m_f alone departs from it as ε
grows: measured, ±0.18 g at ε_f = 1e-5 (the trapezoid's own error, φ is curved), ±0.2 g at 1e-4,
±1.7 g at 1e-3, ±31 g at 1e-2, of changes of about 9 g; the signs (+ below, − above) are those of
a penalty integral that grows with t_f. This is why ``MaximumSearch.branch_jump`` is sound at ε_f
only (docs/perturbed-e6-e7-e8.md, "thirty-fourth session").

    python docs/experiments/envelope_at_eps.py
"""
import dataclasses
from pathlib import Path

import yaml

from spaceopt.indirect import chain, free_time as ft
from spaceopt.indirect.continuation import ContinuationOptions
from spaceopt.studies import multirev, perturbed as P

QUIET = ContinuationOptions(verbose=False)
cfg = yaml.safe_load(Path("config/studies/multirev.yaml").read_text())["multirev"]
tr = multirev.transfer_from_config(cfg, "e1")
ot = chain.solve_ot(chain.solve_lp(tr, QUIET), 15.0, QUIET)
tr_p = dataclasses.replace(tr, perturbations={"geopotential": {"degree": 4, "order": 4}, "earth_angle": "era"},
                           epoch_utc="2021-05-09T12:00:00")
sol = P.perturb_from_unperturbed(ot, tr_p, "e1 g44", options=QUIET)
opt = ft.MaximumOptions(verbose=False, lift_steps=4)     # move_eps: 4 log-uniform steps in ε
fam = ft.FixedTimeFamily(sol.shooting, sol.prm, opt)
s = ft.MaximumSearch(fam, sol.transfer.tu, sol.transfer.m0)
t0 = fam.end_time(sol.z)
p0 = s.solve(t0, sol.z)
h = 0.01 * ft.DAY / sol.transfer.tu
m0 = sol.transfer.m0
print("eps_f", fam.eps_f)
for eps in (fam.eps_f, 1e-4, 1e-3, 1e-2):
    p = p0 if eps == fam.eps_f else s.move_eps(p0, eps)
    fam.set_eps(eps)
    for side in (-1, 1):
        q = fam.point(p.tf + side * h, ft.extrapolate([p], p.tf + side * h, fam.e_t), p.J)
        if q is None:
            print(f"eps {eps:.0e} side {side:+d}: fixed-time Newton failed")
            continue
        obs = (q.m_f - p.m_f) * m0
        pred = -m0 * 0.5 * (p.phi + q.phi) * side * h
        print(f"eps {eps:.0e} side {side:+d}: dm_f obs {1e3*obs:+.4f} g, -m0 phi dt {1e3*pred:+.4f} g, diff {1e3*(obs-pred):+.4f} g", flush=True)
    fam.set_eps(fam.eps_f)
