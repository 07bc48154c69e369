# The reproduction DAG (design.md): ephemeris prep -> minimum-power solves -> minimum-thrust
# existence checks -> minimum-fuel continuation -> lunar junction -> libration runs ->
# discrete comparisons -> tables, figures, report, paper.
#
# Config: config/config.yaml (global) plus one file per study in config/studies/.
# A quick profile for CI and tests: --configfile config/quick.yaml (overrides).
from pathlib import Path
from snakemake.utils import min_version, validate

min_version("9.0")

_CONFIG_FILES = ["config/config.yaml", *map(str, sorted(Path("config/studies").glob("*.yaml")))]
# Malformed YAML in a project config file: one line naming the file and line, no traceback.
import sys as _sys
from spaceopt.config import load_yaml as _load_yaml
from spaceopt.errors import ConfigError as _ConfigError
for _f in _CONFIG_FILES:
    try:
        _load_yaml(_f)
    except _ConfigError as _exc:
        print(f"error: {_exc}", file=_sys.stderr)
        _sys.exit(1)

for _f in _CONFIG_FILES:
    configfile: _f

validate(config, "config/schema/config.schema.yaml")

include: "workflow/rules/common.smk"
for _rules in sorted(Path("workflow/rules").glob("*.smk")):
    if _rules.name != "common.smk":
        include: str(_rules)


rule all:
    default_target: True
    input:
        ALL_TARGETS,
