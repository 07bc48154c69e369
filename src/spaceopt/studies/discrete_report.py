"""The paper section of the four discrete-control papers (D1-D4), from their outputs.

The studies ``discrete_geo_bellman`` (D1, D3) and ``discrete_libration_zonotope`` (D2, D4) write
their reproduction rows and figures under ``results/discrete/``; this module turns them into
``results/discrete/paper_section.tex``: one subsection per paper with its reproduction counts,
the values outside the tolerance, and the figures with captions saying what they show. Every
number comes from the reproduction tables; a figure without a caption below still appears, with
its file name.
"""
from __future__ import annotations

from pathlib import Path

from ..report.paper import breakable, latex_escape
from ..report.scoreboard import fmt_ours, fmt_published

# (prefix of the case names, title, spec paragraph)
PARTS = [
    ("d1", "D1: GEO insertion with engine-start penalties", "05-discrete.md, D1"),
    ("d2", r"D2: Station keeping at the Earth--Moon libration points by $\ell_1$ control", "05-discrete.md, D2"),
    ("d3", "D3: Angular-momentum stabilisation from the Bellman equation", "05-discrete.md, D3"),
    ("d4", "D4: Time-optimal discrete orbit correction", "05-discrete.md, D4"),
]
_INTRO = {
    "d1": r"A satellite goes from a low circular orbit to GEO with a finite number of burns along the "
          r"velocity; a fixed fuel penalty per engine start (Problem~2) makes the number of burns finite. "
          r"We recompute the classical minimum-fuel schemes and the start-penalised one and integrate the "
          r"switching function along each of them.",
    "d2": r"Station keeping at the collinear points of the planar circular restricted Earth--Moon problem: "
          r"the correction impulses minimise the $\ell_1$ norm (a linear programme) and are compared with "
          r"the least-squares ($\ell_2$) correction.",
    "d3": r"A microsatellite's angular velocity is kept in a box by a feedback built from the Bellman "
          r"function $V(t,\omega)$, computed on a grid.",
    "d4": r"Time-optimal correction of a discrete linear orbit model by the maximum principle (MP) and by "
          r"dynamic programming (DP), for relay and impulsive controls; the controllable sets are zonotopes.",
}

_ORBITS = (r"the transfer orbits between the burns (colour from the first to the last), perigee burns in "
           r"red, apogee burns in orange, the GEO radius dashed; the title gives the burn counts and the fuel.")
_SWITCH = (r"the switching function $k(t)$ along the scheme; the engine thrusts where $k \ge 1$ (red dots). "
           r"Lower panel: the beginning of the transfer enlarged.")
_SCHEME = {"classical": "classical scheme (no start penalty), burn counts of our optimum",
           "classical_published_counts": "classical scheme with the burn counts of the paper",
           "start_penalised": "optimal scheme with the start penalty (Problem~2)",
           "flown": "the flown scheme of Problem~2"}

CAPTIONS = {
    **{f"geo_orbits_{k}": f"D1, {v}: {_ORBITS}" for k, v in _SCHEME.items()},
    **{f"geo_switching_{k}": f"D1, {v}: {_SWITCH}" for k, v in _SCHEME.items()},
    "libration_uncontrolled": r"D2: uncontrolled flights from small offsets of the libration points "
                              r"(rotating frame, nondimensional units).",
    "libration_E0_contour": r"D2: the energy function $E_0(x, y)$ of the restricted problem; black: the "
                            r"levels through $L_1$, $L_2$ and $L_3$.",
    "libration_E0_surface": r"D2: the surface $E_0(x, y)$, clipped below.",
    "libration_station_keeping_l1": r"D2: station keeping with the $\ell_1$ correction at each point: the "
                                    r"deviations from the point against time (dashed: a correction starts) "
                                    r"and the trajectory in the $x$--$y$ plane.",
    "libration_station_keeping_l2": r"D2: the same with the least-squares ($\ell_2$) correction.",
    "libration_l1_vs_l2": r"D2: fuel of the first correction by the $\ell_1$ and the $\ell_2$ criterion "
                          r"at each point.",
    "bellman_level_sets": r"D3: level sets of $V(t, 0, \omega_y, \omega_z)$ at several times; one row per "
                          r"horizon (the published one and the longer closed-loop horizon).",
    "bellman_points": r"D3: $V(t)$ at the published points (left) and $1 - V(t)$ on a log scale (right).",
    "bellman_sup": r"D3: $p(t) = \sup_{\omega_y, \omega_z} V(t, 0, \omega_y, \omega_z)$.",
    "bellman_closed_loop": r"D3: closed loop under the feedback from $V$: angular velocities with the box $Q$ "
                           r"(left) and the normalised controls (right), one row per initial state.",
    "orbit_correction_dt_fit": r"D4: the time step $\Delta t$ fitted by least squares to the published "
                               r"maximum-principle tables (left); the MP trajectories at the chosen step "
                               r"beside the published values (right).",
    "orbit_correction_trajectories": r"D4: time-optimal trajectories by DP (lines) and MP (dotted), relay and "
                                     r"impulsive control.",
    "orbit_correction_zonotopes_relay": r"D4: controllable sets $X(n, 0)$ (zonotopes) of the relay control, "
                                        r"with the initial state $x_0$ in red.",
    "orbit_correction_zonotopes_impulsive": r"D4: controllable sets $X(n, 0)$ (zonotopes) of the impulsive "
                                            r"control, with the initial state $x_0$ in red.",
}
# Figures shown side by side (two small, nearly square plots).
PAIRS = [("geo_orbits_classical", "geo_orbits_classical_published_counts"),
         ("geo_orbits_start_penalised", "geo_orbits_flown"),
         ("libration_E0_contour", "libration_E0_surface")]
