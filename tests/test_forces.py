"""Geopotential (EGM96 <= 4x4), J2, third bodies, and the assembled perturbation model."""
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.special import lpmv

from spaceopt import ephemeris as E
from spaceopt import forces as Fo
from spaceopt import frames as F
from spaceopt.constants import MU_MOON, MU_SUN
from spaceopt.errors import ConfigError

EPOCH = "2021-05-09T12:00:00"
EGM = Fo.load_egm96()
GM, RE, C, S = EGM["gm"], EGM["radius"], EGM["C"], EGM["S"]
R_GEO = 42164.0e3


@pytest.fixture(scope="module")
def eph():
    return E.ChebyshevEphemeris.from_de405("2021-04-25", "2021-08-15", "may2021")


@pytest.fixture(scope="module")
def full(eph):
    return Fo.build_model({"geopotential": {"degree": 4, "order": 4}, "third_bodies": ["moon", "sun"]},
                          EPOCH, eph)


# -- coefficients -----------------------------------------------------------------------------
def test_egm96_file_constants_and_j2():
    assert GM == 3.986004415e14 and RE == 6378136.3
    assert EGM["j2"] == pytest.approx(1.0826266835531513e-3, rel=1e-15)   # = -sqrt(5) C20
    assert np.count_nonzero(C) + np.count_nonzero(S) == 12 + 9
    assert C[4, 4] == -0.188560802735e-06 and S[4, 4] == 0.308853169333e-06
    assert C[3, 0] == 0.957254173792e-06 and S[2, 1] == 0.119528012031e-08
    # unnormalized J3, J4 (textbook values -2.5327e-6, -1.6196e-6)
    assert -math.sqrt(7) * C[3, 0] == pytest.approx(-2.53266e-6, rel=1e-5)
    assert -3.0 * C[4, 0] == pytest.approx(-1.61962e-6, rel=1e-5)


# -- geopotential -----------------------------------------------------------------------------
def _potential_spherical(r, degree=4, order=4):
    """Independent reference: angles + scipy's associated Legendre (Condon-Shortley removed)."""
    x, y, z = r
    rr = np.linalg.norm(r)
    sphi, lam = z / rr, math.atan2(y, x)
    u = 0.0
    for n in range(2, degree + 1):
        for m in range(0, min(n, order) + 1):
            pbar = (-1) ** m * lpmv(m, n, sphi) * Fo._norm(n, m)
            u += (RE / rr) ** n * pbar * (C[n, m] * math.cos(m * lam) + S[n, m] * math.sin(m * lam))
    return GM / rr * u


def _points(n, rmin=6.6e6, rmax=4.3e7, seed=3):
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1)[:, None] * rng.uniform(rmin, rmax, n)[:, None]


@pytest.mark.parametrize("degree,order", [(4, 4), (3, 2), (2, 0)])
def test_potential_matches_spherical_formula(degree, order):
    for r in _points(8):
        u = float(Fo.geopotential(jnp.asarray(r), C, S, GM, RE, degree, order))
        assert u == pytest.approx(_potential_spherical(r, degree, order), rel=1e-12)


def test_potential_smooth_at_pole():
    r = jnp.array([0.0, 0.0, 7.0e6])
    a = Fo.geopotential_acceleration(r, C, S, GM, RE)
    assert np.all(np.isfinite(np.asarray(a)))
    j = jax.jit(jax.jacfwd(lambda q: Fo.geopotential_acceleration(q, C, S, GM, RE)))(r)
    assert np.all(np.isfinite(np.asarray(j)))


def test_acceleration_ad_vs_central_differences():
    h = 10.0
    for r in _points(5, seed=11):
        a = np.asarray(Fo.geopotential_acceleration(jnp.asarray(r), C, S, GM, RE))
        fd = np.zeros(3)
        for i in range(3):
            e = np.zeros(3); e[i] = h
            fd[i] = (_potential_spherical(r + e) - _potential_spherical(r - e)) / (2 * h)
        assert np.max(np.abs(a - fd)) < 1e-7 * np.linalg.norm(a)


