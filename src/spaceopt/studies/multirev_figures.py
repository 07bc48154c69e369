"""Figures of §4.1 in the spirit of Figs. 4.1.1–4.1.3, 4.1.5, 4.1.8 and 4.1.9 (spec 02 §8).

Trajectory projections with burn arcs (black) and coast arcs (grey); control histories
(acceleration with S for OT, pitch, yaw); element histories (a, e, i); and Table 4.1.3 plotted
against thrust. Every figure reads only the stage artifacts.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from .. import artifacts
from ..report.figures import save_figure
from ..constants import DAY

STAGE_LABEL = {"lp": "LP (minimum power)", "tmin": "T_min", "ot": "OT"}


def _load(path):
    return artifacts.read_json(path)["scalars"], artifacts.read_npz(path)


def _projection(ax, smp, i, j, burn_color="k", coast_color="0.7", lw=0.6):
    r = smp["r_m"] / 1e3
    burn = smp["delta"] > 0.5
    for mask, col in ((~burn, coast_color), (burn, burn_color)):
        mask = mask | np.roll(mask, 1)          # join each arc to the next sample: no gaps
        seg = np.where(mask, 1.0, np.nan)
        ax.plot(r[:, i] * seg, r[:, j] * seg, color=col, lw=lw)
    ax.plot(0, 0, "o", color="tab:blue", ms=3)
    if (i, j) == (0, 1):
        ax.set_aspect("equal")          # out-of-plane views are stretched to show the z motion
    ax.set_xlabel("xyz"[i] + ", km")
    ax.set_ylabel("xyz"[j] + ", km")


def projections(paths: dict, out: Path, title: str):
    """One row per stage, three coordinate-plane projections (Figs. 4.1.1 a–c, 4.1.2)."""
    fig, axes = plt.subplots(len(paths), 3, figsize=(11, 3.4 * len(paths)), squeeze=False)
    for row, (label, p) in zip(axes, paths.items()):
        sc, smp = _load(p)
        for ax, (i, j) in zip(row, ((0, 1), (0, 2), (1, 2))):
            _projection(ax, smp, i, j)
        row[0].set_title(f"{label}: Δt = {sc['tof_days']:.4f} d", loc="left", fontsize=9)
    fig.suptitle(title + " (black: thrust, grey: coast)")
    return save_figure(fig, out)


def controls(paths: dict, out: Path, title: str):
    """Acceleration (+ S for OT), pitch and yaw against time (Figs. 4.1.1 d–f, 4.1.3)."""
    fig, axes = plt.subplots(len(paths), 3, figsize=(12, 2.8 * len(paths)), squeeze=False)
    for row, (label, p) in zip(axes, paths.items()):
        sc, smp = _load(p)
        t = smp["t_s"] / DAY
        row[0].plot(t, np.linalg.norm(smp["accel_m_s2"], axis=1) * 1e3, "k", lw=0.6)
        row[0].set_ylabel("a, mm/s²")
        if sc["stage"] == "ot":
            ax2 = row[0].twinx()
            ax2.plot(t, smp["S"], color="tab:red", lw=0.5)
            ax2.axhline(0, color="tab:red", lw=0.3, ls=":")
            ax2.set_ylabel("S", color="tab:red")
        row[1].plot(t, smp["pitch_deg"], "k.", ms=0.5)
        row[1].set_ylabel("pitch, deg")
        row[2].plot(t, smp["yaw_deg"], "k.", ms=0.5)
        row[2].set_ylabel("yaw, deg")
        row[0].set_title(label, loc="left", fontsize=9)
        for ax in row:
            ax.set_xlabel("t, d")
    fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, out)


def elements(paths: dict, out: Path, title: str):
    """a, e, i against time for each stage (Fig. 4.1.5)."""
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.2))
    for label, p in paths.items():
        _, smp = _load(p)
        t = smp["t_s"] / DAY
        axes[0].plot(t, smp["a_m"] / 1e3, lw=0.8, label=label)
        axes[1].plot(t, smp["e"], lw=0.8)
        axes[2].plot(t, smp["i_deg"], lw=0.8)
    for ax, lab in zip(axes, ("a, km", "e", "i, deg")):
        ax.set_xlabel("t, d")
        ax.set_ylabel(lab)
    axes[0].legend(fontsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    return save_figure(fig, out)


def thrust_family(paths: dict, out: Path):
    """Equatorial projections of the 100-revolution OT family (Fig. 4.1.8)."""
    n = len(paths)
    cols = min(n, 4)
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 3.2 * rows), squeeze=False)
    for ax, (label, p) in zip(axes.flat, paths.items()):
        _, smp = _load(p)
        _projection(ax, smp, 0, 1, lw=0.3)
        ax.set_title(label, fontsize=8)
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    fig.tight_layout()
    return save_figure(fig, out)


def table_plot(rows: list[dict], out: Path):
    """Δt_opt, m_f and Δt_b/Δt_opt against thrust (Fig. 4.1.9)."""
    T = np.array([r["thrust_N"] for r in rows])
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.2))
    for ax, key, lab in zip(axes, ("tof_days", "m_f_kg", "burn_fraction"), ("Δt_opt, d", "m_f, kg", "Δt_b / Δt_opt")):
        ax.plot(T, [r[key] for r in rows], "ko-", ms=3)
        ax.set_xscale("log")
        ax.set_xlabel("T, N")
        ax.set_ylabel(lab)
    fig.tight_layout()
    return save_figure(fig, out)
