"""Result artifacts: JSON scalars + NPZ arrays, written atomically, with provenance and checksums.

Every JSON artifact carries a ``provenance`` block (config hash, code version, package versions,
wall time) and, for each companion file, its SHA-256, so that a truncated or corrupted file is
detected on read instead of being used silently (design.md, "Artifacts").

Numbers are written with ``repr`` precision and sorted keys so that two runs of a deterministic
computation give byte-identical JSON apart from the ``provenance.wall_time_s`` and
``provenance.created`` fields, which live in one block that comparisons can drop.
"""
from __future__ import annotations

import hashlib
import json
import os
import subprocess
import tempfile
from importlib import metadata
from pathlib import Path

import numpy as np

from .errors import ArtifactError

PACKAGES = ("spaceopt", "jax", "jaxlib", "diffrax", "numpy", "scipy", "jplephem", "pyerfa",
            "snakemake", "matplotlib", "rerun-sdk")


def config_hash(cfg) -> str:
    """SHA-256 of the canonical JSON form of a config mapping (key order does not matter)."""
    blob = json.dumps(cfg, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(blob.encode()).hexdigest()


def _git(*args: str) -> str:
    root = Path(__file__).resolve().parents[2]
    try:
        return subprocess.run(["git", *args], cwd=root, capture_output=True, text=True,
                              timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""


def _read_code_version() -> dict:
    commit = _git("rev-parse", "HEAD") or "unknown"
    dirty = bool(_git("status", "--porcelain", "--untracked-files=no", "--", "src"))
    return {"commit": commit, "dirty": dirty}


# Read once, when the package is imported (spaceopt/__init__ imports this module), not when an
# artifact is written: a solve that runs for hours while commits land records the code it loaded
# (E8 450, sixteenth session: a 107-minute job had saved the commit made 80 minutes after it began).
_LOADED_CODE = _read_code_version()


def code_version() -> dict:
    """Git commit of the source tree this process loaded, and whether src/ differed from it then."""
    return dict(_LOADED_CODE)


def package_versions() -> dict:
    out = {}
    for name in PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    return out


def provenance(cfg, wall_time_s: float | None = None, **extra) -> dict:
    return {"config_hash": config_hash(cfg), "code": code_version(),
            "packages": package_versions(), "wall_time_s": wall_time_s, **extra}


def sha256_file(path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _atomic_write(path: Path, write) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            write(fh)
        os.chmod(tmp, 0o644)          # mkstemp creates 0600
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _to_jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _to_jsonable(obj.tolist())
    if isinstance(obj, (np.floating,)):
        return float(obj)
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    if hasattr(obj, "shape") and getattr(obj, "shape", None) == ():   # jax scalars
        return float(obj)
    return obj


def write_json(path, payload: dict, companions: dict | None = None) -> None:
    """Write ``payload`` atomically; ``companions`` maps a role to a file whose hash is recorded."""
    payload = dict(payload)
    if companions:
        payload["files"] = {role: {"path": Path(p).name, "sha256": sha256_file(p)}
                            for role, p in companions.items()}
    text = json.dumps(_to_jsonable(payload), indent=1, sort_keys=True, allow_nan=True) + "\n"
    _atomic_write(Path(path), lambda fh: fh.write(text.encode()))


FAILURE_SUFFIXES = (".failure.json", ".chain_failure.json")


def failure_path(out, suffix: str = ".failure.json") -> Path:
    """The diagnosis file next to artifact ``out``: <stem><suffix>."""
    out = Path(out)
    return out.with_name(out.stem + suffix)


def write_failure(path, exc, cfg, wall_time_s: float | None = None) -> None:
    """The diagnosis of a computation that did not converge (``exc``: a ConvergenceError)."""
    write_json(path, {"error": str(exc), "diagnosis": exc.diagnosis, "provenance": provenance(cfg, wall_time_s)})


def clear_failures(out) -> None:
    """Remove the diagnoses an earlier run left next to ``out`` (called when a run starts, so that
    a date that converges now does not keep the failure record of an earlier attempt)."""
    for suffix in FAILURE_SUFFIXES:
        failure_path(out, suffix).unlink(missing_ok=True)


def write_npz(path, **arrays) -> None:
    _atomic_write(Path(path), lambda fh: np.savez(fh, **{k: np.asarray(v) for k, v in arrays.items()}))


def read_json(path) -> dict:
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise ArtifactError(f"artifact={str(path)!r}: missing") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ArtifactError(f"artifact={str(path)!r}: corrupted or truncated JSON ({exc.msg if hasattr(exc, 'msg') else exc})") from None
    for role, info in data.get("files", {}).items():
        comp = path.parent / info["path"]
        if not comp.exists():
            raise ArtifactError(f"artifact={str(comp)!r}: missing {role} companion of {path.name}")
        if sha256_file(comp) != info["sha256"]:
            raise ArtifactError(f"artifact={str(comp)!r}: checksum mismatch (corrupted or truncated)")
    return data


def read_npz(json_path, role: str = "trajectory") -> dict:
    """Read the NPZ companion of a JSON artifact after verifying its checksum."""
    data = read_json(json_path)
    comp = Path(json_path).parent / data["files"][role]["path"]
    with np.load(comp) as npz:
        return {k: npz[k] for k in npz.files}
