"""E1 (2 revolutions) chain as a quick regression: LP -> T_min -> OT 15 N from the zero guess.

Published values are read from config/published/yun2023_multirev.yaml with their tolerances.
Also: the first integral p_LK + H, the mass bookkeeping, the existence verdict.
"""
import math
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import yaml

from spaceopt.indirect import chain, tmin_from_ot
from spaceopt.indirect.flow import hamiltonian
from spaceopt.report import compare
from spaceopt.studies import multirev, multirev_config, verify
from spaceopt.studies.trajectory import sample

ROOT = Path(__file__).resolve().parents[1]
PUB = ROOT / "config" / "published" / "yun2023_multirev.yaml"
CFG = yaml.safe_load((ROOT / "config" / "studies" / "multirev.yaml").read_text())["multirev"]


@pytest.fixture(scope="module")
def e1():
    tr = multirev_config.transfer_from_config(CFG, "e1")
    lp = chain.solve_lp(tr)
    tmin = chain.solve_tmin(lp)
    ot = chain.solve_ot(lp, 15.0)
    return {"lp": lp, "tmin": tmin, "ot": ot,
            "samples": {k: sample(v, 200) for k, v in (("lp", lp), ("tmin", tmin), ("ot", ot))}}


def _check(case, stage, e1):
    sc = multirev.scalars(e1[stage], e1["samples"][stage])
    rows = compare.compare(PUB, {(case, q): sc.get(q) for q in
                                 ("tof_days", "m_f_kg", "K_f_deg", "T_min_N", "J_LP_m2s3", "dv_m_s", "T0_guess_N")})
    mine = [r for r in rows if r["case"] == case]
    assert mine, f"no published values for {case}"
    bad = [(r["quantity"], r["published"], r["ours"], r["rel_diff"]) for r in mine if r["status"] == "fail"]
    assert not bad, bad


def test_e1_lp_matches_published(e1):
    _check("e1_lp", "lp", e1)


def test_e1_tmin_matches_published(e1):
    _check("e1_tmin_isp1520", "tmin", e1)


def test_e1_ot_15N_matches_published(e1):
    _check("e1_ot_15N", "ot", e1)


def test_transfer_time_ordering(e1):
    t = {k: e1["samples"][k]["t_s"][-1] for k in ("lp", "tmin", "ot")}
    assert t["ot"] < t["lp"] < t["tmin"]          # R7: 2.477 < 2.761 < 2.926 d


def test_first_integral_p_LK_plus_H(e1):
    for stage in ("lp", "tmin", "ot"):
        sol = e1[stage]
        Ks, ys = chain.dense(sol, 100)
        model = chain.final_model(sol)
        n = model.n
        H = jax.vmap(lambda K, y: y[n + 5] + hamiltonian(model, K, y, 1.0, sol.prm))(jnp.asarray(Ks), jnp.asarray(ys))
        tol = 1e-9 if stage != "ot" else 1e-6         # smoothed δ: only approximately conserved
        assert np.max(np.abs(np.asarray(H))) < tol, (stage, float(np.max(np.abs(H))))


def test_mass_bookkeeping(e1):
    tr = e1["tmin"].transfer
    s = e1["samples"]["tmin"]
    T = e1["tmin"].thrust_N
    assert math.isclose(s["mass_kg"][-1], tr.m0 - T * s["t_s"][-1] / tr.c, rel_tol=1e-9)
    # burn time from the sign of the switching function alone (switch instants: roots of a cubic
    # spline through the S samples), independent of the mass equation
    from scipy.interpolate import CubicSpline
    s = e1["samples"]["ot"]
    spline = CubicSpline(s["t_s"], s["S"])
    edges = np.concatenate([[s["t_s"][0]], np.sort(spline.roots(extrapolate=False)), [s["t_s"][-1]]])
    burn_s = float(np.sum(np.diff(edges)[spline(0.5 * (edges[:-1] + edges[1:])) > 0]))
    assert math.isclose(s["mass_kg"][-1], tr.m0 - 15.0 * burn_s / tr.c, rel_tol=1e-6)


