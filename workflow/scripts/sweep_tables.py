"""Tables 4.1.1-4.1.2 (CSV, Markdown, LaTeX), reproduction rows, regularities, LaTeX fragment."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.report import compare  # noqa: E402
from spaceopt.studies import sweep_report as rep  # noqa: E402
from spaceopt.studies.sweep import CELL_COLUMNS  # noqa: E402


def main(sm):
    out, prm = sm.output, sm.params
    rows = [artifacts.read_json(p) for p in sm.input.rows]
    cells = rep.all_cells([r["cells"] for r in rows])
    rep.write_csv(out.t411_csv, rep.table_cells(cells, prm.table_L0, prm.n_revs), CELL_COLUMNS)
    rep.write_csv(out.cells, cells, CELL_COLUMNS + ["K_f_deg", "mass_balance_kg", "method",
                                                    "jacobian_evaluations", "integration_steps",
                                                    "final_residual", "wall_s"])
    repro = rep.reproduction_rows(sm.input.pub, cells)
    compare.write_rows(out.repro, repro)
    pub = compare.published_lookup(sm.input.pub)
    for q, md, tex in (("T_min_N", out.t411_md, out.t411_tex), ("tof_days", out.t412_md, out.t412_tex)):
        Path(md).write_text(rep.table_markdown(cells, pub, repro, q, prm.table_L0, prm.n_revs))
        Path(tex).write_text(rep.table_latex(cells, pub, repro, q, prm.table_L0, prm.n_revs))
    regs = rep.regularities(cells, prm.table_L0, artifacts.read_json(sm.input.nstar))
    rep.write_csv(out.regularities, regs, rep.REG_COLUMNS)
    timing = {r["n_rev"]: r["timing"] for r in rows}
    summary = ("Sweep time per row (this run, wall / CPU s): "
               + "; ".join(f"{n:g} rev: {t['wall_s']:.0f} / {t['cpu_s']:.0f} ({t['cells']} cells)"
                           for n, t in sorted(timing.items())) + ".")
    figures = sorted(f.stem for f in Path(sm.input.figures).glob("*.pdf"))
    Path(out.section).write_text(rep.paper_section(repro, regs, cells, {"summary": summary}, figures))


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
