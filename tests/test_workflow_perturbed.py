"""Workflow tests of the §4.2 part of the DAG (dry run of the full reproduction): how the E6 dates
and the E8 revolution counts are warm-started, read from the plan Snakemake prints."""
import re
from pathlib import Path

import yaml
from spaceopt.studies import perturbed_config as C
from workflow_skeleton import planned_rules, repo_snakemake as smk

ROOT = Path(__file__).resolve().parents[1]
PT = yaml.safe_load((ROOT / "config/studies/perturbed.yaml").read_text())["perturbed"]


def planned_inputs(text: str, rule: str) -> dict:
    """{first output: [inputs]} of every planned job of ``rule`` in a dry run's output."""
    out = {}
    for block in re.split(r"\n(?=\[.*\]\nrule |rule )", text):
        if not re.match(rf"(\[.*\]\n)?rule {rule}:", block):
            continue
        inputs = re.search(r"^\s*input: (.*)$", block, re.M).group(1).split(", ")
        output = re.search(r"^\s*output: ([^,\n]*)", block, re.M).group(1)
        out[output] = inputs
    return out


def test_full_reproduction_plans_e6_dates_from_the_unperturbed_solve_and_e8_counts_by_count_start():
    """E6: every date from the unperturbed E5 OT, but the dates of ``start_from`` from their named
    neighbour; E8: each revolution count of the first model from the zero guess (count_start:
    chain) or from the next smaller one (previous), every later model from the previous model
    at the same count, or the one model_from names for that count. E6 families: a link job per ordered pair of neighbouring dates, from the
    first date's solve to the second's, but none where the scan started the one from the other; a
    walk job per link, with the scan's solves at its date and the dates past it."""
    rc, out = smk("-n", "--forceall", "--cores", "2", "results/perturbed/e6_date_scan.csv",
                  "results/perturbed/e8.csv", "results/perturbed/e6_families.csv", "results/perturbed/e6_envelope.csv")
    assert rc == 0, out[-2000:]
    jobs = planned_rules(out)
    assert {"e6", "e8"} <= set(PT["run"])
    e6 = planned_inputs(out, "perturbed_e6_date")
    assert len(e6) == jobs["perturbed_e6_date"] == 31
    assert PT["e6"]["warm_start"] == "unperturbed"
    start_from = PT["e6"].get("start_from", {})
    assert start_from, "the test expects some dates to start from a neighbour (perturbed.e6.start_from)"
    for output, inputs in e6.items():
        date = output.split("/")[-1][:10]
        if date in start_from:                       # from the named converged date only
            assert f"results/perturbed/e6/{start_from[date]}.json" in inputs
            assert "results/perturbed/e5/unperturbed.json" not in inputs
        else:                                        # independent jobs, all from one solve
            assert "results/perturbed/e5/unperturbed.json" in inputs
            assert not any(i.startswith("results/perturbed/e6/") for i in inputs)
    links = planned_inputs(out, "perturbed_e6_link")
    assert len(links) == jobs["perturbed_e6_link"] == len(C.link_pairs(PT)) == 2 * 30 - len(C.start_pairs(PT))
    for output, inputs in links.items():
        a, b = Path(output).stem.split("_to_")
        assert inputs[:2] == [f"results/perturbed/e6/{a}.json", f"results/perturbed/e6/{b}.json"]
        assert start_from.get(b) != a                # b's solve is that link
    walks = planned_inputs(out, "perturbed_e6_walk")      # one per link: it ends at once unless the link is 'other'
    assert len(walks) == len(links)
    for output, inputs in walks.items():
        a, b = Path(output).stem.split("_to_")
        ahead = C.walk_dates(PT, a, b)
        assert inputs[:2 + len(ahead)] == [f"results/perturbed/e6_links/{a}_to_{b}.json"] + [
            f"results/perturbed/e6/{d}.json" for d in [b] + ahead]
        assert all((d > b) == (b > a) for d in ahead)     # on past b, away from a
    e8 = planned_inputs(out, "perturbed_e8")
    ns = sorted(PT["e8"]["run_n_rev"])
    models = PT["cases"]["e8"]["models"]
    run_models = PT["e8"].get("run_models", models)
    skip = {m: {float(n) for n in ns_} for m, ns_ in (PT["e8"].get("skip_n_rev") or {}).items()}
    needed = models[:max(models.index(m) for m in run_models) + 1]     # with their start models
    last = needed[-1]                                # skipped counts of the last model are not planned
    assert len(e8) == len(ns) * len(needed) - len(skip.get(last, ()))
    for n in skip.get(last, ()):
        assert f"results/perturbed/e8/{last}_n{n:g}.json" not in e8
    for m in run_models:
        if m == models[0] and C.e8_count_start(PT) == "chain":
            for n in ns:                             # independent chains from the zero guess
                inputs = e8[f"results/perturbed/e8/{m}_n{n:g}.json"]
                assert not any(i.startswith("results/perturbed/e8/") for i in inputs)
        elif m == models[0]:
            for lo, hi in zip(ns, ns[1:]):           # each count from the next smaller one
                assert f"results/perturbed/e8/{m}_n{lo:g}.json" in e8[f"results/perturbed/e8/{m}_n{hi:g}.json"]
        else:                                        # from its start model at the same count (model_from)
            for n in (n for n in ns if n not in skip.get(m, ())):
                inputs = e8[f"results/perturbed/e8/{m}_n{n:g}.json"]
                assert f"results/perturbed/e8/{C.case_start_model(PT, 'e8', m, n)}_n{n:g}.json" in inputs
                assert not any(i.startswith(f"results/perturbed/e8/{m}_") for i in inputs)


