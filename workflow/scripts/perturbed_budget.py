"""E9 ΔΩ budget check (spec 02-multirev §6): natural J2 drift against the required ΔΩ and ω_f."""
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.studies import perturbed as P  # noqa: E402


def main(sm):
    t0 = time.perf_counter()
    cfg = sm.params.cfg
    tr = P.transfer_from_config(cfg, "e9", sm.params.model)
    budget = P.raan_budget(tr, sm.params.days)
    budget["numeric_coast"] = P.raan_budget_numeric(tr, sm.params.days, tr.epoch_utc, tr.perturbations)
    artifacts.write_json(sm.output[0], {"budget": budget,
                                        "provenance": artifacts.provenance(cfg, time.perf_counter() - t0)})


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
