"""The minimum-fuel family followed down in the thrust (spaceopt.studies.thrust_family): E1
(2 revolutions) under J2 from its 15 N OT extremal (conftest), moved to ε 1e-2 and on to 14 N,
then a thrust far below its T_min that the family cannot reach; and its points at ε 1e-2 (15 and
14 N) carried to the 2×2 geopotential on the Earth rotation angle (conftest's e1_g22_era model,
whose OT programs the cache shares), the least-thrust one followed on down from there."""
import dataclasses

import jax.numpy as jnp
import numpy as np
import pytest

from spaceopt.errors import ConfigError, ConvergenceError
from spaceopt.indirect.continuation import ContinuationOptions
from spaceopt.indirect.shooting import residual
from spaceopt.studies import perturbed as P, thrust_family as TF, verify
from spaceopt.studies.perturbed_report import MODEL_TEX
from spaceopt.studies.trajectory import sample

G22_ERA = {"geopotential": {"degree": 2, "order": 2}, "earth_angle": "era"}


def _norm_f(sol, prm) -> float:
    """|f| of the OT problem with data ``prm`` at the unknowns of ``sol``."""
    f, ok = residual(sol.shooting, jnp.asarray(sol.z), 1.0, prm)
    assert bool(ok)
    return float(np.linalg.norm(f))


@pytest.fixture(scope="module")
def family(e1_j2_ot):
    """follow() through 14 N and 0.5 N (30 steps a path at most), with every checkpoint kept."""
    seen = []
    last, points, stop = TF.follow(e1_j2_ot, [14.0, 0.5], 1e-2, ContinuationOptions(max_steps=30, verbose=False),
                                   "e1 family", on_point=lambda s, pts: seen.append((s, [dict(p) for p in pts])))
    return last, points, stop, seen


def test_each_point_solves_the_ot_problem_at_its_thrust_and_eps(family, e1_j2_ot):
    """The start at its own ε, the same extremal at the family's ε, then 14 N: each a root of the
    OT problem with that thrust and ε (the residual of its own data, not the path's), written
    to the checkpoint as it was reached."""
    last, points, stop, seen = family
    assert [(p["thrust_N"], p["eps"]) for p in points] == [(15.0, 1e-5), (15.0, 1e-2), (14.0, 1e-2)]
    assert [len(pts) for _, pts in seen] == [1, 2, 3] and seen[-1][1] == points
    assert e1_j2_ot.prm["eps_final"] == 1e-5                     # the start is not changed
    for sol, pts in seen:
        assert sol.transfer.thrust == sol.thrust_N == pts[-1]["thrust_N"]
        assert sol.transfer.eps_final == sol.prm["eps_final"] == pts[-1]["eps"]
        assert _norm_f(sol, sol.transfer.params(thrust=sol.thrust_N)) < 1e-8
    assert last is seen[-1][0]
    assert points[1]["m_f_kg"] < points[0]["m_f_kg"]             # the smoothing costs propellant


def test_a_point_is_a_transfer_whose_thrust_never_exceeds_its_own(family):
    """The bound's premise: the throttle lies in [0, 1], so |thrust| ≤ T all along, and the
    duty m_p c / (T Δt) is at most 1; the described scalars are those of the samples."""
    last, points, _, _ = family
    s = sample(last, 200)
    assert np.max(np.linalg.norm(s["thrust_N"], axis=1)) <= 14.0 * (1 + 1e-12)
    assert 0 < points[-1]["duty"] <= 1 and points[-1]["least_radius_km"] > 6378
    assert points[-1]["tof_days"] == pytest.approx(s["t_s"][-1] / 86400, rel=1e-12)
    assert points[-1]["propellant_kg"] == pytest.approx(last.transfer.m0 - s["mass_kg"][-1], rel=1e-12)
    assert points[-1]["max_apogee_km"] >= np.max(np.linalg.norm(s["r_m"], axis=1)) / 1e3 * (1 - 1e-9)


def test_a_thrust_not_reached_stops_the_family_without_losing_it(family):
    last, points, stop, _ = family
    assert stop.startswith("T 0.5 N not reached") and last.thrust_N == 14.0 and len(points) == 3


