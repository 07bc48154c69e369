"""A case's minimum-fuel family followed down in the thrust: what a weaker engine costs, and an
upper bound on T_min (not in the dissertation; docs/perturbed-e6-e7-e8.md, sixty-third and sixty-fourth
sessions).

Each converged OT extremal of the smoothed problem (3.3.2) at thrust T and smoothing ε is a
transfer over the case's fixed angular range with the throttle δ(S, ε) ∈ [0, 1], i.e. a thrust
δT ≤ T all along. So T_min ≤ T at every thrust the family reaches, at any ε: this bound needs no
minimum-thrust extremal. E7's minimum-thrust paths all fold (spec 01-methods §3.4's (3.4.1) homotopy
from the LP, and the T_min → OT homotopy of ``spaceopt.indirect.tmin_from_ot`` near its start), so
their bounds (``spaceopt.studies.existence``) stay loose; the family can go below them (E7
unperturbed and J2: 0.30 N against 0.3091 and 0.3110 N; the full model's stops at 0.8 N).

The family starts from the case's OT solution under one force model (the DAG's artifact at ε_f),
moves it to the family's ε (``chain.smoothing_to``; E7 at ε_f stops at 0.911 N, where its
bang-bang structure changes), and continues it in the thrust through the listed values
(``chain.continue_in_params``, arclength), every other datum fixed. The mass and the time of
flight are free as in the OT problem, so as T falls the transfer takes longer, and (E7) buys
its revolutions with ever higher apogees. The family stops at the first listed thrust it does not
reach (a fold, a step-size underflow, the step limit ``max_steps``): the least thrust reached is
the bound. Per point: m_f, the propellant, Δt, the largest osculating apogee radius and
eccentricity, the least radius reached, and the duty (propellant over T·Δt/c: 1 for an engine on
all the time), from the physical samples (``studies.trajectory.sample``).

A family may also start from another model's family (``carry_from``, :func:`carry_points`):
each of that family's points at its ε is carried to this model at its thrust by the force-model
blend, independently of the others, and the least-thrust one reached is followed on down through
the listed thrusts below it. This is how a model whose Hamiltonian depends on t is followed in
the thrust. E7's full model (tesseral terms, Moon, Sun): φ = p_t(K_f) wiggles by 3–5e-6 within
0.2 d of t_f, so its free-time extremals come and go in pairs as T changes, and its own family
from 1 N stops past such a fold near 0.728 N (the path, whose tolerance is 60 times the φ it
should hold at zero, walks on through points that are no extremals until no step contracts;
docs/perturbed-e6-e7-e8.md, sixty-fifth session). Each J2 point carried lands on a free-time
extremal of the full model near the J2 point's t_f (scratch: 14–15 Jacobians at 0.8 and 0.6 N,
146 at 0.30 N), where a time-independent model's family (J2, unperturbed: p_t ≡ 0) runs on one
branch.

With ``hops`` a family whose step in the thrust fails goes on by branch hops (:func:`hop`): the
last point moved to a thrust a little lower on the **fixed-time** map, t_f moved along the
secant of the family's last two points in (T, t_f) (that map has no row p_t(K_f) = 0, so no
fold where a pair of its roots merges), then the free-time end game there
(``spaceopt.indirect.free_time``) to the nearest crossing of φ = p_t(K_f) from − to + in t_f:
a free-time extremal of the new thrust, on whatever branch is nearest. The hops shrink where
one fails (halved down to ``min_step_N``) and grow again after each success (doubled up to
``step_N``); every point reached by a hop is a point of the family (``hop`` true). At ε > 0 the
envelope relation dm_f/dt_f = −m₀φ holds only to O(ε) (``free_time.MaximumSearch.branch_jump``),
so the end game's checks of m_f against φ are off there, and "nearest maximum" means a crossing of φ
from − to +, the free-time condition's, not a certified maximum of the smoothed problem's cost
(there is none: docs/perturbed-e6-e7-e8.md, "thirty-fifth session"). Measured on E7's full model
(sixty-ninth session): from the own family's 0.8 N point ten hops of 0.02 N pass the fold near
0.728 N and reach 0.6 N, where they land on the point carried from J2 (841.223 kg, 91.034 d);
with ``first_step`` 1.2 (seventieth session) the same points in 194 Jacobians instead of 337, and on
to 0.45 N (the carried point again; at 0.5 N another extremal than the carried one, 0.50 d shorter).
From the carried 0.45 N point (seventy-second session) to 0.3225 N, where the secant's t_f fell
short and the fixed-time paths ran off (hence the run-off test and the retry with a longer t_f,
which reached 0.32 N); with the retry's t_f first and its end game's doubling march (seventy-third
session) from the carried 0.32 N point to 0.31 N, onto the carried extremal; with the paths given
up where they run off (``runoff_slope``, seventy-fourth session) in place of step caps, on to
0.305 and 0.30 N (a neighbour of the carried extremal, 0.45 d shorter).
"""
from __future__ import annotations

