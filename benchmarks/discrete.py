"""Benchmark harness of the discrete-control studies (spec 05-discrete.md) -> results/benchmarks/discrete.json.

What it measures (each in a fresh look at the config files):

* D4 (orbit_correction): every method (maximum principle, dynamic programming) for every control
  (relay, impulsive) separately, ``--repeats`` times: median wall time (perf_counter) and median CPU
  time of this process (process_time), beside the published Maple 2019 times; target <= 0.1 s.
* D2 (libration_lp): the first L1 l1 correction (LP only) and the whole study computation
  (station keeping at L1, L2, L3 for every criterion; no figures).
* D1 (geo_burns) and D3 (bellman), when their modules exist: their study computation, once.
* The discrete part of the DAG: a temporary copy of Snakefile inputs (config/, workflow/, src/) with
  a Snakefile that includes only the rules files writing under results/discrete, run from an empty
  results directory with ``snakemake --cores N`` for all of its results/discrete targets; target
  <= 120 s on 2 cores. Per-rule times come from the rules' own benchmark: files.

The machine's load average is recorded before and after, because wall times on a shared machine
include waiting for a core; CPU times do not. ``idle_machine_estimate_s`` = max(sum of the rules'
CPU times / cores, the largest rule's CPU time) is a lower bound of the DAG's wall time on an idle
machine (snakemake's own start-up excluded); it is an estimate, the measured wall time is ``wall_s``.

Usage: python benchmarks/discrete.py [--repeats 15] [--cores 2] [--skip-dag] [--out PATH]
"""
from __future__ import annotations

import argparse
import csv
import importlib
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

from spaceopt.artifacts import provenance, write_json  # noqa: E402
from spaceopt.report.compare import published_lookup  # noqa: E402

from machine import finish, machine_facts  # noqa: E402

PUBLISHED = ROOT / "config/published/discrete_libration_zonotope.yaml"
D4_TARGET_S = 0.1
DAG_TARGET_S = 120.0


def _study_cfg(name: str) -> dict | None:
    path = ROOT / "config/studies" / f"{name}.yaml"
    if not path.exists():
        return None
    return yaml.safe_load(path.read_text()).get(name)


def _timed(fn, repeats: int) -> dict:
    wall, cpu = [], []
    for _ in range(repeats):
        w0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - w0)
        cpu.append(time.process_time() - c0)
    return {"repeats": repeats, "median_wall_s": float(np.median(wall)), "min_wall_s": float(np.min(wall)),
            "max_wall_s": float(np.max(wall)), "median_cpu_s": float(np.median(cpu)), "wall_s": wall}


def bench_d4(cfg: dict, repeats: int) -> dict:
    from spaceopt.discrete import zonotope_control as zc
    pub = published_lookup(PUBLISHED)
    dt, fit = zc.resolve_dt(cfg, zc.published_mp_tables(pub, cfg["controls"]))
    x0 = np.asarray(cfg["x0"], dtype=np.float64)
    out = {"dt": dt, "methods": {}}
    solvers = {"maximum_principle": zc.solve_mp, "dynamic_programming": zc.solve_dp}
    for c in cfg["controls"]:
        for m, solve in solvers.items():
            a = cfg["a_max"][c]
            solve(x0, dt, c, a, cfg["n_max"], cfg["gauge_tol"])          # warm-up (imports, caches)
            t = _timed(lambda: solve(x0, dt, c, a, cfg["n_max"], cfg["gauge_tol"]), repeats)
            maple = pub.get((f"d4_time_{c}", f"{m}_s"), {}).get("value")
            t.update({"maple_2019_s": maple, "speedup_vs_maple": maple / t["median_wall_s"] if maple else None,
                      "target_s": D4_TARGET_S, "meets_target_wall": t["median_wall_s"] <= D4_TARGET_S,
                      "meets_target_cpu": t["median_cpu_s"] <= D4_TARGET_S})
            out["methods"][f"{m}|{c}"] = t
            print(f"D4 {m:20s} {c:9s} median {t['median_wall_s'] * 1e3:7.2f} ms wall, "
                  f"{t['median_cpu_s'] * 1e3:7.2f} ms cpu (Maple {maple} s)", flush=True)
    if fit is not None:
        out["dt_fit"] = {"dt_least_squares": fit["dt"], "rms": fit["rms"]}
    out["dt_inference"] = _timed(lambda: zc.resolve_dt(cfg, zc.published_mp_tables(pub, cfg["controls"])), 3)
    return out


def bench_d2(cfg: dict, repeats: int) -> dict:
    from spaceopt.discrete import libration_lp as ll
    mu = ll.mass_ratio(cfg)
    pts = ll.libration_points(mu)
    A = ll.jacobian(mu, *pts["L1"])
    cc = cfg["correction"]
    K = cc["N"] + cc.get("steps_offset", 0)            # the study's discretisation (config comment)
    lp = _timed(lambda: ll.solve_correction(A, cc["Y0"], K, cc["T"] / cc["N"], "l1",
                                            first_control=cc.get("first_control", 0)), repeats)
    study = _timed(lambda: ll.run_study(cfg), 1)
    print(f"D2 first LP {lp['median_wall_s'] * 1e3:.1f} ms; whole study {study['median_wall_s']:.2f} s", flush=True)
    return {"first_L1_lp": lp, "study_no_figures": study}


