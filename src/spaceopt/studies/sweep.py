"""Minimum-thrust sweep of dissertation §4.1 E3 (Tables 4.1.1–4.1.2, Figs. 4.1.6–4.1.7).

One T_min solution (spec 02-multirev §2.5, unknowns z = (p_p, p_ex, p_ey, p_ix, p_iy, p_LK, p_m,
K_f, T)) per cell (L₀, n_rev), ΔL = 360° n_rev, fixed L₀, free time. Every cell comes from the
zero guess through the LP → T_min chain (:mod:`spaceopt.indirect.chain`) or from cells solved
before it in the same sweep — never from a hand-given or published guess. Three ways to a cell:

* ``cold``: LP from z = 0, K_f = ΔL, then LP → T_min (≈ 50–75 Jacobian evaluations).
* ``march`` (along L₀ inside a row): the tangent dz/dL₀ = −J⁻¹ ∂f/∂L₀ comes free with the last
  Newton evaluation of the previous cell (the 'param' homotopy moves L₀ and L_f together, so its
  τ column is ∂f/∂L₀ times the step); with the tangent of the cell before that, the predictor is
  second order, z(L₀+h) ≈ z + h z' + ½h²(z' − z'₋)/h₋. Newton at the cell's own data follows
  (≈ 2–4 evaluations for a 10° step).
* ``scale`` (along n, from earlier rows at the same L₀): the hyperbolic law of §4.1 —
  T_min·n ≈ const — extends to the costates: measured from 20 to 50 revolutions, the orbit
  costates, p_m and T scale as n⁻¹, p_LK as n⁻² and K_f − ΔL stays put. With one earlier row these
  exponents are used; with two, each component is extrapolated by the power law through both
  rows (log-log), K_f − ΔL linearly in 1/n. Newton at the cell's data follows.

A Newton that does not contract falls back, in this order, to L₀ substeps (the step halved, down
to ``max_bisections`` levels), to Newton from the solved cell 360° away when there is one (the
problem is 2π-periodic in L₀), to the parameter continuation
(:func:`spaceopt.indirect.chain.continue_in_params`) from the previous cell of the row and
finally to the cold chain; each cell records the way it was obtained. Integration length is
capped at ``max_steps_per_rev``·n steps so that a bad iterate fails fast instead of running to the
default 400 000 steps (measured: one 50° L₀ step at 2 revolutions took 300 s that way).

Batching several cells with ``jax.vmap`` was measured and not kept: a 12-cell batch of 20-rev
T_min propagations cost 4.6 s against 12 × 0.6 s = 7.2 s one by one (1.6×), not enough to pay
for a batched Newton with per-cell step control; Snakemake runs independent rows on both cores.
"""
from __future__ import annotations

import dataclasses
import math
import time

import jax.numpy as jnp
import numpy as np

from ..errors import ConfigError, ConvergenceError
from ..indirect import chain
from ..indirect import hamiltonians as hm
from ..indirect.continuation import ContinuationOptions
from ..indirect.flow import Model
from ..indirect.shooting import Shooting, final_state, shoot
from ..indirect.transfer import Transfer, step_cap
from ..constants import DAY
from . import multirev_config

TMIN_PARAM = Model("tmin", "param")
CELL_COLUMNS = ["L0_deg", "n_rev", "T_min_N", "tof_days", "m_f_kg"]


# ---------------------------------------------------------------- problem data

def cell_transfer(mr: dict, sw: dict, L0_deg: float, n_rev: float) -> Transfer:
    """The Transfer of one sweep cell: orbits, spacecraft, constants from ``multirev``."""
    case = {"initial": sw["initial"], "final": sw["final"], "L0_deg": float(L0_deg), "n_rev": float(n_rev)}
    return multirev_config.transfer_from_config({**mr, "cases": {"sweep_cell": case}}, "sweep_cell")


def max_steps_for(numerics: dict, n_rev: float) -> int:
    """Integration-step cap of a cell (:func:`~spaceopt.indirect.transfer.step_cap`)."""
    return step_cap(n_rev, numerics["max_steps_per_rev"], numerics["min_max_steps"])


def shooting(numerics: dict, n_rev: float) -> Shooting:
    """T_min shooting with problem data on a 'param' path (L₀ and L_f may move)."""
    free = chain.ORBIT_COSTATES + (hm.MASS,)
    return Shooting(TMIN_PARAM, free, max_steps=max_steps_for(numerics, n_rev))


