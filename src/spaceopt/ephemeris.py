"""Geocentric Moon and Sun from JPL DE405, evaluated in JAX and differentiable in time.

Source: spec/01-methods.md §1.7 (computation chain, step 1) and §7 ("Ephemerides and frames");
spec/02-multirev.md §1 ("Perturbation model", "Time"). The thesis takes the Moon (l=1) and Sun
(l=2) position r_l and velocity v_l in ICRS from DE405 and carries them as complex-dual numbers
r_l + eps_7 v_l (slot 7 = the time state). Here the position is a pure ``jax.numpy`` function of
t and the velocity is its derivative by AD (``jax.jacfwd``), which replaces the dual number.

Time convention (one for the whole physics layer: ephemeris, frames, forces)
---------------------------------------------------------------------------
``t`` is **seconds of TDB since the J2000 epoch JD 2451545.0 TDB** (2000-01-01 12:00:00 TDB),
float64. Its resolution at 2021 (t ~ 6.7e8 s) is ~1e-7 s, i.e. 0.1 mm of lunar motion. A solver
that carries time from departure adds the epoch: ``t = t0 + t_rel`` with
``t0 = utc_to_tdb_seconds("2021-05-09T12:00:00")``.

Time scales (spec/02-multirev.md §1 "Time": dates are UTC, the scales are not stated)
-------------------------------------------------------------------------------------
UTC -> TAI -> TT -> TDB with pyerfa: ``erfa.dtf2d("UTC", ...)`` (quasi-JD that handles leap
seconds), ``erfa.utctai``, ``erfa.taitt``, then TDB = TT + ``erfa.dtdb`` for a geocentric observer
(u = v = 0; the periodic TDB-TT term has amplitude ~1.66 ms).

Data and evaluation
-------------------
DE405 (PyPI package ``de405``, read with ``jplephem.ephem.Ephemeris``) stores, per body, Chebyshev
coefficients in km over fixed granules of ``days`` TDB days starting at JD ``jalpha``:
  * ``moon``: geocentric Moon, 4-day granules, 13 coefficients per axis;
  * ``earthmoon``: Earth-Moon barycentre (EMB) w.r.t. the solar-system barycentre, 16 days, 13;
  * ``sun``: Sun w.r.t. the solar-system barycentre, 16 days, 11.
Geocentric Sun = Sun - Earth with Earth = EMB - Moon/(1+EMRAT), hence
    r_sun_geo(t) = [Sun - EMB](t) + Moon(t)/(1+EMRAT).
``Sun - EMB`` has identical granule boundaries in both series, so it is stored as one series
(coefficients subtracted, Sun's 11 padded with zeros to 13); the Moon term is added at evaluation.
On granule k with start s_k and length D, x = 2 (t - s_k)/D - 1 in [-1, 1] and
    r(t) = sum_j c_kj T_j(x),  T_0 = 1, T_1 = x, T_{j+1} = 2x T_j - T_{j-1},
the T_j by the scalar recurrence and the sum as one contraction (jplephem's own order, so the
two agree to ~3e-16). Clenshaw's recurrence gives the same numbers but about twice as many
primitives, which slows the compilation of the solver's nested derivatives. The granule index
is piecewise constant, so d/dt acts only through x (velocity = 2/D * sum c_kj T_j'(x)).
Axes: DE405's native ICRF axes (= EME2000/ICRS to ~0.01"), geocentric.

Why hand-written: jplephem evaluates in numpy only, so it is neither traceable by ``jax.jit`` nor
differentiable; the series evaluation is twenty lines of ``jax.numpy``. jplephem stays the
reference in the tests (agreement to round-off).

Window artifacts: ``extract_window`` cuts the granules covering a requested UTC window; the prep
step writes them with ``save_window`` (NPZ: coefficients in km, granule starts as JD TDB, granule
length in days, exactly as stored by DE405; JSON: metadata + provenance); ``load_ephemeris`` turns
the artifact into a :class:`ChebyshevEphemeris` (a JAX pytree).

Outside the window: a concrete time raises :class:`~spaceopt.errors.ConfigError` naming the date;
inside ``jit`` (no Python check possible) the position is NaN, which poisons a propagation instead
of silently extrapolating.
"""
from __future__ import annotations

