"""Scale-out profiles (docs/scale-out.md): workflow/profiles/default and workflow/profiles/slurm.

The structural checks run everywhere. The dry run with the SLURM profile needs the executor
plugin, an optional dependency: pip install -e .[slurm].
"""
import importlib.util
import re
from pathlib import Path

import pytest
import yaml
from workflow_skeleton import make_skeleton, run_snakemake

ROOT = Path(__file__).resolve().parents[1]
PROFILES = ROOT / "workflow" / "profiles"
SLURM = yaml.safe_load((PROFILES / "slurm" / "config.yaml").read_text())
DEFAULT = yaml.safe_load((PROFILES / "default" / "config.yaml").read_text())
HEAVY = re.compile(r"^(multirev|perturbed)_")

RULES = '''
rule multirev_lp:
    output: f"{RESULTS}/toy/lp.txt"
    shell: "echo lp > {output}"


rule multirev_ot:
    input: f"{RESULTS}/toy/lp.txt"
    output: f"{RESULTS}/toy/ot.txt"
    shell: "echo ot > {output}"


rule geo_burns:
    output: f"{RESULTS}/toy/geo.txt"
    shell: "echo geo > {output}"


ALL_TARGETS += [f"{RESULTS}/toy/ot.txt", f"{RESULTS}/toy/geo.txt"]
'''


def workflow_rules() -> set[str]:
    names = set()
    for smk in (ROOT / "workflow" / "rules").glob("*.smk"):
        names |= set(re.findall(r"^(?:rule|checkpoint)\s+(\w+)\s*:", smk.read_text(), re.M))
    return names


def test_default_profile_settings():
    assert DEFAULT["cores"] == 2
    assert DEFAULT["rerun-incomplete"] is True and DEFAULT["printshellcmds"] is True


def test_slurm_profile_structure():
    assert SLURM["executor"] == "slurm"
    assert SLURM["rerun-incomplete"] is True
    defaults = SLURM["default-resources"]
    assert {"mem_mb", "runtime", "cpus_per_task"} <= set(defaults)
    for rule, res in SLURM["set-resources"].items():
        assert set(res) <= {"mem_mb", "runtime", "cpus_per_task", "slurm_partition", "slurm_extra",
                            "constraint", "tasks", "nodes"}, rule
        for key in ("mem_mb", "runtime", "cpus_per_task"):
            if key in res:
                assert isinstance(res[key], int) and res[key] > 0, (rule, key)


def test_solver_rules_are_heavier_than_discrete_rules():
    sr = SLURM["set-resources"]
    heavy = [r for r in sr if HEAVY.match(r) and r.endswith(("_lp", "_tmin", "_ot"))]
    light = [r for r in ("geo_burns", "libration_lp", "orbit_correction") if r in sr]
    assert heavy and light
    assert min(sr[r]["mem_mb"] for r in heavy) > max(sr[r]["mem_mb"] for r in light)
    assert min(sr[r]["runtime"] for r in heavy) > max(sr[r]["runtime"] for r in light)


def test_every_heavy_rule_of_the_workflow_has_resources():
    missing = sorted(r for r in workflow_rules() if HEAVY.match(r) and r not in SLURM["set-resources"])
    assert not missing, (f"add set-resources for {missing} to workflow/profiles/slurm/config.yaml "
                         "(see docs/scale-out.md)")


def _toy_workflow(tmp: Path) -> Path:
    return make_skeleton(tmp, {"workflow/rules/toy.smk": RULES})


def test_default_profile_dry_run(tmp_path):
    root = _toy_workflow(tmp_path)
    proc = run_snakemake(root, "--profile", str(PROFILES / "default"), "-n")
    assert proc.returncode == 0, proc.stderr
    assert re.search(r"multirev_ot\s+1", proc.stdout + proc.stderr)


@pytest.mark.skipif(importlib.util.find_spec("snakemake_executor_plugin_slurm") is None,
                    reason="install the 'slurm' extra: pip install -e .[slurm]")
def test_slurm_profile_dry_run(tmp_path):
    root = _toy_workflow(tmp_path)
    proc = run_snakemake(root, "--profile", str(PROFILES / "slurm"), "-n")
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out
    assert re.search(r"multirev_ot\s+1", out)
    # the per-rule resources reach the jobs
    ot = out[out.index("rule multirev_ot:"):]
    assert re.search(r"mem_mb=16000", ot[:2000]), ot[:2000]
