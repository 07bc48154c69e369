"""The exact bang-bang shooting map (spaceopt.indirect.exact_switching) on E1 (2 revolutions)
under J2: switches, Jacobian, τ column, Newton from the smoothed root, chain.to_exact."""
import dataclasses
from pathlib import Path

import diffrax
import jax
import jax.numpy as jnp
import numpy as np
import pytest
import yaml

from spaceopt.errors import ConfigError
from spaceopt.indirect import chain, exact_switching as X, hamiltonians as hm
from spaceopt.indirect.flow import Model, StepMemory, primal_control
from spaceopt.indirect.shooting import (Shooting, final_state, initial_state, residual, sensitivity_tolerances,
                                       shoot)
from spaceopt.studies import multirev, multirev_config

ROOT = Path(__file__).resolve().parents[1]
CFG = yaml.safe_load((ROOT / "config" / "studies" / "multirev.yaml").read_text())["multirev"]
TR = dataclasses.replace(multirev_config.transfer_from_config(CFG, "e1"), perturbations={"geopotential": "j2"},
                         epoch_utc="2021-05-09T12:00:00")


@pytest.fixture(scope="module")
def smoothed(e1_j2_ot):
    """The smoothed OT extremal at ε_f = 1e-5 (LP → OT → ε; conftest, TR's problem), and its
    exact layout."""
    assert repr(e1_j2_ot.transfer) == repr(TR)        # (== is False: thrust is nan)
    return e1_j2_ot, dataclasses.replace(e1_j2_ot.shooting, switching="exact")


@pytest.fixture(scope="module")
def exact(smoothed):
    """chain.to_exact of the smoothed extremal: the exact extremal that Newton reaches from it."""
    return chain.to_exact(smoothed[0])


@pytest.fixture(scope="module")
def unperturbed_exact():
    """The exact extremal of TR's problem without perturbations (LP → OT 15 N → chain.to_exact)."""
    tr_u = dataclasses.replace(TR, perturbations=None, epoch_utc=None)
    return chain.to_exact(chain.solve_ot(chain.solve_lp(tr_u), 15.0))


def _switching_along(ot):
    """S on the smoothed extremal's dense trajectory, 400 samples per revolution: (K, S)."""
    Ks, ys = chain.dense(ot, samples_per_rev=400)
    S = np.array([float(X.switching(ot.shooting.model, k, jnp.asarray(y), 1.0, ot.prm)) for k, y in zip(Ks, ys)])
    return Ks, S


def test_the_switches_are_the_sign_changes_of_the_smoothed_extremal(smoothed):
    """Pass 1 finds one switch per sign change of S along the smoothed extremal (sampled at 400
    points per revolution), each within one sample interval of it."""
    ot, sh = smoothed
    z = jnp.asarray(ot.z)
    d0, Ks, n_sw, status = X.switch_points(sh, z, 1.0, ot.prm, sh.rtol, sh.atol)
    assert X.STATUS[int(status)] == "done"
    K, S = _switching_along(ot)
    changes = np.nonzero(np.diff(np.sign(S)))[0]
    assert int(n_sw) == len(changes) >= 4
    dK = K[1] - K[0]
    np.testing.assert_array_less(np.abs(np.asarray(Ks[:int(n_sw)]) - K[changes] - dK / 2), dK)
    assert float(d0) == float(S[0] > 0)
    # at a loose tolerance the stepped state at a switch misses S = 0 by more than S_NOISE (1.8e-9
    # at rtol 1e-8): the next arc must not stop on it
    _, Ks_loose, n_loose, status = X.switch_points(sh, z, 1.0, ot.prm, 1e-7, 1e-8)
    assert X.STATUS[int(status)] == "done" and int(n_loose) == int(n_sw)
    np.testing.assert_allclose(Ks_loose[:int(n_sw)], Ks[:int(n_sw)], rtol=0, atol=1e-4)