def bench_optional(name: str) -> dict:
    """D1/D3 (another engineer's modules): time their study computation once, if present."""
    try:
        mod = importlib.import_module(f"spaceopt.discrete.{name}")
    except ImportError as exc:
        return {"present": False, "note": f"module not importable: {exc}"}
    cfg = _study_cfg(name)
    if cfg is None:
        return {"present": True, "note": f"config/studies/{name}.yaml missing"}
    try:
        if hasattr(mod, "run_study"):
            fn, entry = (lambda: mod.run_study(cfg)), "run_study(cfg)"
        elif hasattr(mod, "solve") and hasattr(mod, "params_from_config"):
            fn, entry = (lambda: mod.solve(mod.params_from_config(cfg))), "solve(params_from_config(cfg))"
        else:
            return {"present": True, "note": "no run_study/solve entry point"}
        t = _timed(fn, 1)
        t["entry_point"] = entry
        print(f"{name}: {entry} {t['median_wall_s']:.2f} s", flush=True)
        return {"present": True, **t}
    except Exception as exc:  # noqa: BLE001 - recorded, never hidden
        return {"present": True, "error": f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"}


def _discrete_rule_files() -> list[Path]:
    files = []
    for p in sorted((ROOT / "workflow/rules").glob("*.smk")):
        if p.name != "common.smk" and "/discrete" in p.read_text():
            files.append(p)
    return files


def bench_dag(cores: int) -> dict:
    rules = _discrete_rule_files()
    with tempfile.TemporaryDirectory(prefix="discrete_dag_") as tmp:
        tmp = Path(tmp)
        for d in ("config", "workflow", "src"):
            shutil.copytree(ROOT / d, tmp / d, ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
        includes = "\n".join(f'include: "workflow/rules/{p.name}"' for p in rules)
        (tmp / "Snakefile").write_text(
            "from pathlib import Path\nfrom snakemake.utils import validate\n"
            'configfile: "config/config.yaml"\n'
            'for _c in sorted(Path("config/studies").glob("*.yaml")):\n    configfile: str(_c)\n'
            'include: "workflow/rules/common.smk"\n' + includes + "\n"
            "rule all:\n    default_target: True\n"
            '    input: [t for t in ALL_TARGETS if "/discrete/" in str(t)]\n')
        exe = Path(sys.executable).parent / "snakemake"
        cmd = [str(exe) if exe.exists() else "snakemake", "--cores", str(cores), "--quiet"]
        env = dict(os.environ, PYTHONPATH=str(ROOT / "src"))
        load0 = os.getloadavg()
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, cwd=tmp, capture_output=True, text=True, env=env)
        wall = time.perf_counter() - t0
        per_rule = {}
        for tsv in sorted((tmp / "results/discrete/benchmarks").glob("*.tsv")):
            with open(tsv) as fh:
                row = next(csv.DictReader(fh, delimiter="\t"))
            per_rule[tsv.stem] = {"wall_s": float(row["s"]), "cpu_s": float(row["cpu_time"]),
                                  "max_rss_mb": float(row["max_rss"])}
        cpu_total = sum(r["cpu_s"] for r in per_rule.values())
        return {"rules_files": [p.name for p in rules], "cores": cores, "wall_s": wall,
                "rules_cpu_total_s": cpu_total,
                "idle_machine_estimate_s": max(cpu_total / cores, max((r["cpu_s"] for r in per_rule.values()),
                                                                      default=0.0)),
                "returncode": proc.returncode, "target_s": DAG_TARGET_S,
                "meets_target": proc.returncode == 0 and wall <= DAG_TARGET_S,
                "per_rule": per_rule, "loadavg_before": load0, "loadavg_after": os.getloadavg(),
                "stderr_tail": proc.stderr[-2000:] if proc.returncode else ""}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=None, help="repeats per D4 method (default: config)")
    ap.add_argument("--cores", type=int, default=2)
    ap.add_argument("--skip-dag", action="store_true")
    ap.add_argument("--skip-optional", action="store_true", help="do not time D1/D3")
    ap.add_argument("--out", default=str(ROOT / "results/benchmarks/discrete.json"))
    args = ap.parse_args(argv)
    t_start = time.perf_counter()
    d2cfg, d4cfg = _study_cfg("libration_lp"), _study_cfg("orbit_correction")
    repeats = args.repeats or d4cfg["timing_repeats"]
    result = {"machine": machine_facts()}
    result["d4_orbit_correction"] = bench_d4(d4cfg, repeats)
    result["d2_libration_lp"] = bench_d2(d2cfg, max(3, repeats // 3))
    if not args.skip_optional:
        result["d1_geo_burns"] = bench_optional("geo_burns")
        result["d3_bellman"] = bench_optional("bellman")
    if not args.skip_dag:
        result["dag_discrete"] = bench_dag(args.cores)
        print(f"DAG (discrete, {args.cores} cores): {result['dag_discrete']['wall_s']:.1f} s, "
              f"rc={result['dag_discrete']['returncode']}", flush=True)
    finish(result["machine"])
    d4 = result["d4_orbit_correction"]["methods"]
    result["summary"] = {
        "d4_all_methods_within_0.1s_wall": all(v["meets_target_wall"] for v in d4.values()),
        "d4_all_methods_within_0.1s_cpu": all(v["meets_target_cpu"] for v in d4.values()),
        "dag_within_120s": result.get("dag_discrete", {}).get("meets_target"),
    }
    cfg = {"libration_lp": d2cfg, "orbit_correction": d4cfg, "harness": vars(args) | {"repeats": repeats}}
    result["provenance"] = provenance(cfg, time.perf_counter() - t_start)
    write_json(args.out, result)
    print(f"wrote {args.out}: {result['summary']}")


if __name__ == "__main__":
    main()
