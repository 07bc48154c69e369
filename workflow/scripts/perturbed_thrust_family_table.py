"""results/perturbed/thrust_family.csv and one figure per case: the minimum-fuel families followed
down in the thrust (spaceopt.studies.thrust_family), every point of every listed model's family and
of every carried one."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.report.tables import write_csv  # noqa: E402
from spaceopt.studies import perturbed_figures as F, thrust_family as TF  # noqa: E402


def main(sm):
    rows = [r for p in sm.input.family for r in TF.rows(Path(p).parent.name, artifacts.read_json(p))]
    write_csv(sm.output.table, rows, TF.COLUMNS)
    for case in dict.fromkeys(r["case"] for r in rows):
        F.thrust_family([r for r in rows if r["case"] == case],
                        Path(sm.output.table).parent / "figures" / f"fig_{case}_thrust_family",
                        title=f"{case.upper()}: the minimum-fuel family followed down in the thrust")


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