def test_the_switches_do_not_depend_on_how_the_arcs_are_cut_into_segments(unperturbed_exact, monkeypatch):
    """Pass 1 in segments of 3 steps finds the switches of its default segments (on the
    unperturbed extremal: a program of its own for the segment length, compiled in seconds), in
    nearly the same steps: each segment goes on with the step carried from the one before (with
    diffrax's initial-step rule at every segment instead, it takes many more)."""
    ex = unperturbed_exact
    sh, z = ex.shooting, jnp.asarray(ex.z)
    _, Ks, n_sw, status = X.switch_points(sh, z, 1.0, ex.prm, sh.rtol, sh.atol)
    assert X.STATUS[int(status)] == "done" and int(n_sw) >= 4
    y0 = initial_state(sh, z, ex.prm)
    whole, cut = (X.switches(sh.model, y0, z[sh.kf_index], 1.0, ex.prm, sh.rtol, sh.atol, sh.max_steps,
                             segment_steps=k) for k in (X.SEGMENT_STEPS, 3))
    assert int(cut["n_switches"]) == int(n_sw)
    np.testing.assert_allclose(cut["Ks"], Ks, rtol=0, atol=1e-9)
    assert int(cut["steps"]) <= 1.05 * int(whole["steps"])          # E1: 88 and 88
    monkeypatch.setattr(X, "CARRY_STEPS", False)
    ruled = X.switches(sh.model, y0, z[sh.kf_index], 1.0, ex.prm, sh.rtol, sh.atol, sh.max_steps, segment_steps=3)
    assert int(ruled["n_switches"]) == int(n_sw)
    assert int(ruled["steps"]) > 1.2 * int(cut["steps"])           # E1: 168


def test_an_integration_cut_and_continued_with_the_carried_step_takes_the_steps_of_the_uncut_one():
    """flow.StepMemory: a solve stopped after k steps and continued from the step it recorded
    reaches the uncut solve's end in its number of steps and at its state (diffrax's default
    controller adapts from the last error alone, so the continued solve takes the uncut one's
    steps; the pass-1 test above shows what the initial-step rule costs instead)."""
    term = diffrax.ODETerm(lambda t, y, a: jnp.stack([y[1], -y[0] / (1.0 + 0.5 * jnp.cos(t)) ** 3]))

    def solve(t0, y0, dt0, max_steps):
        return diffrax.diffeqsolve(term, diffrax.Dopri8(), t0, 20.0, dt0, y0,
                                   stepsize_controller=StepMemory(primal_control(1e-10, 1e-12)),
                                   saveat=diffrax.SaveAt(t1=True, controller_state=True), max_steps=max_steps,
                                   throw=False)
    y0 = jnp.array([1.0, 0.0])
    whole = solve(0.0, y0, 1e-3, 4096)
    cut = solve(0.0, y0, 1e-3, 20)
    assert float(cut.ts[-1]) < 20.0
    carried = solve(cut.ts[-1], cut.ys[-1], StepMemory.proposals(cut.controller_state)[0], 4096)
    assert int(cut.stats["num_steps"]) + int(carried.stats["num_steps"]) == int(whole.stats["num_steps"])
    np.testing.assert_allclose(carried.ys[-1], whole.ys[-1], rtol=1e-12, atol=1e-14)


def test_the_jacobian_is_the_derivative_of_the_exact_residual(smoothed):
    """∂f/∂z from the saltation matrices against central differences of the exact residual."""
    ot, sh = smoothed
    z = jnp.asarray(ot.z)
    f, J, _, _, ok = shoot(sh, z, 1.0, ot.prm)
    assert bool(ok)
    cols = []
    for j in range(len(z)):
        h = 1e-7 * max(1.0, abs(float(z[j])))
        dz = jnp.zeros_like(z).at[j].set(h)
        cols.append((residual(sh, z + dz, 1.0, ot.prm)[0] - residual(sh, z - dz, 1.0, ot.prm)[0]) / (2 * h))
    J_fd = np.stack(cols, axis=1)
    assert np.linalg.norm(J - J_fd) / np.linalg.norm(J) < 1e-4
    # the smoothed map's Jacobian at ε_f differs by more than the differences' error
    _, J_smooth, _, _, _ = shoot(ot.shooting, z, 1.0, ot.prm)
    assert np.linalg.norm(J - J_smooth) / np.linalg.norm(J) > 1e-7


def test_the_tau_column_is_the_derivative_in_the_homotopy_parameter(smoothed):
    """∂f/∂τ of the perturbation switch (homotopy 'pert') at τ = 0.5: the field's own τ
    dependence plus the shift of every switch."""
    ot, sh = smoothed
    sh_pert = dataclasses.replace(sh, model=Model("ot", "pert", True))
    z, h = jnp.asarray(ot.z), 1e-4
    _, _, ftau, _, _ = shoot(sh_pert, z, 0.5, ot.prm)
    fd = (residual(sh_pert, z, 0.5 + h, ot.prm)[0] - residual(sh_pert, z, 0.5 - h, ot.prm)[0]) / (2 * h)
    assert np.linalg.norm(ftau - fd) / np.linalg.norm(ftau) < 1e-4


