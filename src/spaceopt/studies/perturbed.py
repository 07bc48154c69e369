"""The perturbed multi-revolution studies of dissertation §4.2 (E5–E9) built from the config.

Config: ``config/studies/perturbed.yaml`` (key ``perturbed``). A case names an initial and a
final orbit (altitudes above the mean Earth radius, or ``a_km``/``e`` where the thesis gives
them), L₀, the angular range, the spacecraft, the departure epoch (UTC), the ephemeris window
and the perturbation models (``forces.build_model`` configs) it is solved with.

The DAG's plan (dates, counts, models, existence checks) and the case options it and the
solves' paths read are in :mod:`.perturbed_config`, which imports no solver.

Chain for every (case, model) (spec 02-multirev §2.6, no published costate as a guess):

1. LP, unperturbed, from the zero guess (a coast on the initial orbit, K_f = ΔL);
2. LP → OT by the homotopy (3.3.1), which also switches the perturbations on with τ
   (H_p = k₁k₂ A·a_p, p_t an unknown when perturbed); then ε log-uniform to ε_f.

Warm starts (allowed: neighbouring *solved* cases of the same chain):

* E6 date → date: a Newton homotopy f(z, τ) = (1 − τ) f(z_prev) at the *new* problem data
  (``chain.continue_in_params`` with nothing to move; the epoch is pytree data of
  ``prm['pert']``, so the new date costs no recompilation);
* a new force model at the same data (E8 J2 → 4×4 + Moon + Sun, E9 J2 → 4×4 → full): the blend
  of the perturbing accelerations (``chain.continue_in_model``), the Newton homotopy its fallback;
* E8 n → n (config ``perturbed.e8.count_start: previous``; the default is a chain from the zero
  guess at every count): ``chain.continue_in_params_smoothed`` moving L_f at ε = ε₁ (10⁻²),
  where the control is smooth, between an ε homotopy up from ε_f and one back down.

The ΔΩ budget of E9 (spec 02-multirev §6) is the secular J2 drift of the osculating initial
orbit, dΩ/dt = −(3/2) n J₂ (R/p)² cos i, dω/dt = (3/4) n J₂ (R/p)² (5 cos² i − 1), compared
with the required ΔΩ, plus a numerical coast with the J2 model of :mod:`spaceopt.forces` (the
osculating Ω difference after the same time).
"""
from __future__ import annotations

import dataclasses
import functools
import math
import time
from pathlib import Path

import numpy as np

from .. import artifacts
from ..errors import ArtifactError, ConfigError, ConvergenceError
from ..indirect import chain
from ..indirect import hamiltonians as hm
from ..indirect.chain import Solution
from ..indirect.continuation import GROWTH, ArclengthOptions, ContinuationOptions
from ..indirect.free_time import MaximumOptions, maximise_final_mass
from ..indirect.shooting import Shooting
from ..indirect.transfer import MAX_STEPS, Orbit, Transfer, datum, step_cap
from ..constants import DAY
from . import multirev
from .multirev_config import number, orbit_from_config as altitude_orbit
from .perturbed_config import (case_corrector, case_model_step, case_path_arcs, case_path_rtol,
                               case_path_step_budget, case_sensitivity_rtol, perturb_at_eps)

ALT_KEYS = ("perigee_alt_km", "apogee_alt_km")
AE_KEYS = ("a_km", "e")
ANGLE_KEYS = ("i_deg", "raan_deg", "argp_deg")
CASE_KEYS = ("initial", "final", "L0_deg", "n_rev", "m0_kg", "isp_s", "thrust_N", "epoch_utc",
             "ephemeris", "models")
OPTIONAL_CASE_KEYS = ("lp_perturbed", "homotopy_path", "blend_ref", "route", "model_start", "fallback",
                      "perturb_at_eps", "model_step_at_eps", "path_rtol", "path_arcs", "warm_step_growth",
                      "model_step", "tof_maximum", "switching", "corrector", "sensitivity_rtol", "model_from",
                      "path_step_budget")


