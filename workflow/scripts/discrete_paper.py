"""The paper section of the discrete studies (D1-D4) from their reproduction tables and figures.

Usage: python workflow/scripts/discrete_paper.py --out paper_section.tex --repro R.csv ...
           --figure F.png|F.pdf ...
"""
import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt.report.scoreboard import gather  # noqa: E402
from spaceopt.studies.discrete_report import paper_section  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--repro", nargs="+", required=True)
    ap.add_argument("--figure", nargs="*", default=[])
    a = ap.parse_args(argv)
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(paper_section(gather(a.repro), a.figure))


if __name__ == "__main__":
    run_step(main)
