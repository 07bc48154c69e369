"""Extremal families of the E6 departure scan: which neighbouring dates lie on one family.

The scan (dissertation §4.2.1, Figs. 4.2.1.4–5) solves every date on its own: the
perturbations are switched on by τ from the date-independent unperturbed extremal, or the date
starts from a named neighbour (``perturbed.e6.start_from``). Two neighbouring dates can so land
on different local extremals, and the curves m_f(date), Δt(date) then jump from one family of
extremals to another (in our scan Δt jumps by several days, e.g. between 22 and 23 May). Read
against the published curves, a jump says which parts of the curve are comparable at all.

A *link* (a, b) answers whether the extremal of date a, continued in the departure epoch, is the
one the scan found at date b. The continuation is :func:`spaceopt.studies.perturbed.warm_start`
(the Newton homotopy in the problem data, the epoch moving linearly in τ; in arclength where the
τ path turns), followed by the free-time end game, as every scan solve is
(:func:`spaceopt.studies.perturbed.maximise_in_tof`). Its status:

* ``same``: its certified maximum agrees with the scan's at b within ``mass_tol_kg`` in m_f and
  ``tof_tol_days`` in Δt, so a and b lie on one family;
* ``other``: it certifies another local maximum of m_f in t_f at b; its m_f beside the scan's
  says whether the scan's extremal at b is the heavier of the two;
* ``not certified``: the end game certifies no maximum from the continued point;
* ``failed``: the continuation does not reach b (a fold of a's family in the epoch between a
  and b, or a stall), with the error, its ``reason`` and
  ``tau_max``, the largest τ its last path reached: where a's family turns back (the arclength
  path ran back below τ = −1), that fraction of the way to b.

A date b that the scan itself started from a (``start_from``) is linked to a by construction: its
solve *is* that link, so no link job runs for (a, b) (status ``start``).

Families (:func:`segments`): runs of dates joined by a ``same`` or ``start`` link in either
direction. :func:`heavier_elsewhere` lists the dates where a neighbour's family, continued there,
is heavier than the scan's extremal: the scan's curve is not the upper envelope of the families
it met there.

:func:`continue_to` (the link jobs) imports the solver when called; the families' table, figure
and paper sentence load without it.

Config ``perturbed.e6.links`` (null: off): ``directions`` (``forward``: (a, a + 1 day) only;
``both``: also backwards), ``max_steps`` (steps, accepted and rejected, of the τ path, which is
tried first; where it runs out the path goes on in arclength with the arclength follower's own
limits, 400 steps and the τ floor −1, as in every warm start), ``mass_tol_kg``, ``tof_tol_days``.
"""
from __future__ import annotations

import time

from .. import artifacts
from ..errors import ConvergenceError

# samples per revolution of the one propagation that reads the continued extremal's m_f and Δt
SAMPLES_PER_REV = 20

# the reason of a continuation that ran back past its floor (spaceopt.indirect.continuation): a fold
TURNED_BACK = "turned back"
STATUSES = ("same", "other", "not certified", "failed", "start")
COLUMNS = ["from_date", "to_date", "status", "m_f_kg", "tof_days", "scan_m_f_kg", "scan_tof_days",
           "dm_f_g", "tau_max", "reason", "jacobian_evaluations", "wall_time_s"]


def same_extremal(m_a: float, t_a: float, m_b: float, t_b: float, settings: dict) -> bool:
    """Two certified maxima are one where m_f and Δt agree within the link tolerances."""
    return abs(m_a - m_b) <= settings["mass_tol_kg"] and abs(t_a - t_b) <= settings["tof_tol_days"]


def continue_to(start, tr_to, scan: dict, pc: dict, case: str, label: str, settings: dict) -> tuple[dict, object]:
    """(the link record, the continued solution at b or None where the continuation failed) from
    the solved extremal ``start`` (a :class:`~spaceopt.indirect.chain.Solution` at date a) to date
    b: ``tr_to`` is b's problem, ``scan`` the scalars of the scan's solution there (its
    artifact's ``m_f_kg`` and ``tof_days``)."""
    from ..indirect.continuation import ContinuationOptions     # the solver, for the link jobs only
    from . import multirev, perturbed as P
    t0 = time.perf_counter()
    options = ContinuationOptions(max_steps=int(settings["max_steps"]), label=label)
    rec = {"scan_m_f_kg": scan["m_f_kg"], "scan_tof_days": scan["tof_days"]}
    try:
        moved = P.warm_start(start, tr_to, label, options=options)
    except ConvergenceError as exc:
        d = exc.diagnosis or {}
        return {**rec, "status": "failed", "error": str(exc), "reason": d.get("reason"), "tau_max": d.get("tau_max"),
                "jacobian_evaluations": d.get("jacobian_evaluations"), "wall_time_s": d.get("wall_time_s")}, None
    sol, end_game = P.maximise_in_tof(moved, pc, case, label)
    ours = multirev.scalars(sol, multirev.sample(sol, SAMPLES_PER_REV))
    m, t = ours["m_f_kg"], ours["tof_days"]
    certified = end_game is None or end_game["certified"]
    status = ("not certified" if not certified else
              "same" if same_extremal(m, t, scan["m_f_kg"], scan["tof_days"], settings) else "other")
    jacobians = (moved.stats.get("jacobian_evaluations") or 0) + (end_game or {}).get("jacobian_evaluations", 0)
    return {**rec, "status": status, "m_f_kg": m, "tof_days": t, "dm_f_g": 1e3 * (m - scan["m_f_kg"]),
            "jacobian_evaluations": jacobians, "wall_time_s": time.perf_counter() - t0,
            "warm_path": moved.stats.get("warm_path"),
            "z": [float(v) for v in sol.z], "tof_maximum": end_game}, sol