def orbit_from_config(cfg, path, radius_m) -> Orbit:
    """Orbit from altitudes above ``radius_m`` or from a_km, e (angles in degrees)."""
    if not isinstance(cfg, dict):
        raise ConfigError(path, cfg, "must be a mapping of orbit elements")
    allowed = set(ALT_KEYS) | set(AE_KEYS) | set(ANGLE_KEYS)
    unknown = sorted(set(cfg) - allowed)
    if unknown:
        raise ConfigError(f"{path}.{unknown[0]}", cfg[unknown[0]],
                          f"unknown key (expected {', '.join(sorted(allowed))}; units in the key name)")
    has_alt, has_ae = any(k in cfg for k in ALT_KEYS), any(k in cfg for k in AE_KEYS)
    if has_alt == has_ae:
        raise ConfigError(path, sorted(cfg), "give either perigee_alt_km/apogee_alt_km or a_km/e")
    if has_alt:
        return altitude_orbit(cfg, path, radius_m)
    a = number(cfg, "a_km", path, positive=True) * 1e3
    e = number(cfg, "e", path)
    if not 0.0 <= e < 1.0:
        raise ConfigError(f"{path}.e", e, "eccentricity must be in [0, 1)")
    return Orbit(a, e, number(cfg, "i_deg", path), cfg.get("raan_deg", 0.0), cfg.get("argp_deg", 0.0))


def model_config(pc: dict, name: str):
    models = pc.get("models", {})
    if name not in models:
        raise ConfigError("perturbed.models", name, f"unknown model (expected one of {sorted(models)})")
    return models[name]


def ephemeris_path(results_dir, window: str) -> str:
    return str(Path(results_dir) / "ephemeris" / f"{window}.json")


def transfer_from_config(pc: dict, case: str, model: str, *, ephemeris: str | None = None,
                         epoch_utc: str | None = None, n_rev: float | None = None) -> Transfer:
    """Build the Transfer of ``perturbed.cases.<case>`` under perturbation model ``model``."""
    cases = pc.get("cases", {})
    if case not in cases:
        raise ConfigError("perturbed.cases", case, "unknown case")
    cc, path = cases[case], f"perturbed.cases.{case}"
    missing = [k for k in CASE_KEYS if k not in cc]
    if missing:
        raise ConfigError(f"{path}.{missing[0]}", None, "missing")
    unknown = sorted(set(cc) - set(CASE_KEYS) - set(OPTIONAL_CASE_KEYS))
    if unknown:
        raise ConfigError(f"{path}.{unknown[0]}", cc[unknown[0]], "unknown key")
    const = pc["constants"]
    radius = number(const, "earth_radius_km", "perturbed.constants", positive=True) * 1e3
    mu = number(const, "mu_km3_s2", "perturbed.constants", positive=True) * 1e9
    orbits = pc.get("orbits", {})
    for end in ("initial", "final"):
        if cc[end] not in orbits:
            raise ConfigError(f"{path}.{end}", cc[end], "unknown orbit name")
    mcfg = model_config(pc, model)
    num = pc["numerics"]
    epoch = epoch_utc if epoch_utc is not None else cc["epoch_utc"]
    if mcfg is not None and not isinstance(epoch, str):
        raise ConfigError(f"{path}.epoch_utc", epoch, "expected a UTC date string 'YYYY-MM-DDTHH:MM:SS'")
    needs_eph = bool(mcfg) and bool(mcfg.get("third_bodies"))
    revs = float(n_rev) if n_rev is not None else number(cc, "n_rev", path, positive=True)
    return Transfer(
        orbit_from_config(orbits[cc["initial"]], f"perturbed.orbits.{cc['initial']}", radius),
        orbit_from_config(orbits[cc["final"]], f"perturbed.orbits.{cc['final']}", radius),
        L0_deg=number(cc, "L0_deg", path),
        n_rev=revs,
        m0=number(cc, "m0_kg", path, positive=True), isp=number(cc, "isp_s", path, positive=True),
        thrust=number(cc, "thrust_N", path, positive=True), mu=mu,
        eps_final=number(num, "eps_final", "perturbed.numerics", positive=True),
        eps_blend=number(num, "eps_blend", "perturbed.numerics", positive=True),
        perturbations=mcfg or None, epoch_utc=epoch if mcfg else None,
        ephemeris=ephemeris if needs_eph else None,
        max_steps=step_cap(revs, num["max_steps_per_rev"], num["min_max_steps"]) if "max_steps_per_rev" in num
        else MAX_STEPS,
        path_rtol=case_path_rtol(cc, model, path), path_arcs=case_path_arcs(cc, model, path),
        sensitivity_rtol=case_sensitivity_rtol(pc, case, model), path_step_budget=case_path_step_budget(cc, path))


