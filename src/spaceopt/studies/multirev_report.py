"""Tables of the §4.1 studies: anchors, Table 4.1.3, verification and the reproduction rows."""
from __future__ import annotations

from .. import artifacts
from ..report import compare
from ..report.verification import verification_sentence

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


def _num(v, digits=10):
    return "" if v in ("", None) else f"{float(v):.{digits}g}"


_FIGURE_CAPTIONS = {
    "projections": "trajectories of the chain's stages (LP, $T_{min}$, OT) projected on the $xy$, $xz$ and "
                   "$yz$ planes of the inertial frame; black: thrust, grey: coast "
                   "(cf.\\ dissertation Figs.~4.1.1a--c and 4.1.2).",
    "controls": "thrust acceleration, pitch and yaw against time for each stage of the chain; for the OT "
                "stage the switching function $S$ is drawn in red (cf.\\ dissertation Figs.~4.1.1d--f and 4.1.3).",
    "elements": "osculating semi-major axis $a$, eccentricity $e$ and inclination $i$ against time for each "
                "stage of the chain (cf.\\ dissertation Fig.~4.1.5).",
}
_FAMILY_CAPTIONS = {
    "t413_family": "Equatorial projections of the OT trajectories of Table~\\ref{tab:t413}, from the $T_{min}$ "
                   "trajectory to the highest thrust; black: thrust, grey: coast (cf.\\ dissertation Fig.~4.1.8).",
    "t413_vs_thrust": "Transfer time $\\Delta t_{opt}$, final mass $m_f$ and burn fraction "
                      "$\\Delta t_b/\\Delta t_{opt}$ against thrust for the trajectories of "
                      "Table~\\ref{tab:t413} (cf.\\ dissertation Fig.~4.1.9).",
}


def figure_caption(name: str) -> str:
    """The LaTeX caption of a §4.1 figure from its file stem (``e1_controls``, ``t413_family``)."""
    if name in _FAMILY_CAPTIONS:
        return _FAMILY_CAPTIONS[name]
    case, _, kind = name.partition("_")
    if kind in _FIGURE_CAPTIONS:
        return f"Case {_tex(case.upper())}: {_FIGURE_CAPTIONS[kind]}"
    return _tex(name.replace("_", " ")) + "."


def paper_section(repro_rows, verify_rows, anchor_rows, t413_rows, figures: list[str]) -> str:
    """LaTeX fragment of the §4.1 section (numbers from the artifacts, files via \\resultsdir)."""
    a = {(r["case"], r["quantity"]): float(r["value"]) for r in anchor_rows}
    counts = {s: sum(r["status"] == s for r in repro_rows) for s in ("pass", "fail", "missing", "info")}
    out = [r"\section{Unperturbed multi-revolution transfers (dissertation \S4.1)}\label{sec:multirev}",
           "Every solve starts from the zero initial guess (LP) or from an earlier stage of the chain; "
           "no published costate, $K_f$ or thrust is used as a guess. "
           f"Of {len(repro_rows)} published values, {counts['pass']} are reproduced within tolerance, "
           f"{counts['fail']} are not, {counts['missing']} were not computed in this run."]
    if ("e1_tmin_isp1520", "T_min_N") in a:
        text = f"For the 2-revolution case E1 the minimum thrust is {a[('e1_tmin_isp1520', 'T_min_N')]:.8f}~N (Isp 1520~s)"
        if ("e1_tmin_isp1000", "T_min_N") in a:
            text += f" and {a[('e1_tmin_isp1000', 'T_min_N')]:.8f}~N (Isp 1000~s)"
        if ("e1_ot_15N", "m_f_kg") in a:
            text += (f"; the OT transfer at 15~N takes {a[('e1_ot_15N', 'tof_days')]:.6f}~d and ends with "
                     f"{a[('e1_ot_15N', 'm_f_kg')]:.6f}~kg")
        out.append(text + ".")
    if ("e2_tmin", "T_min_N") in a:
        out.append(f"At 100 revolutions (E2) $T_{{min}}$ = {a[('e2_tmin', 'T_min_N')]:.8f}~N with a transfer time of "
                   f"{a[('e2_tmin', 'tof_days')]:.6f}~d; any thrust below it has no transfer over this angular range, "
                   r"and the chain says so with the estimate $n^*\approx n\,T_{min}/T$ of the revolutions needed.")
    p_lk = [r for r in repro_rows if r["case"] == "e1_lp" and r["quantity"] == "p_LK"]
    if p_lk:
        out.append(f"The printed LP costate $p_{{LK}}$ = {p_lk[0]['published']} violates the transversality condition; "
                   f"our converged value is {_num(p_lk[0]['ours'], 6)} while the five orbital costates agree to "
                   r"$10^{-9}$ (Section~\ref{sec:errata}).")
    near = [r for r in t413_rows[1:] if r["S_min"] not in ("", None) and float(r["S_min"]) > 0]
    if near:
        out.append("Near the minimum thrust the engine never switches off: up to "
                   f"$T = {max(float(r['thrust_N']) for r in near):g}$~N, $S_{{min}} > 0$ and the burn fraction is 1, "
                   "as the dissertation reports.")
    out += ["", r"\begin{table}[htbp]\centering\small", r"\input{\resultsdir/multirev/table_4_1_3.tex}",
            r"\caption{Table 4.1.3 reproduced: OT trajectories against thrust (100 revolutions, $L_0=300^\circ$); "
            r"first row: the $T_{min}$ trajectory.}\label{tab:t413}\end{table}"]
    if verify_rows:
        out.append(verification_sentence(verify_rows, "OT trajectories"))
    for fig in figures:
        out += [r"\begin{figure}[htbp]\centering",
                f"\\includegraphics[width=\\linewidth]{{\\resultsdir/multirev/figures/{fig}.pdf}}",
                f"\\caption{{{figure_caption(fig)}}}\\label{{fig:multirev-{fig.replace('_', '-')}}}\\end{{figure}}"]
    out.append(r"\clearpage")
    return "\n".join(out) + "\n"
