"""Tables and reproduction rows of the perturbed §4.2 studies (E5–E9).

Inputs are the OT stage payloads (``artifacts.read_json``) keyed as the rules name them:
``<case>_<model>`` (E5, E7, E9), ``e6_<date>``, ``e8_<model>_n<n>``. Tables (issue outputs):

    e5.csv            model, m_f_kg, tof_days, K_f_deg
    e6_date_scan.csv  date, model, m_f_kg, tof_days
    e7.csv            model, tof_days, propellant_kg
    e8.csv            n_rev, model, propellant_kg, tof_days
    e9.csv            model, n_rev, tof_days, m_p_kg, dv_m_s, burn_h

A table whose case is not in the run list is written with its header only. Beside them,
``tof_maximum.csv`` lists the free-time end game of every perturbed solve
(:func:`tof_maximum_rows`, :mod:`spaceopt.indirect.free_time`).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..report import compare
from ..report.paper import latex_escape, latex_number
from ..report.verification import verification_sentence

COLUMNS = {
    "e5": ["model", "m_f_kg", "tof_days", "K_f_deg"],
    "e6_date_scan": ["date", "model", "m_f_kg", "tof_days"],
    "e7": ["model", "tof_days", "propellant_kg"],
    "e8": ["n_rev", "model", "propellant_kg", "tof_days"],
    "e9": ["model", "n_rev", "tof_days", "m_p_kg", "dv_m_s", "burn_h"],
}
# LaTeX column headers (name, unit) of the CSV columns
HEADERS = {"model": ("model", ""), "date": ("departure", ""), "n_rev": ("revolutions", ""),
           "m_f_kg": ("$m_f$", "kg"), "tof_days": (r"$\Delta t$", "d"), "K_f_deg": ("$K_f$", "deg"),
           "propellant_kg": ("$m_p$", "kg"), "m_p_kg": ("$m_p$", "kg"), "dv_m_s": (r"$\Delta V$", "m/s"),
           "burn_h": ("burn time", "h"), "dm_f_kg": (r"$m_f - m_f^{\mathrm{unp}}$", "kg"),
           "dtof_days": (r"$\Delta t - \Delta t^{\mathrm{unp}}$", "d"),
           "scan_m_f_kg": (r"the scan's $m_f$", "kg"), "gain_kg": ("gain", "kg"), "family_of": ("family of", ""),
           "arrival_utc": ("arrival", "UTC")}
TABLE_CAPTIONS = {"e5": "E5, 5-revolution HEO to HEO (Table 4.2.1.2 scalars)",
                  "e6_date_scan": "E6, departure-date scan over May 2021: 4$\\times$4 + Moon + Sun, and the differences from the unperturbed solution",
                  "e7": "E7, 100-revolution GTO to Molniya, 1 N",
                  "e8": "E8, GTO to GEO case B against the number of revolutions",
                  "e9": "E9, 63.007-revolution LEO to LEO, 1 N (Table 4.2.3.2)"}
# What each reproduced figure shows (the dissertation's figure number is the file name)
FIGURE_CAPTIONS = {
    "fig_4_2_1_1": "E5: projections of the unperturbed and perturbed trajectories (thick: burns)",
    "fig_4_2_1_2": "E5: osculating elements against time, unperturbed and perturbed",
    "fig_4_2_1_3": "E5: switching function, pitch and yaw against time",
    "fig_4_2_1_4": "E6: final mass and transfer time against the departure date",
    "fig_4_2_1_5": "E6: initial costates against the departure date",
    "fig_4_2_1_6": "E7: GTO to Molniya, one row per force model of the case (unperturbed, J2, 4x4 + Moon + Sun, top to bottom): projections on the J2000 planes and 3-D view (thick: burns)",
    "fig_4_2_2_1": "E8: GTO to GEO case B trajectory projections",
    "fig_4_2_2_3": "E8: pitch, yaw and switching function against time",
    "fig_4_2_2_5": "E8: propellant against the number of revolutions and the transfer time",
    "fig_4_2_3_1": "E9: controls and elements of the first force model",
    "fig_4_2_3_2": "E9: controls and elements of the second force model",
    "fig_e6_force_shares": "E6: each force's share of the change of angular momentum against the departure "
                           "date, and the final mass against the Moon's share (not in the dissertation)",
    "fig_e7_thrust_family": "E7: the minimum-fuel family followed down from the case's thrust, per force model: "
                            "propellant, time of flight, largest apogee and duty; each line's least thrust is an "
                            "upper bound on the minimum thrust (not in the dissertation)",
}


def initial_burn(npz: dict) -> bool:
    """Does the trajectory start with a thrust arc (δ > ½ at K = 0)?"""
    return bool(np.asarray(npz["delta"])[0] > 0.5)


def tables(payloads: dict, run: list, cases: dict, e6: dict, e8_n: list) -> dict:
    """{table: rows} from the OT payloads."""
    out = {k: [] for k in COLUMNS}
    for case in ("e5", "e7", "e9"):
        if case not in run:
            continue
        for m in cases[case]["models"]:
            if f"{case}_{m}" not in payloads:
                continue
            s = summary(payloads[f"{case}_{m}"])
            row = {"model": m, **s, "m_p_kg": s["propellant_kg"]}
            out[case].append(row)
    if "e6" in run:
        for key in sorted(k for k in payloads if k.startswith("e6_")):
            s = summary(payloads[key])
            out["e6_date_scan"].append({"date": key[3:], "model": e6["model"], **s})
    if "e8" in run:
        for n in e8_n:
            for m in cases["e8"]["models"]:
                key = f"e8_{m}_n{float(n):g}"
                if key in payloads:
                    out["e8"].append({"n_rev": float(n), "model": m, **summary(payloads[key])})
    return out


TOF_MAXIMUM_COLUMNS = ["solve", "start", "status", "t0_days", "tof_days", "m_f_gain_g", "fixed_time_solves",
                       "jacobian_evaluations", "arclength_points", "folds_passed", "downhill_folds_passed",
                       "lift_eps", "survey_maxima", "survey_tof_spread_days", "survey_m_f_spread_g", "wall_time_s"]
MOVED_DAYS = 1e-3       # an end game that changed Δt by more than this moved the extremal


def tof_maximum_rows(payloads: dict) -> list[dict]:
    """One row per solve whose artifact records the free-time end game (``extra.tof_maximum``):
    where it started (``newton``: the free-time Newton solution; ``failed polish``: the best
    point of a free-time polish that did not converge, ``extra.polish_failure``), its status,
    the transfer time before (t0) and after it, the final mass it gained, its cost, and the
    folds of the fixed-time family it went round, and of those, the ones with φ ≠ 0 past which it
    went on downhill in m_f (``MaximumOptions.downhill_folds``; older records have none), and the
    smoothing ε at which it searched again where it found no maximum at ε_f (``lift_eps``,
    ``MaximumSearch.across_branches``; None where it did not), and where it surveyed the family
    round its maximum (``MaximumSearch.survey``), the local maxima found there (the solution is the
    heaviest) and their spread in Δt and in m_f."""
    rows = []
    for key in sorted(payloads):
        extra = payloads[key].get("extra", {})
        rec = extra.get("tof_maximum")
        if rec:
            rows.append({"solve": key, "start": "failed polish" if "polish_failure" in extra else "newton",
                         "status": rec["status"], "t0_days": rec["t0_days"],
                         "tof_days": rec.get("tof_days"),
                         "m_f_gain_g": rec["m_f_gain_kg"] * 1e3 if "m_f_gain_kg" in rec else None,
                         **{k: rec[k] for k in ("fixed_time_solves", "jacobian_evaluations", "wall_time_s")},
                         **{k: rec.get(k) for k in ("arclength_points", "folds_passed", "downhill_folds_passed")},
                         "lift_eps": rec.get("lift", {}).get("eps"), **_survey_columns(rec.get("survey"))})
    return rows


def _survey_columns(survey: dict | None) -> dict:
    """The survey's columns of :func:`tof_maximum_rows`: the count of maxima, and the spread of
    their Δt (days) and final mass (g); None where the end game made no survey."""
    if not survey:
        return {"survey_maxima": None, "survey_tof_spread_days": None, "survey_m_f_spread_g": None}
    tof, m_f = (np.array([m[i] for m in survey["maxima"]]) for i in (0, 1))
    return {"survey_maxima": len(tof), "survey_tof_spread_days": float(np.ptp(tof)),
            "survey_m_f_spread_g": float(np.ptp(m_f)) * 1e3}


def tof_maximum_sentence(rows: list[dict]) -> str:
    """What the free-time end game found, for the paper: how many extremals are certified local
    maxima of m_f in t_f, which were moved to one (and by how much), where the search failed."""
    if not rows:
        return ""
    certified = [r for r in rows if r["status"] == "maximum"]
    moved = [r for r in certified if abs(r["tof_days"] - r["t0_days"]) > MOVED_DAYS]
    failed = [r for r in rows if r["status"] != "maximum"]
    text = (f"Every perturbed extremal then goes through a free-time end game: the fixed-time extremals "
            r"at $t_f\pm\delta$ give $\varphi = p_t(K_f)$, with $dm_f/dt_f = -m_0\varphi$, and a local "
            r"maximum of $m_f$ in $t_f$ is certified by a sign change of $\varphi$ from $-$ to $+$ "
            f"(otherwise the search walks uphill to the next one). Of {len(rows)} perturbed solves, "
            f"{len(certified)} are certified maxima")
    if moved:
        top = max(moved, key=lambda r: abs(r["m_f_gain_g"]))
        text += (f"; {len(moved)} of them were moved there from the Newton solution, by up to "
                 f"{top['m_f_gain_g']:.2f} g of final mass ({latex_escape(top['solve'])}, $\\Delta t$ "
                 f"{top['t0_days']:.4f} $\\to$ {top['tof_days']:.4f} d)")
    text += "."
    unpolished = [r for r in certified if r.get("start") == "failed polish"]
    if unpolished:
        text += (" Where the free-time polish did not converge, the search starts from its best point and "
                 "the maximum it certifies is the solution (" +
                 ", ".join(latex_escape(r["solve"]) for r in unpolished) + ").")
    folds = [r for r in certified if r.get("folds_passed")]
    if folds:
        text += (" Where the fixed-time family folds in $t_f$, the search follows it by pseudo-arclength "
                 "in $(z, t_f)$ round the fold (" + ", ".join(latex_escape(r["solve"]) for r in folds) + ").")
    downhill = [r for r in certified if r.get("downhill_folds_passed")]
    if downhill:
        text += (" Where the branch through the start ends in a fold with $\\varphi \\neq 0$ (a maximum of "
                 "$m_f$ along the family that is no free-time extremal), the search goes on downhill along the "
                 "family to the maximum of a branch beyond, which can be lighter than the start (" +
                 ", ".join(f"{latex_escape(r['solve'])}: ${r['m_f_gain_g']:+.2f}$ g" for r in downhill) + ").")
    lifted = [r for r in certified if r.get("lift_eps")]
    if lifted:
        text += (" Where the search found no maximum at $\\varepsilon_f$ (the family folds with $\\varphi \\neq 0$), "
                 "it searched again on the family at a larger smoothing $\\varepsilon$, across its branches, and "
                 "went back down to $\\varepsilon_f$ at the time of that problem's maximum, where the search at "
                 "$\\varepsilon_f$ certified the maximum of the branch it landed on (" +
                 ", ".join(f"{latex_escape(r['solve'])}: $\\varepsilon$ {r['lift_eps']:g}, $\\Delta t$ "
                           f"{r['t0_days']:.4f} $\\to$ {r['tof_days']:.4f} d" for r in lifted) + ").")
    surveyed = [r for r in certified if r.get("survey_maxima")]
    if surveyed:
        text += (" Where the end game surveyed the family round its maximum (followed by arclength both ways "
                 "within a window of $t_f$, every sign change of $\\varphi$ from $-$ to $+$ solved), the solution "
                 "is the heaviest local maximum found (" +
                 ", ".join(f"{latex_escape(r['solve'])}: {r['survey_maxima']} maxim{'um' if r['survey_maxima'] == 1 else 'a'}, $\\Delta t$ within "
                           f"{r['survey_tof_spread_days']:.3f} d, $m_f$ within {r['survey_m_f_spread_g']:.2f} g"
                           for r in surveyed) + ").")
    if failed:
        text += (" The search did not certify " + ", ".join(
            f"{latex_escape(r['solve'])} ({latex_escape(r['status'])})" for r in failed) + ".")
    return text + " "


def summary(payload: dict) -> dict:
    """Table scalars of an OT artifact payload."""
    s = payload["scalars"]
    tr = payload["transfer"]
    m_p = tr["m0"] - s["m_f_kg"]
    return {"m_f_kg": s["m_f_kg"], "tof_days": s["tof_days"], "K_f_deg": s["K_f_deg"],
            "propellant_kg": m_p, "dv_m_s": s["dv_m_s"], "burn_h": s["burn_days"] * 24.0,
            "burn_fraction": s["burn_fraction"], "n_rev": tr["n_rev"]}


def summary_or_none(payloads: dict, key: str):
    return summary(payloads[key]) if key in payloads else None


def write_rows(path, rows):
    compare.write_rows(path, rows)


def e6_with_unperturbed(rows: list, unperturbed: dict | None) -> list:
    """Add the date-independent unperturbed line (the E5 unperturbed solve) to every date."""
    if unperturbed is None:
        return rows
    out = []
    for r in rows:
        out.append(r)
        out.append({"date": r["date"], "model": "unperturbed", "m_f_kg": unperturbed["m_f_kg"],
                    "tof_days": unperturbed["tof_days"]})
    return out


def e6_summary(rows: list, unperturbed: dict | None, skipped=()) -> dict:
    """Extreme and mean gains of final mass and changes of transfer time over the month, over
    the dates that were run; ``skipped``: the dates left out (``perturbed.e6.skip_dates``),
    listed in the summary as 'skipped_dates'."""
    pert = [r for r in rows if r["model"] != "unperturbed"]
    if not pert or unperturbed is None:
        return {}
    dm = np.array([r["m_f_kg"] - unperturbed["m_f_kg"] for r in pert])
    dt = np.array([r["tof_days"] - unperturbed["tof_days"] for r in pert])
    dates = [r["date"] for r in pert]
    return {"dm_max_kg": float(dm.max()), "dm_max_date": dates[int(dm.argmax())],
            "dm_min_kg": float(dm.min()), "dm_min_date": dates[int(dm.argmin())],
            "dm_mean_kg": float(dm.mean()), "dt_mean_days": float(dt.mean()),
            "dt_max_days": float(dt.max()), "dt_max_date": dates[int(dt.argmax())],
            "dt_min_days": float(dt.min()), "dt_min_date": dates[int(dt.argmin())],
            "n_dates": len(pert), **({"skipped_dates": ", ".join(skipped)} if skipped else {})}


def e8_by_count(tabs: dict) -> dict:
    """{n_rev: {model: row}} of the E8 table."""
    by = {}
    for r in tabs["e8"]:
        by.setdefault(r["n_rev"], {})[r["model"]] = r
    return by


def e8_paired_counts(by: dict) -> list:
    """The counts (ascending) with both an unperturbed and a 4×4 + Moon + Sun solve."""
    return sorted(n for n, d in by.items() if "unperturbed" in d and "g44_moon_sun" in d)


def ours(tabs: dict, payloads: dict, npzs: dict, budget: dict | None) -> dict:
    """(case, quantity) → our value, for the published file's keys."""
    o = {}
    for r in tabs["e5"]:
        for q in ("m_f_kg", "tof_days", "K_f_deg"):
            o[(f"e5_{r['model']}", q)] = r[q]
    if "e5_g44_moon_sun" in npzs:
        o[("e5_g44_moon_sun", "no_initial_burn")] = str(not initial_burn(npzs["e5_g44_moon_sun"])).lower()
    if "e5_unperturbed" in npzs:
        o[("e5_unperturbed", "initial_burn")] = str(initial_burn(npzs["e5_unperturbed"])).lower()
        u = [r for r in tabs["e5"] if r["model"] == "unperturbed"]
        if u:
            o[("e6_unperturbed", "m_f_kg")] = u[0]["m_f_kg"]
            o[("e6_unperturbed", "tof_days")] = u[0]["tof_days"]
    for r in tabs["e8"]:
        tag = f"e8_{r['model']}_n{r['n_rev']:g}"
        o[(tag, "propellant_kg")] = r["propellant_kg"]
        o[(tag, "tof_days")] = r["tof_days"]
    by = e8_by_count(tabs)
    u500 = by.get(500.0, {}).get("unperturbed")
    if u500:
        for q in ("propellant_kg", "tof_days"):
            o[("e8_aziz_unperturbed_n500", q)] = u500[q]
    p500 = by.get(500.0, {}).get("g44_moon_sun")
    if p500:
        for q in ("propellant_kg", "tof_days"):
            o[("e8_aziz_perturbed_n500", q)] = p500[q]
    pairs = [(n, by[n]["unperturbed"], by[n]["g44_moon_sun"]) for n in e8_paired_counts(by)]
    if pairs:
        dm = [p["propellant_kg"] - u["propellant_kg"] for _, u, p in pairs]
        o[("e8", "perturbation_costs_fuel")] = str(all(x > 0 for x in dm)).lower()
        o[("e8", "fuel_increase_min_kg")] = min(dm)
        o[("e8", "fuel_increase_max_kg")] = max(dm)
        for n, u, p in pairs:
            if n == 500.0:
                o[("e8", "dtime_500_days")] = p["tof_days"] - u["tof_days"]
        # §4.2.2: the perturbations shorten the transfer by 0.554…1.024 d, except at 500 rev
        shortening = [u["tof_days"] - p["tof_days"] for n, u, p in pairs if n != 500.0]
        if shortening:
            o[("e8", "perturbation_shortens_time_below_500")] = str(all(x > 0 for x in shortening)).lower()
            o[("e8", "time_decrease_min_days")] = min(shortening)
            o[("e8", "time_decrease_max_days")] = max(shortening)
    e9 = {r["model"]: r for r in tabs["e9"]}
    if "j2" in e9:
        for q in ("tof_days", "m_p_kg", "dv_m_s", "burn_h"):
            o[("e9_j2", q)] = e9["j2"][q]
    if "j2" in e9 and "g44" in e9:
        o[("e9", "g44_less_fuel_than_j2")] = str(e9["g44"]["m_p_kg"] < e9["j2"]["m_p_kg"]).lower()
        o[("e9", "g44_shorter_than_j2")] = str(e9["g44"]["tof_days"] < e9["j2"]["tof_days"]).lower()
    if "g44" in e9 and "g44_moon_sun" in e9:
        rel = abs(e9["g44_moon_sun"]["m_p_kg"] - e9["g44"]["m_p_kg"]) / e9["g44"]["m_p_kg"]
        o[("e9", "moon_sun_change_little")] = str(rel < 0.01).lower()
    if budget:
        o[("e9_draan_5d", "draan_deg")] = budget["egm96_gm"]["draan_deg"]
        o[("e9_dargp_5d", "dargp_deg")] = budget["egm96_gm"]["dargp_deg"]
    return o