# ---------------------------------------------------------------- solves

ROUTES = ("lp-ot", "lp-tmin-ot")


def solve_for(tr: Transfer, label: str, lp_perturbed: bool = False, path: str = "arclength",
              options: ContinuationOptions | None = None, blend_ref: float | str | None = None,
              route: str = "lp-ot", switching: str = "smoothed") -> tuple[Solution, Solution]:
    """The chain from the zero guess → OT (perturbed when ``tr`` is); returns (lp, ot).

    ``route``: 'lp-ot' — LP → OT by the blend (3.3.1) (``chain.solve_ot``); 'lp-tmin-ot' — LP →
    T_min (3.4.1) → existence verdict → OT by the T_min → OT homotopy
    (``chain.solve_ot_from_tmin``), which avoids the blend (E5: its path folds). Perturbations
    are switched on by the (3.4.1) τ in the second route, by the (3.3.1) τ in the first.
    ``path``: how the homotopies are followed, 'tau' or 'arclength' (passes turning points).
    ``lp_perturbed``: solve the LP with the perturbations on (``chain.solve_lp(perturbed=True)``).
    ``blend_ref``: W_ref of the (3.3.1) blend weights: a number, or one of ``chain.BLEND_REFS``
    (None: 'lp_primer', the mean LP primer; 'thrust_ratio': that times T/T⁽⁰⁾).
    ``switching`` 'exact' (case option ``switching``, :func:`case_switching`): the OT extremal of
    the exact bang-bang map, by Newton from ε₁ (``chain.to_exact``), instead of the descent to ε_f.
    """
    if path not in chain.PATHS:
        raise ConfigError("perturbed.numerics.homotopy_path", path, f"expected one of {sorted(chain.PATHS)}")
    if route not in ROUTES:
        raise ConfigError("perturbed.cases.route", route, f"expected one of {', '.join(ROUTES)}")
    if isinstance(blend_ref, str) and blend_ref not in chain.BLEND_REFS:
        raise ConfigError("perturbed.cases.blend_ref", blend_ref,
                          f"expected a number or one of {', '.join(chain.BLEND_REFS)}")
    lp = chain.solve_lp(tr, options, label=f"{label}/lp", perturbed=lp_perturbed and tr.perturbed)
    if tr.perturbed:       # the next homotopy switches the perturbations on along the LP's trajectory
        chain.check_arrival_in_window(lp, tr.perturbation_model(), "arrival of the minimum-power solution")
    if route == "lp-ot":
        ot = chain.solve_ot(lp, tr.thrust, options, label=f"{label}/ot", blend_ref=blend_ref, path=path,
                            switching=switching)
        return lp, ot
    tm = chain.solve_tmin(lp, options, label=f"{label}/tmin")
    verdict = chain.existence_verdict(tm, tr.thrust)
    if not verdict["exists"]:
        raise ConvergenceError(f"{label}: {verdict['message']}", {"reason": "T < T_min", **verdict})
    ot = chain.solve_ot_from_tmin(tm, tr.thrust, options, label=f"{label}/ot", path=path, switching=switching)
    ot.extra["tmin"] = {"T_min_N": tm.thrust_N, "T0_guess_N": tm.extra.get("T0_N"), "z": tm.z.tolist(),
                        "K_f_deg": math.degrees(tm.K_f), "solver": tm.stats, "verdict": verdict["message"]}
    return lp, ot


