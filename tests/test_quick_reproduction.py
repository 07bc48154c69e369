"""The whole DAG end to end on the quick profile (config/quick.yaml), as CI runs it.

One ``snakemake --cores 2 --configfile config/quick.yaml`` into a temporary results directory
builds every landed study at small size, the reproduction scoreboard and the paper PDF; then
``snakemake --report`` builds the HTML report offline from the same run. The tests check:

- the paper PDF exists and its text holds the scoreboard's summary line of every study that
  wrote a reproduction table, plus the errata and performance sections;
- the HTML report is a self-contained file that embeds the registered figures;
- right after the run nothing is left to do (the DAG is complete and deterministic in its plan);
- the §4.1 artifacts carry provenance, dense samples and a rerun recording, and the verifier
  re-propagates them;
- a changed thrust level re-runs only its dependents;
- forced re-runs of a JAX solve (E1 LP) and of the Bellman study give bit-identical numbers.

All tests share one run (module fixture); ``./dev test`` distributes whole files to the
pytest-xdist workers (``--dist loadfile``), so the DAG runs once per test session. (xdist's
``loadgroup`` marks do not group tests under pytest 9.2: checked, they were split.)
"""
import csv
import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import yaml
from workflow_skeleton import planned_rules, repo_snakemake as smk

from spaceopt import artifacts

ROOT = Path(__file__).resolve().parents[1]


def quick_args(results: Path) -> list[str]:
    return ["--configfile", "config/quick.yaml", "--config", f"results_dir={results}"]


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    """The results directory of one complete quick-profile run (default target: everything)."""
    results = tmp_path_factory.mktemp("quick") / "results_q"
    rc, log = smk("--cores", "2", *quick_args(results))
    assert rc == 0, log[-4000:]
    return results


def study_names(results: Path) -> set[str]:
    names = set()
    for path in results.glob("*/reproduction*.csv"):
        names |= {r["study"] for r in csv.DictReader(open(path))}
    return names


def test_nothing_left_to_do_after_the_run(quick):
    rc, out = smk("-n", "--cores", "2", *quick_args(quick))
    assert rc == 0, out[-2000:]
    assert planned_rules(out) == {}


@pytest.mark.skipif(shutil.which("pdftotext") is None, reason="poppler-utils not installed (./dev setup)")
def test_paper_pdf_holds_the_scoreboard_of_every_study(quick):
    pdf = quick / "paper" / "paper.pdf"
    assert pdf.read_bytes()[:5] == b"%PDF-"
    text = subprocess.run(["pdftotext", "-layout", str(pdf), "-"], capture_output=True, text=True,
                          check=True).stdout
    studies = study_names(quick)
    # every study of the DAG writes its reproduction table, even on the quick profile
    assert {"multirev", "sweep", "perturbed", "discrete_geo_bellman",
            "discrete_libration_zonotope"} <= studies, studies
    summary = list(csv.DictReader(open(quick / "report" / "scoreboard_summary.csv")))
    assert {s["study"] for s in summary} == studies | {"all"}
    for s in summary:   # the summary line of each study, with its row count, is in the PDF
        name = s["study"].replace("_", r"[_\s]?")
        assert re.search(rf"{name}\s+{s['total']}\s", text), (s, text[:3000])
    assert "Quick profile" in text     # the title page says which profile built it
    for heading in ("Reproduction scoreboard", "Errata", "Performance"):
        assert re.search(heading, text, re.I), heading


def test_html_report_builds_offline_with_the_figures(quick):
    html = quick / "report.html"
    rc, out = smk("--cores", "1", "--report", str(html), *quick_args(quick), timeout=600)
    assert rc == 0, out[-3000:]
    text = html.read_text(errors="replace")
    assert len(text) > 100_000 and "<html" in text.lower()
    assert "scoreboard" in text.lower()
    assert "fig_4_2_3_1" in text or "multirev" in text      # a registered study figure