E5U_OTHER = ("another extremal of the same problem: ours coasts at K = 0 (S(0) < 0) and keeps 0.87 kg more "
             "than the thesis's, which starts with a burn (printed p_LK(0) < 0); reached by LP -> T_min -> OT, "
             "the (3.3.1) blend path the thesis followed folds here (tau 0.172 / 0.972); a jump over the fold, "
             "11 random starts, starts along the printed costates (both unit scales searched; both columns at "
             "their best-fitting units), continuations "
             "in the thrust (0.45-1 N) and from L0 = 100 deg all end on ours (docs/e5-extremals.md)")
E5P_OTHER = ("the zero-guess chain folds (T_min -> OT, tau 0.286); fallback warm start from our unperturbed extremal "
             "(perturbation strength in arclength, S-shaped fold pair at tau 0.22-0.32) reaches an extremal ~5 d "
             "longer: a different extremal, beyond model choices (ERA, UT1=UTC, TDB, EGM96 GM/a_e, central mu)")
E8_TIME_SIGN = ("at 450 rev every certified maximum of m_f is 2.3-2.8 d longer than the unperturbed transfer; the "
                "free-time condition is flat there: along the fixed-time family through them |p_t(K_f)| <= 2.1e-6 "
                "from 286.74 to 290.49 d (m_f within 49 g), below the thesis's residual level (its E5 Table 4.2.1.3: "
                "relative errors 1e-5-8.5e-5), so a solve at that level does not fix the sign of the time change "
                "at 450 (docs/perturbed-e6-e7-e8.md, forty-fourth and fifty-sixth sessions)")
