"""One chain stage of a §4.1 case: LP, T_min (existence check) or OT, with artifacts."""
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.errors import ConvergenceError  # noqa: E402
from spaceopt.indirect import chain  # noqa: E402
from spaceopt.studies import multirev, multirev_config  # noqa: E402


def main(sm):
    cfg, case, rule = sm.params.cfg, sm.params.case, sm.rule
    out = Path(sm.output[0])
    t0 = time.perf_counter()
    artifacts.clear_failures(out)
    try:
        if rule == "multirev_lp":
            tr = multirev_config.transfer_from_config(cfg, case)
            sol = chain.solve_lp(tr, label=f"{case}/lp")
            extra = {}
        elif rule == "multirev_tmin":
            lp = multirev.load(sm.input.lp)
            tr = multirev_config.transfer_from_config(cfg, case, isp_s=sm.params.isp)
            lp.transfer, lp.prm = tr, tr.params()
            sol = chain.solve_tmin(lp, label=f"{case}/tmin")
            extra = {}
        else:
            start = multirev.load(sm.input.start)
            T = sm.params.thrust
            if sm.params.source == "lp":
                sol = chain.solve_ot(start, T, label=f"{case}/ot {T:g} N")
            else:
                sol = chain.continue_ot_in_thrust(start, T, label=f"{case}/ot {start.thrust_N:g}->{T:g} N")
            extra = {"continued_from": sm.params.source}
    except ConvergenceError as exc:
        artifacts.write_failure(artifacts.failure_path(out), exc, cfg, time.perf_counter() - t0)
        raise
    multirev.save(sol, out, cfg, time.perf_counter() - t0, extra,
                  samples_per_rev=cfg["numerics"]["samples_per_rev"])


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
