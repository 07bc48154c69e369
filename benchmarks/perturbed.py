"""Benchmark of the perturbed §4.2 studies (issue #3: E8 500-rev chain ≤ 10 min on 2 cores; E6 scan).

Nine parts, all written to ``results/benchmarks/perturbed.json`` (parts not rerun are kept):

1. ``measured``: wall times read from the solve artifacts that exist (provenance wall_time_s of
   results/perturbed/**/<stage>.json): each E5/E7/E9 chain, every E6 date and the scan total,
   every E8 solve, and the DAG's whole route to each perturbed E8 solve (``e8_route_s``); the
   E6 family links (``e6_links``: count, summed wall time and Jacobians) and the steps of the
   family walks (``e6_walks``, the same).
2. ``propagation``: the cost of one shooting evaluation (trajectory + sensitivity columns) of the
   E8 problem, unperturbed, J2 and perturbed (4×4 + Moon + Sun), over ``--revs`` revolutions at a
   fixed guess, after compilation, per revolution. With ``--baseline REV`` the same measurement
   runs on the library as of git revision REV (``git archive``, in a temporary directory) *side
   by side*: one worker process per source tree, each compiles once, then the parent alternates
   the two workers round by round (the machine is shared and noisy; the paired per-round ratio is
   the robust number). The workers also return the residuals and Jacobians so that the two
   trees can be checked to agree to round-off.
3. ``e8``: the E8 chain (LP → OT from the zero guess, ``studies.perturbed.solve_for``, the DAG's
   route for the smallest n) at each ``--e8-revs`` n, unperturbed and perturbed: wall time,
   Jacobian evaluations, m_p and Δt. The 500-rev figure is measured only if 500 is in the list;
   otherwise the estimate scales the measured wall time per Jacobian evaluation linearly in n
   (the propagation cost is linear in the revolutions) and says so.

4. ``field_profile`` (``--profile``): where a perturbed step goes. For each force model, the
   right-hand side the integrator calls (field + its sensitivity columns,
   ``flow.field_with_tangents`` as in ``flow.propagate_with_sensitivities``) is compiled in a loop
   of ``PROFILE_EVALS`` evaluations;
   reported: µs per evaluation (min over interleaved rounds) and the number of XLA kernels
   (instructions of the compiled loop body). On CPU the cost is per kernel, not per flop.
5. ``e8_exact_route`` (``--exact-route N``): the E8 route to every model on the exact bang-bang
   map, stage by stage (:func:`e8_exact_route`).
6. ``corrector`` (``--corrector-compare N``): the E8 LP → OT path to ε₁ (the chain's costliest
   stage) at N revolutions with each corrector (``--correctors``: Newton's, the chord corrector,
   Broyden's), one after the other in one process after both maps are compiled, from the same LP
   solution: wall time, Jacobians, residual evaluations, steps, m_p and Δt, and the ratios of the
   wall times to the last corrector's (:func:`corrector_comparison`).
7. ``threads`` (``--threads-compare N``): one Jacobian of the E8 4×4 → full blend at N
   revolutions with its sensitivity columns in one computation and split over ``--threads``
   threads (default 2), side by side (:func:`threads_comparison`). ``--threads k`` alone runs
   the whole benchmark with k threads per Jacobian (recorded in ``machine``; the exact route's
   key gets ``_threads<k>``).
8. ``sensitivity`` (``--sensitivity-compare N``): one Jacobian of the E8 4×4 → full blend on the
   exact map at N revolutions with its sensitivities at the path rtol and at ``--sensitivity-rtol``
   (default 1e-9), side by side, with Newton's contraction ‖J⁻¹ δJ‖ (:func:`sensitivity_comparison`).
   ``--exact-route-sensitivity-rtol X [Y …]`` runs the exact route once per value (key ``_sens<X>``).
9. ``chain_rtol`` (``--chain-rtol-compare N``): at the end point of the E8 unperturbed chain to
   ε₁ (N revolutions), one full evaluation and one residual at the default path rtol (1e-9) and
   at ``--chain-rtol`` (default 1e-7, E8's case's), side by side, with the steps
   and ‖J⁻¹ δJ‖ (:func:`chain_rtol_comparison`).

Usage:
  python benchmarks/perturbed.py [--revs 5] [--rounds 10] [--baseline REV] [--e8-revs 200 ...]
                                 [--skip-propagation] [--skip-e8] [--profile] [--exact-route N ...]
                                 [--corrector-compare N ...] [--threads K] [--threads-compare N ...]
                                 [--exact-route-sensitivity-rtol X ...] [--sensitivity-compare N ...]
                                 [--chain-rtol-compare N ...] [--chain-rtol X]
"""
from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from machine import finish, machine_facts
from spaceopt.indirect.continuation import CORRECTORS

ROOT = Path(__file__).resolve().parents[1]
MODELS = ("unperturbed", "g44_moon_sun")
PROPAGATION_MODELS = ("unperturbed", "j2", "g44_moon_sun")
PUBLISHED = ROOT / "config/published/yun2023_perturbed.yaml"
TARGET_S = 600.0
CALLER_XLA_FLAGS = os.environ.get("XLA_FLAGS")     # read before spaceopt is imported (it adds a flag)


