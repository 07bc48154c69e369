"""The perturbed multi-revolution studies of dissertation §4.2 (E5–E9) built from the config.

Config: ``config/studies/perturbed.yaml`` (key ``perturbed``). A case names an initial and a
final orbit (altitudes above the mean Earth radius, or ``a_km``/``e`` where the thesis gives
them), L₀, the angular range, the spacecraft, the departure epoch (UTC), the ephemeris window
and the perturbation models (``forces.build_model`` configs) it is solved with.

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
from ..indirect.continuation import ACCEPTED_UPDATES, CORRECTORS, GROWTH, ArclengthOptions, ContinuationOptions
from ..indirect.flow import SWITCHINGS
from ..indirect.free_time import MaximumOptions, maximise_final_mass
from ..indirect.shooting import Shooting
from ..indirect.transfer import MAX_STEPS, PATH_RTOL, Orbit, Transfer, datum, step_cap
from ..constants import DAY
from . import multirev

ALT_KEYS = ("perigee_alt_km", "apogee_alt_km")
AE_KEYS = ("a_km", "e")
ANGLE_KEYS = ("i_deg", "raan_deg", "argp_deg")
CASE_KEYS = ("initial", "final", "L0_deg", "n_rev", "m0_kg", "isp_s", "thrust_N", "epoch_utc",
             "ephemeris", "models")
OPTIONAL_CASE_KEYS = ("lp_perturbed", "homotopy_path", "blend_ref", "route", "model_start", "fallback",
                      "perturb_at_eps", "model_step_at_eps", "path_rtol", "path_arcs", "warm_step_growth",
                      "model_step", "tof_maximum", "switching", "corrector", "sensitivity_rtol", "model_from")
MODEL_STEP_PATHS = ("tau", "arclength")


def _number(cfg, key, path, positive=False):
    return multirev._number(cfg, key, path, positive=positive)


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
        return multirev.orbit_from_config(cfg, path, radius_m)
    a = _number(cfg, "a_km", path, positive=True) * 1e3
    e = _number(cfg, "e", path)
    if not 0.0 <= e < 1.0:
        raise ConfigError(f"{path}.e", e, "eccentricity must be in [0, 1)")
    return Orbit(a, e, _number(cfg, "i_deg", path), cfg.get("raan_deg", 0.0), cfg.get("argp_deg", 0.0))


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
    radius = _number(const, "earth_radius_km", "perturbed.constants", positive=True) * 1e3
    mu = _number(const, "mu_km3_s2", "perturbed.constants", positive=True) * 1e9
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
    revs = float(n_rev) if n_rev is not None else _number(cc, "n_rev", path, positive=True)
    return Transfer(
        orbit_from_config(orbits[cc["initial"]], f"perturbed.orbits.{cc['initial']}", radius),
        orbit_from_config(orbits[cc["final"]], f"perturbed.orbits.{cc['final']}", radius),
        L0_deg=_number(cc, "L0_deg", path),
        n_rev=revs,
        m0=_number(cc, "m0_kg", path, positive=True), isp=_number(cc, "isp_s", path, positive=True),
        thrust=_number(cc, "thrust_N", path, positive=True), mu=mu,
        eps_final=_number(num, "eps_final", "perturbed.numerics", positive=True),
        eps_blend=_number(num, "eps_blend", "perturbed.numerics", positive=True),
        perturbations=mcfg or None, epoch_utc=epoch if mcfg else None,
        ephemeris=ephemeris if needs_eph else None,
        max_steps=step_cap(revs, num["max_steps_per_rev"], num["min_max_steps"]) if "max_steps_per_rev" in num
        else MAX_STEPS,
        path_rtol=case_path_rtol(cc, model, path), path_arcs=case_path_arcs(cc, model, path),
        sensitivity_rtol=case_sensitivity_rtol(pc, case, model))


def _per_model(cc: dict, key: str, model: str, path: str, default, read):
    """Case option ``key``: one value for every model of the case, or a mapping {model: value}
    (models not named, and cases without the option, get ``default``); ``read(cfg, key, path)``
    checks a value."""
    val = cc.get(key)
    if not isinstance(val, dict):
        return default if val is None else read(cc, key, path)
    unknown = sorted(set(val) - set(cc["models"]))
    if unknown:
        raise ConfigError(f"{path}.{key}.{unknown[0]}", val[unknown[0]],
                          f"not a model of the case (expected one of {', '.join(cc['models'])})")
    return read(val, model, f"{path}.{key}") if model in val else default


def case_path_rtol(cc: dict, model: str, path: str) -> float:
    """Case option ``path_rtol``: the integration rtol while a homotopy path is followed, one
    number for every model of the case, or a mapping {model: rtol} (models not named, and cases
    without the option, keep the default PATH_RTOL). E8 names only its full model: at 1e-9 the
    propagated Jacobian of 4×4 + Moon + Sun is too inaccurate for Newton's corrector (‖J⁻¹ δJ‖ =
    2.5 at the converged 200-revolution extremal; 0.27 at 1e-10, 0.008 at 1e-11, measured by
    docs/experiments/path_jacobian_accuracy.py)."""
    return _per_model(cc, "path_rtol", model, path, PATH_RTOL,
                      lambda cfg, key, where: _number(cfg, key, where, positive=True))


def case_sensitivity_rtol(pc: dict, case: str, model: str) -> float | None:
    """Case option ``sensitivity_rtol`` (a number or {model: number}, like ``path_rtol``): the
    integration rtol of the exact map's sensitivities where it is looser than the residual's
    (``Shooting.sensitivity_rtol``; None, the default: the residual's). Newton and the path
    correctors need ‖J⁻¹ δJ‖ ≪ 1, not the residual's accuracy: on the exact map at E8 500 rev,
    1e-9 against 1e-11 gives ‖J⁻¹ δJ‖ 1.8e-2 at the full model's extremal and 0.23 at τ 0.5 of
    the 4×4 → full blend, whose Jacobian is 1.41× cheaper (docs/perturbed-e6-e7-e8.md,
    "forty-first session"). Only with ``switching: exact``: the
    smoothed map integrates f and Φ in one solve, and at ε_f its Jacobian needs the tight path
    tolerance (:func:`case_path_rtol`)."""
    cc, path = pc["cases"][case], f"perturbed.cases.{case}"
    if cc.get("sensitivity_rtol") is not None and case_switching(pc, case) != "exact":
        raise ConfigError(f"{path}.sensitivity_rtol", cc["sensitivity_rtol"],
                          "a separate Jacobian tolerance needs the exact bang-bang map (switching: exact)")
    return _per_model(cc, "sensitivity_rtol", model, path, None,
                      lambda cfg, key, where: _number(cfg, key, where, positive=True))


def case_start_model(pc: dict, case: str, model: str) -> str | None:
    """The model whose converged solution the solve of (``case``, ``model``) starts from, or None
    where that solve is the chain from the zero guess: the case's first model, and every model
    when the case says ``model_start: chain`` (E5, E7). Otherwise the model the case option
    ``model_from`` ({model: an earlier model of the case}) names for it, else the one before it in
    ``models``. ``config/e8_exact.yaml`` starts the full model from J2: on the exact map at 500
    revolutions the J2 → full blend took 44 Jacobians and landed on the certified maximum, where
    J2 → 4×4 → full took 16 + 64 and an end game of 33 (docs/perturbed-e6-e7-e8.md,
    "forty-second session"); 4×4 is then a solve beside the route, not on it."""
    cc, where = pc["cases"][case], f"perturbed.cases.{case}.model_from"
    models, model_from = cc["models"], cc.get("model_from") or {}
    for target, start in model_from.items():
        if target not in models[1:]:
            raise ConfigError(f"{where}.{target}", start, f"not a model of the case after its first ({', '.join(models[1:])})")
        if start not in models[:models.index(target)]:
            raise ConfigError(f"{where}.{target}", start, f"must name a model before {target} in the case's models")
    if model_from and cc.get("model_start", "previous") == "chain":
        raise ConfigError(where, model_from, "every model starts from the zero guess here (model_start: chain)")
    if model == models[0] or cc.get("model_start", "previous") == "chain":
        return None
    return model_from.get(model, models[models.index(model) - 1])


def case_route(pc: dict, case: str, model: str) -> list[str]:
    """The models whose solves lead to (``case``, ``model``), in order, ``model`` last: its start
    model's route (:func:`case_start_model`), from the solve that starts from the zero guess."""
    start = case_start_model(pc, case, model)
    return [model] if start is None else case_route(pc, case, start) + [model]


def case_start_models(pc: dict) -> dict:
    """{case: {model: start model or None}} of every case (checks each case's ``model_from``)."""
    return {case: {m: case_start_model(pc, case, m) for m in cc["models"]} for case, cc in pc["cases"].items()}


def case_path_arcs(cc: dict, model: str, path: str) -> int:
    """Case option ``path_arcs`` (a number or {model: number}, like ``path_rtol``): the number
    of shooting arcs while a homotopy path into that model is followed (1, single shooting, by
    default; :mod:`spaceopt.indirect.multiple_shooting`)."""
    def read(cfg, key, where):
        val = cfg[key]
        if isinstance(val, bool) or not isinstance(val, int) or val < 1:
            raise ConfigError(f"{where}.{key}", val, "must be a whole number of shooting arcs >= 1")
        return val
    return _per_model(cc, "path_arcs", model, path, 1, read)


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


def perturb_at_eps(pc: dict, case: str, key: str = "perturb_at_eps") -> float | None:
    """Case option ``perturb_at_eps`` (or ``model_step_at_eps``): the smoothing ε at which the
    perturbations are switched on (:func:`perturb_from_unperturbed`), or a perturbed force
    model is changed (:func:`warm_start`), between ε_f and 1; None (absent) does it at ε_f."""
    eps = pc["cases"][case].get(key)
    if eps is None:
        return None
    val = _number(pc["cases"][case], key, f"perturbed.cases.{case}", positive=True)
    if not pc["numerics"]["eps_final"] < val <= 1.0:
        raise ConfigError(f"perturbed.cases.{case}.{key}", eps, "must lie in (eps_final, 1]")
    return val


def case_switching(pc: dict, case: str) -> str:
    """Case option ``switching``: 'smoothed' (the default), the smoothed throttle (3.3.2) down to
    ε_f, or 'exact', the exact bang-bang map (:mod:`spaceopt.indirect.exact_switching`): the chain
    stops its ε descent at ε₁ and Newton takes it to ε = 0, and every later solve of the case stays
    on the exact map (its warm starts read the switching from their start). The options of the
    smoothed route that need a smoothing ε or multiple shooting are refused with it."""
    cc, path = pc["cases"][case], f"perturbed.cases.{case}"
    value = cc.get("switching", "smoothed")
    if value not in SWITCHINGS:
        raise ConfigError(f"{path}.switching", value, f"expected one of {', '.join(SWITCHINGS)}")
    if value == "exact":
        for key in ("perturb_at_eps", "model_step_at_eps"):
            if cc.get(key) is not None:
                raise ConfigError(f"{path}.{key}", cc[key],
                                  "the exact bang-bang map (switching: exact) has no smoothing eps")
        arcs = cc.get("path_arcs")
        if arcs is not None and any(v > 1 for v in (arcs.values() if isinstance(arcs, dict) else [arcs])):
            raise ConfigError(f"{path}.path_arcs", arcs, "the exact bang-bang map (switching: exact) is single shooting")
        if case == "e8" and "e8" in pc and e8_count_start(pc) != "chain":     # (a job's config has no e8 part)
            raise ConfigError("perturbed.e8.count_start", e8_count_start(pc),
                              "a count moved from the previous one needs the smoothing eps (switching: exact)")
    return value


def case_corrector(pc: dict, case: str) -> str:
    """Case option ``corrector``: 'newton' (the default), a Jacobian at every corrector
    evaluation, or 'chord', the corrector's later steps with the Jacobian of its first and f
    alone (:mod:`spaceopt.indirect.continuation`), on the paths of the chain from the zero guess
    (:func:`chain_options`). The warm starts keep Newton's: their steps converge in one or two
    corrector evaluations, so the chord saves little, and on the exact map at E8 500 rev the 4×4
    blend with it stalled at τ 0.6 (the accepted point's update, with the predictor's Jacobian,
    crossed an edge of the map), and took 152 s with ``accepted_update`` revert against Newton's
    103 s (docs/perturbed-e6-e7-e8.md, "thirty-seventh session")."""
    value = pc["cases"][case].get("corrector", "newton")
    if value not in CORRECTORS:
        raise ConfigError(f"perturbed.cases.{case}.corrector", value, f"expected one of {', '.join(CORRECTORS)}")
    return value


def chain_options(pc: dict, case: str) -> ContinuationOptions | None:
    """Continuation options of the case's chain from the zero guess (:func:`solve_for`): the
    case's ``corrector`` (:func:`case_corrector`); None (the followers' defaults) for Newton's."""
    corrector = case_corrector(pc, case)
    return None if corrector == "newton" else ContinuationOptions(corrector=corrector)


STEP_SETTINGS = ("step_growth", "accepted_update", "corrector", "step_rcond", "flat_step", "end_overshoot", "h_max")


def case_model_step(cc: dict, model: str, path: str, n_rev: float | None = None) -> dict:
    """Case option ``model_step`` ({model: settings}): how the warm start into that model is
    followed, ``path`` ('tau', the default: τ, then its fallbacks; 'arclength': the model blend
    in arclength at once; for the perturbations switched on from an unperturbed solution the
    default is arclength) and the continuation options ``step_growth``, ``accepted_update``,
    ``corrector``, ``step_rcond``, ``flat_step``, ``end_overshoot`` and ``h_max`` (the largest
    step, in the path's own measure; :class:`ContinuationOptions`, :class:`ArclengthOptions`).
    ``config/e8_exact.yaml`` switches J2 on in τ with the chord corrector: at 500 revolutions 14
    Jacobians against 37 with Newton's in τ and 52 in arclength, the same extremal
    (docs/perturbed-e6-e7-e8.md, "forty-second session").
    ``at_n_rev: {count: settings}`` overrides those continuation options for one revolution
    count ``n_rev`` (E8 450: the full model's arclength path with h_max 0.1, whose end point
    has the flat-direction root 0.008 away where h_max 0.3 leaves it 0.02 away, beyond the
    chords' reach; docs/perturbed-e6-e7-e8.md, "twelfth" and "thirteenth session"). E8 names
    its full model (the 4×4 → 4×4 + Moon + Sun step at 450-500 revolutions, "ninth session").
    Models not named get {}."""
    def check(settings, where, allowed):
        if not isinstance(settings, dict):
            raise ConfigError(where, settings, "expected a mapping of model-step settings")
        choices = {"path": MODEL_STEP_PATHS, "step_growth": GROWTH, "accepted_update": ACCEPTED_UPDATES,
                   "corrector": CORRECTORS}
        for k, v in settings.items():
            if k not in allowed:
                raise ConfigError(f"{where}.{k}", v, f"unknown setting (expected {', '.join(allowed)})")
            if k in choices:
                if v not in choices[k]:
                    raise ConfigError(f"{where}.{k}", v, f"expected one of {', '.join(choices[k])}")
            elif k == "h_max":
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v <= 1:
                    raise ConfigError(f"{where}.{k}", v, "expected a number in (0, 1]")
            elif k != "at_n_rev" and (isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 <= v < 1):
                raise ConfigError(f"{where}.{k}", v, "expected a number in [0, 1)")

    def read(cfg, key, where):
        val = cfg[key]
        where = f"{where}.{key}"
        check(val, where, ("path", *STEP_SETTINGS, "at_n_rev"))
        counts = val.get("at_n_rev", {})
        if not isinstance(counts, dict):
            raise ConfigError(f"{where}.at_n_rev", counts, "expected a mapping {revolution count: settings}")
        chosen = {}
        for count, settings in counts.items():
            if isinstance(count, bool) or not isinstance(count, (int, float)) or count <= 0:
                raise ConfigError(f"{where}.at_n_rev.{count}", settings, "the key must be a positive revolution count")
            check(settings, f"{where}.at_n_rev.{count}", STEP_SETTINGS)
            if n_rev is not None and float(count) == float(n_rev):
                chosen = settings
        return {**{k: v for k, v in val.items() if k != "at_n_rev"}, **chosen}
    return _per_model(cc, "model_step", model, path, {}, read)


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

    out = switch_on(sol) if eps_smooth is None else chain.through_smoothing(sol, eps_smooth, switch_on, options, label)
    out.stats["continued_from"] = "unperturbed OT (perturbations switched on by tau" + (
        f" at eps = {eps_smooth:g})" if eps_smooth is not None else ")")
    out.thrust_N = sol.thrust_N
    return out


def tof_maximum_settings(pc: dict, case: str) -> dict | None:
    """The end game's settings of ``case``: ``perturbed.numerics.tof_maximum``, each key the case's
    own ``tof_maximum`` gives replaced (E9: probes 0.001 d apart, its m_f(t_f) falls by 4 g within
    0.001 d of the maximum and the fixed-time Newton fails at 0.05 d); None (absent or null): off."""
    settings = pc["numerics"].get("tof_maximum")
    cc = pc["cases"][case]
    if "tof_maximum" in cc:
        settings = None if cc["tof_maximum"] is None else {**(settings or {}), **cc["tof_maximum"]}
    return settings or None


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


def summary(payload: dict) -> dict:
    """Table scalars of an OT artifact payload."""
    s = payload["scalars"]
    tr = payload["transfer"]
    m_p = tr["m0"] - s["m_f_kg"]
    return {"m_f_kg": s["m_f_kg"], "tof_days": s["tof_days"], "K_f_deg": s["K_f_deg"],
            "propellant_kg": m_p, "dv_m_s": s["dv_m_s"], "burn_h": s["burn_days"] * 24.0,
            "burn_fraction": s["burn_fraction"], "n_rev": tr["n_rev"]}


# ---------------------------------------------------------------- E6 dates

def scan_dates(e6: dict) -> list[str]:
    """UTC epochs of the departure scan (``perturbed.e6``)."""
    from datetime import date, timedelta
    try:
        d0 = date.fromisoformat(e6["first_date"])
        d1 = date.fromisoformat(e6["last_date"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ConfigError("perturbed.e6.first_date/last_date", e6.get("first_date"), f"bad date ({exc})") from None
    step = e6.get("step_days", 1)
    if not isinstance(step, int) or step < 1:
        raise ConfigError("perturbed.e6.step_days", step, "must be a positive integer")
    if d1 < d0:
        raise ConfigError("perturbed.e6.last_date", e6["last_date"], "before first_date")
    out, d = [], d0
    while d <= d1:
        out.append(f"{d.isoformat()}T{e6.get('time_utc', '12:00:00')}")
        d += timedelta(days=step)
    return out


def scan_order(dates: list[str], anchor: str) -> list[tuple[str, str]]:
    """(date, warm-start source) pairs: outward from the anchor date, each from its neighbour."""
    if anchor not in dates:
        raise ConfigError("perturbed.e6", anchor, "the anchor epoch (the E5 date) must be one of the scan dates")
    i = dates.index(anchor)
    pairs = []
    for j in range(i + 1, len(dates)):
        pairs.append((dates[j], dates[j - 1]))
    for j in range(i - 1, -1, -1):
        pairs.append((dates[j], dates[j + 1]))
    return pairs


def scan_start_from(e6: dict) -> dict[str, str]:
    """``perturbed.e6.start_from``: dates (YYYY-MM-DD) that warm-start from a named, converged
    neighbouring date instead of the scan's ``warm_start`` route (E6: where the perturbation
    switch from the unperturbed solve turns back). Checked: both are scan dates, and following
    the map from any date ends at a date on the default route (no cycle)."""
    start_from = e6.get("start_from") or {}
    days = {d[:10] for d in scan_dates(e6)}
    for date, src in start_from.items():
        for value in (date, src):
            if value not in days:
                raise ConfigError(f"perturbed.e6.start_from.{date}", value, "not a date of the scan")
    for date in start_from:
        seen, d = {date}, start_from[date]
        while d in start_from:
            if d in seen:
                raise ConfigError(f"perturbed.e6.start_from.{date}", start_from[date], "the starts form a cycle")
            seen.add(d)
            d = start_from[d]
    return dict(start_from)


def scan_source(pc: dict, date: str) -> str | None:
    """What E6 date ``date`` (YYYY-MM-DD) warm-starts from: a date of ``start_from`` from the
    converged date named there; otherwise, with ``warm_start: unperturbed`` (the default),
    'unperturbed' (the date-independent unperturbed OT of the E6 case, perturbations then
    switched on by τ: every date an independent job); with ``warm_start: neighbour``, the
    neighbouring date towards the E5 anchor (None for the anchor: the E5 solve itself)."""
    e6 = pc["e6"]
    start_from = scan_start_from(e6)
    if date in start_from:
        return start_from[date]
    if e6.get("warm_start", "unperturbed") == "unperturbed":
        return "unperturbed"
    anchor = pc["cases"][e6["case"]]["epoch_utc"]
    return dict((d[:10], s[:10]) for d, s in scan_order(scan_dates(e6), anchor)).get(date)


def scan_run_dates(pc: dict) -> list[str]:
    """The E6 dates (YYYY-MM-DD) the DAG solves: the scan's dates less ``perturbed.e6.skip_dates``
    (dates whose solve does not converge on a machine, left out so that the tables, figures and
    paper are built without them; the report lists them). Checked: each skipped date is a scan
    date, and no date that is run starts from a skipped one."""
    e6 = pc["e6"]
    days = [d[:10] for d in scan_dates(e6)]
    skip = e6.get("skip_dates") or []
    for d in skip:
        if d not in days:
            raise ConfigError("perturbed.e6.skip_dates", d, "not a date of the scan")
    run = [d for d in days if d not in skip]
    for d in run:
        src = scan_source(pc, d)
        if src in skip:
            raise ConfigError("perturbed.e6.skip_dates", src,
                              f"date {d} starts from it (start_from / warm_start: neighbour); skip {d} too, or start it elsewhere")
    return run


# ---------------------------------------------------------------- E8 counts

def e8_count_start(pc: dict) -> str:
    """How each E8 count of the case's first model starts (``perturbed.e8.count_start``, enum
    checked by the schema): 'chain' (the default), from the zero guess, or 'previous', from the
    next smaller count."""
    return pc["e8"].get("count_start", "chain")


def e8_smoothing(pc: dict) -> dict:
    """The smoothing ε values the E8 route uses, for the report text: ``eps_final``, ``eps_blend``
    (where a count moved from the previous one is moved), ``perturb_at_eps`` (J2 switched on) and
    ``model_step_at_eps`` (the force model changed), the last two ε_f where the case leaves them out;
    ``switching`` (:func:`case_switching`): 'exact' where the route runs on the exact bang-bang map."""
    eps_f = float(pc["numerics"]["eps_final"])
    return {"eps_final": eps_f, "eps_blend": float(pc["numerics"]["eps_blend"]), "switching": case_switching(pc, "e8"),
            **{key: eps if eps is not None else eps_f
               for key, eps in (("perturb_at_eps", perturb_at_eps(pc, "e8")),
                                ("model_step_at_eps", perturb_at_eps(pc, "e8", "model_step_at_eps")))}}


def e8_model_steps(pc: dict) -> list[dict]:
    """The force-model steps of the E8 route after J2 is switched on (the case's models from the
    third on), for the report text: {model, from, path, arcs, step_rcond, flat_step} from the
    case options ``model_from``, ``model_step`` and ``path_arcs``; ``from`` is the start model
    (:func:`case_start_model`) where it is not the one before in the list, else None."""
    cc, where = pc["cases"]["e8"], "perturbed.cases.e8"
    steps = []
    for model in cc["models"][2:]:
        step, start = case_model_step(cc, model, where), case_start_model(pc, "e8", model)
        steps.append({"model": model, "from": None if start == cc["models"][cc["models"].index(model) - 1] else start,
                      "path": step.get("path", "tau"), "arcs": case_path_arcs(cc, model, where),
                      "step_rcond": step.get("step_rcond", 0.0), "flat_step": step.get("flat_step", 0.0)})
    return steps


def e8_runs(pc: dict) -> list[tuple[str, float]]:
    """(model, n_rev) of the E8 solves the tables ask for (the solves they start from come with
    them): ``perturbed.e8.run_models`` (default: the case's models) × ``run_n_rev``, less the
    counts ``skip_n_rev`` names for a model (counts whose route is known not to converge, each
    with its measured reason in the config; counts that are not run anyway are ignored, so a
    profile with fewer counts, e.g. the quick one, keeps the map). Checked: the run models are
    models of the case, the run counts lie on the ``n_rev`` grid, and the skipped models are run
    models."""
    e8, models = pc["e8"], pc["cases"]["e8"]["models"]
    run_models = e8.get("run_models", models)
    for m in run_models:
        if m not in models:
            raise ConfigError("perturbed.e8.run_models", m, f"not a model of case e8 (expected one of {', '.join(models)})")
    grid = [float(n) for n in e8["n_rev"]]
    counts = [float(n) for n in e8["run_n_rev"]]
    for n in counts:
        if n not in grid:
            raise ConfigError("perturbed.e8.run_n_rev", n, "not a count of perturbed.e8.n_rev")
    skip = {}
    for m, ns in (e8.get("skip_n_rev") or {}).items():
        if m not in run_models:
            raise ConfigError(f"perturbed.e8.skip_n_rev.{m}", ns, "not a model of perturbed.e8.run_models")
        skip[m] = {float(n) for n in ns}
    return [(m, n) for m in run_models for n in counts if n not in skip.get(m, ())]


def e8_skipped(pc: dict) -> list[tuple[str, float]]:
    """(model, n_rev) of the run list that ``skip_n_rev`` leaves out (:func:`e8_runs`), for the
    paper text: the tables have no row for them."""
    runs = set(e8_runs(pc))
    return [r for r in e8_runs({**pc, "e8": {**pc["e8"], "skip_n_rev": None}}) if r not in runs]


def existence_from_ot(pc: dict) -> dict[str, dict]:
    """{case: the options of ``spaceopt.indirect.tmin_from_ot.FromOtOptions``} for the cases of
    ``perturbed.existence.from_ot``, whose check starts from their OT solution."""
    from_ot = dict((pc.get("existence") or {}).get("from_ot") or {})
    cases = from_ot.pop("cases", [])
    return {c: from_ot for c in cases}


def existence_bound_from(pc: dict) -> dict[tuple[str, str], str]:
    """{(case, model): the model whose upper bound the check of ``model`` carries over}
    (``perturbed.existence.bound_from``, ``spaceopt.indirect.tmin_from_ot.bound_in_model``).
    Cases that are not run are left out. Checked: the case is a from_ot case, and both are
    perturbed models of its check, not the same."""
    out = {}
    from_ot, runs = existence_from_ot(pc), existence_runs(pc)
    for c, pairs in ((pc.get("existence") or {}).get("bound_from") or {}).items():
        key = f"perturbed.existence.bound_from.{c}"
        if c not in from_ot:
            raise ConfigError(key, pairs, "not a case of perturbed.existence.from_ot")
        if c not in pc["run"]:
            continue
        models = [m for cc, m in runs if cc == c and m != "unperturbed"]
        for model, source in pairs.items():
            for m in (model, source):
                if m not in models:
                    raise ConfigError(f"{key}.{model}", m, f"not a perturbed model of the check (expected one of "
                                                           f"{', '.join(models)})")
            if model == source:
                raise ConfigError(f"{key}.{model}", source, "a model cannot carry over its own bound")
            out[(c, model)] = source
    return out


def existence_runs(pc: dict) -> list[tuple[str, str]]:
    """(case, model) of the minimum-thrust existence check (``perturbed.existence``): each listed
    case that is run, unperturbed first and then the case's models, less those ``skip`` names.
    Checked: the skipped models are models of the check, the from_ot cases are listed cases."""
    ex = pc.get("existence") or {}
    cases = [c for c in ex.get("cases", []) if c in pc["run"]]
    for c in existence_from_ot(pc):
        if c not in ex.get("cases", []):
            raise ConfigError("perturbed.existence.from_ot.cases", c, "not a case of perturbed.existence.cases")
    runs = {c: list(dict.fromkeys(["unperturbed", *pc["cases"][c]["models"]])) for c in cases}
    skip = ex.get("skip") or {}
    for c, models in skip.items():
        for m in models:
            if c in runs and m not in runs[c]:
                raise ConfigError(f"perturbed.existence.skip.{c}", m,
                                  f"not a model of the check (expected one of {', '.join(runs[c])})")
    return [(c, m) for c in cases for m in runs[c] if m not in skip.get(c, [])]


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
