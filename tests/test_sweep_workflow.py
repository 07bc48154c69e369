"""The E3 sweep rules (workflow/rules/sweep.smk) build their DAG, full and quick profile.

Dry runs in a temporary copy holding only common.smk and sweep.smk (the other studies' rules are
not needed): the config validates against config/schema/sweep.schema.yaml, every row job exists,
rows scaled along n wait for the rows they are scaled from, and the quick profile
(the sweep section of config/quick.yaml) shrinks the sweep to two rows.
"""
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytest.importorskip("snakemake")

SNAKEFILE = """from pathlib import Path
configfile: "config/config.yaml"
for _c in sorted(Path("config/studies").glob("*.yaml")):
    configfile: str(_c)
include: "workflow/rules/common.smk"
include: "workflow/rules/sweep.smk"
rule all:
    default_target: True
    input: ALL_TARGETS
"""


@pytest.fixture()
def skeleton(tmp_path):
    for d in ("config", "workflow"):
        shutil.copytree(ROOT / d, tmp_path / d, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(ROOT / "src", tmp_path / "src", ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    (tmp_path / "Snakefile").write_text(SNAKEFILE)
    return tmp_path


def _dry(cwd, *extra):
    exe = Path(sys.executable).parent / "snakemake"
    cmd = [str(exe) if exe.exists() else "snakemake", "-n", "--cores", "2", *extra]
    proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return proc.stdout + proc.stderr


def _count(out, rule):
    m = re.search(rf"^{rule}\s+(\d+)$", out, re.M)
    return int(m.group(1)) if m else 0


def test_full_sweep_dag(skeleton):
    out = _dry(skeleton)
    assert _count(out, "sweep_row") == 6
    assert _count(out, "sweep_nstar") == 1 and _count(out, "sweep_tables") == 1
    # row 300 is scaled from rows 50 and 100: it lists them as inputs; row 2 starts cold
    blocks = {re.search(r"output: (\S+)", b).group(1): b for b in out.split("rule sweep_row:")[1:]}
    inp = re.search(r"input: (.*)", blocks["results/multirev/sweep/row_300.json"]).group(1)
    assert "row_50.json" in inp and "row_100.json" in inp
    inp2 = re.search(r"input: (.*)", blocks["results/multirev/sweep/row_2.json"]).group(1)
    assert "row_" not in inp2


def test_quick_profile(skeleton):
    out = _dry(skeleton, "--configfile", "config/quick.yaml")
    assert _count(out, "sweep_row") == 2
    assert "results_quick/multirev/sweep/row_4.json" in out


def test_bad_row_source_is_refused(skeleton):
    cfg = skeleton / "config/studies/sweep.yaml"
    cfg.write_text(cfg.read_text().replace("{n_rev: 300, start: [50, 100]", "{n_rev: 300, start: [50, 400]"))
    exe = Path(sys.executable).parent / "snakemake"
    proc = subprocess.run([str(exe) if exe.exists() else "snakemake", "-n", "--cores", "1"],
                          cwd=skeleton, capture_output=True, text=True)
    assert proc.returncode != 0
    assert "sweep.rows" in proc.stdout + proc.stderr