import re
import warnings
from dataclasses import dataclass
from importlib import metadata

import erfa
import jax
import jax.numpy as jnp
import numpy as np

from .constants import DAY
from .errors import ConfigError

J2000_JD = 2451545.0          # JD of the J2000 epoch (TDB)

BODIES = ("moon", "sun")
SERIES = ("moon", "sun_emb")  # stored Chebyshev series (see module docstring)

_DATE_RE = re.compile(r"^\s*(\d{4})-(\d{2})-(\d{2})(?:[T ](\d{2}):(\d{2})(?::(\d{2}(?:\.\d*)?))?)?\s*(?:UTC|Z)?\s*$")


# --------------------------------------------------------------------------------------------
# Time scales (numpy / pyerfa, prep time only)
# --------------------------------------------------------------------------------------------
def _parse_utc(utc: str, key: str = "epoch"):
    m = _DATE_RE.match(str(utc))
    if not m:
        raise ConfigError(key, utc, "expected a UTC date 'YYYY-MM-DD' or 'YYYY-MM-DDTHH:MM:SS'")
    y, mo, d = int(m[1]), int(m[2]), int(m[3])
    hh = int(m[4]) if m[4] else 0
    mi = int(m[5]) if m[5] else 0
    ss = float(m[6]) if m[6] else 0.0
    return y, mo, d, hh, mi, ss


def utc_to_jd(utc: str, key: str = "epoch"):
    """UTC calendar string -> two-part UTC quasi-JD (erfa.dtf2d convention)."""
    y, mo, d, hh, mi, ss = _parse_utc(utc, key)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", erfa.ErfaWarning)
            u1, u2 = erfa.dtf2d("UTC", y, mo, d, hh, mi, ss)
    except (erfa.ErfaError, ValueError) as exc:
        raise ConfigError(key, utc, f"invalid UTC date ({exc})") from None
    return float(u1), float(u2)


def utc_to_scales(utc: str, key: str = "epoch") -> dict:
    """UTC string -> dict of two-part JDs ``utc``, ``tai``, ``tt`` and ``tdb_minus_tt_s``."""
    u1, u2 = utc_to_jd(utc, key)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", erfa.ErfaWarning)   # "dubious year" far from today
        a1, a2 = erfa.utctai(u1, u2)
        t1, t2 = erfa.taitt(a1, a2)
    ut_frac = ((u1 - 0.5) % 1.0 + u2 % 1.0) % 1.0        # only used by topocentric terms (u=v=0)
    dtdb = float(erfa.dtdb(t1, t2, ut_frac, 0.0, 0.0, 0.0))
    return {"utc": (u1, u2), "tai": (float(a1), float(a2)), "tt": (float(t1), float(t2)),
            "tdb_minus_tt_s": dtdb}


def utc_to_tdb_seconds(utc: str, key: str = "epoch") -> float:
    """UTC calendar string (e.g. ``"2021-05-09T12:00:00"``) -> solver time t [s TDB past J2000].

    UTC -> TAI -> TT (pyerfa) and TDB = TT + erfa.dtdb (geocentre). This is the solver epoch.
    """
    s = utc_to_scales(utc, key)
    t1, t2 = s["tt"]
    return ((t1 - J2000_JD) + t2) * DAY + s["tdb_minus_tt_s"]


def tdb_seconds_to_jd(t: float):
    """t [s TDB past J2000] -> two-part JD TDB (J2000_JD, days)."""
    return J2000_JD, float(t) / DAY


