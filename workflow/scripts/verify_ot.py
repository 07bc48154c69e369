"""Independent Cartesian re-propagation of one OT artifact, §4.1 or §4.2 (scipy DOP853; spaceopt.studies.verify)."""
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.studies.verify import resampled, verify_ot  # noqa: E402


def main(sm):
    t0 = time.perf_counter()
    n = getattr(sm.params, "samples_per_rev", None)        # re-sampled first (E6), else as saved
    if n:
        with tempfile.TemporaryDirectory() as tmp:
            res = {**verify_ot(resampled(sm.input.json, tmp, int(n))), "samples_per_rev": int(n)}
    else:
        res = verify_ot(sm.input.json)
    artifacts.write_json(sm.output[0], {"verification": res, "artifact": "/".join(Path(sm.input.json).parts[-2:]),
                                        "provenance": artifacts.provenance({}, time.perf_counter() - t0)})


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
