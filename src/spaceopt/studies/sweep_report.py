"""Tables 4.1.1–4.1.2, the reproduction rows and the checks of the stated regularities (E3).

Definitions (spec 02-multirev §3 E3): T̃_min(n) and Δt̃(n) are L₀-averages. The thesis does not
say over what; its numbers imply the arithmetic mean over the 10 printed L₀ (0° and 360° both
counted): with it δT_min(100°) at 2 revolutions is the stated 18.5 %, with the period mean
(1/360°)∫₀³⁶⁰ (trapezoidal on the 10° grid) it is 16.4 %. That mean is used here; the period mean
is reported beside it. δT_min(L₀) = (T_min − T̃_min)/T̃_min·100 % and δΔt likewise. Checks R12–R16 of spec §9 and the n* estimate check are evaluated on the data.
"""
from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import numpy as np

from ..report import compare
from .sweep import CELL_COLUMNS

REG_COLUMNS = ["id", "statement", "measured", "criterion", "holds"]


# ---------------------------------------------------------------- data

def all_cells(rows: list[list[dict]]) -> list[dict]:
    return sorted((c for r in rows for c in r), key=lambda c: (c["n_rev"], c["L0_deg"]))


def grid(cells: list[dict]) -> dict:
    """{n: {L0: cell}}."""
    out = {}
    for c in cells:
        out.setdefault(float(c["n_rev"]), {})[float(c["L0_deg"])] = c
    return out


def table_cells(cells: list[dict], table_L0, n_revs) -> list[dict]:
    """The long-format rows of Table 4.1.1 (every printed L₀ × every n), sorted by n then L₀."""
    g = grid(cells)
    out = []
    for n in sorted(float(x) for x in n_revs):
        for L0 in sorted(float(x) for x in table_L0):
            c = g.get(n, {}).get(L0)
            if c is None:
                raise KeyError(f"sweep cell L0={L0:g} n={n:g} missing")
            out.append({k: c[k] for k in CELL_COLUMNS})
    return out


def write_csv(path, rows, columns):
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=columns, lineterminator="\n", extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: (repr(float(v)) if isinstance(v, (float, np.floating)) else v) for k, v in r.items()})


def case_name(L0, n) -> str:
    return f"L0_{float(L0):g}_n{float(n):g}"


# ---------------------------------------------------------------- averages and deviations

def period_mean(L0s, vals) -> float:
    """(1/360)∫₀³⁶⁰ v dL₀ by the trapezoidal rule; the grid must cover [0, 360]."""
    x, y = np.asarray(L0s, float), np.asarray(vals, float)
    o = np.argsort(x)
    x, y = x[o], y[o]
    if x[0] != 0.0 or x[-1] != 360.0:
        raise ValueError("the L0 grid must run from 0 to 360 deg")
    return float(np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(x)) / 360.0)


def row_stats(cells_by_L0: dict, table_L0=None) -> dict:
    """Row arrays, means and deviations. The mean is the arithmetic mean over the printed L₀
    (``table_L0``, 360° included, as the thesis's numbers imply: with it δT_min(100°) at 2 rev is
    the stated 18.5 %); without ``table_L0``, or for reference, the period mean (trapezoidal)."""
    L0 = np.array(sorted(cells_by_L0))
    T = np.array([cells_by_L0[a]["T_min_N"] for a in L0])
    dt = np.array([cells_by_L0[a]["tof_days"] for a in L0])
    Tp, dtp = period_mean(L0, T), period_mean(L0, dt)
    if table_L0 is not None:
        Tm = float(np.mean([cells_by_L0[float(a)]["T_min_N"] for a in table_L0]))
        dtm = float(np.mean([cells_by_L0[float(a)]["tof_days"] for a in table_L0]))
    else:
        Tm, dtm = Tp, dtp
    return {"L0": L0, "T": T, "dt": dt, "T_mean": Tm, "dt_mean": dtm, "T_period_mean": Tp, "dt_period_mean": dtp,
            "dT_pct": (T - Tm) / Tm * 100, "ddt_pct": (dt - dtm) / dtm * 100,
            "uniform": bool(len(L0) > 2 and np.allclose(np.diff(L0), L0[1] - L0[0]))}


