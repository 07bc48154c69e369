"""D3 (Bellman stabilisation): monotone Markov-chain scheme, 0 <= V <= 1, symmetry, config errors."""
import copy
from pathlib import Path

import numpy as np
import pytest
import yaml

from spaceopt.discrete import bellman as bm
from spaceopt.errors import ConfigError

ROOT = Path(__file__).resolve().parents[1]
CFG = yaml.safe_load((ROOT / "config/studies/bellman.yaml").read_text())["bellman"]


def _solve(**over):
    cfg = copy.deepcopy(CFG)
    horizon = over.pop("horizon_s", None)
    cfg.update(over)
    p = bm.params_from_config(cfg, horizon_s=horizon)
    return p, bm.solve(p)


def test_values_are_probabilities():
    p, sol = _solve()
    assert sol["V"].dtype == np.float64
    rep = bm.monotonicity_report(sol)
    assert rep["in_unit_interval"] and rep["nonincreasing_backwards"]
    assert rep["cfl"] <= 1.0


def test_monotone_near_cfl_limit():
    """Strong controls and a long step (CFL close to 1): still 0 <= V <= 1."""
    p, sol = _solve(b=[0.02, 0.02, 0.02], dt_s=0.1, horizon_s=5.0)
    assert 0.5 < sol["cfl"] <= 1.0
    assert sol["V"].min() >= 0.0 and sol["V"].max() <= 1.0


def test_cfl_violation_raises():
    cfg = copy.deepcopy(CFG)
    cfg["dt_s"] = 5.0
    cfg["horizon_s"] = 10.0
    with pytest.raises(ConfigError, match="dt_s"):
        bm.params_from_config(cfg)


def test_comparison_principle():
    """A monotone scheme preserves order: a smaller box Q gives a smaller V everywhere."""
    p_big, big = _solve(horizon_s=20.0)
    p_small, small = _solve(q_half_width=0.08, domain_half_width=p_big.domain_half_width, horizon_s=20.0)
    assert np.all(small["V"] <= big["V"] + 1e-15)
    assert np.any(small["V"] < big["V"])


def test_symmetry_maps_point1_to_point2():
    p, sol = _solve(horizon_s=20.0)
    V = sol["V"]
    assert np.max(np.abs(V - V[:, :, ::-1, ::-1])) < 1e-13
    v1 = bm.value_at(sol, p, CFG["points"]["point1"])
    v2 = bm.value_at(sol, p, CFG["points"]["point2"])
    assert np.allclose(v1, v2, atol=1e-13)


def test_no_drift_keeps_everything_in_Q():
    """Equal inertias: f = 0, the controls push inwards, the chain never leaves Q."""
    p, sol = _solve(inertia_kg_m2=[1.0, 1.0, 1.0], horizon_s=10.0)
    assert np.all(sol["V"][:, sol["in_q"]] == 1.0)


def test_wrong_control_sign_would_leak():
    """The drift alone (b tiny) loses probability at the edges of Q where f points outwards;
    with the controls of the config V is larger: the optimal control matters."""
    p0, sol0 = _solve(b=[1e-9, 1e-9, 1e-9], horizon_s=20.0)
    p1, sol1 = _solve(horizon_s=20.0)
    assert np.all(sol1["V"] >= sol0["V"] - 1e-15)
    assert sol1["V"][0][sol1["in_q"]].sum() > sol0["V"][0][sol0["in_q"]].sum()


def test_closed_loop_stays_in_Q_from_published_points():
    p, sol = _solve(horizon_s=5.0)
    for name in ("point1", "point2"):
        r = bm.closed_loop(sol, p, CFG["points"][name])
        assert r["stays_in_Q"], name


@pytest.mark.parametrize("key,value", [("q_units", "furlongs"), ("q_half_width", 0.105),
                                       ("grid_step", -0.01), ("inertia_kg_m2", [1.0, 2.0]),
                                       ("exit", "sometimes")])
def test_bad_config_raises(key, value):
    cfg = copy.deepcopy(CFG)
    cfg[key] = value
    with pytest.raises(ConfigError) as exc:
        bm.params_from_config(cfg)
    assert key in str(exc.value) and "\n" not in str(exc.value)


def test_point_off_grid_raises():
    p, sol = _solve()
    with pytest.raises(ConfigError, match="points"):
        bm.value_at(sol, p, [0.0, 0.005, 0.1])