def test_existence_verdict(e1):
    tmin = e1["tmin"]
    no = chain.existence_verdict(tmin, 5.0)
    assert not no["exists"] and "no transfer" in no["message"]
    assert math.isclose(no["n_rev_needed_estimate"], 2 * tmin.thrust_N / 5.0)
    assert chain.existence_verdict(tmin, 15.0)["exists"]


def test_lp_costates_match_the_published_normalisation(e1):
    """The LP costates p_x agree with the printed ones (H = k|A|², spec 02 §10.1)."""
    costates = e1["lp"].costates()
    rows = compare.compare(PUB, {("e1_lp", q): costates[q] for q in costates})
    mine = [r for r in rows if r["case"] == "e1_lp" and r["quantity"].startswith("p_")]
    assert len(mine) == 6
    status = {r["quantity"]: r["status"] for r in mine}
    assert all(status[q] == "pass" for q in ("p_p", "p_ex", "p_ey", "p_ix", "p_iy")), mine
    # the printed p_LK violates the transversality condition (erratum, spec 02 §10.1)
    assert status["p_LK"] == "fail"


def test_fixed_time_lp_at_the_free_optimum_has_zero_p_t(e1):
    """Fixed transfer time (1.1.11): with t_f equal to the free-time optimum the solution is the
    same and p_t(0) = 0 — the free-time transversality condition is then satisfied."""
    import dataclasses
    free = e1["lp"]
    tr = dataclasses.replace(free.transfer, tof_s=free.extra["tof_s"])
    fixed = chain.solve_lp(tr)
    c_free, c_fixed = free.costates(), fixed.costates()
    assert abs(c_fixed["p_t"]) < 1e-9
    for k in ("p_p", "p_ex", "p_ey", "p_ix", "p_iy", "p_LK"):
        assert math.isclose(c_fixed[k], c_free[k], rel_tol=1e-7, abs_tol=1e-12), k


def test_ot_via_tmin_route_reaches_the_blend_solution(e1):
    """LP -> T_min -> OT (T_min -> OT homotopy, no LP -> OT blend) lands on the same OT 15 N
    extremal as the (3.3.1) blend: the route E5 needs (its blend folds)."""
    ot = chain.solve_ot_from_tmin(e1["tmin"], 15.0, chain.ContinuationOptions(verbose=False))
    assert ot.stats["route"] == "lp-tmin-ot"
    np.testing.assert_allclose(ot.z, e1["ot"].z, rtol=1e-6, atol=1e-9)


def test_chord_corrector_reaches_the_newton_extremal_with_fewer_jacobians(e1):
    """LP -> OT 15 N with the chord corrector (later corrector steps without a Jacobian): the
    same extremal as Newton's corrector, fewer Jacobians."""
    ot = chain.solve_ot(e1["lp"], 15.0, chain.ContinuationOptions(verbose=False, corrector="chord"))
    assert ot.stats["residual_evaluations"] > 0
    assert ot.stats["jacobian_evaluations"] < e1["ot"].stats["jacobian_evaluations"]
    np.testing.assert_allclose(ot.z, e1["ot"].z, rtol=1e-7, atol=1e-10)


def test_smoothed_continuation_reaches_the_direct_one(e1):
    """continue_in_params_smoothed (ε_f → 10⁻² → move → ε_f, the E8 n → n route) ends on the
    extremal the direct continuation at ε_f reaches: E1 OT at 15 → 16 N."""
    q = chain.ContinuationOptions(verbose=False)
    direct = chain.continue_ot_in_thrust(e1["ot"], 16.0, q)
    tr = e1["ot"].transfer
    detour = chain.continue_in_params_smoothed(e1["ot"], tr.params(thrust=16.0), 1e-2, q)
    assert detour.stats["final_residual"] < 1e-9 and detour.stats["eps_smooth"] == 1e-2
    np.testing.assert_allclose(detour.z, direct.z, rtol=1e-7, atol=1e-10)


def test_thrust_continuation_from_the_ot_solution(e1):
    """continue_ot_in_thrust (the Table 4.1.3 / E4 route, chain.continue_in_params): 15 -> 16 N
    converges and m_f grows with T (R19)."""
    ot16 = chain.continue_ot_in_thrust(e1["ot"], 16.0, chain.ContinuationOptions(verbose=False))
    assert ot16.thrust_N == 16.0 and ot16.stats["final_residual"] < 1e-9
    m = lambda sol: sample(sol, 50)["mass_kg"][-1]
    assert m(ot16) > e1["samples"]["ot"]["mass_kg"][-1]


