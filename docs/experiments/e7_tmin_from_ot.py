"""E7 T_min from the minimum-fuel side: the T_min → OT homotopy followed backwards (docs/perturbed-e6-e7-e8.md,
"thirty-first session").

The (3.4.1) homotopy LP → T_min of E7 folds at τ 0.473 and runs back (twenty-ninth session).
The pipeline also has the homotopy T_min → OT (``flow.Model('tmin', 'ot')``, used by the route
LP → T_min → OT): at τ = 0 it is the T_min problem, at τ = 1 the OT problem at ε₁ with the thrust
a state pinned at T_OT. E7's OT at 1 N converges, so here that homotopy is followed from τ = 1
towards τ = 0 in arclength, starting on the converged OT:

1. the E7 unperturbed OT (``results/perturbed/e7/unperturbed.json``, ε_f) is moved up to
   ε₁ = ``--eps`` by the ε homotopy (``chain.smoothing_to``);
2. z = (its costates, K_f, T_OT) in the T_min layout (p_T(0) = 0, T an unknown);
3. the path parameter s runs from 0 to 1 with τ = τ(s) (:func:`tau_of`, geometric near τ = 0),
   and the thrust row is re-weighted (:func:`reverse`; as written, p_T(K_f) is 10⁵ times T in
   E7's units and the path folds at once).

Where the path stops short of τ = 0 (E7: a fold near τ 1e-4), ``--bound`` polishes the path
point of least thrust at its own τ (the next ones in order of T where that Newton fails,
:func:`polished_least_thrust`). That point is a transfer the dynamics allow, with thrust
T times a throttle 1 − τ + τ δ ∈ [1 − τ, 1], so it bounds T_min from above. ``--verify`` saves it
as an artifact and re-propagates its recorded control independently (``studies.verify``, with
δ = 1: the throttle's deficit, at most τ, is left out, an error of that order).

Usage (from the repository root, after ``./dev reproduce`` has built the E7 artifacts):
    python docs/experiments/e7_tmin_from_ot.py [--eps 1e-2] [--weight 1e-5] [--decades 8]
        [--h-max 0.05] [--max-steps 400] [--bound] [--verify PATH.json]
"""
import argparse
import time

import diffrax
import jax.numpy as jnp
import numpy as np

from spaceopt.config import load_yaml
from spaceopt.errors import ConvergenceError
from spaceopt.indirect import chain, flow, hamiltonians as hm
from spaceopt.indirect.continuation import ArclengthContinuation, ArclengthOptions
from spaceopt.indirect.shooting import final_state, initial_state, shoot
from spaceopt.studies import multirev, trajectory, verify


def tau_of(s, decades):
    """τ(s) from 1 (s = 0) to 0 (s = 1), and dτ/ds: τ = 1 − s for ``decades`` = 0, else
    τ = (10^(−k s) − 10^(−k)) / (1 − 10^(−k)), k = decades (geometric down to ~10^(−k), then to 0):
    near τ = 0 the path's natural measure is log τ (the propellant weight τ in S is measured
    against costates of the size of T)."""
    if decades == 0:
        return 1.0 - s, -1.0
    q, floor = 10.0 ** (-decades * s), 10.0 ** (-decades)
    return (q - floor) / (1.0 - floor), -decades * np.log(10.0) * q / (1.0 - floor)


def reverse(fn, weight, T_ot, decades, trace=None):
    """f(z, s) = f(z, τ(s)) (:func:`tau_of`), the thrust row (1 − τ) p_T(K_f) + τ (T − T_OT)
    replaced by (1 − τ) w p_T(K_f) + τ (T − T_OT) = w·row + (1 − w) τ (T − T_OT). ``trace``
    (a list) collects (τ, z, |f|) of every evaluation."""
    def at(z, s):
        tau, dtau = tau_of(s, decades)
        f, J, ftau, nsteps, ok = fn(z, tau)
        dT = z[-1] - T_ot
        f = f.at[-1].set(weight * f[-1] + (1.0 - weight) * tau * dT)
        J = J.at[-1].set(weight * J[-1]).at[-1, -1].add((1.0 - weight) * tau)
        ftau = ftau.at[-1].set(weight * ftau[-1] + (1.0 - weight) * dT)
        if trace is not None:
            trace.append((float(tau), np.array(z, dtype=float), float(jnp.linalg.norm(f))))
        return f, J, ftau * dtau, nsteps, ok
    return at


def polished_least_thrust(trace, evaluate, tol=1e-6, candidates=8):
    """The path point of least T that Newton polishes at its fixed τ: (τ, z, |f|), or None.

    Only points with |f| < ``tol`` count (on the path, not rejected corrector iterates). They are
    tried in order of increasing T: at a fold in τ, ∂f/∂z is singular and the fixed-τ Newton
    can fail on the least-T point (E7 J2)."""
    on_path = sorted((p for p in trace if p[2] < tol), key=lambda p: p[1][-1])
    for tau, z, _ in on_path[:candidates]:
        for _ in range(10):
            f, J, _, _, _ = evaluate(z, tau)
            norm = float(jnp.linalg.norm(f))
            if norm < 1e-11:
                return tau, z, norm
            z = z - np.linalg.solve(np.asarray(J), np.asarray(f))
    return None


