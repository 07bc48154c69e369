"""Dense physical samples of a chain solution (the NPZ contents of design.md, "Artifacts").

From the nondimensional y(K) of a converged stage: time, inertial Cartesian r and v (Walker
form, spec 01-methods §4), mass, thrust (or, for LP, acceleration) vector in the inertial frame,
switching function, throttle, pitch ϑ = atan2(A_r, A_t) and yaw ψ = asin(A_n/|A|) (2.1.7), and
the osculating Kepler elements. Units are SI; angles in degrees.
"""
from __future__ import annotations

import numpy as np
import jax
import jax.numpy as jnp

from ..elements import mee_to_cartesian, mee_to_kepler
from ..indirect import hamiltonians as hm
from ..indirect.chain import Solution, dense
from ..indirect.flow import Model, ot_delta, tmin_ot_delta


def _frame(r, v):
    e_r = r / jnp.linalg.norm(r)
    h = jnp.cross(r, v)
    e_n = h / jnp.linalg.norm(h)
    return jnp.cross(e_n, e_r), e_r, e_n


def _sample_point(stage, K, y, prm, tmin_ot_tau=None):
    """One sample; ``tmin_ot_tau``: the τ of a point of the T_min → OT homotopy (an upper bound on
    T_min, :mod:`spaceopt.indirect.tmin_from_ot`), whose throttle is 1 − τ + τ δ(S_τ, ε₁)."""
    n = hm.N_STATE + (1 if stage == "tmin" else 0)
    x, lam = y[:n], y[n:]
    g = hm.geometry(K, x)
    weight = 1.0 if tmin_ot_tau is None else 1.0 - tmin_ot_tau        # the p_LK shift of A_τ (h_tmin_ot)
    shift = -weight * 0.5 * x[hm.THRUST] ** 2 if stage == "tmin" else 0.0
    A = hm.primer(x, lam, g, shift)
    An = hm.safe_norm(A)
    mee = jnp.stack([x[hm.P], x[hm.EX], x[hm.EY], x[hm.IX], x[hm.IY], g["L"]])
    r, v = mee_to_cartesian(mee, 1.0)
    e_t, e_r, e_n = _frame(r, v)
    direction = (A[0] * e_t + A[1] * e_r + A[2] * e_n) / An
    if stage == "lp":
        accel = g["k2"] * An            # LP optimal acceleration a = k2 A (2.2.7)
        S = jnp.nan
        delta = 1.0
    elif stage == "tmin" and tmin_ot_tau is not None:
        delta, S = tmin_ot_delta(K, y, tmin_ot_tau, prm)
        accel = delta * x[hm.THRUST] / x[hm.MASS]
    elif stage == "tmin":
        accel = x[hm.THRUST] / x[hm.MASS]
        S = hm.switching_tmin(K, x, lam, prm)
        delta = 1.0
    else:
        delta, S, prm_t = ot_delta(Model("ot", "eps"), K, y, 1.0, prm)
        accel = delta * prm_t["thrust"] / x[hm.MASS]
    pitch = jnp.arctan2(A[1], A[0])
    yaw = jnp.arcsin(jnp.clip(A[2] / An, -1.0, 1.0))
    return dict(t=x[hm.TIME], r=r, v=v, m=x[hm.MASS], accel=accel * direction, S=S, delta=delta,
                pitch=pitch, yaw=yaw, direction=direction, kepler=mee_to_kepler(mee), L=g["L"])


def sample(sol: Solution, samples_per_rev: int = 200) -> dict:
    """Physical samples of ``sol`` on a uniform grid in K."""
    tr = sol.transfer
    Ks, ys = dense(sol, samples_per_rev)
    tmin_ot_tau = sol.tau if sol.shooting.model.kind == "tmin" and sol.shooting.model.homotopy == "ot" else None
    pts = jax.vmap(lambda K, y: _sample_point(sol.stage, K, y, sol.prm, tmin_ot_tau))(jnp.asarray(Ks), jnp.asarray(ys))
    pts = {k: np.asarray(v) for k, v in pts.items()}
    mass = pts["m"] * tr.m0
    accel = pts["accel"] * tr.du / tr.tu**2
    kep = pts["kepler"]
    return {
        "K_rad": Ks, "t_s": pts["t"] * tr.tu, "r_m": pts["r"] * tr.du, "v_m_s": pts["v"] * tr.vu,
        "mass_kg": mass, "accel_m_s2": accel, "direction": pts["direction"], "thrust_N": accel * mass[:, None],
        "S": pts["S"], "delta": np.asarray(pts["delta"]) * np.ones_like(Ks),
        "pitch_deg": np.degrees(pts["pitch"]), "yaw_deg": np.degrees(pts["yaw"]),
        "a_m": kep[:, 0] * tr.du, "e": kep[:, 1], "i_deg": np.degrees(kep[:, 2]),
        "raan_deg": np.degrees(kep[:, 3]), "argp_deg": np.degrees(kep[:, 4]),
        "L_rad": pts["L"], "costates": ys[:, sol.shooting.model.n:],
    }
