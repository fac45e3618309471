"""Command ``roadgrip map``: friction estimates fused into a spatial grid (:mod:`roadgrip.mapping`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import numpy as np
import typer

from roadgrip.cli._common import (
    ChannelsOpt,
    FormatOpt,
    TopicsOpt,
    VehicleOpt,
    app,
    console,
    load_drive,
)

if TYPE_CHECKING:
    import pandas as pd

    from roadgrip.mapping import FrictionGrid


def _estimates_table(path: str, vehicle: str | None, fmt: str | None,
                     topics: str | None = None, channels: str | None = None) -> tuple[pd.DataFrame, str]:
    """The estimates of ``path``: an estimates Parquet file as written, a drive through the cascade."""
    from roadgrip.cli.options import ESTIMATE_KEY
    from roadgrip.estimators import EstimateResult, run_estimator

    p = Path(path)
    if p.is_file() and p.suffix.lower() in (".parquet", ".pq"):
        import pyarrow as pa
        import pyarrow.parquet as pq

        try:
            md = pq.read_schema(str(p)).metadata or {}
        except (OSError, pa.ArrowException):  # truncated or not Parquet: the drive reader says so, by name
            md = {}
        if ESTIMATE_KEY in md:
            res = EstimateResult.read_parquet(p)
            return res.table, f"estimates ({res.method})"
    drive = load_drive(path, fmt, vehicle, topics, channels)
    return run_estimator("cascade", drive).table, "drive (cascade run)"


def map_files(
    inputs: list[str],
    output: str | Path,
    *,
    cell: float = 0.5,
    csv: str | Path | None = None,
    png: str | Path | None = None,
    vehicle: str | None = None,
    fmt: str | None = None,
    console: Any = None,
    topics: str | None = None,
    channels: str | None = None,
) -> FrictionGrid:
    """Grids of estimates files or drives (cascade), merged and written to ``output`` (NPZ).

    Each input is an estimates Parquet file (any method, with ``x, y``) or a
    drive (canonical file or data set), on which the cascade is run. ``csv``
    and ``png`` also write the visited cells and a heat map; ``console``
    (rich) receives a line per input and the map's summary.
    """
    from roadgrip.mapping import grid_from_estimates, merge

    if not inputs:
        raise ValueError("roadgrip map needs at least one estimates file or drive")
    if not (np.isfinite(cell) and cell > 0):
        raise ValueError(f"--cell must be a positive size in m, got {cell}")
    grids = []
    for path in inputs:
        table, kind = _estimates_table(path, vehicle, fmt, topics, channels)
        try:
            g = grid_from_estimates(table, cell)
        except ValueError as exc:  # several inputs: say which
            raise ValueError(f"{Path(path).name}: {exc}") from None
        grids.append(g)
        if console is not None:
            n = g.cells.n_obs
            console.print(f"{path}: {kind}, {int(n.sum())} excited observations in "
                          f"{int((n > 0).sum())} cells")
    grid = merge(*grids)
    grid.to_npz(output)
    if csv:
        grid.to_csv(csv)
    if png:
        from roadgrip.plots.maps import plot_grid

        plot_grid(grid, png)
    if console is not None:
        # the observed cells only: the map's bounding box may be far too large to view
        visited = grid.cells.n_obs > 0
        mean, std = grid.cell_posterior()
        if visited.any():
            console.print(f"map: {int(visited.sum())} cells of {grid.cell} m, mu {mean[visited].min():.2f}"
                          f"..{mean[visited].max():.2f}, median std {np.median(std[visited]):.3f}")
        console.print(f"wrote {output}" + (f", {csv}" if csv else "") + (f", {png}" if png else ""))
    return grid


def show_map(map_path: str | Path, output: str | Path, *, console: Any = None) -> None:
    """``roadgrip map show MAP.npz -o MAP.png``: the heat map of a written grid."""
    from roadgrip.mapping import FrictionGrid
    from roadgrip.plots.maps import plot_grid

    plot_grid(FrictionGrid.from_npz(map_path), output)
    if console is not None:
        console.print(f"wrote {output}")


@app.command("map")
def map_cmd(
    inputs: Annotated[list[str], typer.Argument(metavar="ESTIMATES_OR_DRIVES...", help="Estimates/drives, or `show MAP.npz`.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="map.npz (or map.png for `show`).")],
    cell: Annotated[float, typer.Option(help="Cell size [m].")] = 0.5,
    csv: Annotated[Path | None, typer.Option(help="Write cells as CSV.")] = None,
    png: Annotated[Path | None, typer.Option(help="Write a PNG heat map.")] = None,
    vehicle: VehicleOpt = None,
    fmt: FormatOpt = None,
    topics: TopicsOpt = None,
    channels: ChannelsOpt = None,
) -> None:
    """Fuse friction estimates into a spatial grid (`roadgrip map show MAP -o PNG` to plot)."""
    from roadgrip.cli import options as opt

    if inputs and inputs[0] == "show":
        if len(inputs) != 2:
            raise ValueError("usage: roadgrip map show MAP.npz -o MAP.png")
        opt.check_input(inputs[1])
        opt.check_output(output, "--output", (".png", ".pdf", ".svg"))
        show_map(inputs[1], output, console=console)
        return
    for path in inputs:
        opt.check_input(path)
    opt.check_drive_args(None, fmt, vehicle, topics, channels)
    opt.check_cell(cell)
    opt.check_output(output, "--output", (".npz",))
    opt.check_output(csv, "--csv", (".csv",))
    opt.check_output(png, "--png", (".png", ".pdf", ".svg"))
    map_files(inputs, output, cell=cell, csv=csv, png=png, vehicle=vehicle, fmt=fmt, console=console,
              topics=topics, channels=channels)
