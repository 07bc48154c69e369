"""Study D4 (orbit_correction rule): dt inference, zonotopes, MP and DP solutions, timings, figures."""
import csv
import sys
import time
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _step import run_step  # noqa: E402

from spaceopt.artifacts import provenance, write_json, write_npz  # noqa: E402
from spaceopt.discrete import zonotope_control as zc  # noqa: E402
from spaceopt.report.compare import published_lookup  # noqa: E402
from spaceopt.report.figures import save_figure  # noqa: E402


def _csv(path, rows, columns):
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=columns, lineterminator="\n", extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: (repr(v) if isinstance(v, float) else v) for k, v in r.items()})


def _md(rows, columns, fmt="{:.5e}"):
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    for r in rows:
        lines.append("| " + " | ".join(fmt.format(r[c]) if isinstance(r.get(c), float) else str(r.get(c, ""))
                                       for c in columns) + " |")
    return "\n".join(lines) + "\n"


def study(smk):
    cfg, out = dict(smk.params.cfg), smk.output
    t0 = time.perf_counter()
    pub = published_lookup(smk.input.published)
    res = zc.run_study(cfg, zc.published_mp_tables(pub, cfg["controls"]))
    _csv(out.table, zc.table_rows(res), ["method", "control", "k", "x1", "x2", "x3", "u1", "u2", "u3"])
    sols = res["solutions"]
    _csv(out.n_min, [{"control": c, "method": m, "n_min_original_steps": s.n_min_original,
                      "n_min_method_steps": s.n_min, "step_kind": "regrouped" if m == "maximum_principle" else "original",
                      "gauge_x0": s.gauges[-1], "dt": res["dt"]} for (m, c), s in sols.items()],
         ["control", "method", "n_min_original_steps", "n_min_method_steps", "step_kind", "gauge_x0", "dt"])
    rows = []
    for (m, c), t in res["timing"].items():
        maple = pub.get((f"d4_time_{c}", f"{m}_s"), {}).get("value")
        rows.append({"control": c, "method": m, "ours_median_s": t["median_s"], "ours_min_s": t["min_s"],
                     "ours_max_s": t["max_s"], "ours_median_cpu_s": t["median_cpu_s"], "repeats": t["repeats"], "maple_2019_s": maple,
                     "speedup": (maple / t["median_s"]) if maple else ""})
    _csv(out.timing, rows, ["control", "method", "ours_median_s", "ours_min_s", "ours_max_s", "ours_median_cpu_s",
                            "repeats",
                            "maple_2019_s", "speedup"])
    md = [f"# D4: time-optimal discrete orbit correction (dt = {res['dt']:g})\n"]
    trows = zc.table_rows(res)
    for (m, c), sol in sols.items():
        md.append(f"\n## {m.replace('_', ' ')}, {c} control ({sol.n_min} "
                  f"{'regrouped' if m == 'maximum_principle' else 'original'} steps)\n\n")
        md.append(_md([r for r in trows if r["method"] == m and r["control"] == c],
                      ["k", "x1", "x2", "x3", "u1", "u2", "u3"]))
    md.append("\n## N_min (original steps)\n\n")
    md.append(_md([{"control": c, "method": m, "N_min": s.n_min_original} for (m, c), s in sols.items()],
                  ["control", "method", "N_min"]))
    md.append("\n## Computing time (s): ours (median of repeats) and Maple 2019 (published)\n\n")
    md.append(_md(rows, ["control", "method", "ours_median_s", "ours_median_cpu_s", "maple_2019_s"], "{:.4g}"))
    Path(out.markdown).write_text("".join(md))
    for name, fig in zc.figures(res, cfg).items():
        save_figure(fig, Path(smk.params.figdir) / f"orbit_correction_{name}.png")
    arrays = {}
    for (m, c), s in sols.items():
        arrays[f"x_{m}_{c}"], arrays[f"u_{m}_{c}"], arrays[f"w_{m}_{c}"] = s.x, s.u, s.w
    for (c, n), z in res["zonotopes"].items():
        arrays[f"zonotope_vertices_{c}_N{n}"] = z["vertices"]
    write_npz(out.npz, **arrays)
    fit = res["dt_fit"]
    payload = {
        "study": "orbit_correction", "units": "nondimensional (unit orbit radius, unit angular rate)",
        "dt": res["dt"],
        "dt_inference": None if fit is None else {
            "method": "least squares over dt of x(k+1) - A(k; dt) x(k) - u(k) on the published MP tables "
                      "(A(even) = At^2, A(odd) = At), grid scan then bounded Brent, rounded to round_to",
            "dt_least_squares": fit["dt"], "rms_residual": fit["rms"], "per_control": fit["per_control"],
            "rms_per_table": fit["rms_per_table"], "dt_used": fit["dt_rounded"],
            "rms_at_dt_used": fit["rms_at_rounded"]},
        "solutions": {f"{m}|{c}": {"n_min": s.n_min, "n_min_original": s.n_min_original, "alpha": s.alpha,
                                   "gauges": s.gauges, "x": s.x, "u": s.u, "w": s.w,
                                   "membership_gauges": res["membership"][(m, c)],
                                   "wall_time_s": s.wall_time_s, "extra": s.extra}
                      for (m, c), s in sols.items()},
        "timing": {f"{m}|{c}": t for (m, c), t in res["timing"].items()},
        "zonotopes": {f"{c}|N{n}": {"n_vertices": len(z["vertices"]), "gauge_x0": z["gauge_x0"]}
                      for (c, n), z in res["zonotopes"].items()},
        "reproduced": {f"{c}|{q}": v for (c, q), v in zc.reproduced_numbers(res).items()},
        "reproduction_notes": {f"{c}|{q}": v for (c, q), v in zc.reproduction_notes(res).items()},
        "solver": {"lp": "scipy.optimize.linprog (HiGHS)", "hull": "scipy.spatial.ConvexHull (Qhull)",
                   "gauge_of_ball_sums": "scipy.optimize.minimize (BFGS)"},
        "provenance": provenance(cfg, time.perf_counter() - t0),
    }
    write_json(out.json, payload, companions={"arrays": out.npz})
    print(f"D4 done in {time.perf_counter() - t0:.2f} s, dt = {res['dt']}")


def main(smk):
    with open(smk.log[0], "w") as log, redirect_stdout(log), redirect_stderr(log):
        study(smk)


if __name__ == "__main__":
    run_step(main, snakemake)  # noqa: F821
