"""Element conversions round-trip (property-based)."""
import math

import jax
import numpy as np
from hypothesis import given, settings, strategies as st

from spaceopt.elements import cartesian_to_mee, kepler_to_mee, mee_to_cartesian, mee_to_kepler

angles = st.floats(0.0, 2 * math.pi - 1e-6)
MU = 3.986004418e14


@jax.jit
def _round_trip(a, e, i, raan, argp, nu):
    mee = kepler_to_mee(a, e, i, raan, argp, nu)
    r, v = mee_to_cartesian(mee, MU)
    back = cartesian_to_mee(r, v, MU)
    return mee, r, v, back, mee_to_kepler(back)


@settings(max_examples=60, deadline=None)
@given(a=st.floats(6.6e6, 5e8), e=st.floats(0.0, 0.97), i=st.floats(0.01, math.pi * 0.9),
       raan=angles, argp=angles, nu=angles)
def test_kepler_mee_cartesian_round_trip(a, e, i, raan, argp, nu):
    mu = MU
    mee, r, v, back, kep = (np.asarray(t) for t in _round_trip(a, e, i, raan, argp, nu))
    # vis-viva and angular momentum are consistent with (a, e)
    rn, vn = np.linalg.norm(r), np.linalg.norm(v)
    assert math.isclose(vn**2 / 2 - mu / rn, -mu / (2 * a), rel_tol=1e-9)
    np.testing.assert_allclose(back[:5], mee[:5], rtol=1e-9, atol=1e-10)
    assert abs(math.remainder(back[5] - mee[5], 2 * math.pi)) < 1e-9
    assert math.isclose(kep[0], a, rel_tol=1e-9)
    assert math.isclose(kep[1], e, abs_tol=1e-9)
    assert math.isclose(kep[2], i, abs_tol=1e-9)


def test_circular_equatorial_velocity_is_circular_speed():
    mu, a = 3.986e14, 4.2164e7
    r, v = mee_to_cartesian(np.asarray(kepler_to_mee(a, 0.0, 0.0, 0.0, 0.0, 0.3)), mu)
    assert math.isclose(float(np.linalg.norm(v)), math.sqrt(mu / a), rel_tol=1e-12)
    assert abs(float(np.dot(np.asarray(r), np.asarray(v)))) < 1e-3
