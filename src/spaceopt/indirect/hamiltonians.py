"""Pontryagin functions of the three low-thrust problems in the K-formulation.

State ``x = (p, e_x, e_y, i_x, i_y, L_K, t, m[, T])`` and costate ``λ`` of the same layout; the
independent variable is the auxiliary longitude K with L = K + L_K (dissertation §1.1, spec
01-methods §1.2–1.3). With

    q = 1 + e_x cos L + e_y sin L,  s² = 1 + i_x² + i_y²,  ξ = i_x sin L − i_y cos L,
    k1 = q⁻² √(p³/μ) (= dt/dK),  k2 = q⁻¹ √(p/μ),  k = ½ k1 k2²,

the MEE "primer" is A = Bᵀλ₁…₆ (spec 01-methods §1.3, eq. 2.1.6):

    A_t = 2p p_p + [(q+1)cos L + e_x] p_ex + [(q+1) sin L + e_y] p_ey,
    A_r = q (sin L p_ex − cos L p_ey),
    A_n = ξ(−e_y p_ex + e_x p_ey + p_LK) + ½ s² (cos L p_ix + sin L p_iy).

Maximised Pontryagin functions (μ = 1 units; c = exhaust velocity; T = thrust):

* LP, ideally regulated engine (2.2.8):      H = k |A|² + k1 p_t
* LP in the homotopy normalisation (3.3.1):  H' = ½ k |A|² + k1 p_t   (costates = 2 × those of 2.2.8)
* OT, minimum fuel (2.1.2–2.1.9):            H = δ T k1 [k2 |A|/m − (p_m + 1)/c] + k1 p_t
* T_min, minimum thrust (2.3.3–2.3.8):       H = −½T² + T k1 [k2 |A₁|/m − p_m/c] + k1 p_t,
  with A₁ = A evaluated at p_LK − T²/2 and T a state (dT/dK = 0).

The perturbing part H_p = k1 k2 (A · a_p) (a_p in the orbital t, r, n frame) is added by the
problem when a perturbation model is present. Nothing here is differentiated by hand: the
canonical equations come from ``jax.grad`` in :mod:`spaceopt.indirect.flow`.
"""
from __future__ import annotations

import jax.numpy as jnp

# state / costate layout
P, EX, EY, IX, IY, LK, TIME, MASS, THRUST = range(9)
N_STATE = 8          # without the thrust state of T_min
C_SMOOTH = 2.0 * (jnp.sqrt(2.0) + 1.0)   # c in the smoothing (3.3.2)


def geometry(K, x):
    """Auxiliary quantities (q, s², ξ, k1, k2, k, L) of spec 01-methods §0, with μ = 1."""
    p, ex, ey, ix, iy, lk = x[P], x[EX], x[EY], x[IX], x[IY], x[LK]
    L = K + lk
    cL, sL = jnp.cos(L), jnp.sin(L)
    q = 1.0 + ex * cL + ey * sL
    s2 = 1.0 + ix**2 + iy**2
    xi = ix * sL - iy * cL
    sqp = jnp.sqrt(p)
    k1 = p * sqp / q**2
    k2 = sqp / q
    return dict(q=q, s2=s2, xi=xi, k1=k1, k2=k2, k=0.5 * k1 * k2**2, L=L, cL=cL, sL=sL)


def control_matrix(x, g):
    """The 6×3 matrix B with d(x, L_K)/dK = k1 k2 B a, columns (t, r, n) (spec 01-methods §1.3)."""
    p, ex, ey = x[P], x[EX], x[EY]
    q, s2, xi, cL, sL = g["q"], g["s2"], g["xi"], g["cL"], g["sL"]
    z = jnp.zeros_like(p)
    return jnp.stack([
        jnp.stack([2 * p, z, z]),
        jnp.stack([(q + 1) * cL + ex, q * sL, -ey * xi]),
        jnp.stack([(q + 1) * sL + ey, -q * cL, ex * xi]),
        jnp.stack([z, z, 0.5 * s2 * cL]),
        jnp.stack([z, z, 0.5 * s2 * sL]),
        jnp.stack([z, z, xi]),
    ])