def measured(results: Path) -> dict:
    from spaceopt import artifacts
    base = results / "perturbed"
    out = {"chains": {}, "e6": {}, "e8": {}}
    if not base.exists():
        return out
    for p in sorted(base.glob("*/*.json")):
        if p.name.endswith((".failure.json", ".verify.json")):
            continue
        try:
            d = artifacts.read_json(p)
        except Exception:                                      # noqa: BLE001 — partial results
            continue
        if "provenance" not in d or "solver" not in d:
            continue
        end_game = (d.get("extra") or {}).get("tof_maximum") or {}     # its fixed-time solves, beside the solver's
        rec = {"wall_time_s": d["provenance"].get("wall_time_s"),
               "jacobian_evaluations": d["solver"].get("jacobian_evaluations"),
               "end_game_jacobian_evaluations": end_game.get("jacobian_evaluations", 0),
               "n_rev": d["transfer"]["n_rev"]}
        group = p.parent.name
        if group == "e6":
            out["e6"][p.stem] = rec
        elif group == "e8":
            out["e8"][p.stem] = rec
        else:
            out["chains"][f"{group}/{p.stem}"] = rec
    if out["e6"]:
        out["e6_scan_total_s"] = sum(r["wall_time_s"] or 0.0 for r in out["e6"].values())
        out["e6_dates"] = len(out["e6"])
    out["e8_route_s"] = e8_route_times(out["e8"])
    links = [artifacts.read_json(p)["link"] for p in sorted(base.glob("e6_links/*.json"))]
    if links:   # the E6 family links (studies.scan_families): beside the scan, not part of it
        out["e6_links"] = {"links": len(links), "total_s": sum(r["wall_time_s"] for r in links),
                           "jacobian_evaluations": sum(r.get("jacobian_evaluations") or 0 for r in links)}
    walks = [p for p in sorted(base.glob("e6_walks/*.json")) if not p.name.endswith(".steps.json")]
    steps = [s for p in walks for s in artifacts.read_json(p)["walk"]["steps"]]
    if steps:   # the E6 family walks (studies.scan_walks; not an unfinished walk's resume file): each step a link
        out["e6_walks"] = {"steps": len(steps), "total_s": sum(s.get("wall_time_s") or 0.0 for s in steps),
                           "jacobian_evaluations": sum(s.get("jacobian_evaluations") or 0 for s in steps)}
    return out


def e8_route_times(e8: dict) -> dict:
    """Wall time of the DAG's route to each perturbed E8 solve, from the artifacts: the
    unperturbed count n (``perturbed.e8.count_start: chain``, from the zero guess) or the
    unperturbed counts up to n (``previous``: each continues from the one before), then the
    models at n that lead to the solve (``perturbed_config.case_route`` at n: each from its start model); the
    Jacobians of the solvers and of the free-time end games. Only routes whose solves all exist."""
    from spaceopt.studies.perturbed_config import case_route, e8_count_start
    pc = _perturbed_config()
    models = pc["cases"]["e8"]["models"]
    ns = sorted(float(n) for n in pc["e8"]["n_rev"])
    chained = e8_count_start(pc) == "chain"
    out = {}
    for n in ns:
        first = [f"{models[0]}_n{m:g}" for m in ns if (m == n if chained else m <= n)]
        for model in models[1:]:
            keys = first + [f"{m}_n{n:g}" for m in case_route(pc, "e8", model, n)[1:]]
            if all(k in e8 and e8[k]["wall_time_s"] for k in keys):
                out[f"{model}_n{n:g}"] = {"wall_time_s": sum(e8[k]["wall_time_s"] for k in keys),
                                          "jacobian_evaluations": sum((e8[k]["jacobian_evaluations"] or 0)
                                                                      + e8[k].get("end_game_jacobian_evaluations", 0)
                                                                      for k in keys),
                                          "solves": list(keys)}
    return out


CONFIGFILES: list[str] = []     # --configfile: profiles over the study config, as ./dev reproduce merges them


def _perturbed_config() -> dict:
    """The perturbed section of the study config with the ``--configfile`` profiles over it,
    merged as Snakemake merges them (``snakemake.utils.update_config``: nested mappings key by key)."""
    import yaml
    from snakemake.utils import update_config
    pc = yaml.safe_load((ROOT / "config/studies/perturbed.yaml").read_text())["perturbed"]
    for path in CONFIGFILES:
        update_config(pc, (yaml.safe_load(Path(path).read_text()) or {}).get("perturbed", {}))
    return pc


# ------------------------------------------------------------------ propagation (worker side)

def _worker(revs: float) -> None:
    """Worker process: compile one shooting evaluation per model, then answer 'run' lines.

    Imports ``spaceopt`` from ``sys.path`` as set by the parent (current or baseline tree)."""
    import jax
    import jax.numpy as jnp
    import numpy as np
    from spaceopt.indirect import chain
    from spaceopt.indirect.shooting import shoot
    from spaceopt.studies import perturbed as P

    pc = _perturbed_config()
    eph = P.ephemeris_path(ROOT / "results", pc["cases"]["e8"]["ephemeris"])
    cases = {}
    for model in PROPAGATION_MODELS:
        tr = P.transfer_from_config(pc, "e8", model, ephemeris=eph, n_rev=revs)
        sh = chain.shooting_for("ot", "eps", tr)
        prm = tr.params()
        z = np.zeros(sh.size)
        z[:5] = 1e-3
        z[sh.kf_index] = tr.delta_L
        z = jnp.asarray(z)
        t0 = time.perf_counter()
        res = jax.block_until_ready(shoot(sh, z, 1.0, prm))
        cases[model] = (sh, z, prm)
        print(json.dumps({"model": model, "first_call_s": time.perf_counter() - t0,
                          "f": np.asarray(res[0]).tolist(), "J": np.asarray(res[1]).tolist(),
                          "xf": np.asarray(prm["xf"]).tolist(),
                          "integration_steps": int(res[3])}), flush=True)
    for line in sys.stdin:
        model = line.strip()
        sh, z, prm = cases[model]
        t0 = time.perf_counter()
        jax.block_until_ready(shoot(sh, z, 1.0, prm))
        print(json.dumps({"model": model, "s": time.perf_counter() - t0}), flush=True)


# ------------------------------------------------------------------ propagation (parent side)

class _Worker:
    def __init__(self, src: Path, revs: float):
        # the caller's XLA_FLAGS, not those spaceopt set in this process: each tree sets its own
        env = {**os.environ, "PYTHONPATH": str(src)}
        env.pop("XLA_FLAGS", None)
        if CALLER_XLA_FLAGS is not None:
            env["XLA_FLAGS"] = CALLER_XLA_FLAGS
        self.p = subprocess.Popen([sys.executable, __file__, "--worker", "--revs", str(revs),
                                   *(["--configfile", *CONFIGFILES] if CONFIGFILES else [])],
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env)
        self.first = {}
        for _ in PROPAGATION_MODELS:
            d = json.loads(self.p.stdout.readline())
            self.first[d["model"]] = d

    def run(self, model: str) -> float:
        self.p.stdin.write(model + "\n")
        self.p.stdin.flush()
        return json.loads(self.p.stdout.readline())["s"]

    def close(self):
        self.p.stdin.close()
        self.p.wait()


