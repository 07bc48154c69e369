"""§4.1 tables: anchors.csv, Table 4.1.3 (CSV/Markdown/LaTeX), verification, reproduction rows."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt.report import compare  # noqa: E402
from spaceopt.report.tables import write_csv  # noqa: E402
from spaceopt.report.verification import verification_rows, write_verification_csv  # noqa: E402
from spaceopt.studies import multirev_report as mr  # noqa: E402


def main(sm):
    stages = {k: v for k, v in sm.input.items() if not k.startswith("_")}
    anchor_rows = mr.anchors(stages)
    write_csv(sm.output.anchors, anchor_rows, ["case", "quantity", "value", "unit"])
    t413 = mr.table_4_1_3(stages, sm.params.t413["thrust_N"])
    write_csv(sm.output.t413, t413, mr.T413_COLUMNS)
    t413_cfg = sm.params.t413
    comparable = t413_cfg["case"] == t413_cfg["published_case"]
    pub = compare.published_lookup(sm.input._pub) if comparable else {}
    Path(sm.output.t413_md).write_text(mr.table_4_1_3_markdown(t413, pub))
    Path(sm.output.t413_tex).write_text(mr.table_4_1_3_latex(t413))
    ver_rows = verification_rows(sm.input._verify)
    write_verification_csv(sm.output.verify, ver_rows)
    rows = mr.reproduction_rows(sm.input._pub, anchor_rows, t413, comparable, stages)
    compare.write_rows(sm.output.repro, rows)


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
