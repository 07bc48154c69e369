"""The JAX-derived canonical equations against the printed ones (spec 01-methods §1.3, §2)."""
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from spaceopt.indirect import hamiltonians as hm
from spaceopt.indirect.flow import Model, field, hamiltonian_field

PRM = {"c": 4.848041, "thrust": 0.0669, "eps_final": 1e-5, "eps_blend": 1e-2, "lp_scale": 1.0,
       "blend_ref": 1.0}


def random_point(seed, n=8):
    rng = np.random.default_rng(seed)
    x = np.array([rng.uniform(0.3, 1.2), rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5),
                  rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), rng.uniform(-3, 3),
                  rng.uniform(0, 10), rng.uniform(0.7, 1.0)])
    lam = rng.normal(scale=0.1, size=8)
    lam[hm.TIME] = 0.0
    if n == 9:
        x = np.append(x, rng.uniform(0.01, 0.05))
        lam = np.append(lam, rng.normal(scale=0.01))
    return float(rng.uniform(0, 30)), jnp.asarray(x), jnp.asarray(lam)


def printed_state_rates(K, x, a):
    """(1.1.7) with total acceleration a = (a_t, a_r, a_n)."""
    g = hm.geometry(K, x)
    return g["k1"] * g["k2"] * hm.control_matrix(x, g) @ a, g


@pytest.mark.parametrize("seed", range(5))
def test_ot_field_matches_printed_equations(seed):
    K, x, lam = random_point(seed)
    S = hm.switching_ot(K, x, lam, PRM)
    delta = float(hm.smooth_delta(S, 0.3))
    y = jnp.concatenate([x, lam])
    g = hamiltonian_field(lambda K_, x_, l_: hm.h_ot(K_, x_, l_, PRM, delta), K, y, 8)
    geo = hm.geometry(K, x)
    A = hm.primer(x, lam, geo)
    a = delta * PRM["thrust"] / x[hm.MASS] * A / jnp.linalg.norm(A)
    rates, _ = printed_state_rates(K, x, a)
    np.testing.assert_allclose(g[:6], rates, rtol=1e-12, atol=1e-15)
    assert np.isclose(g[hm.TIME], geo["k1"], rtol=1e-13)
    assert np.isclose(g[hm.MASS], -delta * geo["k1"] * PRM["thrust"] / PRM["c"], rtol=1e-13)
    # dp_m/dK = δ T k1 k2 |A| / m² (2.1.10)
    expected_pm = delta * PRM["thrust"] * geo["k1"] * geo["k2"] * jnp.linalg.norm(A) / x[hm.MASS] ** 2
    assert np.isclose(g[8 + hm.MASS], expected_pm, rtol=1e-12)


@pytest.mark.parametrize("seed", range(5))
def test_lp_field_is_twice_k_B_A(seed):
    K, x, lam = random_point(seed)
    y = jnp.concatenate([x, lam])
    g = field(Model("lp"), K, y, 0.0, PRM)
    geo = hm.geometry(K, x)
    A = hm.primer(x, lam, geo)
    rates, _ = printed_state_rates(K, x, geo["k2"] * A)     # a_LP = k2 A (2.2.7)
    np.testing.assert_allclose(g[:6], rates, rtol=1e-12, atol=1e-15)
    assert g[hm.MASS] == 0.0


@pytest.mark.parametrize("seed", range(5))
def test_tmin_thrust_costate_equation_2_3_9(seed):
    K, x, lam = random_point(seed, n=9)
    y = jnp.concatenate([x, lam])
    g = hamiltonian_field(lambda K_, x_, l_: hm.h_tmin(K_, x_, l_, PRM), K, y, 9)
    geo = hm.geometry(K, x)
    T, m = x[hm.THRUST], x[hm.MASS]
    A1v = hm.primer(x, lam, geo, -0.5 * T**2)
    A1 = jnp.linalg.norm(A1v)
    printed = T + geo["k1"] * lam[hm.MASS] / PRM["c"] + geo["k1"] * geo["k2"] * (
        (-A1 + geo["xi"] * T**2 * A1v[2] / A1) / m)
    assert np.isclose(g[9 + hm.THRUST], printed, rtol=1e-11)
    assert g[hm.THRUST] == 0.0


