# The reproduction DAG (design.md): ephemeris prep -> minimum-power solves -> minimum-thrust
# existence checks -> minimum-fuel continuation -> lunar junction -> libration runs ->
# discrete comparisons -> tables, figures, report, paper.
#
# Config: config/config.yaml (global) plus one file per study in config/studies/.
# A quick profile for CI and tests: --configfile config/quick.yaml (overrides).
from pathlib import Path
from snakemake.utils import min_version, validate

min_version("9.0")

configfile: "config/config.yaml"
for _study_cfg in sorted(Path("config/studies").glob("*.yaml")):
    configfile: str(_study_cfg)

validate(config, "config/schema/config.schema.yaml")

include: "workflow/rules/common.smk"
for _rules in sorted(Path("workflow/rules").glob("*.smk")):
    if _rules.name != "common.smk":
        include: str(_rules)


rule all:
    default_target: True
    input:
        ALL_TARGETS,
