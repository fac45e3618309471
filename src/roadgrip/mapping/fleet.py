"""Fleet maps: many drives estimated in parallel on Dask, their cells merged into one map.

Each drive is read, run through an estimator (default the cascade) and turned into
cell observations (:func:`roadgrip.mapping.observations_from_estimates`, with the
grip-used check); its map is a sparse table of cell sums. The maps of all drives are
combined by :func:`merge_parts`, an associative and commutative reduction of
precision-weighted sums (counts add exactly), so the fleet map does not depend on the
order of the drives nor on how Dask partitions them, up to floating-point rounding.

Cells: H3 hexagons (:mod:`roadgrip.mapping.hexgrid`) where the drives have GNSS
positions (``lat``, ``lon``), square cells of the drives' shared local ``x, y`` frame
otherwise. A fleet mixing both is refused, naming a drive of each kind.

Age decay
---------
Friction changes with the weather, so old observations count less: an observation made
at time ``t`` [s] enters with weight ``exp(-(t_ref - t) / tau)`` relative to the newest
observation of the map at ``t_ref``, with the time constant ``tau`` in seconds
(:attr:`FleetConfig.tau`, default 86,400 s = one day: a day-old observation counts
``e^-1 = 0.37``, a week-old one ``e^-7 = 0.1 %``; ``inf`` keeps all at full weight).
Times are absolute: a drive's ``t`` plus its start time, which is
``meta.extra['start_time']`` [s, Unix] when the drive has one, 0 when its ``t`` is
already Unix time (above 1e8 s), and otherwise the modification time of its file.

Parallelism: a ``dask.distributed`` cluster, a ``LocalCluster`` of processes by default
(one thread each: the estimators are compiled, single-threaded numerical code) or an
existing scheduler by address. ``dask`` is imported only when a fleet runs.

A drive the reader or the estimator refuses (a ``ValueError``: a truncated file, a
missing channel) does not stop the fleet: it adds nothing to the map, and its row in
:attr:`FleetPart.drives` says why (``refused``; empty for a drive that was mapped). A
fleet in which every drive is refused is refused, with the first reason. Any other
exception is a fault of roadgrip and stops the fleet.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pandas as pd

from roadgrip.mapping.estimates import observations_from_estimates
from roadgrip.mapping.grid import FrictionGrid, empty_grid, fuse, merge
from roadgrip.mapping.hexgrid import HexGrid, empty_hexgrid, fuse_hex, merge_hex

__all__ = ["FleetConfig", "FleetPart", "drive_part", "fleet_map", "merge_parts", "sequential_fleet_map",
           "square_map"]

_UNIX_TIME = 1e8  # a drive whose t starts above this [s] is taken to carry Unix time


@dataclass(frozen=True)
class FleetConfig:
    """How a fleet map is built.

    Attributes
    ----------
    method : str
        Estimator (:func:`roadgrip.estimators.get`).
    options : dict
        Its options (``Config.from_options``).
    cell : float
        Square cell size [m] (drives without GNSS).
    h3_resolution : int
        H3 resolution of hexagon cells (drives with GNSS), 0-15 (13: 4.1 m edges).
    tau : float
        Age-decay time constant [s] (module docstring); ``inf``: no decay.
    prior_mean, prior_std : float
        Prior friction of an unobserved cell [-].
    cells : {'auto', 'square', 'h3'}
        ``'auto'``: H3 where a drive has ``lat, lon``, square otherwise.
    seed : int
        Estimator seed.
    origin : (float, float), optional
        ``(lat, lon)`` [deg] of the local frame of square cells for drives with GNSS: their
        observations are placed by GNSS in that frame and the map is written in WGS84
        (:mod:`roadgrip.mapping.geo`); without it square cells use the drives' pose ``x, y``.
    vehicle : str, optional
        Vehicle preset or YAML file of drive files that carry none (:func:`roadgrip.io.read_drive`).
    """

    method: str = "cascade"
    options: dict[str, Any] = field(default_factory=dict)
    cell: float = 0.5
    h3_resolution: int = 13
    tau: float = 86_400.0
    prior_mean: float = 0.7
    prior_std: float = 0.4
    cells: str = "auto"
    seed: int = 0
    origin: tuple[float, float] | None = None
    vehicle: str | None = None

    def __post_init__(self) -> None:
        if self.origin is not None and not (len(self.origin) == 2 and abs(self.origin[0]) <= 90
                                            and abs(self.origin[1]) <= 180):
            raise ValueError(f"origin must be (lat, lon) within +-90, +-180 deg, got {self.origin!r}")
        if not (np.isfinite(self.cell) and self.cell > 0):
            raise ValueError(f"cell size must be positive and finite [m], got {self.cell!r}")
        if not (isinstance(self.h3_resolution, int) and 0 <= self.h3_resolution <= 15):
            raise ValueError(f"h3_resolution must be an integer 0-15, got {self.h3_resolution!r}")
        if not self.tau > 0:
            raise ValueError(f"age-decay time constant tau must be positive [s] (inf: none), got {self.tau!r}")
        if self.cells not in ("auto", "square", "h3"):
            raise ValueError(f"cells must be 'auto', 'square' or 'h3', got {self.cells!r}")


class FleetPart(NamedTuple):
    """A map of one or more drives and what went into it.

    Attributes
    ----------
    map : FrictionGrid or HexGrid or None
        None when every drive of the part was refused.
    drives : DataFrame
        One row per drive: ``source, samples, observations, start_time`` (s), ``seconds``
        (estimation and fusion time [s]), ``cells`` (square or h3), ``refused`` (why the
        drive adds nothing to the map; empty when it was mapped).
    """

    map: FrictionGrid | HexGrid | None
    drives: pd.DataFrame


def _start_time(drive, source: Any) -> float:
    extra = drive.meta.extra or {}
    if isinstance(extra.get("start_time"), int | float) and np.isfinite(extra["start_time"]):
        return float(extra["start_time"])
    if drive.n and float(drive.t[0]) > _UNIX_TIME:
        return 0.0
    if isinstance(source, str | os.PathLike) and Path(source).exists():
        return float(Path(source).stat().st_mtime)
    return 0.0


def drive_part(source: Any, config: FleetConfig, start_time: float | None = None) -> FleetPart:
    """Map of one drive: read (a path) or taken as is (a :class:`~roadgrip.drive.Drive`), estimated, fused.

    ``start_time`` [s] overrides the drive's start time (module docstring).
    """
    from roadgrip.estimators import run_estimator

    t0 = time.perf_counter()
    name = _source_name(source)
    if isinstance(source, str | os.PathLike):
        from roadgrip.io import read_drive

        drive = read_drive(source, vehicle=config.vehicle)
    else:
        drive = source
    start = _start_time(drive, source) if start_time is None else float(start_time)
    try:
        table = run_estimator(config.method, drive, dict(config.options), seed=config.seed).table
    except Exception as exc:  # a fleet of thousands: say which drive
        raise ValueError(f"{name}: {config.method} failed: {exc}") from exc
    geo = drive.has("lat", "lon") and bool(np.isfinite(drive.col("lat")).any())
    kind = "h3" if (config.cells == "h3" or (config.cells == "auto" and geo)) else "square"
    if not {"x", "y"} <= set(table.columns) and drive.has("x", "y"):
        table = table.assign(x=drive.col("x"), y=drive.col("y"))
    if kind == "h3":
        from roadgrip.mapping.geo import geo_observations

        if not geo:
            raise ValueError(f"{name}: H3 cells need GNSS positions (columns lat, lon)")
        # the grip-used check in square cells of the pose frame (a check within the drive)
        obs, lat, lon = geo_observations(table, drive.t, drive.col("lat"), drive.col("lon"), config.cell)
        m = fuse_hex(empty_hexgrid(config.h3_resolution, config.prior_mean, config.prior_std, config.tau),
                     lat, lon, obs.mu, obs.var, t=obs.t + start, sys=obs.sys)
    elif geo and config.origin is not None:
        from roadgrip.mapping.geo import geo_observations, to_local

        obs, lat, lon = geo_observations(table, drive.t, drive.col("lat"), drive.col("lon"), config.cell)
        x, y = to_local(lat, lon, config.origin)
        m = fuse(empty_grid(config.cell, config.prior_mean, config.prior_std, config.tau,
                            origin=tuple(map(float, config.origin))), x, y, obs.mu, obs.var, t=obs.t + start,
                 sys=obs.sys)
    else:
        m = square_map(table, config, start)
    stats = pd.DataFrame({"source": [name], "samples": [drive.n], "observations": [int(m.cells.n_obs.sum())],
                          "start_time": [start], "seconds": [time.perf_counter() - t0], "cells": [kind],
                          "refused": [""]})
    return FleetPart(m, stats)


def _source_name(source: Any) -> str:
    """A drive's name in the fleet's table: its path, or a drive's ``meta.source``."""
    return str(source) if isinstance(source, str | os.PathLike) else str(source.meta.source)