def local_extrema(L0, v) -> tuple[list[float], list[float]]:
    """Strict local minima and maxima of a periodic sampled function (360 dropped)."""
    x, y = np.asarray(L0)[:-1], np.asarray(v)[:-1]
    m = len(y)
    mins = [float(x[i]) for i in range(m) if y[i] < y[i - 1] and y[i] < y[(i + 1) % m]]
    maxs = [float(x[i]) for i in range(m) if y[i] > y[i - 1] and y[i] > y[(i + 1) % m]]
    return mins, maxs


# ---------------------------------------------------------------- regularities

def _reg(rid, statement, measured, criterion, holds):
    return {"id": rid, "statement": statement, "measured": measured, "criterion": criterion,
            "holds": "yes" if holds else "no"}


def regularities(cells: list[dict], table_L0, nstar: dict | None) -> list[dict]:
    g = grid(cells)
    ns = sorted(g)
    st = {n: row_stats(g[n], table_L0) for n in ns}
    out = []
    # R12 periodicity
    worst = max(max(abs(g[n][360.0][q] - g[n][0.0][q]) / abs(g[n][0.0][q]) for q in ("T_min_N", "tof_days", "m_f_kg"))
                for n in ns)
    out.append(_reg("R12", "L0 = 0 and L0 = 360 deg give identical rows", f"max rel. diff {worst:.1e}",
                    "<= 1e-6 rel", worst <= 1e-6))
    # R13 hyperbolic law
    nT = {n: n * st[n]["T_mean"] for n in ns}
    big = [n for n in ns if n >= 50]
    vals = ", ".join(f"{n:g}: {nT[n]:.4f}" for n in ns)
    dev = max(abs(nT[n] / 19.226 - 1) for n in big) if big else math.nan
    out.append(_reg("R13", "n x mean T_min nearly constant (19.224-19.227 N rev for n >= 50)",
                    f"n*T~ [N rev] = {vals}; max dev. from 19.226 for n>=50: {dev * 100:.3f} %",
                    "+-0.2 % of 19.226 for n >= 50", dev <= 2e-3))
    # R14 single minimum near 300 deg
    tbl = sorted(float(x) for x in table_L0 if float(x) < 360.0)
    arg = {n: min(tbl, key=lambda a: g[n][a]["T_min_N"]) for n in ns}
    out.append(_reg("R14", "argmin over the printed L0 of T_min is 300 deg for every n",
                    "; ".join(f"{n:g}: {arg[n]:g}" for n in ns), "300 deg for all n",
                    all(arg[n] == 300.0 for n in ns)))
    fine = [n for n in ns if st[n]["uniform"]]
    if fine:
        parts, single = [], True
        for n in fine:
            mins, _ = local_extrema(st[n]["L0"], st[n]["T"])
            parts.append(f"{n:g}: minima at {mins} deg")
            single &= len(mins) == 1
        out.append(_reg("R14b", "T_min(L0) has a single minimum on [0, 360) (fine rows)",
                        "; ".join(parts), "one local minimum", single))
    # R15 time proportional to n
    per = {n: st[n]["dt_mean"] / n for n in ns}
    big = [n for n in ns if n >= 100]
    dev = max(abs(per[n] / 1.4489 - 1) for n in big) if big else math.nan
    out.append(_reg("R15", "mean time / n = 1.4489 d/rev for n >= 100 (time proportional to n)",
                    "; ".join(f"{n:g}: {per[n]:.5f}" for n in ns) + f"; max dev. for n>=100: {dev * 100:.3f} %",
                    "+-0.1 % for n >= 100", dev <= 1e-3))
    # R16 deviations of T_min
    mx = {n: float(np.max(np.abs(st[n]["dT_pct"]))) for n in ns}
    mono = all(mx[a] > mx[b] for a, b in zip(ns, ns[1:]))
    ok = mono and mx.get(20.0, 0) <= 1.5 and mx.get(100.0, 0) <= 0.3
    out.append(_reg("R16", "max |dT_min| decreases with n; <= 1.5 % (20 rev), <= 0.3 % (100 rev)",
                    "; ".join(f"{n:g}: {mx[n]:.3f} %" for n in ns), "monotone, 1.5 % / 0.3 %", ok))
    if 2.0 in g and 100.0 in g[2.0]:
        L0s = list(st[2.0]["L0"])
        d = st[2.0]["dT_pct"]
        d100 = float(d[L0s.index(100.0)])
        on_tbl = [(abs(float(d[L0s.index(a)])), a) for a in tbl]
        j = int(np.argmax(np.abs(d)))
        out.append(_reg("R16b", "dT_min reaches 18.5 % at L0 = 100 deg for 2 rev (the largest on the printed grid)",
                        f"dT_min(100 deg) = {d100:+.2f} %; largest on the printed grid at {max(on_tbl)[1]:g} deg; "
                        f"on the {L0s[1] - L0s[0]:g} deg grid the largest is {d[j]:+.2f} % at {L0s[j]:g} deg",
                        "18.5 % to the printed digit (+-0.05) and the printed-grid maximum at 100 deg",
                        abs(d100 - 18.5) <= 0.05 and max(on_tbl)[1] == 100.0))
    # time deviations
    mt = {n: float(np.max(np.abs(st[n]["ddt_pct"]))) for n in ns}
    checks = [(2.0, ">", 15.0), (50.0, "~", 0.5), (200.0, "~", 0.1)]
    parts, ok = [], True
    for n, op, v in checks:
        if n in mt:
            parts.append(f"{n:g}: {mt[n]:.3f} %")
            ok &= mt[n] > v if op == ">" else (0.5 * v <= mt[n] <= 1.5 * v)
    out.append(_reg("T-dev", "max |d dt| > 15 % (2 rev), ~0.5 % (50 rev), ~0.1 % (200 rev)",
                    "; ".join(parts) + " (all n: " + ", ".join(f"{n:g}: {mt[n]:.3f} %" for n in ns) + ")",
                    "2 rev > 15 %; 50, 200 rev within x1.5 of the stated value", ok))
    if fine:
        parts, ok = [], True
        for n in fine:
            mins, maxs = local_extrema(st[n]["L0"], st[n]["dt"])
            parts.append(f"{n:g}: {len(mins)} min / {len(maxs)} max")
            ok &= len(mins) <= 2 and len(maxs) <= 2
        out.append(_reg("T-ext", "dt(L0) has up to 2 local minima and 2 local maxima (fine rows)",
                        "; ".join(parts), "<= 2 and <= 2", ok))
    # n* estimate check
    if nstar:
        T_star = nstar["thrust_N"]
        cells_n = {float(c["n_rev"]): c for c in nstar["cells"]}
        est = []
        for n1 in nstar["reference_n_rev"]:
            c = g.get(float(n1), {}).get(float(nstar["L0_deg"]))
            if c is not None:
                est.append(f"from {n1:g} rev: n* = {float(n1) * c['T_min_N'] / T_star:.2f}")
        lo, hi = min(cells_n), max(cells_n)
        holds = cells_n[hi]["T_min_N"] <= T_star <= cells_n[lo]["T_min_N"]
        out.append(_reg("n*", f"T_min({hi:g} rev) <= {T_star:g} N <= T_min({lo:g} rev) at L0 = {nstar['L0_deg']:g} deg",
                        f"T_min({lo:g}) = {cells_n[lo]['T_min_N']:.6f} N, T_min({hi:g}) = "
                        f"{cells_n[hi]['T_min_N']:.6f} N; " + "; ".join(est)
                        + "; hyperbolic law (19.226 N rev) predicts "
                        + ", ".join(f"{n:g}: {19.226 / n:.4f} N" for n in (lo, hi)),
                        "bracket holds", holds))
    return out


