"""Perturbed §4.2 studies: config parsing, E6 date order, E9 ΔΩ budget, report logic (no solves)."""
import copy
import dataclasses
import math
from pathlib import Path

import pytest
import yaml

from spaceopt.errors import ConfigError
from spaceopt.indirect import chain, free_time as ft
from spaceopt.studies import perturbed as P
from spaceopt.studies import perturbed_config as C
from spaceopt.studies import perturbed_report as R
from spaceopt.studies import thrust_family as TF

ROOT = Path(__file__).resolve().parents[1]
PC = yaml.safe_load((ROOT / "config/studies/perturbed.yaml").read_text())["perturbed"]
PUB = ROOT / "config/published/yun2023_perturbed.yaml"


def _with_profile(pc: dict, name: str) -> dict:
    """``pc`` with the profile config/<name> over it, as --configfile merges it."""
    from snakemake.utils import update_config
    out = copy.deepcopy(pc)
    update_config(out, yaml.safe_load((ROOT / "config" / name).read_text())["perturbed"])
    return out


SMOOTHED = _with_profile(PC, "e8_smoothed.yaml")     # E8 on the smoothed route (its options' tests)


def test_schema_validates_config():
    import jsonschema
    schema = yaml.safe_load((ROOT / "config/schema/perturbed.schema.yaml").read_text())
    jsonschema.validate(PC, schema)
    bad = copy.deepcopy(PC)
    bad["orbits"]["geo_42165"]["e"] = 1.5
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate(bad, schema)


def test_e5_orbits_match_spec_appendix_a():
    tr = P.transfer_from_config(PC, "e5", "unperturbed")
    assert tr.initial.a == pytest.approx(306621.0e3)
    assert tr.initial.e == pytest.approx(0.977591228, abs=1e-9)
    assert tr.final.a == pytest.approx(141371.0e3)
    assert tr.final.e == pytest.approx(0.813462450, abs=1e-9)
    assert not tr.perturbed and tr.epoch_utc is None
    x0 = tr.initial.mee5(1.0)
    assert x0[1] == pytest.approx(-0.169756935, abs=1e-8)
    assert x0[3] == pytest.approx(0.466307658, abs=1e-8)


def test_e9_and_e8_from_a_e():
    tr = P.transfer_from_config(PC, "e9", "j2", ephemeris="none.json")
    assert tr.perturbed and tr.ephemeris is None            # J2 only needs no ephemeris
    assert tr.L0_deg == pytest.approx(301.65)
    assert tr.delta_L == pytest.approx(math.radians(22682.52), rel=1e-6)
    xf = tr.final.mee5(tr.du)
    assert xf[3] == pytest.approx(-0.232202036, abs=1e-8)
    tr8 = P.transfer_from_config(PC, "e8", "g44_moon_sun", ephemeris="eph.json", n_rev=250)
    assert tr8.n_rev == 250 and tr8.ephemeris == "eph.json" and tr8.final.a == 42165e3


@pytest.mark.parametrize("mutate,key", [
    (lambda c: c["cases"]["e5"].pop("thrust_N"), "perturbed.cases.e5.thrust_N"),
    (lambda c: c["cases"]["e5"].update(foo=1), "perturbed.cases.e5.foo"),
    (lambda c: c["orbits"]["heo_500x600000"].update(a_km=1.0), "perturbed.orbits.heo_500x600000"),
    (lambda c: c["orbits"]["geo_42165"].update(e=1.2), "perturbed.orbits.geo_42165.e"),
    (lambda c: c["cases"]["e5"].update(initial="nowhere"), "perturbed.cases.e5.initial"),
])
def test_bad_config_is_one_line_config_error(mutate, key):
    cfg = copy.deepcopy(PC)
    mutate(cfg)
    with pytest.raises(ConfigError) as exc:
        P.transfer_from_config(cfg, "e5" if "e5" in key or "heo" in key or "nowhere" in key else "e8",
                               "unperturbed")
    assert str(exc.value).startswith(key) and "\n" not in str(exc.value)


def test_unknown_model_and_case():
    with pytest.raises(ConfigError, match="perturbed.models"):
        P.transfer_from_config(PC, "e5", "egm2008")
    with pytest.raises(ConfigError, match="perturbed.cases"):
        P.transfer_from_config(PC, "e10", "unperturbed")


def test_scan_dates_and_warm_start_order():
    dates = C.scan_dates(PC["e6"])
    assert len(dates) == 31 and dates[0] == "2021-05-01T12:00:00" and dates[-1] == "2021-05-31T12:00:00"
    pairs = C.scan_order(dates, PC["cases"]["e5"]["epoch_utc"])
    assert len(pairs) == 30                                  # every date but the anchor
    solved = {PC["cases"]["e5"]["epoch_utc"]}
    for d, src in pairs:                                     # each source is solved before use
        assert src in solved
        assert abs(int(d[8:10]) - int(src[8:10])) == 1
        solved.add(d)
    with pytest.raises(ConfigError):
        C.scan_order(dates, "2021-06-01T12:00:00")
    with pytest.raises(ConfigError, match="step_days"):
        C.scan_dates({**PC["e6"], "step_days": 0})
    with pytest.raises(ConfigError, match="step_days"):        # a bool is no step
        C.scan_dates({**PC["e6"], "step_days": True})


def test_scan_start_from_names_scan_dates_without_cycles():
    e6 = {**PC["e6"], "start_from": {"2021-05-19": "2021-05-18", "2021-05-18": "2021-05-17"}}
    assert C.scan_start_from(e6) == e6["start_from"]
    assert C.scan_start_from({**PC["e6"], "start_from": None}) == {}
    with pytest.raises(ConfigError, match=r"start_from\.2021-05-19.*2021-06-01"):
        C.scan_start_from({**PC["e6"], "start_from": {"2021-05-19": "2021-06-01"}})
    with pytest.raises(ConfigError, match="cycle"):
        C.scan_start_from({**PC["e6"], "start_from": {"2021-05-19": "2021-05-18", "2021-05-18": "2021-05-19"}})


def _with_e6(**e6):
    return {**PC, "e6": {**PC["e6"], **e6}}


def test_scan_sources_follow_start_from_then_the_warm_start_route():
    assert C.scan_source(PC, "2021-05-20") == "unperturbed"
    assert C.scan_source(PC, "2021-05-18") == PC["e6"]["start_from"]["2021-05-18"]
    chain = _with_e6(warm_start="neighbour", start_from=None)
    assert C.scan_source(chain, "2021-05-12") == "2021-05-11"       # outward from the 9 May anchor
    assert C.scan_source(chain, "2021-05-03") == "2021-05-04"
    assert C.scan_source(chain, "2021-05-09") is None                 # the anchor: the E5 solve


def test_skipped_e6_dates_are_left_out_unless_a_date_that_is_run_starts_from_them():
    assert len(C.scan_run_dates(PC)) == 31
    run = C.scan_run_dates(_with_e6(skip_dates=["2021-05-20", "2021-05-31"]))
    assert len(run) == 29 and "2021-05-20" not in run and "2021-05-31" not in run
    with pytest.raises(ConfigError, match=r"skip_dates.*2021-06-01.*not a date of the scan"):
        C.scan_run_dates(_with_e6(skip_dates=["2021-06-01"]))
    # 18 May starts from 17 May (start_from): 17 May alone cannot go, both together can
    with pytest.raises(ConfigError, match=r"skip_dates.*2021-05-17.*2021-05-18 starts from it"):
        C.scan_run_dates(_with_e6(skip_dates=["2021-05-17"]))
    assert len(C.scan_run_dates(_with_e6(skip_dates=["2021-05-17", "2021-05-18", "2021-05-19"]))) == 28
    # by neighbours, leaving out a date cuts the chain beyond it
    with pytest.raises(ConfigError, match=r"2021-05-30.*2021-05-31 starts from it"):
        C.scan_run_dates(_with_e6(warm_start="neighbour", start_from=None, skip_dates=["2021-05-30"]))
    assert len(C.scan_run_dates(_with_e6(warm_start="neighbour", start_from=None, skip_dates=["2021-05-31"]))) == 30


def test_the_e6_summary_and_paper_text_name_the_dates_left_out():
    unp = {"m_f_kg": 956.0, "tof_days": 60.0}
    rows = [{"date": d, "model": "g44_moon_sun", "m_f_kg": 956.0 + k, "tof_days": 60.0 - k}
            for k, d in enumerate(["2021-05-01", "2021-05-03"])]
    assert "skipped_dates" not in R.e6_summary(rows, unp)
    summary = R.e6_summary(rows, unp, ["2021-05-02"])
    assert summary["skipped_dates"] == "2021-05-02" and summary["n_dates"] == 2
    text = R.paper_section([], {}, None, summary, [], e8_count_start="chain",
                           smoothing={"eps_final": 1e-5, "eps_blend": 1e-2, "perturb_at_eps": 1e-2,
                                      "model_step_at_eps": 1e-2}, e8_steps=[])
    assert "Over 2 departure dates" in text and "skip\\_dates}): 2021-05-02." in text
    families = "Continued in the departure epoch ... form 2 families: 2021-05-01; 2021-05-03."
    with_families = R.paper_section([], {}, None, summary, [], e8_count_start="chain",
                                    smoothing={"eps_final": 1e-5, "eps_blend": 1e-2, "perturb_at_eps": 1e-2,
                                               "model_step_at_eps": 1e-2}, e8_steps=[], e6_families=families)
    assert "2021-05-02. " + families in with_families and families not in text


def test_raan_budget_matches_spec_section_6():
    tr = P.transfer_from_config(PC, "e9", "j2")
    b = P.raan_budget(tr, 5.0)
    assert b["required_draan_deg"] == pytest.approx(-15.08, abs=1e-9)
    g = b["egm96_gm"]
    assert g["raan_deg_per_day"] == pytest.approx(-3.0439, abs=2e-3)    # spec §6: −3.0439 deg/d
    assert g["dargp_deg"] == pytest.approx(11.065, abs=0.02)            # ≈ the target ω 11.070
    assert g["period_min"] == pytest.approx(114.09, abs=0.01)
    assert b["control_must_change_draan_by_deg"] > 0                   # the control slows the regression
    assert g["a_for_required_drift_km"] > 7792.0


def _payload(m_f, tof, kf=1800.0, m0=1000.0, n=5, T=0.5, c=14906.108):
    return {"scalars": {"m_f_kg": m_f, "tof_days": tof, "K_f_deg": kf, "dv_m_s": c * math.log(m0 / m_f),
                        "burn_days": (m0 - m_f) * c / T / 86400, "burn_fraction": 0.25, "costates": {}},
            "transfer": {"m0": m0, "n_rev": n}}


def test_tables_and_reproduction_rows_can_fail():
    cases = {c: {"models": PC["cases"][c]["models"]} for c in PC["cases"]}
    good = {"e5_unperturbed": _payload(955.257737953, 60.669362453, 1818.033626880),
            "e5_g44_moon_sun": _payload(956.0, 60.45, 1817.37),
            "e9_j2": _payload(1000 - 0.6849, 4.997454, m0=1000, n=63.007, T=1.0, c=14709.975),
            "e9_g44": _payload(1000 - 0.67, 4.99, m0=1000, n=63.007, T=1.0, c=14709.975),
            "e9_g44_moon_sun": _payload(1000 - 0.6701, 4.99, m0=1000, n=63.007, T=1.0, c=14709.975)}
    tabs = R.tables(good, ["e5", "e9"], cases, PC["e6"], [])
    assert [r["model"] for r in tabs["e5"]] == ["unperturbed", "g44_moon_sun"]
    o = R.ours(tabs, good, {}, None)
    rows = {(r["case"], r["quantity"]): r for r in R.reproduction_rows(PUB, o)}
    assert rows[("e5_unperturbed", "m_f_kg")]["status"] == "pass"
    assert rows[("e9_j2", "tof_days")]["status"] == "pass"
    assert rows[("e9", "g44_less_fuel_than_j2")]["status"] == "pass"
    assert rows[("e8_unperturbed_n500", "propellant_kg")]["status"] == "missing"
    bad = dict(good, e5_unperturbed=_payload(955.3, 60.669362453, 1818.03),
               e9_g44=_payload(1000 - 0.70, 4.99, m0=1000, n=63.007, T=1.0, c=14709.975))
    tabs = R.tables(bad, ["e5", "e9"], cases, PC["e6"], [])
    rows = {(r["case"], r["quantity"]): r for r in R.reproduction_rows(PUB, R.ours(tabs, bad, {}, None))}
    assert rows[("e5_unperturbed", "m_f_kg")]["status"] == "fail"
    assert rows[("e9", "g44_less_fuel_than_j2")]["status"] == "fail"


def test_e6_summary():
    rows = [{"date": "2021-05-01", "model": "g44_moon_sun", "m_f_kg": 956.0, "tof_days": 60.0},
            {"date": "2021-05-02", "model": "g44_moon_sun", "m_f_kg": 954.0, "tof_days": 61.0}]
    s = R.e6_summary(rows, {"m_f_kg": 955.0, "tof_days": 60.5})
    assert s["dm_max_kg"] == pytest.approx(1.0) and s["dm_max_date"] == "2021-05-01"
    assert s["dm_min_kg"] == pytest.approx(-1.0) and s["dm_min_date"] == "2021-05-02"
    assert s["dm_mean_kg"] == pytest.approx(0.0) and s["dt_mean_days"] == pytest.approx(0.0)


