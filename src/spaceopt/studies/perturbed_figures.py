"""Figures of the perturbed §4.2 studies (spec 02-multirev §8: 4.2.1.x, 4.2.2.x, 4.2.3.x).

Every figure is drawn from the NPZ samples of the OT artifacts (``artifacts.read_npz``): time,
inertial position, throttle δ, switching function S, pitch/yaw and osculating elements.
Burn arcs (δ > ½) are drawn thick/black, coasts thin/grey (perturbed coasts dashed).
"""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..report.figures import save_figure  # noqa: E402
from ..constants import DAY  # noqa: E402
from .force_shares import in_every  # noqa: E402
from .scan_families import segments  # noqa: E402

COLORS = {"unperturbed": "tab:blue", "j2": "tab:green", "g44": "tab:orange", "g44_moon_sun": "tab:red"}


def _burn_segments(ax, x, y, burn, color, dashed=False, label=None):
    ax.plot(x, y, color=color, lw=0.5, ls="--" if dashed else "-", alpha=0.6, label=label)
    xb, yb = np.where(burn, x, np.nan), np.where(burn, y, np.nan)
    ax.plot(xb, yb, color=color, lw=1.6)


def projections(runs: dict, title: str, path, unit_km=1e3, dpi=150):
    """Projections on the x-y, x-z, y-z planes (ICRS/J2000 axes) for {label: npz}."""
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.4))
    for label, s in runs.items():
        r = np.asarray(s["r_m"]) / unit_km / 1e3
        burn = np.asarray(s["delta"]) > 0.5
        for ax, (i, j) in zip(axes, ((0, 1), (0, 2), (1, 2))):
            _burn_segments(ax, r[:, i], r[:, j], burn, COLORS.get(label, "k"), dashed=label != "unperturbed",
                           label=label if ax is axes[0] else None)
    for ax, (a, b) in zip(axes, (("x", "y"), ("x", "z"), ("y", "z"))):
        unit = "km" if unit_km == 1.0 else ("10³ km" if unit_km == 1e3 else f"{unit_km:g} km")
        ax.set_xlabel(f"{a}, {unit}"); ax.set_ylabel(f"{b}, {unit}"); ax.set_aspect("equal", "datalim")
        ax.plot(0, 0, "o", color="k", ms=3)
    axes[0].legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def projections_3d(runs: dict, title: str, path, unit_km=1e3):
    """One row per run: the x-y, x-z, y-z projections (ICRS/J2000 axes) and a 3-D view, on common
    limits (E7, Fig. 4.2.1.6); thick: burns, thin: coasts; o: departure, x: arrival."""
    unit = "km" if unit_km == 1.0 else ("10³ km" if unit_km == 1e3 else f"{unit_km:g} km")
    rs = {label: np.asarray(s["r_m"]) / unit_km / 1e3 for label, s in runs.items()}
    allr = np.concatenate(list(rs.values())) if rs else np.zeros((1, 3))
    mid = 0.5 * (allr.max(axis=0) + allr.min(axis=0))
    half = 0.525 * float((allr.max(axis=0) - allr.min(axis=0)).max())
    lims = [(c - half, c + half) for c in mid]
    fig = plt.figure(figsize=(17, 4.3 * max(len(runs), 1)))
    for row, (label, s) in enumerate(runs.items()):
        r, burn, color = rs[label], np.asarray(s["delta"]) > 0.5, COLORS.get(label, "k")
        for col, (i, j) in enumerate(((0, 1), (0, 2), (1, 2))):
            ax = fig.add_subplot(len(runs), 4, 4 * row + col + 1)
            ax.plot(r[:, i], r[:, j], color=color, lw=0.25, alpha=0.5)
            ax.plot(np.where(burn, r[:, i], np.nan), np.where(burn, r[:, j], np.nan), color=color, lw=0.8)
            ax.plot(r[0, i], r[0, j], "o", color="k", ms=4)
            ax.plot(r[-1, i], r[-1, j], "x", color="k", ms=6)
            ax.plot(0, 0, "+", color="k", ms=5)
            ax.set_xlim(*lims[i]); ax.set_ylim(*lims[j]); ax.set_aspect("equal")
            ax.set_xlabel(f"{'xyz'[i]}, {unit}"); ax.set_ylabel(f"{'xyz'[j]}, {unit}")
            if col == 0:
                ax.set_title(label, loc="left", fontsize=10, color=color)
        ax = fig.add_subplot(len(runs), 4, 4 * row + 4, projection="3d")
        ax.plot(r[:, 0], r[:, 1], r[:, 2], color=color, lw=0.2, alpha=0.5)
        ax.plot(np.where(burn, r[:, 0], np.nan), np.where(burn, r[:, 1], np.nan),
                np.where(burn, r[:, 2], np.nan), color=color, lw=0.6)
        ax.set_xlim(*lims[0]); ax.set_ylim(*lims[1]); ax.set_zlim(*lims[2]); ax.set_box_aspect((1, 1, 1))
        ax.set_xlabel(f"x, {unit}", fontsize=8); ax.set_ylabel(f"y, {unit}", fontsize=8)
        ax.set_zlabel(f"z, {unit}", fontsize=8); ax.tick_params(labelsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


LABELS = {"a_m": "a, km", "e": "e", "i_deg": "i, deg", "raan_deg": "Ω, deg", "argp_deg": "ω, deg",
          "S": "S", "pitch_deg": "pitch, deg", "yaw_deg": "yaw, deg", "delta": "δ"}


def _time_series(runs: dict, keys, title: str, path, row_height: float, lw: float, unwrap=()):
    """One panel per key against time in days, one line per run; a in km, ``unwrap`` angles unwrapped."""
    fig, axes = plt.subplots(len(keys), 1, figsize=(8, row_height * len(keys)), sharex=True)
    for label, s in runs.items():
        t = np.asarray(s["t_s"]) / DAY
        for ax, k in zip(axes, keys):
            v = np.asarray(s[k]) / (1e3 if k == "a_m" else 1.0)
            if k in unwrap:
                v = np.degrees(np.unwrap(np.radians(v)))
            ax.plot(t, v, color=COLORS.get(label, "k"), lw=lw, label=label)
            ax.set_ylabel(LABELS[k])
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("t, days")
    fig.suptitle(title)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def elements(runs: dict, title: str, path, keys=("a_m", "e", "i_deg", "raan_deg", "argp_deg")):
    _time_series(runs, keys, title, path, row_height=1.9, lw=0.8, unwrap=("raan_deg", "argp_deg"))


def controls(runs: dict, title: str, path, with_delta=False, with_elements=()):
    keys = list(with_elements) + ["S", "pitch_deg", "yaw_deg"] + (["delta"] if with_delta else [])
    _time_series(runs, keys, title, path, row_height=1.7, lw=0.6)


def _day(date: str) -> int:
    return int(date[8:10])


def _with_gaps(days: list, values: list, skipped: list):
    """(days, values) with a NaN at each skipped day, so that a line breaks there instead of
    bridging the date that was left out (``perturbed.e6.skip_dates``, or failed: ``failed_solves``)."""
    pts = sorted([*zip(days, values), *((_day(d), np.nan) for d in skipped)])
    return [d for d, _ in pts], [v for _, v in pts]


def _mark_skipped(ax, skipped: list):
    for k, d in enumerate(skipped):
        ax.axvline(_day(d), color="0.6", ls=":", lw=1, label="left out (skipped or failed)" if k == 0 else None)


def date_scan(rows: list, path, title="E6: departure date scan, May 2021", skipped=(), families=(), walks=(),
              envelope=()):
    """Fig. 4.2.1.4: m_f and Δt against the departure day, the unperturbed line dashed; the
    dates of ``skipped`` (left out of the run) break the curve and are marked. ``families``: the
    rows of ``e6_families.csv`` (:mod:`spaceopt.studies.scan_families`); the curve is then drawn
    one family at a time (no line across a jump), and the other extremals that a neighbour's
    family reaches at a date are drawn as open circles. ``walks``: the rows of ``e6_walks.csv``
    (:mod:`spaceopt.studies.scan_walks`), each such family followed on, drawn dashed from its
    link's point; ``envelope``: the rows of ``e6_envelope.csv``, the heaviest extremal found at
    each date, a broad grey band under the curves."""
    pert = sorted((r for r in rows if r["model"] != "unperturbed"), key=lambda r: r["date"])
    unp = [r for r in rows if r["model"] == "unperturbed"]
    by_date = {r["date"]: r for r in pert}
    segs = segments(list(by_date), list(families)) if families else [list(by_date)]
    others = [f for f in families if f["status"] == "other"]
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.8))
    for ax, k, lab in ((axes[0], "m_f_kg", "m_f, kg"), (axes[1], "tof_days", "Δt, days")):
        for i, seg in enumerate(segs):
            inside = [d for d in skipped if seg[0] < d < seg[-1]]
            ax.plot(*_with_gaps([_day(d) for d in seg], [by_date[d][k] for d in seg], inside), "o-",
                    color="tab:red", ms=3, label=("perturbed" + (", one line per family" if families else ""))
                    if i == 0 else None)
        if envelope:
            ax.plot([_day(r["date"]) for r in envelope], [r[k] for r in envelope], "-", color="0.6", lw=6,
                    alpha=0.4, zorder=0, label="heaviest extremal found")
        for i, line in enumerate(_walk_lines(others, walks)):
            ax.plot([_day(r["date"]) for r in line], [r[k] for r in line], "--", color="tab:green", lw=1,
                    label="a family followed on" if i == 0 else None)
        if others:
            ax.plot([_day(f["to_date"]) for f in others], [f[k] for f in others], "o", mfc="none",
                    color="tab:green", ms=6, label="a neighbour's family continued to the date")
        if unp:
            ax.axhline(unp[0][k], color="tab:blue", ls="--", label="unperturbed")
        _mark_skipped(ax, skipped)
        ax.set_xlabel("departure day, May 2021 (12:00 UTC)"); ax.set_ylabel(lab)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="lower center", ncol=4, fontsize=8, frameon=False)
    fig.suptitle(title)
    fig.tight_layout(rect=(0, 0.07, 1, 1))       # the legend below the panels, clear of the points
    save_figure(fig, path)
    plt.close(fig)