def test_a_point_saved_and_loaded_resumes_as_the_same_problem(family, tmp_path):
    """The DAG's checkpoint and artifact: saved and loaded, the 14 N point at ε 1e-2 is the same
    root of the same problem, and the family resumed from it starts at once (no ε move)."""
    last, points, _, _ = family
    P.save(last, tmp_path / "point.json", {"test": 1}, 0.0, {"family": {"points": points}}, samples_per_rev=20)
    back = P.load(tmp_path / "point.json")
    assert (back.thrust_N, back.prm["eps_final"]) == (14.0, 1e-2)
    np.testing.assert_allclose(back.z, last.z, rtol=0, atol=0)
    assert _norm_f(back, back.prm) < 1e-8
    again, pts, stop = TF.follow(back, [], 1e-2, None, "resume", points)
    assert again is back and pts == points and stop == ""


def test_the_verifier_replays_a_family_point_and_probes_its_thrust(family, tmp_path):
    """The DAG re-propagates each family's least-thrust point (studies.verify), re-sampled from its
    unknowns: with the recorded throttle it lands on the solver's end point, and, as on a
    minimum-thrust trajectory, the thrust probe says how sensitive that end point is."""
    last, points, _, _ = family
    P.save(last, tmp_path / "family_j2.json", {"test": 1}, 0.0, {"family": {"points": points}}, samples_per_rev=20)
    (tmp_path / "fine").mkdir()
    check = verify.verify_ot(verify.resampled(tmp_path / "family_j2.json", tmp_path / "fine", 400))   # as the DAG
    assert check["success"] and check["final_position_vs_solver_km"] < 1.0
    assert abs(check["final_mass_error_kg"]) < 1e-3
    assert check["thrust_probe_relative"] == verify.THRUST_PROBE and check["final_position_moved_by_thrust_probe_km"] > 0


@pytest.fixture(scope="module")
def carried(family, e1_j2_ot):
    """The family's points at ε 1e-2 (J2: 15 and 14 N) carried to 2×2 on the ERA, the 14 N one then
    on down to 13.9 N."""
    last, points = family[0], family[1]
    target = dataclasses.replace(e1_j2_ot.transfer, perturbations=G22_ERA, thrust=99.0, eps_final=1e-5)
    options = ContinuationOptions(max_steps=30, verbose=False)
    seen = []
    seed_points = TF.seeds(last, points, 1e-2)
    first, pts, failed = TF.carry_points(seed_points, target, options, "carry",
                                         on_point=lambda s, p, f: seen.append((s, len(p), dict(f))))
    return seed_points, first, pts, failed, seen, target, TF.follow(first, [13.9], 1e-2, options, "carried", pts)


def test_the_seeds_are_the_points_at_the_familys_eps_by_falling_thrust(family, carried):
    """A family's points keep their unknowns, and its points at its ε are solutions of their own
    problems (the start at ε_f is not one of them)."""
    seed_points = carried[0]
    assert [(s.thrust_N, s.prm["eps_final"]) for s in seed_points] == [(15.0, 1e-2), (14.0, 1e-2)]
    for s in seed_points:
        assert _norm_f(s, s.transfer.params(thrust=s.thrust_N)) < 1e-8
    np.testing.assert_array_equal(seed_points[-1].z, family[0].z)


def test_each_point_carried_to_another_model_solves_that_models_problem(carried):
    """Each carried point keeps its seed's thrust and ε (not the target transfer's), is a root of
    the OT problem under the target model and not under the seed's, and each was checkpointed;
    the family goes on down from the least-thrust one as from any point."""
    seed_points, first, pts, failed, seen, _, (last, points, stop) = carried
    assert failed == {} and [p["thrust_N"] for p in pts] == [15.0, 14.0] and [n for _, n, _ in seen] == [1, 2]
    assert (first.thrust_N, first.prm["eps_final"]) == (14.0, 1e-2) == (first.transfer.thrust, first.transfer.eps_final)
    assert first.transfer.perturbations == G22_ERA and first.stats["steps"] > 0 and seen[-1][0] is first
    for p, s in zip(pts, seed_points):
        here = TF.at_thrust(dataclasses.replace(first, z=np.asarray(p["z"])), p["thrust_N"], 1e-2)
        assert _norm_f(here, here.transfer.params(thrust=p["thrust_N"])) < 1e-8
        assert _norm_f(here, dataclasses.replace(here.transfer, perturbations=s.transfer.perturbations).params(
            thrust=p["thrust_N"])) > 1e-6
        assert abs(p["m_f_kg"] - TF.describe(s)["m_f_kg"]) < 1.0             # 2×2 is a small change
    assert stop == "" and [p["thrust_N"] for p in points] == [15.0, 14.0, 13.9] and last.thrust_N == 13.9
    assert _norm_f(last, last.transfer.params(thrust=13.9)) < 1e-8