def test_smoothed_delta_frozen_in_costates_but_seen_by_sensitivities():
    K, x, lam = random_point(7)
    y = jnp.concatenate([x, lam])
    model = Model("ot", "eps")
    prm = {**PRM, "thrust": 0.0669, "eps_blend": 0.2, "eps_final": 0.2}
    g = field(model, K, y, 1.0, prm)
    # costate rows equal −∂H/∂x with δ held constant
    S = hm.switching_ot(K, x, lam, {**prm, "thrust": 0.0669})
    delta = hm.smooth_delta(S, 0.2)
    dHdx = jax.grad(lambda xx: hm.h_ot(K, xx, lam, {**prm, "thrust": 0.0669}, delta))(x)
    np.testing.assert_allclose(g[8:], -dHdx, rtol=1e-12, atol=1e-16)
    # the Jacobian of the field sees dδ/dy: it differs from the frozen-δ Jacobian
    J_full = jax.jacfwd(lambda yy: field(model, K, yy, 1.0, prm))(y)
    J_frozen = jax.jacfwd(lambda yy: hamiltonian_field(
        lambda K_, x_, l_: hm.h_ot(K_, x_, l_, {**prm, "thrust": 0.0669}, delta), K, yy, 8))(y)
    assert np.max(np.abs(J_full - J_frozen)) > 1e-6


def test_homotopy_end_points():
    K, x, lam = random_point(3)
    y = jnp.concatenate([x, lam])
    prm = {**PRM, "lp_scale": 0.5}
    g0 = field(Model("ot", "lp"), K, y, 0.0, PRM)
    g_lp_half = hamiltonian_field(lambda K_, x_, l_: hm.h_lp(K_, x_, l_, prm), K, y, 8)
    np.testing.assert_allclose(g0, g_lp_half, rtol=1e-13, atol=1e-16)


def test_tmin_to_ot_homotopy_end_points():
    """Model('tmin', 'ot'): τ = 0 is the T_min field (2.3.8); τ = 1 the OT field (2.1.9) at ε₁
    (the p_T row aside, which no other row sees)."""
    K, x, lam = random_point(4, n=9)
    y = jnp.concatenate([x, lam])
    g0 = field(Model("tmin", "ot"), K, y, 0.0, PRM)
    g_tmin = hamiltonian_field(lambda K_, x_, l_: hm.h_tmin(K_, x_, l_, PRM), K, y, 9)
    np.testing.assert_allclose(g0, g_tmin, rtol=1e-12, atol=1e-15)
    g1 = field(Model("tmin", "ot"), K, y, 1.0, PRM)
    prm_t = {**PRM, "thrust": x[hm.THRUST]}
    y8 = jnp.concatenate([x[:8], lam[:8]])
    delta = hm.smooth_delta(hm.switching_ot(K, x[:8], lam[:8], prm_t), PRM["eps_blend"])
    g_ot = hamiltonian_field(lambda K_, x_, l_: hm.h_ot(K_, x_, l_, prm_t, delta), K, y8, 8)
    keep = np.r_[0:8, 9:17]                       # drop the T and p_T rows
    np.testing.assert_allclose(np.asarray(g1)[keep], g_ot, rtol=1e-12, atol=1e-15)