def primer(x, lam, g, p_lk_shift=0.0):
    """A = (A_t, A_r, A_n) = Bᵀ λ₁…₆, with p_LK replaced by p_LK + ``p_lk_shift``."""
    lam6 = lam[:6].at[LK].add(p_lk_shift)
    return control_matrix(x, g).T @ lam6


def safe_norm(v):
    """|v| with a finite gradient at v = 0 (the zero initial guess of the LP problem)."""
    sq = jnp.sum(v * v)
    safe = jnp.where(sq > 0, sq, 1.0)
    return jnp.where(sq > 0, jnp.sqrt(safe), 0.0)


def h_lp(K, x, lam, prm):
    """Minimum-power Hamiltonian (2.2.8): k|A|² + k1 p_t; ``prm['lp_scale']`` is 1 or ½."""
    g = geometry(K, x)
    A = primer(x, lam, g)
    return prm["lp_scale"] * g["k"] * jnp.dot(A, A) + g["k1"] * lam[TIME]


def switching_ot(K, x, lam, prm):
    """OT switching function S = k2|A|/m − (p_m + 1)/c (2.1.8)."""
    g = geometry(K, x)
    A = primer(x, lam, g)
    return g["k2"] * safe_norm(A) / x[MASS] - (lam[MASS] + 1.0) / prm["c"]


def h_ot(K, x, lam, prm, delta):
    """Minimum-fuel Hamiltonian (2.1.9) with the throttle δ given (frozen, spec 01-methods §7)."""
    g = geometry(K, x)
    return delta * prm["thrust"] * g["k1"] * switching_ot(K, x, lam, prm) + g["k1"] * lam[TIME]


def switching_tmin(K, x, lam, prm):
    """T_min switching function S_T = k2|A₁|/m − p_m/c (2.3.6)."""
    g = geometry(K, x)
    T = x[THRUST]
    A1 = primer(x, lam, g, -0.5 * T**2)
    return g["k2"] * safe_norm(A1) / x[MASS] - lam[MASS] / prm["c"]


def h_tmin(K, x, lam, prm):
    """Minimum-thrust Hamiltonian (2.3.8), engine always on."""
    g = geometry(K, x)
    T = x[THRUST]
    return -0.5 * T**2 + T * g["k1"] * switching_tmin(K, x, lam, prm) + g["k1"] * lam[TIME]


def h_tmin_ot(K, x, lam, prm, tau, delta):
    """T_min → OT homotopy (route LP → T_min → OT), T a state, throttle δ given (frozen):

        H_τ = −(1 − τ) ½T² + δ T k1 [k2 |A_τ|/m − (p_m + τ)/c] + k1 p_t,

    A_τ = A at p_LK − (1 − τ) T²/2. τ = 0 with δ = 1: the T_min Hamiltonian (2.3.8); τ = 1: the
    OT Hamiltonian (2.1.9) (the cost weight of the propellant, the "+1", grows from 0 to 1).
    """
    g = geometry(K, x)
    T = x[THRUST]
    A = primer(x, lam, g, -(1.0 - tau) * 0.5 * T**2)
    S = g["k2"] * safe_norm(A) / x[MASS] - (lam[MASS] + tau) / prm["c"]
    return -(1.0 - tau) * 0.5 * T**2 + delta * T * g["k1"] * S + g["k1"] * lam[TIME]


def switching_tmin_ot(K, x, lam, prm, tau):
    """Switching function of :func:`h_tmin_ot`."""
    g = geometry(K, x)
    A = primer(x, lam, g, -(1.0 - tau) * 0.5 * x[THRUST] ** 2)
    return g["k2"] * safe_norm(A) / x[MASS] - (lam[MASS] + tau) / prm["c"]


def primer_magnitude(K, x, lam, shift=0.0):
    g = geometry(K, x)
    return safe_norm(primer(x, lam, g, shift))


