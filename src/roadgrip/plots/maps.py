"""Friction-map figures: absolute friction per cell over the driven path, and its uncertainty."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import Normalize

from roadgrip.mapping import FrictionGrid

__all__ = ["plot_grid"]


def plot_grid(
    grid: FrictionGrid,
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
    grid : FrictionGrid
    path : str or Path
        Output ``.png``.
    title : str, optional
    vmin, vmax : float, optional
        Colour range of friction [-]; default the range of visited cells,
        widened to at least 0.3.
    min_obs : int
        Cells shown in the mean panel.
    """
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