import dataclasses
import sys
import time
from typing import TYPE_CHECKING, Callable

import numpy as np

from ..errors import ConfigError, ConvergenceError

if TYPE_CHECKING:
    from ..indirect.chain import Solution
    from ..indirect.transfer import Transfer

COLUMNS = ("case", "model", "start", "thrust_N", "eps", "m_f_kg", "propellant_kg", "tof_days", "max_apogee_km", "max_e",
           "least_radius_km", "duty", "steps", "jacobians", "wall_s", "hop")
HOP_DEFAULTS = {"step_N": 0.02, "min_step_N": 0.0025, "probe_days": 0.1, "max_march_days": 1.6, "max_points": 24,
                "first_step": 1.2, "runoff_slope": 0.01, "runoff_steps": 10, "max_path_steps": 400}
HOP_END_GAME = "hop end game"       # the diagnosis reason of a hop whose end game finds no crossing


def settings(pc: dict) -> dict[str, dict]:
    """{case: {thrusts_N, eps, models, max_steps, carry_from, hops}} of ``perturbed.thrust_family``
    for the cases that are run (eps default 1e-2, models default the case's first, carry_from
    default none, hops default off; the Snakefile plans with it). ConfigError naming the key
    where a case is unknown, the thrusts do not fall strictly from below the case's thrust to
    above 0, ε is not in (0, 1), a model is not one of the case's, max_steps is not a positive
    integer, carry_from is not a mapping {model of the case: another model of the family}, or
    hops is not as :func:`hop_settings` reads it."""
    from .multirev_config import number, positive_integer      # (loads JAX: not at import, for the report jobs)
    out = {}
    for case, s in (pc.get("thrust_family") or {}).items():
        key = f"perturbed.thrust_family.{case}"
        if case not in pc["cases"]:
            raise ConfigError(key, case, f"not a case (expected one of {', '.join(pc['cases'])})")
        if not isinstance(s, dict):
            raise ConfigError(key, s, "must be a mapping with thrusts_N (and eps, models, max_steps)")
        if case not in pc["run"]:
            continue
        thrust = float(pc["cases"][case]["thrust_N"])
        listed = s.get("thrusts_N")
        if not isinstance(listed, list) or not listed:
            raise ConfigError(f"{key}.thrusts_N", listed, "must be a list of thrusts in N")
        thrusts = [number({"thrusts_N": t}, "thrusts_N", key) for t in listed]
        if not all(0 < b < a for a, b in zip([thrust, *thrusts], thrusts)):
            raise ConfigError(f"{key}.thrusts_N", listed,
                              f"must fall strictly from below the case's thrust ({thrust:g} N) to above 0")
        eps = number({"eps": s.get("eps", 1e-2)}, "eps", key)
        if not 0 < eps < 1:
            raise ConfigError(f"{key}.eps", s.get("eps"), "the smoothing must lie in (0, 1)")
        known = pc["cases"][case]["models"]
        models = s.get("models", known[:1])
        for m in models if isinstance(models, list) else [models]:
            if not isinstance(models, list) or m not in known:
                raise ConfigError(f"{key}.models", m, f"not a list of the case's models ({', '.join(known)})")
        max_steps = positive_integer(s.get("max_steps", 2000), f"{key}.max_steps")
        carry = s.get("carry_from") or {}
        if not isinstance(carry, dict):
            raise ConfigError(f"{key}.carry_from", carry, "must be a mapping {model: the model whose family it starts from}")
        for m, seed in carry.items():
            if m not in known:
                raise ConfigError(f"{key}.carry_from", m, f"not one of the case's models ({', '.join(known)})")
            if seed not in models or seed == m:
                raise ConfigError(f"{key}.carry_from.{m}", seed, "must be another of the family's models")
        out[case] = {"thrusts_N": thrusts, "eps": eps, "models": list(models), "max_steps": max_steps,
                     "carry_from": dict(carry), "hops": hop_settings(s.get("hops"), f"{key}.hops")}
    return out


