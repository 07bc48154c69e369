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

* E6 date → date and E9 model → model: a Newton homotopy f(z, τ) = (1 − τ) f(z_prev) at the
  *new* problem data (``chain.continue_in_params`` with nothing to move; the epoch and the force
  model are pytree data of ``prm['pert']``, so the new date costs no recompilation);
* E8 n → n: ``chain.continue_in_params`` moving L_f.

The ΔΩ budget of E9 (spec 02-multirev §6) is the secular J2 drift of the osculating initial
orbit, dΩ/dt = −(3/2) n J₂ (R/p)² cos i, dω/dt = (3/4) n J₂ (R/p)² (5 cos² i − 1), compared
with the required ΔΩ, plus a numerical coast with the J2 model of :mod:`spaceopt.forces` (the
osculating Ω difference after the same time).
"""
from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path

import numpy as np

from .. import artifacts, constants
from ..elements import apsides_to_ae
from ..errors import ConfigError
from ..indirect import chain
from ..indirect import hamiltonians as hm
from ..indirect.chain import Solution
from ..indirect.continuation import ContinuationOptions
from ..indirect.flow import Model
from ..indirect.shooting import Shooting
from ..indirect.transfer import Orbit, Transfer
from . import multirev

DAY = 86400.0
ALT_KEYS = ("perigee_alt_km", "apogee_alt_km")
AE_KEYS = ("a_km", "e")
ANGLE_KEYS = ("i_deg", "raan_deg", "argp_deg")
CASE_KEYS = ("initial", "final", "L0_deg", "n_rev", "m0_kg", "isp_s", "thrust_N", "epoch_utc",
             "ephemeris", "models")
OPTIONAL_CASE_KEYS = ("lp_perturbed", "homotopy_path", "blend_ref")


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
    return Transfer(
        orbit_from_config(orbits[cc["initial"]], f"perturbed.orbits.{cc['initial']}", radius),
        orbit_from_config(orbits[cc["final"]], f"perturbed.orbits.{cc['final']}", radius),
        L0_deg=_number(cc, "L0_deg", path),
        n_rev=float(n_rev) if n_rev is not None else _number(cc, "n_rev", path, positive=True),
        m0=_number(cc, "m0_kg", path, positive=True), isp=_number(cc, "isp_s", path, positive=True),
        thrust=_number(cc, "thrust_N", path, positive=True), mu=mu,
        eps_final=_number(num, "eps_final", "perturbed.numerics", positive=True),
        eps_blend=_number(num, "eps_blend", "perturbed.numerics", positive=True),
        perturbations=mcfg or None, epoch_utc=epoch if mcfg else None,
        ephemeris=ephemeris if needs_eph else None)


# ---------------------------------------------------------------- solves

def solve_for(tr: Transfer, label: str, lp_perturbed: bool = False, path: str = "arclength",
              options: ContinuationOptions | None = None, blend_ref: float | None = None) -> tuple[Solution, Solution]:
    """LP from the zero guess → OT (perturbed when ``tr`` is); returns (lp, ot).

    ``path``: 'arclength' follows the LP → OT homotopy in arclength (passes turning points;
    the 5-rev HEO case E5 has one at τ ≈ 0.17 for 0.5 N), 'tau' uses ``chain.solve_ot``.
    ``lp_perturbed``: solve the LP with the perturbations on (see :func:`solve_lp_perturbed`);
    the LP → OT homotopy then starts off its path (its τ = 0 end is the unperturbed LP) and the
    Newton homotopy carries the initial residual.
    """
    if lp_perturbed and tr.perturbed:
        lp = solve_lp_perturbed(tr, options, label=f"{label}/lp")
    else:
        lp = chain.solve_lp(tr, options, label=f"{label}/lp")
    if path == "arclength":
        ot = solve_ot_arclength(lp, tr.thrust, label=f"{label}/ot", blend_ref=blend_ref)
    elif path == "tau" and blend_ref is None:
        ot = chain.solve_ot(lp, tr.thrust, options, label=f"{label}/ot")
    elif path == "tau":
        ot = solve_ot_tau(lp, tr.thrust, blend_ref, options, label=f"{label}/ot")
    else:
        raise ConfigError("perturbed.numerics.homotopy_path", path, "expected 'arclength' or 'tau'")
    return lp, ot


def arclength_run(sh: Shooting | None, z0, prm, label: str, h0: float = 0.02, h_max: float = 0.3,
                  tol_step: float = 1e-4, tol_final: float = 1e-10, max_steps: int = 400,
                  verbose: bool = True, evaluate=None):
    """Follow the Newton homotopy f(z, τ) = (1 − τ) b by pseudo-arclength (passes folds in τ).

    The τ-parametrised corrector of :mod:`spaceopt.indirect.continuation` cannot pass a turning
    point of the path (dτ/ds = 0), where it stalls with a vanishing step. Here u = (z, τ) is
    continued in arclength s: tangent t = null vector of [∂f/∂z, ∂f/∂τ + b], predictor u + h t,
    Newton corrector on (f − (1 − τ) b, t·(u − u_pred)) = 0; the step grows or shrinks with the
    corrector's iterations as in the τ-continuation. At τ ≥ 1 the end point is interpolated and
    polished at τ = 1. (Should move into spaceopt.indirect.continuation; kept here because that
    module belongs to another study.) ``evaluate(z, τ, final) -> (f, ∂f/∂z, ∂f/∂τ, ok)``
    replaces the shooting map (tests use a scalar fold).
    """
    import sys
    import jax.numpy as jnp
    from ..errors import ConvergenceError
    from ..indirect.shooting import shoot

    def ev(z, tau, final=False):
        if evaluate is not None:
            f, J, ft, ok = evaluate(np.asarray(z), float(tau), final)
            return np.atleast_1d(f), np.atleast_2d(J), np.atleast_1d(ft), bool(ok)
        rtol, atol = max(sh.rtol, chain.PATH_RTOL), max(sh.atol, chain.PATH_RTOL * 0.1)
        tol = {} if final else {"rtol": rtol, "atol": atol}
        f, J, ft, nst, ok = shoot(sh, jnp.asarray(z), float(tau), prm, **tol)
        return np.asarray(f), np.asarray(J), np.asarray(ft), bool(ok)

    t_start = time.perf_counter()
    z = np.asarray(z0, float).copy()
    tau = 0.0
    f, J, ft, ok = ev(z, tau)
    if not ok:
        raise ConvergenceError(f"{label}: integration failed at the start", {"z": z.tolist()})
    b = f.copy()
    n = z.size

    def tangent(J, ft, prev=None):
        A = np.hstack([J, (ft + b)[:, None]])
        _, _, vt = np.linalg.svd(A)
        t = vt[-1]
        if prev is not None and np.dot(t, prev) < 0:
            t = -t
        elif prev is None and t[-1] < 0:
            t = -t
        return t

    t = tangent(J, ft)
    h, steps, jac, rejected = h0, 0, 1, 0
    history = []
    while steps + rejected < max_steps:
        u = np.concatenate([z, [tau]])
        up = u + h * t
        uc, accepted, it, prevn = up.copy(), False, 0, None
        for it in range(1, 5):
            fc, Jc, ftc, okc = ev(uc[:n], uc[n])
            jac += 1
            if not okc or not np.all(np.isfinite(fc)):
                break
            F = fc - (1.0 - uc[n]) * b
            nF = float(np.max(np.abs(F)))
            if nF <= tol_step:
                accepted = True
                break
            if prevn is not None and nF > 0.5 * prevn:
                break
            prevn = nF
            M = np.vstack([np.hstack([Jc, (ftc + b)[:, None]]), t[None, :]])
            rhs = -np.concatenate([F, [np.dot(t, uc - up)]])
            uc = uc + np.linalg.lstsq(M, rhs, rcond=None)[0]
        if accepted:
            t_new = tangent(Jc, ftc, t)
            if uc[n] >= 1.0:                       # crossed τ = 1: interpolate, then polish
                lam = (1.0 - u[n]) / (uc[n] - u[n])
                z = u[:n] + lam * (uc[:n] - u[:n])
                tau = 1.0
                steps += 1
                break
            z, tau, t = uc[:n], uc[n], t_new
            steps += 1
            history.append((tau, h, it))
            if verbose:
                print(f"[{label}] s-step {steps}: tau={tau:.6f} h={h:.3g} corr={it} |F|={nF:.2e} "
                      f"dtau/ds={t[-1]:+.3f}", file=sys.stderr, flush=True)
            h = min(h_max, h * {1: 2.0, 2: 1.5, 3: 1.2}.get(it, 0.8))
        else:
            rejected += 1
            h *= 0.3
            if verbose:
                print(f"[{label}]   rejected at tau={tau:.6f}, h -> {h:.3g}", file=sys.stderr, flush=True)
            if h < 1e-9:
                raise ConvergenceError(f"{label}: arclength continuation failed at tau={tau:.6g} (step underflow)",
                                       {"reason": "step underflow", "tau": tau, "z": z.tolist(),
                                        "history": history[-20:]})
    else:
        raise ConvergenceError(f"{label}: too many arclength steps", {"tau": tau, "z": z.tolist()})
    # polish at τ = 1
    f, J, ft, ok = ev(z, 1.0, final=True)
    jac += 1
    nF = float(np.max(np.abs(f)))
    for _ in range(12):
        if nF <= tol_final:
            break
        zn = z + np.linalg.lstsq(J, -f, rcond=None)[0]
        fn, Jn, ftn, okn = ev(zn, 1.0, final=True)
        jac += 1
        if not okn or float(np.max(np.abs(fn))) > 2 * nF:
            break
        z, f, J, nF = zn, fn, Jn, float(np.max(np.abs(fn)))
    if nF > tol_final * 1e3:
        raise ConvergenceError(f"{label}: final Newton polish did not converge (|F|={nF:.2e})",
                               {"reason": "polish", "residual": nF, "z": z.tolist()})
    stats = {"steps": steps, "rejected_steps": rejected, "jacobian_evaluations": jac,
             "final_residual": nF, "wall_time_s": time.perf_counter() - t_start, "path": "arclength"}
    if verbose:
        print(f"[{label}] done (arclength): |F|={nF:.2e} steps={steps} jac={jac}", file=sys.stderr, flush=True)
    return z, stats


def solve_ot_tau(lp: Solution, thrust_N: float, blend_ref: float, options=None, label="ot") -> Solution:
    """``chain.solve_ot`` with a given blend weight reference W_ref (1 = the printed (3.3.1)
    weights). E5 (5-rev HEO, 0.5 N): with W_ref = the mean LP primer the τ-path turns back at
    τ ≈ 0.172 (a fold; 1 N: τ ≈ 0.079); with W_ref = 1 it runs to τ ≈ 0.972 and stalls there
    (step 3e-6 after 77 Jacobians): also a fold, so E5 needs the arclength path."""
    import jax.numpy as jnp
    tr = lp.transfer
    prm = {**tr.params(thrust=thrust_N), "blend_ref": jnp.asarray(blend_ref)}
    sh = chain.shooting_for("ot", "lp", tr)
    z, st = chain._run(sh, chain.start_vector(sh, lp.doubled_costates(), lp.K_f), prm, label + " LP->OT", options)
    sh_eps = chain.shooting_for("ot", "eps", tr)
    stats = {"lp_to_ot": st, "blend_ref": blend_ref}
    if tr.eps_blend > tr.eps_final:
        z, st_eps = chain._run(sh_eps, z, prm, label + " eps", options)
        stats["eps"] = st_eps
        stats["jacobian_evaluations"] = st["jacobian_evaluations"] + st_eps["jacobian_evaluations"]
        stats["final_residual"] = st_eps["final_residual"]
    return Solution("ot", sh_eps, z, tr.params(thrust=thrust_N), tr, stats, thrust_N=thrust_N)


def solve_ot_arclength(lp: Solution, thrust_N: float, label="ot", blend_ref: float | None = None) -> Solution:
    """LP → OT (3.3.1) followed by pseudo-arclength, then the ε stage (τ-continuation)."""
    import jax.numpy as jnp
    tr = lp.transfer
    bref = chain.blend_reference(lp) if blend_ref is None else blend_ref
    prm = {**tr.params(thrust=thrust_N), "blend_ref": jnp.asarray(bref)}
    sh = chain.shooting_for("ot", "lp", tr)
    z, st = arclength_run(sh, chain.start_vector(sh, lp.doubled_costates(), lp.K_f), prm, label + " LP->OT")
    sh_eps = chain.shooting_for("ot", "eps", tr)
    stats = {"lp_to_ot": st}
    if tr.eps_blend > tr.eps_final:
        z, st_eps = chain._run(sh_eps, z, prm, label + " eps", None)
        stats["eps"] = st_eps
        stats["jacobian_evaluations"] = st["jacobian_evaluations"] + st_eps["jacobian_evaluations"]
        stats["final_residual"] = st_eps["final_residual"]
    return Solution("ot", sh_eps, z, tr.params(thrust=thrust_N), tr, stats, thrust_N=thrust_N)


def lp_shooting(perturbed: bool) -> Shooting:
    """LP layout; the perturbed LP adds p_t to the unknowns (and p_t(K_f) = 0)."""
    if not perturbed:
        return chain.LP_SHOOTING
    return Shooting(Model("lp", "lp", True), chain.ORBIT_COSTATES + (hm.TIME,))


def solve_lp_perturbed(tr: Transfer, options=None, label="lp") -> Solution:
    """Minimum-power solve *with* the perturbations, from the zero guess (K_f = ΔL).

    Used where the transfer only exists thanks to a perturbation (E9: the node is moved by the
    J2 precession, spec 02-multirev §6): the zero guess is then the perturbed coast, which
    already drifts the node by almost the required ΔΩ, whereas the unperturbed LP must buy the
    whole plane change with thrust (~1 km/s, beyond what 1 N delivers in 5 d).
    """
    sh = lp_shooting(tr.perturbed)
    prm = tr.params()
    z0 = np.zeros(sh.size)
    z0[sh.kf_index] = tr.delta_L
    z, stats = chain._run(sh, z0, prm, label, options)
    sol = Solution("lp", sh, z, prm, tr, stats)
    sol.extra.update(lp_integrals(sol))
    return sol


def lp_integrals(sol: Solution) -> dict:
    """J_LP, ΔV and Δt (SI) along an LP solution, with the field the solution was solved with."""
    import diffrax
    import jax.numpy as jnp
    from ..indirect.flow import field as flow_field
    from ..indirect.shooting import initial_state

    tr = sol.transfer
    model = sol.shooting.model
    n = model.n
    y0 = initial_state(sol.shooting, jnp.asarray(sol.z), sol.prm)

    def rhs(K, Y, args):
        y = Y[:-2]
        g = hm.geometry(K, y[:n])
        A = hm.primer(y[:n], y[n:], g)
        return jnp.concatenate([flow_field(model, K, y, 1.0, sol.prm),
                                jnp.stack([g["k"] * jnp.dot(A, A), g["k1"] * g["k2"] * hm.safe_norm(A)])])

    out = diffrax.diffeqsolve(diffrax.ODETerm(rhs), diffrax.Dopri8(), 0.0, sol.K_f, None,
                              jnp.concatenate([y0, jnp.zeros(2)]),
                              stepsize_controller=diffrax.PIDController(rtol=1e-11, atol=1e-12),
                              max_steps=sol.shooting.max_steps)
    yf = np.asarray(out.ys[-1])
    return {"J_LP_m2s3": float(yf[-2]) * tr.du**2 / tr.tu**3, "dv_m_s": float(yf[-1]) * tr.vu,
            "tof_s": float(yf[hm.TIME]) * tr.tu}


def warm_start(sol: Solution, tr_to: Transfer, label: str, options=None) -> Solution:
    """From a converged OT solution to the problem of ``tr_to`` (new date, model or n_rev).

    Same unknowns layout required (perturbed ↔ perturbed). Thrust, L₀, L_f, c move linearly in
    τ; everything else (the epoch, the force model) is the new problem's from τ = 0 on, and the
    Newton homotopy f(z, τ) = (1 − τ) b absorbs the initial residual b.
    """
    if sol.transfer.perturbed and not tr_to.perturbed:
        raise ConfigError("warm_start", tr_to.perturbations, "cannot warm-start an unperturbed problem from a perturbed one")
    if not sol.transfer.perturbed and tr_to.perturbed:
        return perturb_from_unperturbed(sol, tr_to, label)
    prm_to = tr_to.params(thrust=sol.thrust_N)
    out = chain.continue_in_params(sol, prm_to, options, label=label)
    out.transfer, out.thrust_N = tr_to, sol.thrust_N
    return out


def perturb_from_unperturbed(sol: Solution, tr_to: Transfer, label: str) -> Solution:
    """Unperturbed OT solution → the perturbed OT problem of ``tr_to`` (same orbits, thrust).

    z gains p_t(0) = 0; the Newton homotopy f_p(z, τ) = (1 − τ) f_p(z₀) at the *perturbed*
    problem (pure OT at ε_f, nothing moved) is followed in arclength. Used for E5, whose
    LP → perturbed-OT homotopy folds back to τ < 0 (τ ≈ 0.53 with W_ref = 1).
    """
    sh_p = chain.shooting_for("ot", "eps", tr_to)
    names_u = sol.shooting.unknown_names()
    z = np.asarray([0.0 if n == "p_t" else float(sol.z[names_u.index(n)]) for n in sh_p.unknown_names()])
    prm = {**tr_to.params(thrust=sol.thrust_N), "path_from": {}, "path_to": {}}
    sh_param = dataclasses.replace(sh_p, model=dataclasses.replace(sh_p.model, homotopy="param"))
    z, stats = arclength_run(sh_param, z, prm, label)
    stats["continued_from"] = "unperturbed OT (Newton homotopy at the perturbed problem)"
    return Solution("ot", sh_p, z, tr_to.params(thrust=sol.thrust_N), tr_to, stats, thrust_N=sol.thrust_N)


def load(json_path) -> Solution:
    """Rebuild a converged (possibly perturbed) Solution from its JSON artifact."""
    data = artifacts.read_json(json_path)
    t = data["transfer"]
    tr = Transfer(Orbit(**t["initial"]), Orbit(**t["final"]),
                  **{k: v for k, v in t.items() if k not in ("initial", "final")})
    m = data["model"]
    free = tuple(m["free_costates"])
    perturbed = hm.TIME in free
    sh = Shooting(Model(m["kind"], m["homotopy"], perturbed), free)
    thrust = data["thrust_N"]
    nan = thrust is None or (isinstance(thrust, float) and math.isnan(thrust))
    prm = tr.params(thrust=None if nan else thrust)
    sol = Solution(data["scalars"]["stage"], sh, np.asarray(data["z"]), prm, tr, data["solver"],
                   thrust_N=float("nan") if nan else thrust)
    if sol.stage == "lp":
        sol.extra.update({k: data["scalars"][k] for k in ("J_LP_m2s3", "dv_m_s")})
        sol.extra["tof_s"] = data["scalars"]["tof_days"] * DAY
    return sol


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
