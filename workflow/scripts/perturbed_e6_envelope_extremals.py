"""The E6 extremals of other families that are heavier than the scan's (e6_envelope.csv), saved
as artifacts from their unknowns (results/perturbed/e6_envelope/<date>.{json,npz,rrd}), each
re-propagated in Cartesian coordinates (spaceopt.studies.verify) and split by force
(spaceopt.studies.force_shares): results/perturbed/e6_envelope_extremals.csv."""
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.report.tables import read_csv, write_csv  # noqa: E402
from spaceopt.studies import force_shares as S, perturbed as P, scan_walks as W  # noqa: E402
from spaceopt.studies.verify import verify_ot  # noqa: E402

VERIFY = ["final_position_vs_solver_km", "final_position_without_perturbations_km", "final_mass_error_kg",
          "final_a_error_km"]


def main(sm):
    cfg = sm.params.cfg
    scan = dict(zip(sm.params.dates, sm.input.dates))
    links = [artifacts.read_json(p)["link"] for p in sm.input.links]
    steps = [s for p in sm.input.walks for s in artifacts.read_json(p)["walk"]["steps"]]
    out = Path(sm.output.artifacts)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for row, z in W.heavier_extremals(read_csv(sm.input.envelope[0]), links, steps, sm.params.mass_tol_kg):
        t0 = time.perf_counter()
        date = row["date"]
        path = out / f"{date}.json"
        P.save(W.extremal_at(P.load(scan[date]), z), path, cfg, 0.0, extra={"family_of": row["family_of"]},
               samples_per_rev=sm.params.samples_per_rev)
        check = verify_ot(path)
        rows.append({"date": date, "family_of": row["family_of"], "gain_kg": row["gain_kg"],
                     **S.share_row(S.shares_payload(path, f"e6_envelope/{date}.json")),
                     **{k: check.get(k) for k in VERIFY}})
        print(f"[e6 envelope {date}] m_f {rows[-1]['m_f_kg']:.6f} kg, Moon {100 * rows[-1]['h_share_moon']:.1f} % "
              f"of Δh, verified to {check['final_position_vs_solver_km']:.3g} km ({time.perf_counter() - t0:.0f} s)",
              file=sys.stderr, flush=True)
    cols = ["date", "family_of", "gain_kg"] + S.share_columns(rows)[1:] + VERIFY
    write_csv(sm.output.table, rows, cols)


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
