"""Sparse cell tables: the precision-weighted sums of the observed cells only.

A :class:`CellSums` table holds one row per cell that has observations, sorted by an
``int64`` cell key, with the sums of :mod:`roadgrip.mapping`
(``s0 = sum w``, ``s1 = sum w mu``, ``s2 = sum w mu²``, ``sb = sum w b``, ``n``).
Its memory is :data:`BYTES_PER_CELL` per observed cell, whatever the extent of the map:
two observations 30 km apart take two rows.

Keys: a square cell ``(ix, iy)`` packs into ``iy * 2**32 + (ix + 2**31)``
(:func:`square_keys`; sorting the keys sorts by row, then column); an H3 hexagon uses its
64-bit index. Adding tables concatenates them and sums the rows of equal keys, so it
is associative and commutative up to floating-point rounding and the counts add exactly.

Examples
--------
>>> a = cells_from_observations(np.array([5, 5, 7]), np.ones(3), np.full(3, 0.5), np.zeros(3))
>>> b = cells_from_observations(np.array([7]), np.array([2.0]), np.array([0.8]), np.zeros(1))
>>> c = add_cells(a, b)
>>> c.key.tolist(), c.n_obs.tolist(), c.s0.tolist()
([5, 7], [2, 2], [2.0, 3.0])
"""

from __future__ import annotations

from functools import cached_property
from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "BYTES_PER_CELL",
    "MAX_INDEX",
    "CellMap",
    "CellSums",
    "add_cells",
    "cell_posterior",
    "cells_from_observations",
    "cells_from_squares",
    "empty_cells",
    "lookup",
    "neighbour_spread",
    "scale_cells",
    "square_index",
    "square_keys",
    "square_neighbours",
]

MAX_INDEX = 2**31 - 1
"""Largest square-cell index magnitude (a position at most this many cells from the origin)."""

_OFFSET = np.int64(2**31)
_LOW = np.int64(2**32 - 1)

BYTES_PER_CELL = 48
"""Memory of one observed cell [bytes]: an int64 key, four float64 sums and an int64 count."""

SPREAD_MIN_OBS = 5
"""Observations a neighbouring cell needs for its mean to count in :func:`neighbour_spread`."""


class CellSums(NamedTuple):
    """Sums of the observed cells, each shape ``(k,)``, sorted by unique ``key``.

    Attributes
    ----------
    key : ndarray of int64
        Cell key (:func:`square_keys` or an H3 index).
    s0, s1, s2, sb : ndarray of float64
        ``sum w``, ``sum w mu``, ``sum w mu²``, ``sum w b`` over the cell's observations
        (``w`` precision [-], ``mu`` friction [-], ``b`` systematic error [-]).
    n_obs : ndarray of int64
        Number of observations in the cell.
    """

    key: NDArray[np.int64]
    s0: NDArray[np.float64]
    s1: NDArray[np.float64]
    s2: NDArray[np.float64]
    sb: NDArray[np.float64]
    n_obs: NDArray[np.int64]

    @property
    def size(self) -> int:
        """Number of observed cells."""
        return int(self.key.size)

    @property
    def nbytes(self) -> int:
        """Memory of the table's arrays [bytes]."""
        return int(sum(a.nbytes for a in self))


def empty_cells() -> CellSums:
    """A table without cells."""
    f = np.zeros(0)
    return CellSums(np.zeros(0, np.int64), f, f.copy(), f.copy(), f.copy(), np.zeros(0, np.int64))


def square_keys(ix: ArrayLike, iy: ArrayLike) -> NDArray[np.int64]:
    """Keys of square cells ``(ix, iy)`` (global integer indices, ``|i| <=`` :data:`MAX_INDEX`).

    Raises
    ------
    ValueError
        An index beyond :data:`MAX_INDEX`, naming the first.
    """
    ix = np.asarray(ix, dtype=np.int64)
    iy = np.asarray(iy, dtype=np.int64)
    far = (np.abs(ix) > MAX_INDEX) | (np.abs(iy) > MAX_INDEX)
    if far.any():
        i = int(np.flatnonzero(far.ravel())[0])
        raise ValueError(f"cell index ({ix.ravel()[i]}, {iy.ravel()[i]}) is more than {MAX_INDEX} cells "
                         "from the map origin")
    return (iy << np.int64(32)) + (ix + _OFFSET)