@pytest.mark.parametrize("switching, threads", [("smoothed", "3"), ("exact", "2")])
def test_the_columns_propagated_in_threads_give_the_same_map(smoothed, monkeypatch, switching, threads):
    """SPACEOPT_THREADS > 1 (.column_threads): Φ's columns in blocks, one thread each (9
    columns: 3 blocks of 3 on the smoothed map; 2 blocks of 5, one a zero column of padding, on
    the exact map, whose saltations then jump that column too), at τ = 0.5 of the perturbation
    switch where the τ column is not trivial: f, ∂f/∂z, ∂f/∂τ and the steps of one computation;
    traced (under jax.jit), the program of one thread; a thread count that is not a positive
    integer refused. (Each map with one block size: every block size is a program of its own.)"""
    ot, sh = smoothed
    z = jnp.asarray(ot.z)
    layout = dataclasses.replace({"smoothed": ot.shooting, "exact": sh}[switching], model=Model("ot", "pert", True))
    monkeypatch.setenv("SPACEOPT_THREADS", "1")
    one = shoot(layout, z, 0.5, ot.prm)
    monkeypatch.setenv("SPACEOPT_THREADS", threads)
    split = shoot(layout, z, 0.5, ot.prm)
    assert bool(split[4]) and int(split[3]) == int(one[3])
    np.testing.assert_allclose(split[0], one[0], rtol=0, atol=1e-14)
    for a, b in zip(split[1:3], one[1:3]):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * float(jnp.abs(b).max()))
    # under a transformation the map stays one computation: it traces to the program of one
    # thread (compiling that program again would only repeat it)
    program = lambda: str(jax.make_jaxpr(lambda zz: shoot(layout, zz, 0.5, ot.prm))(z))  # noqa: E731
    traced = program()
    monkeypatch.setenv("SPACEOPT_THREADS", "1")
    assert traced == program() and "while" in traced
    monkeypatch.setenv("SPACEOPT_THREADS", "two")
    with pytest.raises(ConfigError, match="SPACEOPT_THREADS='two': expected a positive integer"):
        shoot(sh, z, 1.0, ot.prm)


def test_the_sensitivities_at_a_looser_tolerance_keep_f_and_the_root(smoothed, exact):
    """Shooting.sensitivity_rtol: pass 2 (Φ) at the looser tolerance, in fewer steps; f stays
    pass 1's, the residual map's, to the bit; ∂f/∂z moves within Newton's margin
    (‖J⁻¹ δJ‖ < 0.1); Newton from the smoothed root lands on the same exact extremal."""
    ot, sh = smoothed
    z = jnp.asarray(ot.z)
    loose = dataclasses.replace(sh, sensitivity_rtol=1e-7)
    assert sensitivity_tolerances(loose, 1e-11, 1e-12) == (1e-7, pytest.approx(1e-8))
    assert sensitivity_tolerances(loose, 1e-6, 1e-7) == (1e-6, 1e-7)
    assert sensitivity_tolerances(sh, 1e-11, 1e-12) == (1e-11, 1e-12)
    f, J, _, steps, _ = shoot(sh, z, 1.0, ot.prm)
    f_l, J_l, _, steps_l, ok = shoot(loose, z, 1.0, ot.prm)
    assert bool(ok) and int(steps_l) < int(steps)
    np.testing.assert_array_equal(f_l, residual(sh, z, 1.0, ot.prm)[0])
    np.testing.assert_array_equal(f_l, f)
    rho = np.linalg.norm(np.linalg.solve(J, J_l - J), 2)
    assert 0 < rho < 0.1
    ex_l = chain.to_exact(dataclasses.replace(ot, shooting=dataclasses.replace(ot.shooting, sensitivity_rtol=1e-7)))
    assert ex_l.shooting.sensitivity_rtol == 1e-7
    np.testing.assert_allclose(ex_l.z, exact.z, rtol=0, atol=1e-9)


def test_newton_from_the_smoothed_root_lands_on_the_exact_extremal(smoothed, exact):
    """chain.to_exact: one Newton step from the ε_f root; the exact extremal's m_f and Δt lie
    within ε_f's order of the smoothed ones, and it keeps the smoothed switch structure."""
    ot, ex = smoothed[0], exact
    assert ex.shooting.switching == "exact" and ex.stats["jacobian_evaluations"] <= 3
    f, _ = residual(ex.shooting, jnp.asarray(ex.z), 1.0, ex.prm)
    assert float(jnp.max(jnp.abs(f))) < 1e-9
    y_s, _ = final_state(ot.shooting, jnp.asarray(ot.z), 1.0, ot.prm)
    y_x, _ = final_state(ex.shooting, jnp.asarray(ex.z), 1.0, ex.prm)
    assert abs(float(y_x[hm.MASS] - y_s[hm.MASS])) < 1e-6
    assert abs(float(y_x[hm.TIME] - y_s[hm.TIME])) / float(y_s[hm.TIME]) < 1e-6
    assert 0 < np.max(np.abs(ex.z - ot.z)) < 1e-6


