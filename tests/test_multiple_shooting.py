"""Multiple shooting (indirect.multiple_shooting): exact Jacobian of the split map, its agreement
with single shooting on a trajectory, the residuals without derivatives, and continuation by it landing on the single-shooting
extremal."""
import dataclasses
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest
import yaml

from spaceopt.errors import ConvergenceError
from spaceopt.indirect import chain
from spaceopt.indirect import multiple_shooting as ms_
from spaceopt.indirect.continuation import POLISH_FAILED
from spaceopt.indirect.shooting import residual, shoot
from spaceopt.studies import multirev_config
from spaceopt.studies import perturbed as P

ROOT = Path(__file__).resolve().parents[1]
PT = yaml.safe_load((ROOT / "config/studies/perturbed.yaml").read_text())["perturbed"]
MR = yaml.safe_load((ROOT / "config/studies/multirev.yaml").read_text())["multirev"]


@pytest.fixture(scope="module")
def blend():
    """E5 (5 rev) under the force-model blend J2 → 2×2 geopotential at τ = 0.4 (time-dependent
    through C22/S22 and the Earth angle: t a state, p_t an unknown), three arcs, nodes on the
    trajectory of an arbitrary costate vector. 2×2 rather than the studies' 4×4: the same blend
    and time dependence, programs that compile ~30 % faster."""
    g44 = P.transfer_from_config(PT, "e5", "g44")
    tr = dataclasses.replace(g44, perturbations={**g44.perturbations, "geopotential": {"degree": 2, "order": 2}})
    sh = chain.shooting_for("ot", "model", tr)
    prm = {**tr.params(thrust=0.5), "pert_from": P.transfer_from_config(PT, "e5", "j2").params()["pert"]}
    z = chain.start_vector(sh, {"p_p": 0.03, "p_ex": -0.01, "p_iy": 0.005, "p_LK": -0.02, "p_m": 0.01,
                                "p_t": 0.001}, tr.delta_L + 0.3)
    ms = ms_.MultipleShooting(sh, 3)
    nodes = jnp.asarray(ms_.node_positions(z[sh.kf_index], 3))
    Z, w = ms_.start_nodes(ms, z, 0.4, prm, nodes)
    return {"sh": sh, "ms": ms, "prm": prm, "z": z, "Z": Z, "nodes": nodes, "w": jnp.asarray(w), "tau": 0.4}


def test_split_map_equals_single_shooting_on_a_trajectory(blend):
    """With the nodes on the trajectory through z, continuity holds to the integration error and
    the transversality and terminal rows are those of single shooting."""
    b = blend
    f, J, ftau, n, ok = ms_.shoot(b["ms"], jnp.asarray(b["Z"]), b["tau"], b["prm"], b["nodes"], b["w"])
    f1 = np.asarray(shoot(b["sh"], jnp.asarray(b["z"]), b["tau"], b["prm"])[0])
    f = np.asarray(f)
    assert ok and f.shape == (b["ms"].size,) and J.shape == (f.size, f.size)
    n_cont = (b["ms"].arcs - 1) * b["ms"].width
    assert np.max(np.abs(f[1:1 + n_cont])) < 1e-8
    np.testing.assert_allclose(np.r_[f[0], f[1 + n_cont:]], f1, rtol=1e-7, atol=1e-9)


def test_residuals_without_derivatives_equal_the_shooting_maps(blend):
    """residual() of both maps (no sensitivities): the residual of shoot() to the integration
    error (the step control reads the primal error only; measured 3e-11 on rows of 1e-4)."""
    b = blend
    Z = jnp.asarray(b["Z"]) * (1.0 + 1e-3 * jnp.arange(b["Z"].size) / b["Z"].size)   # off the trajectory
    f, *_ = ms_.shoot(b["ms"], Z, b["tau"], b["prm"], b["nodes"], b["w"])
    r, ok = ms_.residual(b["ms"], Z, b["tau"], b["prm"], b["nodes"], b["w"])
    assert ok and np.max(np.abs(np.asarray(f))) > 1e-6
    np.testing.assert_allclose(np.asarray(r), np.asarray(f), rtol=0, atol=1e-9)
    r1, ok1 = residual(b["sh"], jnp.asarray(b["z"]), b["tau"], b["prm"])
    np.testing.assert_allclose(np.asarray(r1), np.asarray(shoot(b["sh"], jnp.asarray(b["z"]), b["tau"], b["prm"])[0]),
                               rtol=0, atol=1e-9)


