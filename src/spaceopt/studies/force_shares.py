"""What each force contributes to a transfer: the angular-momentum and energy budget.

Central gravity conserves the specific angular momentum h = r × v and the energy
E = v²/2 − μ/|r|, so along a trajectory driven by the thrust acceleration a_T and the perturbing
accelerations a_k (geopotential, Moon, Sun; :func:`spaceopt.forces.acceleration_terms`)

    h_f − h_0 = ∫ r × a_T dt + Σ_k ∫ r × a_k dt,      E_f − E_0 = ∫ v·a_T dt + Σ_k ∫ v·a_k dt.

The share of force j is its integral projected on the total change,

    s_h,j = (∫ r × a_j dt)·Δh / |Δh|²,      s_E,j = ∫ v·a_j dt / ΔE,

and the shares of the thrust and the perturbations add up to 1. The shares tell how much of the
orbit change the propellant pays for and how much the perturbations do for free (or undo): along
the E5/E6 extremals, whose initial apogee lies beyond the Moon (spec 02-multirev §4), the Moon
supplies a large part of the change of h.

The integrals ride along as quadrature states of the independent Cartesian re-propagation with
the recorded control (:func:`spaceopt.studies.verify.recorded_control`, SciPy DOP853), not as
sums over the recorded samples: at 200 samples per revolution a trapezoid sum misses the thrust's
switches and the close lunar passes by up to 16 % of Δh (E6, measured). The closure of the budget
(|Σ_j ∫ r × a_j dt − Δh| / |Δh|, and the same for E, with Δh and ΔE from the re-propagated end
states) is reported as the check of the quadrature.

The same quadratures at the crossings of L = L0 + 2πk (events of the integration) split the
shares of Δh by revolution; with the Moon in the model, the closest approach to it is reported
too (the E6 extremals that take most from the Moon pass it closest).

A static conservative field (J2 about the frozen pole) does work equal to the drop of its
potential between the end points, whatever the path: its share of ΔE says where the transfer
starts and ends, not how it flies (E8: J2's share is −0.839 % at every revolution count, the J2
potential at the GTO perigee; the zonal geopotential likewise to first order). The Moon and the
Sun move, so their work and every torque depend on the path.

A change below MIN_CHANGE of its initial value (|ΔE| of a LEO → LEO transfer at one semi-major
axis, E9) has no meaningful shares: they are left empty (None), and its closure is taken relative
to MIN_CHANGE·|E_0| instead.
"""
from __future__ import annotations

import math
import re

import numpy as np

from .. import artifacts
from ..constants import DAY

# the forces of the budget, in the order of the table's columns; the thrust first
FORCES = ("thrust", "j2", "geopotential", "moon", "sun")
MIN_CHANGE = 1e-3
NAMES = {"thrust": "the thrust", "j2": "J2", "geopotential": "the geopotential", "moon": "the Moon", "sun": "the Sun"}


