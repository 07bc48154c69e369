"""The E6 family walks and the envelope (spaceopt.studies.scan_walks): which dates a walk may
reach, when it stops, how it resumes, and the heaviest distinct extremal per date. The steps
themselves are links (continue_to), tested for real in test_scan_families; here they are
scripted so that every stopping rule is exercised."""
import copy
from pathlib import Path

import numpy as np
import pytest
import yaml

from spaceopt.indirect.chain import Solution
from spaceopt.studies import perturbed_config as C, scan_walks as W

ROOT = Path(__file__).resolve().parents[1]
PT = yaml.safe_load((ROOT / "config/studies/perturbed.yaml").read_text())["perturbed"]
SETTINGS = {"directions": "both", "max_steps": 40, "mass_tol_kg": 1e-5, "tof_tol_days": 1e-3}


def _pc(max_days=31, **e6):
    pc = copy.deepcopy(PT)
    pc["e6"].update({"first_date": "2021-05-01", "last_date": "2021-05-06", "start_from": {},
                     "skip_dates": [], "links": SETTINGS, "walks": {"max_days": max_days}, **e6})
    return pc


def test_a_walk_goes_on_past_its_link_away_from_where_it_came_and_at_most_max_days():
    pc = _pc()
    assert C.walk_dates(pc, "2021-05-02", "2021-05-03") == ["2021-05-04", "2021-05-05", "2021-05-06"]
    assert C.walk_dates(pc, "2021-05-04", "2021-05-03") == ["2021-05-02", "2021-05-01"]
    assert C.walk_dates(pc, "2021-05-02", "2021-05-01") == []
    assert C.walk_dates(_pc(max_days=2), "2021-05-01", "2021-05-02") == ["2021-05-03", "2021-05-04"]
    skipped = _pc(skip_dates=["2021-05-04"])
    assert C.walk_dates(skipped, "2021-05-02", "2021-05-03") == ["2021-05-05", "2021-05-06"]
    assert C.walk_settings(_pc(links=None)) is None and C.walk_settings(_pc()) == {"max_days": 31}


def _sol(date, z):
    return Solution("ot", None, np.asarray(z, float), {}, date, {})


class ScriptedLinks:
    """continue_to with scripted outcomes per date; records from which extremal each step starts."""

    def __init__(self, outcomes):
        self.outcomes, self.starts = outcomes, []

    def __call__(self, start, tr_to, scan, pc, case, label, settings):
        self.starts.append((start.transfer, float(start.z[0])))
        status, m = self.outcomes[tr_to]
        rec = {"status": status, "m_f_kg": m, "tof_days": 60.0, "scan_m_f_kg": scan["m_f_kg"],
               "scan_tof_days": scan["tof_days"], "z": [m, 0.0]}
        return rec, (_sol(tr_to, rec["z"]) if status != "failed" else None)


def test_a_walk_follows_an_other_family_until_it_meets_the_scans_extremal_and_resumes_after_its_last_step(
        monkeypatch):
    dates = ["d2", "d3", "d4", "d5"]
    problems = {d: _sol(d, [0.0, 0.0]) for d in ["d1"] + dates}
    scans = {d: {"m_f_kg": 950.0, "tof_days": 59.0} for d in dates}
    links = ScriptedLinks({"d2": ("other", 961.0), "d3": ("other", 960.0), "d4": ("same", 950.0), "d5": ("other", 1.0)})
    monkeypatch.setattr(W, "continue_to", links)
    recorded = []
    steps = W.walk(_sol("d1", [962.0, 0.0]), dates, problems, scans, {}, "e5", "walk", SETTINGS,
                   record=lambda s: recorded.append(len(s)))
    assert [(s["date"], s["status"]) for s in steps] == [("d2", "other"), ("d3", "other"), ("d4", "same")]
    assert recorded == [1, 2, 3]
    assert links.starts == [("d1", 962.0), ("d2", 961.0), ("d3", 960.0)]     # each step from the last extremal
    # interrupted after two steps: the walk goes on from the second step's extremal at its date
    links.starts.clear()
    resumed = W.walk(None, dates, problems, scans, {}, "e5", "walk", SETTINGS, done=steps[:2])
    assert resumed == steps and links.starts == [("d3", 960.0)]
    # a finished walk is not walked again; a failed step ends it
    assert W.walk(None, dates, problems, scans, {}, "e5", "walk", SETTINGS, done=steps) == steps
    links.outcomes["d3"] = ("failed", None)
    assert [s["status"] for s in W.walk(_sol("d1", [962.0, 0.0]), dates, problems, scans, {}, "e5", "walk",
                                        SETTINGS)] == ["other", "failed"]
    with pytest.raises(ValueError, match="3 unknowns for a problem with 2"):
        W.extremal_at(problems["d2"], [1.0, 2.0, 3.0])


def _step(a, b, date, status, m, t=60.0):
    return {"from_date": a, "link_to": b, "date": date, "status": status, "m_f_kg": m, "tof_days": t}


