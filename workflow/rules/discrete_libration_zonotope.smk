# Studies D2 (l1 station keeping, libration_lp) and D4 (time-optimal discrete orbit correction,
# orbit_correction) of spec 05-discrete.md. Parameters reach the scripts through params: (a config
# change reruns only what depends on it); the library modules are inputs (a solver change reruns).
validate(config["libration_lp"], "../../config/schema/libration_lp.schema.yaml")
validate(config["orbit_correction"], "../../config/schema/orbit_correction.schema.yaml")

DLZ = f"{RESULTS}/discrete"
DLZ_PUBLISHED = "config/published/discrete_libration_zonotope.yaml"
DLZ_D2_FIGS = ["uncontrolled", "E0_contour", "E0_surface"] + \
    [f"station_keeping_{c}" for c in config["libration_lp"]["correction"]["criteria"]] + \
    (["l1_vs_l2"] if {"l1", "l2"} <= set(config["libration_lp"]["correction"]["criteria"]) else [])
DLZ_D4_FIGS = [f"zonotopes_{c}" for c in config["orbit_correction"]["controls"]] + ["trajectories"] + \
    (["dt_fit"] if config["orbit_correction"]["dt"] == "infer" else [])


rule libration_lp:
    input:
        lib_sources("discrete/libration_lp"),
        published=DLZ_PUBLISHED,
    output:
        points=f"{DLZ}/libration_points.csv",
        variants=f"{DLZ}/libration_variants.csv",
        corrections=f"{DLZ}/libration_corrections.csv",
        corrections_full=f"{DLZ}/libration_corrections_full.csv",
        l1_vs_l2=f"{DLZ}/libration_l1_vs_l2.csv",
        markdown=f"{DLZ}/libration_lp_tables.md",
        json=f"{DLZ}/libration_lp.json",
        npz=f"{DLZ}/libration_lp.npz",
        figures=[f"{DLZ}/figures/libration_{f}.png" for f in DLZ_D2_FIGS],
    params:
        cfg=config["libration_lp"],
        figdir=f"{DLZ}/figures",
    log:
        f"{DLZ}/logs/libration_lp.log",
    benchmark:
        f"{DLZ}/benchmarks/libration_lp.tsv"
    script:
        "../scripts/libration_lp.py"


rule orbit_correction:
    input:
        lib_sources("discrete/zonotope_control"),
        published=DLZ_PUBLISHED,
    output:
        table=f"{DLZ}/orbit_correction.csv",
        n_min=f"{DLZ}/n_min.csv",
        timing=f"{DLZ}/timing.csv",
        markdown=f"{DLZ}/orbit_correction_tables.md",
        json=f"{DLZ}/orbit_correction.json",
        npz=f"{DLZ}/orbit_correction.npz",
        figures=[f"{DLZ}/figures/orbit_correction_{f}.png" for f in DLZ_D4_FIGS],
    params:
        cfg=config["orbit_correction"],
        figdir=f"{DLZ}/figures",
    log:
        f"{DLZ}/logs/orbit_correction.log",
    benchmark:
        f"{DLZ}/benchmarks/orbit_correction.tsv"
    script:
        "../scripts/orbit_correction.py"


rule reproduction_libration_zonotope:
    input:
        "src/spaceopt/report/compare.py",
        published=DLZ_PUBLISHED,
        d2=f"{DLZ}/libration_lp.json",
        d4=f"{DLZ}/orbit_correction.json",
    output:
        f"{DLZ}/reproduction_libration_zonotope.csv",
    log:
        f"{DLZ}/logs/reproduction_libration_zonotope.log",
    benchmark:
        f"{DLZ}/benchmarks/reproduction_libration_zonotope.tsv"
    script:
        "../scripts/libration_lp.py"


ALL_TARGETS += [
    rules.libration_lp.output.points, rules.libration_lp.output.corrections,
    rules.orbit_correction.output.table, rules.orbit_correction.output.n_min,
    rules.orbit_correction.output.timing,
    f"{DLZ}/reproduction_libration_zonotope.csv",
] + rules.libration_lp.output.figures + rules.orbit_correction.output.figures
