"""One case's minimum-fuel family under one force model, followed down in the thrust from the case's
OT artifact, or (input ``seed``) from another model's family, each of whose points is carried to
this model and the least-thrust one reached followed on down (spaceopt.studies.thrust_family): the
artifact of its least-thrust point, with every point in its extra. A family that stops short is a
result (the stop is recorded), not a failure, and so is a seed point that is not carried (listed
in ``not_carried``); where no seed point is carried the job writes its diagnosis
(<stem>.failure.json) and fails (its next run tries every seed again). Each point reached, and
each seed given up, is checkpointed next to the output, under the config's hash, and an
interrupted run resumes from the last one (its paths, too, from their last accepted step)
without trying the seeds given up again."""
import json
import shutil
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402
from perturbed_solve import checkpoint_dir  # noqa: E402  (the solves' checkpoints, as theirs)

from spaceopt import artifacts  # noqa: E402
from spaceopt.errors import ConvergenceError  # noqa: E402
from spaceopt.indirect.continuation import ContinuationOptions  # noqa: E402
from spaceopt.studies import perturbed as P, thrust_family as TF  # noqa: E402


def main(sm):
    cfg, case, model, seed = sm.params.cfg, sm.params.case, sm.params.model, sm.params.seed
    fam = cfg["thrust_family"]
    out = Path(sm.output[0])
    label = f"{case}/{out.stem}"
    start = f"family_{seed}" if seed else "ot"
    ckdir = checkpoint_dir(out, cfg)
    point = ckdir / "point.json"
    given_up = ckdir / "not_carried.json"              # the seeds given up before any was carried
    options = ContinuationOptions(max_steps=fam["max_steps"], checkpoint_dir=str(ckdir))
    t0 = time.perf_counter()
    artifacts.clear_failures(out)

    not_carried = {}

    def record(pts, stop=""):
        return {"family": {"model": model, "start": start, "points": pts, "stopped": stop, "eps": fam["eps"],
                           "thrusts_N": fam["thrusts_N"], "wall_s": time.perf_counter() - t0 + before,
                           **({"not_carried": not_carried} if seed else {})}}

    def checkpoint(s, pts):
        if s is None:                                  # no seed point carried yet: only the seeds given up
            given_up.parent.mkdir(parents=True, exist_ok=True)
            given_up.write_text(json.dumps(not_carried))
            return
        P.save(s, point, cfg, time.perf_counter() - t0 + before, record(pts), samples_per_rev=20)
        print(f"[{label}] T {s.thrust_N:g} N, eps {pts[-1]['eps']:g}: m_f {pts[-1]['m_f_kg']:.3f} kg, "
              f"dt {pts[-1]['tof_days']:.3f} d, apogee {pts[-1]['max_apogee_km']:.0f} km, "
              f"duty {pts[-1]['duty']:.4f} ({pts[-1]['wall_s']:.0f} s)", file=sys.stderr, flush=True)

    resumed = point.exists() and artifacts.read_json(point)["extra"]["family"]
    sol, points, before = (P.load(point), resumed["points"], resumed["wall_s"]) if resumed else (None, None, 0.0)
    if resumed:
        not_carried.update(resumed.get("not_carried", {}))
        print(f"[{label}] resumed at {sol.thrust_N:g} N from {point}", file=sys.stderr, flush=True)
    elif given_up.exists():
        not_carried.update(json.loads(given_up.read_text()))
        print(f"[{label}] resumed: seeds given up {sorted(not_carried)} N", file=sys.stderr, flush=True)
    if seed:                                           # every seed point not yet carried or given up
        tr = P.transfer_from_config(cfg, case, model, ephemeris=P.ephemeris_path(sm.params.results,
                                                                               cfg["cases"][case]["ephemeris"]))
        payload = artifacts.read_json(sm.input.seed)["extra"]["family"]
        todo = TF.seeds(P.load(sm.input.seed), payload["points"], fam["eps"])

        def carried(s, pts, failed):
            not_carried.update(failed)
            checkpoint(s, pts)

        last, points, _ = TF.carry_points(todo, tr, options, f"{label}/carry", points, not_carried, carried)
        sol = min((s for s in (sol, last) if s is not None), key=lambda s: s.thrust_N, default=None)
        if sol is None:
            exc = ConvergenceError(f"{label}: no point of the {seed} family carried to {model}",
                                   {"reason": "no seed point carried", "not_carried": not_carried})
            artifacts.write_failure(artifacts.failure_path(out), exc, cfg, time.perf_counter() - t0)
            given_up.unlink(missing_ok=True)
            raise exc
        if not_carried:
            print(f"[{label}] not carried: {not_carried}", file=sys.stderr, flush=True)
    elif not resumed:
        sol = P.load(sm.input.ot)
    below = [T for T in fam["thrusts_N"] if T < sol.thrust_N * (1 - 1e-12)]
    last, points, stop = TF.follow(sol, below, fam["eps"], options, label, points, checkpoint, fam["hops"])
    if stop:
        print(f"[{label}] stopped: {stop}", file=sys.stderr, flush=True)
    P.save(last, out, cfg, time.perf_counter() - t0 + before, record(points, stop),
           samples_per_rev=cfg["numerics"]["samples_per_rev"])
    shutil.rmtree(out.with_suffix(".checkpoints"), ignore_errors=True)


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
