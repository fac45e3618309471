"""GNSS positions for maps, and map files in GeoJSON / GeoParquet (WGS84).

Frames
------
A drive with the optional columns ``lat``, ``lon`` (WGS84 degrees) places its
observations by GNSS: the friction observation of an axle at time ``t`` lies at the
CG's GNSS position at ``t`` plus the axle's offset from the CG, taken from the pose
(``x_<axle> - x``, ``y_<axle> - y``, so the pose's ``x, y`` must point east and north,
in metres, with any origin). Square grids are then built in a local metric frame: the
azimuthal equidistant projection about an origin ``(lat0, lon0)`` (pyproj, WGS84
ellipsoid; distances from the origin exact, a 0.5 m cell 10 km away distorted by less
than 1e-6). The grid keeps its origin (:attr:`FrictionGrid.origin`) and its cells are
written in WGS84. H3 maps (:mod:`roadgrip.mapping.hexgrid`) need no local frame.

Files
-----
:func:`write_map` writes one polygon per observed cell with ``mu_mean``, ``mu_std``
(posterior mean and standard deviation [-]), ``n_obs`` and the cell's id
(``ix, iy`` or ``h3``): GeoJSON for ``.geojson`` / ``.json``, GeoParquet for
``.parquet`` / ``.geoparquet``. A grid without an origin is in a local frame: its
polygons are in metres and the file has no CRS. geopandas, shapely and pyproj are
imported only here, when a file is written or a frame converted.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from roadgrip.mapping.estimates import observations_from_estimates
from roadgrip.mapping.grid import FrictionGrid, Observations, empty_grid, fuse
from roadgrip.mapping.hexgrid import HexGrid

__all__ = ["from_local", "geo_observations", "grid_from_estimates_geo", "map_frame", "to_local", "write_map"]


def _transformer(origin: tuple[float, float], inverse: bool):
    from pyproj import Transformer

    lat0, lon0 = origin
    local = f"+proj=aeqd +lat_0={lat0:.12f} +lon_0={lon0:.12f} +datum=WGS84 +units=m +no_defs"
    return Transformer.from_crs(local, "EPSG:4326", always_xy=True) if inverse else (
        Transformer.from_crs("EPSG:4326", local, always_xy=True))


def to_local(lat: ArrayLike, lon: ArrayLike, origin: tuple[float, float]) -> tuple[NDArray, NDArray]:
    """East, north ``(x, y)`` [m] of ``lat, lon`` [deg] in the local frame about ``origin = (lat0, lon0)``."""
    x, y = _transformer(origin, False).transform(np.asarray(lon, float), np.asarray(lat, float))
    return np.asarray(x, float), np.asarray(y, float)


def from_local(x: ArrayLike, y: ArrayLike, origin: tuple[float, float]) -> tuple[NDArray, NDArray]:
    """Inverse of :func:`to_local`: ``(lat, lon)`` [deg]."""
    lon, lat = _transformer(origin, True).transform(np.asarray(x, float), np.asarray(y, float))
    return np.asarray(lat, float), np.asarray(lon, float)


def geo_observations(table: pd.DataFrame, t: NDArray, lat: NDArray, lon: NDArray,
                     cell: float | None = None) -> tuple[Observations, NDArray, NDArray]:
    """Observations of an estimates table and their GNSS positions.

    Parameters
    ----------
    table : DataFrame
        Estimates (:func:`roadgrip.mapping.observations_from_estimates`), with ``t, x, y``.
    t, lat, lon : ndarray, shape (n,)
        The drive's time [s] and GNSS position [deg] (NaN: no fix).
    cell : float, optional
        Cell size [m] of the grip-used check.

    Returns
    -------
    obs, lat, lon
        The observations (positions still in the pose frame) with a GNSS fix within
        their drive's fixes, and their latitude and longitude [deg].
    """
    fix = np.isfinite(lat) & np.isfinite(lon)
    if fix.sum() < 1:
        raise ValueError("the drive has no GNSS fix (columns lat, lon are all NaN)")
    obs = observations_from_estimates(table, cell)
    tf, la, lo = t[fix], lat[fix], lon[fix]
    inside = (obs.t >= tf[0]) & (obs.t <= tf[-1])
    obs = Observations(*(a[inside] for a in obs))
    origin = (float(la[0]), float(lo[0]))
    ex, ny = to_local(la, lo, origin)
    tt = table["t"].to_numpy(float)
    xc, yc = np.interp(obs.t, tt, table["x"].to_numpy(float)), np.interp(obs.t, tt, table["y"].to_numpy(float))
    e = np.interp(obs.t, tf, ex) + (obs.x - xc)
    n = np.interp(obs.t, tf, ny) + (obs.y - yc)
    olat, olon = from_local(e, n, origin)
    return obs, olat, olon


def grid_from_estimates_geo(table: pd.DataFrame, t: NDArray, lat: NDArray, lon: NDArray, cell: float = 0.5,
                            origin: tuple[float, float] | None = None, **grid_options: Any) -> FrictionGrid:
    """Square grid in the local frame about ``origin`` (default the drive's first fix) from GNSS positions.

    ``grid_options`` go to :func:`roadgrip.mapping.empty_grid`. The grid's
    :attr:`~FrictionGrid.origin` is set, so :func:`write_map` writes it in WGS84.
    """
    obs, olat, olon = geo_observations(table, t, lat, lon, cell)
    if origin is None:
        fix = np.isfinite(lat) & np.isfinite(lon)
        origin = (float(lat[fix][0]), float(lon[fix][0]))
    x, y = to_local(olat, olon, origin)
    g = empty_grid(cell, origin=(float(origin[0]), float(origin[1])), **grid_options)
    return fuse(g, x, y, obs.mu, obs.var, t=obs.t, sys=obs.sys)


def map_frame(grid: FrictionGrid | HexGrid, min_obs: int = 1):
    """A GeoDataFrame of the observed cells: polygon, ``mu_mean, mu_std, n_obs`` and the cell id.

    WGS84 (EPSG:4326) for an H3 map or a grid with an origin; no CRS (metres in the
    grid's local frame) otherwise.
    """
    import geopandas as gpd
    import shapely

    if isinstance(grid, HexGrid):
        from h3.api import basic_int as h3i

        frame = grid.cells_frame(min_obs)
        keys = [h3i.str_to_int(h) for h in frame["h3"]]
        rings = [[(lo, la) for la, lo in h3i.cell_to_boundary(k)] for k in keys]
        geom = [shapely.Polygon(r) for r in rings]
        return gpd.GeoDataFrame(frame, geometry=geom, crs="EPSG:4326")
    frame = grid.cells_frame(min_obs)
    c = grid.cell
    ix = np.floor(frame["x"].to_numpy() / c).astype(np.int64)
    iy = np.floor(frame["y"].to_numpy() / c).astype(np.int64)
    x0, y0 = ix * c, iy * c
    xs = np.stack([x0, x0 + c, x0 + c, x0, x0], axis=1)
    ys = np.stack([y0, y0, y0 + c, y0 + c, y0], axis=1)
    crs = None
    if grid.origin is not None:
        lat, lon = from_local(xs.ravel(), ys.ravel(), grid.origin)
        xs, ys = lon.reshape(xs.shape), lat.reshape(ys.shape)
        clat, clon = from_local(frame["x"].to_numpy(), frame["y"].to_numpy(), grid.origin)
        frame = frame.assign(lat=clat, lon=clon)
        crs = "EPSG:4326"
    geom = shapely.polygons(np.stack([xs, ys], axis=2))
    frame = frame.assign(ix=ix, iy=iy)
    return gpd.GeoDataFrame(frame, geometry=geom, crs=crs)


def write_map(grid: FrictionGrid | HexGrid, path: str | Path, min_obs: int = 1) -> Path:
    """Write the observed cells as GeoJSON (``.geojson``, ``.json``) or GeoParquet (``.parquet``, ``.geoparquet``).

    Raises
    ------
    ValueError
        Another suffix, named.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".geojson", ".json", ".parquet", ".geoparquet"):
        raise ValueError(f"{path.name}: a map file is .geojson / .json (GeoJSON) or .parquet / .geoparquet "
                         "(GeoParquet)")
    frame = map_frame(grid, min_obs)
    if suffix in (".geojson", ".json"):
        import warnings

        with warnings.catch_warnings():  # a local frame has no CRS: said in the module docstring
            warnings.filterwarnings("ignore", message=".*crs.*was not provided", category=UserWarning)
            frame.to_file(path, driver="GeoJSON")
    else:
        frame.to_parquet(path)
    return path
