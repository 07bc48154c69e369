# Ephemeris prep: DE405 Chebyshev windows of the geocentric Moon and Sun, one artifact per named
# window of config/studies/ephemeris.yaml (results/ephemeris/<window>.{npz,json}). The perturbed
# solves read them with spaceopt.ephemeris.load_ephemeris; the physics is in spaceopt.ephemeris.
validate(config["ephemeris"], "../../config/schema/ephemeris.schema.yaml")

EPH_DIR = f"{RESULTS}/ephemeris"
EPH_WINDOWS = sorted(config["ephemeris"]["windows"])


rule ephemeris_prep:
    input:
        lib_sources("ephemeris"),
    params:
        window=lambda wc: {"name": wc.window, **config["ephemeris"]["windows"][wc.window]},
    output:
        json=f"{EPH_DIR}/{{window}}.json",
        npz=f"{EPH_DIR}/{{window}}.npz",
    wildcard_constraints:
        window="|".join(EPH_WINDOWS),
    log:
        f"{EPH_DIR}/logs/{{window}}.log",
    benchmark:
        f"{EPH_DIR}/benchmarks/{{window}}.tsv"
    script:
        "../scripts/ephemeris_prep.py"


ALL_TARGETS += expand(f"{EPH_DIR}/{{window}}.{{ext}}", window=EPH_WINDOWS, ext=["json", "npz"])