MISS_NOTES = {
    ("e5_unperturbed", "m_f_kg"): E5U_OTHER,
    ("e5_unperturbed", "tof_days"): E5U_OTHER,
    ("e5_unperturbed", "K_f_deg"): E5U_OTHER,
    ("e5_unperturbed", "initial_burn"): E5U_OTHER,
    ("e6_unperturbed", "m_f_kg"): E5U_OTHER,
    ("e6_unperturbed", "tof_days"): E5U_OTHER,
    ("e5_g44_moon_sun", "m_f_kg"): E5P_OTHER,
    ("e5_g44_moon_sun", "tof_days"): E5P_OTHER,
    ("e5_g44_moon_sun", "K_f_deg"): E5P_OTHER,
    ("e5_g44_moon_sun", "no_initial_burn"): E5P_OTHER + "; ours starts with a burn, our unperturbed does not",
    ("e8", "perturbation_shortens_time_below_500"): E8_TIME_SIGN,
    ("e8", "time_decrease_min_days"): E8_TIME_SIGN,
    ("e9_j2", "tof_days"): "J2 pole = frozen CIP of 9 May 2021 (~0.1 deg from ICRS z); EGM96 J2, a_e, GM",
}


E8_RANGE = ("perturbation_costs_fuel", "fuel_increase_min_kg", "fuel_increase_max_kg", "dtime_500_days",
            "perturbation_shortens_time_below_500", "time_decrease_min_days", "time_decrease_max_days")


