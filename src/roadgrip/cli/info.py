"""Command ``roadgrip info``: what a drive holds."""

from __future__ import annotations

from typing import Annotated

import typer
from rich.console import Group
from rich.table import Table

from roadgrip.cli._common import FormatOpt, VehicleOpt, app, console, load_drive


def render(sections) -> Group:
    """Rich tables of :func:`roadgrip.io.describe.describe_drive`'s sections."""
    tables = []
    for sec in sections:
        table = Table(title=sec.title, show_header=sec.header)
        for i, name in enumerate(sec.columns):
            table.add_column(name, justify="right" if name in sec.right else "left",
                             style="bold" if not sec.header and i == 0 else None)
        for row in sec.rows:
            table.add_row(*row)
        tables.append(table)
    return Group(*tables)


@app.command()
def info(
    file: Annotated[str, typer.Argument(help="Drive file or data-set path.")],
    fmt: FormatOpt = None,
    vehicle: VehicleOpt = None,
) -> None:
    """Duration, rates, signal ranges and tire excitation of a drive."""
    from roadgrip.io import describe_drive

    console.print(render(describe_drive(load_drive(file, fmt, vehicle))))
