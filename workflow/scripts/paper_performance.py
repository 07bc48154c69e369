"""Render the benchmark results (results/benchmarks/*.json) as the paper's performance table.

Usage: python workflow/scripts/paper_performance.py --tex OUT.tex --md OUT.md BENCH.json ...
"""
import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt.report.paper import performance_markdown, performance_tex  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tex", required=True)
    ap.add_argument("--md", required=True)
    ap.add_argument("benchmarks", nargs="*")
    a = ap.parse_args(argv)
    for p in (a.tex, a.md):
        Path(p).parent.mkdir(parents=True, exist_ok=True)
    Path(a.tex).write_text(performance_tex(a.benchmarks))
    Path(a.md).write_text(performance_markdown(a.benchmarks))


if __name__ == "__main__":
    run_step(main)
