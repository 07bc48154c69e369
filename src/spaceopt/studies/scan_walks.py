"""Walks along the E6 scan's extremal families, and the upper envelope of the extremals found.

A link (:mod:`spaceopt.studies.scan_families`) continues date a's extremal one date, to b. Where
it lands on another local maximum than the scan's at b (status ``other``), that family goes on
past b: a *walk* continues it date by date in the same direction, each step a link
(:func:`~spaceopt.studies.scan_families.continue_to`: the Newton homotopy in the departure epoch,
then the free-time end game), until

* it lands on the scan's extremal (``same``): the family joins the scan's curve, which is known
  from there on;
* the continuation fails, or the end game certifies no maximum (``failed``, ``not certified``);
* the run dates end, or ``max_days`` dates past b were walked.

So every family that a link met is followed across the month as far as it goes. At every date
the scan's extremal, the links' and the walks' certified maxima are local maxima of m_f in t_f
of one problem (the same transfer, model and epoch); :func:`envelope_rows` keeps the distinct
ones (two are one where m_f and Δt agree within the link tolerances) and the heaviest, the
upper envelope of the extremals found: which family a user who wants the most final mass at
that date should fly, and by how much it beats the scan's own extremal.

Config ``perturbed.e6.walks`` (null: off; needs ``links``): ``max_days``, the most dates a walk
goes past its link's date. A walk job is planned for every link and ends at once where its
link is not ``other``.
"""
from __future__ import annotations

import dataclasses
import datetime
from collections import Counter

import numpy as np

from .scan_families import TURNED_BACK, continue_to, same_extremal

STEP_COLUMNS = ["from_date", "link_to", "date", "status", "m_f_kg", "tof_days", "scan_m_f_kg", "scan_tof_days",
                "dm_f_g", "tau_max", "reason", "jacobian_evaluations", "wall_time_s"]
ENVELOPE_COLUMNS = ["date", "scan_m_f_kg", "scan_tof_days", "extremals", "m_f_kg", "tof_days", "family_of", "gain_kg",
                    "arrival_utc"]


def extremal_at(template, z):
    """The solution ``template`` (the scan's at a date: its problem and unknowns' layout) with
    the unknowns ``z`` of another extremal at that date."""
    z = np.asarray(z, dtype=float)
    if z.shape != np.shape(template.z):
        raise ValueError(f"an extremal with {z.size} unknowns for a problem with {np.size(template.z)}")
    return dataclasses.replace(template, z=z)


def walk(sol, ahead: list[str], problems: dict, scans: dict, pc: dict, case: str, label: str, settings: dict,
         done=(), record=None) -> list[dict]:
    """The steps of a walk from ``sol``, the link's continued extremal at its date, through the
    dates ``ahead`` (:func:`.perturbed_config.walk_dates`): each a link record with its ``date``.
    ``problems[c]``: the scan's solution at date c (c's problem, the template of
    :func:`extremal_at`); ``scans[c]``: its scalars. ``done``: the steps recorded before an
    interruption (the walk goes on from the last one's unknowns); ``record(steps)`` is called
    after every step (the job's resume file)."""
    steps = list(done)
    if steps:
        if steps[-1]["status"] != "other":
            return steps
        sol = extremal_at(problems[steps[-1]["date"]], steps[-1]["z"])
    for c in ahead[len(steps):]:
        rec, sol = continue_to(sol, problems[c].transfer, scans[c], pc, case, f"{label} -> {c}", settings)
        steps.append({"date": c, **rec})
        if record is not None:
            record(steps)
        if rec["status"] != "other":
            break
    return steps


def step_rows(walks: list[dict]) -> list[dict]:
    """Rows of ``e6_walks.csv``: one per walk step (``walks``: the walk records, each with its
    link's ``from_date`` and ``to_date`` and its ``steps``)."""
    return [{"from_date": w["from_date"], "link_to": w["to_date"], **{k: s.get(k) for k in STEP_COLUMNS[2:]}}
            for w in walks for s in w["steps"]]


def envelope_rows(dates: list[str], scan: dict, links: list[dict], steps: list[dict], settings: dict,
                  time_utc: str = "12:00:00") -> list[dict]:
    """Rows of ``e6_envelope.csv``, one per date: the scan's extremal, the number of distinct
    certified maxima found there (the scan's, and those of ``other`` links, ``links``: rows of
    ``e6_families.csv``, and of walk steps, ``steps``: :func:`step_rows`), the heaviest, the scan
    date whose family it is (``family_of``), its gain over the scan's, and its arrival (UTC,
    departure at ``time_utc`` plus Δt: along a family it stays nearly fixed, so it tells the
    families apart). ``scan``: {date: (m_f_kg, tof_days)}."""
    found = {d: [(*scan[d], d)] for d in dates}
    met = [(r["to_date"], r) for r in links] + [(s["date"], s) for s in steps]
    for date, r in met:
        if r["status"] != "other" or date not in found:
            continue
        m, t = float(r["m_f_kg"]), float(r["tof_days"])
        if not any(same_extremal(m, t, m2, t2, settings) for m2, t2, _ in found[date]):
            found[date].append((m, t, r["from_date"]))
    rows = []
    for d in dates:
        m, t, family = max(found[d], key=lambda e: e[0])
        rows.append({"date": d, "scan_m_f_kg": scan[d][0], "scan_tof_days": scan[d][1], "extremals": len(found[d]),
                     "m_f_kg": m, "tof_days": t, "family_of": family, "gain_kg": m - scan[d][0],
                     "arrival_utc": arrival(d, time_utc, t)})
    return rows


