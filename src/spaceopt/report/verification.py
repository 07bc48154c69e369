"""The independent verifier's results in the report: its table and the paper's sentence.

The verification itself (:mod:`spaceopt.studies.verify`: SciPy re-propagation, the solver's
force model) writes one ``*.verify.json`` per artifact; the tables and the paper read those
through this module, which imports neither SciPy's integrators nor JAX.
"""
from __future__ import annotations

import math

from .. import artifacts
from .tables import write_csv


VERIFICATION_COLUMNS = ["artifact", "final_a_error_km", "final_e_error", "final_i_error_deg", "final_L_error_deg",
                        "final_mass_error_kg", "final_position_vs_solver_km",
                        "final_position_without_perturbations_km", "thrust_probe_relative",
                        "final_position_moved_by_thrust_probe_km", "integrator", "nfev", "rtol", "success",
                        "samples_per_rev"]


def verification_rows(paths) -> list[dict]:
    """One row per ``*.verify.json`` (the artifact's name, then
    :func:`spaceopt.studies.verify.verify_ot`'s fields)."""
    rows = []
    for path in paths:
        v = artifacts.read_json(path)
        rows.append({"artifact": v["artifact"], **v["verification"]})
    return rows


def write_verification_csv(path, rows: list[dict]) -> None:
    """The verification table: the columns of :data:`VERIFICATION_COLUMNS` that any row has."""
    write_csv(path, rows, [c for c in VERIFICATION_COLUMNS if any(c in r for r in rows)] or ["artifact"])


def verification_sentence(rows: list[dict], what: str) -> str:
    """The paper's sentence on the worst final errors of the re-propagated ``what``
    (e.g. 'OT trajectories'); for perturbed rows also the largest ratio of the end-point
    distance to the distance by which the perturbations move the end point; for minimum-thrust
    rows how far the thrust probe moves their end points, and the farthest one's. '' without rows."""
    if not rows:
        return ""
    worst = {k: max(abs(float(v[k])) for v in rows)
             for k in ("final_a_error_km", "final_e_error", "final_i_error_deg", "final_mass_error_kg",
                       "final_position_vs_solver_km")}
    text = (f"An independent verifier re-propagates each of the {len(rows)} {what} in Cartesian coordinates "
            "with SciPy's DOP853 and the recorded thrust history: the worst final errors are "
            f"{worst['final_a_error_km']:.3g}~km in $a$, {worst['final_e_error']:.2g} in $e$, "
            f"{worst['final_i_error_deg']:.2g}$^\\circ$ in $i$ and {worst['final_mass_error_kg']:.2g}~kg in mass, "
            f"and the final positions differ from the solver's by at most {worst['final_position_vs_solver_km']:.3g}~km.")
    ratios = [float(v["final_position_vs_solver_km"]) / float(v["final_position_without_perturbations_km"])
              for v in rows if v.get("final_position_without_perturbations_km") not in (None, "")]
    if ratios:
        text += (" Each such difference is at most "
                 f"{100 * max(ratios):.2g}~\\% of the distance by which the perturbations move the end point "
                 "(the same control re-propagated without them).")
    probed = [v for v in rows if v.get("final_position_moved_by_thrust_probe_km") not in (None, "")]
    if probed:
        moved = lambda v: float(v["final_position_moved_by_thrust_probe_km"])      # noqa: E731
        far = max(probed, key=lambda v: float(v["final_position_vs_solver_km"]))
        text += (f" For the minimum-thrust ones among them and the least-thrust points of the thrust families "
                 f"({len(probed)}; with the engine always or nearly always on, at or near the least thrust that "
                 f"makes the transfer) a thrust changed by "
                 f"$10^{{{round(math.log10(float(probed[0]['thrust_probe_relative'])))}}}$ (relative) moves the end point by "
                 f"{min(map(moved, probed)):.3g} to {max(map(moved, probed)):.3g}~km; the one farthest from the "
                 f"solver's end point ({float(far['final_position_vs_solver_km']):.3g}~km) is one whose end point "
                 f"that change moves by {moved(far):.3g}~km.")
    return text
