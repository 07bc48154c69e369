# D1 (GEO insertion with start penalties) and D3 (Bellman stabilisation) of the discrete-control
# studies (spec 05-discrete.md). Library: spaceopt.discrete.geo_burns, spaceopt.discrete.bellman.

validate(config["geo_burns"], "../../config/schema/geo_burns.schema.yaml")
validate(config["bellman"], "../../config/schema/bellman.schema.yaml")

_DISC = f"{RESULTS}/discrete"
_GEO_SCHEMES = ["classical", "start_penalised", "flown", "classical_published_counts"]
_GEO_SWITCH = ["classical", "start_penalised", "classical_published_counts"]
_BELLMAN_FIGS = ["bellman_level_sets", "bellman_points", "bellman_sup", "bellman_closed_loop"]
_PUBLISHED_GEO_BELLMAN = "config/published/discrete_geo_bellman.yaml"


rule geo_burns:
    input:
        lib_sources("discrete/geo_burns"),
        published=_PUBLISHED_GEO_BELLMAN,
    params:
        cfg=config["geo_burns"],
        figdir=f"{_DISC}/figures",
    output:
        csv=f"{_DISC}/geo_burns.csv",
        grid=f"{_DISC}/geo_burns_grid.csv",
        sensitivity=f"{_DISC}/geo_burns_mass_flow.csv",
        json=f"{_DISC}/geo_burns.json",
        switching=f"{_DISC}/geo_burns_switching.npz",
        reproduction=f"{_DISC}/geo_burns_reproduction.csv",
        hypotheses=f"{_DISC}/geo_burns_hypotheses.csv",
        figures=expand(f"{_DISC}/figures/geo_orbits_{{s}}.{{ext}}", s=_GEO_SCHEMES, ext=["png", "pdf"])
        + expand(f"{_DISC}/figures/geo_switching_{{s}}.{{ext}}", s=_GEO_SWITCH, ext=["png", "pdf"]),
    log:
        f"{_DISC}/logs/geo_burns.log",
    benchmark:
        f"{_DISC}/benchmarks/geo_burns.tsv"
    script:
        "../scripts/geo_burns.py"


rule bellman:
    input:
        lib_sources("discrete/bellman"),
        published=_PUBLISHED_GEO_BELLMAN,
    params:
        cfg=config["bellman"],
        figdir=f"{_DISC}/figures",
    output:
        points=f"{_DISC}/bellman_points.csv",
        sup=f"{_DISC}/bellman_sup.csv",
        json=f"{_DISC}/bellman.json",
        arrays=f"{_DISC}/bellman.npz",
        reproduction=f"{_DISC}/bellman_reproduction.csv",
        figures=expand(f"{_DISC}/figures/{{f}}.{{ext}}", f=_BELLMAN_FIGS, ext=["png", "pdf"]),
    log:
        f"{_DISC}/logs/bellman.log",
    benchmark:
        f"{_DISC}/benchmarks/bellman.tsv"
    script:
        "../scripts/bellman.py"


rule reproduction_geo_bellman:
    input:
        geo=rules.geo_burns.output.reproduction,
        bellman=rules.bellman.output.reproduction,
    output:
        f"{_DISC}/reproduction_geo_bellman.csv",
    log:
        f"{_DISC}/logs/reproduction_geo_bellman.log",
    benchmark:
        f"{_DISC}/benchmarks/reproduction_geo_bellman.tsv"
    shell:
        "(head -n 1 {input.geo} && tail -n +2 {input.geo} && tail -n +2 {input.bellman}) > {output} 2> {log}"


ALL_TARGETS += [
    rules.geo_burns.output.csv,
    rules.bellman.output.points,
    *rules.reproduction_geo_bellman.output,
    *[f for f in rules.geo_burns.output.figures if f.endswith(".png")],
    *[f for f in rules.bellman.output.figures if f.endswith(".png")],
]
