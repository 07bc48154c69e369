"""Render config/errata.yaml as the paper's errata fragment (LaTeX).

Usage: python workflow/scripts/paper_errata.py --errata config/errata.yaml --out errata.tex [--md errata.md]
"""
import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt.report.paper import errata_markdown, errata_tex, load_errata  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--errata", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--md")
    a = ap.parse_args(argv)
    entries = load_errata(a.errata)
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(errata_tex(entries))
    if a.md:
        Path(a.md).write_text(errata_markdown(entries))


if __name__ == "__main__":
    run_step(main)
