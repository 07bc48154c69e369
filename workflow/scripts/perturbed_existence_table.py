"""results/perturbed/existence.csv: the minimum thrust of each §4.2 case under each force model."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.report.tables import write_csv  # noqa: E402
from spaceopt.studies import existence as E  # noqa: E402


def main(sm):
    rows = [E.row(Path(p).parent.name, Path(p).stem.removeprefix("tmin_"), artifacts.read_json(p))
            for p in sm.input.tmin]
    write_csv(sm.output[0], rows, E.COLUMNS)


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