def test_the_envelope_keeps_the_distinct_extremals_of_a_date_and_the_heaviest():
    dates = ["2021-05-01", "2021-05-02", "2021-05-03", "2021-05-04"]
    scan = {"2021-05-01": (960.0, 60.0), "2021-05-02": (957.0, 65.0), "2021-05-03": (956.0, 59.0), "2021-05-04": (958.0, 55.0)}
    links = [{"from_date": "2021-05-01", "to_date": "2021-05-02", "status": "other", "m_f_kg": 959.5, "tof_days": 61.0},
             {"from_date": "2021-05-02", "to_date": "2021-05-01", "status": "same", "m_f_kg": 960.0, "tof_days": 60.0},
             {"from_date": "2021-05-04", "to_date": "2021-05-03", "status": "other", "m_f_kg": 955.0, "tof_days": 57.0}]
    steps = [_step("2021-05-01", "2021-05-02", "2021-05-03", "other", 958.2, 62.0),
             _step("2021-05-01", "2021-05-02", "2021-05-04", "same", 958.0, 55.0),
             _step("2021-05-04", "2021-05-03", "2021-05-02", "other", 957.0 + 5e-6, 65.0002),         # the scan's extremal again
             {**_step("2021-05-04", "2021-05-03", "2021-05-01", "failed", None, None), "reason": "the path turned back and ran below tau = -1"}]
    env = {r["date"]: r for r in W.envelope_rows(dates, scan, links, steps, SETTINGS)}
    assert [env[d]["extremals"] for d in dates] == [1, 2, 3, 1]
    assert env["2021-05-02"]["family_of"] == "2021-05-01" and env["2021-05-02"]["m_f_kg"] == 959.5 and env["2021-05-02"]["gain_kg"] == pytest.approx(2.5)
    assert env["2021-05-03"]["family_of"] == "2021-05-01" and env["2021-05-03"]["tof_days"] == 62.0
    assert env["2021-05-01"]["family_of"] == "2021-05-01" and env["2021-05-01"]["gain_kg"] == 0.0
    assert env["2021-05-02"]["arrival_utc"] == "2021-07-02T12:00"          # departure 12:00 + 61 d
    assert W.arrival("2021-05-10", "12:00:00", 64.1158) == "2021-07-13T14:46"
    real = W.envelope_rows(["2021-05-09"], {"2021-05-09": (957.5, 65.0)}, [], [], SETTINGS, "06:00:00")
    assert real[0]["arrival_utc"] == "2021-07-13T06:00"
    rows = W.step_rows([{"from_date": "2021-05-01", "to_date": "2021-05-02", "steps": [{"date": "2021-05-03", "status": "other", "m_f_kg": 1.0}]},
                        {"from_date": "2021-05-02", "to_date": "2021-05-01", "steps": []}])
    assert rows == [{**{k: None for k in W.STEP_COLUMNS}, "from_date": "2021-05-01", "link_to": "2021-05-02", "date": "2021-05-03",
                     "status": "other", "m_f_kg": 1.0}]
    text = W.envelope_sentence(steps, list(env.values()), 1e-5)
    assert "(2 walks, 4 steps: 2 other, 1 same, 1 failed): the family of 2021-05-01 (through 2021-05-02) meets the scan's " \
           "extremal at 2021-05-04; the family of 2021-05-04 (through 2021-05-03) turns back between 2021-05-02 and 2021-05-01." in text
    assert W.walk_ends([_step("a", "b", "c", "other", 1.0), {**_step("a", "b", "d", "failed", None), "reason": "x"},
                        _step("e", "f", "g", "not certified", 1.0)]) == [
        "the family of a (through b) stops between c and d (x)", "the family of e (through f) has no certified maximum at g"]
    assert W.walk_ends([_step("a", "b", "c", "other", 1.0)]) == ["the family of a (through b) is followed to c, where the walk ends"]
    assert "At 2 of 4 dates an extremal found is heavier than the scan's own (up to +2.5000 kg at 2021-05-02, on the family of 2021-05-01)" in text
    assert "up to 3 distinct local maxima" in text and "from 958.0000 to 960.0000 kg" in text
    flat = W.envelope_rows(dates, scan, [], [], SETTINGS)
    assert "No link met another extremal" in W.envelope_sentence([], flat, 1e-5)
    assert "At no date is an extremal found heavier" in W.envelope_sentence([], flat, 1e-5)


