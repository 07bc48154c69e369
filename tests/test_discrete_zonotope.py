"""Study D4: model matrices, regrouping, zonotope membership at every step, MP tables, dt fit."""
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad_vec
from scipy.linalg import expm

from spaceopt.discrete import zonotope_control as zc
from spaceopt.errors import ConfigError
from spaceopt.report.compare import published_lookup

ROOT = Path(__file__).resolve().parents[1]
PUBLISHED = ROOT / "config/published/discrete_libration_zonotope.yaml"
A_CONT = np.array([[0.0, 1, 0], [1, 0, 2], [0, -1, 0]])
X0 = np.array([-0.00377869564857395, -0.00391093582674638, 0.0141511512373208])
A_MAX = {"relay": 0.014, "impulsive": 0.0035}
DT = 0.25


def test_closed_form_transition_is_expm():
    for t in (0.1, 0.25, 1.3):
        assert np.abs(zc.transition(t) - expm(A_CONT * t)).max() < 1e-13


def test_input_matrices_from_expm():
    E = np.eye(3)[:, 1:]
    for dt in (0.25, 0.7):
        relay = quad_vec(lambda s: expm(A_CONT * s) @ E, 0, dt, epsabs=1e-14)[0]
        assert np.abs(zc.input_matrix(dt, "relay") - relay).max() < 1e-12
        assert np.abs(zc.input_matrix(dt, "impulsive") - expm(A_CONT * dt) @ E).max() < 1e-13


def test_regrouping_reproduces_three_original_steps():
    rng = np.random.default_rng(1)
    for control in zc.CONTROLS:
        At, Bt = zc.transition(DT), zc.input_matrix(DT, control)
        (Ae, Be), (Ao, Bo) = zc.regrouped_system(DT, control)
        x, w = rng.standard_normal(3), rng.standard_normal((3, 2))
        y = x
        for k in range(3):
            y = At @ y + Bt @ w[k]
        z = Ao @ (Ae @ x + Be @ [w[0, 0], w[0, 1], w[1, 0]]) + Bo @ [w[1, 1], w[2, 0], w[2, 1]]
        assert np.abs(y - z).max() < 1e-13


@pytest.fixture(scope="module", params=zc.CONTROLS)
def solutions(request):
    c = request.param
    return c, zc.solve_mp(X0, DT, c, A_MAX[c], 10), zc.solve_dp(X0, DT, c, A_MAX[c], 10)


def test_dp_trajectory_in_zonotopes_at_every_step(solutions):
    c, mp, dp = solutions
    assert np.abs(dp.x[-1]).max() < 1e-12
    assert np.abs(dp.w).max() <= A_MAX[c] * (1 + 1e-9)
    for k, x in enumerate(dp.x):       # independent generator-form LP, not the vertex LP of the DP
        g = zc.gauge_generators(x, zc.zonotope_generators(DT, c, dp.n_min - k, A_MAX[c]))
        assert g <= 1 + 1e-7, (k, g)
    # minimality: x0 is not in X(N_min - 1)
    assert zc.gauge_generators(X0, zc.zonotope_generators(DT, c, dp.n_min - 1, A_MAX[c])) > 1


def test_membership_check_can_fail(solutions):
    c, mp, dp = solutions
    G = zc.zonotope_generators(DT, c, dp.n_min - 1, A_MAX[c])
    assert zc.gauge_generators(dp.x[0], G) > 1          # one step too few
    assert zc.gauge_generators(3 * dp.x[1], zc.zonotope_generators(DT, c, dp.n_min - 1, A_MAX[c])) > 1


def test_mp_trajectory_optimal_and_in_zonotopes(solutions):
    c, mp, dp = solutions
    assert np.abs(mp.x[-1]).max() < 1e-12
    assert mp.alpha < 1
    assert np.allclose(np.linalg.norm(mp.w, axis=1), mp.alpha * A_MAX[c], rtol=1e-10)
    # the ball sets sit inside the box sets, so the MP states lie in the regrouped zonotopes, at every step
    sysm = zc.regrouped_system(DT, c)
    for k in range(mp.n_min):
        P, gens = np.eye(3), []
        for i in range(k, mp.n_min):
            A_i, B_i = sysm[i % 2]
            P = P @ np.linalg.inv(A_i)
            gens.append(-P @ B_i * A_MAX[c])
        assert zc.gauge_generators(mp.x[k], np.hstack(gens)) <= mp.alpha + 1e-9
    # and the gauge w.r.t. the ball sums stays alpha along the optimal trajectory
    assert np.allclose(zc.mp_membership_gauges(mp, DT, A_MAX[c]), mp.alpha, rtol=1e-6)


def test_n_min_matches_published(solutions):
    c, mp, dp = solutions
    pub = published_lookup(PUBLISHED)
    assert mp.n_min_original == pub[(f"d4_nmin_{c}", "maximum_principle")]["value"]
    assert dp.n_min_original == pub[(f"d4_nmin_{c}", "dynamic_programming")]["value"]


def test_mp_tables_reproduced_within_1e4(solutions):
    c, mp, dp = solutions
    x, u = zc.published_mp_tables(published_lookup(PUBLISHED), [c])[c]
    assert mp.x.shape == x.shape and mp.u.shape == u.shape
    assert np.abs(mp.x - x).max() <= 1e-4
    assert np.abs(mp.u - u).max() <= 1e-4


def test_dt_inference_recovers_a_known_step():
    mp = zc.solve_mp(X0, 0.31, "impulsive", A_MAX["impulsive"], 10)
    fit = zc.infer_dt([(mp.x, mp.u)], (0.05, 1.0, 200))
    assert fit["dt"] == pytest.approx(0.31, abs=1e-7)
    assert fit["rms"] < 1e-12


def test_dt_inferred_from_published_tables():
    tabs = zc.published_mp_tables(published_lookup(PUBLISHED), zc.CONTROLS)
    fit = zc.infer_dt(list(tabs.values()), (0.05, 1.5, 1451))
    assert fit["dt"] == pytest.approx(0.25, abs=1e-4)


@pytest.mark.parametrize("key,value", [("dt", -0.1), ("dt", "guess"), ("controls", ["bang"]), ("n_max", 0),
                                       ("x0", [1.0, 2.0])])
def test_bad_config_raises_config_error(key, value):
    cfg = {"x0": list(X0), "controls": ["relay"], "a_max": {"relay": 0.014}, "dt": 0.25, "n_max": 10}
    cfg[key] = value
    with pytest.raises(ConfigError) as exc:
        zc.check_config(cfg)
    assert f"orbit_correction.{key}" in str(exc.value) and "\n" not in str(exc.value)