def test_tmin_from_the_ot_side_reaches_the_lp_sides_tmin(e1):
    """The T_min → OT homotopy followed back from the OT 15 N solution (tmin_from_ot, the E7
    existence route) reaches τ = 0 on E1 and lands on the T_min of the (3.4.1) path from the LP."""
    tm = tmin_from_ot.solve_tmin_from_ot(e1["ot"], tmin_from_ot.FromOtOptions(verbose=False))
    assert tm.tau == 0.0 and not tm.extra["bound"] and tm.stats["final_residual"] < 1e-9
    assert math.isclose(tm.thrust_N, e1["tmin"].thrust_N, rel_tol=1e-8)
    verdict = chain.existence_verdict(tm, 15.0)
    assert verdict["exists"] and verdict["T_min_is"] == "minimum"


def test_a_path_cut_short_gives_an_upper_bound_whose_throttle_is_recorded(e1, tmp_path):
    """Stopped after a few steps, the route polishes its least-thrust path point at its own τ: a
    transfer with throttle 1 − τ + τδ ≤ 1, so its T bounds T_min from above; the artifact keeps τ,
    its samples the throttle, and the independent re-propagation replays that throttle."""
    tm = tmin_from_ot.solve_tmin_from_ot(e1["ot"], tmin_from_ot.FromOtOptions(max_steps=6, verbose=False))
    T_min = e1["tmin"].thrust_N
    stopped = tm.extra["path_stopped"]
    assert tm.extra["bound"] and 0.0 < tm.tau < 1.0 and stopped["reason"] and stopped["tau_reached"] <= tm.tau
    assert T_min < tm.thrust_N <= 15.0
    verdict = chain.existence_verdict(tm, 15.0)
    assert verdict["exists"] and verdict["T_min_is"] == "upper bound"
    assert verdict["exists"] is not chain.existence_verdict(tm, 0.5 * (T_min + tm.thrust_N))["exists"]   # None: undecided
    path = tmp_path / "tmin_bound.json"
    multirev.save(tm, path, CFG, 0.0, tm.extra)
    smp = np.load(path.with_suffix(".npz"))
    assert 1.0 - tm.tau <= smp["delta"].min() < smp["delta"].max() <= 1.0
    back = multirev.load(path)
    assert back.tau == tm.tau and float(back.prm["thrust"]) == float(tm.prm["thrust"])
    check = verify.verify_ot(path)
    # 0.05 km at 200 samples per revolution (6.7 km with the samples' primer shifted as at τ = 0)
    assert check["final_position_vs_solver_km"] < 0.5 and abs(check["final_mass_error_kg"]) < 1e-4, check
    # always on: the replay also says how far a thrust changed by 1e-7 moves the end point
    assert check["thrust_probe_relative"] == verify.THRUST_PROBE and check["final_position_moved_by_thrust_probe_km"] > 0.0