def test_perturbation_strength_homotopy_end_points():
    """Model('ot', 'pert'): τ scales the perturbation field; τ = 0 unperturbed OT at ε_f,
    τ = 1 the perturbed OT problem."""
    from spaceopt.forces import build_model
    K, x, lam = random_point(5)
    y = jnp.concatenate([x, lam])
    prm = {**PRM, "path_from": {}, "path_to": {}, "du": 7.0e6, "tu": 806.0,
           "pert": build_model({"geopotential": "j2"}, "2021-05-09T12:00:00", None)}
    g_u = field(Model("ot", "param"), K, y, 0.0, prm)
    g_p = field(Model("ot", "param", True), K, y, 0.0, prm)
    assert np.max(np.abs(np.asarray(g_p - g_u))) > 1e-6
    for tau in (0.0, 0.3, 1.0):
        np.testing.assert_allclose(field(Model("ot", "pert", True), K, y, tau, prm),
                                   g_u + tau * (g_p - g_u), rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("seed", range(4))
def test_orbital_frame_of_the_perturbation_is_the_r_v_frame(seed):
    """perturbation_tnr builds e_r, e_t, e_n and r from the equinoctial frame; spec 01-methods
    §1.7 builds them from r, v (Appendix B.1): e_r = r/r, e_n = r×v/|r×v|, e_t = e_n×e_r. Both
    give the same (a_t, a_r, a_n), also at high inclination (tan(i/2) up to 0.9)."""
    from spaceopt.elements import mee_to_cartesian
    from spaceopt.forces import build_model, perturbing_acceleration
    rng = np.random.default_rng(100 + seed)
    K, x, _ = random_point(seed)
    x = x.at[hm.IX].set(rng.uniform(-0.9, 0.9)).at[hm.IY].set(rng.uniform(-0.9, 0.9))
    prm = {"du": 7.0e6, "tu": 806.0,
           "pert": build_model({"geopotential": {"degree": 4, "order": 4}}, "2021-05-09T12:00:00", None)}
    g = hm.geometry(K, x)
    r, v = mee_to_cartesian(jnp.stack([x[hm.P], x[hm.EX], x[hm.EY], x[hm.IX], x[hm.IY], g["L"]]), 1.0)
    e_r = r / jnp.linalg.norm(r)
    e_n = jnp.cross(r, v) / jnp.linalg.norm(jnp.cross(r, v))
    e_t = jnp.cross(e_n, e_r)
    t = prm["pert"].epoch + x[hm.TIME] * prm["tu"]
    a = perturbing_acceleration(r * prm["du"], t, prm["pert"]) * prm["tu"] ** 2 / prm["du"]
    expected = jnp.stack([a @ e_t, a @ e_r, a @ e_n])
    np.testing.assert_allclose(hm.perturbation_tnr(K, x, prm), expected, rtol=1e-12,
                               atol=1e-13 * float(jnp.linalg.norm(a)))


def test_force_model_blend_is_linear_in_the_acceleration():
    """Model('ot', 'model'): the perturbation field of prm['pert_from'] at τ = 0, of prm['pert']
    at τ = 1, and (1 − τ) · from + τ · to between (H_p is linear in a_p)."""
    from spaceopt.forces import build_model
    K, x, lam = random_point(6)
    y = jnp.concatenate([x, lam])
    base = {**PRM, "path_from": {}, "path_to": {}, "du": 7.0e6, "tu": 806.0}
    j2 = build_model({"geopotential": "j2"}, "2021-05-09T12:00:00", None)
    g44 = build_model({"geopotential": {"degree": 4, "order": 4}}, "2021-05-09T12:00:00", None)
    g_j2, g_44 = (field(Model("ot", "param", True), K, y, 0.0, {**base, "pert": m}) for m in (j2, g44))
    assert np.max(np.abs(np.asarray(g_44 - g_j2))) > 1e-9
    prm = {**base, "pert": g44, "pert_from": j2}
    for tau in (0.0, 0.4, 1.0):
        np.testing.assert_allclose(field(Model("ot", "model", True), K, y, tau, prm),
                                   (1 - tau) * g_j2 + tau * g_44, rtol=1e-12, atol=1e-15)
