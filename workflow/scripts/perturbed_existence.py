"""The minimum-thrust existence check of one §4.2 case under one force model, from the zero guess
or, for the cases of existence.from_ot, from the case's OT artifact, or from another model's upper
bound where existence.bound_from says so (spaceopt.studies.existence); failure.json on
non-convergence."""
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.errors import ConvergenceError  # noqa: E402
from spaceopt.indirect.tmin_from_ot import FromOtOptions  # noqa: E402
from spaceopt.studies import existence as E, perturbed as P  # noqa: E402


def main(sm):
    cfg, case, model = sm.params.cfg, sm.params.case, sm.params.model
    out = Path(sm.output[0])
    tr = P.transfer_from_config(cfg, case, model,
                                ephemeris=P.ephemeris_path(sm.params.results, cfg["cases"][case]["ephemeris"]))
    artifacts.clear_failures(out)
    t0 = time.perf_counter()
    try:
        if "existence_bound_from" in cfg:   # another model's bound carried over (existence.bound_from)
            tm, verdict = E.solve_from_bound(P.load(sm.input.ot[0]), tr, cfg["existence_bound_from"],
                                             f"{case}/tmin_{model}", FromOtOptions(**cfg["existence_from_ot"]))
        elif "existence_from_ot" in cfg:     # from the case's OT solution (existence.from_ot)
            tm, verdict = E.solve_from_ot(P.load(sm.input.ot[0]), f"{case}/tmin_{model}",
                                          FromOtOptions(**cfg["existence_from_ot"]))
        else:
            tm, verdict = E.solve(tr, f"{case}/tmin_{model}", bool(cfg["cases"][case].get("lp_perturbed", False)))
    except ConvergenceError as exc:
        artifacts.write_failure(artifacts.failure_path(out), exc, cfg, time.perf_counter() - t0)
        raise
    P.save(tm, out, cfg, time.perf_counter() - t0, tm.extra, samples_per_rev=cfg["numerics"]["samples_per_rev"])
    print(f"[{case}/tmin_{model}] {verdict['message']}", file=sys.stderr)


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