def test_arclength_passes_a_fold_in_tau():
    """z³ − 3z = −2 + 6τ from z = −2: the τ-path folds at τ = 2/3 (z = −1), turns back to
    τ = 0 (z = 1) and reaches z³ − 3z = 4 at τ = 1 (z ≈ 2.1958); τ-continuation cannot."""
    import numpy as np
    from spaceopt.errors import ConvergenceError
    from spaceopt.indirect.continuation import (ArclengthContinuation, ArclengthOptions, Continuation,
                                                ContinuationOptions)

    def ev(z, tau):
        return (np.atleast_1d(z**3 - 3 * z + 2 - 6 * tau), np.array([[3 * z[0] ** 2 - 3]]),
                np.array([-6.0]), 0, True)

    arc = ArclengthContinuation(ev, ArclengthOptions(verbose=False))
    z, _ = arc.run(np.array([-2.0]))
    assert z[0] ** 3 - 3 * z[0] == pytest.approx(4.0, abs=1e-9)
    assert z[0] == pytest.approx(2.1958233, abs=1e-6)
    assert arc.stats.steps > 3 and min(h["tau"] for h in arc.stats.history[3:]) < 0.5   # went back
    cont = Continuation(ev, ContinuationOptions(verbose=False))
    with pytest.raises(ConvergenceError, match="step size underflow") as err:
        cont.run(np.array([-2.0]))
    # every rejected step is in the diagnosis with the corrector's |F| sequence and why it gave up
    rejected = [h["rejected"] for h in err.value.diagnosis["history"] if "rejected" in h]
    assert len(rejected) == cont.stats.rejected or len(err.value.diagnosis["history"]) == 20
    assert rejected and all(r.startswith("|F| ") for r in rejected)
    assert all(r.endswith(("not contracting", "propagation failed", "after 4 iterations")) for r in rejected)
    tangents = [h["tangent"] for h in cont.stats.history if "tangent" in h]
    assert tangents[-1] > 10 * tangents[0]          # |dz/dτ| blows up towards the fold at τ = 2/3


def test_residual_step_growth_follows_a_path_with_a_small_newton_basin():
    """f = 1e-4 atan(c (z − sin(5τ)/5)): Newton diverges from |c (z − z*)| > 1.39, about where
    |f| passes tol_step, as on the E8 lunisolar blend (accepted only when the predictor lands
    within tol_step). Growing the step by the predicted residual and capping it below the last
    rejected step needs fewer evaluations, and at c = 1e3 it converges where the iteration-count
    rule underflows; so do a damped corrector (``max_backtracks``) and the retry from the point
    before the unchecked Newton update (``accepted_update: revert``; at c = 100 that retry makes
    the iteration-count rule underflow instead: the accepted point lies at the basin's edge)."""
    import numpy as np
    from spaceopt.errors import ConvergenceError
    from spaceopt.indirect.continuation import Continuation, ContinuationOptions

    def follower(c, growth, backtracks=0, update="always"):
        def ev(z, tau):
            u = c * (z[0] - np.sin(5 * tau) / 5)
            d = 1e-4 * c / (1 + u * u)
            return np.array([1e-4 * np.arctan(u)]), np.array([[d]]), np.array([-d * np.cos(5 * tau)]), 0, True
        return Continuation(ev, ContinuationOptions(verbose=False, step_growth=growth, max_backtracks=backtracks,
                                                    accepted_update=update))

    by_iterations, by_residual = follower(300.0, "iterations"), follower(300.0, "residual")
    for cont in (by_iterations, by_residual):
        z, _ = cont.run(np.array([0.0]))
        assert z[0] == pytest.approx(np.sin(5.0) / 5, abs=1e-8)
    assert by_residual.stats.rejected <= 2 < by_iterations.stats.rejected
    assert by_residual.stats.jacobians < 0.8 * by_iterations.stats.jacobians
    with pytest.raises(ConvergenceError, match="step size underflow"):
        follower(1e3, "iterations").run(np.array([0.0]))
    z, _ = follower(1e3, "residual").run(np.array([0.0]))
    assert z[0] == pytest.approx(np.sin(5.0) / 5, abs=1e-8)
    # the damped corrector (halving the Newton step where it does not contract) rescues the
    # iteration-count rule there too
    damped = follower(1e3, "iterations", backtracks=3)
    z, _ = damped.run(np.array([0.0]))
    assert z[0] == pytest.approx(np.sin(5.0) / 5, abs=1e-8)
    assert damped.stats.steps > 10
    # and so does retrying a rejected step from the point before its unchecked Newton update
    z, _ = follower(1e3, "iterations", update="revert").run(np.array([0.0]))
    assert z[0] == pytest.approx(np.sin(5.0) / 5, abs=1e-8)
    with pytest.raises(ValueError, match="step_growth"):
        Continuation(lambda z, t: None, ContinuationOptions(step_growth="fast"))
    with pytest.raises(ValueError, match="accepted_update"):
        Continuation(lambda z, t: None, ContinuationOptions(accepted_update="never"))