def e8_range_notes(tabs: dict, e8_n: list) -> dict:
    """Notes on the E8 range statements (§4.2.2: over 200–500 revolutions) when our perturbed /
    unperturbed pairs do not cover every count of ``e8_n``: the counts they are taken over."""
    paired = e8_paired_counts(e8_by_count(tabs))
    if not paired or set(paired) >= {float(n) for n in e8_n}:
        return {}
    note = ("over the counts with both solves only, n_rev = " + ", ".join(f"{n:g}" for n in paired) +
            " (the published range is over 200-500)")
    return {("e8", q): note for q in E8_RANGE}


def reproduction_rows(published_path, o: dict, notes: dict | None = None) -> list[dict]:
    """Compared rows; ``notes`` ({(case, quantity): text}) are added to their rows whatever the status."""
    rows = compare.compare(published_path, o)
    for r in rows:
        if (r["case"], r["quantity"]) in (notes or {}):
            r["note"] = "; ".join(s for s in (r["note"], notes[(r["case"], r["quantity"])]) if s)
        if r["status"] == "missing":
            r["note"] = "; ".join(s for s in (r["note"], "not produced in this run (not in the run list, or its solve did not converge: see the study log)") if s)
        elif r["status"] == "fail" and (r["case"], r["quantity"]) in MISS_NOTES:
            r["note"] = "; ".join(s for s in (r["note"], MISS_NOTES[(r["case"], r["quantity"])]) if s)
    return rows


