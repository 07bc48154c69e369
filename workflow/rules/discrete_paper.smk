# The paper section of the discrete studies (D1-D4): results/discrete/paper_section.tex, built
# from both reproduction tables and every figure of the two discrete rules files (included
# before this one: the rules files are included in alphabetical order).

rule discrete_paper_section:
    input:
        repro=[*rules.reproduction_geo_bellman.output, *rules.reproduction_libration_zonotope.output],
        figures=[*rules.geo_burns.output.figures, *rules.bellman.output.figures,
                 *rules.libration_lp.output.figures, *rules.orbit_correction.output.figures],
        lib=lib_sources("studies/discrete_report", "report/scoreboard", "report/paper"),
        script="workflow/scripts/discrete_paper.py",
    output:
        f"{RESULTS}/discrete/paper_section.tex",
    log:
        f"{RESULTS}/discrete/logs/paper_section.log",
    benchmark:
        f"{RESULTS}/discrete/benchmarks/paper_section.tsv"
    shell:
        "{PY} {input.script} --out {output} --repro {input.repro} --figure {input.figures} 2> {log} "
        "|| {{ tail -n1 {log} >&2; exit 1; }}"


ALL_TARGETS += [f"{RESULTS}/discrete/paper_section.tex"]