def _baseline_tree(rev: str, tmp: Path) -> Path:
    tar = subprocess.run(["git", "-C", str(ROOT), "archive", rev, "src"], check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(tmp)], input=tar, check=True)
    return tmp / "src"


def _agreement(a: dict, b: dict) -> dict:
    """Relative agreement of the final states (elements from the residuals) and the Jacobians."""
    import numpy as np
    fa, fb = np.asarray(a["f"]), np.asarray(b["f"])
    xa = fa[1:6] + np.asarray(a["xf"])
    xb = fb[1:6] + np.asarray(b["xf"])
    Ja, Jb = np.asarray(a["J"]), np.asarray(b["J"])
    jscale = np.maximum(np.max(np.abs(Ja), axis=1, keepdims=True), 1e-300)
    return {"final_elements_max_rel": float(np.max(np.abs(xa - xb) / np.maximum(np.abs(xa), 1e-3))),
            "residual_max_abs": float(np.max(np.abs(fa - fb))),
            "jacobian_max_rel_row": float(np.max(np.abs(Ja - Jb) / jscale)),
            "integration_steps": [a["integration_steps"], b["integration_steps"]]}


def propagation(revs: float, rounds: int, baseline: str | None) -> dict:
    trees = {"current": ROOT / "src"}
    tmp = None
    if baseline:
        tmp = tempfile.TemporaryDirectory(prefix="spaceopt-baseline-")
        trees["baseline"] = _baseline_tree(baseline, Path(tmp.name))
    workers = {}
    for name, src in trees.items():                  # compile one tree at a time (2 cores)
        print(f"[propagation] compiling {name} ({src})", file=sys.stderr, flush=True)
        workers[name] = _Worker(src, revs)
    times = {name: {m: [] for m in PROPAGATION_MODELS} for name in workers}
    for r in range(rounds):
        for m in PROPAGATION_MODELS:
            for name, w in workers.items():
                times[name][m].append(w.run(m))
        print(f"[propagation] round {r + 1}/{rounds}", file=sys.stderr, flush=True)
    out = {"revs": revs, "rounds": rounds, "baseline_rev": baseline, "trees": {},
           "note": "first_call_s includes compilation unless the persistent JAX cache (spaceopt/__init__) "
                   "already held the program; per-rev times are after compilation, min and median over rounds"}
    for name, w in workers.items():
        out["trees"][name] = {}
        for m in PROPAGATION_MODELS:
            ts = times[name][m]
            out["trees"][name][m] = {
                "first_call_s": w.first[m]["first_call_s"], "integration_steps": w.first[m]["integration_steps"],
                "propagation_min_s": min(ts), "propagation_median_s": statistics.median(ts),
                "per_rev_min_s": min(ts) / revs, "per_rev_median_s": statistics.median(ts) / revs}
        w.close()
    if baseline:
        out["speedup_baseline_over_current"] = {}
        out["agreement"] = {}
        for m in PROPAGATION_MODELS:
            ratios = [b / c for b, c in zip(times["baseline"][m], times["current"][m])]
            out["speedup_baseline_over_current"][m] = {
                "paired_median": statistics.median(ratios), "paired_min": min(ratios), "paired_max": max(ratios),
                "of_minima": min(times["baseline"][m]) / min(times["current"][m])}
            out["agreement"][m] = _agreement(workers["current"].first[m], workers["baseline"].first[m])
        tmp.cleanup()
    return out


# ------------------------------------------------------------------ field profile

PROFILE_EVALS = 1000
PROFILE_MODELS = ("unperturbed", "j2", "moon_sun", "g44", "g44_moon_sun")   # moon_sun: added below


def _kernel_count(compiled) -> int:
    """Instructions of the largest non-fused computation (the while body) of a compiled program."""
    import re
    best = 0
    for comp in re.split(r"\n(?=\S)", compiled.as_text()):
        head = comp.split("\n")[0]
        if "fused" in head.split("(")[0] or "{" not in head:
            continue
        n = sum(1 for line in comp.splitlines()[1:]
                if re.match(r"\s*(ROOT )?%?[\w.\-]+ = ", line)
                and not re.search(r" (parameter|constant|get-tuple-element|bitcast|tuple)\(", line))
        best = max(best, n)
    return best


def compiled_field_loop(model, prm: dict, ndir: int, tau: float = 1.0):
    """The integrator's right-hand side of ``model`` (field + ``ndir`` sensitivity columns,
    ``flow.field_with_tangents`` as in ``flow.propagate_with_sensitivities``) at homotopy
    parameter ``tau``, compiled in a loop of PROFILE_EVALS evaluations at a fixed state; returns
    (compiled, args)."""
    import jax
    import jax.numpy as jnp
    from spaceopt.indirect import flow
    from spaceopt.indirect.transfer import datum
    y0 = jnp.concatenate([prm["x0"], jnp.array([0.3, 0.01, 1.0]), 1e-3 * jnp.ones(model.n)])
    Phi = jnp.eye(2 * model.n, ndir) + 0.01
    tt = jnp.zeros(ndir).at[-1].set(1.0)
    tau = datum(tau)

    def loop(y, Phi, prm_):
        def body(i, c):
            y, Phi = c
            gy, dPhi = flow.field_with_tangents(lambda yy, t_: flow.field(model, 0.1 * i, yy, t_, prm_), y, tau,
                                                Phi, tt)
            return y + 1e-9 * gy, Phi + 1e-9 * dPhi
        return jax.lax.fori_loop(0, PROFILE_EVALS, body, (y, Phi))
    return jax.jit(loop).lower(y0, Phi, prm).compile(), (y0, Phi, prm)


