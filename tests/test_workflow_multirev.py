"""Workflow tests of the §4.1 part of the DAG: dry run of the full reproduction. The quick-profile
run of the whole DAG and its selective re-run checks are in test_quick_reproduction.py."""
from pathlib import Path

import yaml
from workflow_skeleton import planned_rules, repo_snakemake as smk

ROOT = Path(__file__).resolve().parents[1]


def test_full_reproduction_dry_run_plans_every_multirev_stage():
    rc, out = smk("-n", "--cores", "2", "--forceall", "results/multirev/anchors.csv")
    assert rc == 0, out[-2000:]
    jobs = planned_rules(out)
    cfg = yaml.safe_load((ROOT / "config/studies/multirev.yaml").read_text())["multirev"]
    n_tmin = sum(len(cfg["cases"][c]["tmin_isp_s"]) for c in cfg["run_cases"])
    assert jobs["multirev_lp"] == len(cfg["run_cases"])
    assert jobs["multirev_tmin"] == n_tmin
    assert jobs["multirev_ot"] >= len(cfg["table_4_1_3"]["thrust_N"])