def smooth_delta(S, eps):
    """Smoothed throttle (3.3.2): δ = ½(1 + S/√(S² + c ε²)), c = 2(√2 + 1)."""
    return 0.5 * (1.0 + S / jnp.sqrt(S**2 + C_SMOOTH * eps**2))


def epsilon_schedule(tau, eps_final):
    """ε(τ) = 1 − τ + ε_f τ (spec 02-multirev §2.4)."""
    return 1.0 - tau + eps_final * tau


def perturbation_tnr(K, x, prm, blend=None):
    """Perturbing acceleration (a_pt, a_pr, a_pn) in the orbital frame, nondimensional.

    Spec 01-methods §1.7 steps 2–4 take r, v from the MEE (Appendix B.1) and build e_r = r/r,
    e_n = r×v/|r×v|, e_t = e_n×e_r. The same vectors come without v, norms or cross products
    from the equinoctial frame of the MEE (the rows of Appendix B.1's position formula), with
    s² = 1 + i_x² + i_y²:

        f̂ = (1 + i_x² − i_y², 2 i_x i_y, −2 i_y)/s²,   ĝ = (2 i_x i_y, 1 − i_x² + i_y², 2 i_x)/s²,
        e_r = cos L f̂ + sin L ĝ,   e_t = cos L ĝ − sin L f̂,   e_n = f̂×ĝ = (2 i_y, −2 i_x, 1 − i_x² − i_y²)/s²,
        r = (p/q) e_r.

    Fewer operations mean fewer XLA kernels under the solver's nested derivatives
    (docs/perturbed-e6-e7-e8.md, "nineteenth session" and "forty-second session"); a test checks
    the frame against the r, v route. a_p comes from
    :func:`spaceopt.forces.perturbing_acceleration` at r·DU and t_TDB = epoch [+ epoch_offset_s]
    + t·TU, scaled by TU²/DU. ``blend`` = τ: the force-model blend a_p = τ a_p[prm['pert']] +
    (1 − τ) a_p[prm['pert_from']], with the orbital frame, position and time computed once for
    both models, and each term the two models share (:func:`spaceopt.forces.blended_acceleration`).
    """
    from ..forces import blended_acceleration, perturbing_acceleration

    g = geometry(K, x)
    ix, iy, s2, cL, sL = x[IX], x[IY], g["s2"], g["cL"], g["sL"]
    f_hat = jnp.stack([1.0 + ix * ix - iy * iy, 2.0 * ix * iy, -2.0 * iy]) / s2
    g_hat = jnp.stack([2.0 * ix * iy, 1.0 - ix * ix + iy * iy, 2.0 * ix]) / s2
    e_r = cL * f_hat + sL * g_hat
    e_t = cL * g_hat - sL * f_hat
    e_n = jnp.stack([2.0 * iy, -2.0 * ix, 1.0 - ix * ix - iy * iy]) / s2
    model = prm["pert"]
    # prm['epoch_offset_s'] (optional): departure epoch shifted from the model's (E6 date homotopy)
    t = model.epoch + prm.get("epoch_offset_s", 0.0) + x[TIME] * prm["tu"]
    r_m = (x[P] / g["q"] * prm["du"]) * e_r
    a = (perturbing_acceleration(r_m, t, model) if blend is None
         else blended_acceleration(r_m, t, model, prm["pert_from"], blend))
    a = a * prm["tu"] ** 2 / prm["du"]
    return jnp.stack([a @ e_t, a @ e_r, a @ e_n])


def h_pert(K, x, lam, prm, p_lk_shift=0.0, blend=None):
    """H_p = k1 k2 (A_t a_pt + A_r a_pr + A_n a_pn) (2.1.4); A₁ (shifted p_LK) for T_min;
    ``blend``: the force-model blend of :func:`perturbation_tnr`."""
    g = geometry(K, x)
    return g["k1"] * g["k2"] * jnp.dot(primer(x, lam, g, p_lk_shift), perturbation_tnr(K, x, prm, blend))