def dense_at(tau):
    """``chain.dense`` at the homotopy point τ (it samples τ = 1, the OT end of this homotopy)."""
    def dense(sol, samples_per_rev=200):
        sh = sol.shooting
        Ks = jnp.linspace(0.0, sol.K_f, max(int(samples_per_rev * sol.transfer.n_rev), 200))
        out = flow._solve(lambda K, y, args: flow.field(sh.model, K, y, *args),
                          initial_state(sh, jnp.asarray(sol.z), sol.prm), 0.0, sol.K_f, (tau, sol.prm),
                          1e-12, 1e-13, sh.max_steps, diffrax.SaveAt(ts=Ks))
        return np.asarray(Ks), np.asarray(out.ys)
    return dense


def verified(sol, tau, path, samples_per_rev=2000):
    """Save ``sol`` (a T_min-layout point at τ) as an artifact and re-propagate its recorded
    control independently (``studies.verify``: Cartesian, SciPy DOP853, δ = 1 for 'tmin')."""
    trajectory.dense = dense_at(tau)
    multirev.save(sol, path, load_yaml("config/studies/perturbed.yaml"), 0.0, samples_per_rev=samples_per_rev)
    return verify.verify_ot(path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", default="unperturbed")
    ap.add_argument("--eps", type=float, default=1e-2, help="ε₁ of the homotopy's OT end")
    ap.add_argument("--weight", type=float, default=1e-5, help="w of p_T(K_f) in the thrust row")
    ap.add_argument("--decades", type=float, default=8.0, help="k of tau_of (0: tau = 1 - s)")
    ap.add_argument("--h-max", type=float, default=0.05)
    ap.add_argument("--tol", type=float, default=1e-6, help="corrector tolerance on the path")
    ap.add_argument("--max-steps", type=int, default=400)
    ap.add_argument("--bound", action="store_true", help="where the path stops: polish its least-T point")
    ap.add_argument("--verify", help="save the end point as this .json artifact and re-propagate it (studies.verify)")
    a = ap.parse_args()
    ot = multirev.load(f"results/perturbed/e7/{a.model}.json")
    tr = ot.transfer
    t0 = time.perf_counter()
    up = chain.smoothing_to(ot, a.eps, label="eps up")
    sh = chain.shooting_for("tmin", "ot", tr)
    prm = {**tr.params(thrust=ot.thrust_N), "eps_blend": jnp.asarray(a.eps)}
    z0 = chain.start_vector(sh, up.costates(), up.K_f, ot.thrust_N / tr.force_unit)
    rtol, atol = chain._path_tolerances(sh)
    at_end_tolerances = lambda z, tau: shoot(sh, jnp.asarray(z), tau, prm)  # noqa: E731
    trace = []
    cont = ArclengthContinuation(
        reverse(lambda z, tau: shoot(sh, jnp.asarray(z), tau, prm, rtol, atol), a.weight, z0[-1], a.decades, trace),
        ArclengthOptions(h_max=a.h_max, tol_step=a.tol, max_steps=a.max_steps, label="e7 OT->T_min"),
        polish=reverse(at_end_tolerances, a.weight, z0[-1], a.decades))
    try:
        z, _ = cont.run(z0)
        tau, norm = 0.0, cont.stats.residual
    except ConvergenceError as exc:
        print(f"the path stopped: {exc}")
        if not a.bound:
            return
        fixed_tau = reverse(at_end_tolerances, a.weight, z0[-1], 0.0)
        found = polished_least_thrust(trace, lambda zz, t: fixed_tau(zz, 1.0 - t))
        if found is None:
            print("no bound: the fixed-τ Newton converged at none of the least-thrust path points")
            return
        tau, z, norm = found
    yf, _ = final_state(sh, jnp.asarray(z), tau, prm)
    u = tr.units()
    print(f"{'T_min' if tau == 0.0 else 'upper bound on T_min'}: T = {float(z[-1]) * tr.force_unit:.6f} N at "
          f"τ {tau:.3e} (throttle ≥ {1.0 - tau:.6f}), |F| {norm:.1e}; Δt {float(yf[hm.TIME]) * u['time_s'] / 86400:.4f} d, "
          f"m_f {float(yf[hm.MASS]) * u['mass_kg']:.3f} kg, element residuals "
          f"{np.max(np.abs(np.asarray(yf[:5] - prm['xf']))):.1e}; {cont.stats.jacobians} path Jacobians, "
          f"{time.perf_counter() - t0:.0f} s")
    if a.verify:
        T = float(z[-1]) * tr.force_unit
        print("independent re-propagation:", verified(chain.Solution("tmin", sh, z, prm, tr, {}, thrust_N=T), tau, a.verify))


if __name__ == "__main__":
    main()
