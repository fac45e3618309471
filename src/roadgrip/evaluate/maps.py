"""Friction grids for the benchmark: build one from an estimator run, and its cell truth."""

from __future__ import annotations

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from roadgrip.evaluate.map_metrics import cell_truth

__all__ = ["cells_from_result", "true_cell_friction"]


def cells_from_result(result, drive, cell: float = 0.5) -> tuple[pd.DataFrame, float, object]:
    """Fuse a run's excited estimates into a :class:`roadgrip.mapping.FrictionGrid`.

    Returns every cell of the grid's extent (visited or not) as a frame with
    ``x, y`` (centre, m), ``mu_mean``, ``mu_std``, ``n_obs``, the cell size
    [m] and the grid itself; ``frame.attrs['cell_size']`` carries the size too. Estimates without a
    position take it from the drive's ``x, y``.
    """
    from roadgrip.mapping import grid_from_estimates

    table = result.table
    if not {"x", "y"} <= set(table.columns):
        if len(table) != drive.n or not drive.has("x", "y"):
            raise ValueError("neither the estimates nor the drive carry a position to map with")
        table = table.assign(x=drive.col("x"), y=drive.col("y"))
    grid = grid_from_estimates(table, cell=cell)
    X, Y = grid.centres()
    mean, std = grid.posterior()
    cells = pd.DataFrame({"x": X.ravel(), "y": Y.ravel(), "mu_mean": mean.ravel(),
                          "mu_std": std.ravel(), "n_obs": grid.n_obs.ravel()})
    cells.attrs["cell_size"] = float(grid.cell)
    return cells, float(grid.cell), grid


def _observed_truth(drive, table, field, mu_at, x, y, cell, fallback):
    """Precision-weighted field at the observations fused into each cell (``fallback``
    where a cell has none)."""
    from roadgrip.mapping import observations_from_estimates

    if not {"x", "y"} <= set(table.columns):
        table = table.assign(x=drive.col("x"), y=drive.col("y"))
    obs = observations_from_estimates(table, cell)
    if len(obs.x) == 0:
        return fallback
    w = 1.0 / np.asarray(obs.var, float)
    mu = np.asarray(mu_at(field, np.asarray(obs.t, float), obs.x, obs.y), float)
    key = pd.DataFrame({"ix": np.floor(obs.x / cell).astype(np.int64),
                        "iy": np.floor(obs.y / cell).astype(np.int64), "w": w, "wm": w * mu})
    sums = key.groupby(["ix", "iy"])[["w", "wm"]].sum()
    idx = pd.MultiIndex.from_arrays([np.floor(x / cell).astype(np.int64), np.floor(y / cell).astype(np.int64)])
    got = sums.reindex(idx)
    out = (got["wm"] / got["w"]).to_numpy(float)
    return np.where(np.isfinite(out), out, fallback)


def true_cell_friction(
    drive, cells: pd.DataFrame, cell: float, sub: int = 5, table: pd.DataFrame | None = None
) -> NDArray[np.float64]:
    """True friction of each cell.

    With the simulator's friction field in ``drive.meta.truth['friction_field']``:

    * given ``table``, the estimates the grid fused, a cell's truth is the field at the
      observations fused into it, weighted by their precision as the grid weighs them:
      the value the cell's estimate converges to (on a patch edge, what was observed on
      the two sides where the car drove);
    * otherwise, and for cells without observations, the field averaged over the cell's
      area (a ``sub x sub`` lattice at the drive's final time).

    Without a field, the mean ``mu_true`` of the drive samples inside the cell
    (:func:`roadgrip.evaluate.map_metrics.cell_truth`); NaN where none.
    """
    field = (drive.meta.truth or {}).get("friction_field")
    x = cells["x"].to_numpy(float)
    y = cells["y"].to_numpy(float)
    if len(x) == 0:
        return np.zeros(0)
    if field is not None:
        from roadgrip.sim.friction import mu_at

        offs = (np.arange(sub) + 0.5) / sub - 0.5
        ox, oy = np.meshgrid(offs * cell, offs * cell)
        px = (x[:, None] + ox.ravel()[None, :]).ravel()
        py = (y[:, None] + oy.ravel()[None, :]).ravel()
        mu = np.asarray(mu_at(field, float(drive.t[-1]), px, py), float)
        area = mu.reshape(len(x), -1).mean(axis=1)
        if table is None:
            return area
        return _observed_truth(drive, table, field, mu_at, x, y, cell, area)
    if not drive.has("x", "y", "mu_true"):
        return np.full(len(x), np.nan)
    return cell_truth(x, y, cell, drive.col("x"), drive.col("y"), drive.col("mu_true"))
