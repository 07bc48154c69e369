"""Glue for workflow scripts: one-line errors, never a traceback (design.md, "Errors").

A SpaceoptError (bad input, no convergence) is one line on the console and in the rule's log.
Anything else is a bug: its traceback goes to the rule's log (where ``sys.stderr`` points while
the script runs; after the script's ``with`` block closes the log it would be lost), and the
console gets one line that says where to look.
"""
import os
import sys
import traceback

from spaceopt.errors import SpaceoptError
from spaceopt.config import THREADS_ENV


def run_step(main, *args, **kwargs):
    """``main(*args, **kwargs)`` with errors as above. Where the first argument is the Snakemake
    job, its ``threads`` become the threads a Jacobian's columns are split over (SPACEOPT_THREADS,
    :mod:`spaceopt.indirect.column_threads`)."""
    if args and hasattr(args[0], "threads"):
        os.environ[THREADS_ENV] = str(args[0].threads)
    try:
        return main(*args, **kwargs)
    except SpaceoptError as exc:
        for stream in {sys.stderr, sys.__stderr__}:
            print(f"error: {exc}", file=stream, flush=True)
        sys.exit(1)
    except Exception as exc:                      # noqa: BLE001 — a bug: keep its traceback in the log
        traceback.print_exc(file=sys.stderr)
        sys.stderr.flush()
        print(f"error: internal error {type(exc).__name__}: {exc} (traceback in the rule's log)",
              file=sys.__stderr__, flush=True)
        sys.exit(1)
