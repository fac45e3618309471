"""Command ``roadgrip info``: what a drive holds."""

from __future__ import annotations

from typing import Annotated

import typer
from rich.console import Group
from rich.table import Table

from roadgrip.cli._common import (
    ChannelsOpt,
    FormatOpt,
    TopicsOpt,
    VehicleOpt,
    app,
    console,
    load_drive,
)


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
    topics: TopicsOpt = None,
    channels: ChannelsOpt = None,
) -> None:
    """Duration, rates, signal ranges and tire excitation of a drive."""
    from roadgrip.cli.options import check_drive_args
    from roadgrip.io import describe_drive

    check_drive_args(file, fmt, vehicle, topics, channels)
    drive = load_drive(file, fmt, vehicle, topics, channels)
    console.print(render(describe_drive(drive)))
    sources = source_table(drive.meta.extra)
    if sources is not None:
        console.print(sources)


def source_table(extra: dict) -> Table | None:
    """The streams of a ROS bag or MDF4 file: rate, count and use, or None for other drives.

    Reads ``meta.extra['source_rates_hz']`` / ``['source_counts']`` and, where the
    reader gives them, which source fills which column and which were not used.
    """
    rates = extra.get("source_rates_hz") if isinstance(extra, dict) else None
    if not rates:
        return None
    counts = extra.get("source_counts") or {}
    used: dict[str, list[str]] = {}
    for section in ("signals", "extras"):
        for col, e in ((extra.get("topic_map") or {}).get(section) or {}).items():
            used.setdefault(e["topic"], []).append(col)
    units = extra.get("units") or {}
    for col, name in (extra.get("channel_map") or {}).items():
        used.setdefault(name, []).append(f"{col} (in {units[col]})" if col in units else col)
    title = "source topics" if extra.get("format") == "rosbag" else "source channels"
    table = Table(title=title)
    for name, right in (("source", False), ("rate [Hz]", True), ("samples", True), ("fills", False)):
        table.add_column(name, justify="right" if right else "left")
    for name, hz in rates.items():
        table.add_row(name, f"{hz:.2f}", str(counts.get(name, "")), ", ".join(used.get(name, [])) or "unused")
    for name in extra.get("channels_unused") or ():
        table.add_row(name, "", "", "unused")
    if extra.get("interpolation"):
        table.caption = f"time base: {extra['interpolation']}"
    return table