def _fmt(v, digits=6):
    if isinstance(v, float):
        if math.isnan(v):
            return "--"
        return f"{v:.{digits}f}"
    return str(v)


def _cell(column: str, value) -> str:
    """A LaTeX table cell: revolutions as given, other numbers in math mode (a true minus sign)."""
    if column == "n_rev" and isinstance(value, float):
        return f"{value:g}"
    text = _fmt(value)
    return f"${text}$" if isinstance(value, float) and text != "--" else latex_escape(text)


def markdown(tabs: dict, e6sum: dict | None = None, budget: dict | None = None) -> str:
    out = ["# Perturbed studies (dissertation §4.2), reproduced\n"]
    if budget:
        g = budget["egm96_gm"]
        out.append(f"E9 ΔΩ budget: natural J2 drift {g['draan_deg']:.3f} deg in {budget['days']:g} d "
                   f"(required {budget['required_draan_deg']:.2f} deg); apsidal drift {g['dargp_deg']:.3f} deg "
                   f"(target ω_f {budget['required_dargp_deg']:.3f} deg)\n")
    if e6sum:
        out.append("E6 summary: " + ", ".join(f"{k} = {_fmt(v, 4)}" for k, v in e6sum.items()) + "\n")
    for name, cols in COLUMNS.items():
        out.append(f"### {name}\n")
        out.append("| " + " | ".join(cols) + " |")
        out.append("|" + "---|" * len(cols))
        for r in tabs[name]:
            out.append("| " + " | ".join(_fmt(r.get(c, "")) for c in cols) + " |")
        out.append("")
    return "\n".join(out) + "\n"