def _walk_lines(others: list, walks: list) -> list[list[dict]]:
    """One line per walk that took a step: its link's point (``others``, rows of
    ``e6_families.csv``), then each step that reached its date (an ``other`` extremal, or the
    scan's where the walk ends on it), as {date, m_f_kg, tof_days}."""
    lines = []
    for f in others:
        steps = [w for w in walks if (w["from_date"], w["link_to"]) == (f["from_date"], f["to_date"])
                 and w["status"] in ("other", "same")]
        if steps:
            lines.append([{"date": f["to_date"], "m_f_kg": f["m_f_kg"], "tof_days": f["tof_days"]}]
                         + [{"date": w["date"], "m_f_kg": w["m_f_kg"], "tof_days": w["tof_days"]} for w in steps])
    return lines


def force_shares_vs_date(rows: list, unperturbed_m_f: float | None, path, heavier=(),
                         title="E6: what each force contributes to the change of the orbit"):
    """Each force's share of the change of angular momentum Δh against the departure day (left),
    and the final mass against the Moon's share (right, with the least-squares line and the
    unperturbed m_f). ``rows``: the E6 rows of ``force_shares.csv``
    (:mod:`spaceopt.studies.force_shares`), artifact ``e6/<date>``; ``heavier``: the rows of
    ``e6_envelope_extremals.csv``, other families' extremals heavier than the scan's, drawn as
    open circles on the right."""
    rows = sorted(rows, key=lambda r: r["artifact"])
    days = [_day(r["artifact"].split("/")[-1]) for r in rows]
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.8))
    for k, color in (("thrust", "k"), ("moon", "tab:gray"), ("sun", "tab:orange"), ("geopotential", "tab:green"),
                     ("j2", "tab:green")):
        if in_every(rows, f"h_share_{k}"):                                   # a force of these solves
            axes[0].plot(days, [100 * r[f"h_share_{k}"] for r in rows], "o-", ms=3, color=color, label=k)
    axes[0].set_xlabel("departure day, May 2021 (12:00 UTC)"); axes[0].set_ylabel("share of Δh, %")
    axes[0].legend(fontsize=8, frameon=False)
    if in_every(rows, "h_share_moon"):
        _mass_against_moon(axes[1], rows, heavier, unperturbed_m_f)
    else:                                                                    # a model without the Moon
        axes[1].set_visible(False)
    fig.suptitle(title)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def _mass_against_moon(ax, rows: list, heavier, unperturbed_m_f: float | None):
    """The right panel of :func:`force_shares_vs_date`: m_f against the Moon's share of Δh."""
    moon = np.array([100 * r["h_share_moon"] for r in rows])
    m_f = np.array([r["m_f_kg"] for r in rows])
    ax.plot(moon, m_f, "o", color="tab:red", ms=4, label="perturbed extremal of a date")
    slope, icpt = np.polyfit(moon, m_f, 1)
    xs = np.array([0.0, moon.max()])
    ax.plot(xs, icpt + slope * xs, "-", color="tab:red", lw=0.8, label=f"least squares, {10 * slope:+.2f} kg per 10 %")
    if heavier:
        ax.plot([100 * r["h_share_moon"] for r in heavier], [r["m_f_kg"] for r in heavier], "o", mfc="none",
                color="tab:green", ms=6, label="another family's heavier extremal")
    if unperturbed_m_f is not None:
        ax.axhline(unperturbed_m_f, color="tab:blue", ls="--", label="unperturbed")
    ax.set_xlabel("the Moon's share of Δh, %"); ax.set_ylabel("m_f, kg")
    ax.legend(fontsize=8, frameon=False)


