"""Command ``roadgrip fleet``: one friction map of many drives, estimated in parallel on Dask (:mod:`roadgrip.mapping.fleet`)."""

from __future__ import annotations

import glob
import math
import time
from pathlib import Path
from typing import Annotated, Any

import typer

from roadgrip.cli._common import VehicleOpt, app, console

_MAP_SUFFIXES = (".parquet", ".geoparquet", ".geojson", ".json", ".npz")


def expand_drives(patterns: list[str]) -> list[str]:
    """Files and glob patterns to a sorted list of drive paths; a pattern matching nothing is refused by name."""
    out: list[str] = []
    for p in patterns:
        if any(ch in p for ch in "*?["):
            hits = sorted(glob.glob(p, recursive=True))
            if not hits:
                raise ValueError(f"no drive matches {p!r}")
            out.extend(hits)
        elif Path(p).exists():
            out.append(p)
        else:
            raise ValueError(f"no such drive: {p}")
    seen: set[str] = set()
    return [p for p in out if not (p in seen or seen.add(p))]


def _check(output: Path, html: Path | None, png: Path | None, cell: float, tau_hours: float, workers: int) -> None:
    """Every option checked before any work starts, with the accepted range."""
    if output.suffix.lower() not in _MAP_SUFFIXES:
        raise ValueError(f"--output {output.name}: a fleet map is {', '.join(_MAP_SUFFIXES)}")
    for opt, path, suffixes in (("--output", output, _MAP_SUFFIXES), ("--html", html, (".html",)),
                                ("--png", png, (".png", ".pdf", ".svg"))):
        if path is None:
            continue
        if path.suffix.lower() not in suffixes:
            raise ValueError(f"{opt} {path.name}: expected {' / '.join(suffixes)}")
        if not path.resolve().parent.is_dir():
            raise ValueError(f"{opt} {path}: folder {path.resolve().parent} does not exist")
    if not (math.isfinite(cell) and 0.01 <= cell <= 1000):
        raise ValueError(f"--cell must be within [0.01, 1000] m, got {cell}")
    if not (tau_hours > 0):
        raise ValueError(f"--decay-hours must be > 0 (inf: no decay), got {tau_hours}")
    if not 1 <= workers <= 256:
        raise ValueError(f"--workers must be within [1, 256], got {workers}")


def _origin(text: str | None) -> tuple[float, float] | None:
    """``'LAT,LON'`` to a tuple, refused in one line otherwise."""
    if text is None:
        return None
    try:
        lat, lon = (float(v) for v in text.split(","))
    except ValueError:
        raise ValueError(f"--origin must be LAT,LON in degrees, got {text!r}") from None
    if not (abs(lat) <= 90 and abs(lon) <= 180):
        raise ValueError(f"--origin must be within +-90 deg latitude and +-180 deg longitude, got {text!r}")
    return lat, lon


def write_fleet_outputs(part: Any, output: Path, html: Path | None = None, png: Path | None = None) -> None:
    """The fleet map as GeoParquet / GeoJSON (or NPZ for square cells), and optionally its page and PNG."""
    from roadgrip.mapping import FrictionGrid

    grid = part.map
    if output.suffix.lower() == ".npz":
        if not isinstance(grid, FrictionGrid):
            raise ValueError(f"--output {output.name}: an H3 map is written as .parquet or .geojson")
        grid.to_npz(output)
    else:
        from roadgrip.mapping.geo import write_map

        write_map(grid, output)
    if png is not None:
        from roadgrip.plots.maps import plot_grid

        plot_grid(grid, png)
    if html is not None:
        from roadgrip.plots.maps_web import write_map_page

        write_map_page(grid, html, png=png, title=f"fleet friction map: {len(part.drives)} drives")


@app.command("fleet")
def fleet_cmd(
    drives: Annotated[list[str], typer.Argument(metavar="DRIVES_OR_GLOB...", help="Drive files or glob patterns.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="fleet_map.parquet (GeoParquet), .geojson or .npz.")],
    scheduler: Annotated[str | None, typer.Option(help="Address of a running Dask scheduler "
                                                       "(default: a local cluster).")] = None,
    workers: Annotated[int, typer.Option(help="Workers of the local cluster.")] = 2,
    method: Annotated[str, typer.Option(help="Estimator of each drive.")] = "cascade",
    cell: Annotated[float, typer.Option(help="Square cell size [m] (drives without lat/lon).")] = 0.5,
    h3_resolution: Annotated[int, typer.Option(min=0, max=15, help="H3 resolution of hexagon cells "
                                                                  "(drives with lat/lon; 13: 4 m edges).")] = 13,
    decay_hours: Annotated[float, typer.Option(help="Age-decay time constant [h]: an observation this much "
                                                    "older than the newest counts exp(-1).")] = 24.0,
    cells: Annotated[str, typer.Option(help="auto (H3 where drives have lat/lon), square or h3.")] = "auto",
    origin: Annotated[str | None, typer.Option(help="LAT,LON [deg]: square cells of drives with lat/lon in "
                                                    "the local frame about it, written in WGS84.")] = None,
    vehicle: VehicleOpt = None,
    html: Annotated[Path | None, typer.Option(help="Also write the interactive map page.")] = None,
    png: Annotated[Path | None, typer.Option(help="Also write a PNG heat map.")] = None,
) -> None:
    """Estimate many drives in parallel on Dask and merge them into one friction map."""
    from roadgrip.cli.options import check_vehicle
    from roadgrip.estimators import get
    from roadgrip.mapping.fleet import FleetConfig, fleet_map

    _check(output, html, png, cell, decay_hours, workers)
    check_vehicle(vehicle)  # refused before the cluster starts, as an unknown method is
    get(method)  # an unknown method is refused before the cluster starts
    config = FleetConfig(method=method, cell=cell, h3_resolution=h3_resolution, tau=decay_hours * 3600.0,
                         cells=cells, origin=_origin(origin), vehicle=vehicle)
    paths = expand_drives(drives)
    t0 = time.perf_counter()
    part = fleet_map(paths, config, scheduler=scheduler, n_workers=workers)
    wall = time.perf_counter() - t0
    write_fleet_outputs(part, output, html, png)
    d = part.drives
    n_obs = int(d["observations"].sum())
    refused = d[d["refused"] != ""]
    kind = d.loc[d["refused"] == "", "cells"].iloc[0]
    console.print(f"{len(d)} drives, {int(d['samples'].sum())} samples, {n_obs} observations in "
                  f"{part.map.n_cells} cells ({kind}) in {wall:.1f} s: "
                  f"{60 * len(d) / wall:.1f} drives/min, {n_obs / wall:.0f} observations/s")
    if len(refused):
        console.print(f"{len(refused)} of {len(d)} drives refused, not in the map:", markup=False, soft_wrap=True)
        for src, why in zip(refused["source"], refused["refused"], strict=True):
            console.print(f"  {src}: {why}", markup=False, soft_wrap=True)  # a path whole, to copy
    console.print(f"wrote {output}" + (f", {html}" if html else "") + (f", {png}" if png else ""))
