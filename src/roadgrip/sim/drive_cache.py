"""On-disk cache of simulated drives, keyed by a hash of what determines them.

A multi-body drive takes seconds to simulate; tests and benchmarks ask for the
same drives again and again. :func:`cached` stores each drive as Parquet in the
folder named by ``ROADGRIP_DRIVE_CACHE`` under a key that hashes the request
(scenario, engine, vehicle, seed, duration), the source text of the simulator
modules and the version of the vehicle-model package, so that any change to
the code that makes the drives makes new keys. Writes are atomic (a temporary
file renamed into place), so parallel test workers can share the folder.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable
from importlib import metadata
from pathlib import Path
from typing import Any

from roadgrip.drive import Drive

__all__ = ["CACHE_ENV", "cache_key", "cached"]

CACHE_ENV = "ROADGRIP_DRIVE_CACHE"
"""Environment variable naming the cache folder."""

_SOURCES = (
    "sim/multibody.py", "sim/mb_model.py", "sim/mb_driver.py", "sim/mb_scenarios.py", "sim/sensors.py",
    "sim/friction.py", "sim/track.py", "sim/engine.py", "vehicle/slip.py",
)


def cache_key(**request: Any) -> str:
    """Hex digest of the request and of the simulator's source text."""
    h = hashlib.sha256(json.dumps(request, sort_keys=True).encode())
    package = Path(__file__).parents[1]
    for name in _SOURCES:
        h.update((package / name).read_bytes())
    for dist in ("commonroad-vehicle-models", "numpy"):
        try:
            h.update(metadata.version(dist).encode())
        except metadata.PackageNotFoundError:
            h.update(b"-")
    return h.hexdigest()[:32]


def cached(build: Callable[[], Drive], *, enabled: bool | None = None, **request: Any) -> Drive:
    """``build()``, or the stored drive of the same request.

    Parameters
    ----------
    build : callable
        Makes the drive.
    enabled : bool, optional
        Use the cache (default: when ``ROADGRIP_DRIVE_CACHE`` is set). With
        ``True`` and no variable, ``~/.cache/roadgrip/drives`` is used.
    **request
        JSON-serialisable description of the drive.
    """
    folder = os.environ.get(CACHE_ENV)
    if enabled is None:
        enabled = bool(folder)
    if not enabled:
        return build()
    root = Path(folder) if folder else Path.home() / ".cache" / "roadgrip" / "drives"
    path = root / f"{request.get('scenario', 'drive')}-{cache_key(**request)}.parquet"
    if path.is_file():
        from roadgrip.io.canonical import read_canonical_parquet

        try:
            return read_canonical_parquet(path)
        except Exception:  # a damaged entry is rebuilt, never trusted
            path.unlink(missing_ok=True)
    drive = build()
    root.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(f".{os.getpid()}.tmp")
    drive.to_parquet(tmp)
    os.replace(tmp, path)
    return drive
