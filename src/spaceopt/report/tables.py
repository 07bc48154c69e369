"""Table output shared by every study: CSV with full float precision (repr), stable columns."""
from __future__ import annotations

import csv
from pathlib import Path

import numpy as np


def read_csv(path) -> list[dict]:
    """Rows (dicts) of a CSV written by :func:`write_csv`: every cell that parses as a number a float."""
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        for k, v in r.items():
            try:
                r[k] = float(v)
            except (TypeError, ValueError):
                pass
    return rows


def write_csv(path, rows, columns) -> None:
    """Write ``rows`` (dicts) with ``columns``; floats as ``repr`` so that a re-read is exact."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=columns, lineterminator="\n", extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: (repr(float(v)) if isinstance(v, (float, np.floating)) else v) for k, v in r.items()})