def _part_or_refusal(source: Any, config: FleetConfig, start_time: float | None = None) -> FleetPart:
    """:func:`drive_part`, or for a drive it refuses (``ValueError``) a part without a map
    whose row says why (module docstring)."""
    t0 = time.perf_counter()
    try:
        return drive_part(source, config, start_time)
    except ValueError as exc:
        why = " ".join(str(exc).split()) or type(exc).__name__
        stats = pd.DataFrame({"source": [_source_name(source)], "samples": [0], "observations": [0], "start_time": [np.nan],
                              "seconds": [time.perf_counter() - t0], "cells": [""], "refused": [why]})
        return FleetPart(None, stats)


def square_map(table: pd.DataFrame, config: FleetConfig, start: float = 0.0) -> FrictionGrid:
    """The square-cell map of one drive's estimates in its pose frame, as :func:`drive_part` fuses
    them: :func:`~roadgrip.mapping.estimates.observations_from_estimates` with the grip-used
    check, the fleet's prior and forgetting, observation times shifted by ``start`` [s]."""
    obs = observations_from_estimates(table, config.cell)
    return fuse(empty_grid(config.cell, config.prior_mean, config.prior_std, config.tau),
                obs.x, obs.y, obs.mu, obs.var, t=obs.t + start, sys=obs.sys)