def field_profile(rounds: int) -> dict:
    import jax
    from spaceopt.indirect import chain
    from spaceopt.studies import perturbed as P

    pc = _perturbed_config()
    eph = P.ephemeris_path(ROOT / "results", pc["cases"]["e8"]["ephemeris"])
    built = {}
    pc["models"].setdefault("moon_sun", {"third_bodies": ["moon", "sun"], "earth_angle": "era"})
    for name in PROFILE_MODELS:
        tr = P.transfer_from_config(pc, "e8", name, ephemeris=eph, n_rev=5.0)
        sh = chain.shooting_for("ot", "eps", tr)
        t0 = time.perf_counter()
        f, args = compiled_field_loop(sh.model, tr.params(), sh.size)
        built[name] = (f, args, time.perf_counter() - t0, _kernel_count(f))
        print(f"[profile] {name}: {built[name][3]} kernels", file=sys.stderr, flush=True)
    best = {k: math.inf for k in built}
    for _ in range(rounds):
        for k, (f, args, _, _) in built.items():
            t0 = time.perf_counter()
            jax.block_until_ready(f(*args))
            best[k] = min(best[k], (time.perf_counter() - t0) / PROFILE_EVALS * 1e6)
    return {"evals_per_loop": PROFILE_EVALS, "rounds": rounds,
            "models": {k: {"us_per_eval_min": best[k], "kernels": built[k][3], "compile_s": built[k][2]}
                       for k in built}}


# ------------------------------------------------------------------ E8 chain

def e8_chain(n_rev: float, model: str, start=None) -> tuple[dict, object]:
    """One E8 solve at ``n_rev``: the chain from the zero guess (``start`` None), or a warm start
    from a converged solution ``start`` (``studies.perturbed.warm_start``; unperturbed → perturbed
    is the Newton homotopy at the perturbed problem). Returns (record, OT Solution or None)."""
    import numpy as np
    from spaceopt.indirect import chain
    from spaceopt.indirect import hamiltonians as hm
    from spaceopt.studies import perturbed as P

    pc = _perturbed_config()
    eph = P.ephemeris_path(ROOT / "results", pc["cases"]["e8"]["ephemeris"])
    tr = P.transfer_from_config(pc, "e8", model, ephemeris=eph, n_rev=n_rev)
    path = pc["numerics"].get("homotopy_path", "arclength")
    label = f"bench/e8/{model}/n{n_rev:g}"
    rec = {"n_rev": n_rev, "model": model}
    t0 = time.perf_counter()
    try:
        if start is None:
            lp, ot = P.solve_for(tr, label, path=path)
            rec.update(route=f"chain LP -> OT ({path})", lp_stats=_jsonable(lp.stats),
                       jacobian_evaluations=_jacobians(lp.stats) + _jacobians(ot.stats))
        else:
            ot = P.warm_start(start, tr, label, **P.warm_start_kwargs(pc, "e8", model, n_rev=n_rev))
            rec.update(route=f"warm start from the converged {start.transfer.perturbations or 'unperturbed'} "
                             f"OT solution (studies.perturbed.warm_start); wall time excludes that solve",
                       jacobian_evaluations=_jacobians(ot.stats))
    except Exception as exc:                                   # noqa: BLE001 — report, go on
        rec.update(converged=False, error=f"{type(exc).__name__}: {exc}", wall_time_s=time.perf_counter() - t0)
        return rec, None
    rec.update(converged=True, wall_time_s=time.perf_counter() - t0, ot_stats=_jsonable(ot.stats))
    _, ys = chain.dense(ot, samples_per_rev=1)
    yf = np.asarray(ys[-1])
    m_f = float(yf[hm.MASS]) * tr.m0
    rec.update(m_p_kg=tr.m0 - m_f, tof_days=float(yf[hm.TIME]) * tr.tu / 86400.0)
    return rec, ot


def _e8_at_eps_blend(pc: dict, model: str, n_rev: float, sensitivity_rtol: float | None = None):
    """The E8 transfer of ``model`` at ``n_rev`` whose smoothing stops at ε₁ = eps_blend, single
    shooting (the start of the exact route and of the corrector comparison), with the exact map's
    ``sensitivity_rtol`` (None: the case's, where the config sets one, else the residual's)."""
    import dataclasses

    from spaceopt.studies import perturbed as P

    eph = P.ephemeris_path(ROOT / "results", pc["cases"]["e8"]["ephemeris"])
    tr = P.transfer_from_config(pc, "e8", model, ephemeris=eph, n_rev=n_rev)
    return dataclasses.replace(tr, eps_final=tr.eps_blend, path_arcs=1,
                               sensitivity_rtol=tr.sensitivity_rtol if sensitivity_rtol is None else sensitivity_rtol)


def _propellant_and_time(sol) -> dict:
    """m_p (kg) and Δt (days) of an OT solution, from y(K_f) at the end-point tolerances."""
    import jax.numpy as jnp
    from spaceopt.indirect import hamiltonians as hm
    from spaceopt.indirect.shooting import final_state

    yf, _ = final_state(sol.shooting, jnp.asarray(sol.z), 1.0, sol.prm)
    u = sol.transfer.units()
    return {"m_p_kg": (1.0 - float(yf[hm.MASS])) * u["mass_kg"],
            "tof_days": float(yf[hm.TIME]) * u["time_s"] / 86400.0}


