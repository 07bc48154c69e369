"""D3 step: Bellman/HJB stabilisation of the angular momentum (spec 05-discrete.md §D3).

Snakemake script: params.cfg (the bellman config section), params.figdir; input.published;
outputs: points (V(t) at the published points), sup (p(t)), json, arrays, reproduction, figures.
All numerics in spaceopt.discrete.bellman.
"""
import csv
import sys
import time
from contextlib import redirect_stderr
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

import numpy as np  # noqa: E402

from spaceopt.artifacts import provenance, write_json, write_npz  # noqa: E402
from spaceopt.discrete import bellman as bm  # noqa: E402
from spaceopt.errors import ConfigError  # noqa: E402
from spaceopt.report.compare import compare, write_rows  # noqa: E402
from spaceopt.report.figures import save_figure  # noqa: E402


def _write_csv(path, header, rows):
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(header)
        for r in rows:
            w.writerow([repr(float(x)) for x in r])


def main(sm):
    t_start = time.time()
    cfg = sm.params.cfg
    figdir = Path(sm.params.figdir)
    p = bm.params_from_config(cfg)
    points = cfg["points"]
    sol = bm.solve(p)
    mono = bm.monotonicity_report(sol)
    names = sorted(points)
    V = {n: bm.value_at(sol, p, points[n]) for n in names}
    _write_csv(sm.output.points, ["t_s"] + [f"V_{n}" for n in names],
               zip(sol["t"], *[V[n] for n in names]))
    sup = bm.sup_on_slice(sol, p, 0.0)
    _write_csv(sm.output.sup, ["t_s", "p_sup_V_wx0"], zip(sol["t"], sup))

    save_figure(bm.plot_points(sol["t"], {f"{n} (wx, wy, wz) = {tuple(points[n])}": V[n] for n in names},
                               "V(t) at the published points (equal by the symmetry wy,wz -> -wy,-wz)"),
                figdir / "bellman_points.png")
    save_figure(bm.plot_sup(sol["t"], sup, "p(t) = sup over (wy, wz) of V(t, 0, wy, wz)"),
                figdir / "bellman_sup.png")

    # closed loop on a longer horizon (V recomputed on [0, closed_loop.horizon_s])
    cl = cfg["closed_loop"]
    pc = bm.params_from_config(cfg, horizon_s=float(cl["horizon_s"]))
    solc = bm.solve(pc)
    runs, cl_out = {}, {}
    for s in cl["starts"]:
        if isinstance(s, str):
            if s not in points:
                raise ConfigError("bellman.closed_loop.starts", s, "not a name in bellman.points")
            label, w0 = s, points[s]
        else:
            label, w0 = f"w0 = {tuple(s)}", s
        r = bm.closed_loop(solc, pc, w0, float(cl["grad_zero_tol"]), float(cl["rtol"]))
        runs[label] = r
        cl_out[label] = {"w0": list(map(float, w0)), "V0": float(bm.value_at(solc, pc, w0)[0]),
                         "max_abs_w": r["max_abs_w"], "stays_in_Q": r["stays_in_Q"],
                         "w_final": r["w"][-1]}
    save_figure(bm.plot_closed_loop(runs, pc), figdir / "bellman_closed_loop.png")
    tc = float(cl["horizon_s"])
    save_figure(bm.plot_level_sets([(sol, p, cfg["level_set_times_s"]),
                                    (solc, pc, [0.0, 0.5 * tc, tc - pc.dt])], cfg["level_set_levels"]),
                figdir / "bellman_level_sets.png")

    i0 = bm.node_index(p, (0.0, 0.0, 0.0))[0]
    write_npz(sm.output.arrays, t_s=sol["t"], axis_rad_s=sol["axis"], V_wx0=sol["V"][:, i0],
              V_t0=sol["V"][0], **{f"closed_loop_{k}_w": r["w"] for k, r in zip("abcdefgh", runs.values())})

    # reproduction rows (D3 part of the published file): V at t = 1 s at both points
    k1 = int(np.argmin(np.abs(sol["t"] - 1.0)))
    sym = float(np.max(np.abs(sol["V"] - sol["V"][:, :, ::-1, ::-1])))
    why = (f"max |V(t,wx,wy,wz) - V(t,wx,-wy,-wz)| = {sym:.1e}: the stated equation is invariant "
           "under (wx,wy,wz) -> (wx,-wy,-wz), which maps point 1 onto point 2, so V must be equal "
           "at both points (erratum: the published 1 vs 0.9 cannot both hold; likely a "
           "non-symmetric discretisation in the source)")
    ours = {("d3_point1", "V_at_t_1s"): float(V["point1"][k1]), ("d3_point2", "V_at_t_1s"): float(V["point2"][k1])}
    note = (f"Q in rad/s, V(T={p.horizon:g} s) = 1 on closed Q, V = 0 outside Q (absorbing); "
            f"V(0) = {V['point1'][0]:.10f} at both points; ")
    rows = [r for r in compare(sm.input.published, ours,
                               {k: note + why for k in ours}) if r["case"].startswith("d3_")]
    write_rows(sm.output.reproduction, rows)

    payload = {
        "study": "bellman", "units": "w in rad/s, t in s, V dimensionless (probability)",
        "choices": {"q_units": cfg["q_units"], "exit": cfg["exit"],
                    "domain_half_width_rad_s": p.domain_half_width, "Q_closed": True},
        "grid": {"nodes_per_axis": len(sol["axis"]), "h_rad_s": p.h, "dt_s": p.dt, "horizon_s": p.horizon},
        "monotonicity": mono, "symmetry_max_abs_diff": sym,
        "V_points": {n: {"t0": float(V[n][0]), "t_1s": float(V[n][k1])} for n in names},
        "p_sup_t0": float(sup[0]), "closed_loop": cl_out,
        "provenance": provenance(cfg, time.time() - t_start),
    }
    write_json(sm.output.json, payload, companions={"arrays": sm.output.arrays})
    print(f"D3: done in {time.time() - t_start:.1f} s", file=sys.stderr)


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as _log, redirect_stderr(_log):  # noqa: F821
        run_step(main, snakemake)  # noqa: F821