def test_the_full_plan_evaluates_every_input_function_without_an_error():
    """No rule is tried on another rule's output: the E5/E7/E9 solve rule once matched
    ``<model>.verify.json`` (the re-propagation's output), its input function raised and Snakemake
    printed an "Error" block per model at the start of every full run (harmless, but alarming)."""
    rc, out = smk("-n", "--forceall", "--cores", "2")
    assert rc == 0, out[-2000:]
    assert "InputFunctionException" not in out, out[out.find("InputFunctionException") - 200:][:1500]


def test_paper_command_of_the_full_profile_passes_its_empty_profile_note():
    """The full profile has no report.paper.profile_note: the paper rule must still hand
    paper_build.py a value (``--note=``), not a bare ``--note`` that argparse rejects."""
    rc, out = smk("-n", "-p", "--forcerun", "paper", "--cores", "1", "results/paper/paper.pdf")
    assert rc == 0, out[-2000:]
    cmd = next(line for line in out.splitlines() if "paper_build.py" in line and "--tex" in line)
    assert "--note=" in cmd and "--note " not in cmd + " "


def test_a_date_listed_in_skip_dates_by_an_overlay_config_is_left_out_of_the_plan(tmp_path):
    """The remedy docs/perturbed-guide.md §5 gives for an E6 date that does not converge: name
    it in ``perturbed.e6.skip_dates`` of a file passed with --configfile. Snakemake merges that
    nested key into the study config (the rest of ``perturbed.e6`` stays), and the tables no longer
    wait for the date."""
    overlay = tmp_path / "skip.yaml"
    overlay.write_text('perturbed:\n  e6:\n    skip_dates: ["2021-05-20"]\n')
    rc, out = smk("-n", "--forceall", "--cores", "2", "results/perturbed/e6_date_scan.csv",
                  "--configfile", str(overlay))             # after the target: it takes several files
    assert rc == 0, out[-2000:]
    e6 = planned_inputs(out, "perturbed_e6_date")
    assert len(e6) == 30
    assert not any("2021-05-20" in output for output in e6)
    assert any("2021-05-18" in output for output in e6)          # start_from kept by the merge
    bad = tmp_path / "bad.yaml"
    bad.write_text('perturbed:\n  e6:\n    skip_dates: ["2021-05-17"]\n')
    rc, out = smk("-n", "--cores", "1", "results/perturbed/e6_date_scan.csv", "--configfile", str(bad))
    assert rc != 0 and "error: perturbed.e6.skip_dates" in out and "Traceback" not in out, out[-2000:]


def test_the_force_shares_are_planned_for_every_perturbed_solve_of_the_listed_cases():
    """perturbed.force_shares: one re-propagation per solve with perturbations (no unperturbed
    model, no case left out of the list), each from that solve's artifact, and the table on all."""
    rc, out = smk("-n", "--forceall", "--cores", "2", "results/perturbed/force_shares.csv")
    assert rc == 0, out[-2000:]
    shares = planned_inputs(out, "perturbed_force_shares")
    cases = PT["force_shares"]["cases"]
    assert {"e5", "e6", "e8"} <= set(cases)
    expected = {f"results/perturbed/e6/{d}.shares.json" for d in C.scan_run_dates(PT)}
    expected |= {f"results/perturbed/e8/{m}_n{n:g}.shares.json" for m, n in C.e8_runs(PT) if PT["models"][m]}
    assert "results/perturbed/e8/g44_moon_sun_n500.shares.json" in expected
    for c in set(cases) - {"e6", "e8"}:
        expected |= {f"results/perturbed/{c}/{m}.shares.json" for m in PT["cases"][c]["models"] if PT["models"][m]}
    assert set(shares) == expected and "results/perturbed/e5/unperturbed.shares.json" not in shares
    for output, inputs in shares.items():
        assert inputs[0] == output.replace(".shares.json", ".json")
    table = planned_inputs(out, "perturbed_force_shares_table")
    assert set(table["results/perturbed/force_shares.csv"]) >= expected


