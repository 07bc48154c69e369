"""The E6 scan's extremal families (spaceopt.studies.scan_families): which link jobs the config
plans, how links join dates into families, the paper sentence, and one real link between two
departure epochs of a small perturbed problem."""
import copy
import dataclasses
from pathlib import Path

import pytest
import yaml

from spaceopt.indirect.continuation import ContinuationOptions
from spaceopt.studies import perturbed_config as C, scan_families as F

ROOT = Path(__file__).resolve().parents[1]
PT = yaml.safe_load((ROOT / "config/studies/perturbed.yaml").read_text())["perturbed"]
SETTINGS = {"directions": "both", "max_steps": 40, "mass_tol_kg": 1e-5, "tof_tol_days": 1e-3}


def _pc(**e6):
    pc = copy.deepcopy(PT)
    pc["e6"].update({"first_date": "2021-05-01", "last_date": "2021-05-05", "start_from": {},
                     "skip_dates": [], "links": SETTINGS, **e6})
    return pc


def test_links_join_neighbouring_run_dates_both_ways_except_where_the_scan_started_one_from_the_other():
    pc = _pc(start_from={"2021-05-03": "2021-05-02"}, skip_dates=["2021-05-05"])
    assert C.start_pairs(pc) == [("2021-05-02", "2021-05-03")]
    pairs = C.link_pairs(pc)
    assert ("2021-05-02", "2021-05-03") not in pairs and ("2021-05-03", "2021-05-02") in pairs
    assert ("2021-05-01", "2021-05-02") in pairs and ("2021-05-02", "2021-05-01") in pairs
    assert not any("2021-05-05" in p for p in pairs) and len(pairs) == 5
    forward = C.link_pairs(_pc(links={**SETTINGS, "directions": "forward"}))
    assert forward == [(f"2021-05-0{i}", f"2021-05-0{i + 1}") for i in range(1, 5)]
    assert C.link_pairs(_pc(links=None)) == []


def _row(a, b, status, m=None, t=None, scan_m=960.0, scan_t=60.0):
    return {"from_date": a, "to_date": b, "status": status, "m_f_kg": m, "tof_days": t,
            "scan_m_f_kg": scan_m, "scan_tof_days": scan_t}


def test_families_are_runs_of_dates_joined_by_a_same_or_start_link_either_way():
    dates = ["d1", "d2", "d3", "d4", "d5"]
    rows = [_row("d1", "d2", "same", 960.0, 60.0), _row("d2", "d1", "other", 959.0, 61.0),
            {**_row("d3", "d2", "failed"), "tau_max": 0.61, "reason": "the path turned back and ran below tau = -1"}, _row("d2", "d3", "other", 960.002, 62.0),   # joined in neither direction
            _row("d4", "d3", "start"), _row("d4", "d5", "not certified"),
            {**_row("d5", "d4", "failed"), "tau_max": 0.25, "reason": "step size underflow"}]
    assert F.segments(dates, rows) == [["d1", "d2"], ["d3", "d4"], ["d5"]]
    heavier = F.heavier_elsewhere(rows, 1e-5)
    assert [(r["from_date"], r["to_date"]) for r in heavier] == [("d2", "d3")]
    text = F.families_sentence(dates, rows, 1e-5)
    assert "form 3 families: d1 to d2; d3 to d4; d5" in text
    assert "(6 links: 1 same, 2 other, 1 not certified, 2 failed; 1 pair linked by construction" in text
    assert "At d3 (from d2: +0.0020 kg, +2.000 d) a neighbour's family is heavier" in text
    assert "the family of d3 turns back 0.610 of the way to d2, the path from d5 stops 0.250 of the way to d4." in text
    lighter = [r for r in rows if r["to_date"] != "d3"]
    assert "No neighbour's family" in F.families_sentence(dates, lighter, 1e-5)
    assert F.families_sentence(dates, [], 1e-5) == ""


def test_same_extremal_needs_both_the_mass_and_the_time_to_agree():
    assert F.same_extremal(960.0, 60.0, 960.0 + 5e-6, 60.0005, SETTINGS)
    assert not F.same_extremal(960.0, 60.0, 960.0 + 2e-5, 60.0, SETTINGS)
    assert not F.same_extremal(960.0, 60.0, 960.0, 60.002, SETTINGS)


@pytest.fixture(scope="module")
def two_epochs(e1_g22_era):
    """E1 OT 15 N (2 revolutions) with EGM96 2×2 on the Earth rotation angle, solved from the
    unperturbed extremal at two departure epochs 6 h apart (the geopotential turns by 90°); the
    first is conftest's."""
    from spaceopt.studies import multirev, perturbed as P

    quiet = ContinuationOptions(verbose=False)
    noon, ot = e1_g22_era
    assert noon.transfer.epoch_utc == "2021-05-09T12:00:00"
    pc = {"numerics": {"tof_maximum": {"probe_days": 0.01}}, "cases": {"e1": {}}}
    out = {}
    for epoch in ("2021-05-09T12:00:00", "2021-05-09T18:00:00"):
        start = noon if epoch == noon.transfer.epoch_utc else P.perturb_from_unperturbed(
            ot, dataclasses.replace(noon.transfer, epoch_utc=epoch), epoch, options=quiet)
        sol, _ = P.maximise_in_tof(start, pc, "e1", epoch)
        out[epoch] = (sol, multirev.scalars(sol, multirev.sample(sol, F.SAMPLES_PER_REV)))
    return pc, out