def tdb_seconds_to_iso(t: float) -> str:
    """Calendar label of t [s TDB past J2000], e.g. '2021-05-09T12:01:09.184 TDB' (for messages)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", erfa.ErfaWarning)
        y, mo, d, f = erfa.d2dtf("TDB", 3, *tdb_seconds_to_jd(t))
    return f"{int(y):04d}-{int(mo):02d}-{int(d):02d}T{f[0]:02d}:{f[1]:02d}:{f[2]:02d}.{f[3]:03d} TDB"


# --------------------------------------------------------------------------------------------
# DE405 window extraction (numpy, prep time only)
# --------------------------------------------------------------------------------------------
def open_de405():
    """The DE405 ``jplephem.ephem.Ephemeris`` (module-based loader of the PyPI ``de405`` data)."""
    import de405
    from jplephem.ephem import Ephemeris
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # jplephem.ephem is flagged deprecated, still the reader
        return Ephemeris(de405)


def check_in_de405(utc: str, key: str, eph=None) -> None:
    """ConfigError naming ``key`` and the date when the UTC date lies outside DE405."""
    eph = eph if eph is not None else open_de405()
    jd = J2000_JD + utc_to_tdb_seconds(utc, key) / DAY
    jalpha, jomega = float(eph.jalpha), float(eph.jomega)
    if not jalpha <= jd < jomega:
        raise ConfigError(key, utc, f"outside DE405 (JD {jalpha} to {jomega} TDB)")


def _granule_slice(n_sets: int, jalpha: float, days: float, jd_lo: float, jd_hi: float):
    k0 = int(np.floor((jd_lo - jalpha) / days))
    k1 = int(np.floor((jd_hi - jalpha) / days))     # granule holding jd_hi
    return k0, min(k1, n_sets - 1) + 1


def extract_window(start_utc: str, end_utc: str, name: str = "window", eph=None) -> dict:
    """Cut the DE405 granules covering [start_utc, end_utc] (UTC dates) for Moon and Sun.

    Returns a dict with numpy arrays (the NPZ content) and a ``meta`` dict (the JSON content).
    Arrays: ``<s>_coef`` (n_granules, 3, n_coef) km, ``<s>_jd0`` (n_granules,) granule start JD
    TDB, ``<s>_days`` granule length in days, for s in SERIES; ``emrat``.
    """
    eph = eph if eph is not None else open_de405()
    t_lo = utc_to_tdb_seconds(start_utc, f"ephemeris.{name}.start")
    t_hi = utc_to_tdb_seconds(end_utc, f"ephemeris.{name}.end")
    if not t_hi > t_lo:
        raise ConfigError(f"ephemeris.{name}.end", end_utc, f"must be after start {start_utc}")
    jd_lo, jd_hi = J2000_JD + t_lo / DAY, J2000_JD + t_hi / DAY
    jalpha, jomega = float(eph.jalpha), float(eph.jomega)
    check_in_de405(start_utc, f"ephemeris.{name}.start", eph)
    check_in_de405(end_utc, f"ephemeris.{name}.end", eph)

    out = {}
    moon = np.asarray(eph.load("moon"))
    emb = np.asarray(eph.load("earthmoon"))
    sun = np.asarray(eph.load("sun"))
    d_moon = (jomega - jalpha) / moon.shape[0]
    d_big = (jomega - jalpha) / emb.shape[0]
    assert sun.shape[0] == emb.shape[0], "Sun and EMB granules differ; cannot combine"
    k0, k1 = _granule_slice(moon.shape[0], jalpha, d_moon, jd_lo, jd_hi)
    out["moon_coef"] = moon[k0:k1].copy()
    out["moon_jd0"] = jalpha + d_moon * np.arange(k0, k1, dtype=float)
    out["moon_days"] = np.float64(d_moon)
    k0, k1 = _granule_slice(emb.shape[0], jalpha, d_big, jd_lo, jd_hi)
    nc = max(sun.shape[2], emb.shape[2])
    sun_p = np.zeros((k1 - k0, 3, nc)); sun_p[:, :, :sun.shape[2]] = sun[k0:k1]
    emb_p = np.zeros((k1 - k0, 3, nc)); emb_p[:, :, :emb.shape[2]] = emb[k0:k1]
    out["sun_emb_coef"] = sun_p - emb_p
    out["sun_emb_jd0"] = jalpha + d_big * np.arange(k0, k1, dtype=float)
    out["sun_emb_days"] = np.float64(d_big)
    out["emrat"] = np.float64(eph.EMRAT)

    cov_lo = max(out["moon_jd0"][0], out["sun_emb_jd0"][0])
    cov_hi = min(out["moon_jd0"][-1] + d_moon, out["sun_emb_jd0"][-1] + d_big)
    meta = {
        "window": name,
        "requested": {"start_utc": str(start_utc), "end_utc": str(end_utc),
                      "start_tdb_s": t_lo, "end_tdb_s": t_hi},
        "coverage": {"start_jd_tdb": cov_lo, "end_jd_tdb": cov_hi,
                     "start_tdb_s": (cov_lo - J2000_JD) * DAY,
                     "end_tdb_s": (cov_hi - J2000_JD) * DAY,
                     "start_label": tdb_seconds_to_iso((cov_lo - J2000_JD) * DAY),
                     "end_label": tdb_seconds_to_iso((cov_hi - J2000_JD) * DAY)},
        "source": {"ephemeris": "JPL DE405", "reader": "jplephem.ephem.Ephemeris",
                   "de405": _version("de405"), "jplephem": _version("jplephem"),
                   "denum": float(eph.DENUM), "jalpha": jalpha, "jomega": jomega,
                   "emrat": float(eph.EMRAT), "au_km": float(eph.AU)},
        "series": {
            "moon": "geocentric Moon (DE405 body 10), as stored",
            "sun_emb": "Sun minus Earth-Moon barycentre (DE405 'sun' - 'earthmoon', coefficient-wise; "
                       "Sun padded to 13 coefficients)",
        },
        "geocentric_sun": "sun_emb(t) + moon(t)/(1+emrat)",
        "units": {"coefficients": "km", "granule_start": "JD TDB", "granule_length": "days (TDB)",
                  "evaluation_time": "s TDB past J2000 (JD 2451545.0 TDB)",
                  "evaluation_position": "m"},
        "frame": "ICRF/EME2000 axes (DE405 native), geocentric",
        "n_granules": {"moon": int(out["moon_coef"].shape[0]),
                       "sun_emb": int(out["sun_emb_coef"].shape[0])},
    }
    out["meta"] = meta
    return out


def _version(pkg):
    try:
        return metadata.version(pkg)
    except metadata.PackageNotFoundError:
        return None


def save_window(window: dict, json_path, cfg, wall_time_s=None) -> None:
    """Write a window from :func:`extract_window` as NPZ (arrays) + JSON (metadata, provenance)."""
    from pathlib import Path

    from .artifacts import provenance, write_json, write_npz
    json_path = Path(json_path)
    npz_path = json_path.with_suffix(".npz")
    write_npz(npz_path, **{k: v for k, v in window.items() if k != "meta"})
    payload = dict(window["meta"])
    payload["provenance"] = provenance(cfg, wall_time_s)
    write_json(json_path, payload, companions={"coefficients": npz_path})


def load_ephemeris(json_path) -> "ChebyshevEphemeris":
    """Read a window artifact (checksum verified) and build the JAX-evaluable ephemeris."""
    from .artifacts import read_json, read_npz
    meta = read_json(json_path)
    arrays = read_npz(json_path, role="coefficients")
    return ChebyshevEphemeris.from_arrays(arrays, name=meta.get("window", "window"))


# --------------------------------------------------------------------------------------------
# JAX evaluation
# --------------------------------------------------------------------------------------------
def chebyshev_series(coef, start_s, length_s, t):
    """Evaluate piecewise Chebyshev series at t (scalar, s).

    coef: (n_granules, 3, n_coef); granule k covers [start_s + k length_s, start_s + (k+1) length_s].
    Granule index by floor + clip (uniform granules; equivalent to searchsorted on the starts);
    the index is piecewise constant, so d/dt flows only through x. The scalar recurrence
    T_{j+1} = 2x T_j - T_{j-1} and one contraction c_k . T(x) (as jplephem sums it) keep the
    program small, which matters for the compile time of nested derivatives in the solver.
    """
    n = coef.shape[0]
    k = jnp.clip(jnp.floor((t - start_s) / length_s), 0, n - 1).astype(jnp.int32)
    seg_start = start_s + k.astype(t.dtype) * length_s          # exact: integer * whole seconds
    x = 2.0 * (t - seg_start) / length_s - 1.0
    x2 = 2.0 * x
    T = [jnp.ones_like(x), x]
    for _ in range(coef.shape[2] - 2):                            # static (13 terms)
        T.append(x2 * T[-1] - T[-2])
    return jnp.dot(coef[k], jnp.stack(T))


@jax.tree_util.register_pytree_node_class
@dataclass(frozen=True, eq=False)
class ChebyshevEphemeris:
    """Geocentric Moon and Sun over one window; a JAX pytree (pass it into jitted functions).

    Array leaves: coefficients in km, granule start in s TDB past J2000, granule length in s,
    ``earth_share`` = 1/(1+EMRAT). Static: window name and coverage [t_min, t_max] (s TDB).
    """
    moon_coef: jax.Array
    moon_start: jax.Array
    moon_len: jax.Array
    sun_emb_coef: jax.Array
    sun_emb_start: jax.Array
    sun_emb_len: jax.Array
    earth_share: jax.Array
    name: str = "window"
    t_min: float = -np.inf
    t_max: float = np.inf

    def tree_flatten(self):
        leaves = (self.moon_coef, self.moon_start, self.moon_len, self.sun_emb_coef,
                  self.sun_emb_start, self.sun_emb_len, self.earth_share)
        return leaves, (self.name, self.t_min, self.t_max)

    @classmethod
    def tree_unflatten(cls, aux, leaves):
        return cls(*leaves, *aux)

    @classmethod
    def from_arrays(cls, arrays: dict, name: str = "window") -> "ChebyshevEphemeris":
        """From the arrays of :func:`extract_window` (or the NPZ artifact)."""
        def start_s(jd0):
            return float((float(np.asarray(jd0)[0]) - J2000_JD) * DAY)   # exact (half days)
        m_len = float(arrays["moon_days"]) * DAY
        s_len = float(arrays["sun_emb_days"]) * DAY
        m0, s0 = start_s(arrays["moon_jd0"]), start_s(arrays["sun_emb_jd0"])
        nm, ns = np.asarray(arrays["moon_coef"]).shape[0], np.asarray(arrays["sun_emb_coef"]).shape[0]
        # granules must be contiguous and uniform (checked, since the lookup assumes it)
        for jd0, d in ((arrays["moon_jd0"], arrays["moon_days"]), (arrays["sun_emb_jd0"], arrays["sun_emb_days"])):
            if not np.allclose(np.diff(np.asarray(jd0)), float(d), rtol=0, atol=1e-9):
                raise ConfigError("ephemeris.granules", name, "granules not contiguous")
        return cls(jnp.asarray(arrays["moon_coef"], dtype=jnp.float64), jnp.float64(m0), jnp.float64(m_len),
                   jnp.asarray(arrays["sun_emb_coef"], dtype=jnp.float64), jnp.float64(s0), jnp.float64(s_len),
                   jnp.float64(1.0 / (1.0 + float(arrays["emrat"]))), name,
                   max(m0, s0), min(m0 + nm * m_len, s0 + ns * s_len))

    @classmethod
    def from_de405(cls, start_utc: str, end_utc: str, name: str = "window", eph=None):
        """Build directly from DE405 without an artifact (tests, interactive use)."""
        return cls.from_arrays(extract_window(start_utc, end_utc, name, eph), name)

    # -- checks -------------------------------------------------------------------------------
    def check_time(self, t, key: str = "date") -> None:
        """Raise ConfigError naming the date if a concrete t is outside the window (no-op if traced)."""
        if isinstance(t, jax.core.Tracer):
            return
        tv = np.asarray(t, dtype=float)
        bad = tv[(tv < self.t_min) | (tv > self.t_max) | ~np.isfinite(tv)]
        if bad.size:
            tb = float(bad.ravel()[0])
            label = tdb_seconds_to_iso(tb) if np.isfinite(tb) else repr(tb)
            raise ConfigError(key, label, f"outside ephemeris window {self.name!r} "
                              f"({tdb_seconds_to_iso(self.t_min)} to {tdb_seconds_to_iso(self.t_max)})")

    # -- positions ----------------------------------------------------------------------------
    def moon(self, t):
        """Geocentric Moon position [m], ICRS axes, at t [s TDB past J2000]."""
        return self.position("moon", t)

    def sun(self, t):
        """Geocentric Sun position [m], ICRS axes, at t [s TDB past J2000]."""
        return self.position("sun", t)

    def position(self, body: str, t):
        """Geocentric position [m] of ``body`` in {'moon', 'sun'} at t [s TDB past J2000].

        t: scalar (result (3,)) or 1-d array (result (n, 3)); pure JAX, usable under jit/grad."""
        _check_body(body)
        self.check_time(t)
        return _batched(_position, self, body, t)

    def velocity(self, body: str, t):
        """Geocentric velocity [m/s] = d position/dt by forward-mode AD."""
        _check_body(body)
        self.check_time(t)
        return _batched(_velocity, self, body, t)

    def positions(self, t):
        """(Moon, Sun) geocentric positions [m] sharing one Moon series evaluation."""
        self.check_time(t)
        t = jnp.asarray(t, dtype=jnp.float64)
        return _positions(self, t) if t.ndim == 0 else jax.vmap(lambda s: _positions(self, s))(t)

    def position_velocity(self, body: str, t):
        """(position [m], velocity [m/s]) in one forward-mode pass (jax.jvp with dt = 1)."""
        _check_body(body)
        self.check_time(t)
        return _batched(_position_velocity, self, body, t)


def _batched(fn, eph, body, t):
    """Scalar t: fn(eph, body, t); array t: vmapped over t (leading axis of the result)."""
    t = jnp.asarray(t, dtype=jnp.float64)
    if t.ndim == 0:
        return fn(eph, body, t)
    return jax.vmap(lambda s: fn(eph, body, s))(t.ravel())


def _check_body(body):
    if body not in BODIES:
        raise ConfigError("third_bodies", body, f"unknown body; expected one of {list(BODIES)}")


def _positions_raw(eph: ChebyshevEphemeris, t):
    moon_km = chebyshev_series(eph.moon_coef, eph.moon_start, eph.moon_len, t)
    se_km = chebyshev_series(eph.sun_emb_coef, eph.sun_emb_start, eph.sun_emb_len, t)
    ok = (t >= eph.t_min) & (t <= eph.t_max)
    scale = jnp.where(ok, 1e3, jnp.nan)                          # m per km, NaN outside window
    return scale * moon_km, scale * (se_km + eph.earth_share * moon_km)


def _position_raw(eph: ChebyshevEphemeris, body: str, t):
    if body == "moon":
        ok = (t >= eph.t_min) & (t <= eph.t_max)
        return jnp.where(ok, 1e3, jnp.nan) * chebyshev_series(eph.moon_coef, eph.moon_start, eph.moon_len, t)
    return _positions_raw(eph, t)[1]


# jitted once per (window shape, body); nested inside a caller's jit they are simply inlined
_position = jax.jit(_position_raw, static_argnums=1)
_positions = jax.jit(_positions_raw)
_velocity = jax.jit(lambda eph, body, t: jax.jacfwd(_position_raw, argnums=2)(eph, body, t),
                    static_argnums=1)
_position_velocity = jax.jit(
    lambda eph, body, t: jax.jvp(lambda s: _position_raw(eph, body, s), (t,), (jnp.ones_like(t),)),
    static_argnums=1)
