"""DE405 Chebyshev windows evaluated in JAX vs jplephem; time scales; window artifacts."""
import json

import erfa
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from spaceopt import ephemeris as E
from spaceopt.errors import ArtifactError, ConfigError

EPOCH = "2021-05-09T12:00:00"
T_DAY0 = 7799 * 86400.0      # 2021-05-09T12:00:00 TDB in s past J2000 (JD 2459344.0)


@pytest.fixture(scope="module")
def de405():
    return E.open_de405()


@pytest.fixture(scope="module")
def eph(de405):
    return E.ChebyshevEphemeris.from_de405("2021-04-25", "2021-08-15", "may2021", de405)


def _jpl(de405, body, t):
    """Reference geocentric position [km] and velocity [km/day] from jplephem at t [s TDB]."""
    d = t / 86400.0
    moon, vmoon = (a.ravel() for a in de405.position_and_velocity("moon", E.J2000_JD, d))
    if body == "moon":
        return moon, vmoon
    sun, vsun = (a.ravel() for a in de405.position_and_velocity("sun", E.J2000_JD, d))
    emb, vemb = (a.ravel() for a in de405.position_and_velocity("earthmoon", E.J2000_JD, d))
    return sun - emb + moon * de405.earth_share, vsun - vemb + vmoon * de405.earth_share


# -- time scales -------------------------------------------------------------------------------
def test_utc_to_tdb_j2000():
    # 2000-01-01 12:00 UTC: TAI-UTC = 32 s, TT-TAI = 32.184 s, |TDB-TT| < 2 ms
    t = E.utc_to_tdb_seconds("2000-01-01T12:00:00")
    assert abs(t - 64.184) < 2e-3
    assert t != pytest.approx(64.184, abs=1e-6)      # the periodic TDB-TT term is included


def test_utc_to_tdb_2021_and_dtdb():
    s = E.utc_to_scales(EPOCH)
    t = E.utc_to_tdb_seconds(EPOCH)
    # TAI-UTC = 37 s since 2017-01-01 -> TT-UTC = 69.184 s
    assert t - s["tdb_minus_tt_s"] == pytest.approx(T_DAY0 + 69.184, abs=1e-6)
    assert s["tdb_minus_tt_s"] == pytest.approx(erfa.dtdb(*s["tt"], 0.5, 0.0, 0.0, 0.0), abs=1e-12)
    assert abs(s["tdb_minus_tt_s"]) < 1.7e-3
    assert E.tdb_seconds_to_iso(T_DAY0).startswith("2021-05-09T12:00:00")


@pytest.mark.parametrize("bad", ["2021-13-40", "yesterday", "2021/05/09"])
def test_bad_utc_string(bad):
    with pytest.raises(ConfigError, match="epoch"):
        E.utc_to_tdb_seconds(bad)


# -- JAX series vs jplephem ----------------------------------------------------------------------
@pytest.mark.parametrize("body", ["moon", "sun"])
def test_position_velocity_match_jplephem_dyadic(eph, de405, body):
    """At times k*1350 s (exact in both representations) the only difference is summation order."""
    ts = T_DAY0 - 10 * 86400.0 + 1350.0 * np.arange(0, 64 * 90, 211)
    worst_p = worst_v = 0.0
    for t in ts:
        p_ref, v_ref = _jpl(de405, body, t)
        p, v = eph.position_velocity(body, t)
        worst_p = max(worst_p, np.max(np.abs(np.asarray(p) / 1e3 - p_ref)) / np.linalg.norm(p_ref))
        worst_v = max(worst_v, np.max(np.abs(np.asarray(v) * 86400 / 1e3 - v_ref)) / np.linalg.norm(v_ref))
    assert worst_p < 1e-14
    assert worst_v < 1e-13


@pytest.mark.parametrize("body", ["moon", "sun"])
def test_match_jplephem_arbitrary_times(eph, de405, body):
    """Arbitrary times: jplephem's own day fraction carries ~1e-6 s of rounding (JD-based time),
    i.e. <= ~3e-12 relative for the Moon; our seconds-based t is finer."""
    rng = np.random.default_rng(7)
    for t in T_DAY0 + rng.uniform(-10, 90, 25) * 86400.0:
        p_ref, v_ref = _jpl(de405, body, t)
        p = np.asarray(eph.position(body, t)) / 1e3
        v = np.asarray(eph.velocity(body, t)) * 86400 / 1e3
        assert np.max(np.abs(p - p_ref)) / np.linalg.norm(p_ref) < 1e-11
        assert np.max(np.abs(v - v_ref)) / np.linalg.norm(v_ref) < 1e-10


def test_velocity_is_derivative_and_units(eph):
    """Velocity (AD) equals a central difference; Moon's acceleration ~ (GM_E+GM_M)/d^2 (units)."""
    t = T_DAY0 + 3.3e5
    h = 60.0
    fd = (np.asarray(eph.moon(t + h)) - np.asarray(eph.moon(t - h))) / (2 * h)
    v = np.asarray(eph.velocity("moon", t))
    assert np.allclose(v, fd, rtol=0, atol=1e-6 * np.linalg.norm(v))
    assert 900 < np.linalg.norm(v) < 1100                      # m/s
    acc = np.asarray(jax.jacfwd(jax.jacfwd(eph.moon))(jnp.float64(t)))
    d = np.linalg.norm(np.asarray(eph.moon(t)))
    assert np.linalg.norm(acc) == pytest.approx((3.986004418e14 + 4.9028e12) / d ** 2, rel=0.03)


