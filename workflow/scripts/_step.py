"""Glue for workflow scripts: one-line errors, never a traceback (design.md, "Errors")."""
import sys

from spaceopt.errors import SpaceoptError


def run_step(main, *args, **kwargs):
    try:
        return main(*args, **kwargs)
    except SpaceoptError as exc:
        for stream in {sys.stderr, sys.__stderr__}:
            print(f"error: {exc}", file=stream, flush=True)
        sys.exit(1)
