"""The peer-benchmark problem definitions (benchmarks/peer_problems.py) convert consistently.

Fast, no pykep needed: MEE ↔ Cartesian round trip for E, revolution counts of P0–P4, the
nondimensional P0 data against the spec's physical values, and the Transfer built by the
harness reproduces the problem's MEE.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import peer_problems as pp  # noqa: E402
from spaceopt.elements import cartesian_to_mee, mee_to_cartesian  # noqa: E402


@pytest.fixture(scope="module")
def probs():
    return pp.problems()


def test_e_cartesian_round_trip(probs):
    e = probs["E"]
    for mee, r, v in ((e["mee0"], pp.E_R0, pp.E_V0), (e["meef"], pp.E_RF, pp.E_VF)):
        pos, vel = mee_to_cartesian(np.asarray(mee), pp.MU_SUN)
        np.testing.assert_allclose(np.asarray(pos), r, rtol=1e-12, atol=1e-3)
        np.testing.assert_allclose(np.asarray(vel), v, rtol=1e-12, atol=1e-9)


def test_numpy_copy_matches_library_conversion():
    for r, v in ((pp.E_R0, pp.E_V0), (pp.E_RF, pp.E_VF)):
        lib = np.asarray(cartesian_to_mee(np.asarray(r), np.asarray(v), pp.MU_SUN))
        np.testing.assert_allclose(pp.cartesian_to_mee_np(r, v, pp.MU_SUN), lib, rtol=1e-13, atol=1e-15)


def test_e_has_zero_full_revolutions(probs):
    assert 0.0 < probs["E"]["n_rev"] < 1.0


@pytest.mark.parametrize("name,revs", [("P1", 2), ("P2", 3), ("P3", 4), ("P4", 5)])
def test_jiang_revolutions(probs, name, revs):
    """L_f − L_0 ≈ 2π·revs (the Jiang targets add exactly 2π per extra revolution)."""
    p = probs[name]
    dL = p["meef"][5] - p["mee0"][5]
    assert revs < p["n_rev"] < revs + 1
    assert math.isclose(dL - 2 * math.pi * revs, probs["P1"]["meef"][5] - p["mee0"][5] - 4 * math.pi,
                        abs_tol=1e-12)


def test_jiang_targets_differ_by_whole_revolutions(probs):
    Ls = [probs[k]["meef"][5] for k in ("P1", "P2", "P3", "P4")]
    np.testing.assert_allclose(np.diff(Ls), 2 * math.pi, rtol=0, atol=1e-12)


def test_p0_units_and_revolutions(probs):
    p = probs["P0"]
    assert math.isclose(p["thrust_N"], 0.32, rel_tol=1e-4)           # "0.32 N at 4000 kg" (rounded)
    assert math.isclose(p["isp_s"], 3000.0, rel_tol=1e-4)            # "Isp 3000 s" (rounded)
    assert math.isclose(p["tof_s"] / pp.DAY, 3534.0, rel_tol=1e-3)   # about 3534 days
    assert math.isclose(p["n_rev"], 5.12, abs_tol=0.01)
    assert math.isclose(p["mu_m3_s2"], pp.MU_SUN, rel_tol=1e-9)      # μ = 1 in AU and TU is the Sun's


def test_nondimensional_is_consistent(probs):
    for p in probs.values():
        nd = pp.nondimensional(p)
        assert math.isclose(nd["thrust"] * nd["FU_N"], p["thrust_N"], rel_tol=1e-14)
        assert math.isclose(nd["c"] * nd["VU_m_s"], p["c_m_s"], rel_tol=1e-14)
        assert math.isclose(nd["tof"] * nd["TU_s"], p["tof_s"], rel_tol=1e-14)


def test_transfer_reproduces_the_problem_mee(probs):
    """The harness's Transfer (MEE → Kepler → MEE) carries the problem's boundary data."""
    from peer_pykep import transfer_of
    for name, p in probs.items():
        tr = transfer_of(p)
        prm = tr.params()
        du = tr.du
        scale = np.array([du, 1, 1, 1, 1])
        np.testing.assert_allclose(np.asarray(prm["x0"]) * scale, p["mee0"][:5], rtol=1e-12, atol=1e-14,
                                   err_msg=name)
        np.testing.assert_allclose(np.asarray(prm["xf"]) * scale, p["meef"][:5], rtol=1e-12, atol=1e-14,
                                   err_msg=name)
        assert math.isclose(float(prm["L0"]), p["mee0"][5], rel_tol=1e-14)
        assert math.isclose(float(prm["Lf"]), p["meef"][5], rel_tol=1e-13)
        assert math.isclose(float(prm["tf"]) * tr.tu, p["tof_s"], rel_tol=1e-14)
        assert math.isclose(tr.c, p["c_m_s"], rel_tol=1e-14)