def e6_wide(rows: list) -> list:
    """The E6 rows one line per date: the perturbed m_f and Δt and their differences from the
    unperturbed line of the same date (the LaTeX table; the CSV keeps one row per model)."""
    unp = {r["date"]: r for r in rows if r["model"] == "unperturbed"}
    return [{"date": r["date"], "m_f_kg": r["m_f_kg"], "tof_days": r["tof_days"],
             **({"dm_f_kg": r["m_f_kg"] - unp[r["date"]]["m_f_kg"],
                 "dtof_days": r["tof_days"] - unp[r["date"]]["tof_days"]} if r["date"] in unp else {})}
            for r in rows if r["model"] != "unperturbed"]


LATEX_LAYOUT = {"e6_date_scan": (["date", "m_f_kg", "tof_days", "dm_f_kg", "dtof_days"], e6_wide)}
# the table of the E6 dates where an extremal heavier than the scan's was found (perturbed.e6.walks)
E6_ENVELOPE_COLUMNS = ["date", "scan_m_f_kg", "m_f_kg", "tof_days", "gain_kg", "family_of", "arrival_utc"]
E6_ENVELOPE_CAPTION = ("E6, the dates where an extremal heavier than the scan's was found: a neighbouring date's "
                       "family, continued in the departure epoch (family links and walks, perturbed.e6.links and "
                       "perturbed.e6.walks)")


def latex(tabs: dict, e6_envelope=()) -> str:
    """The LaTeX tables; ``e6_envelope``: rows of ``e6_envelope.csv``
    (:func:`spaceopt.studies.scan_walks.envelope_rows`): after the E6 table, its dates whose
    heaviest extremal found is another date's family."""
    out = []
    for name, cols in COLUMNS.items():
        if tabs[name]:
            cols, layout = LATEX_LAYOUT.get(name, (cols, list))
            out += _latex_table(TABLE_CAPTIONS[name] + ", ours", cols, layout(tabs[name]))
        if name == "e6_date_scan":
            heavier = [r for r in e6_envelope if r["family_of"] != r["date"]]
            if heavier:
                out += _latex_table(latex_escape(E6_ENVELOPE_CAPTION), E6_ENVELOPE_COLUMNS, heavier)
    return "\n".join(out) + "\n"


def _latex_table(caption: str, cols: list, rows: list) -> list:
    out = [r"\begin{table}[htbp]\centering\small", r"\caption{" + caption + ".}",
           r"\begin{tabular}{l" + "r" * (len(cols) - 1) + "}", r"\toprule",
           " & ".join(HEADERS[c][0] + (f", {HEADERS[c][1]}" if HEADERS[c][1] else "") for c in cols) + r" \\",
           r"\midrule"]
    out += [" & ".join(_cell(c, r.get(c, "")) for c in cols) + r" \\" for r in rows]
    return out + [r"\bottomrule", r"\end{tabular}", r"\end{table}"]


MODEL_TEX = {"unperturbed": "unperturbed", "j2": "$J_2$", "g44": "4$\\times$4",
             "g44_moon_sun": "4$\\times$4 + Moon + Sun"}


