"""The perturbed study's paper fragment (results/perturbed/paper_section.tex) from its artifacts."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.report.tables import read_csv as _read  # noqa: E402
from spaceopt.studies import perturbed_report as R, scan_families as F, scan_walks as W  # noqa: E402
from spaceopt.studies.existence import sentence as existence_sentence  # noqa: E402
from spaceopt.studies.force_shares import shares_sentence  # noqa: E402
from spaceopt.studies.thrust_family import sentence as family_sentence  # noqa: E402


def main(sm):
    rows = _read(sm.input.repro)
    budget = artifacts.read_json(sm.input.budget)["budget"]
    e6 = _read(sm.input.e6_date_scan)
    unp = next((r for r in e6 if r["model"] == "unperturbed"), None)
    e6sum = R.e6_summary(e6, unp, sm.params.e6_skipped)
    families = (F.families_sentence(sm.params.e6_dates, _read(sm.input.families[0]), sm.params.e6_links["mass_tol_kg"])
                if sm.input.families else "")
    if sm.input.envelope:
        families += " " + W.envelope_sentence(_read(sm.input.walks[0]), _read(sm.input.envelope[0]),
                                              sm.params.e6_links["mass_tol_kg"])
    if sm.input.heavier:
        families += " " + W.heavier_sentence(_read(sm.input.heavier[0]))
    checked = _read(sm.input.existence[0]) if sm.input.existence else []
    existence = existence_sentence(checked, R.MODEL_TEX) if checked else ""
    if sm.input.thrust_family:
        stops = {(Path(p).parent.name, f["model"], f["start"]): f["stopped"] for p in sm.input.thrust_family_runs
                 for f in [artifacts.read_json(p)["extra"]["family"]]}
        existence += " " + family_sentence(_read(sm.input.thrust_family[0]), stops, R.MODEL_TEX,
                                           {(r["case"], r["model"]): r for r in checked})
    Path(sm.output[0]).write_text(R.paper_section(rows, {}, budget, e6sum,
                                                  [*sm.input.figures, *sm.input.family_figures],
                                                  e8_count_start=sm.params.e8_count_start,
                                                  smoothing=sm.params.e8_smoothing,
                                                  e8_steps=sm.params.e8_steps,
                                                  verify_rows=_read(sm.input.verify),
                                                  tof_rows=_read(sm.input.tof_maximum),
                                                  e8_skipped=sm.params.e8_skipped, failures=sm.params.failures,
                                                  e6_families=families,
                                                  force_shares=shares_sentence(
                                                      _read(sm.input.force_shares[0]), unp and unp["m_f_kg"],
                                                      _read(sm.input.force_shares_by_revolution[0]))
                                                  if sm.input.force_shares else "",
                                                  existence=existence.strip()))


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