def force_shares(json_path, rtol=1e-10, atol_m=1e-3) -> dict:
    """The budget of one perturbed OT artifact (module docstring): per force its share of Δh and
    of ΔE, |Δh| and ΔE themselves, the closure of both budgets, the shares of Δh by revolution
    and (with the Moon) the closest approach to the Moon. ValueError for an unperturbed artifact."""
    import jax
    from scipy.integrate import solve_ivp

    from ..elements import cartesian_to_mee
    from ..forces import acceleration_terms, build_model
    from .verify import recorded_control
    data = artifacts.read_json(json_path)
    smp = artifacts.read_npz(json_path)
    extra = data.get("extra") or {}
    if not extra.get("perturbations"):
        raise ValueError(f"{json_path}: not a perturbed artifact (no extra.perturbations)")
    model = build_model(extra["perturbations"], extra["epoch_utc"], data["transfer"].get("ephemeris"))
    mu = data["transfer"]["mu"]
    span, y0, thrust = recorded_control(data, smp)
    terms = jax.jit(acceleration_terms)
    names = ["thrust"] + [k for k in FORCES if k in terms(y0[:3], model.epoch + span[0], model)]

    def rhs(tt, y):
        r, v, m = y[:3], y[3:6], y[6]
        a_t, mdot = thrust(tt, m)
        a_p = terms(r, model.epoch + tt, model)
        acc = [a_t] + [np.asarray(a_p[k]) for k in names[1:]]
        rates = [np.concatenate([np.cross(r, a), [v @ a]]) for a in acc]
        return np.concatenate([v, -mu * r / np.linalg.norm(r) ** 3 + sum(acc), [mdot], *rates])

    h0 = np.cross(y0[:3], y0[3:6])
    e0 = _energy(y0[:3], y0[3:6], mu)
    quad_tol = np.tile(np.concatenate([np.full(3, 1e-9 * np.linalg.norm(h0)), [1e-9 * abs(e0)]]), len(names))
    atol = np.concatenate([np.full(3, atol_m), np.full(3, atol_m * 1e-3), [1e-9], quad_tol])
    mee = jax.jit(cartesian_to_mee)
    L0 = math.radians(data["transfer"]["L0_deg"])

    def new_revolution(tt, y):                         # L = L0 + 2πk, L increasing
        return math.sin(float(mee(y[:3], y[3:6], mu)[5]) - L0)
    new_revolution.direction = 1.0

    sol = solve_ivp(rhs, span, np.concatenate([y0, np.zeros(4 * len(names))]), method="DOP853",
                    rtol=rtol, atol=atol, events=new_revolution)
    yf = sol.y[:, -1]
    dh = np.cross(yf[:3], yf[3:6]) - h0
    de = _energy(yf[:3], yf[3:6], mu) - e0
    quad = yf[7:].reshape(len(names), 4)
    h_scale = max(float(np.linalg.norm(dh)), MIN_CHANGE * float(np.linalg.norm(h0)))
    e_scale = max(abs(de), MIN_CHANGE * abs(e0))
    h_shares = np.linalg.norm(dh) >= MIN_CHANGE * np.linalg.norm(h0)
    e_shares = abs(de) >= MIN_CHANGE * abs(e0)
    return {"forces": names,
            "h_share": {k: float(q[:3] @ dh / (dh @ dh)) if h_shares else None for k, q in zip(names, quad)},
            "E_share": {k: float(q[3] / de) if e_shares else None for k, q in zip(names, quad)},
            "delta_h_m2_s": float(np.linalg.norm(dh)), "h0_m2_s": float(np.linalg.norm(h0)),
            "delta_E_m2_s2": float(de), "E0_m2_s2": float(e0),
            "closure_h": float(np.linalg.norm(quad[:, :3].sum(axis=0) - dh) / h_scale),
            "closure_E": float(abs(quad[:, 3].sum() - de) / e_scale),
            "integrator": "scipy DOP853", "rtol": rtol, "nfev": int(sol.nfev), "success": bool(sol.success),
            "revolutions": _by_revolution(sol, names, dh) if h_shares else [],
            **(_closest_moon(sol, model) if "moon" in names else {})}


def _by_revolution(sol, names: list, dh) -> list[dict]:
    """Each force's share of Δh gathered in each revolution of the true longitude (from L0 + 2πk
    to L0 + 2π(k+1), the last one partial): the quadrature states at the event crossings. A
    crossing within 1e-4 of the span of either end (the re-propagation reaches L_f a little
    before or after t_f) is not a boundary."""
    t0, tf = sol.t[0], sol.t[-1]
    tol = 1e-4 * (tf - t0)
    inner = (sol.t_events[0] > t0 + tol) & (sol.t_events[0] < tf - tol)
    times = np.concatenate([[t0], sol.t_events[0][inner], [tf]])
    states = np.vstack([sol.y[:, 0], sol.y_events[0].reshape(-1, sol.y.shape[0])[inner], sol.y[:, -1]])
    quad = states[:, 7:].reshape(len(times), len(names), 4)[:, :, :3] @ dh / (dh @ dh)
    return [{"start_days": float((a - t0) / DAY), "end_days": float((b - t0) / DAY),
             "h_share": {k: float(x) for k, x in zip(names, q1 - q0)}}
            for a, b, q0, q1 in zip(times, times[1:], quad, quad[1:])]


def _closest_moon(sol, model) -> dict:
    """The re-propagation's closest approach to the Moon, over its integration steps: distance
    [km] and time after departure [d]."""
    import jax
    moon = np.asarray(jax.jit(jax.vmap(lambda t: model.eph.positions(t)[0]))(model.epoch + sol.t))
    dist = np.linalg.norm(sol.y[:3].T - moon, axis=1)
    k = int(np.argmin(dist))
    return {"moon_closest_km": float(dist[k] / 1e3), "moon_closest_days": float((sol.t[k] - sol.t[0]) / DAY)}


