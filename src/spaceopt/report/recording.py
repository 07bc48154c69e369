"""Rerun recordings (``.rrd``) of trajectories: a writer for the studies and a reader for tests.

A trajectory recording holds (docs/viewing.md):

- ``trajectory/burn``: the thrust arcs, one 3-D line strip per contiguous burn (static);
- ``trajectory/coast``: the coast arcs, one line strip per contiguous coast (static);
- ``trajectory/spacecraft``: the spacecraft position at every sample, on the timeline ``time``;
- ``series/<name>``: one scalar time series per entry of ``series`` (mass, thrust, switching
  function S, ...), on the timeline ``time``.

The timeline ``time`` is a duration in seconds since departure (``t - t[0]``); positions are in
the unit the caller passes (the studies pass kilometres and say so in ``units``). Everything is
sent column-wise (``send_columns``), so a recording of a 500-revolution transfer is written in one
call per entity and carries no wall-clock timestamps.

Reading back uses the rerun SDK's chunk reader (``rerun.chunk.RrdReader``, rerun-sdk 0.41).
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from ..errors import ArtifactError, ConfigError

TIMELINE = "time"
BURN_COLOR = (220, 40, 40)
COAST_COLOR = (140, 140, 140)


def _arcs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Index ranges [start, stop) of the contiguous runs of True in ``mask``.

    Each arc is extended by one sample into the following arc so that burn and coast strips
    join without a gap in the viewer.
    """
    mask = np.asarray(mask, dtype=bool)
    if mask.size == 0:
        return []
    edges = np.flatnonzero(np.diff(mask.astype(np.int8))) + 1
    starts = np.r_[0, edges]
    stops = np.r_[edges, mask.size]
    return [(int(a), int(min(b + 1, mask.size))) for a, b in zip(starts, stops) if mask[a]]


def write_trajectory_recording(path, t, r, burn_mask, series: dict | None = None, *,
                               application_id: str = "spaceopt", recording_id: str | None = None,
                               units: str = "km") -> Path:
    """Write a trajectory recording to ``path`` (``.rrd``).

    ``t``: times, s, shape (n,), increasing; ``r``: inertial positions, shape (n, 3);
    ``burn_mask``: True where the engine is on, shape (n,); ``series``: name -> array (n,), e.g.
    ``{"mass_kg": m, "thrust_N": T, "switching_S": S}``. ``recording_id`` defaults to the file
    stem, so that the same trajectory always gets the same id.
    """
    import rerun as rr

    t = np.asarray(t, dtype=np.float64)
    r = np.asarray(r, dtype=np.float64)
    burn = np.asarray(burn_mask, dtype=bool)
    n = t.shape[0]
    if t.ndim != 1 or n < 2:
        raise ConfigError("recording.t", t.shape, "expected a 1-D array of at least 2 times")
    if r.shape != (n, 3):
        raise ConfigError("recording.r", r.shape, f"expected shape ({n}, 3)")
    if burn.shape != (n,):
        raise ConfigError("recording.burn_mask", burn.shape, f"expected shape ({n},)")
    if np.any(np.diff(t) < 0):
        raise ConfigError("recording.t", "not sorted", "times must be non-decreasing")
    series = {k: np.asarray(v, dtype=np.float64) for k, v in (series or {}).items()}
    for k, v in series.items():
        if v.shape != (n,):
            raise ConfigError(f"recording.series.{k}", v.shape, f"expected shape ({n},)")

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    rec = rr.RecordingStream(application_id, recording_id=recording_id or path.stem)
    rec.save(str(tmp))
    rec.log("trajectory", rr.TextDocument(f"positions in {units}; timeline '{TIMELINE}' in s since departure"),
            static=True)
    burn_strips = [r[a:b] for a, b in _arcs(burn)]
    coast_strips = [r[a:b] for a, b in _arcs(~burn)]
    rec.log("trajectory/burn", rr.LineStrips3D(burn_strips, colors=BURN_COLOR, radii=rr.Radius.ui_points(2.0)),
            static=True)
    rec.log("trajectory/coast", rr.LineStrips3D(coast_strips, colors=COAST_COLOR, radii=rr.Radius.ui_points(1.0)),
            static=True)
    times = rr.TimeColumn(TIMELINE, duration=t - t[0])
    rec.send_columns("trajectory/spacecraft", indexes=[times],
                     columns=rr.Points3D.columns(positions=r))
    for name, values in series.items():
        rec.send_columns(f"series/{name}", indexes=[times], columns=rr.Scalars.columns(scalars=values))
    rec.flush()
    rec.disconnect()
    tmp.replace(path)
    return path


def read_recording(path) -> dict:
    """Read a recording back: ``{entity_path: {"static": bool, "times": array | None, <component>: list}}``.

    Component columns are named like ``"LineStrips3D:strips"`` or ``"Scalars:scalars"``; their
    values are Python lists (one element per row). ``times`` holds the ``time`` timeline in
    seconds. Several chunks of one entity are concatenated in time order. Raises ArtifactError for
    a missing, truncated (no footer) or unreadable file.
    """
    from rerun.chunk import RrdReader

    path = Path(path)
    if not path.exists():
        raise ArtifactError(f"artifact={str(path)!r}: missing")
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            reader = RrdReader(path)
        if any("no footer" in str(w.message) for w in caught):
            # write_trajectory_recording always ends the file with a footer (rerun >= 0.41):
            # without it the file was cut short, possibly at a frame boundary.
            raise ArtifactError(f"artifact={str(path)!r}: truncated rerun recording (no footer)")
        chunks = list(reader.stream())
    except ArtifactError:
        raise
    except Exception as exc:  # the bindings raise plain exceptions for corrupted files
        raise ArtifactError(f"artifact={str(path)!r}: unreadable rerun recording ({type(exc).__name__}: "
                            f"{str(exc).splitlines()[0] if str(exc) else ''})") from None
    out: dict[str, dict] = {}
    for ch in chunks:
        entity = ch.entity_path.lstrip("/")
        if entity.startswith("__"):
            continue
        rb = ch.to_record_batch()
        names = rb.schema.names
        e = out.setdefault(entity, {"static": ch.is_static, "times": None})
        if TIMELINE in names:
            col = rb.column(names.index(TIMELINE)).cast("int64").to_numpy(zero_copy_only=False)
            t = col.astype(np.float64) * 1e-9
            e["times"] = t if e["times"] is None else np.r_[e["times"], t]
        for i, name in enumerate(names):
            if ":" not in name or name.startswith("rerun."):
                continue
            e.setdefault(name, []).extend(rb.column(i).to_pylist())
    for e in out.values():
        if e["times"] is not None and len(e["times"]) > 1:
            order = np.argsort(e["times"], kind="stable")
            if np.any(order != np.arange(order.size)):
                e["times"] = e["times"][order]
                for k, v in e.items():
                    if k not in ("static", "times") and len(v) == order.size:
                        e[k] = [v[j] for j in order]
    return out


def scalar_series(recording: dict, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(times, values) of ``series/<name>`` from :func:`read_recording`'s result."""
    e = recording.get(f"series/{name}")
    if e is None:
        raise ArtifactError(f"recording: no series {name!r}")
    values = np.array([v[0] if isinstance(v, list) else v for v in e["Scalars:scalars"]], dtype=np.float64)
    return e["times"], values
