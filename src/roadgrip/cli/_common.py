"""Shared pieces of the command line: the typer app, consoles, common options.

Every command that takes a drive accepts a canonical CSV/Parquet file or a
shared data set (``--format dart|frictionmaps``, detected where unambiguous).
Errors are printed as one line, ``error: ...``, with exit status 2.
"""

from __future__ import annotations

from typing import Annotated

import typer
from rich.console import Console

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="Online tire-road friction estimation and mapping.",
    pretty_exceptions_enable=False,
)
console = Console()
err_console = Console(stderr=True)

VehicleOpt = Annotated[
    str | None, typer.Option("--vehicle", help="Preset name (suv, sedan, f1tenth, jetracer) or YAML file.")
]
FormatOpt = Annotated[
    str | None, typer.Option("--format", help="Input format: canonical, dart or frictionmaps.")
]


def load_drive(path: str, fmt: str | None, vehicle: str | None):
    from roadgrip.io import read_drive

    return read_drive(path, format=fmt, vehicle=vehicle)


