# Dissertation §4.1 E3: T_min against the initial true longitude and the number of revolutions
# (Tables 4.1.1-4.1.2, Figs. 4.1.6-4.1.7; spec 02-multirev §3, §9 R11-R16).
#
#   sweep_row     one job per revolution count: results/multirev/sweep/row_<n>.json
#                 (a 'cold' row starts from the zero guess; a scaled row reads the earlier rows
#                 it is scaled from, so independent rows run in parallel on the two cores)
#   sweep_nstar   T_min at the revolution counts bracketing n* (spec §9 estimate check)
#   sweep_tables  Table 4.1.1 long CSV, Tables 4.1.1/4.1.2 Markdown + LaTeX, reproduction rows,
#                 regularities, LaTeX fragment
#   sweep_figures Figs. 4.1.6-4.1.7 analogues from the sweep data
from snakemake.utils import validate

validate(config["sweep"], "../../config/schema/sweep.schema.yaml")
SW = config["sweep"]
SW_MRDIR = f"{RESULTS}/multirev"
SWDIR = f"{SW_MRDIR}/sweep"
SW_SRC = lib_sources("indirect", "elements", "constants", "artifacts", "studies/sweep", "studies/multirev_config")


def _swg(x):
    return f"{float(x):g}"


SW_ROWS = {_swg(r["n_rev"]): r for r in SW["rows"]}
for _r in SW["rows"]:
    if _r["start"] != "cold":
        for _n in _r["start"]:
            if _swg(_n) not in SW_ROWS or float(_n) >= float(_r["n_rev"]):
                raise ValueError(f"sweep.rows[n_rev={_r['n_rev']}].start: {_n} is not an earlier row")
for _n in SW.get("n_star", {}).get("start", []):
    if _swg(_n) not in SW_ROWS:
        raise ValueError(f"sweep.n_star.start: {_n} is not a row")


def sw_problem():
    """What every cell depends on: orbits, spacecraft, constants (from multirev), the numerics."""
    mr = config["multirev"]
    return {"multirev": {"constants": mr["constants"], "spacecraft": mr["spacecraft"],
                         "numerics": {k: mr["numerics"][k] for k in ("eps_final", "eps_blend")},
                         "orbits": {SW[k]: mr["orbits"][SW[k]] for k in ("initial", "final")}},
            "sweep": {"initial": SW["initial"], "final": SW["final"], "numerics": SW["numerics"]}}


def sw_row_cfg(n):
    """Only what row n depends on (its grid and start), so other rows' edits rerun nothing here."""
    row = SW_ROWS[n]
    cfg = sw_problem()
    cfg["sweep"].update(rows=[row], table_L0_deg=SW["table_L0_deg"])
    if row["grid"] == "fine":
        cfg["sweep"]["fine_step_deg"] = SW["fine_step_deg"]
    return cfg


def sw_row_json(n):
    return f"{SWDIR}/row_{_swg(n)}.json"


def sw_row_sources(w):
    start = SW_ROWS[w.n]["start"]
    return [] if start == "cold" else [sw_row_json(n) for n in start]


rule sweep_row:
    input: rows=sw_row_sources, src=SW_SRC
    output: f"{SWDIR}/row_{{n}}.json"
    params: cfg=lambda w: sw_row_cfg(w.n), n_rev=lambda w: float(w.n)
    wildcard_constraints: n=r"[0-9.]+"
    log: f"{SWDIR}/logs/row_{{n}}.log"
    benchmark: f"{SWDIR}/benchmarks/row_{{n}}.tsv"
    resources: mem_mb=3000, runtime=120
    script: "../scripts/sweep_row.py"


rule sweep_nstar:
    input: rows=[sw_row_json(n) for n in SW["n_star"]["start"]], src=SW_SRC
    output: f"{SWDIR}/nstar.json"
    params: cfg=lambda w: sw_problem() | {"n_star": SW["n_star"]}
    log: f"{SWDIR}/logs/nstar.log"
    benchmark: f"{SWDIR}/benchmarks/nstar.tsv"
    resources: mem_mb=3000, runtime=60
    script: "../scripts/sweep_nstar.py"


SW_OUT = {
    "t411_csv": f"{SW_MRDIR}/table_4_1_1.csv",
    "t411_md": f"{SW_MRDIR}/table_4_1_1.md",
    "t411_tex": f"{SW_MRDIR}/table_4_1_1.tex",
    "t412_md": f"{SW_MRDIR}/table_4_1_2.md",
    "t412_tex": f"{SW_MRDIR}/table_4_1_2.tex",
    "repro": f"{SW_MRDIR}/reproduction_sweep.csv",
    "regularities": f"{SWDIR}/regularities.csv",
    "cells": f"{SWDIR}/cells.csv",
    "section": f"{SW_MRDIR}/sweep_paper_section.tex",
}


rule sweep_tables:
    input: rows=[sw_row_json(n) for n in SW_ROWS], nstar=f"{SWDIR}/nstar.json",
           pub="config/published/yun2023_sweep.yaml", src=lib_sources("report/compare", "studies/sweep_report"),
           figures=f"{SW_MRDIR}/sweep_figures"     # the paper fragment includes them
    output: **SW_OUT
    params: table_L0=SW["table_L0_deg"], n_revs=[r["n_rev"] for r in SW["rows"]]
    log: f"{SWDIR}/logs/tables.log"
    benchmark: f"{SWDIR}/benchmarks/tables.tsv"
    script: "../scripts/sweep_tables.py"


rule sweep_figures:
    input: rows=[sw_row_json(n) for n in SW_ROWS], src=lib_sources("studies/sweep_figures", "studies/sweep_report", "report/figures")
    output: directory(f"{SW_MRDIR}/sweep_figures")
    params: style=SW.get("figures", {}), table_L0=SW["table_L0_deg"]
    log: f"{SWDIR}/logs/figures.log"
    benchmark: f"{SWDIR}/benchmarks/figures.tsv"
    script: "../scripts/sweep_figures.py"


ALL_TARGETS += [SW_OUT["t411_csv"], SW_OUT["t411_md"], SW_OUT["t411_tex"], SW_OUT["t412_md"],
                SW_OUT["t412_tex"], SW_OUT["repro"], SW_OUT["section"], f"{SW_MRDIR}/sweep_figures"]
