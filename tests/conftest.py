import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("MPLBACKEND", "Agg")
sys.path.insert(0, str(ROOT / "workflow" / "scripts"))

# The quick-profile DAG (test_quick_reproduction's module fixture, ~8 min on 2 cores) is by far
# the longest file. `./dev test` hands whole files to the two xdist workers in collection order
# (--dist loadfile --no-loadscope-reorder), so it goes first: started late, as xdist's default
# order by test count had it (17th of 38), it left one worker running it alone at the end.
LONGEST_FIRST = ("test_quick_reproduction.py",)


def pytest_collection_modifyitems(items):
    items.sort(key=lambda item: item.path.name not in LONGEST_FIRST)