def warm_start(sol: Solution, tr_to: Transfer, label: str, options=None, eps_smooth: float | None = None,
               model_step_eps: float | None = None, model_path: str | None = None) -> Solution:
    """From a converged OT solution to the problem of ``tr_to`` (new date, model or n_rev).

    Perturbed → perturbed: a new force model at the same data is reached by the model blend
    a_p = (1 − τ) a_p,from + τ a_p,to (:func:`chain.continue_in_model`); thrust, L₀, L_f, c and a
    new departure epoch move linearly in τ, and the Newton homotopy f(z, τ) = (1 − τ) b absorbs
    the initial residual b; followed in τ, and in arclength where the τ-path stalls (a turning
    point). A model step whose blend fails falls back to the Newton homotopy in the model (τ),
    then to the blend in arclength; the failures are in ``stats['path_failures']``. A change of
    n_rev moves L_f at ε₁ through :func:`chain.continue_in_params_smoothed`. Unperturbed → perturbed:
    :func:`perturb_from_unperturbed`. ``eps_smooth`` (case option ``perturb_at_eps``): the
    perturbations are switched on at that ε instead of ε_f; ``model_step_eps`` (case option
    ``model_step_at_eps``): a perturbed force model is changed at that ε, in arclength
    (E7: unperturbed → J2 → 4×4 + Moon + Sun, both at ε = 10⁻²; E8: J2 on at 10⁻², the model
    step at ε_f). ``options``: continuation options of every stage (all but the step sizes reach
    the arclength paths too; case option ``warm_step_growth``, :func:`warm_start_options`).
    ``model_path`` 'arclength' (case option ``model_step``, :func:`case_model_step`): a model
    step at ε_f is the model blend followed in arclength at once (E8 4×4 → 4×4 + Moon + Sun,
    whose τ path crawls); 'tau' or None: in τ, then the fallbacks. For the switch-on from an
    unperturbed solution it is that path's (None: arclength, :func:`perturb_from_unperturbed`).
    The path used is in ``stats['warm_path']``.
    """
    if sol.transfer.perturbed and not tr_to.perturbed:
        raise ConfigError("warm_start", tr_to.perturbations, "cannot warm-start an unperturbed problem from a perturbed one")
    if not sol.transfer.perturbed and tr_to.perturbed:
        return perturb_from_unperturbed(sol, tr_to, label, path=model_path or "arclength", eps_smooth=eps_smooth,
                                        options=options)
    sol = warm_start_integration(sol, tr_to)
    prm_to = tr_to.params(thrust=sol.thrust_N)
    chain.check_arrival_in_window(sol, prm_to["pert"], "arrival of the warm start")
    if sol.transfer.epoch_utc != tr_to.epoch_utc:
        # new departure date (E6): the epoch moves continuously from the old date to the new one
        # (prm['epoch_offset_s'] from t0_old − t0_new to 0), a natural homotopy in the date
        shift = float(sol.prm["pert"].epoch) - float(prm_to["pert"].epoch)
        sol = dataclasses.replace(sol, prm={**sol.prm, "epoch_offset_s": datum(shift)})
        prm_to = {**prm_to, "epoch_offset_s": datum(0.0)}
    same_count = sol.transfer.n_rev == tr_to.n_rev
    new_model = same_count and sol.transfer.perturbations != tr_to.perturbations
    if new_model and model_step_eps is not None:
        # new force model at a larger smoothing ε, followed in arclength (E7: J2 → 4×4 + Moon +
        # Sun; at ε_f its path stalls at τ 0.08)
        out = chain.continue_in_params_smoothed(sol, prm_to, eps_smooth=model_step_eps, options=options,
                                                label=label, path="arclength")
        out.stats["warm_path"] = f"arclength at eps = {model_step_eps:g}"
    else:
        # a new date by the Newton homotopy in the data (E6); more revolutions add burn arcs:
        # move L_f at the smoothing ε₁ of the blend (E8); a new force model by the model blend,
        # and where its end point is singular by the Newton homotopy in the model (E8: the
        # blend converges at 200, 300-400 rev; at 250 both its τ and arclength paths reach
        # τ = 1 with |F| ~ 3e-5 and the polish fails, while the Newton homotopy converges)
        if new_model and model_path == "arclength":
            tries = [(chain.continue_in_model, "arclength", "arclength")]
        elif new_model:
            tries = [(chain.continue_in_model, "tau", "tau"), (chain.continue_in_params, "tau", "newton tau"),
                     (chain.continue_in_model, "arclength", "arclength")]
        else:
            move = chain.continue_in_params if same_count else functools.partial(
                chain.continue_in_params_smoothed, eps_smooth=tr_to.eps_blend)
            tries = [(move, "tau", "tau"), (move, "arclength", "arclength")]
        failures = []
        for move, path, name in tries:
            try:
                out = move(sol, prm_to, options=options,
                           label=label + ("" if name == "tau" else f" ({name})"), path=path)
                break
            except ConvergenceError as exc:
                if len(failures) == len(tries) - 1:
                    if exc.end_point is not None:
                        exc.end_point.transfer, exc.end_point.thrust_N = tr_to, sol.thrust_N
                    raise
                failures.append(f"{name}: {exc}")
        out.stats["warm_path"] = name
        if failures:
            out.stats["path_failures"] = failures
    out.transfer, out.thrust_N = tr_to, sol.thrust_N
    return out


