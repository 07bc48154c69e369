"""Selective re-runs of the workflow (design.md, principle 5: thin glue).

The DAG runs in a temporary copy of the repository's workflow skeleton (Snakefile, common.smk,
report.smk, the global config and src/) with a tiny test-only study ``toy`` written by this file:

    toy_solve (one job per case; params: the case's numbers, the solver tolerance;
               input: a library source file)  ->  toy_table (reproduction.csv)  ->  scoreboard
                                              ->  toy_figure (params: figure style only)

Then, with ``snakemake -n --rerun-triggers params input code mtime``:
(a) changing one case's parameter lists only that case's solve and what depends on it;
(b) touching a library source file listed as input reruns the solves;
(c) changing a figure-style parameter reruns only the figure rule.
The study rules of the real workflow follow the same pattern (docs/conventions.md); a toy
study keeps the test fast (< 20 s) and independent of the studies' own solvers.
"""
import importlib.util
import os
import re
import subprocess
import textwrap
import time
from pathlib import Path

import pytest
import yaml
from workflow_skeleton import make_skeleton, planned_jobs, run_snakemake

ROOT = Path(__file__).resolve().parents[1]

if importlib.util.find_spec("snakemake") is None:  # pragma: no cover
    pytest.skip("snakemake is not installed (it is a pinned dependency: ./dev setup)", allow_module_level=True)

TRIGGERS = ["--rerun-triggers", "params", "input", "code", "mtime", "--"]  # "--": targets follow

TOY_CONFIG = {"toy": {"cases": {"a": {"x": 1.0}, "b": {"x": 2.0}},
                      "solve": {"tol": 1.0e-8},
                      "published": {"a": 2.0, "b": 4.0},
                      "figure": {"color": "C0", "dpi": 50}}}

TOY_RULES = '''
TOY = config["toy"]
TOY_CASES = sorted(TOY["cases"])


rule toy_solve:
    input:
        lib=lib_sources("artifacts"),
        script="workflow/scripts/toy_solve.py",
    output:
        f"{RESULTS}/toy/{{case}}/solve.json",
    params:
        x=lambda wc: TOY["cases"][wc.case]["x"],
        tol=TOY["solve"]["tol"],
    log:
        f"{RESULTS}/logs/toy/solve_{{case}}.log",
    shell:
        "{PY} {input.script} {output} {params.x} {params.tol} 2> {log}"


rule toy_table:
    input:
        solves=expand(f"{RESULTS}/toy/{{case}}/solve.json", case=TOY_CASES),
        script="workflow/scripts/toy_table.py",
    output:
        f"{RESULTS}/toy/reproduction.csv",
    params:
        published=TOY["published"],
    shell:
        "{PY} {input.script} {output} {params.published:q} {input.solves}"


rule toy_figure:
    input:
        solves=expand(f"{RESULTS}/toy/{{case}}/solve.json", case=TOY_CASES),
    output:
        f"{RESULTS}/toy/figures/toy.png",
    params:
        color=TOY["figure"]["color"],
        dpi=TOY["figure"]["dpi"],
    shell:
        "{PY} -c 'import sys; open(sys.argv[1], \\"w\\").write(\\" \\".join(sys.argv[2:]))' "
        "{output} {params.color} {params.dpi} {input.solves}"


ALL_TARGETS += [f"{RESULTS}/toy/reproduction.csv", f"{RESULTS}/toy/figures/toy.png"]
'''

TOY_SOLVE = '''
import json, sys
out, x, tol = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
json.dump({"y": 2 * x, "tol": tol}, open(out, "w"))
'''

TOY_TABLE = '''
import ast, csv, json, sys
from pathlib import Path
COLUMNS = ["study", "case", "quantity", "unit", "published", "ours", "rel_diff", "abs_diff",
           "tolerance", "status", "ref", "note"]
out, published, solves = sys.argv[1], ast.literal_eval(sys.argv[2]), sys.argv[3:]
with open(out, "w", newline="") as fh:
    w = csv.DictWriter(fh, fieldnames=COLUMNS, lineterminator="\\n")
    w.writeheader()
    for s in solves:
        case = Path(s).parent.name
        ours, pub = json.load(open(s))["y"], published[case]
        rel = (ours - pub) / abs(pub)
        w.writerow({"study": "toy", "case": case, "quantity": "y", "unit": "", "published": pub,
                    "ours": ours, "rel_diff": rel, "abs_diff": ours - pub, "tolerance": "rel 1e-09",
                    "status": "pass" if abs(rel) <= 1e-9 else "fail", "ref": "toy", "note": ""})
'''


def make_workflow(tmp: Path) -> Path:
    """A copy of the workflow skeleton plus the toy study; returns its root."""
    files = ("workflow/rules/report.smk", "workflow/scripts/scoreboard.py", "config/studies/report.yaml",
             "config/schema/report.schema.yaml", "config/errata.yaml")
    return make_skeleton(tmp, {"config/studies/toy.yaml": yaml.safe_dump(TOY_CONFIG),
                               "workflow/rules/toy.smk": TOY_RULES,
                               "workflow/scripts/toy_solve.py": TOY_SOLVE,
                               "workflow/scripts/toy_table.py": TOY_TABLE}, files=files, with_src=True)


def snakemake(root: Path, *args, check=True, timeout=120) -> subprocess.CompletedProcess:
    proc = run_snakemake(root, "--cores", "2", *args, timeout=timeout)
    if check and proc.returncode != 0:
        raise AssertionError(f"snakemake {' '.join(args)} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}")
    return proc