def test_interrupted_tau_path_resumes_from_its_checkpoint(tmp_path):
    """A τ path stopped part-way (here by an exception in the evaluation) resumes from its last
    accepted point when run again with the same label and start, and takes the same steps as
    the uninterrupted run (one extra evaluation, the restart), and its wall time includes the
    interrupted run's up to the checkpoint; the file is removed at the end; another start does
    not take the checkpoint."""
    import time
    import numpy as np
    from spaceopt.indirect.continuation import Checkpoint, Continuation, ContinuationOptions, resumed_wall_time

    calls = {"n": 0, "stop": None}

    def ev(z, tau):
        calls["n"] += 1
        if calls["stop"] is not None:
            if calls["n"] > calls["stop"]:
                raise KeyboardInterrupt
            time.sleep(0.005)
        u = 300.0 * (z[0] - np.sin(5 * tau) / 5)
        d = 1e-4 * 300.0 / (1 + u * u)
        return np.array([1e-4 * np.arctan(u)]), np.array([[d]]), np.array([-d * np.cos(5 * tau)]), 0, True

    opt = lambda: ContinuationOptions(verbose=False, label="blend n450", checkpoint_dir=str(tmp_path / "ck"))
    whole = Continuation(ev, ContinuationOptions(verbose=False))
    z_whole, _ = whole.run(np.array([0.0]))
    total = calls["n"]
    calls.update(n=0, stop=total // 2)
    with pytest.raises(KeyboardInterrupt):
        Continuation(ev, opt()).run(np.array([0.0]))
    saved = list((tmp_path / "ck").glob("*.npz"))
    assert [p.name for p in saved] == ["blend_n450.npz"]
    before = float(np.load(saved[0])["wall_time_s"])
    assert before > 0.005
    calls.update(n=0, stop=None)
    resumed = Continuation(ev, opt())
    z, _ = resumed.run(np.array([0.0]))
    assert z[0] == z_whole[0]
    assert resumed.stats.resumed_wall_time_s == before < resumed.stats.wall_time_s
    # nested stages count once each, their sum beside them (chain._merge_stats) not again
    assert resumed_wall_time({"solver": {"path": resumed.stats.as_dict(), "arcs": [resumed.stats.as_dict()],
                                         "resumed_wall_time_s": 2 * before}, "wall_time_s": 1.0}) == 2 * before
    assert resumed.stats.jacobians == whole.stats.jacobians + 1 and resumed.stats.steps == whole.stats.steps
    assert calls["n"] < total
    assert not (tmp_path / "ck").exists()
    # a checkpoint of another start (or other end points) is not used
    calls.update(n=0, stop=total // 2)
    with pytest.raises(KeyboardInterrupt):
        Continuation(ev, opt()).run(np.array([0.0]))
    assert Checkpoint(str(tmp_path / "ck"), "blend n450", np.array([0.0]), 0.0, 1.0).load() is not None
    assert Checkpoint(str(tmp_path / "ck"), "blend n450", np.array([1e-3]), 0.0, 1.0).load() is None
    assert Checkpoint(str(tmp_path / "ck"), "blend n450", np.array([0.0]), 0.0, 0.5).load() is None


def test_interrupted_arclength_path_resumes_with_the_same_steps(tmp_path):
    """The arclength follower through the fold of z³ − 3z = −2 + 6τ, stopped part-way and run
    again: same end point, same steps, no more evaluations than the uninterrupted run."""
    import numpy as np
    from spaceopt.indirect.continuation import ArclengthContinuation, ArclengthOptions

    calls = {"n": 0, "stop": None}

    def ev(z, tau):
        calls["n"] += 1
        if calls["stop"] is not None and calls["n"] > calls["stop"]:
            raise KeyboardInterrupt
        return (np.atleast_1d(z**3 - 3 * z + 2 - 6 * tau), np.array([[3 * z[0] ** 2 - 3]]),
                np.array([-6.0]), 0, True)

    opt = ArclengthOptions(verbose=False, label="fold", checkpoint_dir=str(tmp_path))
    whole = ArclengthContinuation(ev, ArclengthOptions(verbose=False))
    z_whole, _ = whole.run(np.array([-2.0]))
    total = calls["n"]
    calls.update(n=0, stop=total // 2)
    with pytest.raises(KeyboardInterrupt):
        ArclengthContinuation(ev, opt).run(np.array([-2.0]))
    calls.update(n=0, stop=None)
    resumed = ArclengthContinuation(ev, opt)
    z, _ = resumed.run(np.array([-2.0]))
    assert z[0] == z_whole[0] and resumed.stats.steps == whole.stats.steps
    assert resumed.stats.jacobians == whole.stats.jacobians and calls["n"] < total
    assert not (tmp_path / "fold.npz").exists()


def test_a_long_step_past_the_end_is_retaken_to_land_near_it():
    """z = τ² (f = z − τ²): the end point at τ = 1 is interpolated linearly between the points
    either side of it, off the curved path by (1 − τ_a)(τ_c − 1); with end_overshoot a step that
    lands further past τ = 1 is retaken shorter, and the polish starts on the path."""
    import numpy as np
    from spaceopt.indirect.continuation import ArclengthContinuation, ArclengthOptions

    def first_end_point(**kw):
        seen = []

        def ev(z, tau):
            if tau == 1.0:
                seen.append(float(z[0]))
            return np.atleast_1d(z - tau ** 2), np.eye(1), np.array([-2.0 * tau]), 0, True

        arc = ArclengthContinuation(ev, ArclengthOptions(verbose=False, h_init=0.7, h_max=0.7, **kw))
        z, _ = arc.run(np.array([0.0]))
        assert z[0] == pytest.approx(1.0, abs=1e-12)
        return seen[0]

    plain = abs(first_end_point() - 1.0)                  # (1 − 0.7)(τ_c − 1): 0.015
    assert plain > 0.01
    assert abs(first_end_point(end_overshoot=0.01) - 1.0) < 0.2 * plain
    assert abs(first_end_point(end_overshoot=0.001) - 1.0) < 0.02 * plain
    # a retaken step that lands just short of τ = 1 ends the path there (no further retakes)
    evals = []

    def ev(z, tau):
        evals.append(tau)
        return np.atleast_1d(z - tau ** 2), np.eye(1), np.array([-2.0 * tau]), 0, True

    arc = ArclengthContinuation(ev, ArclengthOptions(verbose=False, h_init=0.7, h_max=0.7, end_overshoot=0.01))
    arc.run(np.array([0.0]))
    assert arc.stats.history[-1]["tau"] == 1.0 and len(evals) < 20

def test_path_options_keep_every_option_but_the_step_sizes_of_the_other_kind():
    from spaceopt.indirect.chain import path_options
    from spaceopt.indirect.continuation import STEP_SIZES, ArclengthOptions, ContinuationOptions
    mine = ContinuationOptions(h_init=0.01, tol_step=1e-5, verbose=False, step_growth="residual",
                               max_backtracks=2, accepted_update="revert")
    arc = path_options("arclength", mine, "x")
    assert isinstance(arc, ArclengthOptions) and arc.label == "x"
    assert all(getattr(arc, k) == getattr(ArclengthOptions(), k) for k in STEP_SIZES)
    assert (arc.tol_step, arc.verbose, arc.step_growth, arc.max_backtracks, arc.accepted_update) == \
        (1e-5, False, "residual", 2, "revert")
    assert path_options("tau", mine, "x") == ContinuationOptions(**{**mine.__dict__, "label": "x"})
    assert path_options("tau", None, "x") == ContinuationOptions(label="x")
    with pytest.raises(ValueError, match="homotopy path"):
        path_options("spiral", None, "x")


def test_arclength_gives_up_a_path_that_runs_back_below_the_floor():
    """z² + 1 = 2(1 − τ) from z = 1 has no root at τ = 1: the path folds at τ = ½ (z = 0) and runs
    back towards τ → −∞; the follower stops below ``tau_floor`` with a diagnosis, not at max_steps."""
    import numpy as np
    from spaceopt.errors import ConvergenceError
    from spaceopt.indirect.continuation import ArclengthContinuation, ArclengthOptions

    def ev(z, tau):
        return np.atleast_1d(z**2 + 1.0), np.array([[2.0 * z[0]]]), np.zeros(1), 0, True

    arc = ArclengthContinuation(ev, ArclengthOptions(verbose=False, tau_floor=-1.0))
    with pytest.raises(ConvergenceError, match="turned back") as err:
        arc.run(np.array([1.0]))
    assert -1.5 < err.value.diagnosis["tau"] < -1.0 and arc.stats.steps < 100
    assert 0.45 < err.value.diagnosis["tau_max"] <= 0.5         # where the path turned back


def test_arclength_gives_up_a_path_that_runs_off_in_z_and_passes_folds(tmp_path):
    """e^(−z) + 1 = 2(1 − τ) from z = 0 reaches τ = ½ only as z → ∞: with ``runoff_slope`` the
    follower stops after ``runoff_steps`` steps in a row with |dτ/ds| below it, short of its
    step cap (which it runs into without), and stopped within that run and resumed from its
    checkpoint at the same step; the folds of z³ − 3z = −2 + 6τ (dτ/ds through 0) do not stop it."""
    import numpy as np
    from spaceopt.errors import ConvergenceError
    from spaceopt.indirect.continuation import ArclengthContinuation, ArclengthOptions

    calls = {"n": 0, "stop": None}

    def ev(z, tau):
        calls["n"] += 1
        if calls["stop"] is not None and calls["n"] > calls["stop"]:
            raise KeyboardInterrupt
        return np.atleast_1d(np.exp(-z) + 1.0), np.array([[-np.exp(-z[0])]]), np.zeros(1), 0, True

    def fold(z, tau):
        return (np.atleast_1d(z**3 - 3 * z + 2 - 6 * tau), np.array([[3 * z[0] ** 2 - 3]]), np.array([-6.0]), 0, True)

    watched = ArclengthOptions(verbose=False, runoff_slope=0.01, runoff_steps=5, max_steps=200)
    arc = ArclengthContinuation(ev, watched)
    with pytest.raises(ConvergenceError, match="runs off: 5 steps in a row") as err:
        arc.run(np.array([0.0]))
    assert 0.49 < err.value.diagnosis["tau"] < 0.5 and arc.stats.steps < 60
    total, steps = calls["n"], arc.stats.steps
    saved = dataclasses.replace(watched, label="runoff", checkpoint_dir=str(tmp_path))
    calls.update(n=0, stop=total - 3)            # within the run of slow steps
    with pytest.raises(KeyboardInterrupt):
        ArclengthContinuation(ev, saved).run(np.array([0.0]))
    calls.update(n=0, stop=None)
    resumed = ArclengthContinuation(ev, saved)
    with pytest.raises(ConvergenceError, match="runs off: 5 steps in a row"):
        resumed.run(np.array([0.0]))
    assert resumed.stats.steps == steps and calls["n"] < total
    with pytest.raises(ConvergenceError, match="too many continuation steps"):
        ArclengthContinuation(ev, ArclengthOptions(verbose=False, max_steps=200)).run(np.array([0.0]))
    z, _ = ArclengthContinuation(fold, watched).run(np.array([-2.0]))
    assert z[0] == pytest.approx(2.1958233, abs=1e-6)


def test_step_cap_grows_with_the_revolutions_and_reaches_the_shooting_problem():
    from spaceopt.indirect import chain
    from spaceopt.indirect.transfer import MAX_STEPS
    num = PC["numerics"]
    e5 = P.transfer_from_config(PC, "e5", "unperturbed")
    assert e5.max_steps == max(num["min_max_steps"], 10_000 * math.ceil(num["max_steps_per_rev"] * e5.n_rev / 10_000))
    e8 = P.transfer_from_config(PC, "e8", "unperturbed", n_rev=500)
    assert e8.max_steps == 10_000 * math.ceil(num["max_steps_per_rev"] * 500 / 10_000) > e5.max_steps
    assert chain.shooting_for("ot", "eps", e5).max_steps == e5.max_steps
    assert chain.lp_shooting(e5).max_steps == e5.max_steps
    uncapped = {k: v for k, v in num.items() if k not in ("max_steps_per_rev", "min_max_steps")}
    assert P.transfer_from_config({**PC, "numerics": uncapped}, "e5", "unperturbed").max_steps == MAX_STEPS


def test_path_rtol_reaches_every_shooting_problem_and_is_checked():
    from spaceopt.indirect import chain
    from spaceopt.indirect.transfer import PATH_RTOL
    e5 = P.transfer_from_config(PC, "e5", "g44_moon_sun", ephemeris="unused.json")
    assert e5.path_rtol == PC["cases"]["e5"]["path_rtol"] != PATH_RTOL
    assert chain.shooting_for("ot", "eps", e5).path_rtol == e5.path_rtol
    assert chain.lp_shooting(e5, perturbed=True).path_rtol == e5.path_rtol
    assert P.perturbation_switch(e5).path_rtol == e5.path_rtol
    assert "path_rtol" not in PC["cases"]["e9"]
    assert P.transfer_from_config(PC, "e9", "unperturbed").path_rtol == PATH_RTOL
    bad = copy.deepcopy(PC)
    bad["cases"]["e5"]["path_rtol"] = -1e-10
    with pytest.raises(ConfigError, match=r"perturbed\.cases\.e5\.path_rtol"):
        P.transfer_from_config(bad, "e5", "unperturbed")
    with pytest.raises(ConfigError, match="path_rtol"):
        dataclasses.replace(e5, path_rtol=0.1)


def test_path_rtol_per_model_mapping():
    from spaceopt.indirect.transfer import PATH_RTOL

    def with_rtol(value):
        pc = copy.deepcopy(PC)
        pc["cases"]["e9"]["path_rtol"] = value
        return pc

    pc = with_rtol({"g44": 1e-11})
    assert P.transfer_from_config(pc, "e9", "g44").path_rtol == 1e-11
    assert P.transfer_from_config(pc, "e9", "j2").path_rtol == PATH_RTOL
    with pytest.raises(ConfigError, match=r"perturbed\.cases\.e9\.path_rtol\.unperturbed"):
        P.transfer_from_config(with_rtol({"unperturbed": 1e-11}), "e9", "j2")
    with pytest.raises(ConfigError, match=r"perturbed\.cases\.e9\.path_rtol\.g44"):
        P.transfer_from_config(with_rtol({"g44": "tight"}), "e9", "g44")


def test_path_arcs_per_model_reaches_the_shooting_problem_and_is_checked():
    from spaceopt.indirect import chain

    def with_arcs(value):
        pc = copy.deepcopy(PC)
        pc["cases"]["e9"]["path_arcs"] = value
        return pc

    pc = with_arcs({"g44_moon_sun": 6})
    tr = P.transfer_from_config(pc, "e9", "g44_moon_sun")
    assert tr.path_arcs == 6 and chain.shooting_for("ot", "eps", tr).path_arcs == 6
    assert P.transfer_from_config(pc, "e9", "j2").path_arcs == 1
    assert P.transfer_from_config(with_arcs(3), "e9", "j2").path_arcs == 3
    for bad, key in (({"g44": 0}, r"path_arcs\.g44"), (2.5, r"cases\.e9\.path_arcs"),
                     ({"unperturbed": 4}, r"path_arcs\.unperturbed")):
        with pytest.raises(ConfigError, match=key):
            P.transfer_from_config(with_arcs(bad), "e9", "g44")


def test_perturb_at_eps_is_read_and_checked():
    assert C.perturb_at_eps(PC, "e7") == PC["cases"]["e7"]["perturb_at_eps"]
    assert C.perturb_at_eps(PC, "e7", "model_step_at_eps") == PC["cases"]["e7"]["model_step_at_eps"]
    assert C.perturb_at_eps(PC, "e9", "model_step_at_eps") is None
    assert C.perturb_at_eps(PC, "e5") is None
    bad = copy.deepcopy(PC)
    bad["cases"]["e7"]["perturb_at_eps"] = PC["numerics"]["eps_final"] / 2
    with pytest.raises(ConfigError, match=r"perturbed\.cases\.e7\.perturb_at_eps"):
        C.perturb_at_eps(bad, "e7")
    bad["cases"]["e7"]["perturb_at_eps"] = "big"
    with pytest.raises(ConfigError, match=r"perturbed\.cases\.e7\.perturb_at_eps"):
        C.perturb_at_eps(bad, "e7")
    bad["cases"]["e7"]["model_step_at_eps"] = 2.0
    with pytest.raises(ConfigError, match=r"perturbed\.cases\.e7\.model_step_at_eps"):
        C.perturb_at_eps(bad, "e7", "model_step_at_eps")



def test_switching_is_read_and_refuses_the_options_of_the_smoothed_route():
    """Case option switching (smoothed | exact): exact refuses a smoothing eps, multiple shooting
    and, for E8, counts moved from the previous one; one-line errors naming the key."""
    assert C.case_switching(PC, "e9") == PC["cases"]["e9"].get("switching", "smoothed")
    ok = copy.deepcopy(PC)
    for key in ("perturb_at_eps", "model_step_at_eps", "path_arcs", "model_step"):
        ok["cases"]["e8"].pop(key, None)
    ok["cases"]["e8"]["switching"] = "exact"
    assert C.case_switching(ok, "e8") == "exact"
    assert C.e8_smoothing(ok)["switching"] == "exact"
    text = R.e8_route_text("chain", C.e8_smoothing(ok), [])
    assert "exact bang-bang problem" in text and f"varepsilon={R.latex_number(1e-2)}" in text
    cases = [("switching", "bang", r"perturbed\.cases\.e8\.switching"),
             ("perturb_at_eps", 1e-2, r"perturbed\.cases\.e8\.perturb_at_eps"),
             ("path_arcs", {"g44_moon_sun": 10}, r"perturbed\.cases\.e8\.path_arcs")]
    for key, value, match in cases:
        bad = copy.deepcopy(ok)
        bad["cases"]["e8"][key] = value
        with pytest.raises(ConfigError, match=match):
            C.case_switching(bad, "e8")
    bad = copy.deepcopy(ok)
    bad["e8"]["count_start"] = "previous"
    with pytest.raises(ConfigError, match=r"perturbed\.e8\.count_start"):
        C.case_switching(bad, "e8")


def test_sensitivity_rtol_needs_the_exact_map_and_reaches_the_shooting_problems():
    """Case option sensitivity_rtol (a number or {model: number}): only with switching: exact
    (the smoothed map has one tolerance for f and Φ); it reaches the Transfer and every Shooting
    of it; bad values are one-line errors naming the key."""
    assert P.transfer_from_config(PC, "e9", "j2").sensitivity_rtol is None
    pc = copy.deepcopy(PC)
    pc["cases"]["e9"]["sensitivity_rtol"] = 1e-9
    with pytest.raises(ConfigError, match=r"perturbed\.cases\.e9\.sensitivity_rtol.*switching: exact"):
        P.transfer_from_config(pc, "e9", "j2")
    pc["cases"]["e9"]["switching"] = "exact"
    tr = P.transfer_from_config(pc, "e9", "j2")
    assert tr.sensitivity_rtol == 1e-9 and chain.shooting_for("ot", "eps", tr).sensitivity_rtol == 1e-9
    pc["cases"]["e9"]["sensitivity_rtol"] = {"g44": 1e-8}
    assert P.transfer_from_config(pc, "e9", "g44").sensitivity_rtol == 1e-8
    assert P.transfer_from_config(pc, "e9", "j2").sensitivity_rtol is None
    for value, match in ((-1e-9, r"perturbed\.cases\.e9\.sensitivity_rtol\.g44"),
                         ({"moon": 1e-9}, r"perturbed\.cases\.e9\.sensitivity_rtol\.moon")):
        pc["cases"]["e9"]["sensitivity_rtol"] = value if isinstance(value, dict) else {"g44": value}
        with pytest.raises(ConfigError, match=match):
            P.transfer_from_config(pc, "e9", "g44")
    with pytest.raises(ConfigError, match="sensitivity_rtol"):
        dataclasses.replace(tr, sensitivity_rtol=0.1)


def test_path_step_budget_reaches_every_shooting_problem_and_is_checked():
    """Case option path_step_budget (a factor >= 1; absent or null: off): it reaches the Transfer
    and every Shooting of it; bad values are one-line errors naming the key."""
    assert P.transfer_from_config(PC, "e9", "j2").path_step_budget is None
    pc = copy.deepcopy(PC)
    pc["cases"]["e9"]["path_step_budget"] = 4
    tr = P.transfer_from_config(pc, "e9", "j2")
    assert tr.path_step_budget == 4.0 and chain.shooting_for("ot", "eps", tr).path_step_budget == 4.0
    assert chain.lp_shooting(tr, perturbed=True).path_step_budget == 4.0
    for value in (0.5, "4", True, math.inf):
        pc["cases"]["e9"]["path_step_budget"] = value
        with pytest.raises(ConfigError, match=r"perturbed\.cases\.e9\.path_step_budget"):
            P.transfer_from_config(pc, "e9", "j2")
    with pytest.raises(ConfigError, match="path_step_budget"):
        dataclasses.replace(tr, path_step_budget=0.5)


def test_model_from_names_the_start_of_a_warm_start_and_is_checked():
    """Case option model_from ({model: an earlier model}): that model's solve starts from the one
    named, the others from the previous model, the first from the zero guess; the route to a model
    leaves out the models it skips; the report says where a step starts; bad values are one-line
    errors naming the key."""
    models = SMOOTHED["cases"]["e8"]["models"]
    assert [C.case_start_model(SMOOTHED, "e8", m) for m in models] == [None, *models[:-1]]
    assert C.case_route(SMOOTHED, "e8", "g44_moon_sun") == models
    assert all(s is None for s in C.case_start_models(PC)["e5"].values())     # model_start: chain
    pc = copy.deepcopy(SMOOTHED)
    pc["cases"]["e8"]["model_from"] = {"g44_moon_sun": "j2"}
    assert C.case_start_model(pc, "e8", "g44_moon_sun") == "j2" and C.case_start_model(pc, "e8", "g44") == "j2"
    assert C.case_route(pc, "e8", "g44_moon_sun") == ["unperturbed", "j2", "g44_moon_sun"]
    steps = {s["model"]: s for s in C.e8_model_steps(pc)}
    assert steps["g44"]["from"] is None and steps["g44_moon_sun"]["from"] == "j2"
    assert r"to 4$\times$4 + Moon + Sun from the $J_2$ extremal (" in R.e8_step_text(steps["g44_moon_sun"])
    for value, match in (({"moon": "j2"}, r"perturbed\.cases\.e8\.model_from\.moon='j2'"),
                         ({"g44_moon_sun": "g44_moon_sun"}, r"model_from\.g44_moon_sun.*before g44_moon_sun"),
                         ({"j2": "g44"}, r"model_from\.j2='g44'"),
                         ({"unperturbed": "j2"}, r"model_from\.unperturbed")):
        pc["cases"]["e8"]["model_from"] = value
        with pytest.raises(ConfigError, match=match):
            C.case_start_models(pc)
    pc["cases"]["e5"]["model_from"] = {"g44_moon_sun": "unperturbed"}      # E5 chains every model
    with pytest.raises(ConfigError, match=r"perturbed\.cases\.e5\.model_from.*model_start: chain"):
        C.case_start_model(pc, "e5", "g44_moon_sun")


def test_model_from_can_name_the_start_of_one_revolution_count():
    """model_from {model: {at_n_rev: {count: start}}}: E8's full model starts from J2 at that
    count only, from the previous model (or the entry's ``model``) at the others; the route at
    each count and the report text follow; bad entries are one-line errors naming the key."""
    pc = copy.deepcopy(PC)
    models = pc["cases"]["e8"]["models"]
    n = float(pc["e8"]["n_rev"][-1])
    pc["cases"]["e8"]["model_from"] = {"g44_moon_sun": {"at_n_rev": {int(n): "j2"}}}
    assert C.case_start_model(pc, "e8", "g44_moon_sun") == "g44"
    assert C.case_start_model(pc, "e8", "g44_moon_sun", n) == "j2"
    assert C.case_start_model(pc, "e8", "g44_moon_sun", n - 50) == "g44"
    assert C.case_start_model(pc, "e8", "g44", n) == "j2"                 # another model: unchanged
    assert C.case_route(pc, "e8", "g44_moon_sun", n) == ["unperturbed", "j2", "g44_moon_sun"]
    assert C.case_route(pc, "e8", "g44_moon_sun", n - 50) == models
    assert C.case_start_models(pc)["e8"]["g44_moon_sun"] == "g44"
    steps = {s["model"]: s for s in C.e8_model_steps(pc)}
    assert steps["g44_moon_sun"]["from"] is None and steps["g44_moon_sun"]["from_at_n_rev"] == {n: "j2"}
    assert steps["g44"]["from_at_n_rev"] == {}
    text = R.e8_step_text(steps["g44_moon_sun"])
    assert text.startswith(r"to 4$\times$4 + Moon + Sun (") and text.endswith(f"), at {n:g} revolutions from the $J_2$ extremal")
    pc["cases"]["e8"]["model_from"] = {"g44_moon_sun": {"model": "j2", "at_n_rev": {int(n): "g44"}}}
    assert C.case_start_model(pc, "e8", "g44_moon_sun", n - 50) == "j2"
    assert C.case_start_model(pc, "e8", "g44_moon_sun", n) == "g44"
    for value, match in (({"g44_moon_sun": {"at_n_rev": {450: "moon"}}}, r"model_from\.g44_moon_sun\.at_n_rev\.450='moon'.*before"),
                         ({"g44_moon_sun": {"at_n_rev": {-1: "j2"}}}, r"at_n_rev\.-1='j2'.*positive revolution count"),
                         ({"g44_moon_sun": {"at_n_rev": [450]}}, r"at_n_rev=\[450\].*mapping"),
                         ({"g44_moon_sun": {"from": "j2"}}, r"model_from\.g44_moon_sun\.from='j2'.*unknown"),
                         ({"g44_moon_sun": {"model": "g44_moon_sun"}}, r"model_from\.g44_moon_sun\.model=.*before")):
        pc["cases"]["e8"]["model_from"] = value
        with pytest.raises(ConfigError, match=match):
            C.case_start_models(pc)
    pc["cases"]["e8"]["model_from"] = None
    pc["cases"]["e9"]["model_from"] = {"g44_moon_sun": {"at_n_rev": {450: "j2"}}}   # E9 has no counts
    with pytest.raises(ConfigError, match=r"perturbed\.cases\.e9\.model_from\.g44_moon_sun\.at_n_rev.*only E8"):
        C.case_start_models(pc)


def test_corrector_is_read_and_reaches_the_chain_only():
    """Case option corrector (newton | chord | broyden): Newton's leaves the followers' defaults; chord goes
    into the options of the chain from the zero guess, not into the warm starts' (they keep
    Newton's); a bad value is a one-line error naming the key."""
    assert C.case_corrector(SMOOTHED, "e8") == "newton"
    assert P.chain_options(SMOOTHED, "e8") is None
    pc = copy.deepcopy(SMOOTHED)
    pc["cases"]["e8"]["corrector"] = "chord"
    assert P.chain_options(pc, "e8").corrector == "chord"
    assert P.warm_start_options(pc, "e8", model="j2") is None
    assert P.warm_start_options(pc, "e8", model="g44_moon_sun", n_rev=500).corrector == "newton"
    pc["cases"]["e8"]["corrector"] = "broyden"
    assert P.chain_options(pc, "e8").corrector == "broyden"
    pc["cases"]["e8"]["corrector"] = "secant"
    with pytest.raises(ConfigError, match=r"perturbed\.cases\.e8\.corrector"):
        P.chain_options(pc, "e8")


def test_warm_start_options_follow_the_case_step_growth():
    assert P.warm_start_options(PC, "e9") is None
    pc = copy.deepcopy(PC)
    pc["cases"]["e9"]["warm_step_growth"] = "residual"
    assert P.warm_start_options(pc, "e9").step_growth == "residual"
    assert P.warm_start_options(pc, "e9").checkpoint_dir == ""
    resumable = P.warm_start_options(PC, "e9", checkpoint_dir="results/x.checkpoints")
    assert resumable.checkpoint_dir == "results/x.checkpoints" and resumable.step_growth == "iterations"
    pc["cases"]["e9"]["warm_step_growth"] = "fast"
    with pytest.raises(ConfigError, match=r"perturbed\.cases\.e9\.warm_step_growth"):
        P.warm_start_options(pc, "e9")


def test_model_step_settings_reach_the_warm_start_of_that_model_only():
    """Case option model_step {model: settings}: E8's full model gets the arclength path and its
    continuation settings (over the case's warm_step_growth); other models keep the defaults;
    bad settings name the key and value."""
    full = P.warm_start_kwargs(PC, "e8", "g44_moon_sun", checkpoint_dir="ck")
    step = PC["cases"]["e8"]["model_step"]["g44_moon_sun"]
    assert full["model_path"] == step["path"] == "arclength"
    opt = full["options"]
    assert (opt.step_growth, opt.accepted_update, opt.step_rcond, opt.flat_step, opt.checkpoint_dir) == \
        (step["step_growth"], step["accepted_update"], step["step_rcond"], step["flat_step"], "ck")
    g44 = P.warm_start_kwargs(PC, "e8", "g44")
    assert g44["model_path"] is None and g44["options"] is None           # τ, then the fallbacks
    pc = copy.deepcopy(PC)                                                  # J2 switched on in τ, chord steps
    pc["cases"]["e8"]["model_step"]["j2"] = {"path": "tau", "corrector": "chord"}
    j2 = P.warm_start_kwargs(pc, "e8", "j2")
    assert j2["model_path"] == "tau" and j2["options"].corrector == "chord"
    pc = copy.deepcopy(PC)
    pc["cases"]["e8"]["warm_step_growth"] = "iterations"
    pc["cases"]["e8"]["model_step"]["g44_moon_sun"] = {"step_growth": "residual"}
    assert P.warm_start_options(pc, "e8", model="g44_moon_sun").step_growth == "residual"
    assert P.warm_start_options(pc, "e8", model="g44").step_growth == "iterations"
    for key, val, settings in (("path", "spiral", {"path": "spiral"}), ("flat_step", -1, {"flat_step": -1}),
                               ("accepted_update", "never", {"accepted_update": "never"}),
                               ("corrector", "secant", {"corrector": "secant"}),
                               ("h_init", 0.1, {"h_init": 0.1})):
        pc["cases"]["e8"]["model_step"] = {"g44_moon_sun": settings}
        with pytest.raises(ConfigError, match=rf"perturbed\.cases\.e8\.model_step\.g44_moon_sun\.{key}.*{val}"):
            P.warm_start_kwargs(pc, "e8", "g44_moon_sun")
    pc["cases"]["e8"]["model_step"] = {"g45": {"path": "tau"}}
    with pytest.raises(ConfigError, match=r"perturbed\.cases\.e8\.model_step\.g45"):
        P.warm_start_kwargs(pc, "e8", "g44_moon_sun")


def test_model_step_settings_of_one_revolution_count_override_the_others():
    """model_step.<model>.at_n_rev {count: settings}: E8's full model has the arclength h_max
    0.1 at 450 revolutions only (an arclength, ArclengthOptions, not re-typed to the default by
    chain.path_options), 0.3 elsewhere; a τ stage of the same warm start keeps its own step
    sizes; a bad count or setting names its key and value."""
    from spaceopt.indirect.chain import path_options
    from spaceopt.indirect.continuation import ArclengthOptions, ContinuationOptions

    at_450 = P.warm_start_kwargs(PC, "e8", "g44_moon_sun", n_rev=450)["options"]
    assert isinstance(at_450, ArclengthOptions)
    assert path_options("arclength", at_450, "x").h_max == PC["cases"]["e8"]["model_step"]["g44_moon_sun"][
        "at_n_rev"][450]["h_max"] < ArclengthOptions().h_max
    assert path_options("tau", at_450, "x").h_max == ContinuationOptions().h_max
    for n in (None, 400, 500):
        opt = P.warm_start_kwargs(PC, "e8", "g44_moon_sun", n_rev=n)["options"]
        assert path_options("arclength", opt, "x").h_max == ArclengthOptions().h_max
        assert opt.step_rcond == at_450.step_rcond and opt.flat_step == at_450.flat_step
    pc = copy.deepcopy(PC)
    step = pc["cases"]["e8"]["model_step"]["g44_moon_sun"]
    for bad, key in (({450: {"h_max": 0.0}}, r"at_n_rev\.450\.h_max"), ({450: {"path": "tau"}}, r"at_n_rev\.450\.path"),
                     ({-3: {"h_max": 0.1}}, r"at_n_rev\.-3"), ({450: 0.1}, r"at_n_rev\.450.*0\.1"),
                     ([450], r"at_n_rev.*450")):
        step["at_n_rev"] = bad
        with pytest.raises(ConfigError, match=rf"perturbed\.cases\.e8\.model_step\.g44_moon_sun\.{key}"):
            P.warm_start_kwargs(pc, "e8", "g44_moon_sun", n_rev=450)
    step["at_n_rev"] = {}
    step["h_max"] = 1.5
    with pytest.raises(ConfigError, match=r"g44_moon_sun\.h_max.*1\.5"):
        P.warm_start_kwargs(pc, "e8", "g44_moon_sun")


def test_force_model_step_goes_through_the_smoothing_eps(monkeypatch):
    """warm_start J2 → 4×4 with model_step_eps: the model step is done at that ε, in arclength
    (E7's route); without it, at ε_f by the model blend (E8's, E9's)."""
    import numpy as np

    from spaceopt.indirect import chain
    j2, g44 = (P.transfer_from_config(PC, "e9", m) for m in ("j2", "g44"))
    sh = chain.shooting_for("ot", "eps", j2)
    sol = chain.Solution("ot", sh, np.zeros(len(sh.unknown_names())), j2.params(thrust=1.0), j2, {}, thrust_N=1.0)
    calls = []

    def record(name):
        def move(s, prm_to, eps_smooth=None, options=None, label="", path="tau"):
            calls.append((name, eps_smooth, path, prm_to["pert"] is not None))
            return dataclasses.replace(s, stats={})
        return move

    monkeypatch.setattr(chain, "continue_in_params_smoothed", record("smoothed"))
    monkeypatch.setattr(chain, "continue_in_params", record("plain"))
    out = P.warm_start(sol, g44, "test", eps_smooth=1e-3, model_step_eps=1e-2)
    assert calls == [("smoothed", 1e-2, "arclength", True)]
    assert out.transfer is g44 and out.stats["warm_path"] == "arclength at eps = 0.01"
    monkeypatch.setattr(chain, "continue_in_model", record("model"))
    calls.clear()
    P.warm_start(sol, g44, "test", eps_smooth=1e-2)          # perturb_at_eps alone: at ε_f
    assert calls == [("model", None, "tau", True)]
    calls.clear()
    out = P.warm_start(sol, g44, "test", model_path="arclength")   # model_step path: arclength at once
    assert calls == [("model", None, "arclength", True)] and out.stats["warm_path"] == "arclength"


def test_model_step_falls_back_from_the_blend_to_the_newton_homotopy(monkeypatch):
    """warm_start J2 → 4×4 at ε_f: the model blend in τ first; where it fails, the Newton
    homotopy in the model (τ), then the blend in arclength; the failures are recorded, and the
    last one is raised when every path fails."""
    import numpy as np

    from spaceopt.errors import ConvergenceError
    from spaceopt.indirect import chain
    j2, g44 = (P.transfer_from_config(PC, "e9", m) for m in ("j2", "g44"))
    sh = chain.shooting_for("ot", "eps", j2)
    sol = chain.Solution("ot", sh, np.zeros(len(sh.unknown_names())), j2.params(thrust=1.0), j2, {}, thrust_N=1.0)
    calls, ok = [], set()

    def record(name):
        def move(s, prm_to, options=None, label="", path="tau"):
            calls.append((name, path))
            if (name, path) not in ok:
                raise ConvergenceError(f"{name} {path} failed", {})
            return dataclasses.replace(s, stats={})
        return move

    monkeypatch.setattr(chain, "continue_in_model", record("blend"))
    monkeypatch.setattr(chain, "continue_in_params", record("newton"))
    ok.add(("newton", "tau"))
    out = P.warm_start(sol, g44, "test")
    assert calls == [("blend", "tau"), ("newton", "tau")]
    assert out.stats["warm_path"] == "newton tau" and out.stats["path_failures"] == ["tau: blend tau failed"]
    calls.clear()
    ok.clear()
    with pytest.raises(ConvergenceError, match="blend arclength failed"):
        P.warm_start(sol, g44, "test")
    assert calls == [("blend", "tau"), ("newton", "tau"), ("blend", "arclength")]


def test_warm_start_integrates_with_the_new_problems_settings(monkeypatch):
    """Every stage of a warm start follows its path with the target transfer's path_rtol and
    step cap (E8: J2 at 1e-9 → 4×4 + Moon + Sun at the tighter rtol of the full model)."""
    import numpy as np

    from spaceopt.indirect import chain
    j2 = P.transfer_from_config(PC, "e9", "j2")
    g44 = dataclasses.replace(P.transfer_from_config(PC, "e9", "g44"), path_rtol=1e-11, max_steps=123_000)
    sh = chain.shooting_for("ot", "eps", j2)
    sol = chain.Solution("ot", sh, np.zeros(len(sh.unknown_names())), j2.params(thrust=1.0), j2, {}, thrust_N=1.0)
    seen = []

    def move(s, prm_to, options=None, label="", path="tau"):
        seen.append((s.shooting.path_rtol, s.shooting.max_steps, s.transfer.path_rtol, s.transfer.max_steps))
        return dataclasses.replace(s, stats={})

    monkeypatch.setattr(chain, "continue_in_model", move)
    out = P.warm_start(sol, g44, "test")
    assert seen == [(1e-11, 123_000, 1e-11, 123_000)]
    assert (out.shooting.path_rtol, out.shooting.max_steps) == (1e-11, 123_000)
    assert sol.shooting.path_rtol == j2.path_rtol != 1e-11         # the start is not changed


def test_e8_runs_leave_out_the_skipped_counts_and_check_them():
    e8 = {"n_rev": [200, 250, 300], "run_n_rev": [200, 250, 300], "run_models": ["unperturbed", "g44_moon_sun"],
          "skip_n_rev": {"g44_moon_sun": [300]}}
    pc = {**PC, "e8": e8}
    assert C.e8_runs(pc) == [("unperturbed", 200.0), ("unperturbed", 250.0), ("unperturbed", 300.0),
                             ("g44_moon_sun", 200.0), ("g44_moon_sun", 250.0)]
    assert len(C.e8_runs({**PC, "e8": {**e8, "skip_n_rev": None}})) == 6
    assert len(C.e8_runs({**PC, "e8": {**e8, "skip_n_rev": {"g44_moon_sun": [350]}}})) == 6   # not run anyway
    with pytest.raises(ConfigError, match=r"skip_n_rev\.j2"):
        C.e8_runs({**PC, "e8": {**e8, "skip_n_rev": {"j2": [300]}}})
    with pytest.raises(ConfigError, match=r"run_n_rev.*275"):
        C.e8_runs({**PC, "e8": {**e8, "run_n_rev": [275]}})


def test_e8_range_rows_say_which_counts_they_cover():
    """The §4.2.2 range statements (200–500 rev) taken over fewer paired counts get a note."""
    cases = {c: {"models": PC["cases"][c]["models"]} for c in PC["cases"]}
    pay = {f"e8_{m}_n{n}": _payload(2000 - mp, 150.0, m0=2000, n=n)
           for n, pairs in ((200, {"unperturbed": 194.9, "g44_moon_sun": 196.6}), (250, {"unperturbed": 175.0}))
           for m, mp in pairs.items()}
    tabs = R.tables(pay, ["e8"], cases, PC["e6"], [200, 250])
    notes = R.e8_range_notes(tabs, [200, 250])
    rows = {(r["case"], r["quantity"]): r for r in R.reproduction_rows(PUB, R.ours(tabs, pay, {}, None), notes)}
    assert rows[("e8", "perturbation_costs_fuel")]["status"] == "pass"
    assert "n_rev = 200 " in rows[("e8", "fuel_increase_max_kg")]["note"]
    # 150.0 d both: the transfer is not shortened, which the published statement says it is
    assert rows[("e8", "perturbation_shortens_time_below_500")]["status"] == "fail"
    assert "p_t(K_f)" in rows[("e8", "perturbation_shortens_time_below_500")]["note"]    # the miss explained
    assert rows[("e8", "perturbation_costs_fuel")]["note"].count("p_t(K_f)") == 0         # a pass gets none
    assert rows[("e8", "time_decrease_max_days")]["ours"] == 0.0
    assert rows[("e8_g44_moon_sun_n500", "propellant_kg")]["status"] == "missing"
    assert R.e8_range_notes(tabs, [200]) == {}


def test_paper_section_says_how_the_e8_counts_start():
    """The §4.2 paper text follows perturbed.e8.count_start (independent chains or n → n) and
    writes the ε values of the E8 route from the config (the smoothed route, config/e8_smoothed.yaml)."""
    smoothing = C.e8_smoothing(SMOOTHED)
    assert smoothing["eps_final"] == SMOOTHED["numerics"]["eps_final"]
    assert smoothing["perturb_at_eps"] == SMOOTHED["cases"]["e8"]["perturb_at_eps"]
    assert smoothing["model_step_at_eps"] == smoothing["eps_final"]       # E8 names none
    steps = C.e8_model_steps(SMOOTHED)
    assert [s["model"] for s in steps] == SMOOTHED["cases"]["e8"]["models"][2:]
    chain_text = R.paper_section([], {}, None, {}, [], e8_count_start="chain", smoothing=smoothing, e8_steps=steps)
    previous_text = R.paper_section([], {}, None, {}, [], e8_count_start="previous", smoothing=smoothing,
                                    e8_steps=steps)
    assert "a chain of its own from the zero guess" in chain_text
    assert "next smaller one" not in chain_text
    assert "next smaller one" in previous_text
    assert "skip" not in chain_text
    skipped = C.e8_skipped(SMOOTHED)       # the config's skip_n_rev, as the paper names it
    assert skipped == [(m, float(n)) for m, ns in SMOOTHED["e8"]["skip_n_rev"].items() for n in ns]
    text = R.paper_section([], {}, None, {}, [], e8_count_start="chain", smoothing=smoothing, e8_steps=steps,
                           e8_skipped=[("g44_moon_sun", 450.0)])
    assert "skip\\_n\\_rev" in text and "g44\\_moon\\_sun at 450 revolutions" in text
    assert r"$J_2$ switched on at $\varepsilon=10^{-2}$" in chain_text
    assert r"smoothing stage to $\varepsilon_f=10^{-5}$" in chain_text
    other = {**smoothing, "perturb_at_eps": 3e-2, "eps_blend": 5e-3}
    assert r"switched on at $\varepsilon=3\cdot10^{-2}$" in R.e8_route_text("chain", other, [])
    assert r"smoothing $\varepsilon=5\cdot10^{-3}$" in R.e8_route_text("previous", other, [])
    # the model steps after J2, from the case options model_step and path_arcs
    arcs = SMOOTHED["cases"]["e8"]["path_arcs"]["g44_moon_sun"]
    assert (r"to 4$\times$4 (in $\tau$); then to 4$\times$4 + Moon + Sun (in arclength, by multiple "
            f"shooting over {arcs} arcs, with Newton steps truncated below") in chain_text
    assert "flattest direction" in chain_text
    assert R.e8_route_text("chain", smoothing, []).endswith("accelerations. ")


def test_truncated_svd_steps_leave_a_nearly_flat_direction_alone():
    """step_rcond: where the Jacobian has a nearly flat direction (σ = 1e-6 here, E8 450 rev at
    the lunisolar blend: ten, σ/σ_max ≲ 3e-6) whose tiny residual Newton's step would
    resolve by a long move into the nonlinear region, the truncated-SVD steps of the polish
    leave that direction out and converge the rest; Newton's polish diverges."""
    import numpy as np

    from spaceopt.errors import ConvergenceError
    from spaceopt.indirect.continuation import Continuation, ContinuationOptions, _solve

    def ev(z, tau):
        f = np.array([z[0] - 1.0 + 500.0 * z[1] ** 2, 1e-6 * z[1] + 1e-9])
        return f, np.array([[1.0, 1000.0 * z[1]], [0.0, 1e-6]]), np.zeros(2), 0, True

    J = np.array([[1.0, 0.0], [0.0, 1e-6]])
    assert np.allclose(_solve(J, np.array([2.0, 1e-9]), 1e-3), [2.0, 0.0])
    assert np.allclose(_solve(J, np.array([2.0, 1e-9]), 0.0), [2.0, 1e-3])
    z0 = np.array([1.0 + 1e-4, 0.0])
    polish = lambda z, tau: ev(z, tau)      # a polish of its own: the start at τ₁ is re-evaluated
    with pytest.raises(ConvergenceError, match="final Newton polish"):
        Continuation(ev, ContinuationOptions(verbose=False, tol_final=1e-8), polish=polish).run(z0, tau0=1.0)
    z, _ = Continuation(ev, ContinuationOptions(verbose=False, tol_final=1e-8, step_rcond=1e-3),
                        polish=polish).run(z0, tau0=1.0)
    assert z[0] == pytest.approx(1.0, abs=1e-12) and z[1] == 0.0


def _final_polish(residual, jacobian, **options):
    """(z, statistics) of :class:`Continuation`'s final polish alone (τ₀ = 1) from (0, 0), for a
    residual f(z, τ) → (f, ok) of two unknowns with the Jacobian ``jacobian(z)``."""
    import numpy as np

    from spaceopt.indirect.continuation import Continuation, ContinuationOptions

    def ev(z, tau):
        return residual(z, tau)[0], jacobian(z), np.zeros(2), 0, True

    # a polish distinct from ``evaluate``: at τ₀ = τ₁ = 1 the homotopy's b would zero F otherwise
    cont = Continuation(ev, ContinuationOptions(verbose=False, **options), polish=lambda z, tau: ev(z, tau),
                        residual=residual)
    return cont.run(np.zeros(2), tau0=1.0)[0], cont.stats


def _polish_needing_rounds(residual, jacobian, **options):
    """(z, statistics) of :func:`_final_polish` with three rounds of the flat root
    (``flat_restarts``), after checking that one round alone fails."""
    from spaceopt.errors import ConvergenceError

    with pytest.raises(ConvergenceError, match="final Newton polish"):
        _final_polish(residual, jacobian, flat_restarts=1, **options)
    return _final_polish(residual, jacobian, flat_restarts=3, **options)


def test_a_failed_polish_finds_the_root_along_the_flattest_direction():
    """flat_step: f = (x − y², 10⁻⁶ (y − 0.01) + 100 (x − y²)²) from (0, 0). The flat direction is y
    (σ = 10⁻⁶); Newton's step lands off the valley x = y², where the second row's curvature
    makes J nearly singular and Newton diverges; truncated-SVD steps leave g = 10⁻⁸ alone.
    On the valley g(s) = 10⁻⁶ (s − 0.01): the march and secant find (10⁻⁴, 0.01) from
    residuals alone (E8 450 rev, the lunisolar blend at τ = 1: the same picture,
    docs/perturbed-e6-e7-e8.md, "ninth session")."""
    import numpy as np

    from spaceopt.errors import ConvergenceError

    def residual(z, tau):
        valley = z[0] - z[1] ** 2
        return np.array([valley, 1e-6 * (z[1] - 0.01) + 100.0 * valley ** 2]), True

    def jacobian(z):
        valley = z[0] - z[1] ** 2
        return np.array([[1.0, -2.0 * z[1]], [200.0 * valley, 1e-6 - 400.0 * z[1] * valley]])

    for kw in ({}, {"step_rcond": 1e-3}):
        with pytest.raises(ConvergenceError, match="final Newton polish"):
            _final_polish(residual, jacobian, tol_final=1e-12, **kw)
    z, stats = _final_polish(residual, jacobian, tol_final=1e-12, flat_step=0.004)
    assert z == pytest.approx([1e-4, 0.01], abs=1e-12)
    assert stats.residuals > 0


def test_the_flat_march_accepts_a_valley_point_whose_residual_is_at_a_stiff_rows_noise_floor():
    """flat_step, a noisy stiff row: f = (10⁴ (x − y²) + 5·10⁻¹⁰ n(z), 10⁻⁶ (y − 0.01) + 100 (x − y²)²)
    with n(z) in [−1, 1] a deterministic hash of z, the integration noise of a shooting
    residual. |f_r| stays near 5·10⁻¹⁰, above 10⁻² |g(0)| = 10⁻¹⁰, but the chord step it asks for
    is 5·10⁻¹⁴: the point is on the valley, and the root is found (E8 450, single shooting:
    docs/perturbed-e6-e7-e8.md, "fourteenth session"). Without the noise the residual test
    alone suffices."""
    import zlib

    import numpy as np

    def residual(z, tau, noise=5e-10):
        n = zlib.crc32(np.asarray(z, float).tobytes()) / 2.0 ** 31 - 1.0
        valley = z[0] - z[1] ** 2
        return np.array([1e4 * valley + noise * n, 1e-6 * (z[1] - 0.01) + 100.0 * valley ** 2]), True

    def jacobian(z):
        valley = z[0] - z[1] ** 2
        return np.array([[1e4, -2e4 * z[1]], [200.0 * valley, 1e-6 - 400.0 * z[1] * valley]])

    for noise in (5e-10, 0.0):
        z, stats = _final_polish(lambda z, tau: residual(z, tau, noise), jacobian, tol_final=1e-12, flat_step=0.004)
        assert z == pytest.approx([1e-4, 0.01], abs=1e-9) and stats.residuals > 0


def test_the_flat_march_turns_where_the_valley_curves_away_from_its_root():
    """flat_step, both sides: on the valley x = y² of f = (x − y², g(y) + 100 (x − y²)²) with
    g(y) = 10⁻⁸ + 10⁻⁶ y + 10⁻³ y² − y³, the slope σ_min = 10⁻⁶ sends Newton's direction to y < 0,
    where g only grows (its curvature wins beyond y ≈ −10⁻³); the root lies at y ≈ 0.003. The
    march turns once |g| has doubled and brackets the root with the steps left (E8 450 rev,
    4×4 → full with h_max 0.1: docs/perturbed-e6-e7-e8.md, "twelfth session")."""
    import numpy as np

    from spaceopt.errors import ConvergenceError

    coeffs = (1e-8, 1e-6, 1e-3, -1.0)              # g(y) = Σ c_k y^k

    def residual(z, tau):
        valley = z[0] - z[1] ** 2
        g = sum(c * z[1] ** k for k, c in enumerate(coeffs))
        return np.array([valley, g + 100.0 * valley ** 2]), True

    def jacobian(z):
        valley, y = z[0] - z[1] ** 2, z[1]
        dg = coeffs[1] + 2 * coeffs[2] * y + 3 * coeffs[3] * y ** 2
        return np.array([[1.0, -2.0 * y], [200.0 * valley, dg - 400.0 * y * valley]])

    def polish(max_steps):
        return _final_polish(residual, jacobian, tol_final=1e-14, flat_step=1e-3, flat_max_steps=max_steps)[0]

    y_root = [r.real for r in np.roots(coeffs[::-1]) if abs(r.imag) < 1e-12 and r.real > 0]
    assert len(y_root) == 1 and 0.002 < y_root[0] < 0.004
    assert polish(max_steps=20) == pytest.approx([y_root[0] ** 2, y_root[0]], abs=1e-10)
    with pytest.raises(ConvergenceError, match="final Newton polish"):
        polish(max_steps=3)                         # all three steps spent on Newton's side


def test_the_flat_march_halves_its_step_where_the_extrapolated_start_misses_the_valley():
    """flat_step, a narrow valley: f = (sinh(a d)/a, 10⁻⁶ (y − 0.03) + 100 d²), d = x − y²,
    a = 10⁵. A chord step at fixed J (cosh 0 = 1) contracts only where |a d| ≲ 2: each start,
    extrapolated linearly from the last two valley points, is off by 2 h² here (h² from the
    first), so with h = 0.004 the first point is reached (a h² = 1.6) and the second is not
    (3.2; the chords diverge). Halving the step from the last valley point reaches it again
    (0.75 a h², then 0.5 a h² per step), and the march brackets the root (9·10⁻⁴, 0.03)
    (E8 450, single shooting: flat_step 0.005 reaches the valley at s = −0.005, not at −0.01;
    docs/perturbed-e6-e7-e8.md, "fifteenth session")."""
    import numpy as np

    a, y_root = 1e5, 0.03

    def residual(z, tau):
        d = z[0] - z[1] ** 2
        with np.errstate(over="ignore", invalid="ignore"):
            return np.array([np.sinh(a * d) / a, 1e-6 * (z[1] - y_root) + 100.0 * d ** 2]), True

    def jacobian(z):
        d, y = z[0] - z[1] ** 2, z[1]
        with np.errstate(over="ignore"):
            ch = np.cosh(a * d)
        return np.array([[ch, -2.0 * y * ch], [200.0 * d, 1e-6 - 400.0 * y * d]])

    z, stats = _final_polish(residual, jacobian, tol_final=1e-14, flat_step=0.004)
    assert z == pytest.approx([y_root ** 2, y_root], abs=1e-12) and stats.residuals > 0


def test_the_flat_march_steps_just_past_the_root_its_secant_predicts():
    """flat_step 0.005, a valley that narrows the chords' reach: f = (sinh(a d)/a, g(y) + 100 d²),
    d = x − κ y², a = 2·10⁶, κ = 2.432, g(y) = −5.29·10⁻⁷ + 7.6·10⁻⁴ y (root y* = 0.000696). The
    march from (0, 0) reaches the valley only after three halvings, at y = 0.000625
    (g = −5.4·10⁻⁸), and its next start, extrapolated a step of 0.000625 on, misses it (a d = 3.8;
    the chord diverges): without more, that side ends without a bracket, and so does the other.
    The secant through the two valley points puts y* 7·10⁻⁵ ahead; a step of 1.5 times that lands
    past it on the valley, and regula falsi finds it. Modelled on the numbers of E8 500 rev, full
    model, single shooting, from scratch; there the point at 0.000625 was not exact (|f_r| 3.2e-4,
    accepted by the chord-step test) and the cut step missed the valley too: what converged that
    case is the next round (docs/perturbed-e6-e7-e8.md, "eighteenth session"). Newton's polish is
    switched off (max_final 0) to isolate the march."""
    import numpy as np

    a, kappa, g0, slope = 2e6, 2.432, -5.29e-7, 7.6e-4

    def residual(z, tau):
        d = z[0] - kappa * z[1] ** 2
        with np.errstate(over="ignore", invalid="ignore"):
            return np.array([np.sinh(a * d) / a, g0 + slope * z[1] + 100.0 * d ** 2]), True

    def jacobian(z):
        d, y = z[0] - kappa * z[1] ** 2, z[1]
        with np.errstate(over="ignore"):
            ch = np.cosh(a * d)
        return np.array([[ch, -2.0 * kappa * y * ch], [200.0 * d, slope - 400.0 * kappa * y * d]])

    z, stats = _final_polish(residual, jacobian, tol_final=1e-12, flat_step=0.005, max_final=0)
    assert z[1] == pytest.approx(-g0 / slope, abs=1e-9) and abs(z[0] - kappa * z[1] ** 2) < 1e-12
    assert stats.residuals < 30


def test_the_flat_root_restarts_from_where_its_last_round_stopped():
    """flat_step, a steep valley: f = (x − y², G(y) + 100 (x − y²)²), d = x − y², with
    G(y) = 10⁻⁶ (e^{300 (y − 0.05)} − 1)/300: g(0) = −3.3·10⁻⁹, nearly flat to y ≈ 0.04, then
    steep. With three regula-falsi steps (flat_chord 3) the first round stops at g = 6·10⁻¹¹,
    0.00006 from the root, where Newton still fails (its step leaves the valley). A second
    round from there, with the Jacobian there (σ_min 10⁻⁶) and steps of Newton's distance
    |g|/σ_min, brackets the root at once (E8 450, single shooting: the first round's chords,
    J frozen, stopped short of its bracket's root; docs/perturbed-e6-e7-e8.md,
    "fifteenth session")."""
    import numpy as np

    b, y_root = 300.0, 0.05

    def residual(z, tau):
        d = z[0] - z[1] ** 2
        with np.errstate(over="ignore", invalid="ignore"):     # Newton's diverging steps
            return np.array([d, 1e-6 / b * np.expm1(b * (z[1] - y_root)) + 100.0 * d ** 2]), True

    def jacobian(z):
        d, y = z[0] - z[1] ** 2, z[1]
        with np.errstate(over="ignore", invalid="ignore"):
            return np.array([[1.0, -2.0 * y], [200.0 * d, 1e-6 * np.exp(b * (y - y_root)) - 400.0 * y * d]])

    z, stats = _polish_needing_rounds(residual, jacobian, tol_final=1e-14, flat_step=0.004, flat_chord=3)
    assert z == pytest.approx([y_root ** 2, y_root], abs=1e-7) and stats.jacobians == 6


def test_a_round_without_a_bracket_hands_its_point_nearest_the_root_to_the_next_round():
    """flat_step 0.04, a valley whose chords need a fresh Jacobian: f = (e^{b y} (x − y²),
    10⁻⁶ (y − y*)), b = 100, y* = 0.009. The chords hold J from y = 0, whose slope 1 in x is
    e^{b y} on the valley, so they contract only for y < ln 2 / b ≈ 0.0069: the march reaches
    the valley at y = 0.005 (g −4·10⁻⁹ of g(0) −9·10⁻⁹), every start beyond it misses, and the
    other side moves away from the root; no bracket, and one round fails. A second round from
    y = 0.005, with the Jacobian there, reaches y* at once (E8 500 rev, full model, single
    shooting, from scratch: docs/perturbed-e6-e7-e8.md, "eighteenth session"). Newton's polish
    is switched off (max_final 0) to isolate the rounds."""
    import numpy as np

    residual, jacobian = _stiff_valley()
    z, stats = _polish_needing_rounds(residual, jacobian, tol_final=1e-14, flat_step=0.04, max_final=0)
    assert np.abs(residual(z, 1.0)[0]).max() < 1e-12 and stats.jacobians == 4
    assert z[1] == pytest.approx(0.009, abs=1e-6)          # |g| 1e-13 at slope 1e-6


def _stiff_valley(b=100.0, y_root=0.009):
    """(residual, jacobian) of f = (e^{b y} (x − y²), 10⁻⁶ (y − y*)): a valley x = y² whose
    chords, J held from y = 0, contract only for y < ln 2 / b."""
    import numpy as np

    def residual(z, tau):
        with np.errstate(over="ignore", invalid="ignore"):
            return np.array([np.exp(b * z[1]) * (z[0] - z[1] ** 2), 1e-6 * (z[1] - y_root)]), True

    def jacobian(z):
        d, y = z[0] - z[1] ** 2, z[1]
        return np.exp(b * y) * np.array([[1.0, b * d - 2.0 * y], [0.0, 1e-6 * np.exp(-b * y)]])

    return residual, jacobian


def test_a_failed_polish_counts_the_flat_march_valley_points_among_its_best():
    """One round of the flat root on :func:`_stiff_valley` fails (no bracket, Newton off); its
    valley points lie nearer the root than the start, |F| 9e-9 at (0, 0), and the best of them
    is the diagnosis's ``z_best`` (E8 450 rev: the single-shooting start at |F| 5e-2, the
    valley through it at 3.5e-7; the free-time end game starts from there)."""
    import numpy as np

    from spaceopt.errors import ConvergenceError

    residual, jacobian = _stiff_valley()
    with pytest.raises(ConvergenceError, match="final Newton polish") as info:
        _final_polish(residual, jacobian, tol_final=1e-14, flat_step=0.04, max_final=0, flat_restarts=1)
    d = info.value.diagnosis
    assert d["residual_best"] < 0.5 * 9e-9
    assert d["residual_best"] == pytest.approx(np.abs(residual(np.array(d["z_best"]), 1.0)[0]).max())
    assert 0.0 < d["z_best"][1] < 0.009


def test_e8_figure_breaks_the_line_at_a_missing_count(tmp_path, monkeypatch):
    """Fig. 4.2.2.5: a model without a count the others have (the full model at 450) gets a gap
    there, not a segment bridging it; models keep the rows' order."""
    from spaceopt.studies import perturbed_figures as F
    drawn = []
    monkeypatch.setattr(F, "save_figure", lambda fig, path: drawn.extend(
        (ln.get_label(), list(ln.get_xdata()), list(ln.get_ydata())) for ln in fig.axes[0].lines))
    rows = [{"n_rev": n, "model": m, "propellant_kg": kg, "tof_days": 0.6 * n}
            for m, pts in (("unperturbed", {400: 156.5, 450: 154.1, 500: 152.5}),
                           ("g44_moon_sun", {400: 159.6, 500: 156.8}))
            for n, kg in pts.items()]
    F.fuel_vs_revs(rows, tmp_path / "fig")
    assert [d[0] for d in drawn] == ["unperturbed", "g44_moon_sun"]
    full = drawn[1]
    assert full[1] == [400, 450, 500] and full[2][0] == 159.6 and math.isnan(full[2][1]) and full[2][2] == 156.8


def test_e6_figures_break_the_lines_at_the_dates_left_out(tmp_path, monkeypatch):
    """Figs. 4.2.1.4–5 with ``skip_dates``: a gap (NaN) at each date left out, not a segment
    bridging it, and the date marked."""
    from spaceopt.studies import perturbed_figures as F
    drawn = []
    monkeypatch.setattr(F, "save_figure", lambda fig, path: drawn.append(
        [(list(ln.get_xdata()), list(ln.get_ydata())) for ln in fig.axes[0].lines]))
    dates = ["2021-05-01", "2021-05-02", "2021-05-04"]
    rows = [{"date": d, "model": "g44_moon_sun", "m_f_kg": 956.0 + k, "tof_days": 60.0} for k, d in enumerate(dates)]
    F.date_scan(rows, tmp_path / "scan", skipped=["2021-05-03"])
    F.costates_vs_date(dates, [{"p_p": 0.1 * k} for k in range(3)], tmp_path / "costates", skipped=["2021-05-03"])
    for lines in drawn:
        x, y = lines[0]
        assert x == [1, 2, 3, 4] and math.isnan(y[2]) and not any(map(math.isnan, y[:2] + y[3:]))
        assert any(ln[0] == [3, 3] for ln in lines[1:])             # the vertical mark at day 3


def test_e6_figure_draws_one_line_per_family_and_the_other_families_reached_at_a_date(tmp_path, monkeypatch):
    """Fig. 4.2.1.4 with the scan's families: no line across a jump (2/3 May), a line across a
    date left out inside a family (4 May, a NaN), and the extremal a neighbour's family reaches
    at a date as an open marker."""
    from spaceopt.studies import perturbed_figures as F
    drawn = []
    monkeypatch.setattr(F, "save_figure", lambda fig, path: drawn.append(
        [(list(ln.get_xdata()), list(ln.get_ydata()), ln.get_linestyle()) for ln in fig.axes[0].lines]))
    dates = ["2021-05-01", "2021-05-02", "2021-05-03", "2021-05-05"]
    rows = [{"date": d, "model": "g44_moon_sun", "m_f_kg": 956.0 + k, "tof_days": 60.0} for k, d in enumerate(dates)]
    link = lambda a, b, status, m=None: {"from_date": a, "to_date": b, "status": status, "m_f_kg": m, "tof_days": 61.0}
    families = [link("2021-05-01", "2021-05-02", "same"), link("2021-05-02", "2021-05-03", "other", 958.5),
                link("2021-05-03", "2021-05-05", "start")]
    F.date_scan(rows, tmp_path / "scan", skipped=["2021-05-04"], families=families)
    (x1, y1, ls1), (x2, y2, ls2), (xo, yo, lso) = drawn[0][:3]
    assert (x1, y1) == ([1, 2], [956.0, 957.0]) and ls1 == "-"
    assert x2 == [3, 4, 5] and math.isnan(y2[1]) and (y2[0], y2[2]) == (958.0, 959.0)
    assert (xo, yo, lso) == ([3], [958.5], "None")


def test_e6_figure_draws_each_family_followed_on_from_its_links_point_and_the_envelope_under_it(
        tmp_path, monkeypatch):
    """Fig. 4.2.1.4 with the walks (spaceopt.studies.scan_walks): a dashed line from the link's
    open circle through the walk's steps that reached their date, the envelope as a broad band."""
    from spaceopt.studies import perturbed_figures as F
    drawn = []
    monkeypatch.setattr(F, "save_figure", lambda fig, path: drawn.append(
        [(list(ln.get_xdata()), list(ln.get_ydata()), ln.get_linestyle(), ln.get_linewidth()) for ln in fig.axes[0].lines]))
    dates = ["2021-05-01", "2021-05-02", "2021-05-03"]
    rows = [{"date": d, "model": "g44_moon_sun", "m_f_kg": 956.0, "tof_days": 60.0} for d in dates]
    families = [{"from_date": "2021-05-01", "to_date": "2021-05-02", "status": "other", "m_f_kg": 958.0, "tof_days": 61.0}]
    step = lambda date, status, m: {"from_date": "2021-05-01", "link_to": "2021-05-02", "date": date,
                                    "status": status, "m_f_kg": m, "tof_days": 62.0}
    walks = [step("2021-05-03", "other", 957.5), step("2021-05-04", "failed", None)]
    envelope = [{"date": d, "m_f_kg": m, "tof_days": 60.0} for d, m in zip(dates, (956.0, 958.0, 957.5))]
    F.date_scan(rows, tmp_path / "scan", families=families, walks=walks, envelope=envelope)
    lines = drawn[0]
    band = [ln for ln in lines if ln[3] == 6]
    assert len(band) == 1 and band[0][:2] == ([1, 2, 3], [956.0, 958.0, 957.5])
    dashed = [ln for ln in lines if ln[2] == "--"]
    assert len(dashed) == 1 and dashed[0][:2] == ([2, 3], [958.0, 957.5])


def test_the_verification_sentence_states_the_worst_errors_and_the_perturbation_scale():
    from spaceopt.report.verification import verification_sentence
    row = {"final_a_error_km": -0.2, "final_e_error": 1e-6, "final_i_error_deg": 3e-6, "final_mass_error_kg": 1e-5,
           "final_position_vs_solver_km": 0.5}
    assert verification_sentence([], "x") == ""
    plain = verification_sentence([row], "OT trajectories")
    assert "each of the 1 OT trajectories" in plain and "0.2~km in $a$" in plain and "0.5~km." in plain
    assert "perturbations move" not in plain
    text = verification_sentence([{**row, "final_position_without_perturbations_km": 50.0},
                                  {**row, "final_position_without_perturbations_km": 25.0}], "perturbed trajectories")
    assert "at most 2~\\% of the distance by which the perturbations move the end point" in text
    assert "minimum-thrust" not in text
    probed = verification_sentence([row, {**row, "final_position_vs_solver_km": 400.0, "thrust_probe_relative": 1e-7,
                                          "final_position_moved_by_thrust_probe_km": 800.0}], "trajectories")
    assert "at most 400~km" in probed and ("For the minimum-thrust ones among them and the least-thrust points of the thrust "
                                               "families (1;") in probed
    assert "by $10^{-7}$ (relative) moves the end point by 800 to 800~km" in probed
    assert "farthest from the solver's end point (400~km) is one whose end point that change moves by 800~km" in probed


def test_tof_maximum_settings_merge_the_case_keys_into_the_numerics_ones():
    """The free-time end game: numerics.tof_maximum for every case, a case's own keys replacing
    them one by one (E9: probes 0.001 d apart; E8: the survey), a case's null key leaving the
    numerics' (a profile's removal: config/e8_smoothed.yaml), null switching it off; a bad value is a
    one-line error naming the key."""
    from spaceopt.config import validate_section
    base = PC["numerics"]["tof_maximum"]
    assert P.tof_maximum_settings(PC, "e8") == {**base, **PC["cases"]["e8"]["tof_maximum"]}
    assert P.tof_maximum_settings(SMOOTHED, "e8") == base
    nulled = copy.deepcopy(SMOOTHED)
    assert nulled["cases"]["e8"]["tof_maximum"]["max_points"] is None
    nulled["numerics"]["tof_maximum"]["max_points"] = 24        # the case's null leaves the numerics' value
    assert P.tof_maximum_settings(nulled, "e8")["max_points"] == 24
    nulled["numerics"]["tof_maximum"]["probe_days"] = None      # a null in the numerics: MaximumOptions' default
    assert "probe_days" not in P.tof_maximum_settings(nulled, "e8")
    e9 = P.tof_maximum_settings(PC, "e9")
    assert e9["probe_days"] == PC["cases"]["e9"]["tof_maximum"]["probe_days"] != base["probe_days"]
    assert {k: v for k, v in e9.items() if k != "probe_days"} == {k: v for k, v in base.items() if k != "probe_days"}
    off = copy.deepcopy(PC)
    off["cases"]["e8"]["tof_maximum"] = None
    assert P.tof_maximum_settings(off, "e8") is None
    off["numerics"]["tof_maximum"] = None
    assert P.tof_maximum_settings(off, "e5") is None
    assert P.tof_maximum_settings(off, "e9") == PC["cases"]["e9"]["tof_maximum"]
    bad = {"perturbed": copy.deepcopy(PC)}
    bad["perturbed"]["numerics"]["tof_maximum"]["probe_days"] = -0.05
    with pytest.raises(ConfigError) as info:
        validate_section(bad, "perturbed", ROOT / "config/schema/perturbed.schema.yaml")
    assert str(info.value).startswith("perturbed.numerics.tof_maximum") and "\n" not in str(info.value)


def test_an_unperturbed_solution_skips_the_end_game():
    sol = dataclasses.make_dataclass("S", [("transfer", object)])(P.transfer_from_config(PC, "e8", "unperturbed"))
    assert P.maximise_in_tof(sol, PC, "e8", "e8") == (sol, None)


def test_the_end_game_rows_and_sentence_say_what_was_certified_moved_and_not_found():
    rec = lambda status, t0, t, gain: {"extra": {"tof_maximum": {
        "status": status, "t0_days": t0, **({"tof_days": t, "m_f_gain_kg": gain} if t is not None else {}),
        "fixed_time_solves": 5, "jacobian_evaluations": 9, "wall_time_s": 60.0}}}
    payloads = {"e8_g44_moon_sun_n250": rec("maximum", 177.4674, 177.8050, 1.5e-3),
                "e5_g44_moon_sun": rec("maximum", 65.41938, 65.41938, 0.0),
                "e8_g44_moon_sun_n450": rec("no sign change of phi within 16 fixed-time solves", 289.78, None, None),
                "e5_unperturbed": {"extra": {}}}
    rows = R.tof_maximum_rows(payloads)
    assert [r["solve"] for r in rows] == ["e5_g44_moon_sun", "e8_g44_moon_sun_n250", "e8_g44_moon_sun_n450"]
    assert rows[1]["m_f_gain_g"] == pytest.approx(1.5) and rows[2]["tof_days"] is None
    text = R.tof_maximum_sentence(rows)
    assert "Of 3 perturbed solves, 2 are certified maxima; 1 of them were moved" in text
    assert "1.50 g" in text and "177.4674 $\\to$ 177.8050 d" in text
    assert "did not certify e8\\_g44\\_moon\\_sun\\_n450 (no sign change" in text
    assert "round the fold" not in text and rows[0]["folds_passed"] is None
    payloads["e8_g44_moon_sun_n500"] = rec("maximum", 321.1281, 321.0, 1e-3)
    payloads["e8_g44_moon_sun_n500"]["extra"]["tof_maximum"].update(arclength_points=4, folds_passed=1)
    rows = R.tof_maximum_rows(payloads)
    assert rows[-1]["folds_passed"] == 1 and rows[-1]["arclength_points"] == 4
    assert "round the fold (e8\\_g44\\_moon\\_sun\\_n500)" in R.tof_maximum_sentence(rows)
    assert "downhill" not in R.tof_maximum_sentence(rows) and rows[-1]["downhill_folds_passed"] is None
    payloads["e8_g44_moon_sun_n450"] = rec("maximum", 289.7814, 290.4, -2.5e-3)
    payloads["e8_g44_moon_sun_n450"]["extra"]["tof_maximum"].update(folds_passed=2, downhill_folds_passed=1)
    text = R.tof_maximum_sentence(R.tof_maximum_rows(payloads))
    assert "on downhill along the family" in text and "e8\\_g44\\_moon\\_sun\\_n450: $-2.50$ g" in text
    assert "larger smoothing" not in text and rows[-1]["lift_eps"] is None
    payloads["e8_g44_moon_sun_n500"]["extra"]["tof_maximum"]["lift"] = {"eps": 1e-3, "bracket_days": [321.0, 321.1]}
    rows = R.tof_maximum_rows(payloads)
    assert [r["lift_eps"] for r in rows] == [None, None, None, 1e-3]
    text = R.tof_maximum_sentence(rows)
    assert "at a larger smoothing" in text and "e8\\_g44\\_moon\\_sun\\_n500: $\\varepsilon$ 0.001, $\\Delta t$ 321.1281 $\\to$ 321.0000 d" in text
    assert R.tof_maximum_sentence([]) == ""
    # on the exact bang-bang map the end game has no eps to lift (free_time records why)
    payloads["e8_g44_moon_sun_n500"]["extra"]["tof_maximum"]["lift"] = {"eps": None, "off": "exact map"}
    assert R.tof_maximum_rows(payloads)[-1]["lift_eps"] is None
    # a survey of the family round the maximum: its maxima counted, their spreads, the sentence
    assert rows[-1]["survey_maxima"] is None and "surveyed" not in text
    payloads["e8_g44_moon_sun_n500"]["extra"]["tof_maximum"]["survey"] = {
        "window_days": 1.0, "maxima": [[321.9997, 1843.2337830, -6e-11], [321.5230, 1843.2344100, 2e-11]]}
    rows = R.tof_maximum_rows(payloads)
    assert rows[-1]["survey_maxima"] == 2 and rows[-1]["survey_tof_spread_days"] == pytest.approx(0.4767)
    assert rows[-1]["survey_m_f_spread_g"] == pytest.approx(0.627, abs=1e-6)
    assert "2 maxima, $\\Delta t$ within 0.477 d, $m_f$ within 0.63 g" in R.tof_maximum_sentence(rows)


def test_a_failed_polish_reports_its_best_point_beside_where_it_stopped():
    """f = (∛z₀, z₁): Newton's step z₀ → −2 z₀ grows |F| by 2^⅓ each time, within the polish's
    twofold allowance, so it stops far worse than it began; the diagnosis keeps both where it
    stopped (``z``) and its point of least |F| (``z_best``, here the start), which a caller can
    still certify another way (the free-time end game)."""
    import numpy as np

    from spaceopt.errors import ConvergenceError

    def residual(z, tau):
        return np.array([np.cbrt(z[0]), z[1]]), True

    def jacobian(z):
        return np.diag([abs(z[0]) ** (-2.0 / 3.0) / 3.0, 1.0])

    from spaceopt.indirect.continuation import Continuation, ContinuationOptions
    ev = lambda z, tau: (residual(z, tau)[0], jacobian(z), np.zeros(2), 0, True)
    start = np.array([1e-3, 0.0])
    with pytest.raises(ConvergenceError, match="final Newton polish") as info:
        # a polish distinct from ``evaluate`` (as in _final_polish)
        Continuation(ev, ContinuationOptions(verbose=False, tol_final=1e-12),
                     polish=lambda z, tau: ev(z, tau)).run(start, tau0=1.0)
    d = info.value.diagnosis
    assert d["residual_best"] == pytest.approx(0.1) and d["residual"] > 1.5 * d["residual_best"]
    np.testing.assert_array_equal(d["z_best"], start)


def test_the_e6_latex_tables_add_the_dates_where_another_familys_extremal_is_heavier():
    """R.latex with the envelope (spaceopt.studies.scan_walks.envelope_rows): after the E6
    table, a table of the dates whose heaviest extremal found is another date's family; none
    where the scan's extremal is the heaviest at every date."""
    from spaceopt.studies import perturbed_report as R
    tabs = {n: [] for n in R.COLUMNS}
    tabs["e6_date_scan"] = [{"date": d, "model": "g44_moon_sun", "m_f_kg": 957.0, "tof_days": 60.0}
                            for d in ("2021-05-08", "2021-05-09")]
    env = [{"date": "2021-05-08", "scan_m_f_kg": 957.0, "m_f_kg": 957.0, "tof_days": 60.0, "gain_kg": 0.0,
            "family_of": "2021-05-08", "arrival_utc": "2021-07-07T12:00"},
           {"date": "2021-05-09", "scan_m_f_kg": 957.0, "m_f_kg": 960.5, "tof_days": 65.19, "gain_kg": 3.5,
            "family_of": "2021-05-10", "arrival_utc": "2021-07-13T16:33"}]
    tex = R.latex(tabs, e6_envelope=env)
    assert tex.count(r"\begin{table}") == 2 and tex.index("departure-date scan") < tex.index("heavier than the scan")
    heavier = tex[tex.index("heavier than the scan"):]
    assert "2021-05-09 & $957.000000$ & $960.500000$ & $65.190000$ & $3.500000$ & 2021-05-10 & 2021-07-13T16:33" in heavier
    assert "2021-05-08" not in heavier
    assert R.latex(tabs, e6_envelope=env[:1]) == R.latex(tabs)
    assert R.latex(tabs).count(r"\begin{table}") == 1


def test_the_existence_runs_leave_out_the_skipped_models_and_name_a_bad_one():
    runs = C.existence_runs(PC)
    assert ("e7", "unperturbed") in runs and ("e7", "j2") in runs and ("e7", "g44_moon_sun") in runs
    assert ("e9", "g44_moon_sun") in runs and runs.index(("e5", "unperturbed")) == 0
    bad = copy.deepcopy(PC)
    bad["existence"]["skip"] = {"e7": ["g44_moon_sun"]}
    assert ("e7", "g44_moon_sun") not in C.existence_runs(bad)
    bad["existence"]["skip"] = {"e7": ["g44"]}
    with pytest.raises(ConfigError, match=r"perturbed.existence.skip.e7='g44'.*not a model of the check"):
        C.existence_runs(bad)
    bad["existence"] = {"cases": [e for e in PC["existence"]["cases"] if e != "e7"], "from_ot": {"cases": ["e7"]}}
    with pytest.raises(ConfigError, match=r"from_ot.cases='e7'"):
        C.existence_runs(bad)


def test_a_model_carries_over_another_models_bound_only_where_both_are_checked_from_ot():
    """existence.bound_from (E7: the full model carries the J2 bound over): each pair is checked."""
    assert C.existence_bound_from(PC) == {("e7", "g44_moon_sun"): "j2"}
    for bound_from, match in (({"e9": {"g44_moon_sun": "j2"}}, r"bound_from.e9=.*not a case of .*from_ot"),
                              ({"e7": {"g44_moon_sun": "unperturbed"}}, r"bound_from.e7.g44_moon_sun='unperturbed'"),
                              ({"e7": {"g44": "j2"}}, r"bound_from.e7.g44='g44'.*not a perturbed model"),
                              ({"e7": {"j2": "j2"}}, r"bound_from.e7.j2='j2'.*its own bound")):
        bad = copy.deepcopy(PC)
        bad["existence"]["bound_from"] = bound_from
        with pytest.raises(ConfigError, match=match):
            C.existence_bound_from(bad)
    assert C.existence_bound_from({**PC, "run": ["e9"]}) == {}         # E7 not run (the quick profile)
    bad = copy.deepcopy(PC)
    bad["existence"]["skip"] = {"e7": ["j2"]}                      # the source left out of the check
    with pytest.raises(ConfigError, match=r"bound_from.e7.g44_moon_sun='j2'"):
        C.existence_bound_from(bad)


def test_e8_runs_on_the_exact_map_and_the_smoothed_profile_restores_the_smoothed_route():
    """The study config's E8: schema-valid, on the exact map, its model steps single shooting,
    the full model's in arclength with truncated-SVD steps, no smoothing ε for the warm starts,
    the sensitivities at a looser tolerance than the path's, the unperturbed chain's paths at a
    looser rtol than the default (the other models' unchanged), the full model started from J2,
    the survey in the end game. config/e8_smoothed.yaml over it (as --configfile merges it):
    schema-valid, every one of those options back to the smoothed route's (its nulls remove the
    exact route's values: the default tolerances, J2's default step, the numerics' end game)."""
    import jsonschema
    schema = yaml.safe_load((ROOT / "config/schema/perturbed.schema.yaml").read_text())
    jsonschema.validate(PC, schema)
    jsonschema.validate(SMOOTHED, schema)
    own = PC["cases"]["e8"]
    assert C.case_switching(PC, "e8") == "exact"
    steps = {step["model"]: step for step in C.e8_model_steps(PC)}
    assert all(step["arcs"] == 1 for step in steps.values()) and steps["g44"]["path"] == "tau"
    assert steps["g44_moon_sun"]["path"] == "arclength" and steps["g44_moon_sun"]["step_rcond"] > 0
    kw = P.warm_start_kwargs(PC, "e8", "g44_moon_sun", n_rev=500)
    assert kw["eps_smooth"] is None and kw["model_step_eps"] is None
    settings = P.tof_maximum_settings(PC, "e8")           # the survey added to the study's end game
    assert settings["survey_days"] > 0 and settings["probe_days"] == PC["numerics"]["tof_maximum"]["probe_days"]
    assert ft.MaximumOptions(**settings).survey_days == settings["survey_days"]
    tr = P.transfer_from_config(PC, "e8", "g44_moon_sun", n_rev=200)   # the Jacobians' own tolerance
    assert tr.sensitivity_rtol == own["sensitivity_rtol"] > tr.path_rtol == own["path_rtol"]["g44_moon_sun"]
    chain_tr = P.transfer_from_config(PC, "e8", "unperturbed", n_rev=200)  # the chain's looser paths
    assert chain_tr.path_rtol == own["path_rtol"]["unperturbed"] > P.transfer_from_config(PC, "e8", "j2").path_rtol
    assert C.case_route(PC, "e8", "g44_moon_sun") == ["unperturbed", "j2", "g44_moon_sun"]   # 4x4 beside it
    j2 = P.warm_start_kwargs(PC, "e8", "j2")                 # J2 switched on in tau, chord steps
    assert j2["model_path"] == "tau" and j2["options"].corrector == "chord"
    assert C.e8_runs(PC) == [(m, float(n)) for m in PC["e8"]["run_models"] for n in PC["e8"]["run_n_rev"]]  # 450 too
    text = R.e8_route_text("chain", C.e8_smoothing(PC), C.e8_model_steps(PC))
    assert "exact bang-bang problem" in text and r"4$\times$4 + Moon + Sun from the $J_2$ extremal (in arclength" in text

    sm = SMOOTHED
    assert C.case_switching(sm, "e8") == "smoothed" and P.chain_options(sm, "e8") is None
    steps = {step["model"]: step for step in C.e8_model_steps(sm)}
    assert steps["g44_moon_sun"]["arcs"] == sm["cases"]["e8"]["path_arcs"]["g44_moon_sun"] > 1
    assert P.warm_start_kwargs(sm, "e8", "g44_moon_sun", n_rev=500)["eps_smooth"] == sm["cases"]["e8"]["perturb_at_eps"]
    j2 = P.warm_start_kwargs(sm, "e8", "j2")                 # J2's step as if the case named none
    assert j2["model_path"] is None and C.case_model_step(sm["cases"]["e8"], "j2", "e8") == {}
    assert P.tof_maximum_settings(sm, "e8") == PC["numerics"]["tof_maximum"]
    for model in sm["cases"]["e8"]["models"]:
        tr = P.transfer_from_config(sm, "e8", model, n_rev=500)
        assert tr.sensitivity_rtol is None and tr.path_step_budget is None
    assert P.transfer_from_config(sm, "e8", "unperturbed").path_rtol == C.PATH_RTOL
    assert P.transfer_from_config(sm, "e8", "g44_moon_sun").path_rtol == own["path_rtol"]["g44_moon_sun"]
    assert C.case_start_model(sm, "e8", "g44_moon_sun", 500) == "g44" and C.case_start_model(sm, "e8", "g44_moon_sun", 450) == "j2"


def test_the_thrust_ratio_blend_reference_is_the_lp_primer_times_t_over_t0():
    """blend_ref 'thrust_ratio' (E9's setting): W_ref = 2 V_LP/Δt_LP × T/T⁽⁰⁾ with T⁽⁰⁾ the
    constant thrust giving the LP's Δv over its Δt; a number is taken as it is; anything else is
    a one-line error naming the key, from the schema and from the library."""
    from types import SimpleNamespace

    from spaceopt.config import validate_section
    assert PC["cases"]["e9"]["blend_ref"] == "thrust_ratio"
    tr = P.transfer_from_config(PC, "e9", "j2")
    lp = SimpleNamespace(transfer=tr, extra={"dv_m_s": 10.0, "tof_s": 5 * 86400.0})
    w_ref = 2.0 * (10.0 / tr.vu) / (5 * 86400.0 / tr.tu)
    T0 = tr.m0 * tr.c / (5 * 86400.0) * (1.0 - math.exp(-10.0 / tr.c))
    assert chain.blend_reference(lp) == pytest.approx(w_ref, rel=1e-15)
    assert chain.blend_reference(lp, 1.0) == pytest.approx(w_ref * 1.0 / T0, rel=1e-15)
    assert 20 < 1.0 / T0 < 50                  # E9's 1 N against the LP's ~0.02 N: the layer the ratio removes
    with pytest.raises(ConfigError, match=r"perturbed\.cases\.blend_ref='thrust'.*thrust_ratio"):
        P.solve_for(tr, "e9", blend_ref="thrust")
    with pytest.raises(ValueError, match=r"blend_ref 'thrust': expected a number or one of lp_primer, thrust_ratio"):
        chain.solve_ot(lp, 1.0, blend_ref="thrust")
    for value in ("thrust", -1.0):
        bad = {"perturbed": copy.deepcopy(PC)}
        bad["perturbed"]["cases"]["e9"]["blend_ref"] = value
        with pytest.raises(ConfigError) as info:
            validate_section(bad, "perturbed", ROOT / "config/schema/perturbed.schema.yaml")
        assert str(info.value).startswith("perturbed.cases.e9.blend_ref") and "\n" not in str(info.value)


def test_the_thrust_family_settings_are_read_and_each_bad_one_is_one_line():
    """perturbed.thrust_family (spaceopt.studies.thrust_family): E7's, with its defaults filled;
    none for a case that is not run; every bad value named by its key."""
    tf = TF.settings(PC)
    assert list(tf) == ["e7"] and tf["e7"]["thrusts_N"][-1] < tf["e7"]["thrusts_N"][0] < PC["cases"]["e7"]["thrust_N"]
    assert tf["e7"]["models"] == ["unperturbed", "j2", "g44_moon_sun"] and isinstance(tf["e7"]["max_steps"], int)
    assert TF.settings({**PC, "run": ["e9"]}) == {}
    assert tf["e7"]["carry_from"] == {"g44_moon_sun": "j2"}
    assert TF.settings({**PC, "thrust_family": {"e7": {"thrusts_N": [0.5]}}}) == {
        "e7": {"thrusts_N": [0.5], "eps": 1e-2, "models": ["unperturbed"], "max_steps": 2000, "carry_from": {},
               "hops": None}}
    for family, match in (({"e10": {"thrusts_N": [0.5]}}, r"thrust_family.e10='e10'.*not a case"),
                          ({"e7": [0.5]}, r"thrust_family.e7=\[0.5\].*mapping"),
                          ({"e7": {"thrusts_N": 0.5}}, r"thrust_family.e7.thrusts_N=0.5.*list"),
                          ({"e7": {"thrusts_N": [0.5, "x"]}}, r"thrust_family.e7.thrusts_N='x'.*finite number"),
                          ({"e7": {"thrusts_N": [1.0]}}, r"thrusts_N=\[1.0\].*strictly from below the case's thrust \(1 N\)"),
                          ({"e7": {"thrusts_N": [0.5, 0.6]}}, r"thrusts_N=\[0.5, 0.6\].*strictly"),
                          ({"e7": {"thrusts_N": [0.5, 0.0]}}, r"thrusts_N=.*to above 0"),
                          ({"e7": {"thrusts_N": [0.5], "eps": 1.5}}, r"thrust_family.e7.eps=1.5.*\(0, 1\)"),
                          ({"e7": {"thrusts_N": [0.5], "models": ["g44"]}}, r"thrust_family.e7.models='g44'"),
                          ({"e7": {"thrusts_N": [0.5], "max_steps": 0}}, r"thrust_family.e7.max_steps=0.*positive"),
                          ({"e7": {"thrusts_N": [0.5], "carry_from": ["j2"]}}, r"thrust_family.e7.carry_from=\['j2'\].*mapping"),
                          ({"e7": {"thrusts_N": [0.5], "models": ["j2"], "carry_from": {"g45": "j2"}}},
                           r"thrust_family.e7.carry_from='g45'.*the case's models"),
                          ({"e7": {"thrusts_N": [0.5], "models": ["j2"], "carry_from": {"g44_moon_sun": "unperturbed"}}},
                           r"thrust_family.e7.carry_from.g44_moon_sun='unperturbed'.*another of the family's models"),
                          ({"e7": {"thrusts_N": [0.5], "models": ["j2"], "carry_from": {"j2": "j2"}}},
                           r"thrust_family.e7.carry_from.j2='j2'"),
                          ({"e7": {"thrusts_N": [0.5], "hops": {"step_N": -0.1}}}, r"thrust_family.e7.hops.step_N=-0.1.*positive")):
        with pytest.raises(ConfigError, match=match) as exc:
            TF.settings({**PC, "thrust_family": family})
        assert "\n" not in str(exc.value)
