"""Friction observations from an estimates table, the grip-used check, and grid comparison.

See :mod:`roadgrip.mapping` for the model.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from roadgrip.constants import Z95
from roadgrip.mapping.grid import FrictionGrid, Observations, empty_grid, fuse

__all__ = ["GridSummary", "compare_grids", "grid_from_estimates", "grip_used_bound", "observations_from_estimates"]


def grip_used_bound(table: pd.DataFrame, cell: float) -> tuple[NDArray[np.int64], NDArray[np.int64],
                                                                NDArray[np.float64]] | None:
    """Per cell, the largest friction demonstrably used: ``max hypot(|Fy| - 2 std(Fy), Fx) / Fz`` over both axles.

    Parameters
    ----------
    table : DataFrame
        Estimates with ``Fy<f|r>``, ``Fy<f|r>_std``, ``Fz<f|r>``, optionally the
        axle's longitudinal force ``Fx_<axle>``, and positions (``x_<axle>,
        y_<axle>`` or ``x, y``).
    cell : float
        Cell size [m].

    Returns
    -------
    (ix, iy, bound) or None
        Global cell indices and the bound [-] of every cell with a usable
        sample; ``None`` when the table has no axle forces.
    """
    parts = []
    for axle, f, fz in (("front", "Fyf", "Fzf"), ("rear", "Fyr", "Fzr")):
        if not {f, f"{f}_std", fz} <= set(table.columns):
            continue
        xc, yc = (f"x_{axle}", f"y_{axle}")
        if {xc, yc} & set(table.columns):
            _companions(table, xc if xc in table.columns else yc, (xc, yc))
        else:
            xc, yc = "x", "y"
        load = table[fz].to_numpy(float)
        lateral = np.maximum(np.abs(table[f].to_numpy(float)) - 2.0 * table[f"{f}_std"].to_numpy(float), 0.0)
        # the axle's longitudinal force uses the same friction (friction circle), where given
        fx = table[f"Fx_{axle}"].to_numpy(float) if f"Fx_{axle}" in table.columns else np.zeros(len(table))
        with np.errstate(divide="ignore", invalid="ignore"):
            used = np.hypot(lateral, fx) / load
        x, y = table[xc].to_numpy(float), table[yc].to_numpy(float)
        ok = np.isfinite(used) & (load > 0) & np.isfinite(x) & np.isfinite(y)
        parts.append((np.floor(x[ok] / cell).astype(np.int64), np.floor(y[ok] / cell).astype(np.int64), used[ok]))
    if not parts:
        return None
    ix, iy, used = (np.concatenate([p[i] for p in parts]) for i in range(3))
    frame = pd.DataFrame({"ix": ix, "iy": iy, "used": used}).groupby(["ix", "iy"], sort=False)["used"].max()
    return (frame.index.get_level_values(0).to_numpy(np.int64), frame.index.get_level_values(1).to_numpy(np.int64),
            frame.to_numpy(float))


def _above_grip_used(obs: Observations, table: pd.DataFrame, cell: float) -> NDArray[np.bool_]:
    """Observations not below the friction used in their cell (module docstring)."""
    bound = grip_used_bound(table, cell)
    keep = np.ones(len(obs.mu), bool)
    if bound is None or len(obs.mu) == 0:
        return keep
    lut = pd.Series(bound[2], index=pd.MultiIndex.from_arrays([bound[0], bound[1]]))
    key = pd.MultiIndex.from_arrays([np.floor(obs.x / cell).astype(np.int64), np.floor(obs.y / cell).astype(np.int64)])
    lb = lut.reindex(key).to_numpy(float)
    return ~(np.isfinite(lb) & (obs.mu < lb))


def _numeric_columns(table: pd.DataFrame) -> pd.DataFrame:
    """The table with the columns a map reads checked: numbers (or booleans for the
    ``excited`` flags); text such as 'n/a' is refused naming the column, row and value."""
    read = [c for c in table.columns if isinstance(c, str) and (
        c in ("t", "x", "y", "excited") or c.startswith(("mu_", "x_", "y_", "Fz", "Fy", "Fx_", "excited_")))]
    for c in read:
        col = table[c]
        if col.dtype.kind in "fiub":
            continue
        num = pd.to_numeric(col, errors="coerce")
        bad = (num.isna() & col.notna()).to_numpy()
        if bad.any() or col.dtype.kind not in "fiubO":
            i = int(np.flatnonzero(bad)[0]) if bad.any() else 0
            raise ValueError(f"estimates column {c!r} holds {str(col.iloc[i])[:20]!r} at row {i}: "
                             "expected numbers")
        num = num.astype(float)
        if c.startswith("excited"):  # a missing flag is not excited
            num = num.fillna(0.0).astype(bool)
        table = table.assign(**{c: num})
    return table


def _companions(table: pd.DataFrame, column: str, needed: tuple[str, ...]) -> None:
    """Refuse, naming them, the columns an estimate needs beside ``column`` that are missing."""
    missing = [c for c in needed if c not in table.columns]
    if missing:
        raise ValueError(f"estimates column {column!r} comes without {missing}: the table is incomplete")


def observations_from_estimates(table: pd.DataFrame, cell: float | None = None) -> Observations:
    """Excited friction observations of an estimates table, at the axle positions.

    Uses, per axle, the single-sample observation ``mu_<axle>_obs`` with
    ``mu_<axle>_obs_std``, ``mu_<axle>_obs_sys`` and ``excited_<axle>`` where the
    estimator provides them (the cascade does; the map then collects likelihoods, not filter states
    that remember earlier cells), else the posterior ``mu_<axle>`` with the
    standard deviation implied by its 95 % band and the shared ``excited`` flag.
    Positions are ``x_<axle>, y_<axle>`` when present, else ``x, y``.
    With a cell size [m], observations below the friction used in their cell
    (:func:`grip_used_bound`; module docstring) are dropped.

    Raises
    ------
    ValueError
        When the table has no position columns ``x, y``, or a column it reads holds text
        (named with its row and value).
    """
    if not {"x", "y"} <= set(table.columns):
        raise ValueError("estimates have no position (columns x, y): the drive had no pose to map with")
    table = _numeric_columns(table)
    parts = []
    t_all = table["t"].to_numpy(float) if "t" in table.columns else np.zeros(len(table))
    for axle in ("front", "rear"):
        if f"mu_{axle}_obs" in table.columns:
            _companions(table, f"mu_{axle}_obs", (f"mu_{axle}_obs_std", f"excited_{axle}"))
            mu = table[f"mu_{axle}_obs"].to_numpy(float)
            sd = table[f"mu_{axle}_obs_std"].to_numpy(float)
            exc = table[f"excited_{axle}"].to_numpy(bool)
            sysc = f"mu_{axle}_obs_sys"
            b = table[sysc].to_numpy(float) if sysc in table.columns else np.zeros(len(table))
        elif f"mu_{axle}" in table.columns:
            _companions(table, f"mu_{axle}", (f"mu_{axle}_lower", f"mu_{axle}_upper"))
            mu = table[f"mu_{axle}"].to_numpy(float)
            sd = (table[f"mu_{axle}_upper"].to_numpy(float) - table[f"mu_{axle}_lower"].to_numpy(float)) / (2 * Z95)
            exc = table["excited"].to_numpy(bool) if "excited" in table.columns else np.ones(len(table), bool)
            b = np.zeros(len(table))
        else:
            continue
        xc, yc = (f"x_{axle}", f"y_{axle}")
        if {xc, yc} & set(table.columns):
            _companions(table, xc if xc in table.columns else yc, (xc, yc))
        else:
            xc, yc = "x", "y"
        x, y = table[xc].to_numpy(float), table[yc].to_numpy(float)
        b = np.where(np.isfinite(b), np.abs(b), 0.0)
        with np.errstate(over="ignore"):  # a standard deviation past 1e154 has no variance
            ok = exc & np.isfinite(mu) & np.isfinite(sd * sd) & (sd > 0) & np.isfinite(x) & np.isfinite(y)
        parts.append((x[ok], y[ok], mu[ok], sd[ok] ** 2, t_all[ok], b[ok]))
    if not parts:
        raise ValueError("estimates have no friction columns (mu_front / mu_rear)")
    obs = Observations(*(np.concatenate([p[i] for p in parts]) for i in range(6)))
    if cell is not None:
        keep = _above_grip_used(obs, table, float(cell))
        obs = Observations(*(a[keep] for a in obs))
    return obs


def grid_from_estimates(table: pd.DataFrame, cell: float = 0.5, **grid_options: Any) -> FrictionGrid:
    """Grid of one estimates table (see :func:`observations_from_estimates`, with the grip-used check).

    ``grid_options`` go to :func:`empty_grid` (prior, forgetting, overdispersion).
    """
    obs = observations_from_estimates(table, cell)
    xy = table[["x", "y"]].to_numpy(float)
    step = max(1, len(xy) // 5000)
    g = empty_grid(cell, **grid_options)
    return fuse(g, obs.x, obs.y, obs.mu, obs.var, t=obs.t, path=xy[::step], sys=obs.sys)


class GridSummary(NamedTuple):
    """Agreement of several grids on their common cells.

    Attributes
    ----------
    cells : DataFrame
        One row per common cell: ``x, y`` and ``mu_<i>`` per grid.
    spread_std : float
        Mean over common cells of the standard deviation across grids [-].
    max_abs_diff : float
        Largest difference between two grids in any common cell [-].
    """

    cells: pd.DataFrame
    spread_std: float
    max_abs_diff: float


def compare_grids(grids: list[FrictionGrid], min_obs: int = 10) -> GridSummary:
    """Compare grids on the cells where every grid has at least ``min_obs`` observations."""
    if len(grids) < 2:
        raise ValueError("compare needs at least two grids")
    frames = []
    for i, g in enumerate(grids):
        f = g.cells_frame(min_obs)[["x", "y", "mu_mean"]].rename(columns={"mu_mean": f"mu_{i}"})
        frames.append(f.round({"x": 9, "y": 9}))
    common = frames[0]
    for f in frames[1:]:
        common = common.merge(f, on=["x", "y"], how="inner")
    if common.empty:
        return GridSummary(common, float("nan"), float("nan"))
    vals = common[[f"mu_{i}" for i in range(len(grids))]].to_numpy()
    return GridSummary(common, float(vals.std(axis=1, ddof=1).mean()),
                       float((vals.max(axis=1) - vals.min(axis=1)).max()))
