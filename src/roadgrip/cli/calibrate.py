"""Command ``roadgrip calibrate``: classifier references and thresholds from labelled drives."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from roadgrip.cli._common import FormatOpt, VehicleOpt, app, console


@app.command()
def calibrate(
    drives: Annotated[list[str], typer.Argument(metavar="DRIVE:LABEL...", help="Labelled drives (label high or low).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="calibration.yaml")],
    vehicle: VehicleOpt = None,
    fmt: FormatOpt = None,
) -> None:
    """Learn bRLS / slipmap references and thresholds from labelled drives."""
    from roadgrip.estimators.brls import calibrate_cli

    calibrate_cli(drives, output, vehicle=vehicle, fmt=fmt, console=console)
