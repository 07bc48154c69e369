"""The LP → T_min → OT chain (dissertation §3.3–3.4), from the zero initial guess.

1. LP from z = (0, …, 0, K_f = ΔL) by the Newton homotopy (3.1.3): a coast on the initial orbit.
2. LP → T_min by the homotopy (3.4.1), starting from 2× the LP costates (the (3.4.1) LP limit is
   ½k|A|², spec 01-methods §3.3 erratum (a)), p_m = 0 and T⁽⁰⁾ = m₀c/Δt_LP (1 − e^(−V_LP/c)).
   The printed homotopy is singular at τ = 0 (p_T(K_f) ≡ 0 and no dependence on T); we impose
   Q(K_f) = p_T(K_f)/τ instead, which is exact because p_T is cyclic (see flow.field).
3. Verdict: T < T_min means no transfer over this angular range; n* ≈ n T_min / T revolutions
   would be needed (§4.1, "hyperbolic law").
4. LP → OT by the homotopy (3.3.1) with ε(τ) = 1 − τ + ε₁ τ down to ε₁ (default 10⁻²), then
   pure OT with ε log-uniform from ε₁ to ε_f = 10⁻⁵ (the linear schedule of (3.3.1) all the way
   to ε_f spends most steps in its last 10⁻³ of τ); or, from a converged OT solution,
   continuation in thrust at ε = ε_f (used near T_min, where the dissertation notes that the
   engine never switches off).

Every homotopy is followed in τ (:class:`~.continuation.Continuation`) or, where the path has a
turning point in τ, in arclength (``path='arclength'``, :class:`~.continuation.ArclengthContinuation`).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from functools import partial

import diffrax
import jax
import jax.numpy as jnp
import numpy as np

from ..errors import ConvergenceError
from . import exact_switching, hamiltonians as hm
from .continuation import (POLISH_FAILED, STEP_SIZES, ArclengthContinuation, ArclengthOptions,
                           Continuation, ContinuationOptions, failure_statistics)
from .flow import (STEP_BOUND, Model, capped, field as flow_field, model_blend_params, padded_samples,
                   require_success, uniform_samples)
from .multiple_shooting import MultipleShooting, node_positions, start_nodes
from .multiple_shooting import residual as multiple_residual, shoot as multiple_shoot
from .shooting import Shooting, final_state, initial_state, residual, shoot
from .transfer import Transfer, datum

ORBIT_COSTATES = (hm.P, hm.EX, hm.EY, hm.IX, hm.IY, hm.LK)


def lp_shooting(tr: Transfer, perturbed: bool = False) -> Shooting:
    """LP layout: unperturbed by default; with a fixed time of flight, or with the
    perturbations on (``perturbed``, the transfer's force model), p_t joins the unknowns."""
    if perturbed and not tr.perturbed:
        raise ValueError("a perturbed LP needs a transfer with a perturbation model")
    if tr.tof_s is None and not perturbed:
        return Shooting(Model("lp"), ORBIT_COSTATES, **tr.integration())     # free-time LP layout
    return Shooting(Model("lp", "lp", perturbed), ORBIT_COSTATES + (hm.TIME,), fixed_time=tr.tof_s is not None,
                    **tr.integration())


def shooting_for(kind: str, homotopy: str, tr: Transfer) -> Shooting:
    """OT / T_min layout; perturbed or fixed-time problems add p_t to the unknowns."""
    fixed = tr.tof_s is not None
    free = ORBIT_COSTATES + ((hm.TIME,) if (tr.perturbed or fixed) else ()) + (hm.MASS,)
    return Shooting(Model(kind, homotopy, tr.perturbed), free, fixed_time=fixed, **tr.integration())


def start_vector(sh: Shooting, costates: dict, K_f: float, thrust=None) -> np.ndarray:
    """z in the layout of ``sh`` from named costates (missing ones start at 0)."""
    z = [costates.get(name, 0.0) for name in sh.unknown_names() if name.startswith("p_")]
    return np.asarray(z + [K_f] + ([thrust] if sh.has_thrust else []), dtype=float)


@dataclass
class Solution:
    """A converged stage of the chain: unknowns z (nondimensional) plus what produced them."""
    stage: str                  # 'lp' | 'tmin' | 'ot'
    shooting: Shooting
    z: np.ndarray
    prm: dict
    transfer: Transfer
    stats: dict
    thrust_N: float = float("nan")
    extra: dict = field(default_factory=dict)
    tau: float = 1.0            # the point of the shooting model's homotopy that was solved: 1,
    # its target problem; < 1 only for an upper bound on T_min (tmin_from_ot, model ('tmin', 'ot'))

    @property
    def K_f(self):
        return float(self.z[self.shooting.kf_index])

    def costates(self):
        names = self.shooting.unknown_names()
        return {n: float(v) for n, v in zip(names, self.z) if n.startswith("p_")}

    def doubled_costates(self):
        """LP costates in the homotopy normalisation ½k|A|² (2 × those of (2.2.8))."""
        return {n: 2.0 * v for n, v in self.costates().items()}


PATHS = {"tau": Continuation, "arclength": ArclengthContinuation}


def path_options(path: str, options: ContinuationOptions | None, label: str) -> ContinuationOptions:
    """The follower options for ``path`` ('tau' | 'arclength') from the caller's ``options``:
    options of the wrong kind are re-typed with the path's own step sizes (``STEP_SIZES``: τ
    steps and arclength steps are not the same measure, :class:`~.continuation.ArclengthOptions`)
    and every other option kept; ``label`` names the follower in the log."""
    if path not in PATHS:
        raise ValueError(f"homotopy path {path!r}: expected one of {sorted(PATHS)}")
    kind = ContinuationOptions if path == "tau" else ArclengthOptions
    fields = kind().__dict__
    if options is not None:
        own = isinstance(options, ArclengthOptions) == (path != "tau")
        fields = {**fields, **{k: v for k, v in options.__dict__.items()
                               if k in fields and (own or k not in STEP_SIZES)}}
    return kind(**{**fields, "label": label})


class PathStepBudget:
    """The step cap of a path's propagations, relative to the path (``sh.path_step_budget`` = c):
    c times the integration steps of the path's last successful Jacobian evaluation, at least
    ``MIN_STEPS`` and at most ``sh.max_steps``; before the first success, and with c None,
    ``sh.max_steps`` alone. A predicted point whose propagation fails (the trajectory
    degenerates) otherwise runs to the transfer's cap before it fails: E8 LP → OT at 500
    revolutions, Broyden's corrector, two such f evaluations at the first step took 13.3 s each
    against 0.21 s for the path's others, and at 450 one chord Jacobian took 89 s
    (docs/perturbed-e6-e7-e8.md, "fifty-fifth session"). Along a path the steps grow gradually
    (at most 2.4× between a path's first and last Jacobian there), so a point that needs c times
    more than the last one is treated as a failed propagation, and the step is rejected."""
    MIN_STEPS = 1000

    def __init__(self, sh: Shooting):
        self.sh, self.steps = sh, None

    def shooting(self) -> Shooting:
        """``sh`` with the path's current step cap."""
        c = self.sh.path_step_budget
        if c is None or self.steps is None:
            return self.sh
        cap = min(self.sh.max_steps, max(self.MIN_STEPS, math.ceil(c * self.steps)))
        return dataclasses.replace(self.sh, max_steps=cap)

    def shoot(self, z, tau, prm, rtol, atol):
        """:func:`~.shooting.shoot` under the current cap; a success sets the next cap."""
        out = shoot(self.shooting(), jnp.asarray(z), tau, prm, rtol, atol)
        if bool(out[4]):
            self.steps = int(out[3])
        return out


def _run(sh: Shooting, z0, prm, label, options: ContinuationOptions | None, path: str = "tau"):
    """Follow the Newton homotopy of ``sh`` from z0 (τ = 0) to τ = 1, in τ or in arclength
    (follower options from :func:`path_options`), the path's propagations under
    :class:`PathStepBudget`; ``sh.path_arcs`` > 1: by multiple shooting over that many arcs
    (:mod:`.multiple_shooting`), the end point polished by single shooting."""
    if sh.path_arcs > 1:
        return _run_multiple(sh, z0, prm, label, options, path, sh.path_arcs)
    opt = _polish_floor(sh, path_options(path, options, label))
    rtol, atol = _path_tolerances(sh)
    budget = PathStepBudget(sh)
    cont = PATHS[path](lambda z, tau: budget.shoot(z, tau, prm, rtol, atol), opt,
                       polish=lambda z, tau: shoot(sh, jnp.asarray(z), tau, prm),
                       residual=lambda z, tau: residual(sh, jnp.asarray(z), tau, prm),
                       path_residual=lambda z, tau: residual(budget.shooting(), jnp.asarray(z), tau, prm, rtol, atol))
    return _follow(cont, z0, path)


def _polish_floor(sh: Shooting, opt: ContinuationOptions) -> ContinuationOptions:
    """The follower options of ``sh``: on the exact map the final polish stops at its noise floor
    (:data:`.exact_switching.TOL_FINAL`), not below it, and steps across the map's edges
    (:data:`.exact_switching.POLISH_CROSSINGS`)."""
    if sh.switching != "exact":
        return opt
    return dataclasses.replace(opt, tol_final=max(opt.tol_final, exact_switching.TOL_FINAL),
                               polish_crossings=max(opt.polish_crossings, exact_switching.POLISH_CROSSINGS))


def _path_tolerances(sh: Shooting):
    """Integration (rtol, atol) while a path is followed: the path rtol, never tighter than the
    end-point tolerances."""
    return max(sh.rtol, sh.path_rtol), max(sh.atol, sh.path_rtol * 0.1)


def _follow(cont, z0, path, tau0=0.0):
    z, _ = cont.run(z0, tau0=tau0)
    stats = cont.stats.as_dict()
    if path != "tau":
        stats["path"] = path
    return np.asarray(z), stats


def _run_multiple(sh: Shooting, z0, prm, label, options, path, arcs):
    """:func:`_run` by multiple shooting: nodes at j K_f/M of the starting point's K_f, started
    on the trajectory through z0 at τ = 0; at τ = 1 the single-shooting block of Z is polished
    by single shooting (Newton at τ = 1, end-point tolerances), also where the path reached τ = 1
    and only the multiple-shooting polish failed (recorded in the statistics)."""
    ms = MultipleShooting(sh, arcs)
    nodes = jnp.asarray(node_positions(float(z0[sh.kf_index]), arcs))
    Z0, weights = start_nodes(ms, z0, 0.0, prm, nodes)
    weights = jnp.asarray(weights)
    rtol, atol = _path_tolerances(sh)
    opt = path_options(path, options, f"{label} ({arcs} arcs)")
    cont = PATHS[path](lambda Z, tau: multiple_shoot(ms, jnp.asarray(Z), tau, prm, nodes, weights, rtol, atol),
                       opt, polish=lambda Z, tau: multiple_shoot(ms, jnp.asarray(Z), tau, prm, nodes, weights),
                       residual=lambda Z, tau: multiple_residual(ms, jnp.asarray(Z), tau, prm, nodes, weights),
                       path_residual=lambda Z, tau: multiple_residual(ms, jnp.asarray(Z), tau, prm, nodes, weights,
                                                                      rtol, atol))
    try:
        Z, stats = _follow(cont, Z0, path)
    except ConvergenceError as exc:
        if exc.diagnosis.get("reason") != POLISH_FAILED:
            raise
        # the path reached τ = 1 but the multiple-shooting polish failed: its end point goes to
        # the single-shooting polish, which lacks the nearly flat node-time directions (E8 500
        # rev at τ = 1: σ_min 2.7e-5 of σ_max 3.9e3 over 10 arcs; 3.7e-4 in single shooting)
        Z, stats = np.asarray(exc.diagnosis["z"]), {**failure_statistics(exc.diagnosis), "polish_failed": str(exc)}
    z, stats_polish = _newton_at_end(sh, Z[:sh.size], prm, f"{label} single-shooting polish", options)
    return z, {**_merge_stats({"multiple_shooting": stats, "single_polish": stats_polish}), "arcs": arcs}


def _newton_at_end(sh: Shooting, z0, prm, label, options):
    """Newton on the map of ``sh`` at τ = 1 from z0 (the follower's polish, end-point tolerances)."""
    single = lambda z, tau: shoot(sh, jnp.asarray(z), tau, prm)  # noqa: E731
    # a polish distinct from the path's map: the follower then re-evaluates f at τ = 1 instead of
    # taking its Newton homotopy's F = f − b, which is 0 where it starts
    # a polish alone: no path, so no corrector steps (Newton's, whatever the caller's options)
    opt = dataclasses.replace(_polish_floor(sh, path_options("tau", options, label)), corrector="newton")
    polish = Continuation(single, opt, polish=lambda z, tau: single(z, tau),
                          residual=lambda z, tau: residual(sh, jnp.asarray(z), tau, prm))
    return _follow(polish, z0, "tau", tau0=1.0)


def _merge_stats(parts: dict) -> dict:
    """Statistics of consecutive stages ({name: stats}, in order): each stage's, their summed
    counters, and the final residual of the last stage."""
    stages = list(parts.values())
    return {**parts,
            **{k: sum(p[k] for p in stages) for k in stages[0]
               if k != "final_residual" and isinstance(stages[0][k], (int, float))
               and all(k in p for p in stages)},
            "final_residual": stages[-1]["final_residual"]}


def solve_lp(tr: Transfer, options=None, label="lp", perturbed: bool = False) -> Solution:
    """Minimum-power solve from the zero guess with K_f = ΔL.

    ``perturbed``: with the transfer's perturbations on (p_t an unknown, p_t(K_f) = 0). Used
    where the transfer only exists thanks to a perturbation (§4.2.3: the node is moved by the J2
    precession; the zero guess is then the perturbed coast, which already drifts the node by
    almost the required ΔΩ). The LP → OT/T_min homotopies then start off their paths (their
    τ = 0 end is the unperturbed LP) and the Newton homotopy carries the initial residual.
    """
    prm = tr.params()
    sh = lp_shooting(tr, perturbed)
    z0 = np.zeros(sh.size)
    z0[sh.kf_index] = tr.delta_L
    z, stats = _run(sh, z0, prm, label, options)
    sol = Solution("lp", sh, z, prm, tr, stats)
    sol.extra.update(lp_integrals(sol))
    return sol


def tmin_initial_guess(lp: Solution) -> float:
    """T⁽⁰⁾ = m₀ c / Δt_LP · (1 − exp(−V_LP/c))  [N] (§3.4)."""
    tr = lp.transfer
    dt = lp.extra["tof_s"]
    return tr.m0 * tr.c / dt * (1.0 - math.exp(-lp.extra["dv_m_s"] / tr.c))


BLEND_REFS = ("lp_primer", "thrust_ratio")


def blend_reference(lp: Solution, thrust_N: float | None = None) -> float:
    """W_ref = 2 V_LP/Δt_LP (nondimensional): the mean primer magnitude of the doubled LP costates.

    With ``thrust_N`` (the ``blend_ref`` choice 'thrust_ratio'): W_ref T/T⁽⁰⁾, T⁽⁰⁾ the constant
    thrust that gives the LP's Δv over its Δt (:func:`tmin_initial_guess`). The OT field thrusts
    at T where the LP field's acceleration is of the order of T⁽⁰⁾/m, so with T ≫ T⁽⁰⁾ the OT
    field takes over the blend (3.3.1) once τ W ≳ T⁽⁰⁾/T, and the path crosses from LP to OT
    in a thin layer at small τ. Measured on E9 J2 (T/T⁽⁰⁾ = 32): |dz/dτ| rises from 1e-2 to 1
    within τ 0.001–0.004, where the τ path rejects four steps; with the ratio in W_ref it peaks
    at 4e-2 near τ 0.1, and the LP → OT path in τ takes 86 Jacobians instead of 95, to the same
    extremal (docs/perturbed-e6-e7-e8.md, "Fiftieth session").
    """
    tr = lp.transfer
    w_ref = 2.0 * (lp.extra["dv_m_s"] / tr.vu) / (lp.extra["tof_s"] / tr.tu)
    return w_ref if thrust_N is None else w_ref * thrust_N / tmin_initial_guess(lp)


def solve_tmin(lp: Solution, options=None, label="tmin") -> Solution:
    tr = lp.transfer
    prm = {**tr.params(), "blend_ref": datum(blend_reference(lp))}
    T0 = tmin_initial_guess(lp) / tr.force_unit
    sh = shooting_for("tmin", "lp", tr)
    z, stats = _run(sh, start_vector(sh, lp.doubled_costates(), lp.K_f, T0), prm, label, options)
    sol = Solution("tmin", sh, z, prm, tr, stats)
    sol.thrust_N = float(z[-1]) * tr.force_unit
    sol.extra["T0_N"] = T0 * tr.force_unit
    return sol


def existence_verdict(tmin: Solution, thrust_N: float) -> dict:
    """Does an OT transfer with thrust T exist over this angular range? (§3.4 decision rule).

    ``tmin`` may be an upper bound on T_min (``extra['bound']``, :mod:`.tmin_from_ot`): T at or
    above it still decides "exists"; T below it decides nothing (``exists`` None)."""
    n, T_min = tmin.transfer.n_rev, tmin.thrust_N
    bound = bool(tmin.extra.get("bound"))
    exists = True if thrust_N >= T_min else (None if bound else False)
    name = "the upper bound on T_min" if bound else "T_min"
    message = {True: f"transfer exists: T = {thrust_N:g} N >= {name} = {T_min:.8g} N",
               False: (f"no transfer over {n:g} revolutions: T = {thrust_N:g} N < T_min = {T_min:.8g} N; "
                       f"about {n * T_min / thrust_N:.1f} revolutions would be needed"),
               None: f"undecided: T = {thrust_N:g} N is below {name} = {T_min:.8g} N"}[exists]
    return {"thrust_N": thrust_N, "T_min_N": T_min, "T_min_is": "upper bound" if bound else "minimum",
            "exists": exists, "n_rev": n, "n_rev_needed_estimate": n * T_min / thrust_N, "message": message}


def solve_ot(lp: Solution, thrust_N: float, options=None, label="ot", blend_ref: float | str | None = None,
             path: str = "tau", switching: str = "smoothed") -> Solution:
    """LP → OT homotopy (3.3.1) at thrust T, then ε log-uniform from ε₁ to ε_f (in τ).

    ``blend_ref``: W_ref of the blend weights, a number (1 gives the printed (3.3.1) weights) or
    one of :data:`BLEND_REFS`: 'lp_primer' (None, the default), the LP's mean primer, or
    'thrust_ratio', that times T/T⁽⁰⁾ (:func:`blend_reference`). ``path``: how the LP → OT
    path is followed, 'tau' or 'arclength' (through turning points in τ). ``switching`` 'exact':
    no descent in ε; the exact bang-bang extremal by Newton from the ε₁ one (:func:`to_exact`).
    """
    tr = lp.transfer
    if blend_ref is None or isinstance(blend_ref, str):
        if blend_ref not in (None, *BLEND_REFS):
            raise ValueError(f"blend_ref {blend_ref!r}: expected a number or one of {', '.join(BLEND_REFS)}")
        bref = blend_reference(lp, thrust_N if blend_ref == "thrust_ratio" else None)
    else:
        bref = float(blend_ref)
    prm = {**tr.params(thrust=thrust_N), "blend_ref": datum(bref)}
    sh = shooting_for("ot", "lp", tr)
    z, stats = _run(sh, start_vector(sh, lp.doubled_costates(), lp.K_f), prm, label + " LP->OT", options, path)
    sh_eps = shooting_for("ot", "eps", tr)
    if switching == "exact":
        return _exact_from_blend(Solution("ot", sh_eps, z, prm, tr, stats, thrust_N=thrust_N), "lp_to_ot",
                                 options, label)
    if tr.eps_blend > tr.eps_final:
        z, stats_eps = _run(sh_eps, z, prm, label + " eps", options)
        stats = _merge_stats({"lp_to_ot": stats, "eps": stats_eps})
    return Solution("ot", sh_eps, z, tr.params(thrust=thrust_N), tr, stats, thrust_N=thrust_N)


def _exact_from_blend(at_blend: Solution, stage: str, options, label) -> Solution:
    """The exact extremal from the OT solution at ε₁ that the homotopy ``stage`` reached."""
    exact = to_exact(at_blend, options, label + " exact")
    exact.stats = {**_merge_stats({stage: at_blend.stats, "exact": exact.stats}), "switching": "exact"}
    return exact


def solve_ot_from_tmin(tmin: Solution, thrust_N: float, options=None, label="ot", path: str = "tau",
                       switching: str = "smoothed") -> Solution:
    """T_min → OT at thrust T ≥ T_min (route LP → T_min → OT; no LP → OT blend), then ε to ε_f.

    Homotopy (flow.Model('tmin', 'ot')): the T_min problem with the propellant weight of the OT
    cost ("+1" in (2.1.9)) growing as τ, the −½T² term and the p_LK shift fading as 1 − τ, the
    throttle 1 − τ + τ δ(S, ε₁), and the thrust residual moving from p_T(K_f) = 0 (T free,
    τ = 0: the converged T_min solution, so the path starts on it) to T = T_OT (τ = 1: OT at
    ε₁). The OT costates at T ↓ T_min grow without bound (the OT problem degenerates to the
    single always-on transfer, with zero propellant weight), which is why the path starts from the
    T_min problem rather than from an OT problem at T_min. Then ε log-uniform from ε₁ to ε_f, or
    (``switching`` 'exact') the exact extremal by Newton from ε₁ (:func:`to_exact`).
    """
    tr = tmin.transfer
    prm = tr.params(thrust=thrust_N)
    sh = shooting_for("tmin", "ot", tr)
    z, stats = _run(sh, np.asarray(tmin.z, float), prm, label + " Tmin->OT", options, path)
    sh_eps = shooting_for("ot", "eps", tr)
    z = z[:sh_eps.size]                                  # drop T (= T_OT at τ = 1)
    if switching == "exact":
        exact = _exact_from_blend(Solution("ot", sh_eps, z, prm, tr, stats, thrust_N=thrust_N), "tmin_to_ot",
                                  options, label)
        exact.stats["route"] = "lp-tmin-ot"
        return exact
    if tr.eps_blend > tr.eps_final:
        z, stats_eps = _run(sh_eps, z, prm, label + " eps", options)
        stats = _merge_stats({"tmin_to_ot": stats, "eps": stats_eps})
    stats["route"] = "lp-tmin-ot"
    return Solution("ot", sh_eps, z, prm, tr, stats, thrust_N=thrust_N)


# problem data that continue_in_params moves along a path (the departure-epoch offset: E6 dates;
# t_f of a fixed-time problem: a thrust family's hop, studies.thrust_family.hop)
PATH_DATA = ("thrust", "L0", "Lf", "c", "epoch_offset_s", "tf")


def _on_map_of(sol: Solution, prm_to: dict) -> dict:
    """``prm_to`` for a path from ``sol``: an exact bang-bang solution keeps ε = 0 (the map has none)."""
    return {**prm_to, "eps_final": sol.prm["eps_final"]} if sol.shooting.switching == "exact" else prm_to


def continue_in_params(sol: Solution, prm_to: dict, options=None, label="param", path: str = "tau") -> Solution:
    """From a converged solution to the same problem with other data (thrust, L0, L_f, …).

    ``prm_to`` is a full parameter set (``Transfer.params``); the keys that differ from the
    solution's are moved linearly in τ (thrust, L0, L_f, c, and the departure-epoch offset of a
    perturbed problem when both carry one), everything else stays (``path``: 'tau' or 'arclength').
    """
    prm_to = _on_map_of(sol, prm_to)
    keys = [k for k in PATH_DATA
            if k in sol.prm and k in prm_to and not np.isclose(sol.prm[k], prm_to[k], rtol=0, atol=0)]
    frm = {k: sol.prm[k] for k in keys}
    prm = {**prm_to, "path_from": frm, "path_to": {k: prm_to[k] for k in keys}}
    sh = dataclasses.replace(sol.shooting, model=dataclasses.replace(sol.shooting.model, homotopy="param"))
    z, stats = _run(sh, sol.z, prm, label, options, path)
    out = Solution(sol.stage, sol.shooting, z, dict(prm_to), sol.transfer, stats)
    if sol.stage == "tmin":
        out.thrust_N = float(z[-1]) * sol.transfer.force_unit
    return out


def model_blend(sol: Solution, prm_to: dict) -> tuple[Shooting, dict, dict]:
    """The force-model blend (flow.Model homotopy 'model') from the perturbed OT solution ``sol``
    to ``prm_to['pert']``: its layout, its data (``flow.model_blend_params``), and ``prm_to`` on
    the solution's map. ValueError where any other datum differs from the solution's."""
    prm_to = _on_map_of(sol, prm_to)
    moved = [k for k in (*PATH_DATA, "eps_final")
             if (k in sol.prm or k in prm_to) and not np.isclose(sol.prm.get(k, 0.0), prm_to.get(k, 0.0), rtol=0, atol=0)]
    if moved or sol.stage != "ot" or not sol.shooting.model.perturbed:
        raise ValueError(f"continue_in_model: a perturbed OT solution at the same data is needed (differs: {moved})")
    sh = dataclasses.replace(sol.shooting, model=dataclasses.replace(sol.shooting.model, homotopy="model"))
    return sh, model_blend_params(prm_to, sol.prm["pert"]), prm_to


def continue_in_model(sol: Solution, prm_to: dict, options=None, label="model", path: str = "tau") -> Solution:
    """From a converged perturbed OT solution to the same problem under another force model
    (``prm_to['pert']``, every other datum the solution's), at its ε, by the model blend
    (:func:`model_blend`): a_p = (1 − τ) a_p,from + τ a_p,to.

    The physical path, unlike the Newton homotopy f(z, τ) = (1 − τ) f(z₀) at the new model:
    E8 at 300 revolutions, 4×4 → 4×4 + Moon + Sun at ε_f, the Newton homotopy folds at τ ≈ 0.35
    (113 Jacobians, docs/perturbed-e6-e7-e8.md); the blend of the Moon and Sun terms converges in 13.
    """
    sh, prm, prm_to = model_blend(sol, prm_to)
    solved = lambda z, stats: Solution(sol.stage, sol.shooting, z, dict(prm_to), sol.transfer, stats,
                                       thrust_N=sol.thrust_N)
    try:
        z, stats = _run(sh, sol.z, prm, label, options, path)
    except ConvergenceError as exc:
        # at τ = 1 the blend is the new model itself: a failed polish leaves its best point
        # there as the new problem's unconverged solution (``exc.end_point``)
        if exc.diagnosis.get("reason") == POLISH_FAILED and exc.diagnosis.get("tau") == 1.0:
            exc.end_point = solved(np.asarray(exc.diagnosis["z_best"]), failure_statistics(exc.diagnosis))
        raise
    return solved(z, stats)


def smoothing_to(sol: Solution, eps_to: float, options=None, label="eps", path: str = "tau") -> Solution:
    """The OT solution ``sol`` (at ε = prm['eps_final']) moved to ε = ``eps_to`` at the same data
    by the ε homotopy (log-uniform in τ; upwards too), followed in ``path`` ("tau" or
    "arclength": E7's full model at 1 N from ε 1e-2 stalls at τ 0.576 in τ, and arrives in
    arclength without a fold; docs/perturbed-e6-e7-e8.md, "sixty-sixth session"). The result
    carries eps_final = eps_to."""
    if sol.stage != "ot":
        raise ValueError("the smoothing homotopy is for OT solutions")
    sh = shooting_for("ot", "eps", sol.transfer)
    prm = {**sol.prm, "eps_blend": sol.prm["eps_final"], "eps_final": datum(eps_to)}
    z, stats = _run(sh, sol.z, prm, label, options, path)
    return Solution("ot", sol.shooting, z, {**sol.prm, "eps_final": datum(eps_to)},
                    sol.transfer, stats, thrust_N=sol.thrust_N)


def to_exact(sol: Solution, options=None, label="exact") -> Solution:
    """The OT solution ``sol`` (smoothed, at any ε) moved to the exact bang-bang problem,
    δ = 1[S > 0] with the switches located (:mod:`.exact_switching`), by Newton at τ = 1.

    The exact problem is the limit ε → 0 of the smoothing (3.3.2), so the descent in ε can be
    skipped: at E8 500 revolutions Newton from the ε = 10⁻² root lands on the exact root in 6
    Jacobians, each 5–6× cheaper than one at ε_f (docs/perturbed-e6-e7-e8.md, "thirtieth
    session"). The solution's layout is kept (fixed or free time); its paths afterwards are
    followed on the exact map, by single shooting. An LP → OT solution is read as the pure OT
    problem it is at τ = 1."""
    if sol.stage != "ot" or sol.tau != 1.0:
        raise ValueError("to_exact: a converged OT solution (τ = 1) is needed")
    model = sol.shooting.model
    if model.homotopy == "lp":
        model = Model("ot", "eps", model.perturbed)
    sh = dataclasses.replace(sol.shooting, model=model, switching="exact", path_arcs=1)
    z, stats = _newton_at_end(sh, np.asarray(sol.z, float), sol.prm, label, options)
    # ε = 0 in its data: the map ignores it, and δ(S, 0) = 1[S > 0] where the smoothed throttle
    # is read (the dense samples)
    return Solution("ot", sh, z, {**sol.prm, "eps_final": datum(0.0)}, sol.transfer,
                    {**stats, "switching": "exact"}, thrust_N=sol.thrust_N, extra=dict(sol.extra))


def through_smoothing(sol: Solution, eps_smooth: float, step, options=None, label="param") -> Solution:
    """``step`` (Solution → Solution) done at ε = ``eps_smooth`` instead of ε_f: ε up from ε_f,
    the step, ε back down to ε_f. Statistics of the three stages and their sums.

    Near bang-bang (ε_f = 10⁻⁵) a change of the data that adds or removes burn arcs (E8: more
    revolutions) makes the path stiff: continued at ε_f, E8 200 → 250 revolutions reached only
    τ = 0.24 in 74 Jacobian evaluations; through ε = 10⁻² the whole move took 87 (12 up, 56 to
    move, 19 down).
    """
    eps_f = float(sol.prm["eps_final"])
    up = smoothing_to(sol, eps_smooth, options, label + " eps up")
    moved = step(up)
    down = smoothing_to(moved, eps_f, options, label + " eps down")
    down.stats = {**_merge_stats({"eps_up": up.stats, "step": moved.stats, "eps_down": down.stats}),
                  "eps_smooth": eps_smooth}
    return down


def continue_in_params_smoothed(sol: Solution, prm_to: dict, eps_smooth: float, options=None,
                                label="param", path: str = "tau") -> Solution:
    """:func:`continue_in_params` of an OT solution done at ε = ``eps_smooth``
    (:func:`through_smoothing`)."""
    def step(up):
        return continue_in_params(up, {**prm_to, "eps_final": datum(eps_smooth)}, options, label, path)
    return through_smoothing(sol, eps_smooth, step, options, label)


def continue_ot_in_thrust(ot: Solution, thrust_N: float, options=None, label="ot-thrust") -> Solution:
    """From a converged OT solution at T_a to thrust T_b, at ε = ε_f."""
    sol = continue_in_params(ot, ot.transfer.params(thrust=thrust_N), options, label)
    sol.thrust_N = thrust_N
    return sol


def check_arrival_in_window(sol: Solution, model, what: str) -> None:
    """ConfigError naming ``what``, the window and the date where the arrival of ``sol`` (its time
    of flight counted from the epoch of the perturbation model ``model``) lies outside ``model``'s
    Moon and Sun window. The window is NaN outside (:class:`spaceopt.ephemeris.ChebyshevEphemeris`),
    and a path started from ``sol`` under ``model`` evaluates it at τ = 0 already (τ · NaN): its
    first integration would fail without saying why, after minutes: its steps shrink to zero at
    the window's end and it runs out its step cap in zero-length steps (E1, 2 revolutions: 179 s,
    400 001 steps). Costs one propagation of ``sol``."""
    if model is None or model.eph is None:
        return
    yf, _ = final_state(sol.shooting, jnp.asarray(sol.z), sol.tau, sol.prm)
    model.eph.check_time(float(model.epoch) + float(yf[hm.TIME]) * sol.transfer.tu,
                         key=f"{what} (ephemeris window {model.eph.name})")


# ---------------------------------------------------------------- dense trajectories

def final_model(sol: Solution) -> Model:
    """The field of the converged problem at τ = 1."""
    return sol.shooting.model


def dense(sol: Solution, samples_per_rev: int = 200):
    """Trajectory y(K) at the solution's τ (1: its problem) on a uniform K grid: returns K [rad]
    and y (N × 2n); an exact bang-bang solution's by :func:`.exact_switching.dense`."""
    n = max(int(samples_per_rev * sol.transfer.n_rev), 200)
    if sol.shooting.switching == "exact":
        Ks, ys = exact_switching.dense(sol.shooting, jnp.asarray(sol.z), sol.tau, sol.prm, n, sol.shooting.max_steps)
        return np.asarray(Ks), np.asarray(ys)
    y0 = initial_state(sol.shooting, jnp.asarray(sol.z), sol.prm)
    Ks, ys, ok = _dense(final_model(sol), y0, sol.K_f, sol.prm, n, padded_samples(n), sol.shooting.max_steps,
                        datum(sol.tau))
    require_success(ok, "dense output", sol.shooting.max_steps)
    return np.asarray(Ks)[:n], np.asarray(ys)[:n]


@partial(jax.jit, static_argnums=(0, 5))
def _dense(model, y0, K_f, prm, n, n_pad, max_steps, tau):
    """The trajectory on n uniform samples, padded to n_pad (:func:`.flow.padded_samples`)."""
    Ks = uniform_samples(K_f, n, n_pad)
    rhs = lambda K, y, args: flow_field(model, K, y, tau, args)
    out = diffrax.diffeqsolve(diffrax.ODETerm(rhs), diffrax.Dopri8(), 0.0, K_f, None, y0, args=prm,
                              stepsize_controller=capped(diffrax.PIDController(rtol=1e-12, atol=1e-13), max_steps),
                              saveat=diffrax.SaveAt(ts=Ks), max_steps=STEP_BOUND, throw=False)
    return Ks, out.ys, out.result == diffrax.RESULTS.successful


def lp_integrals(sol: Solution) -> dict:
    """J_LP = ∫ k|A|² dK and V = ∫ k1 k2 |A| dK along the LP solution, plus Δt (SI); with the
    field the solution was solved with (perturbed or not)."""
    tr = sol.transfer
    y0 = initial_state(sol.shooting, jnp.asarray(sol.z), sol.prm)
    yf, ok = _lp_integrals(sol.shooting.model, y0, sol.K_f, sol.prm, sol.shooting.max_steps)
    require_success(ok, "LP integrals", sol.shooting.max_steps)
    yf = np.asarray(yf)
    return {"J_LP_m2s3": float(yf[-2]) * tr.du**2 / tr.tu**3, "dv_m_s": float(yf[-1]) * tr.vu,
            "tof_s": float(yf[hm.TIME]) * tr.tu}


@partial(jax.jit, static_argnums=0)
def _lp_integrals(model, y0, K_f, prm, max_steps):
    n = hm.N_STATE

    def rhs(K, Y, args):
        y = Y[:-2]
        g = hm.geometry(K, y[:n])
        A = hm.primer(y[:n], y[n:], g)
        return jnp.concatenate([flow_field(model, K, y, 1.0, args),
                                jnp.stack([g["k"] * jnp.dot(A, A), g["k1"] * g["k2"] * hm.safe_norm(A)])])

    out = diffrax.diffeqsolve(diffrax.ODETerm(rhs), diffrax.Dopri8(), 0.0, K_f, None,
                              jnp.concatenate([y0, jnp.zeros(2)]), args=prm,
                              stepsize_controller=capped(diffrax.PIDController(rtol=1e-12, atol=1e-13), max_steps),
                              max_steps=STEP_BOUND, throw=False)
    return out.ys[-1], out.result == diffrax.RESULTS.successful