def e8_step_text(step: dict) -> str:
    """One force-model step of the E8 route (:func:`.perturbed_config.e8_model_steps`) in words."""
    how = ["in arclength" if step["path"] == "arclength" else "in $\\tau$"]
    if step["arcs"] > 1:
        how.append(f"by multiple shooting over {step['arcs']} arcs")
    if step["step_rcond"] > 0:
        how.append(f"with Newton steps truncated below ${latex_number(step['step_rcond'])}\\,\\sigma_{{\\max}}$")
    if step["flat_step"] > 0:
        how.append("its end point found along the Jacobian's flattest direction where Newton's polish fails")
    start = step.get("from")
    source = f" from the {MODEL_TEX.get(start, start)} extremal" if start else ""
    by_start = {}
    for n, model in sorted(step.get("from_at_n_rev", {}).items()):
        by_start.setdefault(model, []).append(f"{n:g}")
    counts = "".join(f", at {' and '.join(ns)} revolutions from the {MODEL_TEX.get(m, m)} extremal"
                     for m, ns in by_start.items())
    return f"to {MODEL_TEX.get(step['model'], step['model'])}{source} ({', '.join(how)}){counts}"


def e8_route_text(count_start: str, smoothing: dict, steps: list) -> str:
    """The sentences on how the E8 counts and models start (``count_start``: the config's
    perturbed.e8.count_start; ``smoothing``: :func:`.perturbed_config.e8_smoothing`, the ε values;
    ``steps``: :func:`.perturbed_config.e8_model_steps`, the force-model steps after $J_2$)."""
    eps = {k: latex_number(v) for k, v in smoothing.items() if k != "switching"}
    step_text = ": " + "; then ".join(e8_step_text(s) for s in steps) if steps else ""
    if smoothing.get("switching") == "exact":
        return ("Each revolution count of the GTO$\\to$GEO series is a chain of its own from the zero guess, "
                f"which stops its smoothing at $\\varepsilon={eps['eps_blend']}$: Newton takes that extremal to "
                "the exact bang-bang problem ($\\varepsilon=0$, the switches located on the trajectory and the "
                "Jacobian carried across them by saltation matrices), on which every later solve of the series "
                "stays: $J_2$ is switched on by $\\tau$, then the force model changed by blending the perturbing "
                "accelerations, by single shooting" + step_text + ". ")

    def at(key):
        return r"$\varepsilon_f$" if smoothing[key] == smoothing["eps_final"] else f"$\\varepsilon={eps[key]}$"
    counts = {
        "chain": "Each revolution count of the GTO$\\to$GEO series is a chain of its own from the zero "
                 "guess, so the counts are independent solves. ",
        "previous": "Each revolution count of the GTO$\\to$GEO series starts from the next smaller one, "
                    f"the angular range being moved at the smoothing $\\varepsilon={eps['eps_blend']}$ "
                    "between an $\\varepsilon$ homotopy up and one back down (moved at $\\varepsilon_f$ "
                    "the path crawls as burn arcs appear). "}[count_start]
    text = (counts + f"The perturbed counts start from the unperturbed one, $J_2$ switched on at "
            f"{at('perturb_at_eps')}, then the force model changed at {at('model_step_at_eps')} by "
            "blending the perturbing accelerations")
    return text + step_text + ". "


