"""ICRS -> ITRS with frozen NPB: JAX Earth angle vs pyerfa, dM/dt by AD vs finite differences."""
import erfa
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from spaceopt import ephemeris as E
from spaceopt import frames as F
from spaceopt.errors import ConfigError

EPOCH = "2021-05-09T12:00:00"
K = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])     # [e_z]x


@pytest.fixture(scope="module", params=["era", "gast"])
def rot(request):
    return F.earth_rotation(EPOCH, request.param)


def test_omega_earth():
    assert F.OMEGA_EARTH == pytest.approx(7.292115146706979e-5, rel=1e-15)


@pytest.mark.parametrize("days", [0.0, 0.37, 5.0, 61.0, 330.0])
def test_matrix_matches_erfa_assembly(rot, days):
    t = float(rot.epoch) + days * 86400.0
    M = np.asarray(F.icrs_to_itrs(t, rot))
    assert np.max(np.abs(M - F.erfa_reference_matrix(t, rot))) < 1e-13
    assert np.max(np.abs(M @ M.T - np.eye(3))) < 1e-15


@pytest.mark.parametrize("days", [0.0, 5.0, 330.0])
def test_elementwise_rotation_equals_matrix(rot, days):
    """to_itrs / to_icrs (what the forces use, no 3x3 product) = M v and M^T v, with derivatives."""
    t = jnp.float64(float(rot.epoch) + days * 86400.0)
    v = jnp.array([7.1e6, -3.2e6, 1.9e6])
    M = F.icrs_to_itrs(t, rot)
    th = F.earth_angle(t, rot)
    assert np.allclose(F.to_itrs(v, th, rot), M @ v, rtol=0, atol=1e-15 * 8e6)
    assert np.allclose(F.to_icrs(v, th, rot), M.T @ v, rtol=0, atol=1e-15 * 8e6)
    assert np.allclose(F.to_icrs(F.to_itrs(v, th, rot), th, rot), v, rtol=0, atol=1e-15 * 8e6)
    d_el = jax.jacfwd(lambda tt: F.to_itrs(v, F.earth_angle(tt, rot), rot))(t)
    d_mat = jax.jacfwd(lambda tt: F.icrs_to_itrs(tt, rot) @ v)(t)
    assert np.allclose(d_el, d_mat, rtol=1e-13, atol=0)


def test_epoch_matrix_equals_full_sofa_chain():
    """At t0 both options equal SOFA's full ICRS->ITRS (xp = yp = 0) up to the TIO locator s'
    (-47 microarcsec/century * T = 4.9e-11 rad in 2021), which the frozen model drops."""
    s = E.utc_to_scales(EPOCH)
    ut1 = erfa.utcut1(*s["utc"], 0.0)
    ref = erfa.c2t06a(*s["tt"], *ut1, 0.0, 0.0)
    for method in F.METHODS:
        rot = F.earth_rotation(EPOCH, method)
        diff = np.max(np.abs(np.asarray(F.icrs_to_itrs(rot.epoch, rot)) - ref))
        assert 1e-11 < diff < 1e-10
        sp = erfa.sp00(*s["tt"])
        ref_no_sp = erfa.rz(-sp, ref)         # remove s' (rz: frame rotation about z)
        assert np.max(np.abs(np.asarray(F.icrs_to_itrs(rot.epoch, rot)) - ref_no_sp)) < 1e-13


def test_era_matches_erfa_era00():
    rot = F.earth_rotation(EPOCH, "era")
    for dt in np.linspace(-20, 100, 37) * 86400.0 + 12345.678:
        t = float(rot.epoch) + dt
        theta = float(F.earth_angle(t, rot))
        ref = erfa.era00(E.J2000_JD, (t - float(rot.tdb_minus_ut1_s)) / 86400.0)
        assert abs(np.angle(np.exp(1j * (theta - ref)))) < 1e-12


def test_gast_at_epoch_matches_erfa_gst06a():
    rot = F.earth_rotation(EPOCH, "gast")
    s = E.utc_to_scales(EPOCH)
    ref = erfa.gst06a(*erfa.utcut1(*s["utc"], 0.0), *s["tt"])
    assert abs(float(F.earth_angle(rot.epoch, rot)) - ref) < 1e-12