def path_params(prm_from: dict, prm_to: dict) -> dict:
    """Data of ``prm_to`` with L₀ and L_f on a linear path from ``prm_from`` (τ = 0) to it (τ = 1)."""
    return {**prm_to, "path_from": {k: prm_from[k] for k in ("L0", "Lf")},
            "path_to": {k: prm_to[k] for k in ("L0", "Lf")}}


# ---------------------------------------------------------------- Newton at fixed data

class NewtonFailure(Exception):
    pass


def newton(sh: Shooting, z0, prm: dict, tol: float, max_iter: int):
    """Newton on f(z, τ = 1) = 0 with the exact Jacobian; returns z, J, f_τ and statistics.

    Fails (NewtonFailure) on an integration failure, a non-finite residual or a residual that
    does not at least halve once past the first iteration.

    Each iterate is first propagated without sensitivities (:func:`final_state`, a tenth of the
    Jacobian's cost). Its step control reads the same primal error as the Jacobian's, so it fails
    where the Jacobian's propagation would, and a bad iterate is dropped at that cost: it runs to
    the step cap (2 revolutions: 20 000 steps, 8 s with sensitivities, three times in a row of the
    quick profile). Measured side by side, cold, rows at 2 and 4 revolutions: CPU 91 → 50 s and
    86 → 53 s, every T_min and the way each cell was obtained unchanged to the bit (29 Nov).
    """
    z = np.asarray(z0, float).copy()
    stats = {"jacobian_evaluations": 0, "integration_steps_total": 0, "history": []}
    prev = math.inf
    for _ in range(max_iter):
        yf, ok = final_state(sh, jnp.asarray(z), 1.0, prm)
        if not bool(ok) or not np.all(np.isfinite(np.asarray(yf))):
            stats["history"].append(math.inf)
            raise NewtonFailure("integration failed", stats)
        f, J, ftau, nsteps, ok = shoot(sh, jnp.asarray(z), 1.0, prm)
        f, J, ftau = np.asarray(f), np.asarray(J), np.asarray(ftau)
        stats["jacobian_evaluations"] += 1
        stats["integration_steps_total"] += int(nsteps)
        nF = float(np.max(np.abs(f))) if np.all(np.isfinite(f)) else math.inf
        stats["history"].append(nF)
        if not bool(ok) or not math.isfinite(nF):
            raise NewtonFailure("integration failed", stats)
        if nF <= tol:
            stats["final_residual"] = nF
            return z, J, ftau, stats
        if len(stats["history"]) > 2 and nF > 0.5 * prev:
            raise NewtonFailure(f"no contraction (|f| {prev:.2e} -> {nF:.2e})", stats)
        prev = nF
        try:
            z = z - np.linalg.solve(J, f)
        except np.linalg.LinAlgError:
            raise NewtonFailure("singular Jacobian", stats) from None
    raise NewtonFailure("iteration limit", stats)


# ---------------------------------------------------------------- cell results

def cell_record(tr: Transfer, sh: Shooting, z, prm: dict, method: str, stats: dict, wall_s: float) -> dict:
    """Scalars of a converged cell in physical units (T_min always on: m_f = m₀ − T Δt / c)."""
    # y(K_f) at the chain's end-point tolerance (rtol 1e-12), by the screening propagation's program
    yf = np.asarray(final_state(dataclasses.replace(sh, rtol=1e-12, atol=1e-13), jnp.asarray(z), 1.0, prm)[0])
    T = float(z[-1]) * tr.force_unit
    tof = float(yf[hm.TIME]) * tr.tu
    m_f = float(yf[hm.MASS]) * tr.m0
    return {"L0_deg": tr.L0_deg, "n_rev": tr.n_rev, "T_min_N": T, "tof_days": tof / DAY, "m_f_kg": m_f,
            "K_f_deg": math.degrees(float(z[sh.kf_index])),
            "mass_balance_kg": m_f - (tr.m0 - T * tof / tr.c),
            "method": method, "jacobian_evaluations": int(stats.get("jacobian_evaluations", 0)),
            "integration_steps": int(stats.get("integration_steps_total", 0)),
            "final_residual": float(stats.get("final_residual", float("nan"))),
            "wall_s": wall_s, "z": [float(v) for v in z]}


