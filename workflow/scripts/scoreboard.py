"""Gather every study's reproduction table into the scoreboard (CSV, Markdown, LaTeX).

Usage: python workflow/scripts/scoreboard.py --csv OUT.csv --md OUT.md --tex OUT.tex
           [--summary SUMMARY.csv] TABLE.csv ...
"""
import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt.report.scoreboard import build  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--csv", required=True)
    ap.add_argument("--md", required=True)
    ap.add_argument("--tex", required=True)
    ap.add_argument("--summary")
    ap.add_argument("tables", nargs="*")
    a = ap.parse_args(argv)
    summary = build(a.tables, a.csv, a.md, a.tex, a.summary)
    total = summary[-1]
    print(f"scoreboard: {len(a.tables)} tables, {total['total']} values: {total['pass']} pass, "
          f"{total['fail']} fail, {total['missing']} missing, {total['info']} info", file=sys.stderr)


if __name__ == "__main__":
    run_step(main)
