"""An upper bound on T_min carried from one force model to another (tmin_from_ot.bound_in_model,
the E7 full model's existence check): E1 (2 revolutions) under J2, carried to the 2×2
geopotential (time-dependent through C22/S22 like the studies' 4×4; its programs compile ~30 %
faster)."""
import dataclasses
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest
import yaml

from spaceopt import ephemeris
from spaceopt.errors import ConfigError
from spaceopt.indirect import tmin_from_ot
from spaceopt.indirect.flow import Model, field
from spaceopt.indirect.shooting import residual
from spaceopt.studies import existence as E, multirev_config, perturbed as P, verify

ROOT = Path(__file__).resolve().parents[1]
CFG = yaml.safe_load((ROOT / "config" / "studies" / "multirev.yaml").read_text())["multirev"]
EPOCH = "2021-05-09T12:00:00"


def _e1(geopotential):
    tr = multirev_config.transfer_from_config(CFG, "e1")
    return dataclasses.replace(tr, perturbations={"geopotential": geopotential}, epoch_utc=EPOCH)


TR_J2, TR_G22 = _e1("j2"), _e1({"degree": 2, "order": 2})


def test_the_model_blend_of_the_tmin_ot_problem_ends_in_each_model():
    """('tmin', 'model') at b = 0 and b = 1 is the T_min → OT field at the held τ_ot under the
    source and the target force model."""
    rng = np.random.default_rng(3)
    x = jnp.asarray([1.1, 0.2, -0.1, 0.05, 0.02, 0.3, 0.4, 0.9, 0.02])
    lam = jnp.asarray(rng.normal(scale=0.1, size=9)).at[6].set(0.0)
    y, K, tau_ot = jnp.concatenate([x, lam]), 4.0, 0.3
    frm, to = TR_J2.params(thrust=15.0), TR_G22.params(thrust=15.0)
    blend = {**to, "pert_from": frm["pert"], "tau_ot": tau_ot}
    at = lambda b: field(Model("tmin", "model", True), K, y, b, blend)  # noqa: E731
    ot = lambda prm: field(Model("tmin", "ot", True), K, y, tau_ot, prm)  # noqa: E731
    np.testing.assert_allclose(at(0.0), ot(frm), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(at(1.0), ot(to), rtol=1e-12, atol=1e-15)
    assert not np.allclose(ot(frm), ot(to), rtol=1e-9, atol=0)            # the models do differ here


@pytest.fixture(scope="module")
def j2_bound(e1_j2_ot):
    """The T_min → OT path followed back from the J2 OT extremal (conftest), cut after 6 steps."""
    assert repr(e1_j2_ot.transfer) == repr(TR_J2)        # (== is False: thrust is nan)
    return tmin_from_ot.solve_tmin_from_ot(e1_j2_ot, tmin_from_ot.FromOtOptions(max_steps=6, verbose=False))


def test_a_bound_carried_to_another_force_model_is_a_transfer_of_that_model(j2_bound, tmp_path):
    """The J2 bound (a path point at τ ≈ 0.79) moved to 2×2 at its τ: the point solves the 2×2
    T_min → OT problem there (every boundary row, and the weighted thrust row), keeps τ and the
    weight, is written and read back as a bound, and its independent replay under 2×2 lands on
    the target."""
    assert j2_bound.extra["bound"] and 0.0 < j2_bound.tau < 1.0
    tm, verdict = E.solve_from_bound(j2_bound, TR_G22, "j2", "test",
                                     tmin_from_ot.FromOtOptions(verbose=False))
    assert tm.transfer is TR_G22 and tm.shooting.model == Model("tmin", "ot", True)
    assert tm.tau == j2_bound.tau and tm.extra["weight"] == j2_bound.extra["weight"]
    assert tm.extra["bound"] and tm.extra["bound_from"] == "j2" and tm.extra["route"] == "ot-tmin-model"
    assert verdict["T_min_is"] == "upper bound" and verdict["exists"]
    f, ok = residual(tm.shooting, jnp.asarray(tm.z), tm.tau, tm.prm)
    f = np.asarray(f)
    assert ok and np.abs(f[:-1]).max() < 1e-9, f
    w, T_ot = tm.extra["weight"], 15.0 / TR_G22.force_unit
    assert abs(w * f[-1] + (1.0 - w) * tm.tau * (tm.z[-1] - T_ot)) < 1e-9        # the row of the path
    assert tm.thrust_N != j2_bound.thrust_N and abs(tm.thrust_N / j2_bound.thrust_N - 1.0) < 1e-2
    path = tmp_path / "tmin_g22.json"
    P.save(tm, path, CFG, 0.0, tm.extra)
    back = P.load(path)
    assert back.tau == tm.tau and back.extra["bound"] and back.extra["weight"] == tm.extra["weight"]
    check = verify.verify_ot(path)
    assert check["final_position_vs_solver_km"] < 0.5 and abs(check["final_mass_error_kg"]) < 1e-4, check


def test_only_a_bound_of_a_perturbed_model_is_carried_over(j2_bound):
    unbounded = dataclasses.replace(j2_bound, extra={**j2_bound.extra, "bound": False})
    with pytest.raises(ValueError, match="upper bound"):
        tmin_from_ot.bound_in_model(unbounded, TR_G22)
    with pytest.raises(ValueError, match="eps_blend"):
        tmin_from_ot.bound_in_model(j2_bound, dataclasses.replace(TR_G22, eps_blend=0.1))


def test_a_bound_that_arrives_after_the_ephemeris_window_is_refused_by_its_date(j2_bound, tmp_path):
    """The Moon is NaN outside its window: the carried bound's arrival is checked first and named
    (E7's bounds arrive 150-160 d after departure)."""
    path = tmp_path / "short.json"
    ephemeris.save_window(ephemeris.extract_window("2021-05-01", "2021-05-09", "short"), path, {})
    with_moon = dataclasses.replace(TR_G22, perturbations={"geopotential": "j2", "third_bodies": ["moon"]},
                                    ephemeris=str(path))
    with pytest.raises(ConfigError, match=r"arrival of the bound carried over \(ephemeris window short\)="
                                          r"'2021-05-1\d.*outside ephemeris window 'short'"):
        tmin_from_ot.bound_in_model(j2_bound, with_moon)
