"""Ephemeris prep step: cut one DE405 window (Moon, Sun - EMB) and write NPZ + JSON.

Snakemake script: params.window = {name, start, end[, studies]} (UTC dates); output.json and
output.npz (the NPZ path must be the JSON path with suffix .npz). Physics in spaceopt.ephemeris.
"""
import sys
import time
from contextlib import redirect_stderr
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from _step import run_step  # noqa: E402

from spaceopt import ephemeris  # noqa: E402
from spaceopt.errors import ConfigError  # noqa: E402


def main(sm):
    t0 = time.time()
    w = dict(sm.params.window)
    if Path(sm.output.npz) != Path(sm.output.json).with_suffix(".npz"):
        raise ConfigError("output.npz", sm.output.npz, "must be output.json with suffix .npz")
    print(f"ephemeris {w['name']}: DE405 {w['start']} .. {w['end']} (UTC)", file=sys.stderr)
    window = ephemeris.extract_window(w["start"], w["end"], w["name"])
    window["meta"]["studies"] = list(w.get("studies", []))
    ephemeris.save_window(window, sm.output.json, w, wall_time_s=time.time() - t0)
    n = window["meta"]["n_granules"]
    print(f"ephemeris {w['name']}: {n['moon']} Moon + {n['sun_emb']} Sun-EMB granules, "
          f"coverage {window['meta']['coverage']['start_label']} .. "
          f"{window['meta']['coverage']['end_label']}", file=sys.stderr)


if __name__ == "__main__":
    Path(snakemake.log[0]).parent.mkdir(parents=True, exist_ok=True)  # noqa: F821
    with open(snakemake.log[0], "w") as _log, redirect_stderr(_log):  # noqa: F821
        run_step(main, snakemake)  # noqa: F821