def test_sun_distance_and_speed(eph):
    t = T_DAY0
    d = np.linalg.norm(np.asarray(eph.sun(t)))
    assert 1.0075 * 1.495978707e11 < d < 1.0105 * 1.495978707e11   # early May
    assert np.linalg.norm(np.asarray(eph.velocity("sun", t))) == pytest.approx(2.95e4, rel=0.02)


def test_granule_boundary_continuous(eph):
    # a Moon granule boundary: JD 2459344.5 (4-day granules from jalpha = 2305424.5)
    tb = (2459344.5 - E.J2000_JD) * 86400.0
    assert ((2459344.5 - 2305424.5) / 4.0).is_integer()
    a = np.asarray(eph.moon(tb - 1e-3))
    b = np.asarray(eph.moon(tb + 1e-3))
    v = np.asarray(eph.velocity("moon", tb))
    assert np.allclose(b - a, 2e-3 * v, rtol=0, atol=1e-3)      # continuity to < 1 mm


def test_jit_grad_and_pytree(eph):
    t = jnp.float64(T_DAY0 + 1234.5)
    f = jax.jit(lambda e, s: e.sun(s))
    assert np.allclose(f(eph, t), eph.sun(t), rtol=1e-15, atol=0)
    g = jax.jit(jax.jacfwd(lambda s: eph.moon(s)))(t)
    assert np.allclose(g, eph.velocity("moon", t), rtol=1e-15, atol=1e-12)
    # reverse mode too
    gr = jax.grad(lambda s: eph.moon(s)[0])(t)
    assert float(gr) == pytest.approx(float(g[0]), rel=1e-14)


def test_outside_window_raises_naming_date(eph):
    late = E.utc_to_tdb_seconds("2021-12-01T00:00:00")
    with pytest.raises(ConfigError, match="2021-12-01"):
        eph.moon(late)
    with pytest.raises(ConfigError, match="may2021"):
        eph.velocity("sun", late)
    assert np.all(np.isnan(np.asarray(jax.jit(eph.moon)(late))))     # traced: NaN, not garbage
    with pytest.raises(ConfigError, match="third_bodies"):
        eph.position("mars", T_DAY0)


def test_window_outside_de405():
    with pytest.raises(ConfigError, match="ephemeris.x.end"):
        E.extract_window("2150-01-01", "2250-01-01", "x")


def test_artifact_roundtrip(tmp_path, de405, eph):
    w = E.extract_window("2021-04-25", "2021-08-15", "may2021", de405)
    path = tmp_path / "may2021.json"
    E.save_window(w, path, {"start": "2021-04-25"})
    meta = json.loads(path.read_text())
    assert meta["units"]["coefficients"] == "km" and meta["source"]["denum"] == 405.0
    assert meta["coverage"]["start_tdb_s"] <= E.utc_to_tdb_seconds("2021-04-25")
    loaded = E.load_ephemeris(path)
    t = T_DAY0 + 777.0
    assert np.array_equal(np.asarray(loaded.sun(t)), np.asarray(eph.sun(t)))
    assert (loaded.t_min, loaded.t_max) == (eph.t_min, eph.t_max)
    # corrupt the NPZ: the checksum catches it
    npz = tmp_path / "may2021.npz"
    npz.write_bytes(npz.read_bytes()[:-10])
    with pytest.raises(ArtifactError, match="checksum"):
        E.load_ephemeris(path)


def test_configured_windows_cover_the_studies():
    """config/studies/ephemeris.yaml validates and its windows cover the spec §4.2 studies."""
    from pathlib import Path

    import yaml
    from snakemake.utils import validate

    root = Path(__file__).resolve().parents[1]
    cfg = yaml.safe_load((root / "config/studies/ephemeris.yaml").read_text())["ephemeris"]
    validate(cfg, str(root / "config/schema/ephemeris.schema.yaml"))
    win = cfg["windows"]

    def covers(name, first_departure, last_departure, days):
        lo = E.utc_to_tdb_seconds(win[name]["start"])
        hi = E.utc_to_tdb_seconds(win[name]["end"])
        return (lo <= E.utc_to_tdb_seconds(first_departure)
                and E.utc_to_tdb_seconds(last_departure) + days * 86400.0 <= hi)

    assert covers("may2021", "2021-05-01T12:00:00", "2021-05-31T12:00:00", 70)   # E5/E6
    assert covers("may2021", "2021-05-09T12:00:00", "2021-05-09T12:00:00", 140)  # E9
    assert covers("may2021_e7", "2021-05-09T12:00:00", "2021-05-09T12:00:00", 240)  # E7 (assumed) and its T_min bounds
    assert covers("jan2000", "2000-01-01T12:00:00", "2000-01-01T12:00:00", 340)  # E8
    bad = {"windows": {"x": {"start": "2021-05-01", "finish": "2021-06-01"}}}
    with pytest.raises(Exception, match="finish|end"):
        validate(bad, str(root / "config/schema/ephemeris.schema.yaml"))


def test_vector_times(eph):
    ts = T_DAY0 + np.array([0.0, 1.5e5, 3.0e6])
    p = np.asarray(eph.position("sun", ts))
    v = np.asarray(eph.velocity("moon", ts))
    assert p.shape == (3, 3) and v.shape == (3, 3)
    assert np.allclose(p[1], np.asarray(eph.sun(ts[1])), rtol=1e-15, atol=0)
    assert np.allclose(v[2], np.asarray(eph.velocity("moon", ts[2])), rtol=1e-14, atol=0)
    pm, ps = eph.positions(ts)
    assert np.allclose(np.asarray(ps), p, rtol=1e-15, atol=0)
