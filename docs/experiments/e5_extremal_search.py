"""Search for other E5 unperturbed OT extremals (docs/e5-extremals.md).

The published unperturbed E5 (Table 4.2.1.2: m_f 955.257738 kg, Δt 60.669362 d, a burn at the
start) is not the extremal our chain reaches (956.128311 kg, 60.472112 d, a coast at the start).
Each experiment here tries to reach another extremal of the same problem and prints m_f, Δt,
K_f, whether the engine is on at K = 0 and the number of burn arcs:

  multistart SEED SIGMA N   Newton homotopy (ε₁ → ε_f) from our costates × (1 + SIGMA·N(0, 1)),
                            p_LK (≈ 0 in ours) + 10⁻⁵·N(0, 1)
  foldjump W_REF[,S] …      LP → OT blend (3.3.1) in τ up to its fold, then the Newton homotopy
                            at the OT problem from the last point of the path (a jump over the fold);
                            S scales the LP costates the blend starts from (default 2: the doubling
                            of spec 01 §3.3 erratum (a); the Newton homotopy absorbs any mismatch)
  l0 L0_DEG …               chain at another L₀ (L_f = L₀ + 1800°), then continued in L₀ to 160°
  variant NAME …            other readings of Table 4.2.1.1 (final_lonperi: ω_f = 90° − Ω_f;
                            earth_radius: altitudes over R = 6378.137 km instead of 6371 km)
  printed BEST              the printed unperturbed costates as a direction, z = c·(d·p_p, p_ex,
                            p_ey, p_ix, p_iy, p_LK, p_m), K_f printed: the residual on a grid of
                            the two unknown scales (c: cost unit, d: length-unit ratio), then the
                            Newton homotopy from the BEST grid points
  printed_fit COLUMN[:MODEL] C D [E]
                            the printed costates of COLUMN (unperturbed or g44_moon_sun) at the
                            units that fit MODEL's problem (default: COLUMN's) best: least squares
                            over the scales (c, d and, perturbed, e for p_t) from (C, D, E), then
                            Levenberg-Marquardt in all unknowns at ε_f from there; prints both
                            residuals and the landing point (fifty-sixth session;
                            g44_moon_sun:unperturbed, the perturbed column in the unperturbed
                            problem without its p_t: sixty-third session)
  printed_typo C D          is one printed unperturbed entry a misprint? printed_fit's fit of
                            (c, d) from (C, D) with one entry (or K_f) free, each in turn
                            (sixty-third session)
  thrust T …                chain at thrust T, then continued in the thrust to 0.5 N
  isp ISP_S …               ours continued in the specific impulse to each ISP_S in turn
                            (sixty-third session)
  smoothing EPS …           ours continued upwards in ε (is the published one a smoothed solution?)
  neighbour DATE …          perturbed (4×4 + Moon + Sun): the E6 scan's extremal of DATE
                            (results/perturbed/e6/DATE.json) continued in the departure epoch to
                            9 May, the E6 neighbour route (does a neighbouring family reach the
                            published perturbed 9 May extremal?)

Run from the repository root after ``./dev reproduce`` has written results/perturbed/e5/:
``.venv/bin/python docs/experiments/e5_extremal_search.py multistart 0 0.3 8``.
"""
import dataclasses
import json
import math
import sys

import jax
import jax.numpy as jnp
import numpy as np
import yaml

jax.config.update("jax_enable_x64", True)
from spaceopt.errors import ConvergenceError  # noqa: E402
from spaceopt.indirect import chain, hamiltonians as hm, shooting as S  # noqa: E402
from spaceopt.indirect.continuation import ContinuationOptions  # noqa: E402
from spaceopt.studies import perturbed as P  # noqa: E402

QUIET = ContinuationOptions(verbose=False)
PC = yaml.safe_load(open("config/studies/perturbed.yaml"))["perturbed"]
TR = P.transfer_from_config(PC, "e5", "unperturbed")
SH = chain.shooting_for("ot", "eps", TR)
PRM = TR.params(thrust=TR.thrust)


