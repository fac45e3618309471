"""Command ``roadgrip map``: friction estimates fused into a spatial grid."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from roadgrip.cli._common import FormatOpt, VehicleOpt, app, console


@app.command("map")
def map_cmd(
    inputs: Annotated[list[str], typer.Argument(metavar="ESTIMATES_OR_DRIVES...", help="Estimates/drives, or `show MAP.npz`.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="map.npz (or map.png for `show`).")],
    cell: Annotated[float, typer.Option(help="Cell size [m].")] = 0.5,
    csv: Annotated[Path | None, typer.Option(help="Write cells as CSV.")] = None,
    png: Annotated[Path | None, typer.Option(help="Write a PNG heat map.")] = None,
    vehicle: VehicleOpt = None,
    fmt: FormatOpt = None,
) -> None:
    """Fuse friction estimates into a spatial grid (`roadgrip map show MAP -o PNG` to plot)."""
    from roadgrip import mapping

    if inputs and inputs[0] == "show":
        if len(inputs) != 2:
            raise ValueError("usage: roadgrip map show MAP.npz -o MAP.png")
        mapping.show_cli(inputs[1], output, console=console)
        return
    mapping.map_cli(inputs, output, cell=cell, csv=csv, png=png, vehicle=vehicle, fmt=fmt, console=console)