def e8_exact_route(n_rev: float, corrector: str | None = None, last_model: str | None = None,
                   sensitivity_rtol: float | None = None) -> dict:
    """The E8 route to the case's last model at ``n_rev`` on the exact bang-bang map
    (:mod:`spaceopt.indirect.exact_switching`), each stage timed: the unperturbed chain from the
    zero guess to ε₁ = eps_blend only (no descent in ε), the exact unperturbed extremal by Newton
    (``chain.to_exact``); then each force model of the route (``perturbed_config.case_route``: each from
    its start model, the case option ``model_from``) by the DAG's warm start
    (``perturbed.warm_start`` with the case's ``model_step``: the first perturbed model switched
    on, each later one by the model blend, single shooting on the exact map); the free-time
    end game of the last model on the exact map (the case's settings, its survey where the
    config has one; its lift across branches needs a smoothing ε and is off). Per stage: wall
    time, Jacobians, m_p, Δt; the route's total; the DAG's artifacts of the same solves where they
    exist (``results/perturbed/e8``) for comparison. ``corrector``: the continuation corrector of
    the chain from the zero guess ('newton' | 'chord', ``ContinuationOptions``; None: the case's,
    ``perturbed_config.case_corrector``, as the DAG's chain takes it); the warm starts
    take the case's ``model_step`` (E8's: J2 in τ with the chord corrector,
    the full model in arclength with truncated-SVD steps).
    ``last_model``: the route stops after that model (no end game unless it is the case's last).
    ``sensitivity_rtol``: the exact map's Jacobians at that looser rtol (``Shooting.sensitivity_rtol``,
    E8's case option); None: the case's (``--configfile``)."""
    from spaceopt.indirect import chain
    from spaceopt.indirect.free_time import MaximumOptions, maximise_final_mass
    from spaceopt.studies import perturbed as P, perturbed_config as C

    pc = _perturbed_config()
    models = C.case_route(pc, "e8", last_model or pc["cases"]["e8"]["models"][-1], n_rev)
    label = f"bench/e8-exact/n{n_rev:g}"
    corrector = corrector or C.case_corrector(pc, "e8")
    options = chain.ContinuationOptions(corrector=corrector)

    def transfer(model):
        return _e8_at_eps_blend(pc, model, n_rev, sensitivity_rtol)

    stages, t_route = {}, time.perf_counter()

    def record(name, sol, t0, jacobians):
        m_p_and_tof = _propellant_and_time(sol)
        stages[name] = {"wall_time_s": time.perf_counter() - t0, "jacobian_evaluations": jacobians, **m_p_and_tof}
        print(f"[{label}] {name}: {stages[name]}", file=sys.stderr, flush=True)

    out = {"n_rev": n_rev, "corrector": corrector, "models": models, "stages": stages,
           "sensitivity_rtol": transfer(models[-1]).sensitivity_rtol}
    try:
        t0 = time.perf_counter()
        lp, smooth = P.solve_for(transfer(models[0]), f"{label}/{models[0]}",
                                 path=pc["numerics"].get("homotopy_path", "arclength"), options=options)
        record(f"{models[0]} chain to eps_blend", smooth, t0, _jacobians(lp.stats) + _jacobians(smooth.stats))
        t0 = time.perf_counter()
        sol = chain.to_exact(smooth, label=f"{label}/{models[0]} exact")
        record(f"{models[0]} exact", sol, t0, _jacobians(sol.stats))
        for model in models[1:]:
            tr, t0 = transfer(model), time.perf_counter()
            sol = P.warm_start(sol, tr, f"{label}/{model}", **P.warm_start_kwargs(pc, "e8", model, n_rev=n_rev))
            sol.transfer = tr
            record(f"{model} exact", sol, t0, _jacobians(sol.stats))
        out["converged"] = True
        if models[-1] == pc["cases"]["e8"]["models"][-1]:
            settings = {**(P.tof_maximum_settings(pc, "e8") or {}), "lift_eps": 0.0}
            t0 = time.perf_counter()
            best, rec = maximise_final_mass(sol, MaximumOptions(label=f"{label} end game", **settings))
            record(f"{models[-1]} end game", best, t0, rec.get("jacobian_evaluations"))
            out.update(end_game_certified=rec.get("certified"), end_game_status=rec.get("status"),
                       end_game_survey=rec.get("survey"))
    except Exception as exc:                                   # noqa: BLE001 — report, go on
        out.update(converged=False, error=f"{type(exc).__name__}: {exc}")
    out["route_wall_time_s"] = time.perf_counter() - t_route
    out["route_jacobian_evaluations"] = sum(r["jacobian_evaluations"] or 0 for r in stages.values())
    out["dag_artifacts"] = _dag_e8(n_rev, models)
    return out


def corrector_comparison(n_rev: float, correctors=CORRECTORS) -> dict:
    """E8 unperturbed LP → OT (the (3.3.1) blend to ε₁, the case's homotopy path) at ``n_rev``
    with each of ``correctors`` (``ContinuationOptions.corrector``), one after the other from the
    same LP solution, both maps (full evaluation and residual alone) compiled beforehand; the
    wall-time ratio of each to the last."""
    import jax.numpy as jnp
    from spaceopt.indirect import chain
    from spaceopt.indirect.shooting import residual, shoot

    pc = _perturbed_config()
    tr = _e8_at_eps_blend(pc, "unperturbed", n_rev)
    path = pc["numerics"].get("homotopy_path", "arclength")
    lp = chain.solve_lp(tr, label=f"bench/corrector/n{n_rev:g}/lp")
    sh = chain.shooting_for("ot", "lp", tr)
    prm = {**tr.params(thrust=tr.thrust), "blend_ref": jnp.asarray(chain.blend_reference(lp))}
    z0 = jnp.asarray(chain.start_vector(sh, lp.doubled_costates(), lp.K_f))
    for fn in (shoot, residual):                                # compile both before timing
        jnp.asarray(fn(sh, z0, 0.0, prm, *chain._path_tolerances(sh))[0]).block_until_ready()
    out = {"n_rev": n_rev, "path": path, "stage": "LP -> OT to eps_blend"}
    for corrector in correctors:
        t0 = time.perf_counter()
        ot = chain.solve_ot(lp, tr.thrust, chain.ContinuationOptions(corrector=corrector),
                            label=f"bench/corrector/n{n_rev:g}/{corrector}", path=path)
        wall = time.perf_counter() - t0
        out[corrector] = {"wall_time_s": wall, "jacobian_evaluations": ot.stats["jacobian_evaluations"],
                          "residual_evaluations": ot.stats["residual_evaluations"], "steps": ot.stats["steps"],
                          "rejected_steps": ot.stats["rejected_steps"], **_propellant_and_time(ot)}
    for corrector in correctors[:-1]:
        out[f"wall_time_ratio_{corrector}_over_{correctors[-1]}"] = (out[corrector]["wall_time_s"]
                                                                     / out[correctors[-1]]["wall_time_s"])
    return out


