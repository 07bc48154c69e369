"""Where does E7's full-model T_min bound lead on its own T_min → OT path? (thirty-fifth session)

The full model's check carries the J2 bound over at τ_ot ≈ 1.4e-4 (tmin_from_ot.bound_in_model),
because the full model's path from its own OT folds at τ 0.995. This follows the full model's
T_min → OT homotopy from the carried bound upwards, τ_ot → 1 (the re-weighted thrust row and the
geometric τ(s) of solve_tmin_from_ot, run backwards: s = s_ot (1 − σ), σ from 0 to 1), to see
whether it reaches the OT problem at ε₁, and where.

Measured (code 2aec3a4, one core): it does not get far. From τ_ot 1.38e-4 it climbs to τ 1.99e-4
(σ 0.0413) in 19 steps and then stalls there: the corrector stops contracting at |F| ~ 1e-6, the
step falls to 2e-6, 55 steps, 36 rejected, 147 Jacobians in 6.5 min (stopped by hand). This is
the region where the J2 and unperturbed paths from their OT crawl and fold (λ_m + τ → 0).

    python docs/experiments/e7_bound_upwards.py results/perturbed/e7/tmin_g44_moon_sun.json [max_steps]
"""
import sys

import jax.numpy as jnp
import numpy as np

from spaceopt.indirect import hamiltonians as hm
from spaceopt.indirect.chain import _path_tolerances
from spaceopt.indirect.continuation import ArclengthContinuation, ArclengthOptions
from spaceopt.indirect.shooting import final_state, shoot
from spaceopt.indirect.tmin_from_ot import FromOtOptions, reversed_map
from spaceopt.studies import perturbed as P

bound = P.load(sys.argv[1])
max_steps = int(sys.argv[2]) if len(sys.argv) > 2 else 200
k = FromOtOptions().tau_decades
tau_ot, weight = bound.tau, bound.extra["weight"]
T_ot = bound.extra["T_ot_N"] / bound.transfer.force_unit
s_ot = -np.log10(tau_ot * (1.0 - 10.0 ** -k) + 10.0 ** -k) / k
sh, prm = bound.shooting, bound.prm
rtol, atol = _path_tolerances(sh)
trace = []
on_s = reversed_map(lambda z, t: shoot(sh, jnp.asarray(z), t, prm, rtol, atol), weight, T_ot, k, trace)
at_end = reversed_map(lambda z, t: shoot(sh, jnp.asarray(z), t, prm), weight, T_ot, k)


def upwards(evaluate):
    def at(z, sigma):
        f, J, fs, nsteps, ok = evaluate(z, s_ot * (1.0 - sigma))
        return f, J, -s_ot * fs, nsteps, ok
    return at


print(f"from tau_ot {tau_ot:.4e} (s {s_ot:.5f}), T {bound.thrust_N:.8f} N", flush=True)
cont = ArclengthContinuation(upwards(on_s), ArclengthOptions(h_max=0.05, tol_step=1e-6, max_steps=max_steps,
                                                            label="e7 full bound -> OT"),
                             polish=upwards(at_end))
try:
    z, _ = cont.run(np.asarray(bound.z, float))
    yf, _ = final_state(sh, jnp.asarray(z), 1.0, prm)
    tr = bound.transfer
    print(f"reached tau = 1 (the OT at eps {tr.eps_blend}, T pinned): T {float(z[-1]) * tr.force_unit:.8f} N, "
          f"m_f {float(yf[hm.MASS]) * tr.m0:.4f} kg, t_f {float(yf[hm.TIME]) * tr.tu / 86400:.4f} d, "
          f"{cont.stats.as_dict()}", flush=True)
except Exception as exc:                                    # a scratch study: report where it stopped
    on_path = [p for p in trace if p[2] < 1e-6]
    top = max(on_path, key=lambda p: p[0]) if on_path else None
    print(f"stopped: {exc}; highest tau on the path {top[0] if top else None}, "
          f"T there {float(top[1][-1]) * bound.transfer.force_unit if top else None} N", flush=True)
