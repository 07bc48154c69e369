"""E3 sweep (Tables 4.1.1-4.1.2): periodicity, warm start = cold chain, predictors, report checks.

The solver tests use 2-revolution cells (a cold LP -> T_min chain is ~10-20 s here); the report
tests run on synthetic cells.
"""
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from spaceopt.indirect import hamiltonians as hm
from spaceopt.indirect.shooting import shoot
from spaceopt.studies import sweep, sweep_report

ROOT = Path(__file__).resolve().parents[1]


def _cfg():
    mr = yaml.safe_load((ROOT / "config/studies/multirev.yaml").read_text())["multirev"]
    sw = yaml.safe_load((ROOT / "config/studies/sweep.yaml").read_text())["sweep"]
    return mr, sw


@pytest.fixture(scope="module")
def cold0():
    mr, sw = _cfg()
    tr = sweep.cell_transfer(mr, sw, 0.0, 2)
    z, stats = sweep.cold_cell(tr)
    return mr, sw, z


def test_periodicity_L0_0_equals_360(cold0):
    """L0 = 360 deg is the same problem: the converged z at 0 deg solves it (R12)."""
    mr, sw, z = cold0
    sh = sweep.shooting(sw["numerics"], 2)
    rec = {}
    for L0 in (0.0, 360.0):
        tr = sweep.cell_transfer(mr, sw, L0, 2)
        prm = sweep.path_params(tr.params(), tr.params())
        f = np.asarray(shoot(sh, np.asarray(z), 1.0, prm)[0])
        assert np.max(np.abs(f)) < 1e-9, (L0, f)
        rec[L0] = sweep.cell_record(tr, sh, z, prm, "test", {}, 0.0)
    for q in ("T_min_N", "tof_days", "m_f_kg"):
        assert rec[360.0][q] == pytest.approx(rec[0.0][q], rel=1e-9)


def test_warm_start_equals_cold_chain(cold0):
    """A march 0 -> 10 deg (tangent predictor + Newton) lands on the cold-chain solution at 10 deg."""
    mr, sw, _ = cold0
    sw = {**sw, "table_L0_deg": [0, 10], "rows": [{"n_rev": 2, "start": "cold", "grid": "table"}]}
    cells = sweep.solve_row(mr, sw, 2)
    assert [c["method"] for c in cells] == ["cold", "march"]
    assert cells[1]["jacobian_evaluations"] <= 8
    tr = sweep.cell_transfer(mr, sw, 10.0, 2)
    z_cold, _ = sweep.cold_cell(tr)
    assert cells[1]["z"][-1] == pytest.approx(z_cold[-1], rel=1e-8)
    assert np.allclose(cells[1]["z"], z_cold, rtol=1e-6, atol=1e-9)
    # always-on engine: m_f = m0 - T dt / c (spec §9 T4)
    assert abs(cells[1]["mass_balance_kg"]) < 1e-6


def test_scale_prediction_power_law():
    """Two rows on an exact power law are extrapolated exactly; one row uses n^-1 and n^-2 (p_LK)."""
    kf = 7
    n0, n1, n = 50.0, 100.0, 300.0
    b = np.array([-1.0, -1.1, -0.9, -1.0, -1.2, -2.0, -1.0, 0.0, -1.0])
    a = np.array([0.4, -0.5, 0.01, -0.02, 0.003, -0.05, -0.1, 0.0, 0.2])
    z_of = lambda m: np.where(np.arange(9) == kf, 2 * math.pi * m + 1e-3 + 0.2 / m, a * m ** b)
    z = sweep.scale_prediction(n, [(n0, z_of(n0)), (n1, z_of(n1))], kf)
    assert np.allclose(z, z_of(n), rtol=1e-12, atol=1e-12)
    z1 = sweep.scale_prediction(2 * n1, [(n1, z_of(n1))], kf)
    assert z1[hm.LK] == pytest.approx(z_of(n1)[hm.LK] / 4)
    assert z1[0] == pytest.approx(z_of(n1)[0] / 2)
    assert z1[kf] - 2 * math.pi * 2 * n1 == pytest.approx(z_of(n1)[kf] - 2 * math.pi * n1)


def _synthetic_cells():
    cells = []
    for n in (2.0, 20.0, 100.0):
        for L0 in range(0, 361, 10):
            T = 19.226 / n * (1 + 0.5 / n * math.cos(math.radians(L0 - 120)))
            dt = 1.4489 * n * (1 + 0.3 / n * math.cos(math.radians(2 * L0)))
            cells.append({"n_rev": n, "L0_deg": float(L0), "T_min_N": T, "tof_days": dt,
                          "m_f_kg": 1000 - T * dt * 86400 / 14906.108})
    return cells


def test_period_mean_and_extrema():
    L0 = np.arange(0, 361, 10.0)
    v = 2 + np.cos(np.radians(L0 - 300))
    assert sweep_report.period_mean(L0, v) == pytest.approx(2.0, abs=1e-12)
    mins, maxs = sweep_report.local_extrema(L0, v)
    assert mins == [120.0] and maxs == [300.0]


def test_regularities_on_synthetic_data():
    cells = _synthetic_cells()
    regs = {r["id"]: r for r in sweep_report.regularities(cells, [0, 10, 50, 100, 150, 200, 250, 300, 350, 360], None)}
    assert regs["R12"]["holds"] == "yes"
    assert regs["R13"]["holds"] == "yes"            # n * mean = 19.226 exactly
    assert regs["R14"]["holds"] == "yes"            # minimum of cos(L0 - 120) at 300
    assert regs["R14b"]["holds"] == "yes"
    assert regs["R15"]["holds"] == "yes"
    assert regs["T-ext"]["holds"] == "yes"          # cos(2 L0): two minima, two maxima
    cells[0]["T_min_N"] *= 1.01                     # break periodicity
    regs = {r["id"]: r for r in sweep_report.regularities(cells, [0, 300, 360], None)}
    assert regs["R12"]["holds"] == "no"


def test_published_file_is_well_formed():
    from spaceopt.report import compare
    pub = compare.published_lookup(ROOT / "config/published/yun2023_sweep.yaml")
    assert len(pub) == 42
    assert pub[("L0_0_n2", "T_min_N")]["value"] == pub[("L0_360_n2", "T_min_N")]["value"]
    assert all("ref" in v and "tol" in v for v in pub.values())