def test_a_resumed_carry_skips_the_points_done_and_a_failed_one_is_recorded_not_raised(carried, monkeypatch):
    """An interrupted job's points and failures are not tried again; a seed whose carry does not
    arrive (a ConvergenceError: here the 15 N one's, raised in its place) is listed with its
    reason, and the points before it stand."""
    seed_points, first, pts, _, _, target, _ = carried
    options = ContinuationOptions(max_steps=30, verbose=False)
    assert TF.carry_points(seed_points, target, options, "again", pts, {}) == (None, pts, {})

    def carry(seed, tr, opt, label):
        raise ConvergenceError(f"{label}: fold", {"reason": "fold"})
    monkeypatch.setattr(TF, "carry", carry)
    last, points, failed = TF.carry_points(seed_points, target, options, "failing", pts[1:])
    assert last is None and points == pts[1:] and failed == {"15": "failing 15 N: fold"}
    assert TF.carry_points(seed_points, target, options, "resumed", pts[1:], failed) == (None, pts[1:], failed)


def test_the_rows_and_the_sentence_name_each_bound_and_its_stop():
    pts = [{"thrust_N": t, "eps": e, "m_f_kg": m, "propellant_kg": 1000 - m, "tof_days": d, "max_apogee_km": a,
            "max_e": 0.9, "least_radius_km": 6871.0, "duty": 0.99, "steps": 3, "jacobians": 5, "wall_s": 1.0}
           for t, e, m, d, a in ((1.0, 1e-5, 850.3, 88.1, 75000.0), (1.0, 1e-2, 846.5, 87.9, 75339.0),
                                 (0.3, 1e-2, 668.273, 192.39, 535422.0))]
    rows = TF.rows("e7", {"extra": {"family": {"model": "unperturbed", "start": "ot", "points": pts}}})
    assert list(rows[0]) == list(TF.COLUMNS) and [r["thrust_N"] for r in rows] == [1.0, 1.0, 0.3]
    j2 = [{**r, "model": "j2", "thrust_N": r["thrust_N"] + 0.01} for r in rows]
    full = [{**rows[-1], "model": "g44_moon_sun", "start": "family_j2", "thrust_N": 0.31, "m_f_kg": 670.9}]
    own = [{**r, "model": "g44_moon_sun", "thrust_N": t, "hop": str(h)}      # as read back from the csv
           for r, t, h in zip(rows + rows[-1:], (1.0, 1.0, 0.8, 0.78), (False, False, False, True))]
    checked = {("e7", "unperturbed"): {"T_min_N": 0.309072, "T_min_is": "upper bound"}}
    stops = {("e7", "unperturbed", "ot"): "", ("e7", "j2", "ot"): "T 0.3 N not reached: fold",
             ("e7", "g44_moon_sun", "family_j2"): ""}
    text = TF.sentence(rows + j2 + full + own, {**stops, ("e7", "g44_moon_sun", "ot"): ""}, MODEL_TEX, checked)
    assert ("unperturbed $T_{min} \\le$ 0.3~N ($m_f$ 668.3~kg, $\\Delta t$ 192.4~d, apogee up to 535\\,422~km; "
            "the last listed thrust; the check above: $\\le$ 0.3091~N)") in text
    assert f"{MODEL_TEX['j2']} $T_{{min}} \\le$ 0.31~N" in text and "the next thrust was not reached" in text
    assert (f"{MODEL_TEX['g44_moon_sun']} (the {MODEL_TEX['j2']} family's points carried to it) $T_{{min}} \\le$ 0.31~N "
            "($m_f$ 670.9~kg") in text
    assert f"{MODEL_TEX['g44_moon_sun']} $T_{{min}} \\le$ 0.78~N" in text and "the last listed thrust; below 0.8~N by 1 branch hop)" in text
    assert text.count("branch hop") == 1
    assert TF.sentence([], {}, MODEL_TEX) == ""


