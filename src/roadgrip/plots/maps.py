"""Friction-map figures: absolute friction per cell over the driven path, and its uncertainty."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import Normalize

from roadgrip.mapping import FrictionGrid, HexGrid

__all__ = ["plot_grid"]

_MAX_IMAGE_CELLS = 4_000_000
"""Largest bounding box [cells] drawn as an image; sparser maps are drawn as points."""


def _too_sparse(grid: FrictionGrid) -> bool:
    if grid.n_cells == 0:
        return False
    ix, iy = grid.cell_index()
    return (int(ix.max()) - int(ix.min()) + 1) * (int(iy.max()) - int(iy.min()) + 1) > _MAX_IMAGE_CELLS


def _plot_cells(grid: FrictionGrid | HexGrid, path: str | Path, title: str | None, min_obs: int) -> None:
    """The observed cells as points (H3 maps, and grids whose cells lie far apart)."""
    frame = grid.cells_frame(min_obs)
    hexes = isinstance(grid, HexGrid)
    x, y = (frame["lon"], frame["lat"]) if hexes else (frame["x"], frame["y"])
    fig, axes = plt.subplots(1, 2, figsize=(12, 5), constrained_layout=True)
    for ax, col, cmap, label in ((axes[0], "mu_mean", "viridis", "friction coefficient mu [-] (posterior mean)"),
                                 (axes[1], "mu_std", "magma_r", "std of mu [-]")):
        sc = ax.scatter(x, y, c=frame[col], cmap=cmap, s=12, marker="h" if hexes else "s")
        fig.colorbar(sc, ax=ax, label=label, shrink=0.85)
        ax.set_xlabel("longitude [deg]" if hexes else "x [m]")
        ax.set_ylabel("latitude [deg]" if hexes else "y [m]")
    kind = f"H3 resolution {grid.resolution}" if hexes else f"{grid.cell:g} m cells"
    axes[0].set_title(title or f"friction map, {kind}, {len(frame)} cells observed")
    axes[1].set_title(f"uncertainty ({int(grid.cells.n_obs.sum())} excited observations)")
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_grid(
    grid: FrictionGrid | HexGrid,
    path: str | Path,
    *,
    title: str | None = None,
    vmin: float | None = None,
    vmax: float | None = None,
    min_obs: int = 1,
) -> None:
    """Write a PNG: posterior mean friction (absolute, not normalised) and its std.

    Cells with fewer than ``min_obs`` excited observations are left blank in the
    mean panel (they hold only the prior); the std panel shows every cell of the
    grid window, so unvisited cells appear at the prior's width.

    Parameters
    ----------
    grid : FrictionGrid or HexGrid
        An H3 map, or a grid whose cells lie too far apart for an image, is drawn as points.
    path : str or Path
        Output ``.png``.
    title : str, optional
    vmin, vmax : float, optional
        Colour range of friction [-]; default the range of visited cells,
        widened to at least 0.3.
    min_obs : int
        Cells shown in the mean panel.
    """
    if isinstance(grid, HexGrid) or _too_sparse(grid):
        _plot_cells(grid, path, title, min_obs)
        return
    mean, std = grid.posterior()
    visited = grid.n_obs >= max(min_obs, 1)
    fig, axes = plt.subplots(1, 2, figsize=(12, 5), constrained_layout=True)
    ext = grid.extent
    if visited.any():
        lo, hi = float(mean[visited].min()), float(mean[visited].max())
    else:
        lo, hi = grid.prior_mean - 0.15, grid.prior_mean + 0.15
    mid = 0.5 * (lo + hi)
    half = max(0.5 * (hi - lo), 0.15)
    norm = Normalize(vmin if vmin is not None else max(mid - half, 0.0),
                     vmax if vmax is not None else mid + half)
    panels = (
        (np.where(visited, mean, np.nan), "viridis", norm, "friction coefficient mu [-] (posterior mean)"),
        (std, "magma_r", Normalize(0.0, grid.prior_std), "std of mu [-] (prior where unvisited)"),
    )
    for ax, (img, cmap, nrm, label) in zip(axes, panels, strict=True):
        if img.size:
            im = ax.imshow(img, origin="lower", extent=ext, cmap=cmap, norm=nrm, interpolation="nearest")
            fig.colorbar(im, ax=ax, label=label, shrink=0.85)
        if grid.path.size:
            ax.plot(grid.path[:, 0], grid.path[:, 1], color="0.5", lw=0.5, alpha=0.7)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_aspect("equal")
    axes[0].set_title(title or f"friction map, {grid.cell:g} m cells, {int(visited.sum())} cells observed")
    axes[1].set_title(f"uncertainty ({int(grid.n_obs.sum())} excited observations)")
    fig.savefig(path, dpi=120)
    plt.close(fig)