# -- J2 ---------------------------------------------------------------------------------------
def test_j2_closed_form_is_gradient_and_matches_c20_part():
    for r in _points(6, seed=5):
        r = jnp.asarray(r)
        a = np.asarray(Fo.j2_acceleration(r, GM, EGM["j2"], RE))
        g = np.asarray(jax.grad(Fo.j2_potential)(r, GM, EGM["j2"], RE))
        sh = np.asarray(Fo.geopotential_acceleration(r, C, S, GM, RE, 2, 0))
        assert np.allclose(a, g, rtol=1e-13, atol=0)
        assert np.allclose(a, sh, rtol=1e-12, atol=1e-14 * np.linalg.norm(a))


def test_printed_thesis_j2_formula_is_wrong():
    """Erratum (spec/01-methods.md §1.7): the printed 1/2 factor and 5(z^2/r^2 - 3) z component."""
    r = jnp.array([3.0e6, 4.0e6, 5.0e6])
    rn = float(jnp.linalg.norm(r))
    k = 0.5 * GM * EGM["j2"] * RE ** 2 / rn ** 5
    q = float(r[2]) ** 2 / rn ** 2
    printed = k * np.array([(5 * q - 1) * r[0], (5 * q - 1) * r[1], 5 * (q - 3) * r[2]])
    correct = np.asarray(Fo.j2_acceleration(r, GM, EGM["j2"], RE))
    assert not np.allclose(printed, correct, rtol=0.1)
    assert np.allclose(3 * printed[:2], correct[:2], rtol=1e-14)      # x, y: factor 3 only


def test_j2_magnitude_leo():
    """J2 at r = 7000 km: 3/2 mu J2 Re^2 / r^4 = 1.0967e-2 m/s^2 inward in the equator plane,
    twice that and outward over the pole (oblate Earth: mass deficit along the axis)."""
    ref = 1.5 * GM * EGM["j2"] * RE ** 2 / 7.0e6 ** 4
    assert ref == pytest.approx(1.0967e-2, rel=1e-4)
    eq = np.asarray(Fo.j2_acceleration(jnp.array([7.0e6, 0, 0]), GM, EGM["j2"], RE))
    po = np.asarray(Fo.j2_acceleration(jnp.array([0, 0, 7.0e6]), GM, EGM["j2"], RE))
    assert np.allclose(eq, [-ref, 0, 0], rtol=1e-14) and np.allclose(po, [0, 0, 2 * ref], rtol=1e-14)
    full = np.asarray(Fo.geopotential_acceleration(jnp.array([7.0e6, 0, 0]), C, S, GM, RE))
    assert np.linalg.norm(full - eq) < 0.01 * ref          # 4x4 minus J2: ~1e-3 of J2 at LEO


# -- third bodies -----------------------------------------------------------------------------
def test_third_body_zero_at_geocentre_and_gradient():
    rb = jnp.array([3.8e8, 1.0e7, -2.0e7])
    assert np.allclose(Fo.third_body_acceleration(jnp.zeros(3), rb, MU_MOON), 0, atol=1e-22)
    pot = lambda r: MU_MOON * (1 / jnp.linalg.norm(rb - r) - jnp.dot(r, rb) / jnp.linalg.norm(rb) ** 3)
    r = jnp.array([4.0e7, -1.0e7, 5.0e6])
    assert np.allclose(Fo.third_body_acceleration(r, rb, MU_MOON), jax.grad(pot)(r), rtol=1e-9, atol=0)


