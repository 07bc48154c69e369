"""results/perturbed/force_shares.csv: the force shares of every perturbed solve, one row each."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.report.tables import write_csv  # noqa: E402
from spaceopt.studies.force_shares import share_columns, share_row  # noqa: E402


def main(sm):
    rows = [share_row(artifacts.read_json(p)) for p in sm.input.shares]
    write_csv(sm.output[0], rows, share_columns(rows))


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
