"""One perturbed §4.2 solve: a chain (LP -> OT) or a warm start from a neighbouring solved case
(E6 date to date, E8 n to n, E9 model to model), with artifacts; failure.json on non-convergence."""
import shutil
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.errors import ConvergenceError  # noqa: E402
from spaceopt.indirect.continuation import resumed_wall_time  # noqa: E402
from spaceopt.studies import perturbed as P  # noqa: E402
from spaceopt.studies import perturbed_config as C  # noqa: E402


def checkpoint_dir(out: Path, cfg: dict) -> Path:
    """``<output>.checkpoints/<config hash>``; checkpoints of other configs are removed."""
    root = out.with_suffix(".checkpoints")
    here = root / artifacts.config_hash(cfg)[:16]
    for other in root.glob("*"):
        if other != here:
            shutil.rmtree(other, ignore_errors=True)
    return here


def solve(sm, cfg, case, model, tr, label, warm_kw, fail):
    """The Newton solution of this job: (solution, artifact extra); a failure is written
    (``fail``) and raised. A warm start whose path reached τ = 1 but whose final polish failed
    hands its best point to the free-time end game instead (where the case has one;
    ``P.end_point_of``), with the failure in the extra (``polish_failure``): :func:`main` keeps
    the result only where the end game certifies a local maximum from there."""

    def warm(start, warm_label, extra):
        try:
            return P.warm_start(P.load(start), tr, warm_label, **warm_kw), extra
        except ConvergenceError as exc:
            end = P.end_point_of(exc, tr) if P.tof_maximum_settings(cfg, case) else None
            if end is None:
                raise
            print(f"[{label}] {exc}; its best point (|F| {exc.diagnosis['residual_best']:.2e}) goes to "
                  "the free-time end game", file=sys.stderr, flush=True)
            return end, {**extra, "polish_failure": {
                "error": str(exc), "residual_best": exc.diagnosis["residual_best"],
                **{k: exc.diagnosis.get(k) for k in ("jacobian_evaluations", "residual_evaluations", "wall_time_s")}}}

    try:
        if sm.params.source == "chain":
            cc = cfg["cases"][case]
            route = cc.get("route", "lp-ot")
            try:
                lp, sol = P.solve_for(tr, label, bool(cc.get("lp_perturbed", False)),
                                      cc.get("homotopy_path", cfg["numerics"].get("homotopy_path", "arclength")),
                                      options=P.chain_options(cfg, case), blend_ref=cc.get("blend_ref"), route=route,
                                      switching=C.case_switching(cfg, case))
                extra = {"continued_from": "chain", "route": route,
                         "lp": {k: lp.extra[k] for k in ("J_LP_m2s3", "dv_m_s", "tof_s")},
                         "lp_perturbed": lp.shooting.model.perturbed, **sol.extra}
            except ConvergenceError as exc:
                if not hasattr(sm.input, "start"):
                    raise
                # fallback (case option fallback: previous): the chain's failure stays on record
                fail(exc, ".chain_failure.json")
                print(f"[{label}] chain from the zero guess failed ({exc}); warm start from "
                      f"{sm.input.start}", file=sys.stderr, flush=True)
                sol, extra = warm(sm.input.start, label + "/warm", {
                    "continued_from": str(sm.input.start), "route": route,
                    "chain_failure": {"error": str(exc), "diagnosis": exc.diagnosis}})
        else:
            sol, extra = warm(sm.input.start, label, {"continued_from": str(sm.input.start)})
    except ConvergenceError as exc:
        fail(exc, ".failure.json")
        raise
    return sol, extra


def main(sm):
    cfg, case, model = sm.params.cfg, sm.params.case, sm.params.model
    out = Path(sm.output[0])
    eph = P.ephemeris_path(sm.params.results, cfg["cases"][case]["ephemeris"])
    kw = {"ephemeris": eph}
    if sm.rule == "perturbed_e6_date":
        kw["epoch_utc"] = sm.params.epoch
    if sm.rule == "perturbed_e8":
        kw["n_rev"] = sm.params.n_rev
    tr = P.transfer_from_config(cfg, case, model, **kw)
    label = f"{case}/{model}" + (f"/{kw['epoch_utc'][:10]}" if "epoch_utc" in kw else "") + \
        (f"/n{kw['n_rev']:g}" if "n_rev" in kw else "")
    # perturbations switched on / the force model changed at a larger smoothing ε than ε_f
    # (case options perturb_at_eps, model_step_at_eps), the continuation step rule
    # (warm_step_growth), the path and settings of a model step (model_step, at this count);
    # the warm start's paths save their last accepted point next to the
    # output, under the config's hash, and a rerun after an interruption resumes from it (E8
    # 450-500: hours); checkpoints of another config are dropped
    ckdir = checkpoint_dir(out, cfg)
    warm_kw = P.warm_start_kwargs(cfg, case, model, checkpoint_dir=str(ckdir), n_rev=kw.get("n_rev"))
    t0 = time.perf_counter()
    artifacts.clear_failures(out)

    def wall_time(record):
        """This run's wall time plus what its resumed paths spent in earlier, interrupted runs."""
        return time.perf_counter() - t0 + resumed_wall_time(record)

    def fail(exc, suffix):
        artifacts.write_failure(artifacts.failure_path(out, suffix), exc, cfg, wall_time(exc.diagnosis))

    # the Newton solution is kept until the free-time end game (numerics.tof_maximum) is done: an
    # interrupted end game resumes from it (its continuation checkpoints are gone by then)
    newton = ckdir / "free_time_start.json"
    resumed = P.end_game_start(newton)
    if resumed is not None:
        sol, extra, before = resumed
        print(f"[{label}] resumed from {newton}: the end game of an interrupted run", file=sys.stderr, flush=True)
    else:
        sol, extra = solve(sm, cfg, case, model, tr, label, warm_kw, fail)
        before = resumed_wall_time(sol.stats)

    def save(solution, path):
        P.save(solution, path, cfg, time.perf_counter() - t0 + before, extra,
               samples_per_rev=cfg["numerics"]["samples_per_rev"])

    if resumed is None and P.tof_maximum_settings(cfg, case) and tr.perturbed:
        save(sol, newton)
    # the local maximum of m_f in the time of flight next to the free-time extremal (numerics
    # tof_maximum): a free-time Newton also accepts degenerate points (E8 250, 500 rev)
    sol, record = P.maximise_in_tof(sol, cfg, case, label)
    if record is not None:
        extra["tof_maximum"] = record
    if "polish_failure" in extra and not record["certified"]:
        exc = ConvergenceError(f"{label}: {extra['polish_failure']['error']}; the free-time end game from its "
                               f"best point certified no maximum ({record['status']})",
                               {**extra["polish_failure"], "tof_maximum": record})
        fail(exc, ".failure.json")
        # no resume from this start: a rerun takes the route again (its path checkpoint is kept)
        for part in newton.parent.glob(newton.stem + ".*"):
            part.unlink()
        raise exc
    save(sol, out)
    shutil.rmtree(out.with_suffix(".checkpoints"), ignore_errors=True)   # solved: none needed


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