def report(sol, tag):
    _, y = chain.dense(sol, 100)
    burning = np.diff(y[:, hm.MASS]) < -1e-9
    arcs = int(np.sum(np.diff(burning.astype(int)) == 1) + burning[0])
    print(f"{tag}: m_f={y[-1, hm.MASS] * sol.transfer.m0:.6f} kg  dt={y[-1, hm.TIME] * sol.transfer.tu / 86400:.6f} d  "
          f"K_f={math.degrees(sol.K_f):.4f} deg  burn_at_start={bool(burning[0])}  arcs={arcs}  "
          f"z={np.round(sol.z, 6).tolist()}", flush=True)


def solve_from(z0, tag):
    try:
        z, _ = chain._run(SH, np.asarray(z0, float), PRM, tag, QUIET, "tau")
        report(chain.Solution("ot", SH, z, PRM, TR, {}, thrust_N=TR.thrust), tag)
    except ConvergenceError as exc:
        print(f"{tag}: no convergence ({exc})", flush=True)


def multistart(seed, sigma, n):
    z_ours = np.asarray(json.load(open("results/perturbed/e5/unperturbed.json"))["z"])
    rng = np.random.default_rng(int(seed))
    for k in range(int(n)):
        z0 = z_ours.copy()
        z0[:-1] *= 1.0 + float(sigma) * rng.standard_normal(z0.size - 1)
        z0[SH.unknown_names().index("p_LK")] += 1e-5 * rng.standard_normal()
        solve_from(z0, f"start {k}")


def foldjump(*specs):
    lp = chain.solve_lp(TR, QUIET, label="lp")
    sh = chain.shooting_for("ot", "lp", TR)
    for spec in specs:
        w_ref, scale = (list(map(float, spec.split(","))) + [2.0])[:2]
        costates = {k: scale * v for k, v in lp.costates().items()}
        tag = f"W_ref={w_ref:g} S={scale:g}"
        try:
            z, _ = chain._run(sh, chain.start_vector(sh, costates, lp.K_f),
                              {**PRM, "blend_ref": jnp.asarray(w_ref)}, "blend", QUIET, "tau")
            print(f"{tag}: the blend reached tau = 1 (no fold)", flush=True)
        except ConvergenceError as exc:
            print(f"{tag}: the blend stops at tau = {exc.diagnosis['tau']:.6f}", flush=True)
            z = np.asarray(exc.diagnosis["z"])
        solve_from(z, f"{tag}, after the fold")


def l0(*l0_deg):
    for deg in map(float, l0_deg):
        tr = dataclasses.replace(TR, L0_deg=deg)
        try:
            _, ot = P.solve_for(tr, f"L0={deg:g}", path="tau", options=QUIET, route="lp-tmin-ot")
            report(ot, f"L0={deg:g}")
            sol = chain.continue_in_params(ot, PRM, None, label=f"L0 {deg:g} -> {TR.L0_deg:g}", path="arclength")
            report(dataclasses.replace(sol, transfer=TR, thrust_N=TR.thrust), f"L0={deg:g} -> {TR.L0_deg:g}")
        except ConvergenceError as exc:
            print(f"L0={deg:g}: no convergence ({exc})", flush=True)


def variant(*names):
    def over(R, o, hp, ha):                         # the same altitudes over another Earth radius
        a = R + (hp + ha) / 2
        return dataclasses.replace(o, a=a, e=(ha - hp) / (2 * a))
    r_e = 6378137.0
    readings = {"final_lonperi": {"final": dataclasses.replace(TR.final, argp=(90.0 - TR.final.raan) % 360.0)},
                "earth_radius": {"initial": over(r_e, TR.initial, 500e3, 600000e3),
                                 "final": over(r_e, TR.final, 20000e3, 250000e3)}}
    for name in names:
        tr = dataclasses.replace(TR, **readings[name])
        try:
            report(P.solve_for(tr, name, path="tau", options=QUIET, route="lp-tmin-ot")[1], name)
        except ConvergenceError as exc:
            print(f"{name}: no convergence ({exc})", flush=True)


def printed_column(model, sh):
    """The printed costates and K_f of Table 4.2.1.2's column for ``model``, in the order of
    ``sh``'s unknowns (the perturbed column's p_t is dropped where ``sh`` has none)."""
    pub = yaml.safe_load(open("config/published/yun2023_perturbed.yaml"))
    costates = pub["printed_costates"][f"e5_{model}"]
    value = dict(zip(costates["order"], costates["value"]))
    names = [n for n in sh.unknown_names() if n != "K_f"]
    assert set(names) <= set(value)
    K_f = math.radians(next(r["value"] for r in pub["values"]
                            if r["case"] == f"e5_{model}" and r["quantity"] == "K_f_deg"))
    return np.array([value[n] for n in names]), K_f


