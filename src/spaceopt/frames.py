"""ICRS -> ITRS rotation with precession-nutation frozen at the initial epoch, in JAX.

Source: spec/01-methods.md §1.7 (the matrix M and dM/dt from IAU SOFA) and §6 item 11;
spec/02-multirev.md §1 "Perturbation model": precession and nutation are frozen at the initial
epoch t0 and polar motion is the identity, so

    M(t) = R3(theta(t)) . NPB(t0),       r_ITRS = M(t) r_ICRS,

with R3(a) = [[cos a, sin a, 0], [-sin a, cos a, 0], [0, 0, 1]] (SOFA's ``rz`` frame rotation).
dM/dt = -omega(t) [e_z]x M(t) (omega = dtheta/dt) is *not* hand-coded: ``icrs_to_itrs_rate``
is ``jax.jacfwd`` of ``icrs_to_itrs``, which replaces the thesis's complex-dual M + eps_7 dM/dt.

Two choices of the Earth angle theta (the thesis does not say which; spec §6 item 11):

* ``"era"`` (default): the Earth rotation angle, IAU 2000 (``erfa.era00``),
      theta = 2 pi (frac(D_U) + 0.7790572732640 + 0.00273781191135448 D_U),
  D_U = JD(UT1) - 2451545.0, paired with the CIO-based celestial-to-intermediate matrix
  NPB(t0) = ``erfa.c2i06a``(TT(t0)) (bias-precession-nutation + CIO locator s).
* ``"gast"``: Greenwich apparent sidereal time = GMST (IAU 2006, ``erfa.gmst06``: ERA plus a
  polynomial in TT centuries) + equation of the equinoxes frozen at t0 (``erfa.ee06a``), paired
  with the equinox-based matrix NPB(t0) = ``erfa.pnm06a``(TT(t0)).

Both give the same M(t0) to round-off (GAST = ERA - EO by construction, and the two NPB matrices
differ by R3(EO)). They differ for t != t0: GAST's rate includes the general precession in right
ascension (about 4612"/century = 0.126"/day, ~6.1e-7 rad/day) which, with NPB frozen, is a
spurious extra rotation of the frozen frame; after 330 days the two M differ by ~2e-4 rad about
the pole. ERA is the physical rotation about the (frozen) CIP, so it is the default. For a 4x4
field the difference is negligible, as spec §6 item 11 notes.

Time arguments: t is seconds TDB past J2000 (JD 2451545.0 TDB), the convention of
:mod:`spaceopt.ephemeris`. UT1 and TT for theta(t) follow from t by constant offsets fixed at the
epoch: UT1 = t - (TDB - UT1)(t0), TT = t - (TDB - TT)(t0). Neglected: the periodic part of
TDB - TT (<= 1.7 ms, i.e. <= 1.2e-7 rad in theta) and any leap second inside the window (none
between 1999-01-01 and 2006-01-01, none since 2017-01-01 as far as announced; the configured
windows lie inside these spans; a leap second would shift theta by 7.3e-5 rad).
UT1 - UTC defaults to 0 (option ``ut1_minus_utc``, seconds; |UT1-UTC| < 0.9 s, i.e.
< 6.6e-5 rad). Polar motion (xp, yp) and the TIO locator s' (~5e-11 rad in 2021) are set to
zero (identity polar-motion matrix, as in the thesis). ICRS and GCRS axes are
identified (geocentric vectors).

Why hand-written: pyerfa is numpy-only and not differentiable; it is used once at t0 (matrix and
time offsets), and theta(t) is re-implemented analytically in ``jax.numpy`` (tested against
``erfa.era00``/``erfa.gst06a``) so that dM/dt comes from JAX.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import erfa
import jax
import jax.numpy as jnp
import numpy as np

from .constants import DAY
from .ephemeris import J2000_JD, utc_to_scales, utc_to_tdb_seconds
from .errors import ConfigError

METHODS = ("era", "gast")
ERA_RATE = 1.00273781191135448          # ERA turns per UT1 day (IAU 2000)
OMEGA_EARTH = 2.0 * math.pi * ERA_RATE / DAY   # rad/s (7.292115146706979e-5)
_AS2R = math.pi / (180.0 * 3600.0)
_JC_S = 36525.0 * DAY                  # s per Julian century


@jax.tree_util.register_pytree_node_class
@dataclass(frozen=True, eq=False)
class EarthRotation:
    """Frozen-NPB Earth orientation; a JAX pytree.

    Leaves: ``npb`` (3x3, NPB(t0)), ``tdb_minus_ut1_s`` and ``tdb_minus_tt_s`` (constant offsets
    at t0, s), ``ee0`` (equation of the equinoxes at t0, rad; used by GAST only), ``epoch`` (t0,
    s TDB past J2000). Static: ``method`` in {"era", "gast"}.
    """
    npb: jax.Array
    tdb_minus_ut1_s: jax.Array
    tdb_minus_tt_s: jax.Array
    ee0: jax.Array
    epoch: jax.Array
    method: str = "era"

    def tree_flatten(self):
        return (self.npb, self.tdb_minus_ut1_s, self.tdb_minus_tt_s, self.ee0, self.epoch), (self.method,)

    @classmethod
    def tree_unflatten(cls, aux, leaves):
        return cls(*leaves, *aux)


def earth_rotation(epoch_utc: str, method: str = "era", ut1_minus_utc: float = 0.0,
                   key: str = "frame") -> EarthRotation:
    """Build the frozen-NPB model at the epoch given as a UTC string (pyerfa, prep time).

    method: "era" (default) or "gast"; ut1_minus_utc in seconds (default 0: UT1 = UTC).
    """
    if method not in METHODS:
        raise ConfigError(f"{key}.earth_angle", method, f"unknown Earth angle; expected one of {list(METHODS)}")
    try:
        dut1 = float(ut1_minus_utc)
    except (TypeError, ValueError):
        raise ConfigError(f"{key}.ut1_minus_utc", ut1_minus_utc, "expected seconds (a number)") from None
    if not abs(dut1) < 1.0:
        raise ConfigError(f"{key}.ut1_minus_utc", ut1_minus_utc, "|UT1-UTC| must be < 1 s")
    s = utc_to_scales(epoch_utc, key=f"{key}.epoch")
    tt1, tt2 = s["tt"]
    u1, u2 = s["utc"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", erfa.ErfaWarning)
        ut1_1, ut1_2 = erfa.utcut1(u1, u2, dut1)
    t_tdb = utc_to_tdb_seconds(epoch_utc, key=f"{key}.epoch")
    t_ut1 = ((ut1_1 - J2000_JD) + ut1_2) * DAY
    if method == "era":
        npb = erfa.c2i06a(tt1, tt2)
        ee0 = 0.0
    else:
        npb = erfa.pnm06a(tt1, tt2)
        ee0 = float(erfa.ee06a(tt1, tt2))
    return EarthRotation(jnp.asarray(npb, dtype=jnp.float64), jnp.float64(t_tdb - t_ut1),
                         jnp.float64(s["tdb_minus_tt_s"]), jnp.float64(ee0), jnp.float64(t_tdb),
                         method)


def earth_angle(t, rot: EarthRotation):
    """theta(t) [rad] in [0, 2 pi) (ERA or GAST, see module docstring); t in s TDB past J2000."""
    t = jnp.asarray(t, dtype=jnp.float64)
    du = (t - rot.tdb_minus_ut1_s) / DAY                        # UT1 days past J2000
    # erfa.era00 with d1 = 2451545.0, d2 = du: f = fmod(du, 1); d(mod)/dt = 1 in JAX
    turns = jnp.mod(du, 1.0) + 0.7790572732640 + 0.00273781191135448 * du
    theta = 2.0 * jnp.pi * turns
    if rot.method == "gast":
        tc = (t - rot.tdb_minus_tt_s) / _JC_S                    # TT Julian centuries past J2000
        poly = 0.014506 + (4612.156534 + (1.3915817 + (-0.00000044 + (-0.000029956
                            + (-0.0000000368) * tc) * tc) * tc) * tc) * tc           # erfa.gmst06
        theta = theta + poly * _AS2R + rot.ee0
    return jnp.mod(theta, 2.0 * jnp.pi)


def rot3(a):
    """SOFA-style frame rotation about z: R3(a) = [[c, s, 0], [-s, c, 0], [0, 0, 1]]."""
    c, s = jnp.cos(a), jnp.sin(a)
    z, o = jnp.zeros_like(a), jnp.ones_like(a)
    return jnp.stack([jnp.stack([c, s, z]), jnp.stack([-s, c, z]), jnp.stack([z, z, o])])


def icrs_to_itrs(t, rot: EarthRotation):
    """M(t) = R3(theta(t)) NPB(t0) (3x3); r_ITRS = M r_ICRS. t in s TDB past J2000."""
    return rot3(earth_angle(t, rot)) @ rot.npb


def to_itrs(v, theta, rot: EarthRotation):
    """M(t) v = R3(theta) (NPB v) without forming M: theta = :func:`earth_angle` (t).

    Same product as ``icrs_to_itrs(t, rot) @ v`` up to round-off, written elementwise: under the
    solver's nested derivatives a 3x3 matrix product is a separate (unfused) kernel per
    derivative level, and this form roughly halves the kernels of the perturbed field
    (benchmarks/perturbed.py).
    """
    N = rot.npb
    p = N[:, 0] * v[0] + N[:, 1] * v[1] + N[:, 2] * v[2]
    c, s = jnp.cos(theta), jnp.sin(theta)
    return jnp.stack([c * p[0] + s * p[1], c * p[1] - s * p[0], p[2]])


def to_icrs(v, theta, rot: EarthRotation):
    """M(t)^T v = NPB^T (R3(theta)^T v), elementwise like :func:`to_itrs`."""
    N = rot.npb
    c, s = jnp.cos(theta), jnp.sin(theta)
    b0, b1 = c * v[0] - s * v[1], s * v[0] + c * v[1]
    return N[0] * b0 + N[1] * b1 + N[2] * v[2]


def icrs_to_itrs_rate(t, rot: EarthRotation):
    """dM/dt [1/s] by forward-mode AD of :func:`icrs_to_itrs`."""
    return jax.jacfwd(icrs_to_itrs, argnums=0)(jnp.asarray(t, dtype=jnp.float64), rot)


def erfa_reference_matrix(t, rot: EarthRotation) -> np.ndarray:
    """Reference M(t) assembled with pyerfa only (for tests): erfa.c2tcio / era00 or gst06."""
    t = float(t)
    ut1 = (J2000_JD, (t - float(rot.tdb_minus_ut1_s)) / DAY)
    tt = (J2000_JD, (t - float(rot.tdb_minus_tt_s)) / DAY)
    npb = np.asarray(rot.npb)
    if rot.method == "era":
        theta = erfa.era00(*ut1)
    else:
        theta = erfa.gmst06(*ut1, *tt) + float(rot.ee0)
    return erfa.c2tcio(npb, theta, np.eye(3))
