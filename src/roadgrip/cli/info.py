"""Command ``roadgrip info``: what a drive holds."""

from __future__ import annotations

from typing import Annotated

import typer

from roadgrip.cli._common import FormatOpt, VehicleOpt, app, console, load_drive


@app.command()
def info(
    file: Annotated[str, typer.Argument(help="Drive file or data-set path.")],
    fmt: FormatOpt = None,
    vehicle: VehicleOpt = None,
) -> None:
    """Duration, rates, signal ranges and tire excitation of a drive."""
    from roadgrip.io import describe_drive

    console.print(describe_drive(load_drive(file, fmt, vehicle)))