def square_index(key: ArrayLike) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Inverse of :func:`square_keys`: ``(ix, iy)``."""
    key = np.asarray(key, dtype=np.int64)
    return (key & _LOW) - _OFFSET, key >> np.int64(32)


def square_neighbours(key: ArrayLike) -> NDArray[np.int64]:
    """Keys of the eight cells around each square cell, shape ``(k, 8)``.

    A neighbour beyond :data:`MAX_INDEX` is replaced by the cell itself.
    """
    ix, iy = square_index(np.asarray(key, dtype=np.int64).ravel())
    d = np.array([(dx, dy) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dx or dy], np.int64)
    nx, ny = ix[:, None] + d[:, 0], iy[:, None] + d[:, 1]
    inside = (np.abs(nx) <= MAX_INDEX) & (np.abs(ny) <= MAX_INDEX)
    return square_keys(np.where(inside, nx, ix[:, None]), np.where(inside, ny, iy[:, None]))


def neighbour_spread(c: CellSums, mean: NDArray[np.float64], neighbours: NDArray[np.int64]) -> NDArray[np.float64]:
    """Range of the posterior means over each cell and its observed neighbours [-], shape ``(k,)``.

    Parameters
    ----------
    c : CellSums
    mean : ndarray, shape (k,)
        Posterior means of the rows of ``c``.
    neighbours : ndarray of int64, shape (k, m)
        Keys of the cells around each row (:func:`square_neighbours`, H3 rings); a
        neighbour counts when it holds at least :data:`SPREAD_MIN_OBS` observations.
    """
    if c.size == 0:
        return np.zeros(0)
    row = lookup(c, neighbours)
    ok = row >= 0
    ok[ok] = c.n_obs[row[ok]] >= SPREAD_MIN_OBS
    m = mean[np.where(ok, row, 0)]
    hi = np.maximum(mean, np.where(ok, m, -np.inf).max(axis=1))
    lo = np.minimum(mean, np.where(ok, m, np.inf).min(axis=1))
    return hi - lo


def _reduce(key: NDArray[np.int64], sums: tuple[NDArray[np.float64], ...], n: NDArray[np.int64]) -> CellSums:
    """Sort by key (stable) and add the rows of equal keys."""
    if key.size == 0:
        return empty_cells()
    order = np.argsort(key, kind="stable")
    k = key[order]
    starts = np.flatnonzero(np.concatenate([[True], k[1:] != k[:-1]]))
    out = [np.add.reduceat(a[order], starts) for a in sums]
    return CellSums(k[starts], *out, np.add.reduceat(n[order], starts))


def cells_from_observations(key: ArrayLike, w: ArrayLike, mu: ArrayLike, b: ArrayLike) -> CellSums:
    """Table of observations with cell ``key``, weight ``w`` (precision times decay), ``mu`` and ``b``.

    All arrays shape ``(n,)``; the values are trusted (validated by the caller).
    """
    key = np.asarray(key, dtype=np.int64).ravel()
    w, mu, b = (np.asarray(a, dtype=float).ravel() for a in (w, mu, b))
    wm = w * mu
    return _reduce(key, (w, wm, wm * mu, w * b), np.ones(key.size, np.int64))


_WINDOW_PER_OBS = 8
"""A batch whose cells span at most this many cells per observation (or 65,536) is summed in a
temporary window of its bounding box, which then costs no more than the observations; a
sparser batch is sorted by key."""


def cells_from_squares(ix: NDArray[np.int64], iy: NDArray[np.int64], w: NDArray[np.float64],
                       mu: NDArray[np.float64], b: NDArray[np.float64]) -> CellSums:
    """Table of observations in square cells ``(ix, iy)`` (as :func:`cells_from_observations`).

    A compact batch (a road, a track) is accumulated by a compiled pass over a temporary
    window of its bounding box, bounded by ``8 n`` cells; a scattered one is sorted by key.
    """
    n = ix.size
    if n == 0:
        return empty_cells()
    x0, x1, y0, y1 = int(ix.min()), int(ix.max()), int(iy.min()), int(iy.max())
    nx, ny = x1 - x0 + 1, y1 - y0 + 1
    if nx * ny > max(_WINDOW_PER_OBS * n, 65_536):
        return cells_from_observations(square_keys(ix, iy), w, mu, b)
    square_keys(np.array([x0, x1]), np.array([y0, y1]))  # the range check
    sums = np.zeros((4, ny * nx))
    counts = np.zeros(ny * nx, np.int64)
    _window_sums(ix, iy, np.ascontiguousarray(w, dtype=float), np.ascontiguousarray(mu, dtype=float),
                 np.ascontiguousarray(b, dtype=float), x0, y0, nx, sums, counts)
    idx = np.flatnonzero(counts)  # row-major: sorted by (iy, ix), the key order
    return CellSums(square_keys(idx % nx + x0, idx // nx + y0), sums[0, idx], sums[1, idx], sums[2, idx],
                    sums[3, idx], counts[idx])


@njit(cache=True)
def _window_sums(ix, iy, w, mu, b, x0, y0, nx, sums, counts):  # pragma: no cover - compiled
    """Add ``w, w mu, w mu², w b`` and a count of each observation to its cell of the window."""
    for i in range(ix.shape[0]):
        j = (iy[i] - y0) * nx + (ix[i] - x0)
        wm = w[i] * mu[i]
        sums[0, j] += w[i]
        sums[1, j] += wm
        sums[2, j] += wm * mu[i]
        sums[3, j] += w[i] * b[i]
        counts[j] += 1


def add_cells(*tables: CellSums) -> CellSums:
    """Sum of tables: rows of equal keys add (associative, commutative, counts exact)."""
    tables = tuple(t for t in tables if t.size)
    if not tables:
        return empty_cells()
    if len(tables) == 1:
        return tables[0]
    cat = [np.concatenate([getattr(t, f) for t in tables]) for f in CellSums._fields]
    return _reduce(cat[0], tuple(cat[1:5]), cat[5])


def scale_cells(c: CellSums, factor: float) -> CellSums:
    """Every weighted sum times ``factor`` (forgetting); counts unchanged."""
    return CellSums(c.key, c.s0 * factor, c.s1 * factor, c.s2 * factor, c.sb * factor, c.n_obs)


def lookup(c: CellSums, keys: ArrayLike) -> NDArray[np.int64]:
    """Row of each key in the table, ``-1`` where the cell has no observations."""
    keys = np.asarray(keys, dtype=np.int64)
    if c.size == 0:
        return np.full(keys.shape, -1, np.int64)
    pos = np.minimum(np.searchsorted(c.key, keys), c.size - 1)
    return np.where(c.key[pos] == keys, pos, -1)


def birge_ratio(c: CellSums) -> NDArray[np.float64]:
    """Per-row ``max(1, chi² / (n - 1))`` (1 where fewer than two observations), shape ``(k,)``."""
    out = np.ones(c.size)
    ok = (c.n_obs >= 2) & (c.s0 > 0)
    if ok.any():
        s0, s1, s2 = c.s0[ok], c.s1[ok], c.s2[ok]
        chi2 = np.maximum(s2 - s1 * s1 / s0, 0.0)
        out[ok] = np.maximum(chi2 / (c.n_obs[ok] - 1), 1.0)
    return out


def cell_posterior(c: CellSums, prior_mean: float, prior_std: float,
                   overdispersion: bool = True) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Posterior friction mean and standard deviation [-] of each row from its own sums, shape ``(k,)``.

    The model is in :mod:`roadgrip.mapping` (prior, Birge ratio, systematic part);
    :meth:`CellMap.cell_posterior` adds the spread across the neighbourhood.
    """
    b = birge_ratio(c) if overdispersion else np.ones(c.size)
    p0 = 1.0 / prior_std**2
    prec = p0 + c.s0 / b
    mean = (prior_mean * p0 + c.s1 / b) / prec
    sys = c.sb / b / prec
    return mean, np.sqrt(1.0 / prec + sys * sys)