@pytest.mark.parametrize("body,mu,lo,hi", [("moon", MU_MOON, 3.0e-6, 1.1e-5), ("sun", MU_SUN, 1.5e-6, 3.6e-6)])
def test_tidal_magnitudes_at_geo(full, body, mu, lo, hi):
    """|a| at GEO against the tidal (quadrupole) approximation mu/d^3 (3 (r.e) e - r):
    between mu r/d^3 (r perpendicular to the body) and 2 mu r/d^3 (aligned), up to O(r/d).
    Lunar: 3.1e-6 .. 8.9e-6 m/s^2 (+~18 % octupole at most); solar: 1.6e-6 .. 3.5e-6 m/s^2."""
    t = full.epoch
    rb = np.asarray(full.eph.position(body, t))
    d = np.linalg.norm(rb)
    e = rb / d
    for r in _points(6, R_GEO, R_GEO, seed=2):
        a = np.asarray(Fo.third_body_acceleration(jnp.asarray(r), jnp.asarray(rb), mu))
        tidal = mu / d ** 3 * (3 * np.dot(r, e) * e - r)
        assert np.linalg.norm(a - tidal) < 2.0 * R_GEO / d * np.linalg.norm(tidal)
        assert lo < np.linalg.norm(a) < hi
    aligned = np.asarray(Fo.third_body_acceleration(jnp.asarray(R_GEO * e), jnp.asarray(rb), mu))
    assert np.linalg.norm(aligned) == pytest.approx(2 * mu * R_GEO / d ** 3, rel=2.0 * R_GEO / d)


# -- model ------------------------------------------------------------------------------------
def test_model_terms_and_frames(full):
    t = full.epoch + 4321.0
    r = jnp.array([7.0e6, 1.0e6, 2.0e6])
    terms = Fo.acceleration_terms(r, t, full)
    assert set(terms) == {"geopotential", "moon", "sun"}
    M = np.asarray(F.icrs_to_itrs(t, full.rot))
    a_f = np.asarray(Fo.geopotential_acceleration(jnp.asarray(M @ np.asarray(r)), C, S, GM, RE))
    assert np.allclose(np.asarray(terms["geopotential"]), M.T @ a_f, rtol=1e-14, atol=0)
    total = sum(np.asarray(v) for v in terms.values())
    assert np.allclose(np.asarray(Fo.perturbing_acceleration(r, t, full)), total, rtol=1e-15, atol=0)


@pytest.mark.parametrize("frm_cfg, to_cfg, shared", [
    ({"geopotential": {"degree": 4, "order": 4}}, None, ("geopotential",)),        # E8's 4x4 -> full
    ({"geopotential": "j2"}, None, ()),                                               # J2 -> full
    ({"geopotential": "j2", "third_bodies": ["sun"]}, None, ("sun",)),
    (None, {"geopotential": {"degree": 4, "order": 4}}, ("geopotential",)),         # full -> 4x4
])
def test_model_blend_evaluates_shared_terms_once_and_equals_the_blend_of_totals(eph, full, frm_cfg, to_cfg, shared):
    frm = full if frm_cfg is None else Fo.build_model(frm_cfg, EPOCH, eph)
    to = full if to_cfg is None else Fo.build_model(to_cfg, EPOCH, eph)
    assert Fo.shared_terms(frm, to) == shared
    Fo.check_blend(frm, to)
    t = full.epoch + 8765.0
    for r in _points(3, seed=5):
        for tau in (0.0, 0.37, 1.0):
            want = tau * np.asarray(Fo.perturbing_acceleration(r, t, to)) + \
                (1 - tau) * np.asarray(Fo.perturbing_acceleration(r, t, frm))
            got = np.asarray(Fo.blended_acceleration(r, t, to, frm, tau))
            assert np.allclose(got, want, rtol=1e-13, atol=1e-15 * np.linalg.norm(want))
    # each shared term is traced once: the blend's graph holds one geopotential, not two
    calls = []
    real = Fo.geopotential_acceleration
    try:
        Fo.geopotential_acceleration = lambda *a, **k: calls.append(1) or real(*a, **k)
        jax.make_jaxpr(lambda rr: Fo.blended_acceleration(rr, t, to, frm, 0.5))(jnp.asarray(_points(1)[0]))
    finally:
        Fo.geopotential_acceleration = real
    assert len(calls) == (1 if "geopotential" in shared else 1 if frm.gravity == "sh" or to.gravity == "sh" else 0)


def test_model_blend_with_different_epochs_is_refused(eph, full):
    other = Fo.build_model({"geopotential": {"degree": 4, "order": 4}}, "2021-05-10T12:00:00", eph)
    with pytest.raises(ValueError, match="pert_from: the geopotential term differs"):
        Fo.check_blend(other, full)
    Fo.check_blend(Fo.build_model({"geopotential": {"degree": 4, "order": 4}}, "2021-05-10T12:00:00"),
                   Fo.build_model({"geopotential": "j2"}, EPOCH))     # nothing shared: nothing to agree