# Simple single plots: narrower than the default 0.9 of the text width.
WIDTHS = {"bellman_sup": r"0.6\linewidth", "libration_l1_vs_l2": r"0.7\linewidth"}
_PART_OF_PREFIX = {"geo": "d1", "libration": "d2", "bellman": "d3", "orbit": "d4"}


def _prefer_pdf(figures) -> dict[str, str]:
    """{stem: path}, the PDF where both a PDF and a PNG are given."""
    out: dict[str, str] = {}
    for f in sorted({str(f) for f in figures}):
        stem = Path(f).stem
        if stem not in out or f.endswith(".pdf"):
            out[stem] = f
    return out


def _include(path, width) -> str:
    return f"\\includegraphics[width={width},height=0.42\\textheight,keepaspectratio]{{{path}}}"


def _caption(stem) -> str:
    return CAPTIONS.get(stem, latex_escape(stem.replace("_", " ")) + ".")


def _figures_tex(stems: list[str], paths: dict[str, str]) -> list[str]:
    out, done = [], set()
    pair_of = {a: b for a, b in PAIRS} | {b: a for a, b in PAIRS}
    for stem in stems:
        if stem in done:
            continue
        other = pair_of.get(stem)
        if other in stems and other not in done:
            first, second = (stem, other) if (stem, other) in PAIRS else (other, stem)
            out.append(r"\begin{figure}[htbp]\centering")
            for i, s in enumerate((first, second)):
                out += [r"\begin{minipage}[t]{0.48\linewidth}\centering", _include(paths[s], r"\linewidth"),
                        f"\\caption{{{_caption(s)}}}\\label{{fig:{s.replace('_', '-')}}}",
                        r"\end{minipage}" + (r"\hfill" if i == 0 else "")]
            out.append(r"\end{figure}")
            done |= {first, second}
            continue
        out += [r"\begin{figure}[htbp]\centering", _include(paths[stem], WIDTHS.get(stem, r"0.9\linewidth")),
                f"\\caption{{{_caption(stem)}}}\\label{{fig:{stem.replace('_', '-')}}}", r"\end{figure}"]
        done.add(stem)
    return out


def _counts_sentence(rows: list[dict]) -> str:
    c = {s: sum(r["status"] == s for r in rows) for s in ("pass", "fail", "missing", "info")}
    parts = [f"{c['pass']} pass", f"{c['fail']} fail"]
    if c["missing"]:
        parts.append(f"{c['missing']} are missing")
    if c["info"]:
        parts.append(f"{c['info']} are for information only")
    return (f"Of its {len(rows)} published values, " + ", ".join(parts[:-1]) + " and " + parts[-1]
            + r" (Table~\ref{tab:scoreboard}).")


def _fails_tex(rows: list[dict]) -> list[str]:
    fails = [r for r in rows if r["status"] == "fail"]
    if not fails:
        return []
    out = [r"Outside the tolerance (the notes of Table~\ref{tab:scoreboard} and Section~\ref{sec:errata} "
           r"give the readings tested):", r"\begin{itemize}\small\raggedright\setlength{\itemsep}{0pt}"]
    for r in fails:
        unit = f"~{latex_escape(r['unit'])}" if r["unit"] not in ("", "nondim", "fraction") else ""
        out.append(f"\\item \\texttt{{{breakable(latex_escape(r['case']))}}}, "
                   f"\\texttt{{{breakable(latex_escape(r['quantity']))}}}: published "
                   f"{breakable(latex_escape(fmt_published(r['published'])))}{unit}, ours "
                   f"{breakable(latex_escape(fmt_ours(r['ours'], r['published'])))}{unit}.")
    out.append(r"\end{itemize}")
    return out


def paper_section(repro_rows: list[dict], figures) -> str:
    """LaTeX fragment of the discrete studies (rows: both reproduction tables; figures: paths)."""
    paths = _prefer_pdf(figures)
    by_part: dict[str, list[str]] = {}
    for stem in paths:
        part = _PART_OF_PREFIX.get(stem.split("_", 1)[0], "other")
        by_part.setdefault(part, []).append(stem)
    order = {s: i for i, s in enumerate(CAPTIONS)}
    out = [r"\section{Discrete and impulsive spacecraft control (four short papers)}\label{sec:discrete}",
           r"{\sloppy Four short papers on discrete and impulsive control are reproduced by the studies "
           r"\texttt{discrete\_\allowbreak{}geo\_\allowbreak{}bellman} (D1, D3) and "
           r"\texttt{discrete\_\allowbreak{}libration\_\allowbreak{}zonotope} (D2, D4) "
           r"of the specification \texttt{05-discrete.md}. Every published value beside ours is in "
           r"Table~\ref{tab:scoreboard}; the errata and the readings we had to choose are in "
           r"Section~\ref{sec:errata}.\par}", ""]
    for prefix, title, _spec in PARTS:
        rows = [r for r in repro_rows if r["case"].split("_", 1)[0] == prefix]
        stems = sorted(by_part.get(prefix, []), key=lambda s: (order.get(s, len(order)), s))
        if not rows and not stems:
            continue
        out += [f"\\subsection{{{title}}}\\label{{sec:discrete-{prefix}}}", _INTRO[prefix]]
        if rows:
            out.append(_counts_sentence(rows))
        out += _fails_tex(rows)
        out.append("")
        out += _figures_tex(stems, paths)
        out.append(r"\FloatBarrier")
    if by_part.get("other"):
        out += [r"\subsection{Other figures}"] + _figures_tex(sorted(by_part["other"]), paths)
    out.append(r"\clearpage")
    return "\n".join(out) + "\n"