def hop_settings(hops, key: str) -> dict | None:
    """``hops`` ({step_N, min_step_N, probe_days, max_march_days, max_points, first_step,
    runoff_slope, runoff_steps, max_path_steps}, each defaulting to :data:`HOP_DEFAULTS`; null:
    off) checked: ConfigError naming the key where it is no mapping, has another key, a step,
    probe, first step or run-off slope is not positive, min_step_N exceeds step_N, max_march_days
    is less than probe_days, or max_points, runoff_steps or max_path_steps is not a positive integer."""
    from .multirev_config import number, positive_integer
    if hops is None:
        return None
    if not isinstance(hops, dict):
        raise ConfigError(key, hops, f"must be a mapping of {', '.join(HOP_DEFAULTS)} (or null: off)")
    unknown = sorted(set(hops) - set(HOP_DEFAULTS))
    if unknown:
        raise ConfigError(f"{key}.{unknown[0]}", hops[unknown[0]], f"not a hop setting (expected {', '.join(HOP_DEFAULTS)})")
    out = {**HOP_DEFAULTS, **hops}
    for k in ("step_N", "min_step_N", "probe_days", "max_march_days", "first_step", "runoff_slope"):
        out[k] = number(out, k, key, positive=True)
    if out["min_step_N"] > out["step_N"]:
        raise ConfigError(f"{key}.min_step_N", out["min_step_N"], f"must not exceed step_N ({out['step_N']:g})")
    if out["max_march_days"] < out["probe_days"]:
        raise ConfigError(f"{key}.max_march_days", out["max_march_days"],
                          f"must not be less than probe_days ({out['probe_days']:g})")
    for k in ("max_points", "runoff_steps", "max_path_steps"):
        positive_integer(out[k], f"{key}.{k}")
    return out


def at_thrust(sol: Solution, thrust_N: float, eps: float) -> Solution:
    """``sol`` relabelled as the solution of its transfer at ``thrust_N`` and ε = ``eps`` (its
    transfer then saves and loads as that problem, ``studies.multirev.load``)."""
    tr = dataclasses.replace(sol.transfer, thrust=thrust_N, eps_final=eps)
    return dataclasses.replace(sol, transfer=tr, thrust_N=thrust_N, prm={**sol.prm, **tr.params(thrust=thrust_N)})


def describe(sol: Solution, samples_per_rev: int = 400) -> dict:
    """m_f, propellant, Δt, the largest apogee radius and eccentricity, the least radius and the
    duty of the OT solution ``sol`` (its thrust: ``sol.thrust_N``), from its physical samples."""
    from .trajectory import sample
    s, tr = sample(sol, samples_per_rev), sol.transfer
    apogee_km = np.where(s["e"] < 1, s["a_m"] * (1 + s["e"]), np.inf) / 1e3
    m_f, tof_s = float(s["mass_kg"][-1]), float(s["t_s"][-1])
    return {"m_f_kg": m_f, "propellant_kg": tr.m0 - m_f, "tof_days": tof_s / 86400,
            "max_apogee_km": float(apogee_km.max()), "max_e": float(s["e"].max()),
            "least_radius_km": float(np.linalg.norm(s["r_m"], axis=1).min() / 1e3),
            "duty": (tr.m0 - m_f) / (sol.thrust_N * tof_s / tr.c)}


def point(sol: Solution, stats: dict, wall_s: float) -> dict:
    """One point of a family: the thrust, ε, :func:`describe`, the cost of the path to it, whether
    a hop reached it (and the hop's end game, ``stats['end_game']``), and the unknowns ``z`` (so
    that another model's family can start from it, :func:`seeds`)."""
    end_game = stats.get("end_game")
    return {"thrust_N": sol.thrust_N, "eps": float(sol.prm["eps_final"]), **describe(sol),
            "steps": stats.get("steps", 0), "jacobians": stats.get("jacobian_evaluations", 0), "wall_s": wall_s,
            "hop": end_game is not None, **({"end_game": end_game} if end_game is not None else {}),
            "z": [float(v) for v in sol.z]}


