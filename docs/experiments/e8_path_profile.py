"""Where the E8 LP → OT path's time goes, per corrector: every evaluation timed (fifty-fifth session).

Usage (repository root): PYTHONPATH=src .venv/bin/python docs/experiments/e8_path_profile.py N CORRECTOR...
e.g. ``450 chord broyden``. The exact profile's transfer at N revolutions, smoothing stopped at ε₁
(as ``benchmarks/perturbed.py --corrector-compare``); the chain's ``shoot`` and ``residual`` are
wrapped to time each call. Prints per corrector: wall time; per kind of evaluation (Jacobian or f
alone) and tolerance (the path's, or None: the end point's): calls, seconds, integration steps a
call; the first and last ten Jacobian times.
"""
import collections
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import perturbed as B  # noqa: E402

import jax.numpy as jnp  # noqa: E402
from spaceopt.indirect import chain  # noqa: E402

B.CONFIGFILES[:] = []       # the study config: E8 on the exact map
n, order = float(sys.argv[1]), sys.argv[2:]
pc = B._perturbed_config()
tr = B._e8_at_eps_blend(pc, "unperturbed", n)
lp = chain.solve_lp(tr, label="profile/lp", options=chain.ContinuationOptions(verbose=False))
calls = []
shoot, residual = chain.shoot, chain.residual


def timed_shoot(sh, z, tau, prm, rtol=None, atol=None):
    t = time.perf_counter()
    out = shoot(sh, z, tau, prm, rtol, atol)
    jnp.asarray(out[1]).block_until_ready()
    calls.append(("J", rtol, time.perf_counter() - t, int(out[3])))
    return out


def timed_residual(sh, z, tau, prm, rtol=None, atol=None):
    t = time.perf_counter()
    out = residual(sh, z, tau, prm, rtol, atol)
    jnp.asarray(out[0]).block_until_ready()
    calls.append(("f", rtol, time.perf_counter() - t, 0))
    return out


chain.shoot, chain.residual = timed_shoot, timed_residual
for corrector in order:
    calls.clear()
    t0 = time.perf_counter()
    chain.solve_ot(lp, tr.thrust, chain.ContinuationOptions(corrector=corrector, verbose=False),
                   label=f"profile/{corrector}", path="arclength")
    print(f"{corrector}: wall {time.perf_counter() - t0:.1f} s, in evaluations {sum(c[2] for c in calls):.1f} s")
    kinds = collections.defaultdict(lambda: [0, 0.0, 0])
    for kind, rtol, dt, steps in calls:
        k = kinds[(kind, rtol)]
        k[0], k[1], k[2] = k[0] + 1, k[1] + dt, k[2] + steps
    for (kind, rtol), (count, dt, steps) in sorted(kinds.items(), key=str):
        print(f"   {kind} at rtol {rtol}: {count} calls, {dt:.1f} s, {dt / count:.3f} s each"
              + (f", {steps / count:.0f} steps a call" if kind == "J" else ""))
    jac = [round(c[2], 2) for c in calls if c[0] == "J"]
    print(f"   Jacobian times, first ten {jac[:10]}, last ten {jac[-10:]}")