def test_the_family_job_resumes_without_the_seeds_it_gave_up_and_a_failed_job_tries_them_again(tmp_path, monkeypatch):
    """workflow/scripts/perturbed_thrust_family.py with a seed family none of whose points
    arrives (the carry replaced by one that gives the 0.9 N seed up): interrupted after that, the
    job resumes without trying it again; run to the end it fails with its diagnosis, and its next
    run tries every seed again."""
    import importlib.util
    import sys
    from pathlib import Path
    from types import SimpleNamespace
    scripts = Path(__file__).parents[1] / "workflow/scripts"
    sys.path.insert(0, str(scripts))
    spec = importlib.util.spec_from_file_location("perturbed_thrust_family_job", scripts / "perturbed_thrust_family.py")
    job = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(job)
    seen, interrupt = [], [True]

    def carry_points(todo, tr, options, label, points, not_carried, on_point):
        seen.append(dict(not_carried))
        failed = {**not_carried, "0.9": "fold"}
        on_point(None, list(points or []), failed)
        if interrupt.pop():
            raise KeyboardInterrupt
        return None, [], failed
    monkeypatch.setattr(job.TF, "carry_points", carry_points)
    monkeypatch.setattr(job.TF, "seeds", lambda *a: [])
    monkeypatch.setattr(job.P, "transfer_from_config", lambda *a, **k: None)
    monkeypatch.setattr(job.P, "ephemeris_path", lambda *a: None)
    monkeypatch.setattr(job.P, "load", lambda path: None)
    monkeypatch.setattr(job.artifacts, "read_json", lambda path: {"extra": {"family": {"points": []}}})
    cfg = {"thrust_family": {"max_steps": 5, "eps": 1e-2, "thrusts_N": [0.9]}, "cases": {"e7": {"ephemeris": "e"}}}
    out = tmp_path / "family_g44_moon_sun_from_j2.json"
    sm = SimpleNamespace(params=SimpleNamespace(cfg=cfg, case="e7", model="g44_moon_sun", seed="j2", results=str(tmp_path)),
                         output=[str(out)], input=SimpleNamespace(seed="family_j2.json"))
    with pytest.raises(KeyboardInterrupt):
        job.main(sm)
    interrupt.append(False)
    with pytest.raises(ConvergenceError, match="no point of the j2 family"):
        job.main(sm)
    assert job.artifacts.failure_path(out).exists()
    interrupt.append(True)
    with pytest.raises(KeyboardInterrupt):
        job.main(sm)
    assert seen == [{}, {"0.9": "fold"}, {}]


HOPS = {**TF.HOP_DEFAULTS, "step_N": 0.06, "probe_days": 0.002}


@pytest.fixture(scope="module")
def hopped(carried):
    """The carried 2×2 family's 14 N point hopped to 13.9 N (:func:`TF.hop`), t_f predicted on the
    secant of its 15 and 14 N points."""
    first, pts = carried[1], carried[2]
    tof = TF.predicted_tof(pts, 13.9, 1e-2)
    return tof, TF.hop(first, 13.9, tof, ContinuationOptions(max_steps=30, verbose=False), HOPS, "hop")


def test_a_hop_lands_on_the_extremal_that_the_path_in_the_thrust_reaches(carried, hopped):
    """Where the family has no fold the hop (the fixed-time path in (T, t_f), then the end game in
    t_f) and the path in the thrust reach one free-time extremal: the same t_f and m_f, the hop's
    a root of every free-time row but p_t(K_f), which its end game brings to a crossing."""
    last = carried[-1][0]
    tof, sol = hopped
    assert (sol.thrust_N, sol.prm["eps_final"]) == (13.9, 1e-2) == (sol.transfer.thrust, sol.transfer.eps_final)
    assert not sol.shooting.fixed_time and sol.transfer.perturbations == G22_ERA
    here, there = TF.describe(sol), TF.describe(last)
    assert here["tof_days"] == pytest.approx(there["tof_days"], abs=2e-5)      # 2.1e-6 d
    assert here["m_f_kg"] == pytest.approx(there["m_f_kg"], abs=1e-4)          # 7.8 mg
    f, ok = residual(sol.shooting, jnp.asarray(sol.z), 1.0, sol.transfer.params(thrust=13.9))
    rows = np.asarray(f)
    pt = sol.shooting.residual_names().index("p_t(K_f)")
    assert np.linalg.norm(np.delete(rows, pt)) < 1e-7 and abs(rows[pt]) < 1e-5
    game = sol.stats["end_game"]
    assert game["t0_days"] == pytest.approx(tof, abs=1e-6) and game["tof_days"] == pytest.approx(here["tof_days"], abs=1e-7)
    assert sol.stats["jacobian_evaluations"] > game["jacobian_evaluations"] > 0