def costates_vs_date(dates: list, costates: list, path, title="E6: initial costates vs departure date",
                     skipped=()):
    """Fig. 4.2.1.5: each initial costate against the departure day (gaps at ``skipped``)."""
    names = sorted({k for c in costates for k in c})
    fig, axes = plt.subplots(len(names), 1, figsize=(8, 1.4 * len(names)), sharex=True)
    day = [_day(d) for d in dates]
    for ax, n in zip(np.atleast_1d(axes), names):
        ax.plot(*_with_gaps(day, [c.get(n, np.nan) for c in costates], skipped), "o-", ms=2)
        _mark_skipped(ax, skipped)
        ax.set_ylabel(n, fontsize=8)
    np.atleast_1d(axes)[-1].set_xlabel("departure day, May 2021")
    fig.suptitle(title)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def fuel_vs_revs(rows: list, path, title="E8: propellant vs revolutions and vs Δt"):
    """Fig. 4.2.2.5: m_p against n and against Δt, one line per model. A count that another
    model has and this one lacks (skipped or failed, e.g. the full model at 450) breaks the
    line there instead of being bridged. Models are drawn in the rows' order (the case's: each
    later model on top of the one it starts from)."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.8))
    counts = sorted({r["n_rev"] for r in rows})
    for model in dict.fromkeys(r["model"] for r in rows):
        by_n = {r["n_rev"]: r for r in rows if r["model"] == model}
        m_p = [by_n[n]["propellant_kg"] if n in by_n else np.nan for n in counts]
        tof = [by_n[n]["tof_days"] if n in by_n else np.nan for n in counts]
        c = COLORS.get(model, "k")
        axes[0].plot(counts, m_p, "o-", color=c, label=model)
        axes[1].plot(tof, m_p, "o-", color=c, label=model)
    axes[0].set_xlabel("revolutions"); axes[1].set_xlabel("Δt, days")
    for ax in axes:
        ax.set_ylabel("m_p, kg")
    axes[0].legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


MOON_DISTANCE_KM = 384_400.0     # the Moon's mean distance, for scale (Fig. e7_thrust_family)


def thrust_family(rows: list, path, title: str):
    """m_p, Δt, the largest apogee radius and the throttle's duty against the thrust along the
    minimum-fuel families of one case (``thrust_family.csv``'s rows, one line per model and
    start; a family carried from another model's, squares; the point at the OT's own ε, where it
    differs from the family's, open; a point reached by a branch hop, crossed). The least thrust of
    each line is an upper bound on T_min (:mod:`spaceopt.studies.thrust_family`)."""
    keys = (("propellant_kg", "m_p, kg"), ("tof_days", "Δt, days"), ("max_apogee_km", "largest apogee, km"),
            ("duty", "duty (m_p c / (T Δt))"))
    fig, axes = plt.subplots(1, 4, figsize=(14, 3.6))
    for model, start in dict.fromkeys((r["model"], r["start"]) for r in rows):
        rs = [r for r in rows if (r["model"], r["start"]) == (model, start)]
        eps = rs[-1]["eps"]
        on = sorted((r for r in rs if r["eps"] == eps), key=lambda r: r["thrust_N"])
        off = [r for r in rs if r["eps"] != eps]
        c = COLORS.get(model, "k")
        carried = start != "ot"
        label = f"{model}" + (f" from {start.removeprefix('family_')}'s family" if carried else "") + f" (ε {eps:g})"
        for ax, (k, _) in zip(axes, keys):
            ax.plot([r["thrust_N"] for r in on], [r[k] for r in on], "s--" if carried else "o-", color=c,
                    ms=6 if carried else 3, mfc="none" if carried else c, label=label)
            if off:
                ax.plot([r["thrust_N"] for r in off], [r[k] for r in off], "o", mfc="none", color=c, ms=5)
            hopped = [r for r in on if r.get("hop")]
            if hopped:
                ax.plot([r["thrust_N"] for r in hopped], [r[k] for r in hopped], "x", color=c, ms=7,
                        label=f"{model}: reached by a branch hop")
    axes[2].set_yscale("log")
    axes[2].axhline(MOON_DISTANCE_KM, color="0.5", lw=0.8, ls=":")
    axes[2].text(axes[2].get_xlim()[1], MOON_DISTANCE_KM, "Moon ", ha="right", va="bottom", fontsize=7, color="0.4")
    for ax, (_, label) in zip(axes, keys):
        ax.set_xlabel("thrust T, N")
        ax.set_ylabel(label)
    axes[0].legend(fontsize=7)
    fig.suptitle(title + " (open: the OT at its own ε" + ("; ×: reached by a branch hop)" if any(r.get("hop") for r in rows)
                                                          else ")"))
    fig.tight_layout()
    save_figure(fig, path)