def test_the_heavier_extremals_of_the_envelope_are_saved_verified_and_split_by_force_in_one_job():
    """perturbed_e6_envelope_extremals reads the envelope, every link and walk (their z) and the
    scan's solves (the problems), and feeds the figures and the paper."""
    rc, out = smk("-n", "--forceall", "--cores", "2", "results/perturbed/paper_section.tex")
    assert rc == 0, out[-2000:]
    job = planned_inputs(out, "perturbed_e6_envelope_extremals")["results/perturbed/e6_envelope_extremals.csv"]
    assert "results/perturbed/e6_envelope.csv" in job
    assert sum(i.startswith("results/perturbed/e6_links/") for i in job) == len(C.link_pairs(PT))
    assert sum(i.startswith("results/perturbed/e6_walks/") for i in job) == len(C.link_pairs(PT))
    assert sum(i.startswith("results/perturbed/e6/") for i in job) == len(C.scan_run_dates(PT))
    for rule in ("perturbed_figures", "perturbed_paper_section"):
        assert any("results/perturbed/e6_envelope_extremals.csv" in inputs for inputs in planned_inputs(out, rule).values())


def test_the_report_pass_leaves_out_the_failed_solves_and_those_that_start_from_them(tmp_path, monkeypatch):
    """SPACEOPT_REPORT_FAILED=1 (the second pass of ./dev reproduce): an E6 date, an E8 solve and
    a minimum-thrust solve whose artifact is missing and whose failure.json is there are not
    planned again, nor the solves that start from them (E6: start_from; E8: the later models at
    that count), and the tables and paper are planned without them. Without the variable they
    are planned as usual."""
    for stem in ("e6/2021-05-17", "e8/j2_n450", "e9/tmin_g44", "e7/tmin_j2", "e7/family_g44_moon_sun_from_j2"):
        path = tmp_path / "perturbed" / f"{stem}.failure.json"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text('{"error": "no convergence (test)"}')
    args = ("-n", "--forceall", "--cores", "2", f"{tmp_path}/perturbed/paper_section.tex",
            "--config", f"results_dir={tmp_path}")
    rc, out = smk(*args)
    assert rc == 0, out[-2000:]
    assert f"{tmp_path}/perturbed/e6/2021-05-18.json" in planned_inputs(out, "perturbed_e6_date")
    assert f"{tmp_path}/perturbed/e8/g44_n450.json" in planned_inputs(out, "perturbed_e8")
    assert f"{tmp_path}/perturbed/e9/tmin_g44.json" in planned_inputs(out, "perturbed_existence")
    assert planned_rules(out)["perturbed_thrust_family_carried"] == 1
    monkeypatch.setenv("SPACEOPT_REPORT_FAILED", "1")
    rc, out = smk(*args)
    assert rc == 0, out[-2000:]
    dates = {Path(o).stem for o in planned_inputs(out, "perturbed_e6_date")}
    left = {"2021-05-17", "2021-05-18", "2021-05-19"}            # 05-18 starts from 05-17, 05-19 from 05-18
    assert dates == set(C.scan_run_dates(PT)) - left
    e8 = {Path(o).stem for o in planned_inputs(out, "perturbed_e8")}
    assert "unperturbed_n450" in e8 and "j2_n400" in e8 and not {"j2_n450", "g44_n450"} & e8
    assert planned_rules(out)["perturbed_paper_section"] == 1
    tables = next(iter(planned_inputs(out, "perturbed_tables").values()))
    assert not any(f"/e6/{d}.json" in i for d in left for i in tables)
    assert not any(i.endswith(("/e8/j2_n450.json", "/e8/g44_n450.json")) for i in tables)
    existence = {Path(o).stem for o in planned_inputs(out, "perturbed_existence")}     # the minimum-thrust check
    assert "tmin_g44_moon_sun" in existence and "tmin_g44" not in existence
    planned = planned_inputs(out, "perturbed_existence")                 # E7's full model carries J2's bound over
    assert f"{tmp_path}/perturbed/e9/tmin_g44_moon_sun.json" in planned
    assert not {f"{tmp_path}/perturbed/e7/tmin_{m}.json" for m in ("j2", "g44_moon_sun")} & set(planned)
    assert not any(i.endswith("/e9/tmin_g44.json") for i in planned_inputs(out, "perturbed_existence_table")[
        f"{tmp_path}/perturbed/existence.csv"])
    assert "perturbed_thrust_family_carried" not in planned_rules(out)        # the carried family (E7 full model)
    family = planned_inputs(out, "perturbed_thrust_family_table")[f"{tmp_path}/perturbed/thrust_family.csv"]
    assert f"{tmp_path}/perturbed/e7/family_g44_moon_sun.json" in family
    assert not any("_from_" in i for i in family)