def test_a_hop_t_f_first_from_far_above_marches_back_to_the_same_extremal(carried, hopped):
    """With ``tof_first`` (t_f alone, then T at that t_f) from a t_f 0.05 d above the secant's,
    25 probes: the end game's march, its steps doubling from 0.002 d, comes back down to the
    extremal of the secant's hop in fewer solves than a march of probe steps would take."""
    first, pts = carried[1], carried[2]
    tof, near = hopped
    sol = TF.hop(first, 13.9, tof + 0.05, ContinuationOptions(max_steps=30, verbose=False), HOPS, "hop", tof_first=True)
    here, there = TF.describe(sol), TF.describe(near)
    assert here["tof_days"] == pytest.approx(there["tof_days"], abs=2e-5)
    assert here["m_f_kg"] == pytest.approx(there["m_f_kg"], abs=1e-4)
    assert sol.stats["steps"] >= 2 and sol.stats["end_game"]["t0_days"] == pytest.approx(tof + 0.05, abs=1e-6)
    assert sol.stats["end_game"]["fixed_time_solves"] < 0.05 / HOPS["probe_days"]


@pytest.mark.parametrize("given, why", [({"first_step": 1e-3, "max_path_steps": 3}, "too many continuation steps"),
                                        ({"first_step": 1e-3, "runoff_slope": 1.01, "runoff_steps": 2}, "runs off: 2 steps in a row")])
def test_a_hop_whose_fixed_time_path_takes_too_many_steps_or_runs_off_fails(carried, given, why):
    """The fixed-time path is given up after ``max_path_steps`` steps (from a first step of 1e-3
    three steps cannot reach τ = 1), and where it runs off: ``runoff_steps`` steps in a row with
    |dτ/ds| < ``runoff_slope`` (above 1 every step counts), as a ConvergenceError the hops halve on."""
    first, pts = carried[1], carried[2]
    with pytest.raises(ConvergenceError, match=why):
        TF.hop(first, 13.9, TF.predicted_tof(pts, 13.9, 1e-2), ContinuationOptions(verbose=False), {**HOPS, **given},
               "hop")


@pytest.fixture
def fake_hops(carried, monkeypatch):
    """follow() from the carried 14 N point with its path in the thrust failing and :func:`TF.hop`
    replaced by one that keeps the unknowns and fails over more than 0.035 N: (the calls of the
    hop as (from, to) thrusts, follow with these two in place)."""
    from spaceopt.indirect import chain
    first, pts = carried[1], carried[2]
    calls = []

    def path(sol, prm, options, label, path="tau"):
        assert "/T " in label, "the hops must not call the path in the thrust"
        raise ConvergenceError(f"{label}: step-size underflow", {"reason": "underflow"})

    def hop(sol, T, tof, options, hops, label, tof_first=False):
        calls.append((sol.thrust_N, T))
        if sol.thrust_N - T > 0.035:
            raise ConvergenceError(f"{label}: no crossing", {"reason": TF.HOP_END_GAME})
        return dataclasses.replace(TF.at_thrust(sol, T, 1e-2), stats={"steps": 1, "end_game": {"tof_days": tof}})
    monkeypatch.setattr(chain, "continue_in_params", path)
    monkeypatch.setattr(TF, "hop", hop)
    return calls, lambda thrusts, hops, points=pts, start=first: TF.follow(start, thrusts, 1e-2, None, "f", points,
                                                                         hops=hops)


