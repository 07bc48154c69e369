"""One E6 family walk: the extremal a link (a, b) continued to b, where it is not the scan's,
followed on date by date past b (spaceopt.studies.scan_walks). Every step is recorded in a
resume file beside the output, so an interrupted walk goes on from its last step."""
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.studies import perturbed as P, scan_walks as W  # noqa: E402


def resume_file(out: Path) -> Path:
    return out.with_suffix(".steps.json")


def done_steps(path: Path, key: dict) -> list:
    """The steps a walk recorded before an interruption, where it started from the same link
    extremal under the same config (``key``); none otherwise."""
    if not path.exists():
        return []
    data = artifacts.read_json(path)
    return data["steps"] if data.get("key") == key else []


def main(sm):
    t0 = time.perf_counter()
    cfg, case = sm.params.cfg, sm.params.case
    a, b = sm.wildcards.a, sm.wildcards.b
    link = artifacts.read_json(sm.input.link)["link"]
    out = Path(sm.output[0])
    steps = []
    if link["status"] == "other":
        dates = sm.params.dates                      # b, then the dates ahead
        problems = {d: P.load(p) for d, p in zip(dates, sm.input.scan)}
        scans = {d: artifacts.read_json(p)["scalars"] for d, p in zip(dates, sm.input.scan)}
        key = {"config": artifacts.config_hash(cfg), "z": link["z"]}
        resume = resume_file(out)
        done = done_steps(resume, key)
        if done:
            print(f"[e6 walk {a} -> {b}] resuming after {len(done)} steps", file=sys.stderr, flush=True)
        steps = W.walk(W.extremal_at(problems[b], link["z"]), dates[1:], problems, scans, cfg, case,
                       f"e6 walk {a} -> {b}", cfg["links"], done=done,
                       record=lambda s: artifacts.write_json(resume, {"key": key, "steps": s}))
        for s in steps:
            print(f"[e6 walk {a} -> {b}] {s['date']}: {s['status']}" + (
                f", m_f {s['m_f_kg']:.6f} kg, {s['tof_days']:.5f} d against the scan's {s['scan_m_f_kg']:.6f} kg"
                if "m_f_kg" in s else f": {s.get('error')}"), file=sys.stderr, flush=True)
    wall = time.perf_counter() - t0
    artifacts.write_json(out, {"walk": {"from_date": a, "to_date": b, "link_status": link["status"], "steps": steps,
                                        "wall_time_s": wall},
                               "provenance": artifacts.provenance(cfg, wall)})
    resume_file(out).unlink(missing_ok=True)


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
