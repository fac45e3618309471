"""Friction-map figures: absolute friction per cell over the driven path, and its uncertainty.

Both panels use the shared colour scales of :mod:`roadgrip.plots.scales` (the report's map
uses them too), and draw a cell without an excited observation as *no data* (hatched grey),
in the mean panel and in the standard-deviation panel alike: an unvisited cell holds only
the prior, which says nothing about the road there.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from roadgrip.mapping import FrictionGrid, HexGrid
from roadgrip.plots.scales import draw_no_data, friction_scale, no_data_handle, std_scale

__all__ = ["grid_figure", "plot_grid"]

_MAX_IMAGE_CELLS = 4_000_000
"""Largest bounding box [cells] drawn as an image; sparser maps are drawn as points."""

_MEAN_LABEL = "friction coefficient mu [-] (posterior mean)"
_STD_LABEL = "std of mu [-]"


def _too_sparse(grid: FrictionGrid) -> bool:
    if grid.n_cells == 0:
        return False
    ix, iy = grid.cell_index()
    return (int(ix.max()) - int(ix.min()) + 1) * (int(iy.max()) - int(iy.min()) + 1) > _MAX_IMAGE_CELLS


def _legend(fig: Figure, ax, path_drawn: bool) -> None:
    handles = [no_data_handle()]
    if path_drawn:
        handles.append(ax.get_lines()[0])
    fig.legend(handles=handles, loc="outside lower center", ncol=len(handles), fontsize=8)


def _friction_scale(vmin: float | None, vmax: float | None):
    cmap, norm = friction_scale()
    if vmin is not None or vmax is not None:
        norm = Normalize(norm.vmin if vmin is None else vmin, norm.vmax if vmax is None else vmax)
    return cmap, norm


def _cells_figure(grid: FrictionGrid | HexGrid, title: str | None, min_obs: int, fscale) -> Figure:
    """The observed cells as points (H3 maps, and grids whose cells lie far apart)."""
    frame = grid.cells_frame(min_obs)
    hexes = isinstance(grid, HexGrid)
    x, y = (frame["lon"], frame["lat"]) if hexes else (frame["x"], frame["y"])
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.4), layout="constrained")
    for ax, col, (cmap, norm), label in ((axes[0], "mu_mean", fscale, _MEAN_LABEL),
                                         (axes[1], "mu_std", std_scale(), _STD_LABEL)):
        draw_no_data(ax)
        sc = ax.scatter(x, y, c=frame[col], cmap=cmap, norm=norm, s=12, marker="h" if hexes else "s")
        fig.colorbar(sc, ax=ax, label=label, shrink=0.85, extend="max")
        ax.set_xlabel("longitude [deg]" if hexes else "x [m]")
        ax.set_ylabel("latitude [deg]" if hexes else "y [m]")
    kind = f"H3 resolution {grid.resolution}" if hexes else f"{grid.cell:g} m cells"
    axes[0].set_title(title or f"friction map, {kind}, {len(frame)} cells observed", fontsize=10)
    axes[1].set_title(f"uncertainty ({int(grid.cells.n_obs.sum())} excited observations)", fontsize=10)
    _legend(fig, axes[0], False)
    return fig


def grid_figure(grid: FrictionGrid | HexGrid, *, title: str | None = None, min_obs: int = 1,
                vmin: float | None = None, vmax: float | None = None) -> Figure:
    """The map's figure: posterior mean friction (absolute, not normalised) and its std.

    Cells with fewer than ``min_obs`` excited observations (at least 1) are drawn as no
    data in both panels; the axes cover the observed cells and the driven path, so a
    driven stretch without observations shows as no data too.

    Parameters
    ----------
    grid : FrictionGrid or HexGrid
        An H3 map, or a grid whose cells lie too far apart for an image, is drawn as points.
    title : str, optional
    min_obs : int
        Fewest excited observations of a cell with data.
    vmin, vmax : float, optional
        Replace the ends of the shared friction range [-] (for a figure that must
        resolve a narrow range; figures meant to be compared keep the default).

    Returns
    -------
    Figure
        Two panels, each with its image (or scatter) in the shared colour scales of
        :mod:`roadgrip.plots.scales`.
    """
    if isinstance(grid, HexGrid) or _too_sparse(grid):
        return _cells_figure(grid, title, min_obs, _friction_scale(vmin, vmax))
    mean, std = grid.posterior()
    visited = grid.n_obs >= max(min_obs, 1)
    fig, axes = plt.subplots(1, 2, figsize=(12, 5.4), layout="constrained")
    ext = grid.extent
    lo_x, hi_x, lo_y, hi_y = ext
    path = grid.path[np.isfinite(grid.path).all(axis=1)] if grid.path.size else grid.path
    if len(path):
        lo_x, hi_x = min(lo_x, float(path[:, 0].min())), max(hi_x, float(path[:, 0].max()))
        lo_y, hi_y = min(lo_y, float(path[:, 1].min())), max(hi_y, float(path[:, 1].max()))
    pad = grid.cell
    panels = ((np.where(visited, mean, np.nan), _friction_scale(vmin, vmax), _MEAN_LABEL),
              (np.where(visited, std, np.nan), std_scale(), _STD_LABEL))
    for ax, (img, (cmap, norm), label) in zip(axes, panels, strict=True):
        draw_no_data(ax)
        if img.size:
            ax.imshow(img, origin="lower", extent=ext, cmap=cmap, norm=norm, interpolation="nearest")
        fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax, label=label, shrink=0.85,
                     extend="max")
        if grid.path.size:
            ax.plot(grid.path[:, 0], grid.path[:, 1], color="0.3", lw=0.5, alpha=0.7, label="driven path")
        if img.size or len(path):
            ax.set_xlim(lo_x - pad, hi_x + pad)
            ax.set_ylim(lo_y - pad, hi_y + pad)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_aspect("equal")
    axes[0].set_title(title or f"friction map, {grid.cell:g} m cells, {int(visited.sum())} cells observed",
                      fontsize=10)
    axes[1].set_title(f"uncertainty ({int(grid.n_obs.sum())} excited observations)", fontsize=10)
    _legend(fig, axes[0], bool(grid.path.size))
    return fig


def plot_grid(grid: FrictionGrid | HexGrid, path: str | Path, *, title: str | None = None,
              vmin: float | None = None, vmax: float | None = None, min_obs: int = 1) -> None:
    """Write :func:`grid_figure` as a PNG to ``path``."""
    fig = grid_figure(grid, title=title, min_obs=min_obs, vmin=vmin, vmax=vmax)
    fig.savefig(path, dpi=120)
    plt.close(fig)