def chain_rtol_comparison(n_rev: float, rtol: float, rounds: int) -> dict:
    """The unperturbed chain's evaluations at the library's default path rtol (``PATH_RTOL``) and
    at ``rtol`` (a profile's looser ``path_rtol``): the E8 chain from the zero guess to ε₁ at
    ``n_rev`` revolutions (the case's settings), then at its end point a full evaluation (f, ∂f/∂z,
    ∂f/∂τ) and a residual alone (the chord corrector's), side by side in ``rounds`` alternating
    rounds after compilation; the paired median ratios, the integration steps, the largest
    difference of f and ‖J⁻¹ δJ‖₂ (Newton's contraction with the looser Jacobian at best)."""
    import dataclasses

    import jax.numpy as jnp
    from spaceopt.indirect import chain
    from spaceopt.indirect.shooting import residual, shoot
    from spaceopt.indirect.transfer import PATH_RTOL
    from spaceopt.studies import perturbed as P, perturbed_config as C

    pc = _perturbed_config()
    options = chain.ContinuationOptions(corrector=C.case_corrector(pc, "e8"))
    _, ot = P.solve_for(_e8_at_eps_blend(pc, "unperturbed", n_rev), f"bench/chain-rtol/n{n_rev:g}",
                        path=pc["numerics"].get("homotopy_path", "arclength"), options=options)
    sh, z = ot.shooting, jnp.asarray(ot.z)
    tols = {name: chain._path_tolerances(dataclasses.replace(sh, path_rtol=value))
            for name, value in (("default", PATH_RTOL), ("loose", rtol))}
    out = {"n_rev": n_rev, "point": "the chain's OT extremal at eps_blend", "chain_path_rtol": sh.path_rtol,
           "default_path_rtol": tols["default"][0], "path_rtol": tols["loose"][0], "rounds": rounds}
    for kind, fn in (("full", shoot), ("residual", residual)):
        results, times, ratio = _evaluated_side_by_side(lambda name, fn=fn: fn(sh, z, 1.0, ot.prm, *tols[name]),
                                                        "default", "loose", rounds)
        out[kind] = {"wall_time_s": times, "median_ratio_default_over_loose": ratio}
        if kind == "full":
            out.update(_looser_evaluation(results, "default", "loose"))
    return out


def _side_by_side(seconds, a, b, rounds: int) -> tuple[dict, float]:
    """``seconds(name)`` (one timed run) for the names a and b, ``rounds`` rounds with the order
    alternating round by round; the wall times {a: [...], b: [...]} and the paired median ratio
    a / b (the machine is shared and noisy: the per-round ratio is the robust number)."""
    times = {a: [], b: []}
    for i in range(rounds):
        for name in ((a, b) if i % 2 == 0 else (b, a)):
            times[name].append(seconds(name))
    return times, statistics.median(ta / tb for ta, tb in zip(times[a], times[b]))


def _evaluated_side_by_side(evaluate, a, b, rounds: int) -> tuple[dict, dict, float]:
    """``evaluate(name)`` (one JAX evaluation) for the names a and b: each once first (compiled,
    its result kept), then timed side by side, blocked until ready (:func:`_side_by_side`):
    (results {a, b}, wall times, paired median ratio a / b)."""
    import jax

    def timed(name):
        t0 = time.perf_counter()
        out = jax.block_until_ready(evaluate(name))
        return out, time.perf_counter() - t0

    results = {name: timed(name)[0] for name in (a, b)}
    times, ratio = _side_by_side(lambda name: timed(name)[1], a, b, rounds)
    return results, times, ratio


def _looser_evaluation(results: dict, tight: str, loose: str) -> dict:
    """How a looser shooting evaluation (f, ∂f/∂z, ∂f/∂τ, steps, ok) agrees with a tighter one:
    the integration steps of both, the largest difference of f and ‖J⁻¹ δJ‖₂, the rate at which
    Newton with the looser Jacobian converges at best."""
    import numpy as np

    J, J_loose = np.asarray(results[tight][1]), np.asarray(results[loose][1])
    return {"steps": {name: int(results[name][3]) for name in (tight, loose)},
            "max_abs_diff_f": float(np.abs(np.asarray(results[tight][0]) - np.asarray(results[loose][0])).max()),
            "newton_contraction": float(np.linalg.norm(np.linalg.solve(J_loose, J_loose - J), 2))}


def _blend_jacobian_at(n_rev: float):
    """The E8 4×4 → full model blend at ``n_rev`` revolutions from the DAG's 4×4 artifact, on
    its map: (layout, z, data, path tolerances) of its Jacobian at τ = 0.5."""
    import dataclasses

    import jax.numpy as jnp
    from spaceopt.indirect import chain
    from spaceopt.studies import perturbed as P

    pc = _perturbed_config()
    start = P.load(ROOT / "results" / "perturbed" / "e8" / f"g44_n{n_rev:g}.json")
    tr = dataclasses.replace(P.transfer_from_config(
        pc, "e8", "g44_moon_sun", n_rev=n_rev,
        ephemeris=P.ephemeris_path(ROOT / "results", pc["cases"]["e8"]["ephemeris"])), path_arcs=1)
    sh, prm, _ = chain.model_blend(P.warm_start_integration(start, tr), tr.params(thrust=start.thrust_N))
    return sh, jnp.asarray(start.z), prm, chain._path_tolerances(sh)