def test_the_exact_layout_is_refused_where_it_is_undefined():
    with pytest.raises(ValueError, match="pure OT"):
        Shooting(Model("ot", "lp"), (0, 1), switching="exact")
    with pytest.raises(ValueError, match="pure OT"):
        Shooting(Model("tmin", "ot"), (0, 1), switching="exact")
    with pytest.raises(ValueError, match="single shooting"):
        Shooting(Model("ot", "eps"), (0, 1), switching="exact", path_arcs=10)
    with pytest.raises(ValueError, match="neither"):
        Shooting(Model("ot", "eps"), (0, 1), switching="bang")


def test_perturbations_switched_on_and_changed_on_the_exact_map(exact, unperturbed_exact):
    """studies.perturbed.perturb_from_unperturbed from an exact unperturbed extremal: J2 switched
    on by τ on the exact map lands on the exact J2 extremal that Newton reaches from the smoothed
    J2 one; chain.continue_in_model then moves it to the 2×2 geopotential on the exact map (2×2:
    time-dependent like the studies' 4×4, and its programs compile ~30 % faster)."""
    from spaceopt.studies import perturbed as P
    unperturbed = unperturbed_exact
    j2 = P.perturb_from_unperturbed(unperturbed, TR, "j2 on", path="tau")
    assert j2.shooting.switching == "exact" and j2.shooting.model.perturbed
    np.testing.assert_allclose(j2.z, exact.z, rtol=0, atol=1e-8)
    with pytest.raises(Exception, match="no smoothing eps"):
        P.perturb_from_unperturbed(unperturbed, TR, "j2 on", eps_smooth=1e-2)
    # the force model changed on the exact map (the data's smoothing eps is no datum of it)
    tr22 = dataclasses.replace(TR, perturbations={"geopotential": {"degree": 2, "order": 2}})
    g22 = chain.continue_in_model(j2, tr22.params(thrust=15.0))
    assert g22.shooting.switching == "exact" and float(g22.prm["eps_final"]) == 0.0
    f, ok = residual(g22.shooting, jnp.asarray(g22.z), 1.0, g22.prm)
    assert bool(ok) and float(jnp.max(jnp.abs(f))) < 1e-9 and np.max(np.abs(g22.z - j2.z)) > 1e-9


def test_an_exact_solution_is_sampled_saved_and_read_back(exact, tmp_path):
    """The dense trajectory of an exact solution steps to its switches (its last sample is the
    shooting map's y(K_f)), its throttle samples are 0 or 1, and its artifact reads back as the
    exact problem."""
    ex = exact
    _, ys = chain.dense(ex, samples_per_rev=50)
    yf, _ = final_state(ex.shooting, jnp.asarray(ex.z), 1.0, ex.prm)
    assert np.max(np.abs(ys[-1] - np.asarray(yf))) < 1e-8
    path = tmp_path / "exact.json"
    multirev.save(ex, path, {}, 1.0, samples_per_rev=50)
    delta = np.load(path.with_suffix(".npz"))["delta"]
    assert set(np.unique(delta)) == {0.0, 1.0}
    back = multirev.load(path)
    assert back.shooting.switching == "exact" and float(back.prm["eps_final"]) == 0.0
    f, ok = residual(back.shooting, jnp.asarray(back.z), 1.0, back.prm)
    assert bool(ok) and float(jnp.max(jnp.abs(f))) < 1e-9


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_an_arc_shorter_than_a_sample_interval_is_found_from_its_birth(monkeypatch, sign):
    """Pass 1 on a toy field u' = 1 with S = ±(c − (u − 2)²): an arc of the other throttle on
    [2 − √c, 2 + √c] is found for every c > 0 down to 1e-14 (width 2e-7, far below the sample
    spacing of Dopri8's long steps on this field), at the right place, and not for c < 0: the
    switch list, and so f, moves continuously where an arc is born."""
    monkeypatch.setattr(X, "field", lambda model, K, y, tau, prm, delta: jnp.ones_like(y))
    monkeypatch.setattr(X, "switching", lambda model, K, y, tau, prm: sign * (prm - (y[0] - 2.0) ** 2))
    pass1 = jax.jit(lambda c: X.switches(None, jnp.zeros(1), 5.0, 1.0, c, 1e-12, 1e-13, 1000))
    for c in (0.25, 1e-6, 1e-10, 1e-14, -1e-14, -1e-6):
        out = pass1(c)
        assert X.STATUS[int(out["status"])] == "done"
        assert float(out["d0"]) == float(sign < 0)
        n = int(out["n_switches"])
        if c < 0:
            assert n == 0, c
        else:
            assert n == 2, c
            np.testing.assert_allclose(out["Ks"][:2], [2 - c**0.5, 2 + c**0.5], rtol=0, atol=1e-12)