def seeds(last: Solution, points: list, eps: float) -> list[Solution]:
    """A family's points at ε = ``eps`` as solutions, by falling thrust: its artifact's solution
    ``last`` (the least-thrust point) with each point's unknowns, relabelled at the point's
    thrust (:func:`at_thrust`)."""
    at_eps = [p for p in points if np.isclose(p["eps"], eps, rtol=1e-12, atol=0)]
    return [at_thrust(dataclasses.replace(last, z=np.asarray(p["z"], float)), p["thrust_N"], eps)
            for p in sorted(at_eps, key=lambda p: -p["thrust_N"])]


def carry(seed: Solution, tr: Transfer, options, label: str) -> Solution:
    """The family point ``seed`` (another force model's OT solution, at its thrust and ε) carried
    to the force model of ``tr`` at the same thrust and ε: the model blend followed in arclength
    (``studies.perturbed.warm_start``; from an unperturbed point, the perturbations switched on).
    ConvergenceError where it does not arrive."""
    from .perturbed import warm_start
    T, eps = seed.thrust_N, float(seed.prm["eps_final"])
    tr = dataclasses.replace(tr, thrust=T, eps_final=eps)
    return at_thrust(warm_start(seed, tr, label, options=options, model_path="arclength"), T, eps)


def carry_points(seed_points: list[Solution], tr: Transfer, options, label: str, points: list | None = None,
                 not_carried: dict | None = None, on_point: Callable[[Solution, list, dict], None] | None = None
                 ) -> tuple[Solution | None, list, dict]:
    """Each of ``seed_points`` (another model's family, :func:`seeds`, by falling thrust) carried to
    the model of ``tr`` (:func:`carry`): (the least-thrust solution reached, or None where none
    arrived, the points, {thrust: why} of the seeds not carried).

    ``points`` and ``not_carried``: those of an interrupted run (its checkpoint); a seed whose
    thrust is in either is not tried again. After each seed, the solution reached last (None
    where none has arrived yet), the points and the failures go to ``on_point`` (a checkpoint)."""
    points, not_carried = list(points or []), dict(not_carried or {})
    done = {p["thrust_N"] for p in points} | {float(T) for T in not_carried}
    last = None
    for s in seed_points:
        if s.thrust_N in done:
            continue
        t0 = time.perf_counter()
        try:
            last = carry(s, tr, options, f"{label} {s.thrust_N:g} N")
            points.append(point(last, last.stats, time.perf_counter() - t0))
        except ConvergenceError as exc:
            not_carried[f"{s.thrust_N:g}"] = str(exc)
        if on_point:
            on_point(last, points, not_carried)
    return last, points, not_carried