def test_multirev_artifacts_carry_provenance_samples_and_recording(quick):
    mr = quick / "multirev"
    rows = list(csv.DictReader(open(mr / "anchors.csv")))
    cases = {r["case"] for r in rows}
    assert {"e1_lp", "e1_tmin", "e1_ot_15N"} <= cases
    assert {r["quantity"] for r in rows if r["case"] == "e1_tmin"} >= {"T_min_N", "tof_days", "m_f_kg", "K_f_deg"}
    data = artifacts.read_json(mr / "e1" / "ot_15N.json")
    prov = data["provenance"]
    assert len(prov["config_hash"]) == 64 and prov["code"]["commit"] and prov["packages"]["jax"]
    smp = artifacts.read_npz(mr / "e1" / "ot_15N.json")
    for key in ("t_s", "r_m", "v_m_s", "mass_kg", "thrust_N", "S"):
        assert np.all(np.isfinite(smp[key])), key
    assert (mr / "e1" / "ot_15N.rrd").stat().st_size > 1000
    ver = list(csv.DictReader(open(mr / "verification.csv")))
    assert ver and all(abs(float(v["final_mass_error_kg"])) < 1e-2 for v in ver)


def test_perturbed_solves_are_re_propagated_with_their_force_model(quick):
    """The E9 J2 solve of the quick profile and the minimum-thrust solves of its existence check,
    re-propagated in Cartesian coordinates with their force model (63 rev)."""
    ver = list(csv.DictReader(open(quick / "perturbed" / "verification.csv")))
    assert [v["artifact"] for v in ver] == ["e9/j2.json", "e9/tmin_j2.json", "e9/tmin_unperturbed.json"]
    for v in ver:
        assert abs(float(v["final_a_error_km"])) < 0.01 and float(v["final_position_vs_solver_km"]) < 1.0, v
    assert "An independent verifier re-propagates each of the 3 perturbed" in (quick / "perturbed" / "paper_section.tex").read_text()


def test_the_existence_check_finds_that_j2_makes_the_leo_transfer_possible(quick):
    """The minimum thrust of E9 (63 revolutions, 1 N) from the zero guess: without J2 the plane
    change must be thrust (T_min above 1 N: no transfer), with J2 the node's precession makes it
    and T_min falls by two orders of magnitude (spaceopt.studies.existence); a sentence in the
    paper, and the T_min artifact records its verdict."""
    rows = {r["model"]: r for r in csv.DictReader(open(quick / "perturbed" / "existence.csv"))}
    assert list(rows) == ["unperturbed", "j2"]
    unp, j2 = (float(rows[m]["T_min_N"]) for m in ("unperturbed", "j2"))
    assert unp > 1.0 and rows["unperturbed"]["exists"] == "False"
    assert float(rows["unperturbed"]["n_rev_needed"]) == pytest.approx(63.007 * unp / 1.0)
    assert j2 < unp / 50 and rows["j2"]["exists"] == "True" and rows["j2"]["lp_perturbed"] == "True"
    art = artifacts.read_json(quick / "perturbed" / "e9" / "tmin_j2.json")
    assert art["thrust_N"] == pytest.approx(j2) and art["extra"]["verdict"]["exists"] is True
    assert art["scalars"]["burn_fraction"] == pytest.approx(1.0)       # the engine never switches off at T_min
    text = (quick / "perturbed" / "paper_section.tex").read_text()
    assert "Does the transfer exist with the perturbations on?" in text
    assert "the thrust is below $T_{min}$ for unperturbed (no transfer over this angular range" in text
    assert "above it for $J_2$" in text


def test_the_perturbed_solve_is_split_by_force(quick):
    """The force shares of the E9 J2 solve (spaceopt.studies.force_shares): J2's precession makes
    the plane change (its share of Δh near 1, spec §6), ΔE too small for shares; one row per
    revolution of L (63.007: 64 rows); a sentence in the paper."""
    rows = list(csv.DictReader(open(quick / "perturbed" / "force_shares.csv")))
    assert [r["artifact"] for r in rows] == ["e9/j2.json"]
    assert 0.95 < float(rows[0]["h_share_j2"]) < 1.05 and rows[0]["E_share_j2"] == ""
    assert float(rows[0]["closure_h"]) < 1e-6
    revs = list(csv.DictReader(open(quick / "perturbed" / "force_shares_by_revolution.csv")))
    assert len(revs) == 64 and sum(float(r["h_share_j2"]) for r in revs) == pytest.approx(float(rows[0]["h_share_j2"]))
    assert "What each force contributes" in (quick / "perturbed" / "paper_section.tex").read_text()