# ---------------------------------------------------------------- reproduction and tables

def reproduction_rows(published_path, cells: list[dict]) -> list[dict]:
    ours = {}
    for c in cells:
        name = case_name(c["L0_deg"], c["n_rev"])
        ours[(name, "T_min_N")] = c["T_min_N"]
        ours[(name, "tof_days")] = c["tof_days"]
    return compare.compare(published_path, ours)


def _published(pub: dict, L0, n, q):
    e = pub.get((case_name(L0, n), q))
    return None if e is None else e["value"]


def _status(repro, L0, n, q):
    for r in repro:
        if r["case"] == case_name(L0, n) and r["quantity"] == q:
            return r["status"]
    return None


TITLES = {"T_min_N": ("Table 4.1.1", "Minimum thrust [N] against the number of revolutions and the initial true longitude", 5),
          "tof_days": ("Table 4.1.2", "Transfer time [days] of the optimal T_min trajectory against the number of revolutions and the initial true longitude", 5)}


def _grid_rows(cells, pub: dict, repro, quantity, table_L0, n_revs):
    """The revolution counts (ascending) and, per L0, the cells (ours, published or None, failing)."""
    g = grid(cells)
    ns = sorted(float(x) for x in n_revs)
    rows = [(L0, [(g[n][L0][quantity], _published(pub, L0, n, quantity),
                   _status(repro, L0, n, quantity) == "fail") for n in ns])
            for L0 in sorted(float(x) for x in table_L0)]
    return ns, rows


