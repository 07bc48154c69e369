"""A temporary copy of the workflow skeleton with test-only studies, for the workflow tests.

The skeleton is the real ``Snakefile``, ``common.smk``, the global config and its schema; a
test adds its own rules and scripts (``texts``) and any further repository files it needs
(``files``, e.g. report.smk for the scoreboard). Snakemake then runs there with this
interpreter's environment, so the copied workflow behaves as the real one does.
"""
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SKELETON = ("Snakefile", "workflow/rules/common.smk", "workflow/scripts/_step.py", "config/config.yaml",
            "config/schema/config.schema.yaml")


def make_skeleton(tmp: Path, texts: dict[str, str], files=(), with_src: bool = False) -> Path:
    """Copy the skeleton and ``files`` into tmp/repo, write ``texts`` ({path: content}); return the root."""
    root = tmp / "repo"
    for d in ("workflow/rules", "workflow/scripts", "config/schema", "config/studies"):
        (root / d).mkdir(parents=True, exist_ok=True)
    for rel in (*SKELETON, *files):
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(ROOT / rel, root / rel)
    if with_src:
        shutil.copytree(ROOT / "src", root / "src", ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    for rel, text in texts.items():
        (root / rel).write_text(text)
    return root


def snakemake_env() -> dict:
    """This interpreter's bin first on PATH; no bytecode files written into the copy."""
    return dict(os.environ, PATH=f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}",
                PYTHONDONTWRITEBYTECODE="1")


def run_snakemake(root: Path, *args, timeout=120) -> subprocess.CompletedProcess:
    """``python -m snakemake ARGS`` in ``root``; the caller checks the return code."""
    return subprocess.run([sys.executable, "-m", "snakemake", *args], cwd=root, env=snakemake_env(),
                          capture_output=True, text=True, timeout=timeout)


def repo_snakemake(*args, timeout=1800) -> tuple[int, str]:
    """Snakemake in the repository itself: (return code, stdout + stderr)."""
    proc = run_snakemake(ROOT, *args, timeout=timeout)
    return proc.returncode, proc.stdout + proc.stderr


def planned_rules(text: str) -> dict:
    """{rule: count} from the 'Job stats' table of a (dry) run's output; {} when nothing is to be done."""
    m = re.search(r"Job stats:\s*\n\s*job\s+count\s*\n[-\s]+\n(.*?)\n\s*total\s+\d+", text, re.S)
    if not m:
        assert "Nothing to be done" in text, text[-3000:]
        return {}
    return {name: int(n) for name, n in re.findall(r"^\s*(\S+)\s+(\d+)\s*$", m.group(1), re.M)}


def planned_jobs(proc) -> dict:
    """planned_rules of a completed process."""
    return planned_rules(proc.stdout + proc.stderr)
