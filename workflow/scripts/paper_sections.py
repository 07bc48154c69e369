"""Write results/paper/sections.tex: one section per study that the workflow produces.

A study's own fragment (results/<study>/paper_section.tex) is \\input; a study without one gets
an automatic section from its reproduction tables, LaTeX tables and figures.

Usage: python workflow/scripts/paper_sections.py --out sections.tex --results RESULTS
           [--order a,b*,...] [--no-auto] [--fragment F ...] [--repro R ...] [--table T ...]
           [--figure G ...]
"""
import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt.report.paper import sections_tex  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--results", required=True, help="the results directory (config results_dir)")
    ap.add_argument("--order", default="", help="comma-separated study names or fnmatch patterns")
    ap.add_argument("--no-auto", action="store_true", help="no automatic sections")
    for name in ("fragment", "repro", "table", "figure"):
        ap.add_argument(f"--{name}", nargs="*", default=[])
    a = ap.parse_args(argv)
    order = [s for s in a.order.split(",") if s]
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(sections_tex(a.results, a.fragment, a.repro, a.table, a.figure, order,
                                        auto_sections=not a.no_auto))


if __name__ == "__main__":
    run_step(main)
