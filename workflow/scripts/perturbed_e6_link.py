"""One E6 family link: date a's extremal continued in the departure epoch to date b, its end
game, and the comparison with the scan's extremal at b (spaceopt.studies.scan_families)."""
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.studies import perturbed as P, scan_families as F  # noqa: E402


def main(sm):
    t0 = time.perf_counter()
    cfg, case, model = sm.params.cfg, sm.params.case, sm.params.model
    eph = P.ephemeris_path(sm.params.results, cfg["cases"][case]["ephemeris"])
    tr_to = P.transfer_from_config(cfg, case, model, ephemeris=eph, epoch_utc=sm.params.epoch)
    a, b = sm.wildcards.a, sm.wildcards.b
    scan = artifacts.read_json(sm.input.scan)["scalars"]
    rec, _ = F.continue_to(P.load(sm.input.start), tr_to, scan, cfg, case, f"e6 link {a} -> {b}", cfg["links"])
    print(f"[e6 link {a} -> {b}] {rec['status']}" + (
        f": m_f {rec['m_f_kg']:.6f} kg, {rec['tof_days']:.5f} d against the scan's "
        f"{rec['scan_m_f_kg']:.6f} kg, {rec['scan_tof_days']:.5f} d" if "m_f_kg" in rec else f": {rec.get('error')}"),
        file=sys.stderr, flush=True)
    wall = time.perf_counter() - t0
    artifacts.write_json(sm.output[0], {"link": {"from_date": a, "to_date": b, **rec, "wall_time_s": wall},
                                        "provenance": artifacts.provenance(cfg, wall)})


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
