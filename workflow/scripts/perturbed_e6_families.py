"""results/perturbed/e6_families.csv: every E6 family link, and the pairs linked by construction
(a date the scan started from its neighbour), beside the scan's values."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.report.tables import write_csv  # noqa: E402
from spaceopt.studies import scan_families as F  # noqa: E402


def main(sm):
    links = {}
    for path in sm.input.links:
        rec = artifacts.read_json(path)["link"]
        links[(rec["from_date"], rec["to_date"])] = rec
    scan = F.scan_values(sm.params.dates, sm.input.dates)
    rows = F.family_rows(links, [tuple(p) for p in sm.params.starts], scan)
    write_csv(sm.output[0], rows, F.COLUMNS)


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