def _energy(r, v, mu) -> float:
    return 0.5 * float(v @ v) - mu / float(np.linalg.norm(r))


def shares_payload(json_path, artifact: str) -> dict:
    """What a ``*.shares.json`` holds (:func:`share_row`'s input): the budget of the artifact at
    ``json_path`` (:func:`force_shares`), its name ``artifact`` and its m_f and Δt."""
    scalars = artifacts.read_json(json_path)["scalars"]
    return {"force_shares": force_shares(json_path), "artifact": artifact,
            "scalars": {k: scalars[k] for k in ("m_f_kg", "tof_days")}}


def present(rows: list[dict], key: str) -> list[float]:
    """The values of column ``key`` in the rows that have it (None or a CSV's empty cell: not)."""
    return [float(r[key]) for r in rows if r.get(key) not in (None, "")]


def in_every(rows: list[dict], key: str) -> bool:
    """Does every row have a value in column ``key`` (a force of every solve)?"""
    return all(r.get(key) not in (None, "") for r in rows)


def share_row(payload: dict) -> dict:
    """One table row of a ``*.shares.json`` payload: the artifact, its m_f and Δt, |Δh|/|h_0|,
    ΔE, the share of Δh and of ΔE of each force of :data:`FORCES` it has, the closest approach to
    the Moon (with the Moon in the model), and both closures."""
    res, sc = payload["force_shares"], payload["scalars"]
    row = {"artifact": payload["artifact"], "m_f_kg": sc["m_f_kg"], "tof_days": sc["tof_days"],
           "delta_h_over_h0": res["delta_h_m2_s"] / res["h0_m2_s"], "delta_E_m2_s2": res["delta_E_m2_s2"]}
    for k in res["forces"]:
        row[f"h_share_{k}"] = res["h_share"][k]
        row[f"E_share_{k}"] = res["E_share"][k]
    moon = {k: res[k] for k in ("moon_closest_km", "moon_closest_days") if k in res}
    return {**row, **moon, "closure_h": res["closure_h"], "closure_E": res["closure_E"]}


def share_columns(rows: list[dict]) -> list[str]:
    """The columns of the table: those of :func:`share_row` that any row has, forces in :data:`FORCES` order."""
    forces = [f"{q}_share_{k}" for k in FORCES for q in ("h", "E")]
    cols = (["artifact", "m_f_kg", "tof_days", "delta_h_over_h0", "delta_E_m2_s2"] + forces
            + ["moon_closest_km", "moon_closest_days", "closure_h", "closure_E"])
    return [c for c in cols if any(c in r for r in rows)]


def revolution_rows(payload: dict) -> list[dict]:
    """The table by revolution of a ``*.shares.json`` payload: per revolution of the true
    longitude (1-based), its start and end [d after departure] and each force's share of Δh gathered in it."""
    return [{"artifact": payload["artifact"], "revolution": k, "start_days": rev["start_days"],
             "end_days": rev["end_days"], **{f"h_share_{f}": x for f, x in rev["h_share"].items()}}
            for k, rev in enumerate(payload["force_shares"].get("revolutions", []), start=1)]


def revolution_columns(rows: list[dict]) -> list[str]:
    cols = ["artifact", "revolution", "start_days", "end_days"] + [f"h_share_{k}" for k in FORCES]
    return [c for c in cols if any(c in r for r in rows)]


