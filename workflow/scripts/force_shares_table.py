"""results/perturbed/force_shares.csv (the force shares of every perturbed solve, one row each)
and force_shares_by_revolution.csv (each force's share of Δh gathered in each revolution)."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.report.tables import write_csv  # noqa: E402
from spaceopt.studies.force_shares import revolution_columns, revolution_rows, share_columns, share_row  # noqa: E402


def main(sm):
    payloads = [artifacts.read_json(p) for p in sm.input.shares]
    rows = [share_row(p) for p in payloads]
    write_csv(sm.output.table, rows, share_columns(rows))
    revs = [r for p in payloads for r in revolution_rows(p)]
    write_csv(sm.output.by_revolution, revs, revolution_columns(revs))


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