def _walk_script():
    import importlib.util
    import sys
    sys.path.insert(0, str(ROOT / "workflow" / "scripts"))
    spec = importlib.util.spec_from_file_location("perturbed_e6_walk", ROOT / "workflow/scripts/perturbed_e6_walk.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _job(tmp_path, status):
    from types import SimpleNamespace
    from spaceopt import artifacts
    link = tmp_path / "link.json"
    artifacts.write_json(link, {"link": {"status": status, "z": [961.0, 0.0]}})
    scans = []
    for d in ("d2", "d3", "d4"):
        scans.append(tmp_path / f"{d}.json")
        artifacts.write_json(scans[-1], {"scalars": {"m_f_kg": 950.0, "tof_days": 59.0}})
    out = tmp_path / "walks" / "d1_to_d2.json"
    return SimpleNamespace(params=SimpleNamespace(cfg={"links": SETTINGS, "walks": {"max_days": 31}}, case="e5",
                                                  dates=["d2", "d3", "d4"]),
                           wildcards=SimpleNamespace(a="d1", b="d2"),
                           input=SimpleNamespace(link=str(link), scan=[str(p) for p in scans]), output=[str(out)]), out


def test_the_walk_job_resumes_from_its_recorded_steps_and_removes_them_when_done(tmp_path, monkeypatch):
    """An interrupted walk job (a step raised) keeps its finished steps in the resume file; the
    rerun walks on from them, writes the record and removes the file. A resume file of another
    link extremal or config is not used. A link that is not 'other' gives an empty walk."""
    from spaceopt import artifacts
    script = _walk_script()
    monkeypatch.setattr(script.P, "load", lambda path: _sol(Path(path).stem, [0.0, 0.0]))
    links = ScriptedLinks({"d3": ("other", 960.0), "d4": ("same", 950.0)})
    monkeypatch.setattr(W, "continue_to", links)
    sm, out = _job(tmp_path, "other")

    def crash_after_first(start, tr_to, *args):
        if tr_to == "d4":
            raise KeyboardInterrupt
        return links(start, tr_to, *args)
    monkeypatch.setattr(W, "continue_to", crash_after_first)
    with pytest.raises(KeyboardInterrupt):
        script.main(sm)
    resume = script.resume_file(out)
    assert [s["date"] for s in artifacts.read_json(resume)["steps"]] == ["d3"] and not out.exists()
    monkeypatch.setattr(W, "continue_to", links)
    links.starts.clear()
    script.main(sm)
    assert links.starts == [("d3", 960.0)]                       # on from the recorded step, not from d2
    walk = artifacts.read_json(out)["walk"]
    assert [(s["date"], s["status"]) for s in walk["steps"]] == [("d3", "other"), ("d4", "same")]
    assert not resume.exists()
    artifacts.write_json(resume, {"key": {"config": "another", "z": [961.0, 0.0]}, "steps": walk["steps"][:1]})
    assert script.done_steps(resume, {"config": "this", "z": [961.0, 0.0]}) == []
    sm_flat, out_flat = _job(tmp_path / "flat", "same")
    script.main(sm_flat)
    assert artifacts.read_json(out_flat)["walk"]["steps"] == []


def test_the_heavier_extremals_of_the_envelope_get_their_unknowns_from_the_link_or_step_that_found_them():
    """scan_walks.heavier_extremals: each envelope date whose heaviest extremal is another family's
    (gain above the tolerance), with the z of the link or walk step of that date and m_f."""
    envelope = [{"date": "2021-05-02", "m_f_kg": 959.5, "gain_kg": 2.5, "family_of": "2021-05-01"},
                {"date": "2021-05-03", "m_f_kg": 958.2, "gain_kg": 2.2, "family_of": "2021-05-01"},
                {"date": "2021-05-04", "m_f_kg": 958.0, "gain_kg": 0.0, "family_of": "2021-05-04"},
                {"date": "2021-05-05", "m_f_kg": 957.0, "gain_kg": 5e-6, "family_of": "2021-05-06"}]
    links = [{"to_date": "2021-05-02", "m_f_kg": 959.5, "z": [1.0]}, {"to_date": "2021-05-03", "m_f_kg": 958.0, "z": [9.0]},
             {"to_date": "2021-05-07", "status": "failed", "m_f_kg": None}]
    steps = [{"date": "2021-05-03", "m_f_kg": 958.2, "z": [2.0]}, {"date": "2021-05-04", "status": "failed"}]
    found = W.heavier_extremals(envelope, links, steps, 1e-5)
    assert [(row["date"], z) for row, z in found] == [("2021-05-02", [1.0]), ("2021-05-03", [2.0])]
    with pytest.raises(ValueError, match="no link or walk step holds the extremal of 2021-05-03"):
        W.heavier_extremals(envelope, links, steps[1:], 1e-5)


def test_the_heavier_extremals_sentence_gives_their_verification_and_their_lunar_share():
    rows = [{"final_position_vs_solver_km": 894.0, "final_mass_error_kg": -7.1e-3, "h_share_moon": 0.47,
             "moon_closest_km": 76736.0},
            {"final_position_vs_solver_km": 0.26, "final_mass_error_kg": 1e-4, "h_share_moon": 0.634,
             "moon_closest_km": 66831.0}]
    text = W.heavier_sentence(rows)
    assert text.startswith("The 2 heavier extremals of other families")
    assert "to within 894 km of the solver's end point and 0.0071 kg of its final mass" in text
    assert "they take 47 to 63 % of the change of angular momentum from the Moon and pass it at 66,831 to 76,736 km." in text
    assert W.heavier_sentence([]) == ""
    no_moon = W.heavier_sentence([{k: v for k, v in rows[0].items() if "moon" not in k}])
    assert "Moon" not in no_moon and no_moon.endswith("final mass.")