def warm_start_integration(sol: Solution, tr_to: Transfer) -> Solution:
    """``sol`` integrating with the settings of ``tr_to`` (path rtol, step cap, path arcs): every
    stage of a warm start does, not with the start's (E8 J2 → 4×4 + Moon + Sun needs the full
    model's tighter path_rtol)."""
    return dataclasses.replace(sol, shooting=dataclasses.replace(sol.shooting, **tr_to.integration()),
                               transfer=dataclasses.replace(sol.transfer, **tr_to.integration()))


def chain_options(pc: dict, case: str) -> ContinuationOptions | None:
    """Continuation options of the case's chain from the zero guess (:func:`solve_for`): the
    case's ``corrector`` (:func:`case_corrector`); None (the followers' defaults) for Newton's."""
    corrector = case_corrector(pc, case)
    return None if corrector == "newton" else ContinuationOptions(corrector=corrector)


def warm_start_kwargs(pc: dict, case: str, model: str, checkpoint_dir: str = "",
                      n_rev: float | None = None) -> dict:
    """The keyword arguments of :func:`warm_start` into ``model`` (at revolution count ``n_rev``,
    E8) from the case options: ``eps_smooth`` and ``model_step_eps`` (``perturb_at_eps``,
    ``model_step_at_eps``, each checked by :func:`perturb_at_eps`), ``options``
    (:func:`warm_start_options`) and ``model_path`` (:func:`case_model_step`; None where it
    names none)."""
    step = case_model_step(pc["cases"][case], model, f"perturbed.cases.{case}")
    return {"eps_smooth": perturb_at_eps(pc, case), "model_step_eps": perturb_at_eps(pc, case, "model_step_at_eps"),
            "options": warm_start_options(pc, case, checkpoint_dir, model, n_rev), "model_path": step.get("path")}


def warm_start_options(pc: dict, case: str, checkpoint_dir: str = "", model: str | None = None,
                       n_rev: float | None = None) -> ContinuationOptions | None:
    """Continuation options of the case's warm starts (:func:`warm_start`): case option
    ``warm_step_growth`` ('iterations' | 'residual', :mod:`spaceopt.indirect.continuation`),
    the continuation settings ``model_step`` names for ``model`` at ``n_rev``
    (:func:`case_model_step`; they take precedence) and ``checkpoint_dir`` (paths resumable
    after an interruption, ``ContinuationOptions``); None (the followers' defaults) where none
    is given. Options of an arclength model step are :class:`ArclengthOptions`, so that its
    ``h_max`` is an arclength (the τ stages of the same warm start keep their own step sizes,
    ``chain.path_options``)."""
    cc = pc["cases"][case]
    growth = cc.get("warm_step_growth")
    if growth is not None and growth not in GROWTH:
        raise ConfigError(f"perturbed.cases.{case}.warm_step_growth", growth, f"expected one of {', '.join(GROWTH)}")
    step = case_model_step(cc, model, f"perturbed.cases.{case}", n_rev) if model is not None else {}
    settings = {**({"step_growth": growth} if growth else {}), **{k: v for k, v in step.items() if k != "path"}}
    if not settings and not checkpoint_dir:
        return None
    kind = ArclengthOptions if step.get("path") == "arclength" else ContinuationOptions
    return kind(**settings, checkpoint_dir=checkpoint_dir)


