# The software around the science: reproduction scoreboard, paper, HTML report.
#
#   results/report/scoreboard.{csv,md,tex}   every published value beside ours, per-study summary
#   results/paper/paper.pdf                  the paper (paper/paper.tex + generated fragments)
#   snakemake --report results/report.html   the Snakemake HTML report (captions: workflow/report)
#
# Inputs are collected lazily from ALL_TARGETS (functions evaluated when the DAG is built, after
# every rules file has been included), so the alphabetical include order does not matter.
# Contract for study owners: docs/conventions-paper.md.
import os as _os
import re as _re
import shutil as _shutil
import sys as _sys
from glob import glob as _glob_report

validate(config["report"], "../../config/schema/report.schema.yaml")

report: "../report/workflow.rst"

REPORT_DIR = f"{RESULTS}/report"
PAPER_DIR = f"{RESULTS}/paper"
_RES = RESULTS.rstrip("/") + "/"
# Top-level folders of RESULTS that are not studies.
_NOT_STUDIES = {"report", "paper", "benchmarks", "logs"}
_REPRO_RE = _re.compile(r"(?:^|/)reproduction(?:_[^/]+)?\.csv$")


def _study_targets():
    """(study, path) for every target in ALL_TARGETS below RESULTS/<study>/."""
    out = []
    for t in ALL_TARGETS:
        p = str(t)
        if not p.startswith(_RES):
            continue
        parts = p[len(_RES):].split("/")
        if len(parts) >= 2 and parts[0] not in _NOT_STUDIES:
            out.append((parts[0], p))
    return out


def reproduction_tables(wildcards=None):
    """Every reproduction table the DAG produces: results/<study>/reproduction[_*].csv."""
    return sorted({p for _, p in _study_targets() if _REPRO_RE.search(p)})


_FRAGMENT_RE = _re.compile(r"^(?:[A-Za-z0-9]+_)?paper_section\.tex$")


def paper_fragments(wildcards=None):
    """Each study's own paper sections: results/<study>/[<part>_]paper_section.tex."""
    return sorted({p for s, p in _study_targets()
                   if p.startswith(f"{_RES}{s}/") and "/" not in p[len(f"{_RES}{s}/"):]
                   and _FRAGMENT_RE.match(p.rsplit("/", 1)[1])})


def study_figures(wildcards=None):
    """Figures of the studies (results/<study>/figures/*.pdf|png) for automatic sections."""
    return sorted({p for s, p in _study_targets()
                   if p.startswith(f"{_RES}{s}/figures/") and p.endswith((".pdf", ".png"))})


def study_latex_tables(wildcards=None):
    """Generated LaTeX tables of the studies (results/<study>/**/*.tex but the fragment)."""
    return sorted({p for s, p in _study_targets()
                   if p.endswith(".tex") and p != f"{_RES}{s}/paper_section.tex"})


def benchmark_files(wildcards=None):
    """Benchmark results: those the DAG produces plus those the harnesses already wrote."""
    dag = {str(t) for t in ALL_TARGETS if _re.match(_re.escape(_RES) + r"benchmarks/[^/]+\.json$", str(t))}
    return sorted(dag | set(_glob_report(f"{_RES}benchmarks/*.json")))


def _paper_study_inputs(wildcards=None):
    frag = set(paper_fragments())
    studies_with_fragment = {p[len(_RES):].split("/")[0] for p in frag}
    if not config["report"]["paper"]["auto_sections"]:
        return sorted(frag)
    auto = [p for p in reproduction_tables() + study_figures() + study_latex_tables()
            if p[len(_RES):].split("/")[0] not in studies_with_fragment]
    return sorted(frag | set(auto))


_REPORT_LIB = lib_sources("report/scoreboard", "report/compare", "report/paper")


rule scoreboard:
    """Every published value beside ours, with relative difference, tolerance, pass/fail."""
    input:
        tables=reproduction_tables,
        lib=_REPORT_LIB,
        script="workflow/scripts/scoreboard.py",
    output:
        csv=report(f"{REPORT_DIR}/scoreboard.csv", caption="../report/scoreboard.rst",
                   category="Reproduction", labels={"table": "all values"}),
        summary=report(f"{REPORT_DIR}/scoreboard_summary.csv", caption="../report/scoreboard_summary.rst",
                       category="Reproduction", labels={"table": "summary per study"}),
        md=f"{REPORT_DIR}/scoreboard.md",
        tex=f"{REPORT_DIR}/scoreboard.tex",
    params:
        tables=reproduction_tables,
    log:
        f"{RESULTS}/logs/report/scoreboard.log",
    benchmark:
        f"{RESULTS}/benchmarks/rules/scoreboard.tsv"
    shell:
        "{PY} {input.script} --csv {output.csv} --summary {output.summary} --md {output.md} "
        "--tex {output.tex} {params.tables} 2> {log} || {{ tail -n1 {log} >&2; exit 1; }}"


