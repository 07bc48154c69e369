# Shared helpers of the rules files. Each study's rules file appends its final targets to
# ALL_TARGETS and validates its own config section against config/schema/<study>.schema.yaml.
import glob as _glob

ALL_TARGETS = []
RESULTS = config.get("results_dir", "results")
PY = "python"


def lib_sources(*packages):
    """Library source files a rule depends on: a solver change reruns the solves."""
    files = []
    for pkg in packages:
        p = f"src/spaceopt/{pkg}"
        files += sorted(_glob.glob(f"{p}/*.py")) if Path(p).is_dir() else [f"{p}.py"]
    return files