def scaled_start(sh, z_pub, K_f, c, d, e=None):
    """z = c·(d·p_p, …, e·p_t, …, p_m), K_f: c the cost unit, d the length-unit ratio (p_p scales
    with the length unit), e the time-unit ratio of p_t (perturbed column only)."""
    z = c * z_pub
    z[0] *= d
    if e is not None:
        z[sh.unknown_names().index("p_t")] *= e
    return np.append(z, K_f)


def printed(best):
    z_pub, K_f = printed_column("unperturbed", SH)

    def start(c, d):
        return scaled_start(SH, z_pub, K_f, c, d)
    grid = [(c, d) for c in np.logspace(-1.5, 1.5, 41) for d in np.logspace(-1.5, 0.7, 45)]
    residual = jax.jit(jax.vmap(lambda z: S.residual(SH, z, 1.0, PRM, 1e-9, 1e-10)))
    f, ok = residual(jnp.asarray([start(c, d) for c, d in grid]))
    size = np.where(np.asarray(ok), np.linalg.norm(np.asarray(f)[:, 1:7], axis=1), np.inf)
    for k in np.argsort(size)[:int(best)]:
        c, d = grid[k]
        print(f"c={c:.4g} d={d:.4g}: |f_elements| = {size[k]:.3e}", flush=True)
        solve_from(start(c, d), f"c={c:.4g} d={d:.4g}")


def shooter(sh, prm):
    """f and J of the OT shooting map at ε_f, one propagation per point (the last one kept);
    f = 1e3 in every row where the propagation fails."""
    shot = {}

    def evaluate(z):
        key = z.tobytes()
        if key not in shot:
            shot.clear()
            shot[key] = S.shoot(sh, jnp.asarray(z), 1.0, prm)
        f, J, _, _, ok = shot[key]
        return (np.asarray(f), np.asarray(J)) if bool(ok) else (np.full(z.size, 1e3), None)
    return evaluate


def printed_fit(column, *scales):
    from scipy.optimize import least_squares
    column, _, model = column.partition(":")
    model = model or column
    tr = P.transfer_from_config(PC, "e5", model, ephemeris=None if model == "unperturbed" else
                                P.ephemeris_path("results", PC["cases"]["e5"]["ephemeris"]))
    sh, prm = chain.shooting_for("ot", "eps", tr), tr.params(thrust=tr.thrust)
    z_pub, K_f = printed_column(column, sh)
    evaluate = shooter(sh, prm)
    fit = least_squares(lambda q: evaluate(scaled_start(sh, z_pub, K_f, *np.exp(q)))[0],
                        np.log(np.asarray(scales, float)), diff_step=1e-4, max_nfev=300)
    tag = column if column == model else f"{column} column in the {model} problem"
    print(f"{tag}: scales (c, d[, e]) = {np.round(np.exp(fit.x), 6).tolist()}, length unit "
          f"{tr.du / np.exp(fit.x[1]) / 1e3:.0f} km: |f| = {np.linalg.norm(fit.fun):.3e}", flush=True)
    lm = least_squares(lambda z: evaluate(z)[0], scaled_start(sh, z_pub, K_f, *np.exp(fit.x)),
                       jac=lambda z: evaluate(z)[1], method="lm", x_scale="jac",
                       xtol=1e-14, ftol=1e-14, gtol=1e-14, max_nfev=400)
    print(f"{tag}: Levenberg-Marquardt from there: |f| = {np.linalg.norm(lm.fun):.3e}", flush=True)
    report(chain.Solution("ot", sh, lm.x, prm, tr, {}, thrust_N=tr.thrust), f"{tag}, printed at fitted units")