def cold_cell(tr: Transfer, options: ContinuationOptions | None = None, label="cold"):
    """LP from the zero guess, then LP → T_min; returns z and the chain statistics."""
    lp = chain.solve_lp(tr, options, label=f"{label}/lp")
    tm = chain.solve_tmin(lp, options, label=f"{label}/tmin")
    stats = {k: lp.stats[k] + tm.stats[k] for k in ("jacobian_evaluations", "integration_steps_total")}
    stats["final_residual"] = tm.stats["final_residual"]
    return np.asarray(tm.z), stats


# ---------------------------------------------------------------- predictors along n

def scale_prediction(n: float, rows: list[tuple[float, np.ndarray]], kf_index: int) -> np.ndarray:
    """z at n revolutions from the same cell at earlier revolution counts (module docstring)."""
    rows = sorted(rows, key=lambda r: r[0])
    n1, z1 = rows[-1]
    z = np.empty_like(z1)
    dK1 = z1[kf_index] - 2 * math.pi * n1
    if len(rows) == 1:
        expo = np.ones_like(z1)
        expo[hm.LK] = 2.0
        z[:] = z1 * (n1 / n) ** expo
        z[kf_index] = 2 * math.pi * n + dK1
        return z
    n0, z0 = rows[-2]
    dK0 = z0[kf_index] - 2 * math.pi * n0
    for i in range(len(z1)):
        if i == kf_index:
            continue
        if z0[i] * z1[i] > 0:
            b = math.log(z1[i] / z0[i]) / math.log(n1 / n0)
            z[i] = z1[i] * (n / n1) ** b
        else:                                   # sign change: fall back to n⁻¹
            z[i] = z1[i] * n1 / n
    s = (1 / n - 1 / n1) / (1 / n0 - 1 / n1)   # K_f − ΔL linear in 1/n
    z[kf_index] = 2 * math.pi * n + dK1 + s * (dK0 - dK1)
    return z


# ---------------------------------------------------------------- rows

def _grid(sw: dict, row: dict) -> list[float]:
    if row["grid"] == "table":
        return sorted(float(x) for x in sw["table_L0_deg"])
    step = float(sw["fine_step_deg"])
    fine = np.arange(0.0, 360.0 + 0.5 * step, step)
    return sorted({float(round(x, 9)) for x in fine} | {float(x) for x in sw["table_L0_deg"]})


def row_grid(sw: dict, n_rev: float) -> list[float]:
    return _grid(sw, row_config(sw, n_rev))


def row_config(sw: dict, n_rev: float) -> dict:
    for row in sw["rows"]:
        if float(row["n_rev"]) == float(n_rev):
            return row
    raise ConfigError("sweep.rows", n_rev, "no row with this n_rev")


def _log(log, msg):
    if log is not None:
        print(msg, file=log, flush=True)


def _substeps(sh, z_a, prm_a, prm_b, numerics, parts=2, depth=0):
    """March from the data ``prm_a`` (solution ``z_a``) to ``prm_b`` in ``parts`` equal L₀ substeps,
    each predicted along the tangent of the last evaluation; a substep whose Newton fails is split
    again (down to ``max_bisections`` levels). Returns z, J, f_τ of the last substep and the work."""
    tol, it = float(numerics["newton_tol"]), int(numerics["newton_max_iter"])
    work = {"jacobian_evaluations": 0, "integration_steps_total": 0}
    z, prm_prev, dz = np.asarray(z_a, float), prm_a, None
    for k in range(1, parts + 1):
        prm_k = {**prm_b, **{key: prm_a[key] + (prm_b[key] - prm_a[key]) * k / parts for key in ("L0", "Lf")}}
        prm = path_params(prm_prev, prm_k)
        if dz is None:
            _, J0, f0, nst, _ = shoot(sh, jnp.asarray(z), 0.0, prm)
            work["jacobian_evaluations"] += 1
            work["integration_steps_total"] += int(nst)
            dz = -np.linalg.solve(np.asarray(J0), np.asarray(f0))
        try:
            z, J, ftau, st = newton(sh, z + dz, prm, tol, it)
        except NewtonFailure as exc:
            st = exc.args[1]
            if depth + 1 >= int(numerics.get("max_bisections", 3)):
                raise
            work["jacobian_evaluations"] += st["jacobian_evaluations"]
            z, J, ftau, st = _substeps(sh, z, prm_prev, prm_k, numerics, 2, depth + 1)
            ftau = ftau * 2          # the last sub-substep covered half of this substep
        for key in work:
            work[key] += st[key]
        prm_prev = prm_k
        dz = -np.linalg.solve(J, ftau)
    work["final_residual"] = st.get("final_residual", float("nan"))
    return z, J, ftau, work