def merge_parts(parts: list[FleetPart] | tuple[FleetPart, ...]) -> FleetPart:
    """Merge fleet parts (associative, commutative; counts add). Refuses square and H3 maps
    together. Parts without a map (refused drives) add their rows only."""
    parts = [p for p in parts if p is not None]
    if not parts:
        raise ValueError("no drives to merge")
    mapped = [p for p in parts if p.map is not None]
    kinds = {type(p.map) for p in mapped}
    if len(kinds) > 1:
        sq = next(p for p in mapped if isinstance(p.map, FrictionGrid)).drives["source"].iloc[0]
        hx = next(p for p in mapped if isinstance(p.map, HexGrid)).drives["source"].iloc[0]
        raise ValueError(f"drives with GNSS (H3 cells, e.g. {hx}) and without (square cells, e.g. {sq}) "
                         "cannot share a map: add lat, lon to every drive or map them apart (cells='square')")
    maps = [p.map for p in mapped]
    merged = None if not maps else merge_hex(*maps) if isinstance(maps[0], HexGrid) else merge(*maps)
    drives = pd.concat([p.drives for p in parts], ignore_index=True)
    return FleetPart(merged, drives)


def _mapped(part: FleetPart) -> FleetPart:
    """The fleet's result, or its refusal when no drive could be mapped."""
    if part.map is None:
        first = part.drives["refused"].iloc[0]
        raise ValueError(f"no drive could be mapped: all {len(part.drives)} were refused; the first, "
                         f"{part.drives['source'].iloc[0]}: {first}")
    return part


def sequential_fleet_map(sources: list[Any], config: FleetConfig | None = None,
                         start_times: dict[int, float] | None = None) -> FleetPart:
    """The fleet map without Dask: each drive in turn, merged in order (the reference of :func:`fleet_map`)."""
    config = config or FleetConfig()
    st = start_times or {}
    return _mapped(merge_parts([_part_or_refusal(s, config, st.get(i)) for i, s in enumerate(sources)]))


def _part_list(items: list[tuple[int, Any]], config: FleetConfig, start_times: dict[int, float]) -> FleetPart:
    parts = [_part_or_refusal(s, config, start_times.get(i)) for i, s in items]
    return merge_parts([p._replace(drives=p.drives.assign(_i=i)) for p, (i, _) in zip(parts, items, strict=True)])


def fleet_map(
    sources: list[Any],
    config: FleetConfig | None = None,
    *,
    scheduler: str | None = None,
    client: Any = None,
    n_workers: int = 2,
    processes: bool = True,
    partitions: int | None = None,
    start_times: dict[int, float] | None = None,
) -> FleetPart:
    """Build the fleet map of ``sources`` (drive paths or drives) on a Dask cluster.

    Parameters
    ----------
    sources : list of path or Drive
    config : FleetConfig, optional
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``); default a new
        ``LocalCluster`` of ``n_workers`` single-threaded workers.
    client : distributed.Client, optional
        Use this client (and its cluster) instead.
    n_workers : int
        Workers of the local cluster.
    processes : bool
        Local workers as processes (``False``: threads of this process).
    partitions : int, optional
        Number of tasks the drives are split into (default one per drive, at most 64 per worker
        thread: a drive takes a tenth of a second or more, against milliseconds of scheduling,
        and small tasks keep the workers evenly loaded to the end); each task merges its
        drives, then the task maps are merged in a tree.
    start_times : dict, optional
        Start time [s] by position in ``sources`` (overrides the drives' own).

    Returns
    -------
    FleetPart
        The merged map and one row per drive (in the order of ``sources``; a refused
        drive's row says why, module docstring).

    Raises
    ------
    ValueError
        No drives, or every drive refused (the first reason named).
    """
    config = config or FleetConfig()
    if not sources:
        raise ValueError("no drives given")
    st = dict(start_times or {})
    items = list(enumerate(sources))
    own = None
    if client is None:
        from distributed import Client, LocalCluster

        if scheduler:
            own = client = Client(scheduler)
        else:
            cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=processes,
                                   dashboard_address=None)
            own = client = Client(cluster)
    try:
        threads = sum(w.get("nthreads", 1) for w in client.scheduler_info()["workers"].values()) or 1
        k = 64 * threads if partitions is None else int(partitions)
        chunks = [c.tolist() for c in np.array_split(np.arange(len(items)), max(1, min(k, len(items))))]
        futures = [client.submit(_part_list, [items[i] for i in c], config, st, pure=False) for c in chunks]
        while len(futures) > 1:  # tree reduction, pairs of partial maps
            futures = [client.submit(merge_parts, futures[i:i + 2], pure=False) if i + 1 < len(futures)
                       else futures[i] for i in range(0, len(futures), 2)]
        part = futures[0].result()
    finally:
        if own is not None:
            cluster = own.cluster if scheduler is None else None
            own.close()
            if cluster is not None:
                cluster.close()
    drives = part.drives.sort_values("_i", kind="stable").drop(columns="_i").reset_index(drop=True)
    return _mapped(FleetPart(part.map, drives))