def planned_wildcards(proc, rule: str) -> list[str]:
    """The wildcards lines of the planned jobs of ``rule`` (dry-run output)."""
    text = proc.stdout + proc.stderr
    blocks = re.split(r"\n(?=(?:localrule|rule) )", text)
    return [m.group(1).strip() for b in blocks if re.match(rf"(?:localrule|rule) {rule}:", b)
            for m in [re.search(r"wildcards: (.*)", b)] if m]


TARGETS = ["results/report/scoreboard.csv", "results/toy/figures/toy.png"]


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    root = make_workflow(tmp_path_factory.mktemp("reruns"))
    snakemake(root, *TARGETS)
    # nothing left to do right after a complete run
    assert planned_jobs(snakemake(root, "-n", *TRIGGERS, *TARGETS)) == {}
    return root


def _edit_config(root, fn):
    path = root / "config" / "studies" / "toy.yaml"
    original = path.read_text()
    cfg = yaml.safe_load(original)
    fn(cfg["toy"])
    path.write_text(yaml.safe_dump(cfg))
    return lambda: path.write_text(original)


def test_first_run_builds_scoreboard_from_the_toy_reproduction_table(built):
    text = (built / "results" / "report" / "scoreboard.csv").read_text()
    assert text.count("\ntoy,") == 2
    summary = (built / "results" / "report" / "scoreboard_summary.csv").read_text()
    assert "toy,2,2,0,0,0,0" in summary


def test_parameter_change_reruns_only_its_dependents(built):
    restore = _edit_config(built, lambda c: c["cases"]["a"].update(x=1.5))
    try:
        proc = snakemake(built, "-n", *TRIGGERS, *TARGETS)
        jobs = planned_jobs(proc)
        assert jobs.get("toy_solve") == 1, jobs
        assert planned_wildcards(proc, "toy_solve") == ["case=a"]
        # downstream of the changed solve: the table, the figure, the scoreboard
        assert {"toy_table", "toy_figure", "scoreboard"} <= set(jobs), jobs
        assert not {"paper", "paper_errata", "paper_performance"} & set(jobs), jobs
    finally:
        restore()


def test_solver_parameter_reruns_every_solve(built):
    restore = _edit_config(built, lambda c: c["solve"].update(tol=1e-10))
    try:
        jobs = planned_jobs(snakemake(built, "-n", *TRIGGERS, *TARGETS))
        assert jobs.get("toy_solve") == 2, jobs
    finally:
        restore()


def test_library_source_change_reruns_the_solves(built):
    # Snakemake 9 reruns on a newer input only when its content changed too (checksum check for
    # small files), so the source is edited, not just touched.
    lib = built / "src" / "spaceopt" / "artifacts.py"
    original = lib.read_text()
    lib.write_text(original + "\n# a solver change\n")
    future = time.time() + 2
    os.utime(lib, (future, future))
    try:
        jobs = planned_jobs(snakemake(built, "-n", *TRIGGERS, *TARGETS))
        assert jobs.get("toy_solve") == 2, jobs
        assert {"toy_table", "toy_figure", "scoreboard"} <= set(jobs), jobs
    finally:
        lib.write_text(original)


def test_figure_style_change_reruns_only_the_figure(built):
    restore = _edit_config(built, lambda c: c["figure"].update(dpi=72, color="k"))
    try:
        jobs = planned_jobs(snakemake(built, "-n", *TRIGGERS, *TARGETS))
        jobs.pop("all", None)
        assert jobs == {"toy_figure": 1}, jobs
        # and running it really changes only the figure
        before = {p: p.stat().st_mtime_ns for p in (built / "results" / "toy").rglob("*.json")}
        snakemake(built, *TRIGGERS, *TARGETS)
        assert {p: p.stat().st_mtime_ns for p in before} == before
        assert "k 72" in (built / "results" / "toy" / "figures" / "toy.png").read_text()
    finally:
        restore()


def test_report_rules_collect_reproduction_tables_lazily(built):
    """A study rules file that sorts after report.smk is still seen by the scoreboard."""
    extra = built / "workflow" / "rules" / "zz_late.smk"
    extra.write_text(textwrap.dedent('''
        rule zz_late:
            output: f"{RESULTS}/zz_late/reproduction_extra.csv"
            shell: "cp {RESULTS}/toy/reproduction.csv {output}"
        ALL_TARGETS.append(f"{RESULTS}/zz_late/reproduction_extra.csv")
    '''))
    try:
        proc = snakemake(built, "-n", *TRIGGERS, "results/report/scoreboard.csv")
        jobs = planned_jobs(proc)
        assert jobs.get("zz_late") == 1 and jobs.get("scoreboard") == 1, jobs
        assert re.search(r"input: [^\n]*results/zz_late/reproduction_extra\.csv", proc.stdout + proc.stderr)
    finally:
        extra.unlink()


def test_paper_sections_use_fragments_first_then_automatic_sections():
    from spaceopt.report.paper import sections_tex

    tex = sections_tex("results",
                       fragments=["results/multirev/paper_section.tex"],
                       repro=[],
                       figures=["results/discrete/figures/a.png", "results/discrete/figures/a.pdf",
                                "results/multirev/figures/x.pdf", "results/zeta/figures/z.png"],
                       section_order=["multirev", "discrete*"])
    lines = [line for line in tex.splitlines() if line.startswith(("\\input", "% study"))]
    assert lines[:2] == ["% study multirev", "\\input{results/multirev/paper_section.tex}"]
    assert lines[2].startswith("% study discrete (automatic") and lines[3].startswith("% study zeta (automatic")
    assert "results/discrete/figures/a.pdf" in tex and "figures/a.png" not in tex   # PDF preferred
    assert "results/multirev/figures/x.pdf" not in tex                              # the fragment decides
    assert "No study" in sections_tex("results")