def test_the_perturbed_solve_ends_on_a_certified_maximum_of_the_final_mass(quick):
    """The free-time end game of the E9 J2 solve: a local maximum of m_f in t_f (probes 0.001 d
    apart, the case's setting), recorded in its artifact, tof_maximum.csv and the paper."""
    rows = list(csv.DictReader(open(quick / "perturbed" / "tof_maximum.csv")))
    assert [(r["solve"], r["status"]) for r in rows] == [("e9_j2", "maximum")]
    rec = artifacts.read_json(quick / "perturbed" / "e9" / "j2.json")["extra"]["tof_maximum"]
    assert rec["certified"] and rec["probe_days"] == 0.001 and rec["free_time_residual"] < 1e-7
    assert "Of 1 perturbed solves, 1 are certified maxima" in (quick / "perturbed" / "paper_section.tex").read_text()


def test_changing_one_thrust_level_reruns_only_its_dependents(quick, tmp_path):
    override = tmp_path / "override.yaml"
    override.write_text(yaml.safe_dump({"multirev": {"cases": {"e1": {"ot_thrust_N": [16.0]}},
                                                     "table_4_1_3": {"anchor_N": 16.0, "thrust_N": [16.0]}}}))
    rc, out = smk("-n", "--cores", "2", f"{quick}/multirev/anchors.csv", "--configfile", "config/quick.yaml",
                  str(override), "--config", f"results_dir={quick}")
    assert rc == 0, out[-2000:]
    jobs = planned_rules(out)
    assert "multirev_lp" not in jobs and "multirev_tmin" not in jobs, jobs
    assert jobs.get("multirev_ot") == 1 and jobs.get("multirev_verify") == 1, jobs


def _numbers(json_path: Path) -> str:
    """An artifact's numbers as canonical JSON text (NaN included): everything except the
    provenance, wall/compile times and the hash of the rerun recording (rerun chunk ids are random)."""
    data = json.loads(json_path.read_text())
    data.pop("provenance", None)
    data.get("files", {}).pop("recording", None)
    for block in data.values():
        if isinstance(block, dict):
            for key in [k for k in block if k.endswith(("wall_time_s", "compile_time_s"))]:
                block.pop(key)
    return json.dumps(data, sort_keys=True)


def test_forced_reruns_give_bit_identical_numbers(quick):
    """Run the E1 LP solve and the D3 Bellman study again: the same JSON numbers, and every
    rewritten table, array and figure (CSV, NPZ, PNG, PDF) byte for byte the same."""
    lp, bellman = quick / "multirev" / "e1" / "lp.json", quick / "discrete" / "bellman.json"
    numbers = {p: _numbers(p) for p in (lp, bellman)}
    files = {p: (p.read_bytes(), p.stat().st_atime_ns, p.stat().st_mtime_ns) for p in quick.rglob("*") if p.is_file()}
    rc, out = smk("--cores", "2", "--forcerun", "multirev_lp", "bellman", *quick_args(quick), "--",
                  str(lp), str(bellman))
    assert rc == 0, out[-3000:]
    assert {p: _numbers(p) for p in (lp, bellman)} == numbers
    rewritten = [p for p, (_, _, mtime) in files.items() if p.stat().st_mtime_ns != mtime]
    compared = [p for p in rewritten if p.suffix in (".csv", ".npz", ".png", ".pdf")]
    assert len(compared) >= 4, rewritten
    assert [p for p in compared if p.read_bytes() != files[p][0]] == []
    for p in rewritten:   # same numbers and bytes: give the outputs their old times back, so that
        os.utime(p, ns=files[p][1:])   # the DAG stays complete for the other tests of this module