def _newton_or_fallback(tr, sh, z_pred, prm, prev_cell, numerics, log, label, periodic=None):
    """Newton from ``z_pred``; else L₀ substeps from the previous cell of the row; else Newton from
    the solved cell 360° away (``periodic``: the problem is 2π-periodic in L₀); else the parameter
    continuation from the previous cell; else the cold chain."""
    tol, it = float(numerics["newton_tol"]), int(numerics["newton_max_iter"])
    try:
        z, J, ftau, st = newton(sh, z_pred, prm, tol, it)
        return z, J, ftau, st, None
    except NewtonFailure as exc:
        reason, st0 = exc.args
        _log(log, f"[{label}] Newton failed ({reason}); falling back")
    spent = st0["jacobian_evaluations"]
    if prev_cell is not None and prev_cell[1]["L0"] != prm["L0"]:
        z_prev, prm_prev = prev_cell
        try:
            z, J, ftau, st = _substeps(sh, z_prev, prm_prev, {k: v for k, v in prm.items()
                                                              if not k.startswith("path_")}, numerics)
            st["jacobian_evaluations"] += spent
            return z, J, ftau * 2, st, "march-substeps"
        except NewtonFailure as exc:
            spent += exc.args[1]["jacobian_evaluations"]
            _log(log, f"[{label}] substeps failed")
    if periodic is not None:
        try:
            z, J, ftau, st = newton(sh, periodic, prm, tol, it)
            st["jacobian_evaluations"] += spent
            return z, J, ftau, st, "periodic"
        except NewtonFailure as exc:
            spent += exc.args[1]["jacobian_evaluations"]
            _log(log, f"[{label}] periodic image failed")
    if prev_cell is not None:
        z_prev, prm_prev = prev_cell
        try:
            sol = chain.Solution("tmin", dataclasses.replace(sh, model=Model("tmin", "lp")),
                                 np.asarray(z_prev), prm_prev, tr, {})
            out = chain.continue_in_params(sol, {k: v for k, v in prm.items() if not k.startswith("path_")},
                                           ContinuationOptions(verbose=False), label=f"{label}/param")
            z, J, ftau, st = newton(sh, out.z, prm, tol, it)
            st["jacobian_evaluations"] += spent + out.stats["jacobian_evaluations"]
            return z, J, ftau, st, "continuation"
        except (ConvergenceError, NewtonFailure):
            _log(log, f"[{label}] continuation failed; cold chain")
    z_cold, st_c = cold_cell(tr, ContinuationOptions(verbose=False), label=label)
    z, J, ftau, st = newton(sh, z_cold, prm, tol, it)
    st["jacobian_evaluations"] += spent + st_c["jacobian_evaluations"]
    return z, J, ftau, st, "cold"


