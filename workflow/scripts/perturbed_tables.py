"""§4.2 tables (E5-E9 CSVs, Markdown, LaTeX) and the reproduction rows of the perturbed studies."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.report.tables import read_csv, write_csv  # noqa: E402
from spaceopt.studies import perturbed_report as R  # noqa: E402
from spaceopt.report.verification import verification_rows, write_verification_csv  # noqa: E402


def main(sm):
    stages = {k: v for k, v in sm.input.items() if not k.startswith("_")}
    payloads = {k: artifacts.read_json(v) for k, v in stages.items()}
    npzs = {k: artifacts.read_npz(v) for k, v in stages.items() if k.startswith("e5_")}
    tabs = R.tables(payloads, sm.params.run, sm.params.cases, sm.params.e6, sm.params.e8_n)
    unpert = R.summary_or_none(payloads, "e5_unperturbed")
    tabs["e6_date_scan"] = R.e6_with_unperturbed(tabs["e6_date_scan"], unpert)
    for name, cols in R.COLUMNS.items():
        write_csv(getattr(sm.output, name), tabs[name], cols)
    budget = artifacts.read_json(sm.input._budget)["budget"]
    e6sum = R.e6_summary(tabs["e6_date_scan"], unpert, sm.params.e6.get("skip_dates") or [])
    Path(sm.output.md).write_text(R.markdown(tabs, e6sum, budget))
    Path(sm.output.tex).parent.mkdir(parents=True, exist_ok=True)
    envelope = read_csv(sm.input._envelope[0]) if sm.input._envelope else []
    Path(sm.output.tex).write_text(R.latex(tabs, e6_envelope=envelope))
    write_csv(sm.output.tof_maximum, R.tof_maximum_rows(payloads), R.TOF_MAXIMUM_COLUMNS)
    ver_rows = verification_rows(sm.input._verify)
    write_verification_csv(sm.output.verify, ver_rows)
    rows = R.reproduction_rows(sm.input._pub, R.ours(tabs, payloads, npzs, budget),
                               R.e8_range_notes(tabs, sm.params.e8_n))
    R.write_rows(sm.output.repro, rows)


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