def test_j2_model_equals_degree2_order0_model():
    a = Fo.build_model({"geopotential": "j2"}, EPOCH)
    b = Fo.build_model({"geopotential": {"degree": 2, "order": 0}}, EPOCH)
    for r in _points(4, seed=9):
        for dt in (0.0, 1e5):
            x = Fo.perturbing_acceleration(r, a.epoch + dt, a)
            y = Fo.perturbing_acceleration(r, b.epoch + dt, b)
            assert np.allclose(x, y, rtol=1e-12, atol=1e-14 * np.linalg.norm(x))


def test_j2_pole_is_frozen_cip_not_icrs_z():
    m = Fo.build_model({"geopotential": "j2"}, EPOCH)
    r = jnp.array([7.0e6, 0.0, 0.0])
    a_icrs_pole = np.asarray(Fo.j2_acceleration(r, GM, EGM["j2"], RE))
    a = np.asarray(Fo.perturbing_acceleration(r, m.epoch, m))
    assert 1e-6 < abs(a[2] / a[0]) < 1e-2 and abs(a_icrs_pole[2]) == 0.0


def test_j2_about_the_frozen_pole_equals_the_rotated_earth_fixed_form():
    """acceleration_terms evaluates J2 in ICRS about NPB's third row; the same as rotating r to
    the Earth-fixed frame, the printed formula, and back, at any Earth angle; no t-dependence."""
    m = Fo.build_model({"geopotential": "j2"}, EPOCH)
    for r in _points(4, seed=11):
        for dt in (0.0, 3.3e4, 2.0e6):
            t = m.epoch + dt
            theta = Fo.earth_angle(t, m.rot)
            rotated = Fo.to_icrs(Fo.j2_acceleration(Fo.to_itrs(r, theta, m.rot), m.gm, m.j2, m.radius),
                                 theta, m.rot)
            a = np.asarray(Fo.perturbing_acceleration(r, t, m))
            assert np.allclose(a, rotated, rtol=1e-13, atol=1e-15 * np.linalg.norm(a))
    assert np.all(np.asarray(jax.jacfwd(Fo.perturbing_acceleration, argnums=1)(r, m.epoch, m)) == 0.0)


def test_jacobians_ad_vs_finite_differences(full):
    f = jax.jit(Fo.perturbing_acceleration)
    t = full.epoch + 2.0e5
    for r in (jnp.array([7.0e6, 1.0e6, 2.0e6]), jnp.array([-2.0e7, 3.5e7, 1.0e7])):
        Jr, Jt = jax.jit(jax.jacfwd(Fo.perturbing_acceleration, argnums=(0, 1)))(r, t, full)
        h = 10.0
        fd = np.stack([(np.asarray(f(r + h * e, t, full)) - np.asarray(f(r - h * e, t, full))) / (2 * h)
                       for e in np.eye(3)], axis=1)
        assert np.max(np.abs(np.asarray(Jr) - fd)) < 1e-6 * np.max(np.abs(np.asarray(Jr)))
        ht = 8.0
        fdt = (np.asarray(f(r, t + ht, full)) - np.asarray(f(r, t - ht, full))) / (2 * ht)
        assert np.linalg.norm(np.asarray(Jt) - fdt) < 1e-5 * np.linalg.norm(np.asarray(Jt))


