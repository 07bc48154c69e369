"""§4.2 figures (4.2.1.x, 4.2.2.x, 4.2.3.x) from the OT artifacts of the perturbed studies."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.report.tables import read_csv  # noqa: E402
from spaceopt.studies import perturbed_figures as F  # noqa: E402
from spaceopt.studies import perturbed_report as R  # noqa: E402


def main(sm):
    out = Path(sm.output[0]).parent
    stages = {k: v for k, v in sm.input.items() if not k.startswith("_")}
    run, cases = sm.params.run, sm.params.cases
    npz = lambda key: artifacts.read_npz(stages[key])  # noqa: E731
    if "e5" in run:
        runs = {m: npz(f"e5_{m}") for m in cases["e5"]["models"] if f"e5_{m}" in stages}
        F.projections(runs, "E5: 5-rev HEO -> HEO (thick: burns)", out / "fig_4_2_1_1", unit_km=1.0)
        F.elements(runs, "E5: osculating elements", out / "fig_4_2_1_2")
        F.controls(runs, "E5: switching function, pitch, yaw", out / "fig_4_2_1_3")
    if "e6" in run:
        payloads = {k: artifacts.read_json(v) for k, v in stages.items() if k.startswith("e6_") or k == "e5_unperturbed"}
        tabs = R.tables(payloads, ["e6"], cases, sm.params.e6, [])
        rows = R.e6_with_unperturbed(tabs["e6_date_scan"], R.summary_or_none(payloads, "e5_unperturbed"))
        skipped = sm.params.e6.get("skip_dates") or []
        families = read_csv(sm.input._families[0]) if sm.input._families else []
        walks = read_csv(sm.input._walks[0]) if sm.input._walks else []
        envelope = read_csv(sm.input._envelope[0]) if sm.input._envelope else []
        F.date_scan(rows, out / "fig_4_2_1_4", skipped=skipped, families=families, walks=walks, envelope=envelope)
        keys = sorted(k for k in payloads if k.startswith("e6_"))
        F.costates_vs_date([k[3:] for k in keys], [payloads[k]["scalars"]["costates"] for k in keys],
                           out / "fig_4_2_1_5", skipped=skipped)
        shares = [r for r in (read_csv(sm.input._force_shares[0]) if sm.input._force_shares else [])
                  if r["artifact"].startswith("e6/")]
        if shares:
            unp = R.summary_or_none(payloads, "e5_unperturbed")
            heavier = read_csv(sm.input._envelope_extremals[0]) if sm.input._envelope_extremals else []
            F.force_shares_vs_date(shares, unp and unp["m_f_kg"], out / "fig_e6_force_shares", heavier=heavier)
    if "e7" in run:
        runs = {m: npz(f"e7_{m}") for m in cases["e7"]["models"] if f"e7_{m}" in stages}
        F.projections_3d(runs, "E7: GTO -> Molniya, 100 rev, 1 N (thick: burns)", out / "fig_4_2_1_6")
    if "e8" in run:
        n = max(sm.params.e8_n)
        runs = {m: npz(f"e8_{m}_n{float(n):g}") for m in cases["e8"]["models"] if f"e8_{m}_n{float(n):g}" in stages}
        F.projections(runs, f"E8: GTO -> GEO case B, {n:g} rev", out / "fig_4_2_2_1")
        F.controls(runs, f"E8: pitch, yaw, S ({n:g} rev)", out / "fig_4_2_2_3")
        payloads = {k: artifacts.read_json(v) for k, v in stages.items() if k.startswith("e8_")}
        payloads_named = {}
        for m in cases["e8"]["models"]:
            for nn in sm.params.e8_n:
                k = f"e8_{m}_n{float(nn):g}"
                if k in payloads:
                    payloads_named[k] = payloads[k]
        tabs = R.tables(payloads_named, ["e8"], cases, {}, sm.params.e8_n)
        F.fuel_vs_revs(tabs["e8"], out / "fig_4_2_2_5")
    if "e9" in run:
        models = cases["e9"]["models"]
        for m, fig in zip(models[:2], ("fig_4_2_3_1", "fig_4_2_3_2")):
            if f"e9_{m}" not in stages:
                continue
            F.controls({m: npz(f"e9_{m}")}, f"E9: LEO, {m}", out / fig, with_delta=True,
                       with_elements=("a_m", "e", "raan_deg"))


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
