# Dissertation §4.1: minimum-power solves -> minimum-thrust existence checks -> minimum-fuel
# continuation -> tables and figures (spec 02-multirev §3).
from spaceopt.studies.multirev_config import check_config as _check_multirev

check_section("multirev", _check_multirev)
MR = config["multirev"]
MRDIR = f"{RESULTS}/multirev"
SOLVER_SRC = lib_sources("indirect", "elements", "constants", "artifacts", "studies/multirev", "studies/multirev_config",
                         "studies/trajectory")


def _fmt(x):
    return f"{float(x):g}"


def mr_config_for(case):
    """Only what a case depends on, so an unrelated config change reruns nothing."""
    cc = MR["cases"][case]
    return {"constants": MR["constants"], "spacecraft": MR["spacecraft"], "numerics": MR["numerics"],
            "orbits": {cc[k]: MR["orbits"][cc[k]] for k in ("initial", "final")},
            "cases": {case: {k: cc[k] for k in ("initial", "final", "L0_deg", "n_rev")}
                      | {"tmin_isp_s": [], "ot_thrust_N": []}}}


def ot_source(case, thrust):
    """Continuation source of an OT level: 'lp' or the neighbouring thrust level (Table 4.1.3)."""
    t413 = MR["table_4_1_3"]
    if case != t413["case"]:
        return "lp"
    levels = sorted({float(x) for x in t413["thrust_N"]} | {float(t413["anchor_N"])})
    T, anchor = float(thrust), float(t413["anchor_N"])
    if T == anchor or T not in levels:
        return "lp"
    i = levels.index(T)
    return _fmt(levels[i + 1] if T < anchor else levels[i - 1])


def ot_input(w):
    src = ot_source(w.case, w.thrust)
    return f"{MRDIR}/{w.case}/lp.json" if src == "lp" else f"{MRDIR}/{w.case}/ot_{src}N.json"


def mr_stage_files(case, stem):
    return [f"{MRDIR}/{case}/{stem}.{ext}" for ext in ("json", "npz", "rrd")]


rule multirev_lp:
    input: SOLVER_SRC
    output: mr_stage_files("{case}", "lp")
    params: cfg=lambda w: mr_config_for(w.case), case="{case}"
    log: f"{MRDIR}/logs/{{case}}_lp.log"
    benchmark: f"{MRDIR}/benchmarks/{{case}}_lp.tsv"
    resources: mem_mb=3000, runtime=60
    script: "../scripts/multirev_solve.py"


rule multirev_tmin:
    input: lp=f"{MRDIR}/{{case}}/lp.json", src=SOLVER_SRC
    output: mr_stage_files("{case}", "tmin_isp{isp}")
    params: cfg=lambda w: mr_config_for(w.case), case="{case}", isp=lambda w: float(w.isp)
    log: f"{MRDIR}/logs/{{case}}_tmin_isp{{isp}}.log"
    benchmark: f"{MRDIR}/benchmarks/{{case}}_tmin_isp{{isp}}.tsv"
    resources: mem_mb=3000, runtime=60
    script: "../scripts/multirev_solve.py"


rule multirev_ot:
    input: start=ot_input, src=SOLVER_SRC
    output: mr_stage_files("{case}", "ot_{thrust}N")
    params: cfg=lambda w: mr_config_for(w.case), case="{case}", thrust=lambda w: float(w.thrust),
            source=lambda w: ot_source(w.case, w.thrust)
    log: f"{MRDIR}/logs/{{case}}_ot_{{thrust}}N.log"
    benchmark: f"{MRDIR}/benchmarks/{{case}}_ot_{{thrust}}N.tsv"
    resources: mem_mb=3000, runtime=120
    script: "../scripts/multirev_solve.py"