def test_forward_over_reverse_matches_differences_of_gradient(full):
    """The solver's pattern: jvp of grad (Hessian-vector product; third derivative of U for the
    geopotential part) equals a central difference of the reverse-mode gradient."""
    w = jnp.array([0.3, -1.2, 0.7])

    def h(y, m):              # y = (r, t), a scalar like a Hamiltonian's perturbation term
        return jnp.dot(w, Fo.perturbing_acceleration(y[:3], y[3], m))

    y = jnp.array([2.0e7, -1.0e7, 3.0e6, full.epoch + 5.0e4])
    v = jnp.array([1.0, 2.0, -1.0, 3.0])
    grad = jax.jit(jax.grad(h))
    hvp = jax.jit(lambda y, v, m: jax.jvp(lambda q: jax.grad(h)(q, m), (y,), (v,))[1])
    got = np.asarray(hvp(y, v, full))
    eps = 4.0
    fd = (np.asarray(grad(y + eps * v, full)) - np.asarray(grad(y - eps * v, full))) / (2 * eps)
    assert np.linalg.norm(got - fd) < 1e-6 * np.linalg.norm(got)


def test_model_is_pytree_argument(full):
    r = jnp.array([7.0e6, 1.0e6, 2.0e6])
    f = jax.jit(Fo.perturbing_acceleration)
    t = jnp.float64(full.epoch + 10.0)
    assert np.allclose(f(r, t, full), Fo.perturbing_acceleration(r, t, full), rtol=1e-11, atol=0)
    vm = jax.vmap(f, in_axes=(0, None, None))(jnp.stack([r, 2 * r]), t, full)
    assert vm.shape == (2, 3)


def test_model_from_artifact_path(tmp_path, full):
    w = E.extract_window("2021-04-25", "2021-08-15", "may2021")
    E.save_window(w, tmp_path / "may2021.json", {})
    m = Fo.build_model({"third_bodies": ["sun"]}, EPOCH, tmp_path / "may2021.json")
    r = jnp.array([R_GEO, 0.0, 0.0])
    assert np.allclose(Fo.perturbing_acceleration(r, m.epoch, m),
                       Fo.acceleration_terms(r, full.epoch, full)["sun"], rtol=1e-14, atol=0)


def test_null_model_is_zero():
    m = Fo.build_model({"geopotential": None, "third_bodies": []}, EPOCH)
    assert np.all(np.asarray(Fo.perturbing_acceleration(jnp.ones(3) * 7e6, m.epoch, m)) == 0.0)


@pytest.mark.parametrize("cfg,key", [
    ({"geopotential": "j3"}, "perturbations.geopotential"),
    ({"geopotential": {"degree": 5, "order": 5}}, "perturbations.geopotential.degree"),
    ({"geopotential": {"degree": 4, "order": 5}}, "perturbations.geopotential.order"),
    ({"geopotential": {"degree": 4, "orders": 4}}, "perturbations.geopotential.orders"),
    ({"third_bodies": ["moon", "mars"]}, "perturbations.third_bodies"),
    ({"third_bodies": "moon"}, "perturbations.third_bodies"),
    ({"drag": True}, "perturbations.drag"),
    ({"earth_angle": "gmst"}, "perturbations.earth_angle"),
])
def test_config_errors_name_key_and_value(cfg, key):
    with pytest.raises(ConfigError) as exc:
        Fo.build_model(cfg, EPOCH)
    assert exc.value.key == key
    assert str(exc.value).startswith(key + "=")


def test_third_bodies_need_ephemeris_covering_epoch(eph):
    with pytest.raises(ConfigError, match="needs an ephemeris"):
        Fo.build_model({"third_bodies": ["moon"]}, EPOCH)
    with pytest.raises(ConfigError, match="perturbations.epoch='2022-01-01"):
        Fo.build_model({"third_bodies": ["moon"]}, "2022-01-01T00:00:00", eph)


def test_models_for_other_dates_reuse_the_compiled_function(eph):
    """E6 solves 31 departure dates: the epoch must be data, not a compile-time constant."""
    traces = []

    @jax.jit
    def f(r, t, m):
        traces.append(1)
        return Fo.perturbing_acceleration(r, t, m)

    cfg = {"geopotential": "j2", "third_bodies": ["moon", "sun"]}
    r = jnp.array([R_GEO, 0.0, 0.0])
    outs = []
    for day in ("2021-05-01T12:00:00", "2021-05-02T12:00:00"):
        m = Fo.build_model(cfg, day, eph)
        outs.append(np.asarray(f(r, m.epoch, m)))
    assert len(traces) == 1
    assert not np.allclose(outs[0], outs[1])
