"""One row of the E3 sweep (all L0 of one revolution count): results/multirev/sweep/row_<n>.json."""
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.studies import sweep  # noqa: E402


def main(sm, log):
    cfg, n = sm.params.cfg, sm.params.n_rev
    w0, c0 = time.perf_counter(), time.process_time()
    sources = sweep.sources_from_rows([artifacts.read_json(p)["cells"] for p in sm.input.rows])
    cells = sweep.solve_row(cfg["multirev"], cfg["sweep"], n, sources=sources, log=log)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    artifacts.write_json(sm.output[0], {
        "n_rev": n, "row": cfg["sweep"]["rows"][0], "cells": cells,
        "timing": {"wall_s": wall, "cpu_s": cpu, "cells": len(cells)},
        "units": {"T_min_N": "N", "tof_days": "d", "m_f_kg": "kg", "K_f_deg": "deg",
                  "z": "nondimensional (DU = final-orbit radius, mu = 1, mass unit m0)"},
        "provenance": artifacts.provenance(cfg, wall)})


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake, log)  # noqa: F821