def mr_stage_jsons():
    out = {}
    for case in MR["run_cases"]:
        cc = MR["cases"][case]
        out[f"{case}_lp"] = f"{MRDIR}/{case}/lp.json"
        isps = cc["tmin_isp_s"]
        for isp in isps:
            key = f"{case}_tmin" if len(isps) == 1 else f"{case}_tmin_isp{_fmt(isp)}"
            out[key] = f"{MRDIR}/{case}/tmin_isp{_fmt(isp)}.json"
        for T in cc["ot_thrust_N"]:
            out[f"{case}_ot_{_fmt(T)}N"] = f"{MRDIR}/{case}/ot_{_fmt(T)}N.json"
    t413 = MR["table_4_1_3"]
    for T in t413["thrust_N"]:
        out[f"t413_{_fmt(T)}N"] = f"{MRDIR}/{t413['case']}/ot_{_fmt(T)}N.json"
    out["t413_tmin"] = f"{MRDIR}/{t413['case']}/tmin_isp{_fmt(MR['spacecraft']['isp_s'])}.json"
    return out


rule multirev_verify:
    input: json=f"{MRDIR}/{{case}}/ot_{{thrust}}N.json", src=lib_sources("studies/verify")
    output: f"{MRDIR}/{{case}}/ot_{{thrust}}N.verify.json"
    log: f"{MRDIR}/logs/{{case}}_ot_{{thrust}}N_verify.log"
    benchmark: f"{MRDIR}/benchmarks/{{case}}_ot_{{thrust}}N_verify.tsv"
    resources: mem_mb=2000, runtime=30
    script: "../scripts/verify_ot.py"


def mr_verify_files():
    ots = sorted({p for p in mr_stage_jsons().values() if "/ot_" in p})
    return [p.replace(".json", ".verify.json") for p in ots]


rule multirev_tables:
    input: **mr_stage_jsons(), _verify=mr_verify_files(), _pub="config/published/yun2023_multirev.yaml",
           _src=lib_sources("report/compare", "report/verification", "studies/multirev_report")
    output:
        anchors=f"{MRDIR}/anchors.csv",
        t413=f"{MRDIR}/table_4_1_3.csv",
        t413_md=f"{MRDIR}/table_4_1_3.md",
        t413_tex=f"{MRDIR}/table_4_1_3.tex",
        verify=f"{MRDIR}/verification.csv",
        repro=f"{MRDIR}/reproduction.csv",
    params: t413=MR["table_4_1_3"]
    log: f"{MRDIR}/logs/tables.log"
    benchmark: f"{MRDIR}/benchmarks/tables.tsv"
    script: "../scripts/multirev_tables.py"


rule multirev_figures:
    input: **mr_stage_jsons(), _src=lib_sources("studies/multirev_figures", "report/figures")
    output: directory(f"{MRDIR}/figures")
    params: style=MR.get("figures", {}), t413=MR["table_4_1_3"], isp=MR["spacecraft"]["isp_s"]
    log: f"{MRDIR}/logs/figures.log"
    benchmark: f"{MRDIR}/benchmarks/figures.tsv"
    script: "../scripts/multirev_figures.py"


rule multirev_paper_section:
    input: repro=f"{MRDIR}/reproduction.csv", verify=f"{MRDIR}/verification.csv", anchors=f"{MRDIR}/anchors.csv",
           t413=f"{MRDIR}/table_4_1_3.csv", t413_tex=f"{MRDIR}/table_4_1_3.tex", figures=f"{MRDIR}/figures",
           _src=lib_sources("studies/multirev_report", "report/verification")
    output: f"{MRDIR}/paper_section.tex"
    params: cases=MR["run_cases"]
    log: f"{MRDIR}/logs/paper_section.log"
    benchmark: f"{MRDIR}/benchmarks/paper_section.tsv"
    script: "../scripts/multirev_paper.py"


ALL_TARGETS += [f"{MRDIR}/paper_section.tex", f"{MRDIR}/anchors.csv", f"{MRDIR}/table_4_1_3.csv", f"{MRDIR}/reproduction.csv",
                f"{MRDIR}/figures"]