def test_the_step_cap_is_traced_and_fails_a_propagation_that_needs_more(e1):
    """Shooting.max_steps is a traced value (.flow.StepCap): layouts that differ only in their cap
    share one compiled program and give the same map to the bit, and a cap one step below what
    the propagation needs fails it, as diffrax's static max_steps did."""
    import dataclasses
    from spaceopt.indirect import shooting
    ot = e1["ot"]
    z = jnp.asarray(ot.z)
    full = shooting.shoot(ot.shooting, z, 1.0, ot.prm)
    needed = int(full[3])
    assert bool(shooting.final_state(ot.shooting, z, 1.0, ot.prm)[1])
    compiled = (shooting._shoot_capped._cache_size(), shooting._final_state_capped._cache_size())
    for cap, ok in ((needed, True), (needed - 1, False)):
        capped = dataclasses.replace(ot.shooting, max_steps=cap)
        f, J, _, steps, success = shooting.shoot(capped, z, 1.0, ot.prm)
        assert bool(success) is ok and int(steps) == needed       # a failed solve stops at step cap + 1
        if ok:
            assert np.array_equal(f, full[0]) and np.array_equal(J, full[1])
    # y alone is another compiled program, whose steps differ from those with Φ at round-off (XLA's
    # fused multiply-adds), by a step or two
    for cap, ok in ((needed + 10, True), (needed - 10, False)):
        capped = dataclasses.replace(ot.shooting, max_steps=cap)
        assert bool(shooting.final_state(capped, z, 1.0, ot.prm)[1]) is ok
    assert (shooting._shoot_capped._cache_size(), shooting._final_state_capped._cache_size()) == compiled
    # the re-propagations of a solution return diffrax's flag (no callback in the program, which
    # JAX's persistent cache would refuse) and fail with a diagnosis, not from inside XLA
    from spaceopt.errors import ConvergenceError
    for sol, redo in ((e1["ot"], lambda s: chain.dense(s, samples_per_rev=50)), (e1["lp"], chain.lp_integrals)):
        starved = dataclasses.replace(sol, shooting=dataclasses.replace(sol.shooting, max_steps=10))
        with pytest.raises(ConvergenceError, match="the propagation failed .step cap 10"):
            redo(starved)
    lp = e1["lp"]
    y0 = shooting.initial_state(lp.shooting, jnp.asarray(lp.z), lp.prm)
    assert "callback" not in chain._lp_integrals.lower(lp.shooting.model, y0, lp.K_f, lp.prm, 10).as_text()


def test_a_propagation_whose_step_shrinks_to_zero_at_a_non_finite_field_fails_at_once():
    """At a wall past which the field is not finite, each step across it is rejected and shrunk
    until K + dK == K; that zero-length step is accepted (its error is zero) and stays zero (the
    PID update is multiplicative), so the solve used to run out its cap. .flow.StepCap ends it
    (dt_min_reached) at the second zero-length proposal, at the wall; without a wall the same
    controller integrates through."""
    import diffrax
    from spaceopt.indirect import flow
    from spaceopt.indirect.transfer import STEP_BOUND

    def solve(wall):
        term = diffrax.ODETerm(lambda t, y, args: jnp.where(y < wall, jnp.cos(y), jnp.nan))
        return diffrax.diffeqsolve(term, diffrax.Dopri8(), t0=0.0, t1=2.0, dt0=None, y0=jnp.zeros(1),
                                   stepsize_controller=flow.step_control(1e-10, 1e-12, 100_000),
                                   saveat=diffrax.SaveAt(t1=True), max_steps=STEP_BOUND, throw=False)
    walled = solve(0.5)                              # y = arcsin(tanh t) reaches 0.5 at t = 0.522
    assert walled.result == diffrax.RESULTS.dt_min_reached
    assert int(walled.stats["num_steps"]) < 1000 and 0.5 - 1e-6 < float(walled.ys[-1, 0]) < 0.5
    through = solve(10.0)
    assert through.result == diffrax.RESULTS.successful
    assert abs(float(through.ys[-1, 0]) - np.arcsin(np.tanh(2.0))) < 1e-9


def test_a_datum_reaches_the_compiled_programs_with_one_input_type(e1):
    """τ given as a Python float (a polish), a NumPy scalar (an arclength path) or an array
    shares one compiled Jacobian program and gives the same map to the bit; a solution's data
    are strongly typed (transfer.datum): a weakly typed scalar is another input type to jax.jit,
    and every program it reached was traced and compiled again."""
    from spaceopt.indirect import shooting
    ot = e1["ot"]
    z = jnp.asarray(ot.z)
    ref = shooting.shoot(ot.shooting, z, 1.0, ot.prm)
    compiled = shooting._shoot_capped._cache_size()
    for tau in (np.float64(1.0), jnp.asarray(1.0), np.float32(1.0)):
        assert np.array_equal(shooting.shoot(ot.shooting, z, tau, ot.prm)[1], ref[1])
    assert shooting._shoot_capped._cache_size() == compiled
    for sol in (e1["lp"], e1["tmin"], ot):
        assert not [k for k, v in sol.prm.items() if isinstance(v, jax.Array) and v.weak_type], sol.prm