class CellMap:
    """What the square and the hexagon maps share: their cell table, prior and forgetting.

    A mixin of the frozen dataclasses :class:`~roadgrip.mapping.grid.FrictionGrid` and
    :class:`~roadgrip.mapping.hexgrid.HexGrid`, which hold the attributes below.

    Attributes
    ----------
    cells : CellSums
    prior_mean, prior_std : float
        Prior friction of an unvisited cell [-].
    tau : float
        Forgetting (age decay) time constant [s] (``inf``: none).
    overdispersion : bool
        Inflate cell variances by the Birge ratio.
    """

    cells: CellSums
    prior_mean: float
    prior_std: float
    tau: float
    overdispersion: bool

    def _check_prior(self) -> None:
        if not (np.isfinite(self.prior_std) and self.prior_std > 0 and np.isfinite(self.prior_mean)):
            raise ValueError("prior_mean must be finite and prior_std positive")
        if not self.tau > 0:
            raise ValueError(f"forgetting time constant tau must be positive (inf: none), got {self.tau!r}")

    @property
    def n_cells(self) -> int:
        """Number of observed cells."""
        return self.cells.size

    @property
    def nbytes(self) -> int:
        """Memory of the cell table [bytes] (:data:`BYTES_PER_CELL` a cell)."""
        return self.cells.nbytes

    def neighbour_keys(self) -> NDArray[np.int64]:
        """Keys of the cells adjacent to each observed cell, shape ``(k, m)``."""
        raise NotImplementedError

    def cell_posterior(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Posterior mean and standard deviation [-] of the observed cells, each shape ``(k,)``.

        The standard deviation adds to the cell's own (:func:`cell_posterior`) the sub-cell
        spread ``R / sqrt(12)``, with ``R`` the range of the means over the cell and its
        observed neighbours (:func:`neighbour_spread`; :mod:`roadgrip.mapping`). Computed
        once per map; the arrays are read-only.
        """
        return self._posterior

    @cached_property
    def _posterior(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        mean, std = cell_posterior(self.cells, self.prior_mean, self.prior_std, self.overdispersion)
        if self.cells.size:
            spread = neighbour_spread(self.cells, mean, self.neighbour_keys())
            std = np.sqrt(std * std + spread * spread / 12.0)
        for a in (mean, std):
            a.setflags(write=False)
        return mean, std