def test_ut1_option_shifts_angle():
    r0 = F.earth_rotation(EPOCH, "era", 0.0)
    r1 = F.earth_rotation(EPOCH, "era", 0.3)
    d = float(F.earth_angle(r1.epoch, r1) - F.earth_angle(r0.epoch, r0))
    assert d == pytest.approx(0.3 * F.OMEGA_EARTH, rel=1e-6)


def test_rate_by_ad_equals_finite_difference_and_omega_cross_m(rot):
    t = float(rot.epoch) + 3.7e5
    dM = np.asarray(F.icrs_to_itrs_rate(t, rot))
    h = 2.0
    fd = (np.asarray(F.icrs_to_itrs(t + h, rot)) - np.asarray(F.icrs_to_itrs(t - h, rot))) / (2 * h)
    assert np.max(np.abs(dM - fd)) < 1e-7 * np.max(np.abs(dM))
    M = np.asarray(F.icrs_to_itrs(t, rot))
    omega = F.OMEGA_EARTH
    if rot.method == "gast":     # + d(GMST - ERA)/dt: general precession in RA, ~4612.157"/cy
        tc = (t - float(rot.tdb_minus_tt_s)) / (36525 * 86400.0)
        omega += (4612.156534 + 2 * 1.3915817 * tc) * np.pi / 648000.0 / (36525 * 86400.0)
    assert np.max(np.abs(dM + omega * K @ M)) < 1e-18          # dM/dt = -omega [e_z]x M


def test_rate_jit_and_reverse_mode(rot):
    t = jnp.float64(float(rot.epoch) + 100.0)
    f = jax.jit(F.icrs_to_itrs_rate)
    # XLA may turn /86400 into *(1/86400): one ulp of the UT1 day count (~1e-12 d at 2021),
    # i.e. ~6e-12 rad in theta, the same size as the resolution of t itself (1.2e-7 s).
    assert np.allclose(f(t, rot), F.icrs_to_itrs_rate(t, rot), rtol=0, atol=1e-15)
    g = jax.grad(lambda s: F.icrs_to_itrs(s, rot)[0, 1])(t)
    assert float(g) == pytest.approx(float(F.icrs_to_itrs_rate(t, rot)[0, 1]), rel=1e-12)


def test_era_vs_gast_drift_is_precession_in_ra():
    """Same M(t0); afterwards GAST adds ~0.126"/day of spurious rotation (module docstring)."""
    a, b = F.earth_rotation(EPOCH, "era"), F.earth_rotation(EPOCH, "gast")
    t0 = float(a.epoch)
    assert np.max(np.abs(np.asarray(F.icrs_to_itrs(t0, a) - F.icrs_to_itrs(t0, b)))) < 1e-13
    t = t0 + 330 * 86400.0
    D = np.asarray(F.icrs_to_itrs(t, b)) @ np.asarray(F.icrs_to_itrs(t, a)).T    # = R3(delta)
    delta = np.arctan2(D[0, 1], D[0, 0])
    assert delta == pytest.approx(4612.156534 * 330 / 36525 * np.pi / 648000, rel=0.01)


def test_pole_is_frozen_cip():
    rot = F.earth_rotation(EPOCH, "era")
    z = np.asarray(F.icrs_to_itrs(float(rot.epoch) + 50 * 86400, rot))[2]
    tilt = np.degrees(np.arccos(z[2]))
    assert 0.05 < tilt < 0.15                       # ~0.1 deg of precession since J2000


@pytest.mark.parametrize("kwargs,key", [({"method": "gmst"}, "frame.earth_angle"),
                                        ({"ut1_minus_utc": 2.0}, "frame.ut1_minus_utc"),
                                        ({"ut1_minus_utc": "x"}, "frame.ut1_minus_utc")])
def test_bad_options(kwargs, key):
    with pytest.raises(ConfigError, match=key):
        F.earth_rotation(EPOCH, **kwargs)