def hop(sol: Solution, thrust_N: float, tof_days: float, options, hops: dict, label: str,
        tof_first: bool = False) -> Solution:
    """The family point ``sol`` (a free-time OT solution at its thrust and ε) hopped to
    ``thrust_N``: moved there on the fixed-time map (t(K_f) = t_f in place of p_t(K_f) = 0),
    t_f moved linearly with T from the point's own to ``tof_days`` (with ``tof_first``, for a
    t_f chosen long: t_f alone first, at the point's thrust, then T at that t_f), in arclength
    from a first step of ``first_step`` (``chain.continue_in_params``). Each leg is given up
    where it runs off, ``runoff_steps`` steps in a row with |dτ/ds| < ``runoff_slope``
    (``ArclengthOptions``: where the predicted t_f is too short for the thrust the path runs off
    in z at a τ short of 1, dτ/ds → 0, with steps that each pass the corrector: E7 full model,
    seventy-second session, 400 steps and 30 min before the follower's own cap, where an
    arriving path takes 1–9), or after ``max_path_steps`` steps (slow legs that arrive take
    many: E7, the path 0.305 → 0.30 N 260 steps, 34 min, seventy-fourth session); then
    the free-time end game at ``thrust_N`` from there (``free_time.maximise_final_mass``: probes
    ``probe_days`` apart, the march in t_f by such steps (with ``tof_first`` doubling up to
    ``max_march_days``: the start may lie days above the crossing), Brent; at most
    ``max_points`` fixed-time solves; no survey, no lift, the checks of m_f against φ off, as
    the family's ε is > 0), to the nearest crossing of φ from − to + (with ``tof_first`` the
    first one the march meets: a longer step may pass a pair). The fixed-time extremal
    there, relabelled at ``thrust_N``; its stats hold the path's steps, the Jacobians of both
    parts and the end game's record (``end_game``: where it started and ended, its solves).
    ConvergenceError where the path does not arrive or the end game finds no crossing."""
    from ..constants import DAY
    from ..indirect import chain
    from ..indirect.free_time import MaximumOptions, maximise_final_mass
    from ..indirect.transfer import datum
    eps, tu = float(sol.prm["eps_final"]), sol.transfer.tu
    fixed = dataclasses.replace(sol, shooting=dataclasses.replace(sol.shooting, fixed_time=True),
                                prm={**sol.prm, "tf": datum(tof_of(sol) * DAY / tu)})
    target = {**at_thrust(sol, thrust_N, eps).prm, "tf": datum(tof_days * DAY / tu)}
    follower = dataclasses.replace(chain.path_options("arclength", options, f"{label} fixed time"),
                                   h_init=hops["first_step"], max_steps=hops["max_path_steps"],
                                   runoff_slope=hops["runoff_slope"], runoff_steps=hops["runoff_steps"])
    legs = [{**fixed.prm, "tf": target["tf"]}] if tof_first else []
    moved, steps, jacobians = fixed, 0, 0
    for leg in [*legs, target]:
        moved = chain.continue_in_params(moved, leg, follower, label=f"{label} fixed time", path="arclength")
        steps += moved.stats.get("steps", 0)
        jacobians += moved.stats.get("jacobian_evaluations", 0)
    free = dataclasses.replace(at_thrust(sol, thrust_N, eps), z=moved.z)
    out, record = maximise_final_mass(free, MaximumOptions(
        probe_days=hops["probe_days"], max_points=hops["max_points"],
        max_march_days=hops["max_march_days"] if tof_first else 0.0,
        lift_eps=0.0, jump_tol=np.inf, hidden_tol=np.inf, verbose=_verbose(options), label=f"{label} end game"))
    if not record["certified"]:
        raise ConvergenceError(f"{label}: no crossing of p_t(K_f) from - to + in t_f at {thrust_N:g} N "
                               f"({record['status']})", {"reason": HOP_END_GAME, "end_game": record})
    end_game = {k: record[k] for k in ("t0_days", "tof_days", "phi", "fixed_time_solves", "jacobian_evaluations",
                                       "wall_time_s")}
    stats = {"steps": steps, "end_game": end_game, "jacobian_evaluations": jacobians + record["jacobian_evaluations"]}
    return dataclasses.replace(at_thrust(out, thrust_N, eps), stats=stats)


def tof_of(sol: Solution) -> float:
    """t(K_f) of the solution ``sol``, in days."""
    import jax.numpy as jnp

    from ..constants import DAY
    from ..indirect import hamiltonians as hm
    from ..indirect.shooting import final_state
    yf, ok = final_state(sol.shooting, jnp.asarray(sol.z), sol.tau, sol.prm)
    if not bool(ok):
        raise ConvergenceError("the propagation of a family point failed", {"reason": "propagation"})
    return float(yf[hm.TIME]) * sol.transfer.tu / DAY


def predicted_tof(points: list, thrust_N: float, eps: float) -> float:
    """Δt at ``thrust_N`` on the secant in (T, Δt) through the family's last two points at ε
    (the last point's Δt where it has one only)."""
    at_eps = [p for p in points if np.isclose(p["eps"], eps, rtol=1e-12, atol=0)]
    if len(at_eps) < 2 or at_eps[-1]["thrust_N"] == at_eps[-2]["thrust_N"]:
        return at_eps[-1]["tof_days"]
    a, b = at_eps[-2], at_eps[-1]
    slope = (b["tof_days"] - a["tof_days"]) / (b["thrust_N"] - a["thrust_N"])
    return b["tof_days"] + slope * (thrust_N - b["thrust_N"])


