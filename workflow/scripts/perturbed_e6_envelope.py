"""results/perturbed/e6_walks.csv (every step of every E6 family walk) and e6_envelope.csv (at
each date, the distinct extremals found and the heaviest; spaceopt.studies.scan_walks)."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.report.tables import read_csv, write_csv  # noqa: E402
from spaceopt.studies import scan_families as F, scan_walks as W  # noqa: E402


def main(sm):
    walks = [artifacts.read_json(p)["walk"] for p in sm.input.walks]
    steps = W.step_rows(walks)
    scan = F.scan_values(sm.params.dates, sm.input.dates)
    links = read_csv(sm.input.families[0])
    write_csv(sm.output.steps, steps, W.STEP_COLUMNS)
    write_csv(sm.output.envelope, W.envelope_rows(sm.params.dates, scan, links, steps, sm.params.links,
                                                  sm.params.time_utc), W.ENVELOPE_COLUMNS)


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