def paper_section(rows: list, tabs: dict, budget: dict | None, e6sum: dict, figures: list, *,
                  e8_count_start: str, smoothing: dict, e8_steps: list, verify_rows=(), tof_rows=(),
                  e8_skipped=(), failures: str = "", e6_families: str = "", force_shares: str = "",
                  existence: str = "", resultsdir_macro=r"\resultsdir") -> str:
    """LaTeX fragment of the §4.2 section; every number comes from the artifacts or the config.
    ``e8_count_start``, ``smoothing``, ``e8_steps``: how each E8 count and model starts
    (:func:`e8_route_text`); ``verify_rows``: the independent re-propagations
    (:func:`spaceopt.report.verification.verification_rows`); ``tof_rows``: the free-time end games
    (:func:`tof_maximum_rows`); ``e8_skipped``: the (model, n_rev) the run leaves out
    (``perturbed.e8.skip_n_rev``, :func:`spaceopt.studies.perturbed_config.e8_skipped`), named in the text;
    ``failures``: the solves that failed in this run and were left out, with their diagnoses
    (:func:`spaceopt.studies.failed_solves.failures_sentence`; plain text);
    ``e6_families``: the scan's families and the envelope of the extremals found
    (:func:`spaceopt.studies.scan_families.families_sentence`,
    :func:`spaceopt.studies.scan_walks.envelope_sentence`; plain text); ``force_shares``: what each
    force contributes to the change of the orbit (:func:`spaceopt.studies.force_shares.shares_sentence`;
    plain text); ``existence``: the minimum thrust under each force model
    (:func:`spaceopt.studies.existence.sentence`; LaTeX)."""
    n_pass = sum(r["status"] == "pass" for r in rows)
    n_fail = sum(r["status"] == "fail" for r in rows)
    n_miss = sum(r["status"] == "missing" for r in rows)
    lines = [r"\section{Perturbed multi-revolution transfers (dissertation \S4.2)}\label{sec:perturbed}",
             "Each chain starts from the zero guess with the minimum-power (LP) solve. The minimum-fuel "
             r"solution is reached either by the LP $\to$ minimum-fuel homotopy (3.3.1), which also switches "
             r"the perturbations on, or (E5) through the minimum-thrust solution and a $T_{min}\to$ "
             r"minimum-fuel homotopy, then a log-uniform smoothing stage to "
             f"$\\varepsilon_f={latex_number(smoothing['eps_final'])}$. "
             "Where the zero-guess chain of a perturbed case does not converge, the run warm-starts from "
             "our unperturbed extremal by a homotopy in the perturbation strength and says so in its "
             "artifact and its reproduction notes; the 4$\\times$4 LEO runs start from the $J_2$ solution "
             "(the perturbing accelerations of the two models blended). Each departure date of the scan starts from the "
             "unperturbed extremal in the same way, so every date is an independent solve. "
             + e8_route_text(e8_count_start, smoothing, e8_steps)
             + (r"Left out of this run (\texttt{perturbed.e8.skip\_n\_rev}, counts whose route is known "
                "not to converge; the E8 table has no row for them): "
                + ", ".join(f"{latex_escape(m)} at {n:g} revolutions" for m, n in e8_skipped) + ". "
                if e8_skipped else "")
             + (latex_escape(failures) + " " if failures else "")
             + tof_maximum_sentence(list(tof_rows))
             + f"Of the reproduction rows, {n_pass} pass, {n_fail} fail "
             f"and {n_miss} were not produced in this run (Table~\\ref{{tab:scoreboard}}). "
             + verification_sentence(list(verify_rows), "perturbed trajectories (its perturbing accelerations are "
                                     "the solver's force model, evaluated at the re-propagated positions)")
             + (" " + latex_escape(force_shares) if force_shares else "")
             + (" " + existence if existence else ""), ""]
    if budget:
        g = budget["egm96_gm"]
        lines += [r"\subsection{LEO $\Delta\Omega$ budget}",
                  f"With EGM96 $J_2$, the natural nodal drift of the initial LEO is "
                  f"${g['raan_deg_per_day']:.4f}^\\circ$/d, i.e. ${g['draan_deg']:.3f}^\\circ$ in "
                  f"{budget['days']:g}~d against the required ${budget['required_draan_deg']:.2f}^\\circ$; "
                  f"the apsidal drift ${g['dargp_deg']:.3f}^\\circ$ matches the target "
                  f"$\\omega_f={budget['required_dargp_deg']:.3f}^\\circ$. The control must slow the "
                  f"regression by ${budget['control_must_change_draan_by_deg']:.3f}^\\circ$."
                  + (f" A free Cartesian coast with the $J_2$ model (frozen pole of the epoch) gives an "
                     f"osculating $\\Delta\\Omega$ of ${budget['numeric_coast']['draan_deg']:.3f}^\\circ$ "
                     f"(the osculating $\\omega$ of this near-circular orbit is not meaningful)."
                     if "numeric_coast" in budget else ""), ""]
    if e6sum:
        lines += [r"\subsection{Departure-date scan}",
                  f"Over {e6sum['n_dates']} departure dates the perturbations change the final mass by "
                  f"{e6sum['dm_min_kg']:+.3f} kg ({latex_escape(e6sum['dm_min_date'])}) to "
                  f"{e6sum['dm_max_kg']:+.3f} kg ({latex_escape(e6sum['dm_max_date'])}), mean "
                  f"{e6sum['dm_mean_kg']:+.3f} kg; the transfer time changes by "
                  f"{e6sum['dt_mean_days']:+.3f} d on average."
                  + (f" Left out of this run (\\texttt{{perturbed.e6.skip\\_dates}}): "
                     f"{latex_escape(e6sum['skipped_dates'])}." if e6sum.get("skipped_dates") else "")
                  + (" " + latex_escape(e6_families) if e6_families else ""), ""]
    lines.append(r"\input{" + resultsdir_macro + "/perturbed/tables/perturbed.tex}")
    for f in figures:
        stem = Path(f).stem
        lines += [r"\begin{figure}[htbp]\centering",
                  r"\includegraphics[width=\linewidth,height=0.75\textheight,keepaspectratio]{"
                  + resultsdir_macro + "/perturbed/figures/" + stem + ".pdf}",
                  r"\caption{" + latex_escape(FIGURE_CAPTIONS.get(stem, stem))
                  + (" (dissertation " + latex_escape(stem.replace("fig_", "Fig. ").replace("_", ".")) + ")"
                     if stem[4:5].isdigit() else "") + ".}",
                  r"\end{figure}"]
    return "\n".join(lines) + "\n"
