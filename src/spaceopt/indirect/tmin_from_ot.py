"""Minimum thrust from the minimum-fuel side: the T_min → OT homotopy followed backwards.

The existence check of §3.4 solves the minimum-thrust problem by the (3.4.1) homotopy from the
LP (:func:`.chain.solve_tmin`). Where that path folds (E7, GTO → Molniya over 100 revolutions:
at τ 0.473, unperturbed and at 20 and 50 revolutions alike), a converged OT solution at the
case's thrust T_OT gives a second way in. The route LP → T_min → OT has a homotopy
(``flow.Model('tmin', 'ot')``, :func:`.chain.solve_ot_from_tmin`) whose τ = 0 end is the T_min
problem and whose τ = 1 end is the OT problem at ε₁ with the thrust, a state, pinned at T_OT:

    H_τ = −(1 − τ) ½T² + δ_τ T k1 [k2 |A_τ|/m − (p_m + τ)/c] + k1 p_t,   δ_τ = 1 − τ + τ δ(S, ε₁),
    thrust row (1 − τ) p_T(K_f) + τ (T − T_OT) = 0.

Here it is followed from τ = 1 to τ = 0, in arclength, from the OT solution moved to ε₁:

1. the path parameter s runs from 0 (τ = 1) to 1 (τ = 0) with τ(s) geometric near τ = 0
   (:func:`tau_of`): the propellant weight τ in S is measured against costates of the size of
   T, so the path's natural measure there is log τ;
2. the thrust row is re-weighted to (1 − τ) w p_T(K_f) + τ (T − T_OT) (:func:`reversed_map`),
   w = |T_OT / p_T(K_f)| at the start unless given: as written, E7's p_T(K_f) is 10⁵ times T in
   the problem's units and the path folds at once;
3. a path that reaches τ = 0 is the T_min solution (``tau`` 0); one that stops short (E7: a fold
   near τ 1e-4, where λ_m + τ → 0 and the last coasts vanish) gives an **upper bound**: the path
   point of least T that Newton polishes at its own fixed τ (:func:`polished_least_thrust`) is a
   transfer the dynamics allow with thrust T·δ_τ ≤ T, so every thrust of at least T has one,
   T_min ≤ T. The solution keeps its τ; its samples carry the throttle δ_τ
   (:mod:`spaceopt.studies.trajectory`) and the independent re-propagation replays it;
4. where a force model's own path folds at once (E7 with 4×4 + Moon + Sun), the bound of a
   simpler model is carried over to it at its fixed τ by blending the force model
   (:func:`bound_in_model`): another upper bound, under the target model.

Written here rather than with a library: the path follower is the project's own
(:class:`.continuation.ArclengthContinuation`), this module only maps the homotopy onto it.
"""
from __future__ import annotations

from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from ..errors import ConvergenceError
from . import hamiltonians as hm
from .chain import Solution, _path_tolerances, check_arrival_in_window, shooting_for, smoothing_to, start_vector
from .continuation import ArclengthContinuation, ArclengthOptions
from .flow import model_blend_params
from .shooting import final_state, shoot


@dataclass(frozen=True)
class FromOtOptions:
    """How the T_min → OT homotopy is followed back from an OT solution (module docstring)."""
    tau_decades: float = 8.0        # k of tau_of; 0: τ = 1 − s
    weight: float = 0.0             # w of p_T(K_f) in the thrust row; 0: |T_OT / p_T(K_f)| at the start
    h_max: float = 0.05             # arclength step cap
    tol_step: float = 1e-6          # corrector tolerance on the path
    max_steps: int = 120            # path steps before the bound is taken (E7: the fold after ~100)
    candidates: int = 8             # least-thrust path points tried by the bound's polish
    verbose: bool = True

    def arclength(self, label: str) -> ArclengthOptions:
        """The path follower's options."""
        return ArclengthOptions(h_max=self.h_max, tol_step=self.tol_step, max_steps=self.max_steps,
                                verbose=self.verbose, label=label)


def tau_of(s, decades):
    """τ(s) from 1 (s = 0) to 0 (s = 1), and dτ/ds: τ = 1 − s for ``decades`` = 0, else
    τ = (10^(−k s) − 10^(−k)) / (1 − 10^(−k)), k = ``decades``."""
    if decades == 0:
        return 1.0 - s, -1.0
    q, floor = 10.0 ** (-decades * s), 10.0 ** (-decades)
    return (q - floor) / (1.0 - floor), -decades * np.log(10.0) * q / (1.0 - floor)


def weighted_thrust_row(shot, z, tau, weight, T_ot, tau_moves=True):
    """:func:`.shooting.shoot`'s tuple ``shot`` with the thrust row (1 − τ) p_T(K_f) + τ (T − T_OT)
    replaced by (1 − τ) w p_T(K_f) + τ (T − T_OT) = w·row + (1 − w) τ (T − T_OT). ``tau_moves``:
    τ is the path's parameter (its column gets the added term's derivative); False where τ is held
    and the path moves something else (:func:`bound_in_model`)."""
    f, J, ftau, nsteps, ok = shot
    dT = z[-1] - T_ot
    f = f.at[-1].set(weight * f[-1] + (1.0 - weight) * tau * dT)
    J = J.at[-1].set(weight * J[-1]).at[-1, -1].add((1.0 - weight) * tau)
    ftau = ftau.at[-1].set(weight * ftau[-1] + ((1.0 - weight) * dT if tau_moves else 0.0))
    return f, J, ftau, nsteps, ok


