# Shared helpers of the rules files. Each study's rules file appends its final targets to
# ALL_TARGETS and validates its own config section against config/schema/<study>.schema.yaml.
import glob as _glob
import sys as _sys_common

from spaceopt.config import validate_section as _validate_section
from spaceopt.errors import SpaceoptError as _SpaceoptError

ALL_TARGETS = []
RESULTS = config.get("results_dir", "results")
PY = _sys_common.executable   # the interpreter running Snakemake (the venv), not whatever "python" is on PATH


def lib_sources(*packages):
    """Library source files a rule depends on: a solver change reruns the solves."""
    files = []
    for pkg in packages:
        p = f"src/spaceopt/{pkg}"
        files += sorted(_glob.glob(f"{p}/*.py")) if Path(p).is_dir() else [f"{p}.py"]
    return files


def check_section(name, physical=None):
    """Schema validation (snakemake.utils.validate) + physical checks, one-line error on failure."""
    try:
        _validate_section(config, name, Path(workflow.basedir) / "config" / "schema" / f"{name}.schema.yaml")
        if physical is not None:
            physical(config[name])
    except _SpaceoptError as exc:
        print(f"error: {exc}", file=_sys_common.stderr)
        _sys_common.exit(1)
