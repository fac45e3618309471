"""The friction grid: cells of precision-weighted sums, fusion, merging, posterior and files.

The model is described in :mod:`roadgrip.mapping`.
"""


from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd
from numba import njit
from numpy.typing import ArrayLike, NDArray

__all__ = ["MAX_CELLS", "MAX_COORD", "MAX_MU", "MIN_VAR", "FrictionGrid", "Observations", "empty_grid", "fuse", "merge"]

MAX_CELLS = 10_000_000
"""Largest grid [cells]: 400 MB for its five arrays (40 bytes a cell). A map is dense over
the bounding box of its observations; a larger one is refused with what it would need."""

MAX_COORD = 1.0e8
"""Largest position magnitude [m] in a map frame (a local frame: 100,000 km)."""

MIN_VAR = 1e-8
"""Smallest observation variance [-] (standard deviation 1e-4): smaller ones are raised to it,
so that the precision-weighted sums stay finite."""

MAX_MU = 100.0
"""Largest friction magnitude [-] an observation may carry."""

_BYTES_PER_CELL = 40


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


@dataclass(frozen=True)
class FrictionGrid:
    """A friction grid (immutable; :func:`fuse` and :func:`merge` return new grids).

    Attributes
    ----------
    cell : float
        Cell size [m].
    ix0, iy0 : int
        Global index of the first column / row (cell ``(i, j)`` covers
        ``[i cell, (i+1) cell) x [j cell, (j+1) cell)``).
    s0, s1, s2, sb : ndarray, shape (ny, nx)
        Sums of ``w``, ``w mu``, ``w mu²``, ``w b`` (``b`` systematic error).
    n_obs : ndarray of int64, shape (ny, nx)
        Number of observations fused into each cell.
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
    """

    cell: float
    ix0: int
    iy0: int
    s0: NDArray[np.float64]
    s1: NDArray[np.float64]
    s2: NDArray[np.float64]
    sb: NDArray[np.float64]
    n_obs: NDArray[np.int64]
    prior_mean: float = 0.7
    prior_std: float = 0.4
    tau: float = float("inf")
    t_ref: float = float("-inf")
    overdispersion: bool = True
    path: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))

    def __post_init__(self) -> None:
        if not (np.isfinite(self.cell) and self.cell > 0):
            raise ValueError(f"cell size must be positive and finite, got {self.cell!r}")
        if not (np.isfinite(self.prior_std) and self.prior_std > 0 and np.isfinite(self.prior_mean)):
            raise ValueError("prior_mean must be finite and prior_std positive")
        if not self.tau > 0:
            raise ValueError(f"forgetting time constant tau must be positive (inf: none), got {self.tau!r}")
        shapes = {np.shape(a) for a in (self.s0, self.s1, self.s2, self.sb, self.n_obs)}
        if len(shapes) != 1 or len(next(iter(shapes))) != 2:
            raise ValueError(f"grid arrays must share one 2-D shape, got {shapes}")
        ny, nx = next(iter(shapes))
        _check_size(nx, ny, self.cell)
        for name, i0, n in (("ix0", self.ix0, nx), ("iy0", self.iy0, ny)):
            if not abs(i0 * self.cell) <= MAX_COORD or not abs((i0 + n) * self.cell) <= MAX_COORD:
                raise ValueError(f"grid origin {name} = {i0} cells of {self.cell:g} m lies beyond "
                                 f"+-{MAX_COORD:g} m")

    # -- geometry --------------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        """``(ny, nx)``."""
        return self.s0.shape  # type: ignore[return-value]

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """``(xmin, xmax, ymin, ymax)`` of the grid [m]."""
        ny, nx = self.shape
        c = self.cell
        return (self.ix0 * c, (self.ix0 + nx) * c, self.iy0 * c, (self.iy0 + ny) * c)

    def centres(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Cell-centre coordinates ``X, Y`` [m], each shape ``(ny, nx)``."""
        ny, nx = self.shape
        xs = (self.ix0 + np.arange(nx) + 0.5) * self.cell
        ys = (self.iy0 + np.arange(ny) + 0.5) * self.cell
        return np.meshgrid(xs, ys)

    # -- posterior -------------------------------------------------------------------
    def birge_ratio(self) -> NDArray[np.float64]:
        """Per-cell ``max(1, chi² / (n - 1))`` (1 where fewer than two observations)."""
        out = np.ones(self.shape)
        ok = (self.n_obs >= 2) & (self.s0 > 0)
        if ok.any():
            s0, s1, s2 = self.s0[ok], self.s1[ok], self.s2[ok]
            chi2 = np.maximum(s2 - s1 * s1 / s0, 0.0)
            out[ok] = np.maximum(chi2 / (self.n_obs[ok] - 1), 1.0)
        return out

    def posterior(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Per-cell posterior mean and standard deviation [-], shape ``(ny, nx)``."""
        b = self.birge_ratio() if self.overdispersion else np.ones(self.shape)
        p0 = 1.0 / self.prior_std**2
        prec = p0 + self.s0 / b
        mean = (self.prior_mean * p0 + self.s1 / b) / prec
        sys = self.sb / b / prec
        return mean, np.sqrt(1.0 / prec + sys * sys)

    def query(self, x: ArrayLike, y: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Friction mean and standard deviation [-] at positions ``(x, y)`` [m].

        Positions outside the grid or in cells without observations return the
        prior (``prior_mean``, ``prior_std``).

        Examples
        --------
        >>> g = fuse(empty_grid(1.0), [0.5, 0.5], [0.5, 0.5], [0.6, 0.6], [0.01, 0.01])
        >>> m, s = g.query([0.2, 10.0], [0.7, 10.0])
        >>> [round(float(v), 3) for v in m], round(float(s[1]), 3)
        ([0.603, 0.7], 0.4)
        """
        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        mean, std = self.posterior()
        out_m = np.full(np.broadcast(x, y).shape, self.prior_mean)
        out_s = np.full(out_m.shape, self.prior_std)
        x, y = np.broadcast_arrays(x, y)
        ix = np.floor(x / self.cell).astype(np.int64) - self.ix0
        iy = np.floor(y / self.cell).astype(np.int64) - self.iy0
        ny, nx = self.shape
        inside = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny) & np.isfinite(x) & np.isfinite(y)
        out_m[inside] = mean[iy[inside], ix[inside]]
        out_s[inside] = std[iy[inside], ix[inside]]
        return out_m, out_s

    # -- files -----------------------------------------------------------------------
    def cells_frame(self, min_obs: int = 1) -> pd.DataFrame:
        """Cells with at least ``min_obs`` observations: ``x, y, mu_mean, mu_std, n_obs``."""
        X, Y = self.centres()
        mean, std = self.posterior()
        sel = self.n_obs >= max(min_obs, 1)
        return pd.DataFrame({"x": X[sel], "y": Y[sel], "mu_mean": mean[sel], "mu_std": std[sel],
                             "n_obs": self.n_obs[sel]})

    def to_csv(self, path: str | Path) -> None:
        """Visited cells as CSV with columns ``x, y`` (cell centre, m), ``mu_mean, mu_std, n_obs``."""
        self.cells_frame().to_csv(path, index=False, float_format="%.6g")

    def to_npz(self, path: str | Path) -> None:
        """Lossless NPZ (sums, counts, geometry, prior, forgetting, path)."""
        np.savez_compressed(
            path, cell=self.cell, ix0=self.ix0, iy0=self.iy0, s0=self.s0, s1=self.s1, s2=self.s2, sb=self.sb,
            n_obs=self.n_obs, prior_mean=self.prior_mean, prior_std=self.prior_std, tau=self.tau,
            t_ref=self.t_ref, overdispersion=self.overdispersion, path=self.path,
            format="roadgrip-friction-grid-1",
        )

    @classmethod
    def from_npz(cls, path: str | Path) -> FrictionGrid:
        """Read :meth:`to_npz` output; a one-line error naming the file for anything else."""
        import zipfile
        import zlib

        name = Path(path).name
        try:
            with np.load(path, allow_pickle=False) as z:
                if not hasattr(z, "files") or "format" not in z.files or (
                        str(z["format"]) != "roadgrip-friction-grid-1"):
                    raise ValueError(f"{name} is not a roadgrip friction grid (.npz from `roadgrip map`)")
                arrays = [np.asarray(z[k], dtype=float) for k in ("s0", "s1", "s2", "sb")]
                return cls(
                    float(z["cell"]), int(z["ix0"]), int(z["iy0"]), *arrays,
                    np.asarray(z["n_obs"]).astype(np.int64), float(z["prior_mean"]),
                    float(z["prior_std"]), float(z["tau"]), float(z["t_ref"]),
                    bool(z["overdispersion"]), np.asarray(z["path"], dtype=float).reshape(-1, 2),
                )
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


def _check_size(nx: int, ny: int, cell: float, spread: str = "") -> None:
    """Refuse a grid of more than :data:`MAX_CELLS` cells, with the memory it would need."""
    n = int(nx) * int(ny)
    if n > MAX_CELLS:
        gib = n * _BYTES_PER_CELL / 2**30
        raise ValueError(
            f"the map would need {nx} x {ny} = {n:.3g} cells of {cell:g} m ({gib:.3g} GiB){spread}; "
            f"the limit is {MAX_CELLS:.3g} cells ({MAX_CELLS * _BYTES_PER_CELL / 2**30:.2g} GiB): "
            "use larger cells or map the areas separately"
        )


def empty_grid(
    cell: float = 0.5,
    prior_mean: float = 0.7,
    prior_std: float = 0.4,
    tau: float = float("inf"),
    overdispersion: bool = True,
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
    """
    z = np.zeros((0, 0))
    return FrictionGrid(float(cell), 0, 0, z, z.copy(), z.copy(), z.copy(), np.zeros((0, 0), np.int64),
                        float(prior_mean), float(prior_std), float(tau), float("-inf"), bool(overdispersion))


class _Batch(NamedTuple):
    """Observations as the compiled accumulation reads them, each shape (n,) (``decay`` may be empty)."""

    x: NDArray[np.float64]
    y: NDArray[np.float64]
    mu: NDArray[np.float64]
    var: NDArray[np.float64]
    decay: NDArray[np.float64]  # forgetting factor of each observation; empty: none
    sys: NDArray[np.float64]


class _Sums(NamedTuple):
    """The per-cell sums of a grid window, shape (ny, nx) each (:class:`FrictionGrid`)."""

    s0: NDArray[np.float64]
    s1: NDArray[np.float64]
    s2: NDArray[np.float64]
    sb: NDArray[np.float64]
    n_obs: NDArray[np.int64]


class _Window(NamedTuple):
    """A window of global cell indices: first column and row, number of columns and rows."""

    ix0: int
    iy0: int
    nx: int
    ny: int


def _embed(g: FrictionGrid, ix0: int, iy0: int, nx: int, ny: int) -> _Sums:
    """The grid's sums placed into a larger window starting at ``(ix0, iy0)``."""
    out = _Sums(*(np.zeros((ny, nx)) for _ in range(4)), np.zeros((ny, nx), np.int64))
    gy, gx = g.shape
    if gy and gx:
        ox, oy = g.ix0 - ix0, g.iy0 - iy0
        for o, a in zip(out, (g.s0, g.s1, g.s2, g.sb, g.n_obs), strict=True):
            o[oy:oy + gy, ox:ox + gx] = a
    return out


def _window(g: FrictionGrid) -> _Window:
    return _Window(g.ix0, g.iy0, g.shape[1], g.shape[0])


def _union(a: _Window, b: _Window) -> _Window:
    """Union of two index windows; empty windows are ignored."""
    if a.nx == 0 or a.ny == 0:
        return b
    if b.nx == 0 or b.ny == 0:
        return a
    x0, y0 = min(a.ix0, b.ix0), min(a.iy0, b.iy0)
    x1, y1 = max(a.ix0 + a.nx, b.ix0 + b.nx), max(a.iy0 + a.ny, b.iy0 + b.ny)
    return _Window(x0, y0, x1 - x0, y1 - y0)


def _decay(g: FrictionGrid, t_new: float) -> FrictionGrid:
    """Move the reference time to ``t_new``, scaling the sums when the grid forgets."""
    if not t_new > g.t_ref:
        return g
    if np.isfinite(g.tau) and np.isfinite(g.t_ref):
        f = np.exp(-(t_new - g.t_ref) / g.tau)
        return dataclasses.replace(g, s0=g.s0 * f, s1=g.s1 * f, s2=g.s2 * f, sb=g.sb * f, t_ref=t_new)
    return dataclasses.replace(g, t_ref=t_new)


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
        Non-finite values, non-positive variances, mismatched lengths.

    Notes
    -----
    The accumulation is a compiled single pass over the observations (the
    ``np.bincount`` pattern without temporaries).
    """
    x, y, mu, var = (np.ascontiguousarray(np.asarray(a, dtype=float).ravel()) for a in (x, y, mu, var))
    n = x.size
    if not (y.size == mu.size == var.size == n):
        raise ValueError(f"x, y, mu, var must have one length, got {x.size}, {y.size}, {mu.size}, {var.size}")
    g = grid
    if t is not None:
        t = np.ascontiguousarray(np.asarray(t, dtype=float).ravel())
        if t.size != n or not np.all(np.isfinite(t)):
            raise ValueError("observation times t must be finite and as many as the observations")
    if np.isfinite(grid.tau) and t is None:
        raise ValueError("a forgetting grid needs observation times t")
    new_path = g.path
    if path is not None:
        p = np.asarray(path, dtype=float).reshape(-1, 2)
        new_path = p if g.path.size == 0 else np.vstack([g.path, [[np.nan, np.nan]], p])
    if n == 0:
        return dataclasses.replace(g, path=new_path)
    b = np.zeros(n) if sys is None else np.ascontiguousarray(np.asarray(sys, dtype=float).ravel())
    if b.size != n or not np.all(np.isfinite(b)) or np.any(b < 0):
        raise ValueError("systematic errors sys must be finite, >= 0 and as many as the observations")
    far = ~(np.abs(x) <= MAX_COORD) | ~(np.abs(y) <= MAX_COORD)
    if far.any():
        i = int(np.flatnonzero(far)[0])
        raise ValueError(f"observation {i} is not usable: at x = {x[i]:.6g}, y = {y[i]:.6g} m; positions must be "
                         f"finite and within +-{MAX_COORD:g} m of the map origin")
    bad, bx0, by0, bx1, by1 = _bounds(x, y, mu, var, g.cell)
    if bad < 0 and np.any(np.abs(mu) > MAX_MU):
        bad = int(np.flatnonzero(np.abs(mu) > MAX_MU)[0])
    if bad >= 0:
        raise ValueError(f"observation {bad} is not usable: positions, mu and var must be finite, var > 0, "
                         f"|mu| <= {MAX_MU:g} (mu = {mu[bad]:.6g}, var = {var[bad]:.6g})")
    var = np.maximum(var, MIN_VAR)
    decay = np.empty(0)
    if t is not None:
        g = _decay(grid, float(t.max()))
        if np.isfinite(g.tau):
            decay = np.exp(-(g.t_ref - t) / g.tau)
    x0, y0, nx, ny = _union(_window(g), _Window(bx0, by0, bx1 - bx0 + 1, by1 - by0 + 1))
    _check_size(nx, ny, g.cell, f" to hold observations over x {x0 * g.cell:.6g} to "
                f"{(x0 + nx) * g.cell:.6g} m, y {y0 * g.cell:.6g} to {(y0 + ny) * g.cell:.6g} m")
    sums = _embed(g, x0, y0, nx, ny)
    _accumulate(_Batch(x, y, mu, var, decay, b), g.cell, x0, y0, sums)
    return dataclasses.replace(g, ix0=x0, iy0=y0, **sums._asdict(), path=new_path)


@njit(cache=True)
def _bounds(x, y, mu, var, cell):  # pragma: no cover - compiled
    """First bad observation (-1 if none) and the cell-index bounds of the data."""
    ix0 = iy0 = np.iinfo(np.int64).max
    ix1 = iy1 = np.iinfo(np.int64).min
    for i in range(x.shape[0]):
        if not (np.isfinite(x[i]) and np.isfinite(y[i]) and np.isfinite(mu[i]) and var[i] > 0.0
                and np.isfinite(var[i])):
            return i, 0, 0, 0, 0
        ix = np.int64(np.floor(x[i] / cell))
        iy = np.int64(np.floor(y[i] / cell))
        ix0 = min(ix0, ix)
        ix1 = max(ix1, ix)
        iy0 = min(iy0, iy)
        iy1 = max(iy1, iy)
    return -1, ix0, iy0, ix1, iy1


@njit(cache=True)
def _accumulate(obs, cell, x0, y0, sums):  # pragma: no cover - compiled
    """Add precision, precision * mu, precision * mu², precision * sys and counts into ``sums``."""
    use_decay = obs.decay.shape[0] > 0
    for i in range(obs.x.shape[0]):
        ix = np.int64(np.floor(obs.x[i] / cell)) - x0
        iy = np.int64(np.floor(obs.y[i] / cell)) - y0
        w = 1.0 / obs.var[i]
        if use_decay:
            w *= obs.decay[i]
        wm = w * obs.mu[i]
        sums.s0[iy, ix] += w
        sums.s1[iy, ix] += wm
        sums.s2[iy, ix] += wm * obs.mu[i]
        sums.sb[iy, ix] += w * obs.sys[i]
        sums.n_obs[iy, ix] += 1


def merge(*grids: FrictionGrid) -> FrictionGrid:
    """Merge grids of several drives: sums add, nothing is lost.

    All grids must share cell size, prior, forgetting constant and the
    overdispersion setting. With forgetting, every grid is first brought to the
    latest reference time. ``merge(merge(a, b), c) == merge(a, merge(b, c))``
    up to floating-point rounding, and the counts add exactly.
    """
    if not grids:
        raise ValueError("merge needs at least one grid")
    first = grids[0]
    for g in grids[1:]:
        for attr in ("cell", "prior_mean", "prior_std", "tau", "overdispersion"):
            if getattr(g, attr) != getattr(first, attr):
                raise ValueError(f"cannot merge grids with different {attr}: "
                                 f"{getattr(first, attr)!r} and {getattr(g, attr)!r}")
    t_ref = max(g.t_ref for g in grids)
    grids = tuple(_decay(g, t_ref) for g in grids)
    win = _Window(0, 0, 0, 0)
    for g in grids:
        win = _union(win, _window(g))
    x0, y0, nx, ny = win
    _check_size(nx, ny, first.cell, f" to hold the merged grids over x {x0 * first.cell:.6g} to "
                f"{(x0 + nx) * first.cell:.6g} m, y {y0 * first.cell:.6g} to {(y0 + ny) * first.cell:.6g} m")
    acc = _Sums(*(np.zeros((ny, nx)) for _ in range(4)), np.zeros((ny, nx), np.int64))
    paths = []
    for g in grids:
        for a, b in zip(acc, _embed(g, x0, y0, nx, ny), strict=True):
            a += b
        if g.path.size:
            paths.append(g.path)
    path = np.zeros((0, 2))
    for p in paths:
        path = p if path.size == 0 else np.vstack([path, [[np.nan, np.nan]], p])
    return dataclasses.replace(first, ix0=x0, iy0=y0, **acc._asdict(), t_ref=t_ref, path=path)