rule paper_errata:
    """The errata of the sources (config/errata.yaml) as a LaTeX fragment."""
    input:
        errata="config/errata.yaml",
        lib=_REPORT_LIB,
        script="workflow/scripts/paper_errata.py",
    output:
        tex=f"{PAPER_DIR}/errata.tex",
        md=report(f"{PAPER_DIR}/errata.md", caption="../report/errata.rst", category="Errata"),
    log:
        f"{RESULTS}/logs/report/paper_errata.log",
    benchmark:
        f"{RESULTS}/benchmarks/rules/paper_errata.tsv"
    shell:
        "{PY} {input.script} --errata {input.errata} --out {output.tex} --md {output.md} 2> {log} "
        "|| {{ tail -n1 {log} >&2; exit 1; }}"


rule paper_performance:
    """The benchmark results (results/benchmarks/*.json) as a table."""
    input:
        benchmarks=benchmark_files,
        lib=_REPORT_LIB,
        script="workflow/scripts/paper_performance.py",
    output:
        tex=f"{PAPER_DIR}/performance.tex",
        md=report(f"{PAPER_DIR}/performance.md", caption="../report/performance.rst",
                  category="Performance"),
    params:
        benchmarks=benchmark_files,
    log:
        f"{RESULTS}/logs/report/paper_performance.log",
    benchmark:
        f"{RESULTS}/benchmarks/rules/paper_performance.tsv"
    shell:
        "{PY} {input.script} --tex {output.tex} --md {output.md} {params.benchmarks} 2> {log} "
        "|| {{ tail -n1 {log} >&2; exit 1; }}"


rule paper_sections:
    """results/paper/sections.tex: the studies' own fragments, or automatic sections."""
    input:
        studies=_paper_study_inputs,
        lib=_REPORT_LIB,
        script="workflow/scripts/paper_sections.py",
    output:
        tex=f"{PAPER_DIR}/sections.tex",
    params:
        results=RESULTS,
        order=",".join(config["report"]["paper"]["section_order"]),
        auto="" if config["report"]["paper"]["auto_sections"] else "--no-auto",
        fragments=paper_fragments,
        repro=reproduction_tables,
        tables=study_latex_tables,
        figures=study_figures,
    log:
        f"{RESULTS}/logs/report/paper_sections.log",
    benchmark:
        f"{RESULTS}/benchmarks/rules/paper_sections.tsv"
    shell:
        "{PY} {input.script} --out {output.tex} --results {params.results} --order '{params.order}' "
        "{params.auto} --fragment {params.fragments} --repro {params.repro} --table {params.tables} "
        "--figure {params.figures} 2> {log} || {{ tail -n1 {log} >&2; exit 1; }}"


rule paper:
    """The paper, built with pdflatex in a fresh build directory until its auxiliary files converge, byte-stable."""
    input:
        tex=sorted(_glob_report("paper/*.tex")),
        sections=f"{PAPER_DIR}/sections.tex",
        studies=_paper_study_inputs,
        errata=f"{PAPER_DIR}/errata.tex",
        performance=f"{PAPER_DIR}/performance.tex",
        scoreboard=f"{REPORT_DIR}/scoreboard.tex",
        script="workflow/scripts/paper_build.py",
    output:
        pdf=report(f"{PAPER_DIR}/paper.pdf", caption="../report/paper.rst", category="Paper"),
    params:
        results=RESULTS,
        build=f"{PAPER_DIR}/build",
        epoch=config["report"]["paper"]["source_date_epoch"],
        note=config["report"]["paper"].get("profile_note", ""),
    log:
        f"{RESULTS}/logs/report/paper.log",
    benchmark:
        f"{RESULTS}/benchmarks/rules/paper.tsv"
    shell:
        "{PY} {input.script} --tex paper/paper.tex --results {params.results} --build {params.build} "
        "--out {output.pdf} --epoch {params.epoch} --note={params.note:q} 2> {log} || {{ tail -n1 {log} >&2; exit 1; }}"


ALL_TARGETS += [f"{REPORT_DIR}/scoreboard.csv"]
if _shutil.which("pdflatex"):
    ALL_TARGETS += [f"{PAPER_DIR}/paper.pdf"]
else:
    # Without TeX (SPACEOPT_NO_TEX=1) the paper is left out of `rule all`; ask for it by name.
    _os.environ.get("SPACEOPT_NO_TEX") == "1" or print(
        "report.smk: pdflatex not found; results/paper/paper.pdf is not part of `all` "
        "(./dev setup installs TeX)", file=_sys.stderr)
