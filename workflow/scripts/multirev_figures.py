"""§4.1 figures from the stage artifacts."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

import matplotlib  # noqa: E402

from spaceopt import artifacts  # noqa: E402
from spaceopt.studies import multirev_figures as fig  # noqa: E402
from spaceopt.studies import multirev_report as mr  # noqa: E402


def main(sm):
    style = sm.params.style
    matplotlib.rcParams["savefig.dpi"] = style.get("dpi", 150)
    out = Path(sm.output[0])
    out.mkdir(parents=True, exist_ok=True)
    st = {k: v for k, v in sm.input.items() if not k.startswith("_")}
    for case in sorted({k.split("_")[0] for k in st if not k.startswith("t413")}):
        stages = {}
        for key, path in st.items():
            if key.startswith(case + "_") and "isp1000" not in key:
                sc = artifacts.read_json(path)["scalars"]
                thrust = f" {sc.get('thrust_N', 0):g} N" if sc["stage"] == "ot" else ""
                stages[fig.STAGE_LABEL[sc["stage"]] + thrust] = path
        fig.projections(stages, out / f"{case}_projections", f"{case}: trajectories")
        fig.controls(stages, out / f"{case}_controls", f"{case}: control histories")
        fig.elements(stages, out / f"{case}_elements", f"{case}: osculating elements")
    levels = sorted((artifacts.read_json(p)["scalars"]["thrust_N"], p)
                    for k, p in st.items() if k.startswith("t413_") and k != "t413_tmin")
    family = {f"T = {T:g} N": p for T, p in levels}
    family = {"T_min": st["t413_tmin"], **family}
    fig.thrust_family(family, out / "t413_family")
    fig.table_plot(mr.table_4_1_3(st, sm.params.t413["thrust_N"]), out / "t413_vs_thrust")


if __name__ == "__main__":
    with open(snakemake.log[0], "w") as log:  # noqa: F821
        sys.stderr = log
        run_step(main, snakemake)  # noqa: F821
