"""Figures of the E3 sweep (analogues of dissertation Figs. 4.1.6–4.1.7) from the row artifacts.

* ``mean_vs_n``: the L₀-averaged T̃_min and Δt̃ against n (log-log), with the hyperbolic law
  n·T̃_min = const and Δt̃ ∝ n through the largest n.
* ``dev_T_vs_L0`` / ``dev_dt_vs_L0``: δT_min(L₀) and δΔt(L₀) in % of the row mean (the mean over
  the printed L₀, :func:`spaceopt.studies.sweep_report.row_stats`), one curve per n.
* ``T_vs_L0``: T_min(L₀) of each row normalised by its mean (fine rows every ``fine_step_deg``).
"""
from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from ..report.figures import save_figure
from .sweep_report import all_cells, grid, row_stats


def make_all(rows, outdir: Path, table_L0, style: dict | None = None) -> list[Path]:
    style = style or {}
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    g = grid(all_cells(rows))
    ns = sorted(g)
    st = {n: row_stats(g[n], table_L0) for n in ns}
    written = []

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(9, 3.6))
    n_arr = np.array(ns)
    Tm = np.array([st[n]["T_mean"] for n in ns])
    dtm = np.array([st[n]["dt_mean"] for n in ns])
    a1.loglog(n_arr, Tm, "o-", label=r"$\tilde T_{min}$ (sweep)")
    a1.loglog(n_arr, Tm[-1] * n_arr[-1] / n_arr, "k--", lw=0.8, label=r"$n\tilde T_{min}$ = const")
    a1.set_xlabel("revolutions n")
    a1.set_ylabel(r"$\tilde T_{min}$, N")
    a1.legend(fontsize=8)
    a2.loglog(n_arr, dtm, "s-", color="C1", label=r"$\Delta\tilde t$ (sweep)")
    a2.loglog(n_arr, dtm[-1] / n_arr[-1] * n_arr, "k--", lw=0.8, label=r"$\Delta t\propto n$")
    a2.set_xlabel("revolutions n")
    a2.set_ylabel(r"$\Delta\tilde t$, days")
    a2.legend(fontsize=8)
    fig.suptitle("L0-averaged minimum thrust and transfer time (cf. Fig. 4.1.6)", fontsize=10)
    fig.tight_layout()
    written += save_figure(fig, outdir / "mean_vs_n.png")

    for key, ylabel, name, title in (
            ("dT_pct", r"$\delta T_{min}$, %", "dev_T_vs_L0", "Deviation of T_min from the L0 mean (cf. Fig. 4.1.7)"),
            ("ddt_pct", r"$\delta\Delta t$, %", "dev_dt_vs_L0", "Deviation of the transfer time from the L0 mean")):
        fig, axes = plt.subplots(1, 2, figsize=(9, 3.6))
        for n in ns:
            ax = axes[0] if n <= 20 else axes[1]
            ax.plot(st[n]["L0"], st[n][key], "o-" if not st[n]["uniform"] else ".-", ms=3, label=f"{n:g} rev")
        for ax in axes:
            if not ax.lines:
                ax.set_visible(False)
                continue
            ax.axhline(0, color="k", lw=0.5)
            ax.set_xlabel(r"$L_0$, deg")
            ax.set_ylabel(ylabel)
            ax.set_xticks(range(0, 361, 60))
            ax.legend(fontsize=7)
        fig.suptitle(title, fontsize=10)
        fig.tight_layout()
        written += save_figure(fig, outdir / f"{name}.png")

    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    for n in ns:
        ax.plot(st[n]["L0"], st[n]["T"] * n, ".-", ms=3, label=f"{n:g} rev")
    ax.set_xlabel(r"$L_0$, deg")
    ax.set_ylabel(r"$n\,T_{min}$, N rev")
    ax.set_xticks(range(0, 361, 60))
    ax.legend(fontsize=7)
    ax.set_title(r"$n\,T_{min}(L_0)$", fontsize=10)
    fig.tight_layout()
    written += save_figure(fig, outdir / "nT_vs_L0.png")
    return written
