"""Independent check of an OT artifact: Cartesian re-propagation with SciPy DOP853.

Separate from the solver: it reads only the NPZ (time, r, v, mass, thrust direction, switching
function) and the transfer data of the JSON, and integrates

    r'' = −μ r/|r|³ + δ(S(t)) T/m e(t),    m' = −δ(S(t)) T/c,

with e(t) and S(t) cubic-spline interpolants of the recorded samples and δ the same smoothed
throttle (3.3.2) at ε_f. The final state is compared with the target orbit (a, e, i, true
longitude) and the final mass with the solver's. Errors are reported, not hidden.

A perturbed artifact (§4.2: its JSON names the force model, the departure epoch and the
ephemeris window) adds the perturbing acceleration a_p(r, t_0 + t) to r''. The force model is
the solver's own (:func:`spaceopt.forces.perturbing_acceleration`, checked separately against
textbook magnitudes, finite differences and jplephem); what is independent here is the rest:
Newton's equations in Cartesian coordinates and time instead of the Hamiltonian system in
equinoctial elements and the auxiliary longitude, SciPy's integrator instead of diffrax, and the
control rebuilt from the recorded samples. Where those samples are too sparse for a long transfer
(the control spline sets the check's resolution), :func:`resampled` saves the same extremal again,
sampled finer, before the check.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline

from .. import artifacts
from ..elements import cartesian_to_mee, mee_to_kepler
from ..indirect.hamiltonians import C_SMOOTH


def recorded_control(data: dict, smp: dict):
    """The recorded thrust history of an artifact, for a Cartesian re-propagation.

    Returns (t_span [s], y0 = (r [m], v [m/s], m [kg]), thrust), with thrust(t, m) ->
    (thrust acceleration δ(S(t)) T/m e(t) [m/s²], mass flow −δ T/c [kg/s]): e(t) and S(t) cubic
    splines of the samples, δ the smoothed throttle (3.3.2) at ε_f; δ = 1 on a minimum-thrust
    trajectory (§3.4: the engine never switches off; its samples' S is not an OT switching
    function: δ(S) of it fell to 0.5–0.7 on E9's and lost 0.4 kg of its 1.06 kg of propellant);
    on an upper bound on T_min (a point of the T_min → OT homotopy at τ > 0, its JSON model has
    ``tau``; :mod:`spaceopt.indirect.tmin_from_ot`) δ is a spline of the recorded throttle
    1 − τ + τ δ(S_τ): E7's replay at δ = 1 amplified the 5e-5 difference to 50 000 km.
    """
    tr = data["transfer"]
    T, c, eps = data["thrust_N"], tr["isp"] * 9.80665, tr["eps_final"]
    always_on = data["model"]["kind"] == "tmin"
    t = smp["t_s"]
    keep = np.concatenate([[True], np.diff(t) > 0])
    t = t[keep]
    S = CubicSpline(t, smp["S"][keep])
    e = CubicSpline(t, smp["direction"][keep])
    recorded = CubicSpline(t, smp["delta"][keep]) if "tau" in data["model"] else None

    def thrust(tt, m):
        s = S(tt)
        if recorded is not None:
            delta = float(recorded(tt))
        else:
            delta = 1.0 if always_on else 0.5 * (1.0 + s / math.sqrt(s * s + C_SMOOTH * eps * eps))
        d = e(tt)
        return delta * T / m * (d / np.linalg.norm(d)), -delta * T / c

    y0 = np.concatenate([smp["r_m"][0], smp["v_m_s"][0], [smp["mass_kg"][0]]])
    return (t[0], t[-1]), y0, thrust


THRUST_PROBE = 1e-7     # relative thrust change of the conditioning probe on minimum-thrust trajectories


def verify_ot(json_path, rtol=1e-11, atol_m=1e-3) -> dict:
    """The re-propagation's final errors (module docstring). On a minimum-thrust trajectory or an
    upper bound on T_min (always on, model kind 'tmin'), and on the least-thrust point of a thrust
    family (``spaceopt.studies.thrust_family``: its throttle all but always on; E7 unperturbed at
    0.30 N, apogee 535 000 km, replayed 394 km from the solver) also how far a thrust changed by
    ±``THRUST_PROBE`` (relative) moves the end point, the smaller of the two
    (``final_position_moved_by_thrust_probe_km``): such a trajectory is the one that barely makes
    the transfer, and its end point can be far more sensitive than an OT one's (at 2000 samples
    per revolution): E7 unperturbed's bound (100 revolutions, apogee raised to 218 700 km on the
    way) moves by 312 km, where its OT 1 N trajectory's moves by about 1 km; E5's T_min by 3.9 km,
    E9's by 0.066 km unperturbed and 0.0003 km with J2. It is the scale against which the replay's
    distance to the solver reads."""
    data = artifacts.read_json(json_path)
    smp = artifacts.read_npz(json_path)
    tr = data["transfer"]
    mu = tr["mu"]
    span, y0, thrust = recorded_control(data, smp)
    perturbing = _perturbing_acceleration(data)

    def propagate(a_p, thrust_scale=1.0):
        def rhs(tt, y):
            r, v, m = y[:3], y[3:6], y[6]
            a_t, mdot = thrust(tt, m)
            a_t, mdot = thrust_scale * a_t, thrust_scale * mdot
            acc = -mu * r / np.linalg.norm(r) ** 3 + a_t + a_p(r, tt)
            return np.concatenate([v, acc, [mdot]])

        scale = np.concatenate([np.full(3, atol_m), np.full(3, atol_m * 1e-3), [1e-9]])
        return solve_ivp(rhs, span, y0, method="DOP853", rtol=rtol, atol=scale)

    sol = propagate(perturbing)
    rf, vf, mf = sol.y[:3, -1], sol.y[3:6, -1], sol.y[6, -1]
    kep = np.asarray(mee_to_kepler(cartesian_to_mee(rf, vf, mu)))
    Lf = math.radians(tr["L0_deg"]) + 2 * math.pi * tr["n_rev"]
    mee = np.asarray(cartesian_to_mee(rf, vf, mu))
    dL = math.remainder(float(mee[5]) - Lf, 2 * math.pi)
    fin = tr["final"]
    out = {
        "integrator": "scipy DOP853", "rtol": rtol, "nfev": int(sol.nfev), "success": bool(sol.success),
        "final_a_error_km": (kep[0] - fin["a"]) / 1e3, "final_e_error": kep[1] - fin["e"],
        "final_i_error_deg": math.degrees(kep[2]) - fin["i"], "final_L_error_deg": math.degrees(dL),
        "final_mass_error_kg": mf - data["scalars"]["m_f_kg"],
        "final_position_vs_solver_km": float(np.linalg.norm(rf - smp["r_m"][-1]) / 1e3),
    }
    if data["model"]["kind"] == "tmin" or "family" in (data.get("extra") or {}):
        out["thrust_probe_relative"] = THRUST_PROBE
        out["final_position_moved_by_thrust_probe_km"] = min(
            float(np.linalg.norm(propagate(perturbing, 1.0 + side * THRUST_PROBE).y[:3, -1] - rf) / 1e3)
            for side in (1.0, -1.0))
    if (data.get("extra") or {}).get("perturbations"):
        # the same control without the perturbations: how far they move the end point, the
        # scale against which the check above resolves the force model
        r_off = propagate(lambda r, tt: 0.0).y[:3, -1]
        out["final_position_without_perturbations_km"] = float(np.linalg.norm(r_off - smp["r_m"][-1]) / 1e3)
    return out


def resampled(json_path, out_dir, samples_per_rev: int) -> Path:
    """The artifact saved again in ``out_dir`` with ``samples_per_rev`` samples per revolution:
    its solution rebuilt from the unknowns z by the solver (the same extremal, sampled finer; the
    NPZ is the solver's flow in any case), so that the samples do not limit the check's resolution.
    The artifact's extra is kept (a thrust family's marks its point for the thrust probe)."""
    from . import perturbed as P
    out = Path(out_dir) / Path(json_path).name
    P.save(P.load(json_path), out, {}, 0.0, artifacts.read_json(json_path).get("extra"), samples_per_rev=samples_per_rev)
    return out


def _perturbing_acceleration(data: dict):
    """a_p(r [m], t [s after departure]) [m/s²] of a perturbed artifact; zero for an unperturbed one."""
    extra = data.get("extra") or {}
    if not extra.get("perturbations"):
        return lambda r, t: 0.0
    import jax

    from ..forces import build_model, perturbing_acceleration
    model = build_model(extra["perturbations"], extra["epoch_utc"], data["transfer"].get("ephemeris"))
    accel = jax.jit(perturbing_acceleration)
    return lambda r, t: np.asarray(accel(r, model.epoch + t, model))
