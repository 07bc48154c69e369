"""Figs. 4.1.6-4.1.7 analogues from the sweep rows: results/multirev/sweep_figures/*.png (+ .pdf)."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.studies import sweep_figures  # noqa: E402


def main(sm):
    rows = [artifacts.read_json(p)["cells"] for p in sm.input.rows]
    sweep_figures.make_all(rows, Path(sm.output[0]), sm.params.table_L0, sm.params.style)


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
