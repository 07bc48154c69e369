"""The machine a benchmark ran on: the ``machine`` block of every harness's JSON.

The machines of this workplace run this project's loads at speeds up to 3× apart (the E8 chain
at 500 rev, code of 28 or 30 Nov that runs at one speed side by side: 153.9 s on one machine,
232–326 s alone on another, 480 s on a third; docs/perturbed-e6-e7-e8.md, "fifty-third
session"). A time is therefore compared with another tree's only side by side in one run; a
number from another session's machine says nothing about the code. This block tells the machines apart and flags a slow or busy one:

- ``cpu_model``, ``cpu_count``, ``python``;
- ``load_avg_start`` / ``load_avg_end`` (:func:`finish`): the load average, since wall times on a
  shared machine include waiting for a core;
- ``reference_s``: the least of three timings of a fixed single-threaded pure-Python workload
  (:func:`reference_seconds`). It moves with the core's speed and with time stolen from it, as the
  solver's compiled loops do, but it is an indicator, not a factor to rescale other times by:
  XLA's loops and the interpreter do not slow down alike (the E8 LP → OT path at 500 rev took
  205–299 s in one script over four alternated rounds on one idle machine, and 257–273 s in the
  benchmark's runs between them, whose ``reference_s`` stayed at 0.087–0.090 s;
  docs/perturbed-e6-e7-e8.md, "fifty-fourth session").

Written by hand: the standard library has the parts (``os``, ``platform``) and no package of the
environment records them.
"""
from __future__ import annotations

import os
import platform
import sys
import time

REFERENCE_ITERATIONS = 2_000_000


def cpu_model() -> str:
    """The CPU's model name (/proc/cpuinfo on Linux, else ``platform.processor()``)."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def reference_seconds(rounds: int = 3) -> float:
    """The least wall time of ``rounds`` runs of a fixed loop of float multiply-adds (0.07–0.09 s
    on an idle machine of November 2026, twice that with both cores busy)."""
    best = float("inf")
    for _ in range(rounds):
        t0, x = time.perf_counter(), 0.0
        for i in range(REFERENCE_ITERATIONS):
            x = x * 0.999999 + i
        best = min(best, time.perf_counter() - t0)
    return best


def machine_facts(**extra) -> dict:
    """The ``machine`` block at a benchmark's start; ``extra`` adds the harness's own settings."""
    return {"cpu_model": cpu_model(), "cpu_count": os.cpu_count(), "python": sys.version.split()[0],
            "load_avg_start": os.getloadavg(), "reference_s": reference_seconds(), **extra}


def finish(machine: dict) -> dict:
    """Add the load average at the benchmark's end to ``machine``; returns it."""
    machine["load_avg_end"] = os.getloadavg()
    return machine
