"""T_min at the revolution counts bracketing n* = n1 T_min1 / T* (spec 02-multirev §9)."""
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.studies import sweep  # noqa: E402


def main(sm, log):
    cfg = sm.params.cfg
    ns = cfg["n_star"]
    w0 = time.perf_counter()
    sources = sweep.sources_from_rows([artifacts.read_json(p)["cells"] for p in sm.input.rows])
    cells = [sweep.solve_single(cfg["multirev"], cfg["sweep"], ns["L0_deg"], n, sources, ns["start"], log=log)
             for n in ns["n_rev"]]
    wall = time.perf_counter() - w0
    artifacts.write_json(sm.output[0], {**ns, "cells": cells, "provenance": artifacts.provenance(cfg, wall)})


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake, log)  # noqa: F821
