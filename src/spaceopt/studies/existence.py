"""Does the transfer exist with the perturbations on? The minimum-thrust check of the §4.2 cases.

The dissertation decides whether a transfer with thrust T exists over a given angular range by
the minimum-thrust problem (§3.4: fixed angular range, optimal time, T itself the cost; T < T_min
means no transfer, and about n·T_min/T revolutions would be needed). Its tables give T_min for
the unperturbed §4.1 cases only. Here the same check is made for each §4.2 case under each force
model, from the zero guess as the rest of the chain (spec 01-methods §1.7 and §3.3; issue: the
perturbed LP, T_min and OT chains all start from the zero guess):

1. the LP, with the perturbations on where the case says ``lp_perturbed`` (E9: the node's
   precession does the plane change, spec 02-multirev §6);
2. the (3.4.1) homotopy LP → T_min (``chain.solve_tmin``), whose τ also switches the
   perturbations on; with time-dependent perturbations t is a state and p_t(K_f) = 0 is the
   optimal-time condition;
3. the verdict for the case's thrust (``chain.existence_verdict``).

Where the (3.4.1) path folds (E7), the check starts instead from the case's converged OT
solution and follows the T_min → OT homotopy back (:func:`solve_from_ot`,
``spaceopt.indirect.tmin_from_ot``): it reaches T_min, or stops at a fold and gives an upper
bound on it (``T_min_is``), which still decides "exists" for any thrust at or above it.

Where that path folds at once too (E7 with 4×4 + Moon + Sun, at τ 0.995), the bound of another
force model of the case (J2) is carried over to it at its fixed τ by blending the force model
(:func:`solve_from_bound`, ``tmin_from_ot.bound_in_model``): again an upper bound.

Not in the dissertation; the results are ours (``results/perturbed/existence.csv``).
The solve functions import the solver when called: the table and the paper's sentence
(:func:`row`, :func:`sentence`) load without it.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from ..indirect.chain import Solution
    from ..indirect.tmin_from_ot import FromOtOptions
    from ..indirect.transfer import Transfer

COLUMNS = ("case", "model", "n_rev", "thrust_N", "T_min_N", "T_min_is", "exists", "n_rev_needed", "tof_days",
           "K_f_deg", "lp_perturbed", "route", "bound_from")


def _with_verdict(tm: Solution, thrust_N: float) -> tuple[Solution, dict]:
    from ..indirect import chain
    verdict = chain.existence_verdict(tm, thrust_N)
    tm.extra["verdict"] = verdict
    return tm, verdict


def solve(tr: Transfer, label: str, lp_perturbed: bool = False, options=None) -> tuple[Solution, dict]:
    """The minimum-thrust solution of ``tr`` (perturbed when ``tr`` is) from the zero guess, and
    the verdict for ``tr.thrust``."""
    from ..indirect import chain
    lp = chain.solve_lp(tr, options, label=f"{label}/lp", perturbed=lp_perturbed and tr.perturbed)
    tm = chain.solve_tmin(lp, options, label=f"{label}/tmin")
    tm.extra.update({"lp_perturbed": lp.shooting.model.perturbed, "route": "lp-tmin",
                     "lp": {k: lp.extra[k] for k in ("J_LP_m2s3", "dv_m_s", "tof_s")}})
    return _with_verdict(tm, tr.thrust)


def solve_from_ot(ot: Solution, label: str, options: FromOtOptions | None = None) -> tuple[Solution, dict]:
    """T_min, or an upper bound on it, from the converged OT solution ``ot`` of the case, and the
    verdict for its thrust (``options``: the defaults of ``FromOtOptions`` where None)."""
    from ..indirect.tmin_from_ot import FromOtOptions, solve_tmin_from_ot
    tm = solve_tmin_from_ot(ot, options or FromOtOptions(), label=f"{label}/tmin from ot")
    tm.extra["lp_perturbed"] = False
    return _with_verdict(tm, ot.thrust_N)


def solve_from_bound(bound: Solution, tr: Transfer, from_model: str, label: str,
                     options: FromOtOptions | None = None) -> tuple[Solution, dict]:
    """An upper bound on T_min under the force model of ``tr``, carried over from ``bound``, the
    upper bound of the case's model ``from_model``, and the verdict for the OT thrust that bound
    was found from (the case's)."""
    from ..indirect.tmin_from_ot import FromOtOptions, bound_in_model
    tm = bound_in_model(bound, tr, options or FromOtOptions(), label=f"{label}/bound from {from_model}")
    tm.extra.update({"lp_perturbed": False, "bound_from": from_model})
    return _with_verdict(tm, bound.extra["T_ot_N"])


def row(case: str, model: str, payload: dict) -> dict:
    """One row of the table from a minimum-thrust artifact."""
    v, s = payload["extra"]["verdict"], payload["scalars"]
    return {"case": case, "model": model, "n_rev": v["n_rev"], "thrust_N": v["thrust_N"],
            "T_min_N": v["T_min_N"], "T_min_is": v.get("T_min_is", "minimum"), "exists": v["exists"],
            "n_rev_needed": v["n_rev_needed_estimate"], "tof_days": s["tof_days"], "K_f_deg": s["K_f_deg"],
            "lp_perturbed": payload["extra"]["lp_perturbed"], "route": payload["extra"].get("route", "lp-tmin"),
            "bound_from": payload["extra"].get("bound_from", "")}


def _verdict(row: dict):
    """The verdict of a row, as written (True, False, None: undecided) or read back from the CSV (text)."""
    return {"True": True, "False": False}.get(str(row["exists"]))


def _is_bound(row: dict) -> bool:
    return row.get("T_min_is", "minimum") == "upper bound"


def sentence(rows: list, model_names: dict) -> str:
    """LaTeX for the paper: T_min per case and model (``model_names``: model key → LaTeX), the
    change against the unperturbed value (in per cent, or as a factor), and where the verdict for
    the case's thrust differs between the models; an upper bound is written "≤" and its route
    named. '' without rows."""
    parts = []
    for case in dict.fromkeys(r["case"] for r in rows):
        rs = [r for r in rows if r["case"] == case]
        base = next((float(r["T_min_N"]) for r in rs if r["model"] == "unperturbed" and not _is_bound(r)), None)
        items = []
        for r in rs:
            t, name = float(r["T_min_N"]), model_names.get(r["model"], r["model"])
            ratio = t / base if base and r["model"] != "unperturbed" and not _is_bound(r) else None   # not of bounds
            change = "" if ratio is None else (f" ({100 * (ratio - 1):+.1f}\\,\\%)" if 0.5 < ratio < 2
                                               else f" ($\\times{ratio:.3g}$)")
            le = "$\\le$ " if _is_bound(r) else ""
            items.append(f"{name} {le}{t:.4g}~N{change}")
        text = (f"{case.upper()} ({float(rs[0]['n_rev']):g} revolutions, $T = {float(rs[0]['thrust_N']):g}$~N): "
                + "; ".join(items))
        no, yes = [r for r in rs if _verdict(r) is False], [r for r in rs if _verdict(r) is True]
        open_ = [r for r in rs if _verdict(r) is None]
        names = lambda group: ", ".join(model_names.get(r["model"], r["model"]) for r in group)  # noqa: E731
        if no and yes:
            text += (f"; the thrust is below $T_{{min}}$ for {names(no)} (no transfer over this angular range; "
                     + ", ".join(f"about {float(r['n_rev_needed']):.0f}" for r in no)
                     + f" revolutions would be needed) and above it for {names(yes)}")
        elif no:
            text += f"; the thrust is below $T_{{min}}$ for {names(no)}: no transfer over this angular range"
        if open_:
            text += f"; the thrust is below the upper bound for {names(open_)}: undecided"
        if any(_is_bound(r) for r in rs):
            text += (" (upper bounds: the (3.4.1) path from the LP folds, and the $T_{min}\\to$OT homotopy followed "
                     "back from the case's minimum-fuel solution stops at a fold short of $T_{min}$; its point of least "
                     "thrust is a transfer with a throttle at most 1, so every thrust at or above the bound has one"
                     + "".join(f"; the bound for {model_names.get(r['model'], r['model'])} is that for "
                               f"{model_names.get(r['bound_from'], r['bound_from'])} carried over at its point of the "
                               "homotopy by blending the force model, as its own path folds at once"
                               for r in rs if r.get("bound_from")) + ")")
        parts.append(text)
    if not parts:
        return ""
    return ("Does the transfer exist with the perturbations on? The minimum-thrust problem (\\S3.4: fixed angular "
            "range, optimal time) of each case under each force model, from the zero guess (the LP, then the "
            "(3.4.1) homotopy, which switches the perturbations on; not in the dissertation, whose tables give "
            "$T_{min}$ of unperturbed cases only) gives $T_{min}$: " + ". ".join(parts) + ".")
