"""Tables of the §4.1 studies: anchors, Table 4.1.3, verification and the reproduction rows."""
from __future__ import annotations

import csv
from pathlib import Path

from .. import artifacts
from ..report import compare

ANCHOR_QUANTITIES = {
    "lp": ("tof_days", "m_f_kg", "K_f_deg", "J_LP_m2s3", "dv_m_s", "T0_guess_N"),
    "tmin": ("tof_days", "T_min_N", "m_f_kg", "K_f_deg"),
    "ot": ("tof_days", "m_f_kg", "K_f_deg", "burn_days"),
}
UNITS = {"tof_days": "d", "T_min_N": "N", "m_f_kg": "kg", "K_f_deg": "deg", "J_LP_m2s3": "m2/s3",
         "dv_m_s": "m/s", "burn_days": "d", "T0_guess_N": "N"}
T413_COLUMNS = ["thrust_N", "tof_days", "m_f_kg", "burn_days", "burn_fraction", "S_min", "S_max"]


def anchors(stage_files: dict) -> list[dict]:
    """Rows case,quantity,value,unit for every stage artifact (t413_* keys excluded)."""
    rows = []
    for key, path in stage_files.items():
        if key.startswith("t413"):
            continue
        sc = artifacts.read_json(path)["scalars"]
        for q in ANCHOR_QUANTITIES[sc["stage"]]:
            if q in sc and sc[q] is not None:
                rows.append({"case": key, "quantity": q, "value": sc[q], "unit": UNITS[q]})
    return rows


def table_4_1_3(stage_files: dict, thrust_levels) -> list[dict]:
    """One row per level, first the T_min trajectory (S undefined: its switching function differs)."""
    tmin = artifacts.read_json(stage_files["t413_tmin"])["scalars"]
    rows = [{"thrust_N": tmin["T_min_N"], "tof_days": tmin["tof_days"], "m_f_kg": tmin["m_f_kg"],
             "burn_days": tmin["tof_days"], "burn_fraction": 1.0, "S_min": "", "S_max": ""}]
    for T in sorted(float(t) for t in thrust_levels):
        sc = artifacts.read_json(stage_files[f"t413_{T:g}N"])["scalars"]
        rows.append({"thrust_N": T, **{k: sc[k] for k in T413_COLUMNS[1:]}})
    return rows



def write_csv(path, rows, columns):
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=columns, lineterminator="\n", extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: (repr(v) if isinstance(v, float) else v) for k, v in r.items()})


def _fmt(v, digits):
    return "–" if v == "" or v is None else f"{v:.{digits}f}"


def table_4_1_3_markdown(rows, published: dict) -> str:
    """Markdown Table 4.1.3 with the published cells of each row beside ours ({} to omit them)."""
    head = "| T, N | Δt_opt, d | m_f, kg | Δt_b, d | Δt_b/Δt_opt | S_min | S_max | published (Δt, m_f, Δt_b, S_min, S_max) |\n"
    head += "|---|---|---|---|---|---|---|---|\n"
    lines = []
    for i, r in enumerate(rows):
        key = "t413_0.191718N" if i == 0 else f"t413_{r['thrust_N']:g}N"
        pub = [published.get((key, q), {}).get("value") for q in ("tof_days", "m_f_kg", "burn_days", "S_min", "S_max")]
        pub_s = ", ".join("–" if p is None else f"{p:g}" for p in pub) if any(p is not None for p in pub) else "held back"
        lines.append(f"| {r['thrust_N']:.6f} | {_fmt(r['tof_days'], 4)} | {_fmt(r['m_f_kg'], 4)} | "
                     f"{_fmt(r['burn_days'], 4)} | {_fmt(r['burn_fraction'], 4)} | {_fmt(r['S_min'], 4)} | "
                     f"{_fmt(r['S_max'], 4)} | {pub_s} |")
    return head + "\n".join(lines) + "\n"