def test_split_map_jacobian_matches_central_differences(blend):
    """Columns of ∂F/∂Z from every block (costates at K = 0, p_t, K_f, both nodes) and ∂F/∂τ
    against central differences, relative to each column's size."""
    b = blend
    ev = lambda Z, tau: np.asarray(ms_.shoot(b["ms"], jnp.asarray(Z), tau, b["prm"], b["nodes"], b["w"])[0])
    Z, s, w = b["Z"], b["sh"].size, b["ms"].width
    _, J, ftau, _, _ = ms_.shoot(b["ms"], jnp.asarray(Z), b["tau"], b["prm"], b["nodes"], b["w"])
    J = np.asarray(J)
    p_t = b["sh"].unknown_names().index("p_t")
    for i in (0, p_t, b["sh"].kf_index, s, s + 7, s + w - 1, s + w, Z.size - 1):
        d = 1e-6 * max(1.0, abs(Z[i]))
        e = np.zeros_like(Z)
        e[i] = d
        column = (ev(Z + e, b["tau"]) - ev(Z - e, b["tau"])) / (2 * d)
        assert np.max(np.abs(column - J[:, i])) < 1e-4 * max(1.0, np.max(np.abs(column))), i
    ftau_fd = (ev(Z, b["tau"] + 1e-6) - ev(Z, b["tau"] - 1e-6)) / 2e-6
    assert np.max(np.abs(np.asarray(ftau) - ftau_fd)) < 1e-4 * max(1.0, np.max(np.abs(ftau_fd)))


def test_one_arc_and_a_start_that_does_not_integrate_are_refused(blend):
    with pytest.raises(ValueError, match="at least 2 arcs"):
        ms_.MultipleShooting(blend["sh"], 1)
    bad = blend["z"].copy()
    bad[:-1] *= 10.0                   # costates that blow the trajectory up before the first node
    with pytest.raises(ConvergenceError, match="does not reach the last node"):
        ms_.start_nodes(blend["ms"], bad, blend["tau"], blend["prm"], blend["nodes"])


def test_continuation_by_multiple_shooting_lands_on_the_single_shooting_extremal():
    """E1 OT, 15 → 16 N: the thrust continuation over three arcs ends (after the single-shooting
    polish) on the extremal single shooting reaches."""
    tr = multirev_config.transfer_from_config(MR, "e1")
    q = chain.ContinuationOptions(verbose=False)
    ot = chain.solve_ot(chain.solve_lp(tr, q), 15.0, q)
    single = chain.continue_in_params(ot, tr.params(thrust=16.0), q)
    split = dataclasses.replace(ot, shooting=dataclasses.replace(ot.shooting, path_arcs=3))
    multi = chain.continue_in_params(split, tr.params(thrust=16.0), q)
    assert multi.stats["arcs"] == 3 and multi.stats["final_residual"] < 1e-9
    assert multi.stats["multiple_shooting"]["jacobian_evaluations"] > 0
    np.testing.assert_allclose(multi.z, single.z, rtol=1e-8, atol=1e-11)


def test_a_failed_multiple_shooting_polish_goes_on_to_the_single_shooting_polish(monkeypatch):
    """E1 OT, 15 → 16 N over three arcs: where the path reaches τ = 1 and only its polish fails
    (E8 500 rev: nearly flat node-time directions), the end point's first block is polished by
    single shooting, onto the same extremal, and the failure is in the statistics."""
    tr = multirev_config.transfer_from_config(MR, "e1")
    q = chain.ContinuationOptions(verbose=False)
    ot = chain.solve_ot(chain.solve_lp(tr, q), 15.0, q)
    split = dataclasses.replace(ot, shooting=dataclasses.replace(ot.shooting, path_arcs=3))
    follow = chain._follow

    def failing_polish(cont, z0, path, tau0=0.0):
        z, stats = follow(cont, z0, path, tau0)
        if tau0 == 0.0:                         # the multiple-shooting path: its polish "fails"
            raise ConvergenceError("polish", {"reason": POLISH_FAILED, "tau": 1.0,
                                              "z": (z * (1 + 1e-7)).tolist(), **stats})
        return z, stats

    monkeypatch.setattr(chain, "_follow", failing_polish)
    multi = chain.continue_in_params(split, tr.params(thrust=16.0), q)
    assert multi.stats["multiple_shooting"]["polish_failed"] == "polish"
    assert multi.stats["final_residual"] < 1e-9
    monkeypatch.setattr(chain, "_follow", follow)
    single = chain.continue_in_params(ot, tr.params(thrust=16.0), q)
    np.testing.assert_allclose(multi.z, single.z, rtol=1e-8, atol=1e-11)

    def failing_path(cont, z0, path, tau0=0.0):
        raise ConvergenceError("path", {"reason": "step size underflow", "tau": 0.5, "z": list(z0)})

    monkeypatch.setattr(chain, "_follow", failing_path)
    with pytest.raises(ConvergenceError, match="path"):
        chain.continue_in_params(split, tr.params(thrust=16.0), q)