def table_markdown(cells, pub: dict, repro, quantity, table_L0, n_revs) -> str:
    name, title, d = TITLES[quantity]
    ns, rows = _grid_rows(cells, pub, repro, quantity, table_L0, n_revs)
    lines = [f"**{name}** (reproduced). {title}. Each cell: ours, then the published value in "
             "brackets where the specification gives it (`!` marks a cell outside the tolerance: "
             f"{'1e-5 abs' if quantity == 'T_min_N' else '1e-4 rel'}); rows without brackets were held back.", "",
             "| L0, deg | " + " | ".join(f"{n:g} rev" for n in ns) + " |",
             "|---|" + "---|" * len(ns)]
    for L0, row in rows:
        text = [f"{v:.{d}f}" + ("" if p is None else f" [{p:.{d}f}]" + ("!" if bad else "")) for v, p, bad in row]
        lines.append(f"| {L0:g} | " + " | ".join(text) + " |")
    return "\n".join(lines) + "\n"


def table_latex(cells, pub: dict, repro, quantity, table_L0, n_revs) -> str:
    name, title, d = TITLES[quantity]
    ns, rows = _grid_rows(cells, pub, repro, quantity, table_L0, n_revs)
    out = [r"\begin{tabular}{r" + "r" * len(ns) + "}", r"\hline",
           r"$L_0$, deg & " + " & ".join(f"{n:g} rev" for n in ns) + r" \\", r"\hline"]
    for L0, row in rows:
        text = []
        for v, p, bad in row:
            s = f"{v:.{d}f}"
            if p is not None:
                # top-aligned stack: the first line sits on the row's baseline (a \shortstack
                # would rise into the rule above the first row)
                s = (r"\begin{tabular}[t]{@{}r@{}}" + s + (r"$^\dagger$" if bad else "")
                     + r"\\{\scriptsize(" + f"{p:.{d}f}" + r")}\end{tabular}")
            text.append(s)
        out.append(f"{L0:g} & " + " & ".join(text) + r" \\")
    out += [r"\hline", r"\end{tabular}", ""]
    return "\n".join(out)


def _tex(s) -> str:
    out = str(s).replace("_", r"\_").replace("%", r"\%").replace("&", r"\&").replace("~", r"$\sim$")
    out = out.replace("<=", "\x00le").replace(">=", "\x00ge").replace("<", "$<$").replace(">", "$>$")
    return out.replace("\x00le", r"$\le$").replace("\x00ge", r"$\ge$").replace("|", r"$|$")


# Identifiers of the regularity texts typeset as math (longest first).
_MATH_TOKENS = [("n*T~", r"$n\tilde T_{min}$"), ("n x mean T_min", r"$n\times{}$mean $T_{min}$"),
                ("dT_min", r"$\delta T_{min}$"), ("T_min", r"$T_{min}$"), ("d dt", r"$\delta\Delta t$"),
                ("L0", r"$L_0$"), ("n*", r"$n^*$"), ("+-", r"$\pm$")]
_MATH_RE = re.compile("|".join(re.escape(a) for a, _ in _MATH_TOKENS) + r"|\bdt\b")


def _tex_math(s) -> str:
    """:func:`_tex` with the identifiers of the regularity texts as math (T_min, L0, dt, n*)."""
    table = dict(_MATH_TOKENS, dt=r"$\Delta t$")
    out, pos = [], 0
    for m in _MATH_RE.finditer(str(s)):
        out += [_tex(str(s)[pos:m.start()]), table[m.group(0)]]
        pos = m.end()
    return "".join(out) + _tex(str(s)[pos:])


_QUANTITY_TEX = {"T_min_N": r"$T_{min}$ [N]", "tof_days": r"$\Delta t$ [d]"}