def shares_sentence(rows: list[dict], unperturbed_m_f: float | None = None, revolutions=()) -> str:
    """Plain text for the paper: the budget's method and closure; over the E6 dates (artifacts
    ``e6/<date>``) the range of each force's share of Δh, the thrust's share of ΔE, and how m_f
    goes with the Moon's share (correlation, least-squares slope and its value at no lunar share,
    beside the unperturbed ``unperturbed_m_f``), the share with the closest approach to the Moon,
    and (with ``revolutions``, the rows of :func:`revolution_rows`) the revolution in which the
    date of the largest share gathers the most of it; every other solve by its shares of Δh and
    the thrust's of ΔE, the counts of one E8 model as ranges. '' without rows."""
    if not rows:
        return ""
    closure = max(max(float(r["closure_h"]), float(r["closure_E"])) for r in rows)
    text = ("What each force contributes: along each perturbed solve the change of the orbit's angular momentum "
            "Δh is split into the integrals of r × a of the thrust and of each perturbing acceleration, projected "
            "on Δh, and the change of energy ΔE likewise into the integrals of v·a (central gravity changes "
            "neither; a static field's work is the drop of its potential between the end points, whatever the "
            "path); the integrals ride along the independent Cartesian re-propagation, and each budget closes "
            f"to {closure:.1e} (results/perturbed/force_shares.csv).")
    e6 = [r for r in rows if str(r["artifact"]).startswith("e6/")]
    if e6:
        pct = lambda k: [100 * x for x in present(e6, f"h_share_{k}")]  # noqa: E731
        ranges = ", ".join(f"{NAMES[k]} {min(v):.0f} to {max(v):.0f} %" if max(abs(x) for x in v) >= 0.5
                           else f"{NAMES[k]} less than 0.5 %" for k in FORCES[1:] if (v := pct(k)))
        thrust_e = [100 * x for x in present(e6, "E_share_thrust")]
        text += (f" Over the {len(e6)} E6 dates the thrust supplies {min(pct('thrust')):.0f} to "
                 f"{max(pct('thrust')):.0f} % of Δh, {ranges}"
                 + (f"; the thrust supplies {min(thrust_e):.0f} to {max(thrust_e):.0f} % of ΔE." if thrust_e else "."))
        moon, m_f = np.array(pct("moon")), np.array([float(r["m_f_kg"]) for r in e6])
        if len(e6) >= 3 and len(moon) == len(e6) and np.ptp(moon) > 0:
            slope, icpt = np.polyfit(moon, m_f, 1)
            text += (f" The final mass {'rises' if slope > 0 else 'falls'} with the Moon's share: correlation "
                     f"{np.corrcoef(moon, m_f)[0, 1]:.2f}; "
                     f"a least-squares line gives {10 * slope:+.2f} kg per 10 % of Δh and {icpt:.2f} kg at no "
                     "lunar share" + (f" (unperturbed: {unperturbed_m_f:.2f} kg)." if unperturbed_m_f is not None
                                      else "."))
            closest = np.array(present(e6, "moon_closest_km"))
            if len(closest) == len(moon) and np.ptp(closest) > 0:
                text += (f" The Moon's share goes with how closely the transfer passes the Moon (closest approach "
                         f"{closest.min():,.0f} to {closest.max():,.0f} km): correlation "
                         f"{np.corrcoef(closest, moon)[0, 1]:.2f}.")
            top = e6[int(np.argmax(moon))]
            revs = [r for r in revolutions if r["artifact"] == top["artifact"] and in_every([r], "h_share_moon")]
            if revs:
                best = max(revs, key=lambda r: float(r["h_share_moon"]))
                text += (f" It is gathered mostly in one revolution: at {_date(top['artifact'])}, "
                         f"{100 * float(best['h_share_moon']):.0f} of its {max(moon):.0f} % in revolution "
                         f"{int(best['revolution'])} of {len(revs)} (days {float(best['start_days']):.1f} to "
                         f"{float(best['end_days']):.1f}; results/perturbed/force_shares_by_revolution.csv).")
    groups = {}
    for r in rows:
        if r not in e6:              # E8's counts of one model together
            groups.setdefault(re.sub(r"_n[0-9.]+$", "", _name(r["artifact"])), []).append(r)
    if groups:
        text += " Elsewhere (share of Δh; of ΔE, the thrust's): " + "; ".join(
            f"{name}" + (f" ({len(g)} counts)" if len(g) > 1 else "") + ": "
            + ", ".join(f"{NAMES[k]} {_pct_range(g, f'h_share_{k}')}" for k in FORCES
                        if in_every(g, f"h_share_{k}"))
            + (f"; {_pct_range(g, 'E_share_thrust')} of ΔE"
               if in_every(g, "E_share_thrust") else "")
            for name, g in groups.items()) + "."
    return text


def _name(artifact) -> str:
    return str(artifact).removesuffix(".json")


def _date(artifact) -> str:
    return _name(artifact).split("/")[-1]


def _pct_range(rows: list, key: str) -> str:
    lo, hi = (f"{100 * f(float(r[key]) for r in rows):.1f}" for f in (min, max))
    return f"{lo} %" if lo == hi else f"{lo} to {hi} %"