def follow(sol: Solution, thrusts_N: list, eps: float, options, label: str, points: list | None = None,
           on_point: Callable[[Solution, list], None] | None = None, hops: dict | None = None
           ) -> tuple[Solution, list, str]:
    """The family of the OT solution ``sol`` down through ``thrusts_N`` at ε = ``eps``: (its last
    solution, the points, the reason it stopped: '' where it reached the last thrust).

    ``points``: those of an interrupted run that reached ``sol`` (its checkpoint); None for a new
    family, whose first point is ``sol`` itself at its own ε, and whose second is ``sol`` moved
    to ``eps`` where that differs. Each point (:func:`describe` plus the thrust, ε and the cost
    of its path) is appended as it is reached, and the solution and all the points go to
    ``on_point`` (a checkpoint). A step that does not arrive (``ConvergenceError``, also the move
    in ε) is the stop, not raised: the least thrust reached stays the bound. With ``hops``
    (:func:`hop_settings`) a step in the thrust that does not arrive hands over to branch hops
    (:func:`hop_down`), which go on through the remaining thrusts; a family resumed at a point
    that a hop reached goes on by hops."""
    from ..indirect import chain
    points = list(points or [])

    def reached(s: Solution, stats: dict, wall_s: float) -> None:
        points.append(point(s, stats, wall_s))
        if on_point:
            on_point(s, points)

    if not points:
        sol = at_thrust(sol, sol.thrust_N, float(sol.prm["eps_final"]))
        reached(sol, {}, 0.0)
    if not np.isclose(float(sol.prm["eps_final"]), eps, rtol=1e-12, atol=0):
        t0 = time.perf_counter()
        try:
            moved = chain.smoothing_to(sol, eps, options, label=f"{label}/eps {eps:g}")
        except ConvergenceError as exc:
            return sol, points, f"eps {eps:g} not reached: {exc}"
        sol = at_thrust(moved, sol.thrust_N, eps)
        reached(sol, moved.stats, time.perf_counter() - t0)
    hopping = hops is not None and points[-1].get("hop", False)
    for T in thrusts_N:
        if not hopping:
            t0 = time.perf_counter()
            try:
                moved = chain.continue_in_params(sol, at_thrust(sol, T, eps).prm, options, label=f"{label}/T {T:g} N",
                                                 path="arclength")
            except ConvergenceError as exc:
                if hops is None:
                    return sol, points, f"T {T:g} N not reached: {exc}"
                hopping = True
                _log(options, f"[{label}] T {T:g} N not reached ({exc}); on by hops from {sol.thrust_N:g} N")
            else:
                sol = at_thrust(moved, T, eps)
                reached(sol, moved.stats, time.perf_counter() - t0)
                continue
        sol, stop = hop_down(sol, T, eps, options, hops, label, points, reached)
        if stop:
            return sol, points, stop
    return sol, points, ""


def hop_down(sol: Solution, thrust_N: float, eps: float, options, hops: dict, label: str, points: list,
             reached: Callable[[Solution, dict, float], None]) -> tuple[Solution, str]:
    """From the family point ``sol`` down to ``thrust_N`` by :func:`hop`, each to at most
    ``step_N`` below the last point, its t_f predicted by :func:`predicted_tof`. A hop whose
    fixed-time path fails is retried once at the same thrust with t_f moved twice as far from the
    point's own, t_f first (``tof_first``): the secant falls short where Δt(T) steepens, and a
    fixed-time problem whose t_f is shorter than the least time at the thrust has no solution
    (the path runs off), while a longer one has (the engine coasts; the end game marches back
    down, its steps growing to ``max_march_days``). A hop that fails again,
    or in its end game, is retried from the same point at half the step it tried (not of
    ``step_N``: a hop cut short by ``thrust_N`` would otherwise be retried unchanged), down to
    ``min_step_N``, and after each that arrives the step doubles again (up to ``step_N``). Each
    point reached goes to ``reached``: (the last solution, '' or why ``thrust_N`` was not
    reached)."""
    h, longer = hops["step_N"], False
    while sol.thrust_N > thrust_N * (1 + 1e-12):
        T = max(thrust_N, round(sol.thrust_N - h, 12))
        tof = predicted_tof(points, T, eps)
        if longer:
            tof += tof - tof_of(sol)
        t0 = time.perf_counter()
        try:
            moved = hop(sol, T, tof, options, hops, f"{label}/hop {T:g} N", tof_first=longer)
        except ConvergenceError as exc:
            if not longer and exc.diagnosis.get("reason") != HOP_END_GAME:
                longer = True
                _log(options, f"[{label}] the hop to {T:g} N failed on its path ({exc}); again with a longer t_f")
                continue
            longer = False
            h = (sol.thrust_N - T) / 2          # half the step tried (which the target may have cut short)
            if h < hops["min_step_N"] * (1 - 1e-12):
                return sol, (f"T {thrust_N:g} N not reached: the hop to {T:g} N failed with steps down to "
                             f"{2 * h:g} N: {exc}")
            _log(options, f"[{label}] the hop to {T:g} N failed ({exc}); again at a step of {h:g} N")
            continue
        sol, longer = moved, False
        reached(sol, moved.stats, time.perf_counter() - t0)
        h = min(2.0 * h, hops["step_N"])
    return sol, ""