def _cell_tex(case: str) -> str:
    r"""``L0_200_n2`` as ``$L_0 = 200^\circ$, 2 rev``."""
    m = re.fullmatch(r"L0_([-0-9.e+]+)_n([0-9.e+]+)", case)
    return _tex(case) if m is None else f"$L_0 = {m.group(1)}^\\circ$, {m.group(2)} rev"


_FIGURES = {  # stem: (width, caption)
    "mean_vs_n": (r"\linewidth", r"Minimum thrust $\tilde T_{min}$ and transfer time $\Delta\tilde t$ averaged over "
                  r"$L_0$ against the number of revolutions $n$, with the laws $n\,\tilde T_{min} = $ const and "
                  r"$\Delta t \propto n$ (dashed; cf.\ dissertation Fig.~4.1.6)."),
    "dev_T_vs_L0": (r"\linewidth", r"Deviation $\delta T_{min}$ of the minimum thrust from its mean over $L_0$, "
                    r"per number of revolutions (cf.\ dissertation Fig.~4.1.7)."),
    "dev_dt_vs_L0": (r"\linewidth", r"Deviation $\delta\Delta t$ of the transfer time from its mean over $L_0$, "
                     r"per number of revolutions."),
    "nT_vs_L0": (r"0.65\linewidth", r"$n\,T_{min}$ against $L_0$ for every number of revolutions; under the "
                 r"hyperbolic law $T_{min} \propto 1/n$ all curves would coincide."),
}


def paper_section(repro, regs, cells, timing: dict | None = None, figures=()) -> str:
    npub = len(repro)
    npass = sum(r["status"] == "pass" for r in repro)
    fails = [r for r in repro if r["status"] == "fail"]
    lines = [r"\subsection{Minimum thrust against $L_0$ and the number of revolutions (dissertation \S4.1, Tables 4.1.1--4.1.2)}",
             f"Every one of the {len(cells)} cells of the sweep (including the printed grid of 60 cells "
             r"and the rows held back from the specification) was computed from the zero guess, "
             r"either by the LP$\to T_{min}$ chain or by warm starts from cells solved before it "
             r"(along $L_0$ inside a row, along $n$ by the hyperbolic law). "
             f"Of {npub} published cells, {npass} agree within the tolerance "
             r"(5 printed digits: $10^{-5}$~N for $T_{min}$, $10^{-4}$ relative for $\Delta t$)."]
    if fails:
        lines.append("Cells outside the tolerance: " + "; ".join(
            f"{_cell_tex(r['case'])}, {_QUANTITY_TEX.get(r['quantity'], _tex(r['quantity']))}: "
            f"published {r['published']}, ours {float(r['ours']):.6g}"
            for r in fails) + ".")
    if timing:
        lines.append(_tex(timing.get("summary", "")))
    lines += ["", r"\begin{table}[htbp]\centering\scriptsize", r"\input{\resultsdir/multirev/table_4_1_1.tex}",
              r"\caption{Table 4.1.1 reproduced: $T_{min}$ [N]; published values in brackets, $\dagger$ outside the tolerance.}\end{table}",
              r"\begin{table}[htbp]\centering\scriptsize", r"\input{\resultsdir/multirev/table_4_1_2.tex}",
              r"\caption{Table 4.1.2 reproduced: transfer time [d]; published values in brackets.}\end{table}",
              r"\begin{table}[htbp]\centering\scriptsize\begin{tabular}{lp{0.3\textwidth}p{0.42\textwidth}l}\hline",
              r"id & statement & measured & holds \\\hline"]
    for r in regs:
        lines.append(f"{_tex_math(r['id'])} & {_tex_math(r['statement'])} & {_tex_math(r['measured'])} & {r['holds']} \\\\")
    lines += [r"\hline\end{tabular}\caption{Stated regularities of \S4.1 checked on the sweep.}\end{table}"]
    order = {k: i for i, k in enumerate(_FIGURES)}
    for fig in sorted(figures, key=lambda f: (order.get(f, len(order)), f)):
        width, caption = _FIGURES.get(fig, (r"\linewidth", _tex(fig.replace("_", " ")) + "."))
        lines += [r"\begin{figure}[htbp]\centering",
                  f"\\includegraphics[width={width}]{{\\resultsdir/multirev/sweep_figures/{fig}.pdf}}",
                  f"\\caption{{{caption}}}\\label{{fig:sweep-{fig.replace('_', '-')}}}\\end{{figure}}"]
    lines.append("")
    return "\n".join(lines)