def sensitivity_comparison(n_rev: float, sensitivity_rtol: float, rounds: int) -> dict:
    """One Jacobian of the E8 4×4 → full blend at τ = 0.5 (``n_rev`` revolutions, the DAG's 4×4
    artifact, which must be on the exact map) with the sensitivities at the path rtol and at
    ``sensitivity_rtol`` (``Shooting.sensitivity_rtol``), side by side: both compiled first, then
    ``rounds`` rounds in alternating order; wall times and their paired median ratio, the steps,
    the largest difference of f (none: both from pass 1) and ‖J⁻¹ δJ‖₂, the rate at which Newton
    with the looser Jacobian converges at best."""
    import dataclasses

    import numpy as np
    from spaceopt.indirect.shooting import shoot

    sh, z, prm, tol = _blend_jacobian_at(n_rev)
    if sh.switching != "exact":
        raise SystemExit(f"--sensitivity-compare {n_rev:g}: the 4x4 artifact is on the {sh.switching} map, "
                         "not the exact one (the study config's E8 makes it; config/e8_smoothed.yaml does not)")
    # both layouts named: on the exact route the blend's own already has a sensitivity_rtol
    layouts = {name: dataclasses.replace(sh, sensitivity_rtol=value)
               for name, value in (("path_rtol", None), ("sensitivity_rtol", sensitivity_rtol))}

    results, times, ratio = _evaluated_side_by_side(lambda name: shoot(layouts[name], z, 0.5, prm, *tol),
                                                    "path_rtol", "sensitivity_rtol", rounds)
    return {"n_rev": n_rev, "map": sh.switching, "path_rtol": tol[0], "sensitivity_rtol": sensitivity_rtol,
            "rounds": rounds, "wall_time_s": times, "median_ratio_path_over_sensitivity": ratio,
            **_looser_evaluation(results, "path_rtol", "sensitivity_rtol"),
            "cond_J": float(np.linalg.cond(np.asarray(results["path_rtol"][1])))}


def threads_comparison(n_rev: float, k: int, rounds: int) -> dict:
    """One Jacobian of the E8 4×4 → full model blend at τ = 0.5 (``n_rev`` revolutions, from the
    DAG's 4×4 artifact and on its map, at the path rtol), with the sensitivity columns in one
    computation and split over ``k`` threads (:mod:`spaceopt.indirect.column_threads`), side by
    side: both compiled first, then ``rounds`` rounds in alternating order; wall times, their
    paired median ratio, and the largest differences of f, ∂f/∂z, ∂f/∂τ and the steps."""
    import jax.numpy as jnp
    from spaceopt.config import THREADS_ENV
    from spaceopt.indirect.shooting import shoot

    sh, z, prm, tol = _blend_jacobian_at(n_rev)
    before = os.environ.get(THREADS_ENV)

    def evaluate(threads):
        os.environ[THREADS_ENV] = str(threads)
        return shoot(sh, z, 0.5, prm, *tol)

    try:
        results, times, ratio = _evaluated_side_by_side(evaluate, 1, k, rounds)
        one, split = results[1], results[k]
    finally:
        os.environ.pop(THREADS_ENV) if before is None else os.environ.__setitem__(THREADS_ENV, before)
    return {"n_rev": n_rev, "threads": k, "map": sh.switching, "rtol": tol[0], "rounds": rounds,
            "wall_time_s": {"1": times[1], str(k): times[k]}, "median_ratio_1_over_k": ratio,
            "max_abs_diff": {name: float(jnp.abs(a - b).max()) for name, a, b in zip(("f", "J", "f_tau"), one, split)},
            "steps": [int(one[3]), int(split[3])]}


def _dag_e8(n_rev: float, models) -> dict:
    """m_p, Δt and wall time of the DAG's E8 artifacts at ``n_rev`` that exist (for comparison)."""
    from spaceopt import artifacts
    out = {}
    for model in models:
        p = ROOT / "results" / "perturbed" / "e8" / f"{model}_n{n_rev:g}.json"
        if p.exists():
            d = artifacts.read_json(p)
            out[model] = {"m_p_kg": d["units"]["mass_kg"] - d["scalars"]["m_f_kg"], "tof_days": d["scalars"]["tof_days"],
                          "wall_time_s": d["provenance"].get("wall_time_s")}
    return out


def _jacobians(stats: dict) -> int:
    return int(stats.get("jacobian_evaluations") or 0)


def _jsonable(d):
    return json.loads(json.dumps(d, default=lambda o: getattr(o, "tolist", lambda: str(o))()))


def published_500() -> dict:
    """The thesis's 500-revolution E8 values (§4.2.2 table) from the published data file."""
    from spaceopt.report.compare import published_lookup
    pub = published_lookup(PUBLISHED)
    return {m: {"m_p_kg": pub[(f"e8_{m}_n500", "propellant_kg")]["value"],
                "tof_days": pub[(f"e8_{m}_n500", "tof_days")]["value"]} for m in MODELS}