def test_a_failed_step_in_the_thrust_hands_over_to_hops_that_shrink_and_grow(fake_hops):
    """The step to 13.9 N fails; the hops go on from 14 N: halved where one fails (half the step
    tried: 13.94 → 13.9, cut short by the target to 0.04 N, is retried at 0.02 N), doubled again
    after each that arrives, through 13.9 N and on to 13.85 N without the path in the thrust."""
    calls, follow = fake_hops
    last, points, stop = follow([13.9, 13.85], HOPS)
    assert calls == [(14.0, 13.94), (14.0, 13.97), (13.97, 13.91), (13.97, 13.94), (13.94, 13.9), (13.94, 13.92),
                     (13.92, 13.9), (13.9, 13.85), (13.9, 13.875), (13.875, 13.85)]
    assert stop == "" and last.thrust_N == 13.85
    assert [(p["thrust_N"], p["hop"]) for p in points[2:]] == [(13.97, True), (13.94, True), (13.92, True), (13.9, True),
                                                              (13.875, True), (13.85, True)]
    assert [p["hop"] for p in points[:2]] == [False, False] and "end_game" in points[-1]


def test_a_hop_whose_fixed_time_path_fails_is_retried_once_with_t_f_moved_twice_as_far(fake_hops, carried,
                                                                                       monkeypatch):
    """A failure of the fixed-time path (not of the end game) retries the same thrust with t_f
    moved twice as far from the point's own, t_f first; a second failure halves the step."""
    _, follow = fake_hops
    first, pts = carried[1], carried[2]
    own, calls = TF.tof_of(first), []

    def hop(sol, T, tof, options, hops, label, tof_first=False):
        calls.append((sol.thrust_N, T, tof, tof_first))
        if len(calls) in (1, 3, 4):
            raise ConvergenceError(f"{label}: continuation failed", {"reason": "too many continuation steps"})
        return dataclasses.replace(TF.at_thrust(sol, T, 1e-2), stats={"steps": 1, "end_game": {"tof_days": tof}})
    monkeypatch.setattr(TF, "hop", hop)
    last, points, stop = follow([13.9], HOPS)
    secant = TF.predicted_tof(pts, 13.94, 1e-2)
    assert [c[:2] for c in calls] == [(14.0, 13.94), (14.0, 13.94), (13.94, 13.9), (13.94, 13.9), (13.94, 13.92),
                                      (13.92, 13.9)]
    assert calls[0][2] == pytest.approx(secant) and calls[1][2] - own == pytest.approx(2 * (secant - own))
    assert [c[3] for c in calls] == [False, True, False, True, False, False]
    assert calls[4][2] == pytest.approx(TF.predicted_tof(points[:-2], 13.92, 1e-2))
    assert stop == "" and last.thrust_N == 13.9


def test_hops_that_fail_down_to_the_least_step_stop_the_family_and_a_resumed_hop_hops_on(fake_hops):
    calls, follow = fake_hops
    last, points, stop = follow([13.9], {**HOPS, "min_step_N": 0.04})
    assert calls == [(14.0, 13.94)] and last.thrust_N == 14.0 and len(points) == 2
    assert stop.startswith("T 13.9 N not reached: the hop to 13.94 N failed with steps down to 0.06 N")
    calls.clear()
    resumed = [*points, {**points[-1], "thrust_N": 13.93, "hop": True}]
    last, points, stop = follow([13.9], HOPS, resumed, TF.at_thrust(last, 13.93, 1e-2))
    assert calls == [(13.93, 13.9)] and stop == "" and points[-1]["thrust_N"] == 13.9


def test_the_hop_settings_default_and_name_a_bad_key():
    assert TF.hop_settings(None, "k") is None
    assert TF.hop_settings({"step_N": 0.05}, "k") == {**TF.HOP_DEFAULTS, "step_N": 0.05}
    for bad, key in (({"step": 1}, "k.step"), ({"min_step_N": 0.1}, "k.min_step_N"), ({"probe_days": 0}, "k.probe_days"),
                     ({"max_points": 2.5}, "k.max_points"), ({"first_step": -0.3}, "k.first_step"),
                     ({"max_path_steps": 0}, "k.max_path_steps"), ({"max_march_days": 0.05}, "k.max_march_days"),
                     ({"runoff_steps": True}, "k.runoff_steps"), ({"runoff_slope": 0}, "k.runoff_slope"),
                     ([0.02], "k")):
        with pytest.raises(ConfigError, match=f"^{key.replace('.', '[.]')}"):
            TF.hop_settings(bad, "k")
