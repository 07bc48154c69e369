"""Benchmark harness of the E3 sweep (Tables 4.1.1-4.1.2) -> results/benchmarks/sweep.json.

What it records:

* ``cells``: per-cell cost against n_rev from the row artifacts of a sweep run
  (results/multirev/sweep/row_<n>.json): wall time, Jacobian evaluations and the way each cell was
  obtained (cold chain, march along L0, scaled along n, fallbacks), summarised per n and method.
* ``rows``: wall and CPU time of every sweep job from Snakemake's benchmark files, the total CPU
  and the critical path of the row DAG (rows scaled from earlier rows wait for them), and an
  idle-machine estimate max(total CPU / cores, critical-path CPU) of the whole sweep.
* ``--dag``: runs the sweep part of the DAG (rows, n* check, tables, figures), every job forced,
  with ``snakemake --cores N`` (nice'd) from a temporary Snakefile that includes only
  workflow/rules/sweep.smk, writing into ``--results``; records its wall time against the
  10-minute target. That run is the pipeline's run: ``pipeline_run`` is then read from it.
* ``--micro``: cold vs warm at small n, measured here: the cold LP -> T_min chain of one cell,
  one 10 deg march step, one cell scaled along n; and jax.vmap batching of the T_min shooting map
  (12 cells at once against 12 one by one).

The load average is recorded before and after: wall times on a shared machine include waiting for
a core, CPU times do not.

Usage: python benchmarks/sweep.py [--results results] [--dag] [--micro] [--cores 2] [--out PATH]
"""
from __future__ import annotations

import argparse
import csv
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from spaceopt.artifacts import provenance, read_json, write_json  # noqa: E402

from machine import finish, machine_facts  # noqa: E402

TARGET_S = 600.0


def _cfg():
    mr = yaml.safe_load((ROOT / "config/studies/multirev.yaml").read_text())["multirev"]
    sw = yaml.safe_load((ROOT / "config/studies/sweep.yaml").read_text())["sweep"]
    return mr, sw


def _tsv(path: Path) -> dict:
    with open(path) as fh:
        row = next(csv.DictReader(fh, delimiter="\t"))
    return {"wall_s": float(row["s"]), "cpu_s": float(row["cpu_time"]), "max_rss_mb": float(row["max_rss"])}


def from_results(results: Path, sw: dict, cores: int) -> dict:
    sdir = results / "multirev/sweep"
    cells, per_n = [], {}
    for row in sw["rows"]:
        p = sdir / f"row_{float(row['n_rev']):g}.json"
        if not p.exists():
            continue
        data = read_json(p)
        for c in data["cells"]:
            cells.append({k: c[k] for k in ("L0_deg", "n_rev", "method", "jacobian_evaluations", "wall_s")})
        per_n[f"{float(row['n_rev']):g}"] = {"row_wall_s": data["timing"]["wall_s"], "row_cpu_s": data["timing"]["cpu_s"],
                                            "cells": data["timing"]["cells"], "start": row["start"], "grid": row["grid"]}
    summary = {}
    for n in sorted({c["n_rev"] for c in cells}):
        sel = [c for c in cells if c["n_rev"] == n]
        by = {}
        for m in sorted({c["method"] for c in sel}):
            s = [c for c in sel if c["method"] == m]
            by[m] = {"cells": len(s), "median_wall_s": float(np.median([c["wall_s"] for c in s])),
                     "median_jacobians": float(np.median([c["jacobian_evaluations"] for c in s]))}
        summary[f"{n:g}"] = {"cells": len(sel), "mean_wall_s_per_cell": float(np.mean([c["wall_s"] for c in sel])),
                             "by_method": by}
    jobs = {p.stem: _tsv(p) for p in sorted((sdir / "benchmarks").glob("*.tsv"))} if (sdir / "benchmarks").exists() else {}
    # critical path over the row dependencies (CPU seconds of the jobs)
    cp = {}
    for row in sw["rows"]:
        key = f"row_{float(row['n_rev']):g}"
        own = jobs.get(key, {}).get("cpu_s", per_n.get(f"{float(row['n_rev']):g}", {}).get("row_cpu_s", 0.0))
        deps = [] if row["start"] == "cold" else [cp.get(f"row_{float(n):g}", 0.0) for n in row["start"]]
        cp[key] = own + max(deps, default=0.0)
    cpu_total = sum(j["cpu_s"] for j in jobs.values())
    table_cells = len(sw["table_L0_deg"]) * len(sw["rows"])
    return {"cells": cells, "per_n": summary, "rows": per_n, "jobs": jobs,
            "jobs_cpu_total_s": cpu_total, "critical_path_cpu_s": max(cp.values(), default=0.0),
            "idle_machine_estimate_s": max(cpu_total / cores, max(cp.values(), default=0.0)),
            "table_cells": table_cells, "cells_total": len(cells)}


