"""The §4.1 section of the paper, generated from the tables and figures."""
import csv
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt.studies import multirev_report as mr  # noqa: E402


def _rows(path):
    with open(path) as fh:
        return list(csv.DictReader(fh))


def main(sm):
    figures = sorted(p.stem for p in Path(sm.input.figures).glob("*.pdf"))
    text = mr.paper_section(_rows(sm.input.repro), _rows(sm.input.verify), _rows(sm.input.anchors),
                            _rows(sm.input.t413), figures)
    Path(sm.output[0]).write_text(text)


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
