"""Join published reference values (``config/published/*.yaml``) with reproduced numbers.

A published file holds::

    source: <bibliographic source>
    study: <study name>
    values:
      - {case: e1_tmin_isp1520, quantity: T_min_N, value: 7.85384929, unit: N,
         ref: "§4.1, text", tol: {rel: 1.0e-5}, note: "..."}

``tol`` is ``{rel: x}`` (relative) or ``{abs: x}`` (absolute); ``value`` may be a string for
qualitative claims (then ``ours`` is compared for equality). The output rows are the
reproduction table (design.md, principle 4): value, ours, relative difference, tolerance,
pass/fail and a note.
"""
from __future__ import annotations

import math
from pathlib import Path

import yaml

from ..errors import ConfigError
from .tables import write_csv

COLUMNS = ["study", "case", "quantity", "unit", "published", "ours", "rel_diff", "abs_diff",
           "tolerance", "status", "ref", "note"]


def load_published(path) -> dict:
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ConfigError(str(path), "<yaml>", f"malformed YAML: {str(exc).splitlines()[0]}") from None
    for i, v in enumerate(data.get("values", [])):
        for key in ("case", "quantity", "value", "ref"):
            if key not in v:
                raise ConfigError(f"{path.name}:values[{i}].{key}", None, "missing")
    return data


def published_lookup(path) -> dict:
    """{(case, quantity): entry} of a published file."""
    return {(v["case"], v["quantity"]): v for v in load_published(path)["values"]}


def _row(study, entry, ours, extra_note=""):
    pub = entry["value"]
    tol = entry.get("tol", {})
    row = {"study": study, "case": entry["case"], "quantity": entry["quantity"],
           "unit": entry.get("unit", ""), "published": pub, "ours": ours, "rel_diff": "",
           "abs_diff": "", "tolerance": "", "status": "", "ref": entry["ref"],
           "note": "; ".join(s for s in (entry.get("note", ""), extra_note) if s)}
    if ours is None or (isinstance(ours, float) and math.isnan(ours)):
        row["status"] = "missing"
        return row
    if isinstance(pub, str) or isinstance(ours, str):
        row["status"] = "pass" if str(pub) == str(ours) else "fail"
        row["tolerance"] = "equal"
        return row
    absd = float(ours) - float(pub)
    rel = absd / abs(pub) if pub != 0 else math.inf
    row["abs_diff"], row["rel_diff"] = absd, rel
    if "rel" in tol:
        row["tolerance"] = f"rel {tol['rel']:g}"
        ok = abs(rel) <= tol["rel"]
    elif "abs" in tol:
        row["tolerance"] = f"abs {tol['abs']:g}"
        ok = abs(absd) <= tol["abs"]
    else:
        row["tolerance"] = "report only"
        ok = None
    row["status"] = "info" if ok is None else ("pass" if ok else "fail")
    return row


def compare(published_path, ours: dict, notes: dict | None = None) -> list[dict]:
    """Rows for every published value; ``ours`` maps (case, quantity) to our number."""
    data = load_published(published_path)
    notes = notes or {}
    return [_row(data.get("study", Path(published_path).stem), v, ours.get((v["case"], v["quantity"])),
                 notes.get((v["case"], v["quantity"]), "")) for v in data["values"]]


def write_rows(path, rows: list[dict]) -> None:
    write_csv(path, rows, COLUMNS)