def perturbation_switch(tr: Transfer) -> Shooting:
    """The shooting problem that switches the perturbations of ``tr`` on by τ: OT at ε_f plus
    τ H_p (flow.Model('ot', 'pert'), the perturbation switch of (3.3.1) on its own)."""
    sh_p = chain.shooting_for("ot", "eps", tr)
    return dataclasses.replace(sh_p, model=dataclasses.replace(sh_p.model, homotopy="pert"))


def perturb_from_unperturbed(sol: Solution, tr_to: Transfer, label: str, path: str = "arclength",
                             eps_smooth: float | None = None, options=None) -> Solution:
    """Unperturbed OT solution → the perturbed OT problem of ``tr_to`` (same orbits, thrust).

    z gains p_t(0) = 0; the perturbations are switched on by τ (flow.Model('ot', 'pert'):
    pure OT at ε_f plus τ H_p — the perturbation switch of (3.3.1) on its own), followed in τ or
    in arclength (default: E5's strength path has an S-shaped pair of folds, τ ≈ 0.318 and
    0.221; the Newton homotopy f_p(z, τ) = (1 − τ) f_p(z₀) at the perturbed problem folds at
    τ ≈ 0.957 and runs back to τ < 0). ``eps_smooth``: switch them on at that ε instead of ε_f
    (:func:`chain.through_smoothing`; case option ``perturb_at_eps``), for transfers with
    many burn arcs, where the switch at ε_f stalls (E7: τ = 0.3728 after 42 Jacobians; at
    ε = 10⁻² its path meets a near branch point at τ ≈ 0.611, at 3·10⁻² it runs clean).
    ``options``: continuation options of every stage (default: the path's own). An exact
    bang-bang solution (``chain.to_exact``) has its perturbations switched on on the exact map
    (E8 200 rev, J2: 11 Jacobians, the extremal of the smoothed route's to 1e-10).
    """
    exact = sol.shooting.switching == "exact"
    if exact and eps_smooth is not None:
        raise ConfigError("perturb_at_eps", eps_smooth, "the exact bang-bang map has no smoothing eps")
    sh_p = dataclasses.replace(chain.shooting_for("ot", "eps", tr_to), switching=sol.shooting.switching)
    sh_pert = dataclasses.replace(perturbation_switch(tr_to), switching=sol.shooting.switching)
    names_u = sol.shooting.unknown_names()

    def switch_on(unp: Solution) -> Solution:
        z = np.asarray([0.0 if n == "p_t" else float(unp.z[names_u.index(n)]) for n in sh_p.unknown_names()])
        prm = {**tr_to.params(thrust=sol.thrust_N), **({"eps_final": unp.prm["eps_final"]} if exact else {})}
        if eps_smooth is not None:
            prm["eps_final"] = unp.prm["eps_final"]              # = eps_smooth (through_smoothing)
        z, stats = chain._run(sh_pert, z, prm, label, options, path=path)
        return Solution("ot", sh_p, z, prm, tr_to, stats, thrust_N=sol.thrust_N)

    chain.check_arrival_in_window(sol, tr_to.perturbation_model(), "arrival of the transfer switched on")
    out = switch_on(sol) if eps_smooth is None else chain.through_smoothing(sol, eps_smooth, switch_on, options, label)
    out.stats["continued_from"] = "unperturbed OT (perturbations switched on by tau" + (
        f" at eps = {eps_smooth:g})" if eps_smooth is not None else ")")
    out.thrust_N = sol.thrust_N
    return out


def tof_maximum_settings(pc: dict, case: str) -> dict | None:
    """The end game's settings of ``case``: ``perturbed.numerics.tof_maximum``, each key the case's
    own ``tof_maximum`` gives replaced (E9: probes 0.001 d apart, its m_f(t_f) falls by 4 g within
    0.001 d of the maximum and the fixed-time Newton fails at 0.05 d). A null key is as if not
    given: the case's leaves the numerics' value (a profile removes a case's value so), the
    numerics' leaves MaximumOptions' default. None (the entry absent or null): off."""
    settings = pc["numerics"].get("tof_maximum")
    cc = pc["cases"][case]
    if "tof_maximum" in cc:
        own = cc["tof_maximum"]
        settings = None if own is None else {**(settings or {}), **{k: v for k, v in own.items() if v is not None}}
    return {k: v for k, v in settings.items() if v is not None} if settings else None


