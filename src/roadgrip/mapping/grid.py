"""The friction grid: a sparse table of observed cells, fusion, merging, posterior and files.

The model is described in :mod:`roadgrip.mapping`. A grid stores only the cells that
hold observations (:class:`roadgrip.mapping.cells.CellSums`, 48 bytes a cell), so its
memory follows the observed cells, not the bounding box of the observations. The dense
views (``s0 ... n_obs``, :meth:`FrictionGrid.posterior`, :meth:`FrictionGrid.centres`)
lay the cells out over their bounding box for figures and compact maps; they refuse a box
of more than :data:`MAX_CELLS` cells, with the memory it would need.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from roadgrip.mapping.cells import (
    MAX_INDEX,
    CellMap,
    CellSums,
    add_cells,
    birge_ratio,
    cells_from_squares,
    empty_cells,
    lookup,
    scale_cells,
    square_index,
    square_keys,
    square_neighbours,
)

__all__ = ["MAX_CELLS", "MAX_COORD", "MAX_MU", "MIN_VAR", "FrictionGrid", "Observations", "empty_grid", "fuse", "merge"]

MAX_CELLS = 10_000_000
"""Largest dense view [cells] (:attr:`FrictionGrid.s0` and the like over the bounding box of
the observed cells): 400 MB for its five arrays. The sparse grid itself has no such limit."""

MAX_COORD = 1.0e8
"""Largest position magnitude [m] in a map frame (a local frame: 100,000 km)."""

MIN_VAR = 1e-8
"""Smallest observation variance [-] (standard deviation 1e-4): smaller ones are raised to it,
so that the precision-weighted sums stay finite."""

MAX_MU = 100.0
"""Largest friction magnitude [-] an observation may carry."""

_DENSE_BYTES_PER_CELL = 40
_FORMAT = "roadgrip-friction-grid-2"


class Observations(NamedTuple):
    """Position-stamped friction observations, all shape (n,).

    Attributes
    ----------
    x, y : ndarray
        Position [m] in the map frame.
    mu : ndarray
        Friction [-].
    var : ndarray
        Variance of ``mu`` [-], > 0.
    t : ndarray
        Time [s] (used by forgetting).
    sys : ndarray
        Systematic error [-] (0 where the estimator does not report one).
    """

    x: NDArray[np.float64]
    y: NDArray[np.float64]
    mu: NDArray[np.float64]
    var: NDArray[np.float64]
    t: NDArray[np.float64]
    sys: NDArray[np.float64]


class _Dense(NamedTuple):
    ix0: int
    iy0: int
    s0: NDArray[np.float64]
    s1: NDArray[np.float64]
    s2: NDArray[np.float64]
    sb: NDArray[np.float64]
    n_obs: NDArray[np.int64]


@dataclass(frozen=True)
class FrictionGrid(CellMap):
    """A sparse friction grid (immutable; :func:`fuse` and :func:`merge` return new grids).

    Attributes
    ----------
    cell : float
        Cell size [m]; cell ``(i, j)`` covers ``[i cell, (i+1) cell) x [j cell, (j+1) cell)``.
    cells : CellSums
        The observed cells' sums, keyed by :func:`roadgrip.mapping.cells.square_keys`.
    prior_mean, prior_std : float
        Prior friction of an unvisited cell [-].
    tau : float
        Forgetting time constant [s] (``inf``: no forgetting).
    t_ref : float
        Reference time of the sums [s] (latest observation; ``-inf`` when empty).
    overdispersion : bool
        Inflate cell variances by the Birge ratio (module docstring).
    path : ndarray, shape (k, 2)
        Decimated driven path for plots (rows of NaN separate drives).
    origin : tuple of float or None
        ``(lat, lon)`` [deg, WGS84] of the local east-north frame the positions are in, when the
        grid was built from GNSS positions (:mod:`roadgrip.mapping.geo`); ``None``: a local frame.
    """

    cell: float
    cells: CellSums = field(default_factory=empty_cells)
    prior_mean: float = 0.7
    prior_std: float = 0.4
    tau: float = float("inf")
    t_ref: float = float("-inf")
    overdispersion: bool = True
    path: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    origin: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if not (np.isfinite(self.cell) and self.cell > 0):
            raise ValueError(f"cell size must be positive and finite, got {self.cell!r}")
        self._check_prior()
        c = self.cells
        if not isinstance(c, CellSums) or len({a.shape for a in c}) != 1 or c.key.ndim != 1:
            raise ValueError("grid cells must be a CellSums table of one length")
        if c.size and not np.all(np.diff(c.key) > 0):
            raise ValueError("grid cell keys must be sorted and unique")
        ix, iy = square_index(c.key)
        if c.size and max(np.abs(ix).max(), np.abs(iy).max()) * self.cell > MAX_COORD + self.cell:
            raise ValueError(f"grid cells lie beyond +-{MAX_COORD:g} m of the map origin")

    # -- the sparse table (n_cells, nbytes, cell_posterior: CellMap) ------------------
    def cell_index(self) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """Global indices ``(ix, iy)`` of the observed cells, each shape ``(k,)``."""
        return square_index(self.cells.key)

    def neighbour_keys(self) -> NDArray[np.int64]:
        """Keys of the eight cells around each observed cell, shape ``(k, 8)``."""
        return square_neighbours(self.cells.key)

    def cell_centres(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Centres ``(x, y)`` [m] of the observed cells, each shape ``(k,)``."""
        ix, iy = self.cell_index()
        return (ix + 0.5) * self.cell, (iy + 0.5) * self.cell

    # -- dense views over the bounding box of the observed cells ----------------------
    @cached_property
    def _dense(self) -> _Dense:
        c = self.cells
        if c.size == 0:
            z = np.zeros((0, 0))
            return _Dense(0, 0, z, z, z, z, np.zeros((0, 0), np.int64))
        ix, iy = square_index(c.key)
        x0, y0 = int(ix.min()), int(iy.min())
        nx, ny = int(ix.max()) - x0 + 1, int(iy.max()) - y0 + 1
        _check_size(nx, ny, self.cell, f" to lay out the observed cells over x {x0 * self.cell:.6g} to "
                    f"{(x0 + nx) * self.cell:.6g} m, y {y0 * self.cell:.6g} to {(y0 + ny) * self.cell:.6g} m")
        out = []
        for a in (c.s0, c.s1, c.s2, c.sb, c.n_obs):
            d = np.zeros((ny, nx), a.dtype)
            d[iy - y0, ix - x0] = a
            out.append(d)
        return _Dense(x0, y0, *out)

    @property
    def ix0(self) -> int:
        """Global index of the first column of the dense view."""
        return self._dense.ix0

    @property
    def iy0(self) -> int:
        """Global index of the first row of the dense view."""
        return self._dense.iy0

    @property
    def s0(self) -> NDArray[np.float64]:
        """Dense ``sum w``, shape ``(ny, nx)``."""
        return self._dense.s0

    @property
    def s1(self) -> NDArray[np.float64]:
        """Dense ``sum w mu``, shape ``(ny, nx)``."""
        return self._dense.s1

    @property
    def s2(self) -> NDArray[np.float64]:
        """Dense ``sum w mu²``, shape ``(ny, nx)``."""
        return self._dense.s2

    @property
    def sb(self) -> NDArray[np.float64]:
        """Dense ``sum w b``, shape ``(ny, nx)``."""
        return self._dense.sb

    @property
    def n_obs(self) -> NDArray[np.int64]:
        """Dense observation counts, shape ``(ny, nx)``."""
        return self._dense.n_obs

    @property
    def shape(self) -> tuple[int, int]:
        """``(ny, nx)`` of the dense view."""
        return self._dense.s0.shape  # type: ignore[return-value]

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """``(xmin, xmax, ymin, ymax)`` of the dense view [m]."""
        ny, nx = self.shape
        c = self.cell
        return (self.ix0 * c, (self.ix0 + nx) * c, self.iy0 * c, (self.iy0 + ny) * c)

    def centres(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Cell-centre coordinates ``X, Y`` [m] of the dense view, each shape ``(ny, nx)``."""
        ny, nx = self.shape
        xs = (self.ix0 + np.arange(nx) + 0.5) * self.cell
        ys = (self.iy0 + np.arange(ny) + 0.5) * self.cell
        return np.meshgrid(xs, ys)

    def _spread(self, values: NDArray[np.float64], fill: float) -> NDArray[np.float64]:
        out = np.full(self.shape, fill)
        if self.cells.size:
            ix, iy = self.cell_index()
            out[iy - self.iy0, ix - self.ix0] = values
        return out

    def birge_ratio(self) -> NDArray[np.float64]:
        """Dense per-cell ``max(1, chi² / (n - 1))`` (1 where fewer than two observations)."""
        return self._spread(birge_ratio(self.cells), 1.0)

    def posterior(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Dense per-cell posterior mean and standard deviation [-], shape ``(ny, nx)`` (prior where unvisited)."""
        mean, std = self.cell_posterior()
        return self._spread(mean, self.prior_mean), self._spread(std, self.prior_std)

    def query(self, x: ArrayLike, y: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Friction mean and standard deviation [-] at positions ``(x, y)`` [m].

        Positions in cells without observations return the prior (``prior_mean``, ``prior_std``).

        Examples
        --------
        >>> g = fuse(empty_grid(1.0), [0.5, 0.5], [0.5, 0.5], [0.6, 0.6], [0.01, 0.01])
        >>> m, s = g.query([0.2, 10.0], [0.7, 10.0])
        >>> [round(float(v), 3) for v in m], round(float(s[1]), 3)
        ([0.603, 0.7], 0.4)
        """
        x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        out_m = np.full(x.shape, self.prior_mean)
        out_s = np.full(x.shape, self.prior_std)
        with np.errstate(invalid="ignore", over="ignore"):
            fx, fy = np.floor(x / self.cell), np.floor(y / self.cell)
        ok = np.isfinite(fx) & np.isfinite(fy) & (np.abs(fx) <= MAX_INDEX) & (np.abs(fy) <= MAX_INDEX)
        if ok.any() and self.cells.size:
            row = lookup(self.cells, square_keys(fx[ok].astype(np.int64), fy[ok].astype(np.int64)))
            mean, std = self.cell_posterior()
            hit = np.flatnonzero(ok)[row >= 0]
            out_m.flat[hit] = mean[row[row >= 0]]
            out_s.flat[hit] = std[row[row >= 0]]
        return out_m, out_s

    # -- files -----------------------------------------------------------------------
    def cells_frame(self, min_obs: int = 1) -> pd.DataFrame:
        """Cells with at least ``min_obs`` observations: ``x, y, mu_mean, mu_std, n_obs`` (row, then column order)."""
        x, y = self.cell_centres()
        mean, std = self.cell_posterior()
        sel = self.cells.n_obs >= max(min_obs, 1)
        return pd.DataFrame({"x": x[sel], "y": y[sel], "mu_mean": mean[sel], "mu_std": std[sel],
                             "n_obs": self.cells.n_obs[sel]})

    def to_csv(self, path: str | Path) -> None:
        """Visited cells as CSV with columns ``x, y`` (cell centre, m), ``mu_mean, mu_std, n_obs``."""
        self.cells_frame().to_csv(path, index=False, float_format="%.6g")

    def to_npz(self, path: str | Path) -> None:
        """Lossless NPZ (cell keys, sums, counts, size, prior, forgetting, path, origin)."""
        c = self.cells
        origin = np.array(self.origin if self.origin is not None else (np.nan, np.nan), float)
        np.savez_compressed(
            path, cell=self.cell, key=c.key, s0=c.s0, s1=c.s1, s2=c.s2, sb=c.sb, n_obs=c.n_obs,
            prior_mean=self.prior_mean, prior_std=self.prior_std, tau=self.tau, t_ref=self.t_ref,
            overdispersion=self.overdispersion, path=self.path, origin=origin, format=_FORMAT,
        )

    @classmethod
    def from_npz(cls, path: str | Path) -> FrictionGrid:
        """Read :meth:`to_npz` output (also the earlier dense format); a one-line error naming the file otherwise."""
        import zipfile
        import zlib

        name = Path(path).name
        try:
            with np.load(path, allow_pickle=False) as z:
                fmt = str(z["format"]) if hasattr(z, "files") and "format" in z.files else ""
                if fmt not in (_FORMAT, "roadgrip-friction-grid-1"):
                    raise ValueError(f"{name} is not a roadgrip friction grid (.npz from `roadgrip map`)")
                return _from_arrays(z, fmt)
        except FileNotFoundError:
            raise ValueError(f"map file not found: {path}") from None
        except IsADirectoryError:
            raise ValueError(f"map file {path} is a folder") from None
        except (zipfile.BadZipFile, EOFError, zlib.error, KeyError, OSError, TypeError,
                ValueError) as exc:
            if str(exc).startswith(name):
                raise
            why = ("a damaged or truncated archive" if isinstance(exc, zipfile.BadZipFile | EOFError | zlib.error)
                   else "not an .npz archive of arrays" if isinstance(exc, ValueError | OSError)
                   else f"a grid array is missing or malformed ({type(exc).__name__})")
            raise ValueError(f"{name} is not a readable roadgrip friction grid (.npz from "
                             f"`roadgrip map`): {why}") from None


def _from_arrays(z, fmt: str) -> FrictionGrid:
    """A grid from the arrays of an NPZ file of format ``fmt``."""
    sums = [np.asarray(z[k], dtype=float).ravel() for k in ("s0", "s1", "s2", "sb")]
    n = np.asarray(z["n_obs"]).astype(np.int64).ravel()
    if fmt == _FORMAT:
        key = np.asarray(z["key"]).astype(np.int64).ravel()
        origin = np.asarray(z["origin"], float).ravel()
    else:  # dense window of format 1
        shape = np.shape(z["n_obs"])
        iy, ix = np.nonzero(np.asarray(z["n_obs"]).reshape(shape) > 0)
        sel = np.ravel_multi_index((iy, ix), shape) if len(shape) == 2 else np.zeros(0, int)
        key = square_keys(ix + int(z["ix0"]), iy + int(z["iy0"]))
        sums, n = [a[sel] for a in sums], n[sel]
        origin = np.array([np.nan, np.nan])
    if not all(a.shape == key.shape for a in (*sums, n)):
        raise ValueError("not an .npz archive of arrays: the grid arrays differ in length")
    return FrictionGrid(
        float(z["cell"]), CellSums(key, *sums, n), float(z["prior_mean"]), float(z["prior_std"]),
        float(z["tau"]), float(z["t_ref"]), bool(z["overdispersion"]),
        np.asarray(z["path"], dtype=float).reshape(-1, 2),
        (float(origin[0]), float(origin[1])) if origin.size == 2 and np.all(np.isfinite(origin)) else None,
    )


def _check_size(nx: int, ny: int, cell: float, spread: str = "") -> None:
    """Refuse a dense view of more than :data:`MAX_CELLS` cells, with the memory it would need."""
    n = int(nx) * int(ny)
    if n > MAX_CELLS:
        gib = n * _DENSE_BYTES_PER_CELL / 2**30
        raise ValueError(
            f"the map would need {nx} x {ny} = {n:.3g} cells of {cell:g} m ({gib:.3g} GiB){spread}; "
            f"the limit of a dense view is {MAX_CELLS:.3g} cells: use the sparse cells "
            "(cells_frame, cell_posterior, query) or larger cells"
        )


def empty_grid(
    cell: float = 0.5,
    prior_mean: float = 0.7,
    prior_std: float = 0.4,
    tau: float = float("inf"),
    overdispersion: bool = True,
    origin: tuple[float, float] | None = None,
) -> FrictionGrid:
    """A grid with no cells yet.

    Parameters
    ----------
    cell : float
        Cell size [m].
    prior_mean, prior_std : float
        Friction prior of unvisited cells [-].
    tau : float
        Forgetting time constant [s]; ``inf`` keeps every observation at full weight.
    overdispersion : bool
        Inflate cell variances by the Birge ratio.
    origin : (float, float), optional
        ``(lat, lon)`` [deg] of the local east-north frame of the positions (GNSS maps).
    """
    return FrictionGrid(float(cell), empty_cells(), float(prior_mean), float(prior_std), float(tau),
                        float("-inf"), bool(overdispersion), origin=origin)


def _decay(g: FrictionGrid, t_new: float) -> FrictionGrid:
    """Move the reference time to ``t_new``, scaling the sums when the grid forgets."""
    if not t_new > g.t_ref:
        return g
    if np.isfinite(g.tau) and np.isfinite(g.t_ref):
        return dataclasses.replace(g, cells=scale_cells(g.cells, np.exp(-(t_new - g.t_ref) / g.tau)), t_ref=t_new)
    return dataclasses.replace(g, t_ref=t_new)


def _join_paths(paths: list[NDArray[np.float64]]) -> NDArray[np.float64]:
    out = np.zeros((0, 2))
    for p in paths:
        if p.size:
            out = p if out.size == 0 else np.vstack([out, [[np.nan, np.nan]], p])
    return out


def _check_observations(x, y, mu, var, b, cell: float) -> None:
    """Refuse the first unusable observation, naming it and its values."""
    far = ~(np.abs(x) <= MAX_COORD) | ~(np.abs(y) <= MAX_COORD)
    if far.any():
        i = int(np.flatnonzero(far)[0])
        raise ValueError(f"observation {i} is not usable: at x = {x[i]:.6g}, y = {y[i]:.6g} m; positions must be "
                         f"finite and within +-{MAX_COORD:g} m of the map origin")
    bad = ~(np.isfinite(mu) & np.isfinite(var) & (var > 0) & (np.abs(mu) <= MAX_MU))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"observation {i} is not usable: positions, mu and var must be finite, var > 0, "
                         f"|mu| <= {MAX_MU:g} (mu = {mu[i]:.6g}, var = {var[i]:.6g})")
    far = (np.abs(np.floor(x / cell)) > MAX_INDEX) | (np.abs(np.floor(y / cell)) > MAX_INDEX)
    if far.any():
        i = int(np.flatnonzero(far)[0])
        raise ValueError(f"observation {i} is not usable: at x = {x[i]:.6g}, y = {y[i]:.6g} m it lies more than "
                         f"{MAX_INDEX} cells of {cell:g} m from the map origin: use larger cells")
    if b.size != x.size or not np.all(np.isfinite(b)) or np.any(b < 0):
        raise ValueError("systematic errors sys must be finite, >= 0 and as many as the observations")


def fuse(
    grid: FrictionGrid,
    x: ArrayLike,
    y: ArrayLike,
    mu: ArrayLike,
    var: ArrayLike,
    t: ArrayLike | None = None,
    path: ArrayLike | None = None,
    sys: ArrayLike | None = None,
) -> FrictionGrid:
    """Fuse observations into a grid (returns a new grid).

    Parameters
    ----------
    grid : FrictionGrid
    x, y : array_like, shape (n,)
        Positions [m].
    mu : array_like, shape (n,)
        Friction observations [-].
    var : array_like, shape (n,)
        Their variances [-], positive (raised to :data:`MIN_VAR`).
    t : array_like, shape (n,), optional
        Observation times [s]; required when the grid forgets (finite ``tau``).
    path : array_like, shape (k, 2), optional
        Driven path to keep for plots.
    sys : array_like, shape (n,), optional
        Systematic error of each observation [-] (>= 0; default 0).

    Raises
    ------
    ValueError
        Non-finite values, non-positive variances, mismatched lengths, positions beyond
        :data:`MAX_COORD` (naming the first such observation).

    Notes
    -----
    The observations are summed per cell (:func:`roadgrip.mapping.cells.cells_from_squares`:
    a compiled pass over a temporary window of at most ``8 n`` cells, else a sort by key), then
    added to the grid's table: memory and time follow the observations and the observed cells.
    """
    x, y, mu, var = (np.asarray(a, dtype=float).ravel() for a in (x, y, mu, var))
    n = x.size
    if not (y.size == mu.size == var.size == n):
        raise ValueError(f"x, y, mu, var must have one length, got {x.size}, {y.size}, {mu.size}, {var.size}")
    if t is not None:
        t = np.asarray(t, dtype=float).ravel()
        if t.size != n or not np.all(np.isfinite(t)):
            raise ValueError("observation times t must be finite and as many as the observations")
    if np.isfinite(grid.tau) and t is None:
        raise ValueError("a forgetting grid needs observation times t")
    new_path = grid.path if path is None else _join_paths([grid.path, np.asarray(path, dtype=float).reshape(-1, 2)])
    if n == 0:
        return dataclasses.replace(grid, path=new_path)
    b = np.zeros(n) if sys is None else np.asarray(sys, dtype=float).ravel()
    _check_observations(x, y, mu, var, b, grid.cell)
    w = 1.0 / np.maximum(var, MIN_VAR)
    g = grid
    if t is not None:
        g = _decay(grid, float(t.max()))
        if np.isfinite(g.tau):
            w = w * np.exp(-(g.t_ref - t) / g.tau)
    new = cells_from_squares(np.floor(x / g.cell).astype(np.int64), np.floor(y / g.cell).astype(np.int64), w, mu, b)
    return dataclasses.replace(g, cells=add_cells(g.cells, new), path=new_path)


def merge(*grids: FrictionGrid) -> FrictionGrid:
    """Merge grids of several drives: sums add, nothing is lost.

    All grids must share cell size, prior, forgetting constant, the overdispersion setting
    and the frame origin. With forgetting, every grid is first brought to the latest
    reference time. ``merge(merge(a, b), c) == merge(a, merge(b, c)) == merge(c, b, a)``
    up to floating-point rounding, and the counts add exactly. Memory follows the
    observed cells.
    """
    if not grids:
        raise ValueError("merge needs at least one grid")
    first = grids[0]
    for g in grids[1:]:
        for attr in ("cell", "prior_mean", "prior_std", "tau", "overdispersion", "origin"):
            if getattr(g, attr) != getattr(first, attr):
                raise ValueError(f"cannot merge grids with different {attr}: "
                                 f"{getattr(first, attr)!r} and {getattr(g, attr)!r}")
    t_ref = max(g.t_ref for g in grids)
    grids = tuple(_decay(g, t_ref) for g in grids)
    cells = add_cells(*(g.cells for g in grids))
    return dataclasses.replace(first, cells=cells, t_ref=t_ref, path=_join_paths([g.path for g in grids]))

