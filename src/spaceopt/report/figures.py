"""Byte-stable figure output: fixed metadata, no timestamps, Agg backend."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

matplotlib.rcParams["svg.hashsalt"] = "spaceopt"
matplotlib.rcParams["pdf.compression"] = 6
matplotlib.rcParams["pdf.fonttype"] = 42      # embed TrueType, not bitmap Type 3 fonts

_METADATA = {
    ".png": {"Software": None},
    ".pdf": {"Creator": None, "Producer": None, "CreationDate": None},
    ".svg": {"Creator": None, "Date": None},
}


def save_figure(fig, path, formats=(".png", ".pdf")) -> list[Path]:
    """Save ``fig`` as ``path`` with each suffix in ``formats``; returns the written paths."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    out = []
    for suffix in formats:
        target = path.with_suffix(suffix)
        fig.savefig(target, dpi=150, metadata=_METADATA[suffix], bbox_inches="tight")
        out.append(target)
    plt.close(fig)
    return out
