"""What each force contributes to the change of h and E along one perturbed solve (spaceopt.studies.force_shares)."""
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.studies.force_shares import shares_payload  # noqa: E402


def main(sm):
    t0 = time.perf_counter()
    payload = shares_payload(sm.input.json, "/".join(Path(sm.input.json).parts[-2:]))
    artifacts.write_json(sm.output[0], {**payload, "provenance": artifacts.provenance({}, time.perf_counter() - t0)})


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