def reversed_map(shoot_at, weight, T_ot, decades, trace=None):
    """f(z, s) = f(z, τ(s)) with the thrust row weighted (:func:`weighted_thrust_row`);
    ``shoot_at(z, τ)`` returns :func:`.shooting.shoot`'s tuple. ``trace`` (a list) collects
    (τ, z, |f|) of every evaluation."""
    def at(z, s):
        tau, dtau = tau_of(s, decades)
        f, J, ftau, nsteps, ok = weighted_thrust_row(shoot_at(z, tau), z, tau, weight, T_ot)
        if trace is not None:
            trace.append((float(tau), np.array(z, dtype=float), float(jnp.linalg.norm(f))))
        return f, J, ftau * dtau, nsteps, ok
    return at


def polished_least_thrust(trace, evaluate, tol, candidates):
    """The path point of least T that Newton polishes at its fixed τ: (τ, z, |f|), or None.

    Only points with |f| < ``tol`` count (on the path, not rejected corrector iterates). They are
    tried in order of increasing T: at a fold in τ, ∂f/∂z is singular and the fixed-τ Newton
    can fail on the least-T point (E7 J2). ``evaluate(z, τ)`` returns :func:`shoot`'s tuple."""
    on_path = sorted((p for p in trace if p[2] < tol), key=lambda p: p[1][-1])
    for tau, z, _ in on_path[:candidates]:
        found = newton_at_fixed_tau(evaluate, z, tau)
        if found is not None:
            return (tau, *found)
    return None


def newton_at_fixed_tau(evaluate, z, tau, iterations=10):
    """Newton on f(·, τ) from z to |f| < 1e-11: (z, |f|), or None where it fails within
    ``iterations``; ``evaluate(z, τ)`` returns :func:`shoot`'s tuple."""
    for _ in range(iterations):
        f, J, _, _, ok = evaluate(z, tau)
        norm = float(jnp.linalg.norm(f))
        if not ok or not np.isfinite(norm):
            return None
        if norm < 1e-11:
            return z, norm
        z = z - np.linalg.solve(np.asarray(J), np.asarray(f))
    return None


def thrust_row_weight(sh, z, prm) -> float:
    """|T_OT / p_T(K_f)| at the OT end (τ = 1) of the path: the weight that puts both terms of
    the thrust row on one scale."""
    yf, _ = final_state(sh, jnp.asarray(z), 1.0, prm)
    p_T = float(yf[sh.model.n + hm.THRUST])
    return abs(float(z[-1]) / p_T) if p_T != 0.0 else 1.0


def solve_tmin_from_ot(ot: Solution, options: FromOtOptions = FromOtOptions(), label="tmin from ot") -> Solution:
    """T_min, or an upper bound on it, from the OT solution ``ot`` (module docstring).

    Returns a 'tmin' Solution of the T_min → OT homotopy at its ``tau``: 0 where the path
    reached the T_min problem, > 0 for the bound (``extra['bound']``). Raises ConvergenceError
    where the path stops short and no path point polishes.
    """
    if ot.stage != "ot":
        raise ValueError(f"solve_tmin_from_ot needs an OT solution, got stage {ot.stage!r}")
    tr = ot.transfer
    start = smoothing_to(ot, tr.eps_blend, label=f"{label} eps up") if float(ot.prm["eps_final"]) != tr.eps_blend else ot
    sh = shooting_for("tmin", "ot", tr)
    prm = tr.params(thrust=ot.thrust_N)
    z0 = start_vector(sh, start.costates(), start.K_f, ot.thrust_N / tr.force_unit)
    weight = options.weight or thrust_row_weight(sh, z0, prm)
    rtol, atol = _path_tolerances(sh)
    trace = []
    on_path = reversed_map(lambda z, tau: shoot(sh, jnp.asarray(z), tau, prm, rtol, atol),
                           weight, z0[-1], options.tau_decades, trace)
    at_end = lambda z, tau: shoot(sh, jnp.asarray(z), tau, prm)  # noqa: E731
    cont = ArclengthContinuation(on_path, options.arclength(f"{label} (OT -> T_min)"),
                                 polish=reversed_map(at_end, weight, z0[-1], options.tau_decades))
    extra = {"route": "ot-tmin", "weight": weight, "T_ot_N": ot.thrust_N, "eps_blend": tr.eps_blend,
             "eps_up": start.stats if start is not ot else None}
    try:
        z, _ = cont.run(z0)
        tau, norm, stopped = 0.0, cont.stats.residual, None
    except ConvergenceError as exc:
        found = polished_least_thrust(trace, _fixed_tau(sh, prm, weight, z0[-1]), options.tol_step,
                                      options.candidates)
        if found is None:
            exc.diagnosis["bound"] = "no least-thrust path point polished at its fixed tau"
            raise
        tau, z, norm = found
        stopped = {"reason": exc.diagnosis.get("reason"),      # the follower's "tau" is s here
                   "tau_reached": min(p[0] for p in trace if p[2] < options.tol_step)}
    stats = {**cont.stats.as_dict(), "path": "arclength", "final_residual": norm}
    extra.update({"tau": tau, "bound": tau > 0.0, "throttle_min": 1.0 - tau, "path_stopped": stopped})
    sol = Solution("tmin", sh, np.asarray(z, float), prm, tr, stats, extra=extra, tau=tau)
    sol.thrust_N = float(z[-1]) * tr.force_unit
    return sol