def scan_values(dates: list[str], paths: list) -> dict:
    """{date: (m_f_kg, tof_days)} from the scan's artifacts ``paths`` of ``dates``."""
    scalars = {d: artifacts.read_json(p)["scalars"] for d, p in zip(dates, paths)}
    return {d: (s["m_f_kg"], s["tof_days"]) for d, s in scalars.items()}


def family_rows(links: dict, starts: list[tuple[str, str]], scan: dict) -> list[dict]:
    """Rows of ``e6_families.csv``: one per link record (``links``: {(from, to): record}) and one
    per pair linked by construction (``starts``, status ``start``, the scan's own values);
    ``scan``: {date: (m_f_kg, tof_days)} of the scan."""
    rows = [{"from_date": a, "to_date": b, "status": "start", "m_f_kg": scan[b][0], "tof_days": scan[b][1],
             "scan_m_f_kg": scan[b][0], "scan_tof_days": scan[b][1], "dm_f_g": 0.0} for a, b in starts]
    for (a, b), rec in links.items():
        rows.append({"from_date": a, "to_date": b, **{k: rec.get(k) for k in COLUMNS[2:]}})
    return sorted(rows, key=lambda r: (min(r["from_date"], r["to_date"]), r["from_date"]))


def segments(dates: list[str], rows: list[dict]) -> list[list[str]]:
    """The scan's dates (in order) cut into families: a date joins the one before it where a
    ``same`` or ``start`` link joins the two in either direction."""
    joined = {frozenset((r["from_date"], r["to_date"])) for r in rows if r["status"] in ("same", "start")}
    out = []
    for d in dates:
        if out and frozenset((out[-1][-1], d)) in joined:
            out[-1].append(d)
        else:
            out.append([d])
    return out


def heavier_elsewhere(rows: list[dict], mass_tol_kg: float) -> list[dict]:
    """The ``other`` links whose continued extremal is heavier than the scan's at their date by
    more than ``mass_tol_kg``, heaviest gain first."""
    out = [r for r in rows if r["status"] == "other" and r["m_f_kg"] - r["scan_m_f_kg"] > mass_tol_kg]
    return sorted(out, key=lambda r: r["scan_m_f_kg"] - r["m_f_kg"])


def families_sentence(dates: list[str], rows: list[dict], mass_tol_kg: float) -> str:
    """The paper's account of the scan's families (plain text; the caller escapes it)."""
    if not rows:
        return ""
    segs = segments(dates, rows)
    span = "; ".join(s[0] if len(s) == 1 else f"{s[0]} to {s[-1]}" for s in segs)
    counts = {s: sum(r["status"] == s for r in rows) for s in STATUSES}
    starts = counts.pop("start")
    text = (f"Continued in the departure epoch from each date to its neighbours ({sum(counts.values())} links: "
            + ", ".join(f"{n} {s}" for s, n in counts.items() if n)
            + (f"; {starts} pair{'s' if starts > 1 else ''} linked by construction, one date's solve started from the other"
               if starts else "")
            + f"), the scan's extremals form {len(segs)} famil{'y' if len(segs) == 1 else 'ies'}: {span}.")
    failed = [r for r in rows if r["status"] == "failed" and isinstance(r.get("tau_max"), float)]
    if failed:
        text += " Continued in the epoch, " + ", ".join(
            (f"the family of {r['from_date']} turns back" if TURNED_BACK in str(r.get("reason"))
             else f"the path from {r['from_date']} stops") + f" {r['tau_max']:.3f} of the way to {r['to_date']}"
            for r in failed) + "."
    heavier = heavier_elsewhere(rows, mass_tol_kg)
    if heavier:
        text += (" At " + ", ".join(f"{r['to_date']} (from {r['from_date']}: {r['m_f_kg'] - r['scan_m_f_kg']:+.4f} kg, "
                                    f"{r['tof_days'] - r['scan_tof_days']:+.3f} d)" for r in heavier)
                 + " a neighbour's family is heavier than the scan's extremal.")
    else:
        text += " No neighbour's family, continued to a date, is heavier there than the scan's extremal."
    return text