def _verbose(options) -> bool:
    """Whether the paths log: ``options.verbose``, or True without options (their default)."""
    return options is None or options.verbose


def _log(options, msg: str) -> None:
    if _verbose(options):
        print(msg, file=sys.stderr, flush=True)


def rows(case: str, payload: dict) -> list[dict]:
    """The table's rows of one family artifact (its ``extra['family']``: the force model, the
    start, 'ot' or 'family_<model>' for a carried family, and the points)."""
    fam = payload["extra"]["family"]
    return [{"case": case, "model": fam["model"], "start": fam["start"], **{k: p[k] for k in COLUMNS[3:-1]},
             "hop": p.get("hop", False)} for p in fam["points"]]


def sentence(rows: list, stops: dict, model_names: dict, checked: dict | None = None) -> str:
    """LaTeX for the paper: per case and family (model and start) the least thrust reached (an
    upper bound on T_min), its m_f, Δt and largest apogee there, whether it stopped short
    (``stops``: (case, model, start) → reason, '' where it reached its last thrust), from which
    thrust on and by how many branch hops it went on where hops reached points (``hop``), and the
    existence check's T_min or bound beside it (``checked``: (case, model) → the
    ``existence.csv`` row). '' without rows."""
    parts = []
    for case in dict.fromkeys(r["case"] for r in rows):
        items = []
        for model, start in dict.fromkeys((r["model"], r["start"]) for r in rows if r["case"] == case):
            rs = [r for r in rows if (r["case"], r["model"], r["start"]) == (case, model, start)]
            last = min(rs, key=lambda r: float(r["thrust_N"]))
            apogee = f"{float(last['max_apogee_km']):,.0f}".replace(",", "\\,")
            check = (checked or {}).get((case, model))
            le = "$\\le$ " if check is not None and check["T_min_is"] == "upper bound" else ""
            beside = "" if check is None else f"; the check above: {le}{float(check['T_min_N']):.4g}~N"
            name = model_names.get(model, model)
            if start != "ot":
                seed = start.removeprefix("family_")
                name += f" (the {model_names.get(seed, seed)} family's points carried to it)"
            hopped = [str(r.get("hop", False)) == "True" for r in rs]      # a bool, or its text in the csv
            hops, walked = sum(hopped), min(float(r["thrust_N"]) for r, h in zip(rs, hopped) if not h)
            by_hops = f"; below {walked:g}~N by {hops} branch hop{'s' * (hops > 1)}" if hops else ""
            items.append(f"{name} $T_{{min}} \\le$ {float(last['thrust_N']):g}~N "
                         f"($m_f$ {float(last['m_f_kg']):.1f}~kg, $\\Delta t$ {float(last['tof_days']):.1f}~d, "
                         f"apogee up to {apogee}~km; "
                         + ("the next thrust was not reached" if stops.get((case, model, start)) else "the last listed thrust")
                         + by_hops + beside + ")")
        eps = float(min((r for r in rows if r["case"] == case), key=lambda r: float(r["thrust_N"]))["eps"])
        parts.append(f"{case.upper()}: " + "; ".join(items)
                     + f" (the minimum-fuel family at $\\varepsilon = {eps:g}$ followed down in the thrust: every "
                       "point of it is a transfer whose thrust never exceeds its $T$)")
    return ("Followed down in the thrust, the minimum-fuel family gives upper bounds on $T_{min}$ of its own: "
            + ". ".join(parts) + ".") if parts else ""
