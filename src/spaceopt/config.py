"""Config loading and validation with one-line errors (design.md "Errors").

Each study section is validated against ``config/schema/<study>.schema.yaml`` with
``snakemake.utils.validate``; on failure, jsonschema's best match names the exact key path and
the offending value. Physical checks (eccentricity < 1, positive thrust, dates inside the
ephemeris, …) are done by the study modules and raise :class:`~spaceopt.errors.ConfigError`.

One setting comes from the environment: ``SPACEOPT_THREADS``, the threads a Jacobian's columns
are split over (:mod:`spaceopt.indirect.column_threads`). It is read here, without JAX, so that
the workflow's glue (``workflow/scripts/_step.py``) can set it cheaply.
"""
from __future__ import annotations

import os
from datetime import date, datetime
from pathlib import Path

import yaml

from .errors import ConfigError


def load_yaml(path) -> dict:
    """Parse a YAML file; malformed YAML is a one-line ConfigError naming the file and line."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ConfigError(str(path), f"<yaml{where}>", f"malformed YAML: {problem}") from None
    except OSError as exc:
        raise ConfigError(str(path), None, f"cannot read config file ({exc.strerror})") from None
    if data is not None and not isinstance(data, dict):
        raise ConfigError(str(path), type(data).__name__, "a config file must hold a mapping")
    return data or {}


def validate_section(config: dict, name: str, schema_path) -> None:
    """Validate ``config[name]`` against the JSON schema at ``schema_path`` (absolute path)."""
    import jsonschema
    from snakemake.utils import validate

    if name not in config or config[name] is None:
        raise ConfigError(name, None, "missing config section")
    try:
        validate(config[name], str(schema_path))
    except Exception as exc:  # snakemake wraps jsonschema errors in a multi-line WorkflowError
        schema = load_yaml(schema_path)
        errors = jsonschema.Draft202012Validator(schema).iter_errors(config[name])
        err = jsonschema.exceptions.best_match(errors)
        if err is None:
            raise ConfigError(name, "?", str(exc).strip().splitlines()[0]) from None
        key = ".".join([name] + [str(p) for p in err.absolute_path])
        message = err.message.split("\n")[0]
        if isinstance(err.instance, (date, datetime)):   # YAML reads an unquoted 2021-05-20 as a date
            message += f' (quote it: "{err.instance.isoformat()}")'
        raise ConfigError(key, err.instance, message) from None


THREADS_ENV = "SPACEOPT_THREADS"


def threads() -> int:
    """The number of threads a Jacobian's columns are split over (``SPACEOPT_THREADS``, ≥ 1)."""
    raw = os.environ.get(THREADS_ENV, "1")
    try:
        k = int(raw)
    except ValueError:
        k = 0
    if k < 1:
        raise ConfigError(THREADS_ENV, raw, "expected a positive integer (threads per Jacobian)")
    return k