def printed_typo(c, d):
    """Is one entry of the printed unperturbed column a misprint? For each entry in turn (the
    costates, then K_f) the fit of printed_fit, with that entry free beside (c, d), from (C, D)
    and the printed value times 1, −1, ½ and 2 (K_f: the printed value); prints the best |f| and
    its rows. A misprint would show as one entry whose freeing drops |f| far below the 0.41 of the
    printed column at its fitted units (the perturbed column: 2.4e-2)."""
    from scipy.optimize import least_squares
    z_pub, K_f = printed_column("unperturbed", SH)
    names = [n for n in SH.unknown_names() if n != "K_f"] + ["K_f"]
    evaluate = shooter(SH, PRM)
    for k, name in enumerate(names):
        def start(q):
            z, kf = z_pub.copy(), K_f
            if name == "K_f":
                kf = q[2]
            else:
                z[k] = q[2]
            return scaled_start(SH, z, kf, math.exp(q[0]), math.exp(q[1]))
        printed_value = K_f if name == "K_f" else z_pub[k]
        fits = [least_squares(lambda q: evaluate(start(q))[0],
                              [math.log(float(c)), math.log(float(d)), printed_value * m],
                              diff_step=1e-5, max_nfev=200)
                for m in ((1.0,) if name == "K_f" else (1.0, -1.0, 0.5, 2.0))]
        best = min(fits, key=lambda fit: fit.cost)
        print(f"{name} free: |f| = {np.linalg.norm(best.fun):.3e} at c {math.exp(best.x[0]):.4g}, "
              f"d {math.exp(best.x[1]):.4g}, value {best.x[2]:.6g} (printed {printed_value:.6g}); "
              f"rows {np.round(best.fun, 4).tolist()}", flush=True)


def thrust(*thrust_N):
    for T in map(float, thrust_N):
        try:
            _, ot = P.solve_for(dataclasses.replace(TR, thrust=T), f"T={T:g}", path="tau", options=QUIET,
                                route="lp-tmin-ot")
            report(ot, f"T={T:g}")
            sol = chain.continue_in_params(ot, PRM, QUIET, label=f"T {T:g} -> {TR.thrust:g}", path="arclength")
            report(dataclasses.replace(sol, transfer=TR, thrust_N=TR.thrust), f"T={T:g} -> {TR.thrust:g}")
        except ConvergenceError as exc:
            print(f"T={T:g}: no convergence ({exc})", flush=True)


def smoothing(*eps):
    _, sol = P.solve_for(TR, "ours", path="tau", options=QUIET, route="lp-tmin-ot")
    for e in map(float, eps):
        try:
            sol = chain.smoothing_to(sol, e, QUIET, label=f"eps {e:g}")
            report(sol, f"eps={e:g}")
        except ConvergenceError as exc:
            print(f"eps={e:g}: no convergence ({exc})", flush=True)
            break


def isp(*isp_s):
    """Ours continued in the specific impulse (the exhaust velocity c of the shooting data) to
    each ISP_S in turn, in arclength: does the Isp that gives the published m_f also give its Δt
    and K_f (was the published column solved with another Isp than the case's 1520 s)?"""
    _, sol = P.solve_for(TR, "ours", path="tau", options=QUIET, route="lp-tmin-ot")
    report(sol, f"Isp={TR.isp:g}")
    for value in map(float, isp_s):
        tr = dataclasses.replace(TR, isp=value)
        try:
            sol = dataclasses.replace(chain.continue_in_params(sol, tr.params(thrust=tr.thrust), QUIET,
                                                               label=f"Isp {value:g}", path="arclength"),
                                      transfer=tr)
            report(sol, f"Isp={value:g}")
        except ConvergenceError as exc:
            print(f"Isp={value:g}: no convergence ({exc})", flush=True)
            break


def neighbour(*dates):
    tr = P.transfer_from_config(PC, "e5", "g44_moon_sun",
                                ephemeris=P.ephemeris_path("results", PC["cases"]["e5"]["ephemeris"]))
    for date in dates:
        try:
            sol = P.warm_start(P.load(f"results/perturbed/e6/{date}.json"), tr, f"{date} -> 9 May",
                               **P.warm_start_kwargs(PC, "e5", "g44_moon_sun"))
            report(sol, f"from {date}")
        except ConvergenceError as exc:
            print(f"from {date}: no convergence ({exc})", flush=True)


if __name__ == "__main__":
    {"multistart": multistart, "foldjump": foldjump, "l0": l0, "variant": variant, "printed": printed,
     "printed_fit": printed_fit, "printed_typo": printed_typo, "thrust": thrust, "isp": isp, "smoothing": smoothing,
     "neighbour": neighbour}[sys.argv[1]](*sys.argv[2:])