def solve_row(mr: dict, sw: dict, n_rev: float, sources: dict | None = None, log=None) -> list[dict]:
    """Every cell of the row ``n_rev`` (its L₀ grid from ``sw``), in the configured way.

    ``sources``: {n_prev: {L0_deg: z}} of earlier rows, for a row started by ``scale``.
    """
    row = row_config(sw, n_rev)
    numerics = sw["numerics"]
    sh = shooting(numerics, n_rev)
    grid = _grid(sw, row)
    start = row["start"]
    cells = []
    prev = None                 # (z, prm, tangent per rad, step) of the previous cell
    tangent_prev = None
    scale_err = None            # z − scaled prediction at the previous cell (scale rows)
    for L0 in grid:
        t0 = time.perf_counter()
        tr = cell_transfer(mr, sw, L0, n_rev)
        label = f"sweep n={n_rev:g} L0={L0:g}"
        if start != "cold":
            if not sources:
                raise ConfigError(f"sweep.rows[n_rev={n_rev:g}].start", start, "source rows not given")
            src = []
            for n_src in start:
                zs = sources.get(float(n_src), {}).get(float(L0))
                if zs is None:
                    raise ConfigError(f"sweep.rows[n_rev={n_rev:g}].start", start,
                                      f"row {n_src} has no cell at L0={L0:g} deg")
                src.append((float(n_src), np.asarray(zs)))
            prm = path_params(tr.params(), tr.params())
            z_scaled = scale_prediction(n_rev, src, sh.kf_index)
            # the scaling error varies slowly with L0: correct by the previous cell's error
            z_pred = z_scaled if scale_err is None else z_scaled + scale_err
            z, J, ftau, st, fb = _newton_or_fallback(
                tr, sh, z_pred, prm, None if prev is None else prev[:2], numerics, log, label)
            method = fb or "scale"
            scale_err = np.asarray(z) - z_scaled
        elif prev is None:
            z_c, st_c = cold_cell(tr, ContinuationOptions(verbose=False), label=label)
            prm = path_params(tr.params(), tr.params())
            z, J, ftau, st = newton(sh, z_c, prm, float(numerics["newton_tol"]), int(numerics["newton_max_iter"]))
            st["jacobian_evaluations"] += st_c["jacobian_evaluations"]
            st["integration_steps_total"] += st_c["integration_steps_total"]
            method = "cold"
        else:
            z_a, prm_a, _, _ = prev
            prm = path_params(prm_a, tr.params())
            h = math.radians(L0 - prev_L0)
            z_pred = z_a
            if tangent_prev is not None:
                t_a, h_a, t_b = tangent_prev
                z_pred = z_a + h * t_a
                if t_b is not None:
                    z_pred = z_pred + 0.5 * h * h * (t_a - t_b[0]) / h_a
            image = next((c["z"] for c in cells if (L0 - c["L0_deg"]) % 360.0 == 0.0), None)
            z, J, ftau, st, fb = _newton_or_fallback(tr, sh, z_pred, prm, (z_a, prm_a), numerics, log, label,
                                                     None if image is None else np.asarray(image))
            method = fb or "march"
        # tangent dz/dL0 at this cell from the τ column of the last evaluation (path L0_prev -> L0)
        if prev is not None and start == "cold":
            step = math.radians(L0 - prev_L0)
            t_new = -np.linalg.solve(J, ftau) / step
            tangent_prev = (t_new, step, (tangent_prev[0], tangent_prev[1]) if tangent_prev else None)
        elif start == "cold":
            # first cell: one evaluation with a unit L0 path gives the tangent
            prm_u = {**prm, "path_from": {"L0": prm["L0"] - 1.0, "Lf": prm["Lf"] - 1.0}}
            _, Ju, fu, _, _ = shoot(sh, jnp.asarray(z), 1.0, prm_u)
            st["jacobian_evaluations"] += 1
            tangent_prev = (-np.linalg.solve(np.asarray(Ju), np.asarray(fu)), 1.0, None)
        wall = time.perf_counter() - t0
        rec = cell_record(tr, sh, z, prm, method, st, wall)
        _log(log, f"[{label}] {method}: T_min={rec['T_min_N']:.8f} N tof={rec['tof_days']:.5f} d "
                  f"jac={rec['jacobian_evaluations']} |f|={rec['final_residual']:.1e} ({wall:.1f} s)")
        cells.append(rec)
        prev = (z, {k: v for k, v in prm.items() if not k.startswith("path_")}, None, None)
        prev_L0 = L0
    return cells


def sources_from_rows(rows: list[list[dict]]) -> dict:
    """{n_rev: {L0_deg: z}} from solved rows (cell records)."""
    out = {}
    for cells in rows:
        for c in cells:
            out.setdefault(float(c["n_rev"]), {})[float(c["L0_deg"])] = np.asarray(c["z"])
    return out


def solve_single(mr: dict, sw: dict, L0_deg: float, n_rev: float, sources: dict, start: list, log=None) -> dict:
    """One cell (e.g. the n* check at 76 and 77 revolutions) scaled from earlier rows."""
    t0 = time.perf_counter()
    tr = cell_transfer(mr, sw, L0_deg, n_rev)
    sh = shooting(sw["numerics"], n_rev)
    src = [(float(n), np.asarray(sources[float(n)][float(L0_deg)])) for n in start]
    prm = path_params(tr.params(), tr.params())
    z, J, ftau, st, fb = _newton_or_fallback(tr, sh, scale_prediction(n_rev, src, sh.kf_index), prm,
                                             None, sw["numerics"], log, f"sweep n={n_rev:g} L0={L0_deg:g}")
    return cell_record(tr, sh, z, prm, fb or "scale", st, time.perf_counter() - t0)