def e8_estimates(e8: dict) -> dict:
    """500-rev wall time of each converged E8 route: measured if run at 500, else scaled linearly in
    n from the measured run (the propagation cost is linear in the revolutions; the Jacobian count
    is assumed unchanged). A warm start adds the unperturbed chain it starts from."""
    out = {}
    for key, r in e8.items():
        if not r.get("converged"):
            continue
        wall = r["wall_time_s"]
        if key.endswith("_warm"):
            base = e8.get(f"unperturbed_n{r['n_rev']:g}", {})
            wall = wall + base.get("wall_time_s", math.nan)
        scale = 500.0 / r["n_rev"]
        out[key] = {"wall_time_s": wall * scale,
                    "kind": "measured" if scale == 1.0 else
                    f"extrapolated x{scale:g} from the measured {r['n_rev']:g}-rev run "
                    f"({r['jacobian_evaluations']} Jacobian evaluations, assumed unchanged at 500 rev)"
                    + (" incl. the unperturbed chain it warm-starts from" if key.endswith("_warm") else "")}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--revs", type=float, default=5.0)
    ap.add_argument("--rounds", type=int, default=10)
    ap.add_argument("--baseline", default=None, help="git revision to compare the propagation with")
    ap.add_argument("--e8-revs", type=float, nargs="*", default=[200.0])
    ap.add_argument("--e8-models", nargs="*", default=list(MODELS))
    ap.add_argument("--e8-route", choices=("chain", "warm"), default="chain",
                    help="chain: every model from the zero guess (the DAG's E8 route); warm: later "
                         "models warm-start from the previous model's OT solution at the same n")
    ap.add_argument("--results", default=str(ROOT / "results"))
    ap.add_argument("--out", default=str(ROOT / "results/benchmarks/perturbed.json"))
    ap.add_argument("--skip-propagation", action="store_true")
    ap.add_argument("--skip-e8", action="store_true")
    ap.add_argument("--exact-route", type=float, nargs="*", default=[],
                    help="revolution counts of the E8 route on the exact bang-bang map (e8_exact_route)")
    ap.add_argument("--exact-route-corrector", choices=CORRECTORS, default=None,
                    help="the continuation corrector of the exact route's chain (default: the case's corrector)")
    ap.add_argument("--exact-route-to", default=None, help="the exact route's last model (default: the case's last)")
    ap.add_argument("--exact-route-sensitivity-rtol", type=float, nargs="*", default=[None],
                    help="the exact route's Jacobian rtol (Shooting.sensitivity_rtol); several: one route each")
    ap.add_argument("--sensitivity-compare", type=float, nargs="*", default=[],
                    help="revolution counts of the E8 blend Jacobian on the exact map, the path rtol against "
                         "--sensitivity-rtol (sensitivity)")
    ap.add_argument("--sensitivity-rtol", type=float, default=1e-9)
    ap.add_argument("--corrector-compare", type=float, nargs="*", default=[],
                    help="revolution counts of the E8 LP -> OT path with each of --correctors (corrector)")
    ap.add_argument("--correctors", nargs="+", choices=CORRECTORS, default=list(CORRECTORS),
                    help="the correctors --corrector-compare runs, in this order (ratios to the last)")
    ap.add_argument("--chain-rtol-compare", type=float, nargs="*", default=[],
                    help="revolution counts of the E8 unperturbed chain, its end point's evaluations at the "
                         "default path rtol against --chain-rtol (chain_rtol)")
    ap.add_argument("--chain-rtol", type=float, default=1e-7)
    ap.add_argument("--profile", action="store_true", help="field cost per force model (kernels, us/eval)")
    ap.add_argument("--threads", type=int, default=None,
                    help="SPACEOPT_THREADS for this run: a Jacobian's columns split over this many threads")
    ap.add_argument("--threads-compare", type=float, nargs="*", default=[],
                    help="revolution counts of the E8 blend Jacobian, 1 thread against --threads (default 2)")
    ap.add_argument("--configfile", nargs="+", default=[],
                    help="config profiles over the study config for every part (e.g. config/e8_smoothed.yaml)")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    CONFIGFILES[:] = a.configfile
    if a.worker:
        return _worker(a.revs)
    if a.threads is not None:
        os.environ["SPACEOPT_THREADS"] = str(a.threads)
    out_path = Path(a.out)
    report = json.loads(out_path.read_text()) if out_path.exists() else {}
    report = {k: v for k, v in report.items()
              if k in ("propagation", "e8", "field_profile", "e8_exact_route", "corrector", "threads", "sensitivity",
                       "chain_rtol")}
    report["machine"] = machine_facts(jacobian_threads=int(os.environ.get("SPACEOPT_THREADS", "1")),
                                      configfiles=a.configfile)
    report["measured"] = measured(Path(a.results))
    report["target_s"] = TARGET_S

    def write():
        finish(report["machine"])
        out_path.parent.mkdir(parents=True, exist_ok=True)
        out_path.write_text(json.dumps(report, indent=2) + "\n")

    if a.profile:
        report["field_profile"] = field_profile(a.rounds)
        write()
    if not a.skip_propagation:
        report["propagation"] = propagation(a.revs, a.rounds, a.baseline)
        write()
    if not a.skip_e8:
        report.setdefault("e8", {})
        for n in a.e8_revs:
            prev = None
            for model in a.e8_models:
                warm = a.e8_route == "warm" and prev is not None
                print(f"[e8] {model} n={n:g} {'warm start' if warm else 'chain'}", file=sys.stderr, flush=True)
                rec, sol = e8_chain(n, model, prev if warm else None)
                report["e8"][f"{model}_n{n:g}" + ("_warm" if warm else "")] = rec
                prev = sol if sol is not None else prev
                report["e8_500rev_chain_s"] = e8_estimates(report["e8"])
                report["e8_published_500"] = published_500()
                write()
    for n in a.exact_route:
        for sens in a.exact_route_sensitivity_rtol:
            rec = e8_exact_route(n, a.exact_route_corrector, a.exact_route_to, sens)
            key = f"n{n:g}" + ("" if rec["corrector"] == "newton" else f"_{rec['corrector']}") + \
                (f"_to_{a.exact_route_to}" if a.exact_route_to else "") + \
                (f"_threads{report['machine']['jacobian_threads']}" if report["machine"]["jacobian_threads"] > 1 else "") + \
                (f"_sens{sens:g}" if sens is not None else "") + "".join(f"_{Path(c).stem}" for c in a.configfile)
            report.setdefault("e8_exact_route", {})[key] = rec
            write()
    for n in a.sensitivity_compare:
        report.setdefault("sensitivity", {})[f"n{n:g}"] = sensitivity_comparison(n, a.sensitivity_rtol, a.rounds)
        write()
    for n in a.threads_compare:
        report.setdefault("threads", {})[f"n{n:g}"] = threads_comparison(n, a.threads or 2, a.rounds)
        write()
    for n in a.corrector_compare:
        report.setdefault("corrector", {})[f"n{n:g}"] = corrector_comparison(n, tuple(a.correctors))
        write()
    for n in a.chain_rtol_compare:
        report.setdefault("chain_rtol", {})[f"n{n:g}"] = chain_rtol_comparison(n, a.chain_rtol, a.rounds)
        write()
    write()
    print(json.dumps(report, indent=2), file=sys.stderr)


if __name__ == "__main__":
    main()
