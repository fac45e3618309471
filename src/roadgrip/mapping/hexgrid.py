"""Friction map on H3 hexagons: the sparse cell sums of :mod:`roadgrip.mapping`, keyed by H3 index.

For drives with GNSS positions (``lat``, ``lon``), a fleet map uses the global H3
grid (Uber's hierarchical hexagons, :func:`h3.latlng_to_cell`) so that maps of any
drives anywhere share cells without agreeing on a local frame. The sums, the posterior,
forgetting and merging are those of the square grid (:mod:`roadgrip.mapping.grid`); only
the cell key differs. ``h3`` is imported when a map is built.

H3 resolutions (mean hexagon edge): 12: 10.8 m, 13: 4.1 m, 14: 1.5 m, 15: 0.58 m.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from roadgrip.mapping.cells import (
    CellMap,
    CellSums,
    add_cells,
    cells_from_observations,
    empty_cells,
    lookup,
    scale_cells,
)
from roadgrip.mapping.grid import MAX_MU, MIN_VAR

__all__ = ["HexGrid", "empty_hexgrid", "fuse_hex", "h3_keys", "merge_hex"]


def h3_keys(lat: ArrayLike, lon: ArrayLike, resolution: int) -> NDArray[np.int64]:
    """H3 cell indices (int64) of positions ``lat, lon`` [deg, WGS84], shape ``(n,)``."""
    from h3.api import basic_int as h3i

    lat = np.asarray(lat, float).ravel()
    lon = np.asarray(lon, float).ravel()
    return np.fromiter((h3i.latlng_to_cell(a, b, resolution) for a, b in zip(lat.tolist(), lon.tolist(), strict=True)),
                       dtype=np.int64, count=lat.size)


@dataclass(frozen=True)
class HexGrid(CellMap):
    """A friction map on H3 hexagons (immutable; :func:`fuse_hex`, :func:`merge_hex` return new maps).

    Attributes
    ----------
    resolution : int
        H3 resolution, 0-15.
    cells : CellSums
        Sums of the observed hexagons, keyed by their H3 index.
    prior_mean, prior_std : float
        Prior friction of an unvisited cell [-].
    tau : float
        Forgetting (age decay) time constant [s] (``inf``: none).
    t_ref : float
        Reference time of the sums [s] (latest observation; ``-inf`` when empty).
    overdispersion : bool
        Inflate cell variances by the Birge ratio.
    """

    resolution: int
    cells: CellSums = field(default_factory=empty_cells)
    prior_mean: float = 0.7
    prior_std: float = 0.4
    tau: float = float("inf")
    t_ref: float = float("-inf")
    overdispersion: bool = True

    def __post_init__(self) -> None:
        if not (isinstance(self.resolution, int | np.integer) and 0 <= self.resolution <= 15):
            raise ValueError(f"H3 resolution must be an integer 0-15, got {self.resolution!r}")
        self._check_prior()

    def neighbour_keys(self) -> NDArray[np.int64]:
        """H3 indices of the six hexagons around each observed cell, shape ``(k, 6)``.

        Around one of H3's twelve pentagons the missing sixth neighbour repeats the cell.
        """
        from h3.api import basic_int as h3i

        out = np.empty((self.cells.size, 6), np.int64)
        for i, k in enumerate(self.cells.key.tolist()):
            ring = [r for r in h3i.grid_disk(k, 1) if r != k][:6]
            out[i] = ring + [k] * (6 - len(ring))
        return out

    def cell_centres(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Centres ``(lat, lon)`` [deg] of the observed cells."""
        from h3.api import basic_int as h3i

        ll = np.array([h3i.cell_to_latlng(int(k)) for k in self.cells.key.tolist()], float).reshape(-1, 2)
        return ll[:, 0], ll[:, 1]

    def cells_frame(self, min_obs: int = 1) -> pd.DataFrame:
        """Cells with at least ``min_obs`` observations: ``h3, lat, lon, mu_mean, mu_std, n_obs``."""
        from h3.api import basic_int as h3i

        lat, lon = self.cell_centres()
        mean, std = self.cell_posterior()
        sel = self.cells.n_obs >= max(min_obs, 1)
        return pd.DataFrame({"h3": [h3i.int_to_str(int(k)) for k in self.cells.key[sel].tolist()],
                             "lat": lat[sel], "lon": lon[sel], "mu_mean": mean[sel], "mu_std": std[sel],
                             "n_obs": self.cells.n_obs[sel]})

    def query(self, lat: ArrayLike, lon: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Friction mean and standard deviation [-] at ``lat, lon`` [deg]; the prior in unobserved cells."""
        lat, lon = np.broadcast_arrays(np.asarray(lat, float), np.asarray(lon, float))
        out_m = np.full(lat.shape, self.prior_mean)
        out_s = np.full(lat.shape, self.prior_std)
        ok = np.isfinite(lat) & np.isfinite(lon) & (np.abs(lat) <= 90) & (np.abs(lon) <= 180)
        if ok.any() and self.cells.size:
            row = lookup(self.cells, h3_keys(lat[ok], lon[ok], self.resolution))
            mean, std = self.cell_posterior()
            hit = np.flatnonzero(ok)[row >= 0]
            out_m.flat[hit] = mean[row[row >= 0]]
            out_s.flat[hit] = std[row[row >= 0]]
        return out_m, out_s


def empty_hexgrid(resolution: int = 13, prior_mean: float = 0.7, prior_std: float = 0.4,
                  tau: float = float("inf"), overdispersion: bool = True) -> HexGrid:
    """A hexagon map with no cells yet (parameters as :class:`HexGrid`)."""
    return HexGrid(int(resolution), empty_cells(), float(prior_mean), float(prior_std), float(tau),
                   float("-inf"), bool(overdispersion))


def _decay(g: HexGrid, t_new: float) -> HexGrid:
    if not t_new > g.t_ref:
        return g
    if np.isfinite(g.tau) and np.isfinite(g.t_ref):
        return dataclasses.replace(g, cells=scale_cells(g.cells, np.exp(-(t_new - g.t_ref) / g.tau)), t_ref=t_new)
    return dataclasses.replace(g, t_ref=t_new)


def fuse_hex(grid: HexGrid, lat: ArrayLike, lon: ArrayLike, mu: ArrayLike, var: ArrayLike,
             t: ArrayLike | None = None, sys: ArrayLike | None = None) -> HexGrid:
    """Fuse observations at ``lat, lon`` [deg] into a hexagon map (as :func:`roadgrip.mapping.fuse`).

    Raises
    ------
    ValueError
        Naming the first unusable observation (position off the globe, non-finite or
        non-positive variance, ``|mu|`` above the limit) or mismatched lengths.
    """
    lat, lon, mu, var = (np.asarray(a, float).ravel() for a in (lat, lon, mu, var))
    n = lat.size
    if not (lon.size == mu.size == var.size == n):
        raise ValueError(f"lat, lon, mu, var must have one length, got {lat.size}, {lon.size}, {mu.size}, {var.size}")
    b = np.zeros(n) if sys is None else np.asarray(sys, float).ravel()
    if t is not None:
        t = np.asarray(t, float).ravel()
        if t.size != n or not np.all(np.isfinite(t)):
            raise ValueError("observation times t must be finite and as many as the observations")
    if np.isfinite(grid.tau) and t is None:
        raise ValueError("a forgetting map needs observation times t")
    if n == 0:
        return grid
    bad = ~((np.abs(lat) <= 90) & (np.abs(lon) <= 180) & np.isfinite(mu) & np.isfinite(var) & (var > 0)
            & (np.abs(mu) <= MAX_MU))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"observation {i} is not usable: lat = {lat[i]:.6g}, lon = {lon[i]:.6g} deg, "
                         f"mu = {mu[i]:.6g}, var = {var[i]:.6g} (lat within +-90, lon within +-180, "
                         f"var > 0, |mu| <= {MAX_MU:g})")
    if b.size != n or not np.all(np.isfinite(b)) or np.any(b < 0):
        raise ValueError("systematic errors sys must be finite, >= 0 and as many as the observations")
    w = 1.0 / np.maximum(var, MIN_VAR)
    g = grid
    if t is not None:
        g = _decay(grid, float(t.max()))
        if np.isfinite(g.tau):
            w = w * np.exp(-(g.t_ref - t) / g.tau)
    new = cells_from_observations(h3_keys(lat, lon, g.resolution), w, mu, b)
    return dataclasses.replace(g, cells=add_cells(g.cells, new))


def merge_hex(*grids: HexGrid) -> HexGrid:
    """Merge hexagon maps: brought to the latest reference time, sums added (as :func:`roadgrip.mapping.merge`)."""
    if not grids:
        raise ValueError("merge needs at least one map")
    first = grids[0]
    for g in grids[1:]:
        for attr in ("resolution", "prior_mean", "prior_std", "tau", "overdispersion"):
            if getattr(g, attr) != getattr(first, attr):
                raise ValueError(f"cannot merge maps with different {attr}: "
                                 f"{getattr(first, attr)!r} and {getattr(g, attr)!r}")
    t_ref = max(g.t_ref for g in grids)
    return dataclasses.replace(first, cells=add_cells(*(_decay(g, t_ref).cells for g in grids)), t_ref=t_ref)