def heavier_extremals(envelope: list[dict], links: list[dict], steps: list[dict], mass_tol_kg: float) -> list[tuple]:
    """(envelope row, z) of every date where another family's extremal is heavier than the scan's
    by more than ``mass_tol_kg``: its unknowns z from the link record (``links``: the ``link``
    blocks of the link artifacts) or the walk step (``steps``: the steps of the walk artifacts)
    that found it, matched by date and m_f (the envelope takes m_f from them)."""
    found = {(r["to_date"], r["m_f_kg"]): r["z"] for r in links if r.get("z") is not None}
    found |= {(s["date"], s["m_f_kg"]): s["z"] for s in steps if s.get("z") is not None}
    out = []
    for row in envelope:
        if float(row["gain_kg"]) > mass_tol_kg:
            z = found.get((row["date"], float(row["m_f_kg"])))
            if z is None:
                raise ValueError(f"e6_envelope.csv: no link or walk step holds the extremal of {row['date']} "
                                 f"({row['m_f_kg']} kg)")
            out.append((row, z))
    return out


def heavier_sentence(rows: list[dict]) -> str:
    """The paper's account of ``e6_envelope_extremals.csv`` (the heavier extremals of other
    families saved, re-propagated and split by force; plain text). '' without rows."""
    if not rows:
        return ""
    col = lambda k: [float(r[k]) for r in rows if r.get(k) not in (None, "")]  # noqa: E731
    text = (f"The {len(rows)} heavier extremals of other families, saved from their unknowns "
            f"(results/perturbed/e6_envelope/), re-propagate in Cartesian coordinates to within "
            f"{max(col('final_position_vs_solver_km')):.3g} km of the solver's end point and "
            f"{max(abs(x) for x in col('final_mass_error_kg')):.2g} kg of its final mass")
    moon, closest = col("h_share_moon"), col("moon_closest_km")
    if moon and closest:
        text += (f"; they take {100 * min(moon):.0f} to {100 * max(moon):.0f} % of the change of angular momentum "
                 f"from the Moon and pass it at {min(closest):,.0f} to {max(closest):,.0f} km")
    return text + "."


def arrival(date: str, time_utc: str, tof_days: float) -> str:
    """The arrival epoch (UTC, to the minute) of a departure at ``date`` ``time_utc`` after
    ``tof_days``."""
    t = datetime.datetime.fromisoformat(f"{date}T{time_utc}") + datetime.timedelta(days=tof_days)
    return t.isoformat(timespec="minutes")


def envelope_sentence(steps: list[dict], envelope: list[dict], mass_tol_kg: float) -> str:
    """The paper's account of the walks (where each ends, :func:`walk_ends`) and the envelope
    (plain text; the caller escapes it)."""
    if not envelope:
        return ""
    if not steps:
        text = "No link met another extremal, so no family was followed on."
    else:
        walks = {(s["from_date"], s["link_to"]) for s in steps}
        counts = Counter(s["status"] for s in steps)
        text = (f"Each family that a link met was followed on, date by date, in the same direction "
                f"({len(walks)} walk{'s' if len(walks) != 1 else ''}, {len(steps)} step{'s' if len(steps) != 1 else ''}: "
                + ", ".join(f"{n} {status}" for status, n in counts.items()) + "): " + "; ".join(walk_ends(steps)) + ".")
    above = [r for r in envelope if r["gain_kg"] > mass_tol_kg]
    if not above:
        return text + " At no date is an extremal found heavier than the scan's own."
    best = max(above, key=lambda r: r["gain_kg"])
    n_max = int(max(r["extremals"] for r in envelope))
    return text + (
        f" At {len(above)} of {len(envelope)} dates an extremal found is heavier than the scan's own "
        f"(up to {best['gain_kg']:+.4f} kg at {best['date']}, on the family of {best['family_of']}); "
        f"up to {n_max} distinct local maxima of m_f in the transfer time were found at one date. "
        f"The upper envelope of them has m_f from {min(r['m_f_kg'] for r in envelope):.4f} to "
        f"{max(r['m_f_kg'] for r in envelope):.4f} kg.")


def walk_ends(steps: list[dict]) -> list[str]:
    """Where each walk (rows of :func:`step_rows`, in order) ends, in words: the family of its
    link's first date, and its last step."""
    walks: dict = {}
    for s in steps:
        walks.setdefault((s["from_date"], s["link_to"]), []).append(s)
    out = []
    for (a, b), ss in walks.items():
        last, before = ss[-1], (ss[-2]["date"] if len(ss) > 1 else b)
        end = {"other": f"is followed to {last['date']}, where the walk ends",
               "same": f"meets the scan's extremal at {last['date']}",
               "not certified": f"has no certified maximum at {last['date']}"}.get(last["status"])
        if end is None:
            end = (f"turns back between {before} and {last['date']}" if TURNED_BACK in str(last.get("reason"))
                   else f"stops between {before} and {last['date']} ({last.get('reason')})")
        out.append(f"the family of {a} (through {b}) {end}")
    return out