def micro() -> dict:
    import jax
    import jax.numpy as jnp

    from spaceopt.indirect.shooting import shoot
    from spaceopt.studies import sweep

    mr, sw = _cfg()
    out = {}
    for n in (2.0, 20.0):
        tr = sweep.cell_transfer(mr, sw, 100.0, n)
        sweep.cold_cell(sweep.cell_transfer(mr, sw, 90.0, n))        # warm-up: compilation
        w0, c0 = time.perf_counter(), time.process_time()
        z, st = sweep.cold_cell(tr)
        cold = {"wall_s": time.perf_counter() - w0, "cpu_s": time.process_time() - c0,
                "jacobian_evaluations": st["jacobian_evaluations"]}
        row = {**sw, "table_L0_deg": [100, 110], "rows": [{"n_rev": n, "start": "cold", "grid": "table"}]}
        cells = sweep.solve_row(mr, row, n)
        march = {k: cells[1][k] for k in ("wall_s", "jacobian_evaluations", "method")}
        out[f"{n:g}"] = {"cold_cell": cold, "march_10deg": march,
                         "speedup_wall": cold["wall_s"] / march["wall_s"]}
        print(f"n={n:g}: cold {cold['wall_s']:.1f} s ({cold['jacobian_evaluations']} jac), march 10 deg "
              f"{march['wall_s']:.2f} s ({march['jacobian_evaluations']} jac)", flush=True)
    # scaled along n: 20 -> 50 at L0 = 100 with the 20-rev cell above
    src = {20.0: {100.0: np.asarray(z)}}
    w0 = time.perf_counter()
    c = sweep.solve_single(mr, sw, 100.0, 50.0, src, [20.0])
    out["scale_20_to_50"] = {"wall_s": time.perf_counter() - w0, "jacobian_evaluations": c["jacobian_evaluations"],
                             "method": c["method"]}
    # vmap batching of the shooting map (20 rev, 12 cells)
    sh = sweep.shooting(sw["numerics"], 20.0)
    prms = []
    for i in range(12):
        t = sweep.cell_transfer(mr, sw, 10.0 * i, 20.0)
        prms.append(sweep.path_params(t.params(), t.params()))
    zj = jnp.asarray(z)
    one = jax.jit(lambda zz, p: shoot(sh, zz, 1.0, p))
    jax.block_until_ready(one(zj, prms[0]))
    w0 = time.perf_counter()
    for p in prms:
        jax.block_until_ready(one(zj, p))
    t_single = time.perf_counter() - w0
    pb = jax.tree_util.tree_map(lambda *a: jnp.stack(a), *prms)
    many = jax.jit(jax.vmap(lambda zz, p: shoot(sh, zz, 1.0, p), in_axes=(None, 0)))
    jax.block_until_ready(many(zj, pb))
    w0 = time.perf_counter()
    jax.block_until_ready(many(zj, pb))
    t_batch = time.perf_counter() - w0
    out["vmap_12_cells_20rev"] = {"one_by_one_s": t_single, "batched_s": t_batch, "speedup": t_single / t_batch}
    print(f"vmap: 12 one by one {t_single:.2f} s, batched {t_batch:.2f} s", flush=True)
    return out


