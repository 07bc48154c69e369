"""§4.2 solves that failed in an earlier pass, left out so that the report is built without them.

``./dev reproduce`` runs the DAG with ``--keep-going``. A perturbed solve that does not converge
writes its diagnosis, ``<stem>.failure.json`` (:func:`spaceopt.artifacts.write_failure`), and
exits non-zero (design.md, "Errors"); every table, figure and the paper wait on its artifact, so
one failed solve out of ~90 used to cost the whole report. When a first pass leaves such a
diagnosis, ``./dev reproduce`` runs a second one with ``SPACEOPT_REPORT_FAILED=1`` in the
environment (``SPACEOPT_REPORT_FAILED=1 snakemake ...`` does the same by hand). There the
E6 dates and E8 solves whose artifact is missing and whose diagnosis is present are left out,
as ``perturbed.e6.skip_dates`` and ``perturbed.e8.skip_n_rev`` leave out the solves known
beforehand not to converge, together with the solves that start from them (a later force model
at the same count, a date warm-started from a failed date). The tables, figures and paper are
then built from what converged, the paper names each failure with its diagnosis, and
``./dev reproduce`` still exits non-zero. The next ``./dev reproduce`` (without the flag) retries
the failed solves.

The minimum-thrust solves of the existence check (:mod:`spaceopt.studies.existence`) and the
thrust families carried from another model's (:mod:`spaceopt.studies.thrust_family`) are left
out the same way. Not covered: the E5, E7 and E9 solves (their tables take every model of the
case, and dropping a model from the case would change the params of its other solves) and the
other studies; a failure there still holds the report back.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Callable, Hashable, Iterable

from ..artifacts import failure_path


def diagnosis(artifact) -> str | None:
    """The first line of the error recorded next to ``artifact`` (a solve's ``.json``) when the
    artifact is missing and its ``.failure.json`` is there; None otherwise (converged, or not
    run yet)."""
    artifact = Path(artifact)
    fail = failure_path(artifact)
    if artifact.exists() or not fail.exists():
        return None
    try:
        error = str(json.loads(fail.read_text()).get("error", ""))
    except (OSError, ValueError):
        return f"unreadable diagnosis {fail.name}"
    return error.splitlines()[0] if error.strip() else f"no error text in {fail.name}"


def left_out(solves: Iterable[Hashable], source: Callable, why: Callable, name: Callable = str) -> dict:
    """{solve: reason} for each of ``solves`` that failed itself (``why(solve)`` is its diagnosis)
    or starts, through its chain of starts (``source(solve)``, None at the chain's root), from a
    solve that failed (``name`` names that one in the reason)."""
    out = {}
    for solve in solves:
        cur = solve
        while cur is not None:
            reason = why(cur)
            if reason is not None:
                out[solve] = reason if cur == solve else f"starts from {name(cur)}, which failed"
                break
            cur = source(cur)
    return out


def without_failed(pc: dict, e6: dict, e8: dict) -> dict:
    """The perturbed config section with the failed E6 dates (``e6``: {date: reason}) added to
    ``e6.skip_dates`` and the failed E8 solves (``e8``: {(model, n_rev): reason}) to
    ``e8.skip_n_rev``."""
    skip_dates = sorted({*(pc["e6"].get("skip_dates") or []), *e6})
    skip_n_rev = {m: list(ns) for m, ns in (pc["e8"].get("skip_n_rev") or {}).items()}
    for m, n in e8:
        skip_n_rev.setdefault(m, []).append(n)
    return {**pc, "e6": {**pc["e6"], "skip_dates": skip_dates}, "e8": {**pc["e8"], "skip_n_rev": skip_n_rev}}


def failures_sentence(e6: dict, e8: dict, existence: dict | None = None, family: dict | None = None) -> str:
    """Plain text for the paper: what failed in this run and was left out, with the reasons
    (``existence``: {(case, model): reason} of the minimum-thrust check; ``family``: {(case,
    model, seed): reason} of the thrust families carried from another model's)."""
    items = [f"E6 {d} ({why})" for d, why in sorted(e6.items())]
    items += [f"E8 {m} at {n:g} revolutions ({why})" for (m, n), why in sorted(e8.items())]
    items += [f"the minimum thrust of {c.upper()} {m} ({why})" for (c, m), why in sorted((existence or {}).items())]
    items += [f"the {c.upper()} {m} thrust family carried from {s}'s ({why})" for (c, m, s), why in sorted((family or {}).items())]
    if not items:
        return ""
    return ("Failed in this run and left out of the tables and figures (each diagnosis is in the "
            "solve's failure.json; the next ./dev reproduce retries them): " + "; ".join(items) + ".")