def _fixed_tau(sh, prm, weight, T_ot):
    """f(z, τ) of the T_min → OT homotopy at a fixed τ, at the end-point tolerances, its thrust
    row weighted as on the path."""
    at_end = lambda z, tau: shoot(sh, jnp.asarray(z), tau, prm)  # noqa: E731
    on_s = reversed_map(at_end, weight, T_ot, 0.0)                # s = 1 − τ
    return lambda z, tau: on_s(z, 1.0 - tau)


def bound_in_model(bound: Solution, tr_to, options: FromOtOptions = FromOtOptions(),
                   label="tmin bound model") -> Solution:
    """An upper bound on T_min under the force model of ``tr_to``, from a bound under another.

    Where the T_min → OT path of the target model folds at once (E7 with 4×4 + Moon + Sun: at
    τ 0.995 from its OT), the bound found under a simpler model (J2) is carried over instead: at
    its own fixed τ_ot and thrust-row weight, the force model is blended from the bound's to
    ``tr_to``'s by a second parameter b, a_p = (1 − b) a_p,from + b a_p,to (flow.Model
    ('tmin', 'model')), followed in arclength from b = 0 (the bound itself) to b = 1. There the
    point solves the target model's T_min → OT problem at τ_ot, polished by Newton: a transfer
    under the target model with thrust T·δ_τ ≤ T, so T_min ≤ T there too (module docstring).
    Raises ConvergenceError where the blend stops short of b = 1 or the end point does not polish.
    """
    if bound.stage != "tmin" or not bound.extra.get("bound") or not (bound.transfer.perturbed and tr_to.perturbed):
        raise ValueError("bound_in_model needs an upper bound on T_min (tmin_from_ot) of a perturbed "
                         "transfer, and a perturbed target")
    if tr_to.eps_blend != bound.extra["eps_blend"]:
        raise ValueError(f"bound_in_model: the target's eps_blend {tr_to.eps_blend} is not the bound's "
                         f"{bound.extra['eps_blend']}")
    tau_ot, weight = bound.tau, bound.extra["weight"]
    T_ot = bound.extra["T_ot_N"] / tr_to.force_unit
    prm = tr_to.params(thrust=bound.extra["T_ot_N"])
    # E7: the bounds arrive after 150-160 d, the OT after 88 d
    check_arrival_in_window(bound, prm["pert"], "arrival of the bound carried over")
    blend_prm = {**model_blend_params(prm, bound.prm["pert"]), "tau_ot": tau_ot}
    sh = shooting_for("tmin", "model", tr_to)
    rtol, atol = _path_tolerances(sh)
    blended = lambda tol: lambda z, b: weighted_thrust_row(  # noqa: E731
        shoot(sh, jnp.asarray(z), b, blend_prm, *tol), z, tau_ot, weight, T_ot, tau_moves=False)
    cont = ArclengthContinuation(blended((rtol, atol)),
                                 options.arclength(f"{label} (force-model blend at tau {tau_ot:.3g})"),
                                 polish=blended((None, None)))
    z, _ = cont.run(np.asarray(bound.z, float))
    sh_to = shooting_for("tmin", "ot", tr_to)
    found = newton_at_fixed_tau(_fixed_tau(sh_to, prm, weight, T_ot), np.asarray(z, float), tau_ot)
    if found is None:
        raise ConvergenceError(f"{label}: the end of the force-model blend does not polish at tau {tau_ot:.3g}",
                               {"reason": "end point not polished", "tau": tau_ot, "z_best": np.asarray(z).tolist()})
    z, norm = found
    stats = {**cont.stats.as_dict(), "path": "arclength", "final_residual": norm}
    extra = {**{k: bound.extra[k] for k in ("weight", "T_ot_N", "eps_blend")},
             "route": f"{bound.extra['route']}-model", "tau": tau_ot, "bound": True, "throttle_min": 1.0 - tau_ot,
             "from_model_bound_N": bound.thrust_N, "path_stopped": bound.extra.get("path_stopped")}
    sol = Solution("tmin", sh_to, np.asarray(z, float), prm, tr_to, stats, extra=extra, tau=tau_ot)
    sol.thrust_N = float(z[-1]) * tr_to.force_unit
    return sol