def maximise_in_tof(sol: Solution, pc: dict, case: str, label: str) -> tuple[Solution, dict | None]:
    """The free-time end game of a perturbed OT solution (:mod:`spaceopt.indirect.free_time`,
    :func:`tof_maximum_settings`): (the solution at the local maximum of m_f in t_f next to
    ``sol``, its record). An unperturbed solution is returned as it is, with no record: its
    family m_f(t_f) has no perturbation wiggle, and its layout no p_t."""
    settings = tof_maximum_settings(pc, case)
    if not settings or not sol.transfer.perturbed:
        return sol, None
    return maximise_final_mass(sol, MaximumOptions(label=f"{label} tof maximum", **settings))


def end_point_of(exc: ConvergenceError, tr: Transfer) -> Solution | None:
    """The unconverged free-time solution of ``tr`` that a failed warm start left where its path
    reached τ = 1 and only the final polish failed (``exc.end_point``, its point of least |F|;
    :func:`chain.continue_in_model`), or None where there is none or it is not ``tr``'s
    perturbed OT problem at its final ε. The free-time end game can still certify a local
    maximum of m_f from it: the fixed-time Jacobian stays regular where the free-time one has
    a nearly flat direction (E8 450 rev, full model: σ_min 0.21 against 3e-4,
    docs/perturbed-e6-e7-e8.md, "twenty-first session"). On the exact bang-bang map the point
    has no smoothing ε to check (``chain.to_exact`` sets its ``eps_final`` to 0, the problem's is ε_f):
    E8 450, full model, whose blend on the exact map reached τ = 1 with |F| 8e-7 ("fortieth
    session")."""
    end = exc.end_point
    if end is None or end.stage != "ot" or not tr.perturbed or end.transfer is not tr:
        return None
    if end.shooting.switching != "exact" and not np.isclose(
            float(end.prm["eps_final"]), float(tr.params(thrust=end.thrust_N)["eps_final"]), rtol=1e-12):
        return None
    return end


load = multirev.load     # rebuilds perturbed solutions too (model.perturbed in the artifact)


def end_game_start(path) -> tuple[Solution, dict, float] | None:
    """The free-time solution a solve saved (:func:`save`) before its end game, so that the end
    game of an interrupted run resumes from it: (solution, artifact extra, the wall time spent on
    it), or None where there is none or it does not read back (checksums). The extra keeps the
    saved solution's own provenance (``free_time_start_provenance``: the code and config it was
    computed with, which can be older than the end game's, e.g. a solve from before the end game
    existed given one, with a config that differs only in ``tof_maximum``)."""
    if not Path(path).exists():
        return None
    try:
        payload = artifacts.read_json(path)
        extra = {**payload["extra"], "free_time_start_provenance": payload["provenance"]}
        return load(path), extra, float(payload["provenance"].get("wall_time_s") or 0.0)
    except (ArtifactError, KeyError, OSError, ValueError):
        return None


def save(sol: Solution, json_path, cfg: dict, wall_time_s: float, extra: dict | None = None,
         samples_per_rev: int = 200):
    """Stage artifacts (JSON + NPZ + RRD) as in §4.1, plus the perturbation model and epoch."""
    tr = sol.transfer
    ex = {"perturbations": tr.perturbations, "epoch_utc": tr.epoch_utc, **(extra or {})}
    if tr.perturbed:
        ex["p_t0"] = float(sol.z[list(sol.shooting.free_costates).index(hm.TIME)])
    return multirev.save(sol, json_path, cfg, wall_time_s, ex, samples_per_rev)


# ---------------------------------------------------------------- E9 ΔΩ budget