def test_a_link_continued_in_the_epoch_lands_on_the_extremal_solved_at_the_new_date(two_epochs):
    pc, sols = two_epochs
    (a, (sol_a, _)), (b, (sol_b, scan_b)) = sols.items()
    rec, sol = F.continue_to(sol_a, sol_b.transfer, scan_b, pc, "e1", "e1 link", SETTINGS)
    assert rec["status"] == "same", rec
    assert list(sol.z) == rec["z"] and sol.transfer.epoch_utc == b and rec["wall_time_s"] > 0
    assert abs(rec["dm_f_g"]) < 1e-2 and rec["tof_maximum"]["certified"] and rec["jacobian_evaluations"] > 0
    assert not F.same_extremal(rec["m_f_kg"], rec["tof_days"], scan_b["m_f_kg"] - 0.05, scan_b["tof_days"], SETTINGS)


def test_a_transfer_that_arrives_after_its_ephemeris_window_is_refused_up_front(e1_g22_era, tmp_path, monkeypatch):
    """Switching the Moon on over a window that ends before the transfer does (an E6 date moved
    past its window), from the unperturbed extremal, from a perturbed one, or in the chain from
    the zero guess after its LP: one ConfigError naming the arrival and the window, before any
    path step (the ephemeris is NaN outside its window, and the path would fail at its first
    point after minutes of zero-length integration steps at the window's end, saying only
    "integration failed at the starting point")."""
    from spaceopt import ephemeris
    from spaceopt.errors import ConfigError
    from spaceopt.studies import perturbed as P

    noon, ot = e1_g22_era
    path = tmp_path / "short.json"                # granules to 10 May 00:00 TDB; E1 arrives on 11 May
    ephemeris.save_window(ephemeris.extract_window("2021-05-09", "2021-05-09T13:00:00", "short"), path, {})
    with_moon = dataclasses.replace(noon.transfer, perturbations={"geopotential": "j2", "third_bodies": ["moon"]},
                                    ephemeris=str(path))
    with pytest.raises(ConfigError, match=r"arrival of the transfer switched on \(ephemeris window short\)="
                                          r"'2021-05-11T.*outside ephemeris window 'short'"):
        P.perturb_from_unperturbed(ot, with_moon, "short", options=ContinuationOptions(verbose=False))
    # the same from the perturbed extremal (2×2): every warm start of one perturbed problem from
    # another (a new date, force model or revolution count) checks it first too
    with pytest.raises(ConfigError, match=r"arrival of the warm start \(ephemeris window short\)="
                                          r"'2021-05-11T.*outside ephemeris window 'short'"):
        P.warm_start(noon, with_moon, "short", options=ContinuationOptions(verbose=False))
    # and the chain from the zero guess (E5's route), after its LP, before the perturbations go on
    with pytest.raises(ConfigError, match=r"arrival of the minimum-power solution \(ephemeris window short\)="
                                          r"'2021-05-1[12]T.*outside ephemeris window 'short'"):
        P.solve_for(dataclasses.replace(with_moon, thrust=15.0), "short", route="lp-tmin-ot",
                    options=ContinuationOptions(verbose=False))
    # Without the check, the path fails at its first point, in a few hundred integration steps:
    # the steps shrink to zero at the window's end, where flow.StepCap stops the propagation
    # (before it, the zero-length steps ran to the cap: 400 001 steps, minutes)
    from spaceopt.errors import ConvergenceError
    from spaceopt.indirect import chain
    monkeypatch.setattr(chain, "check_arrival_in_window", lambda *args, **kwargs: None)
    with pytest.raises(ConvergenceError, match="integration failed at the starting point") as failed:
        P.perturb_from_unperturbed(ot, with_moon, "short", options=ContinuationOptions(verbose=False))
    assert failed.value.diagnosis["integration_steps_total"] < 1000


def test_a_continuation_that_does_not_reach_the_new_date_is_a_result_not_an_error(monkeypatch):
    """A fold of a's family in the epoch (or a stall) gives the link status 'failed' with the
    error and the path's cost; the job still writes its record."""
    from spaceopt.errors import ConvergenceError
    from spaceopt.studies import perturbed as P          # continue_to imports it when called

    def fold(*args, **kwargs):
        raise ConvergenceError("e6 link: the arclength path turned back at tau 0.61",
                               {"jacobian_evaluations": 17, "wall_time_s": 42.0, "tau_max": 0.61})
    monkeypatch.setattr(P, "warm_start", fold)
    rec, sol = F.continue_to(None, None, {"m_f_kg": 960.0, "tof_days": 60.0}, {}, "e5", "link", SETTINGS)
    assert rec["status"] == "failed" and "tau 0.61" in rec["error"]
    assert rec["jacobian_evaluations"] == 17 and rec["scan_m_f_kg"] == 960.0 and "m_f_kg" not in rec
    assert rec["tau_max"] == 0.61 and sol is None
