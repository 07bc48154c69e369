"""Workflow tests of the §4.1 part of the DAG: dry run of the full reproduction, a quick-config
run, and selective re-runs (one thrust level changed -> only its dependents rerun)."""
import csv
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from spaceopt import artifacts

ROOT = Path(__file__).resolve().parents[1]
SNAKEMAKE = str(Path(sys.executable).with_name("snakemake"))


def smk(*args, timeout=1500):
    res = subprocess.run([SNAKEMAKE, *args], cwd=ROOT, capture_output=True, text=True, timeout=timeout)
    return res.returncode, res.stdout + res.stderr


def planned_rules(output: str) -> dict:
    """{rule: count} from the 'Job stats' table of a dry run."""
    stats = output.split("Job stats:")[-1]
    return {m.group(1): int(m.group(2)) for m in re.finditer(r"^(\w+)\s+(\d+)$", stats, re.M) if m.group(1) != "total"}


def test_full_reproduction_dry_run_plans_every_multirev_stage():
    rc, out = smk("-n", "--cores", "2", "--forceall", "results/multirev/anchors.csv")
    assert rc == 0, out[-2000:]
    jobs = planned_rules(out)
    cfg = yaml.safe_load((ROOT / "config/studies/multirev.yaml").read_text())["multirev"]
    n_tmin = sum(len(cfg["cases"][c]["tmin_isp_s"]) for c in cfg["run_cases"])
    assert jobs["multirev_lp"] == len(cfg["run_cases"])
    assert jobs["multirev_tmin"] == n_tmin
    assert jobs["multirev_ot"] >= len(cfg["table_4_1_3"]["thrust_N"])


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("quick")
    rc, log = smk("--cores", "2", f"{out}/results_q/multirev/anchors.csv", "--configfile", "config/quick.yaml",
                  "--config", f"results_dir={out}/results_q")
    assert rc == 0, log[-3000:]
    return out / "results_q" / "multirev"


def test_quick_run_writes_anchors_and_artifacts(quick_run):
    rows = list(csv.DictReader(open(quick_run / "anchors.csv")))
    cases = {r["case"] for r in rows}
    assert {"e1_lp", "e1_tmin", "e1_ot_15N"} <= cases
    assert {r["quantity"] for r in rows if r["case"] == "e1_tmin"} >= {"T_min_N", "tof_days", "m_f_kg", "K_f_deg"}
    data = artifacts.read_json(quick_run / "e1" / "ot_15N.json")
    prov = data["provenance"]
    assert len(prov["config_hash"]) == 64 and prov["code"]["commit"] and prov["packages"]["jax"]
    smp = artifacts.read_npz(quick_run / "e1" / "ot_15N.json")
    for key in ("t_s", "r_m", "v_m_s", "mass_kg", "thrust_N", "S"):
        assert np.all(np.isfinite(smp[key])), key
    assert (quick_run / "e1" / "ot_15N.rrd").stat().st_size > 1000
    ver = list(csv.DictReader(open(quick_run / "verification.csv")))
    assert ver and all(abs(float(v["final_mass_error_kg"])) < 1e-2 for v in ver)


def test_changing_one_thrust_level_reruns_only_its_dependents(quick_run, tmp_path):
    override = tmp_path / "override.yaml"
    override.write_text(yaml.safe_dump({"multirev": {"cases": {"e1": {"ot_thrust_N": [16.0]}},
                                                     "table_4_1_3": {"anchor_N": 16.0, "thrust_N": [16.0]}}}))
    rc, out = smk("-n", "--cores", "2", f"{quick_run}/anchors.csv", "--configfile", "config/quick.yaml", str(override),
                  "--config", f"results_dir={quick_run.parent}")
    assert rc == 0, out[-2000:]
    jobs = planned_rules(out)
    assert "multirev_lp" not in jobs and "multirev_tmin" not in jobs, jobs
    assert jobs.get("multirev_ot") == 1 and jobs.get("multirev_verify") == 1, jobs