def run_dag(cores: int, results: Path) -> dict:
    """The sweep rules alone (a temporary Snakefile that includes only sweep.smk), every job forced,
    results written to ``results`` (the real results directory: this run is the pipeline's run)."""
    with tempfile.TemporaryDirectory(prefix="sweep_dag_") as tmp:
        tmp = Path(tmp)
        for d in ("config", "workflow"):
            shutil.copytree(ROOT / d, tmp / d, ignore=shutil.ignore_patterns("__pycache__"))
        (tmp / "src").symlink_to(ROOT / "src")
        (tmp / "Snakefile").write_text(
            "from pathlib import Path\nfrom snakemake.utils import validate\n"
            'configfile: "config/config.yaml"\n'
            'for _c in sorted(Path("config/studies").glob("*.yaml")):\n    configfile: str(_c)\n'
            'include: "workflow/rules/common.smk"\ninclude: "workflow/rules/sweep.smk"\n'
            "rule all:\n    default_target: True\n    input: ALL_TARGETS\n")
        exe = Path(sys.executable).parent / "snakemake"
        cmd = ["nice", "-n", "5", str(exe) if exe.exists() else "snakemake", "--cores", str(cores),
               "--forceall", "--config", f"results_dir={Path(results).resolve()}"]
        env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
        load0 = os.getloadavg()
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, cwd=tmp, capture_output=True, text=True, env=env)
        wall = time.perf_counter() - t0
        return {"cores": cores, "wall_s": wall, "returncode": proc.returncode, "target_s": TARGET_S,
                "meets_target": proc.returncode == 0 and wall <= TARGET_S,
                "loadavg_before": load0, "loadavg_after": os.getloadavg(),
                "stderr_tail": proc.stderr[-3000:] if proc.returncode else ""}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", default=str(ROOT / "results"))
    ap.add_argument("--cores", type=int, default=2)
    ap.add_argument("--dag", action="store_true", help="run the sweep DAG from scratch in a temporary copy")
    ap.add_argument("--micro", action="store_true", help="cold vs warm and vmap measurements at small n")
    ap.add_argument("--out", default=str(ROOT / "results/benchmarks/sweep.json"))
    args = ap.parse_args(argv)
    t_start = time.perf_counter()
    mr, sw = _cfg()
    result = {"machine": machine_facts(),
              "target_s": TARGET_S, "strategy": {"rows": sw["rows"], "numerics": sw["numerics"]}}
    if args.dag:
        result["dag"] = run_dag(args.cores, Path(args.results))
        print(f"sweep DAG ({args.cores} cores): {result['dag']['wall_s']:.1f} s, rc={result['dag']['returncode']}", flush=True)
    result["pipeline_run"] = from_results(Path(args.results), sw, args.cores)
    if args.micro:
        result["micro"] = micro()
    finish(result["machine"])
    pr = result["pipeline_run"]
    result["summary"] = {
        "cells_computed": pr["cells_total"], "table_cells": pr["table_cells"],
        "rows_cpu_total_s": pr["jobs_cpu_total_s"], "idle_machine_estimate_s": pr["idle_machine_estimate_s"],
        "dag_wall_s": result.get("dag", {}).get("wall_s"),
        "meets_10_min": result.get("dag", {}).get("meets_target"),
        "per_cell_wall_s_vs_n": {n: v["mean_wall_s_per_cell"] for n, v in pr["per_n"].items()},
    }
    result["provenance"] = provenance({"sweep": sw, "harness": vars(args)}, time.perf_counter() - t_start)
    write_json(args.out, result)
    print(f"wrote {args.out}: {result['summary']}")


if __name__ == "__main__":
    main()
