"""D1 (GEO insertion with start penalties): geometry, Kepler arcs, the approximate method, config errors."""
import copy
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.integrate import solve_ivp

from spaceopt.discrete import geo_burns as gb
from spaceopt.errors import ConfigError
from spaceopt.report.compare import published_lookup

ROOT = Path(__file__).resolve().parents[1]
CFG = yaml.safe_load((ROOT / "config/studies/geo_burns.yaml").read_text())["geo_burns"]
PUB = published_lookup(ROOT / "config/published/discrete_geo_bellman.yaml")


@pytest.fixture(scope="module")
def p():
    return gb.params_from_config(CFG)


def test_float64_and_mu(p):
    assert isinstance(p.mu, float)
    assert p.mu == pytest.approx(CFG["model"]["mass_flow_kg_s"] / CFG["model"]["thrust_max_n"], rel=1e-15)


def test_osculating_matches_printed_formulas_off_apsis(p):
    # an ellipse state away from the apsides: the spec's printed e and p formulas hold there
    x = np.array([9.0e6, 0.7, 1500.0, 7.0e-4, 2.0e4])
    o = gb.osculating(x, 0.0, p.gm)
    rho, phi, v, om = x[:4]
    th = phi - o.psi
    assert math.tan(th) == pytest.approx(rho ** 2 * v * om / (rho ** 3 * om ** 2 - p.gm), rel=1e-10)
    den = rho * om * math.sin(th) - v * math.cos(th)
    assert o.e == pytest.approx(v / den, rel=1e-10)
    assert o.p == pytest.approx(rho ** 2 * om * math.sin(th) / den, rel=1e-10)


def test_kepler_arc_matches_integration(p):
    x = np.array([9.0e6, 0.7, 1500.0, 7.0e-4, 2.0e4])
    o = gb.osculating(x, 0.0, p.gm)
    t = 30000.0
    num = solve_ivp(gb.rhs, (0.0, t), x, method="RK45", args=(p, 0.0), rtol=1e-12, atol=1e-12).y[:, -1]
    kep = gb.state_at_time(o, t, p.gm)
    assert kep[0] == pytest.approx(num[0], rel=1e-8)
    assert kep[1] == pytest.approx(num[1], abs=1e-7)
    assert kep[3] == pytest.approx(num[3], rel=1e-7)
    # next perigee: radial velocity 0 and radius = perigee radius
    tp = gb.next_apsis_time(o, "p", p.gm)
    xp = gb.state_at_time(o, tp, p.gm)
    assert xp[0] == pytest.approx(o.r_perigee, rel=1e-12)
    assert abs(xp[2]) < 1e-6


def test_burn_mass_flow_and_centring(p):
    orb = gb.initial_orbit(p)
    b = gb.centred_burn(orb, 100.0, 200.0, "p", p)
    assert b.t_start == pytest.approx(0.0)
    assert p.m0 - b.x_end[4] == pytest.approx(p.mass_flow_kg_s * 200.0, rel=1e-10)
    # the new perigee sits close to the burn centre and the apogee went up
    assert b.orbit_after.r_apogee > p.r0 * 1.01
    assert b.orbit_after.r_perigee == pytest.approx(p.r0, rel=1e-3)


def test_published_structure_durations_and_fuel(p):
    """At the published burn counts the method gives the published durations (a few seconds)."""
    n_p = PUB[("d1_classical", "perigee_burns")]["value"]
    n_a = PUB[("d1_classical", "apogee_burns")]["value"]
    s = gb.optimised_scheme(n_p, n_a, p)
    assert (s.n_p, s.n_a) == (n_p, n_a)
    case = "d1_classical_published_counts"
    for q, val in (("perigee_burn_s", s.durations("p")[0]), ("perigee_last_burn_s", s.durations("p")[-1]),
                   ("apogee_burn_s", s.durations("a")[0]), ("apogee_last_burn_s", s.durations("a")[-1])):
        assert abs(val - PUB[(case, q)]["value"]) <= PUB[(case, q)]["tol"]["abs"], q
    # targets hit: apogee at GEO after the perigee series, near-circular GEO at the end
    assert s.burns[n_p - 1].orbit_after.r_apogee == pytest.approx(p.r_target, rel=1e-7)
    assert s.final_ecc < 1e-5
    assert abs(s.rho_t1_miss_m) < 1e3
    # fuel is the mass flow times the total burn time
    total = sum(b.duration for b in s.burns)
    assert s.fuel_kg == pytest.approx(p.mass_flow_kg_s * total, rel=1e-9)


def test_more_perigee_burns_less_fuel(p):
    f = [gb.optimised_scheme(n, 3, p).fuel_kg for n in (1, 2, 4)]
    assert f[0] > f[1] > f[2]


def test_switching_function_peaks_at_burns(p):
    s = gb.optimised_scheme(2, 3, p)
    k = gb.switching_function(s, 20, 2000.0)
    assert k["switch_residual_max"] < 0.05
    assert k["k_max_on_coasts"] < 1.0 + 0.05
    assert k["k_min_on_burns"] > 1.0 - 0.05
    assert k["backward_state_gap_rel"] < 1e-8


@pytest.mark.parametrize("path,value", [
    (("model", "thrust_max_n"), -1.0),
    (("model", "m0_kg"), "heavy"),
    (("model", "r_target_m"), 1.0e6),
    (("numerics", "rtol"), 0.1),
    (("cost", "lambda1"), -5.0),
])
def test_bad_config_raises(path, value):
    cfg = copy.deepcopy(CFG)
    cfg[path[0]][path[1]] = value
    with pytest.raises(ConfigError) as exc:
        gb.params_from_config(cfg)
    assert path[1] in str(exc.value) and "\n" not in str(exc.value)


def test_bad_search_range_raises():
    cfg = copy.deepcopy(CFG)
    cfg["search"]["perigee_burns"] = [5, 2]
    with pytest.raises(ConfigError, match="perigee_burns"):
        gb._range(cfg, "perigee_burns")