def table_4_1_3_latex(rows) -> str:
    out = [r"\begin{tabular}{rrrrrrr}", r"\hline",
           r"$T$, N & $\Delta t_{opt}$, d & $m_f$, kg & $\Delta t_b$, d & $\Delta t_b/\Delta t_{opt}$ & $S_{min}$ & $S_{max}$ \\",
           r"\hline"]
    for r in rows:
        out.append(f"{r['thrust_N']:.6f} & {_fmt(r['tof_days'], 4)} & {_fmt(r['m_f_kg'], 4)} & "
                   f"{_fmt(r['burn_days'], 4)} & {_fmt(r['burn_fraction'], 4)} & "
                   f"{_fmt(r['S_min'], 4).replace('–', '--')} & {_fmt(r['S_max'], 4).replace('–', '--')} \\\\")
    out += [r"\hline", r"\end{tabular}", ""]
    return "\n".join(out)


def reproduction_rows(published_path, anchor_rows, t413_rows, t413_comparable=True,
                      stage_files=None) -> list[dict]:
    """Reproduction rows; Table 4.1.3 cells are joined only when the table was computed for the
    published case (``table_4_1_3.published_case``), e.g. not in the quick profile. Initial
    costates of every stage are joined too (``stage_files``)."""
    ours = {}
    for key, path in (stage_files or {}).items():
        for name, value in artifacts.read_json(path)["scalars"]["costates"].items():
            ours[(key, name)] = value
    for r in anchor_rows:
        case = r["case"]
        # published case names: e2_tmin (one Isp) and e1_tmin_isp1520 / e1_tmin_isp1000
        ours[(case, r["quantity"])] = r["value"]
    for i, r in enumerate(t413_rows if t413_comparable else []):
        key = "t413_0.191718N" if i == 0 else f"t413_{r['thrust_N']:g}N"
        for q in T413_COLUMNS[1:]:
            if r[q] != "":
                ours[(key, q)] = r[q]
    return compare.compare(published_path, ours)


def _tex(s) -> str:
    return str(s).replace("_", r"\_").replace("%", r"\%").replace("&", r"\&")


def paper_section(repro_rows, verify_rows) -> str:
    """LaTeX fragment of the §4.1 section: reproduction rows, Table 4.1.3, verification, figures."""
    n_pass = sum(r["status"] == "pass" for r in repro_rows)
    lines = [r"\subsection{Unperturbed multi-revolution transfers (dissertation \S4.1)}",
             f"Of {len(repro_rows)} published values, {n_pass} are reproduced within tolerance. "
             r"Every solve starts from the zero guess or from an earlier stage of the chain.",
             r"\begin{table}[h]\centering\small", r"\input{../multirev/table_4_1_3.tex}",
             r"\caption{Table 4.1.3 reproduced (100 revolutions, $L_0=300^\circ$).}\end{table}",
             r"\begin{table}[h]\centering\scriptsize\begin{tabular}{llrrrl}\hline",
             r"case & quantity & published & ours & rel.\ diff. & status \\\hline"]
    for r in repro_rows:
        ours = "" if r["ours"] is None else f"{r['ours']:.10g}" if isinstance(r["ours"], float) else r["ours"]
        rel = f"{r['rel_diff']:.2e}" if isinstance(r["rel_diff"], float) else ""
        lines.append(f"{_tex(r['case'])} & {_tex(r['quantity'])} & {r['published']} & {ours} & {rel} & {r['status']} \\\\")
    lines += [r"\hline\end{tabular}\caption{\S4.1 reproduction table.}\end{table}"]
    if verify_rows:
        worst_a = max(abs(v["final_a_error_km"]) for v in verify_rows)
        worst_m = max(abs(v["final_mass_error_kg"]) for v in verify_rows)
        lines.append(f"Independent Cartesian re-propagation (SciPy DOP853) of all {len(verify_rows)} OT "
                     f"trajectories: worst final semi-major-axis error {worst_a:.3g} km, worst final-mass "
                     f"difference {worst_m:.3g} kg.")
    lines.append("")
    return "\n".join(lines)
