"""Workflow tests of the §4.1 part of the DAG: dry run of the full reproduction. The quick-profile
run of the whole DAG and its selective re-run checks are in test_quick_reproduction.py."""
import re
import subprocess
import sys
from pathlib import Path

import yaml

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
