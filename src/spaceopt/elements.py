"""Orbital element conversions: Kepler <-> modified equinoctial (MEE) <-> Cartesian.

MEE are Walker's (p, f, g, h, k, L), written here as in the dissertation (spec 01-methods §0):

    e_x = e cos(ω+Ω),  e_y = e sin(ω+Ω),  i_x = tan(i/2) cos Ω,  i_y = tan(i/2) sin Ω,
    L = ν + ω + Ω,     p = a (1 - e²).

MEE -> Cartesian is the Walker form of Appendix B.1 (spec 01-methods §4); the inverse uses the
angular-momentum vector σ = r × v: p = σ²/μ, i_x = -σ_y/(σ + σ_z), i_y = σ_x/(σ + σ_z), then the
eccentricity vector projected on the equinoctial frame. All functions work on numpy or JAX
arrays (jax.numpy), so they can sit inside the solver and be differentiated.
"""
from __future__ import annotations

import jax.numpy as jnp
import numpy as np


def kepler_to_mee(a, e, i, raan, argp, nu):
    """Kepler (a, e, i, Ω, ω, ν) with angles in radians -> MEE (p, e_x, e_y, i_x, i_y, L)."""
    lon_peri = argp + raan
    t = jnp.tan(i / 2.0)
    return jnp.stack([a * (1.0 - e**2), e * jnp.cos(lon_peri), e * jnp.sin(lon_peri),
                      t * jnp.cos(raan), t * jnp.sin(raan), nu + lon_peri])


def mee_to_kepler(mee):
    """MEE -> Kepler (a, e, i, Ω, ω, ν); angles in radians, Ω, ω, ν wrapped to [0, 2π)."""
    p, ex, ey, ix, iy, L = mee
    e = jnp.hypot(ex, ey)
    a = p / (1.0 - e**2)
    i = 2.0 * jnp.arctan(jnp.hypot(ix, iy))
    raan = jnp.mod(jnp.arctan2(iy, ix), 2 * jnp.pi)
    lon_peri = jnp.arctan2(ey, ex)
    argp = jnp.mod(lon_peri - raan, 2 * jnp.pi)
    nu = jnp.mod(L - lon_peri, 2 * jnp.pi)
    return jnp.stack([a, e, i, raan, argp, nu])


def mee_to_cartesian(mee, mu):
    """MEE -> (r, v), Walker form (dissertation Appendix B.1)."""
    p, ex, ey, ix, iy, L = mee
    cL, sL = jnp.cos(L), jnp.sin(L)
    alpha2 = ix**2 - iy**2
    s2 = 1.0 + ix**2 + iy**2
    q = 1.0 + ex * cL + ey * sL
    r = p / q
    pos = (r / s2) * jnp.stack([cL + alpha2 * cL + 2 * ix * iy * sL,
                                sL - alpha2 * sL + 2 * ix * iy * cL,
                                2 * (ix * sL - iy * cL)])
    sq = jnp.sqrt(mu / p) / s2
    vel = sq * jnp.stack([-(sL + alpha2 * sL - 2 * ix * iy * cL + ey - 2 * ex * ix * iy + alpha2 * ey),
                          -(-cL + alpha2 * cL + 2 * ix * iy * sL - ex + 2 * ey * ix * iy + alpha2 * ex),
                          2 * (ix * cL + iy * sL + ex * ix + ey * iy)])
    return pos, vel


def cartesian_to_mee(pos, vel, mu):
    """(r, v) -> MEE with L continuous in (-π, π]; valid for prograde, non-equatorial-retrograde orbits."""
    h = jnp.cross(pos, vel)
    hn = jnp.linalg.norm(h)
    p = hn**2 / mu
    ix = -h[1] / (hn + h[2])
    iy = h[0] / (hn + h[2])
    s2 = 1.0 + ix**2 + iy**2
    # equinoctial frame unit vectors f (towards the equinoctial x axis) and g
    f_hat = jnp.stack([1 + ix**2 - iy**2, 2 * ix * iy, -2 * iy]) / s2
    g_hat = jnp.stack([2 * ix * iy, 1 - ix**2 + iy**2, 2 * ix]) / s2
    rn = jnp.linalg.norm(pos)
    e_vec = jnp.cross(vel, h) / mu - pos / rn
    ex = jnp.dot(e_vec, f_hat)
    ey = jnp.dot(e_vec, g_hat)
    L = jnp.arctan2(jnp.dot(pos, g_hat), jnp.dot(pos, f_hat))
    return jnp.stack([p, ex, ey, ix, iy, L])


def apsides_to_ae(h_peri, h_apo, radius):
    """Perigee/apogee altitudes above ``radius`` -> (a, e)."""
    rp, ra = radius + h_peri, radius + h_apo
    return 0.5 * (rp + ra), (ra - rp) / (ra + rp)


def wrap_angle(x):
    """Wrap to (-π, π]."""
    return np.angle(np.exp(1j * np.asarray(x)))