def test_the_e7_existence_check_starts_from_the_e7_ot_solves():
    """existence.from_ot (E7: the (3.4.1) path from the LP folds): each E7 minimum-thrust job
    reads the E7 OT artifact of its model, but the full model's, which carries the J2 bound over
    (existence.bound_from), and its table row is planned; E5 and E9 keep the route from the zero
    guess (no OT input)."""
    rc, out = smk("-n", "--forceall", "--cores", "2", "results/perturbed/existence.csv")
    assert rc == 0, out[-2000:]
    jobs = planned_inputs(out, "perturbed_existence")
    for model in ("unperturbed", "j2"):
        assert f"results/perturbed/e7/{model}.json" in jobs[f"results/perturbed/e7/tmin_{model}.json"]
    full = jobs["results/perturbed/e7/tmin_g44_moon_sun.json"]                 # existence.bound_from
    assert "results/perturbed/e7/tmin_j2.json" in full and "results/perturbed/e7/g44_moon_sun.json" not in full
    assert not any(i.startswith("results/perturbed/e9/") and not i.endswith("_window.json")
                   for i in jobs["results/perturbed/e9/tmin_j2.json"]), jobs["results/perturbed/e9/tmin_j2.json"]
    table = planned_inputs(out, "perturbed_existence_table")["results/perturbed/existence.csv"]
    assert "results/perturbed/e7/tmin_unperturbed.json" in table


def test_the_e7_full_models_family_is_also_carried_from_the_j2_familys_point():
    """thrust_family.carry_from {g44_moon_sun: j2}: besides its own family from its OT, the full
    model gets one that starts from the J2 family's artifact (not an OT), with the ephemeris; the
    table and the paper take both."""
    rc, out = smk("-n", "--forceall", "--cores", "2", "results/perturbed/paper_section.tex")
    assert rc == 0, out[-2000:]
    carried = planned_inputs(out, "perturbed_thrust_family_carried")["results/perturbed/e7/family_g44_moon_sun_from_j2.json"]
    assert "results/perturbed/e7/family_j2.json" in carried and "results/ephemeris/may2021_e7.json" in carried
    assert not any(i.endswith("/e7/g44_moon_sun.json") for i in carried)
    own = planned_inputs(out, "perturbed_thrust_family")
    assert "results/perturbed/e7/g44_moon_sun.json" in own["results/perturbed/e7/family_g44_moon_sun.json"]
    table = planned_inputs(out, "perturbed_thrust_family_table")["results/perturbed/thrust_family.csv"]
    assert {f"results/perturbed/e7/family_{s}.json" for s in ("j2", "g44_moon_sun", "g44_moon_sun_from_j2")} <= set(table)
    paper = planned_inputs(out, "perturbed_paper_section")["results/perturbed/paper_section.tex"]
    assert "results/perturbed/e7/family_g44_moon_sun_from_j2.json" in paper
    assert "results/perturbed/e7/family_g44_moon_sun_from_j2.verify.json" in planned_inputs(out, "perturbed_tables")[
        "results/perturbed/e5.csv"]


def test_e8_s_full_model_starts_from_j2_or_by_the_smoothed_profile_from_4x4_and_a_bad_model_from_is_one_line(tmp_path):
    """The study config's E8 names model_from: {g44_moon_sun: j2}: the full model's E8 jobs take
    the J2 artifact at their count, 4×4's still J2's; config/e8_smoothed.yaml takes the full model
    from 4×4 but at 450 (from J2); a model_from naming a later model stops the plan with a
    one-line error naming the key."""
    for profile, start in (((), lambda n: "j2"),
                           (("--configfile", str(ROOT / "config/e8_smoothed.yaml")), lambda n: "j2" if n == "450" else "g44")):
        rc, out = smk("-n", "--forceall", "--cores", "2", "results/perturbed/e8.csv", *profile)
        assert rc == 0, out[-2000:]
        e8 = planned_inputs(out, "perturbed_e8")
        full = {o: i for o, i in e8.items() if "/g44_moon_sun_n" in o}
        assert len(full) == len(PT["e8"]["run_n_rev"])
        for output, inputs in full.items():
            n = output.split("_n")[-1].rsplit(".", 1)[0]
            starts = {i.split("/")[-1].rsplit("_n", 1)[0] for i in inputs if i.startswith("results/perturbed/e8/")}
            assert starts == {start(n)}, (profile, output, inputs)
    bad = tmp_path / "bad.yaml"
    bad.write_text("perturbed:\n  cases:\n    e8:\n      model_from: {j2: g44_moon_sun}\n")
    rc, out = smk("-n", "--cores", "1", "results/perturbed/e8.csv", "--configfile", str(bad))
    assert rc != 0 and "error: perturbed.cases.e8.model_from.j2" in out and "Traceback" not in out, out[-2000:]