def j2_secular_rates(orbit: Orbit, mu: float, j2: float, radius: float) -> dict:
    """Secular J2 rates [deg/day] of Ω and ω for a Keplerian orbit (first order)."""
    a, e, i = orbit.a, orbit.e, math.radians(orbit.i)
    p = a * (1 - e * e)
    n = math.sqrt(mu / a**3)
    f = n * j2 * (radius / p) ** 2
    return {"raan_deg_per_day": math.degrees(-1.5 * f * math.cos(i)) * DAY,
            "argp_deg_per_day": math.degrees(0.75 * f * (5 * math.cos(i) ** 2 - 1)) * DAY,
            "period_min": 2 * math.pi / n / 60.0}


def raan_budget(tr: Transfer, days: float, tof_days: float | None = None) -> dict:
    """Spec 02-multirev §6: natural J2 drift against the required ΔΩ (and ω drift against ω_f).

    Two constant sets: the EGM96 J₂ with its GM and a_e (the forces module's J2 model), and the
    same J₂ with the thesis central μ. ``tof_days`` (e.g. the solved J2-only Δt) adds the drift
    over the actual transfer time.
    """
    from ..forces import load_egm96
    egm = load_egm96()
    d_raan = math.remainder(tr.final.raan - tr.initial.raan, 360.0)
    d_argp = math.remainder(tr.final.argp - tr.initial.argp, 360.0)
    out = {"required_draan_deg": d_raan, "required_dargp_deg": d_argp, "days": days,
           "j2": egm["j2"], "radius_m": egm["radius"]}
    for tag, mu in (("egm96_gm", egm["gm"]), ("central_mu", tr.mu)):
        r = j2_secular_rates(tr.initial, mu, egm["j2"], egm["radius"])
        out[tag] = {**r, "draan_deg": r["raan_deg_per_day"] * days, "dargp_deg": r["argp_deg_per_day"] * days}
        if tof_days is not None:
            out[tag]["draan_over_tof_deg"] = r["raan_deg_per_day"] * tof_days
        # mean semi-major axis that would make the natural drift equal the requirement over `days`
        # (Ω̇ ∝ a^(-7/2) at fixed e, i)
        need = d_raan / days
        out[tag]["a_for_required_drift_km"] = tr.initial.a * (r["raan_deg_per_day"] / need) ** (2 / 7) / 1e3
    out["control_must_change_draan_by_deg"] = d_raan - out["egm96_gm"]["draan_deg"]
    return out


def raan_budget_numeric(tr: Transfer, days: float, epoch_utc: str, model_cfg) -> dict:
    """Osculating Ω and ω after a free coast of ``days`` (Cartesian, DOP853) under ``model_cfg``."""
    import jax
    from scipy.integrate import solve_ivp
    from ..elements import cartesian_to_mee, kepler_to_mee, mee_to_cartesian, mee_to_kepler
    from ..forces import build_model, perturbing_acceleration

    model = build_model(model_cfg, epoch_utc, tr.ephemeris)
    o = tr.initial
    nu0 = math.radians(tr.L0_deg - o.raan - o.argp)
    mee = kepler_to_mee(o.a, o.e, math.radians(o.i), math.radians(o.raan), math.radians(o.argp), nu0)
    r0, v0 = (np.asarray(v) for v in mee_to_cartesian(np.asarray(mee), tr.mu))
    acc = jax.jit(lambda r, t: perturbing_acceleration(r, model.epoch + t, model))

    def rhs(t, y):
        r = y[:3]
        a = -tr.mu * r / np.linalg.norm(r) ** 3 + np.asarray(acc(r, t))
        return np.concatenate([y[3:], a])

    sol = solve_ivp(rhs, (0.0, days * DAY), np.concatenate([r0, v0]), method="DOP853", rtol=1e-11, atol=1e-4)
    kep0 = np.asarray(mee_to_kepler(cartesian_to_mee(r0, v0, tr.mu)))
    kep1 = np.asarray(mee_to_kepler(cartesian_to_mee(sol.y[:3, -1], sol.y[3:, -1], tr.mu)))
    return {"days": days, "model": model_cfg,
            "draan_deg": math.degrees(math.remainder(kep1[3] - kep0[3], 2 * math.pi)),
            "dargp_deg": math.degrees(math.remainder(kep1[4] - kep0[4], 2 * math.pi)),
            "nfev": int(sol.nfev)}


def timed(fn, *args, **kwargs):
    t0 = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t0
