"""Shared pieces of the command line: the typer app, consoles, common options.

Every command that takes a drive accepts a canonical CSV/Parquet file, a ROS bag
(``--topics`` topic map), an ASAM MDF4 file (``--channels`` channel map) or a
shared data set (``--format dart|frictionmaps``); the format is detected where
unambiguous.
Errors are printed as one line, ``error: ...``, with exit status 2.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
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
    str | None,
    typer.Option("--format", help="Input format: canonical, dart, frictionmaps, rosbag or mdf."),
]
TopicsOpt = Annotated[
    str | None,
    typer.Option("--topics", help="ROS bags: topic map YAML, or a shipped map's name (default f1tenth)."),
]
ChannelsOpt = Annotated[
    str | None, typer.Option("--channels", help="MDF4 files: channel map YAML.")
]
AlignOpt = Annotated[bool, typer.Option(
    "--align", help="Remove the estimated sensor delays (those reported reliable) before use.")]


def load_drive(path: str, fmt: str | None, vehicle: str | None,
               topics: str | None = None, channels: str | None = None):
    """Read a drive file or data set (:func:`roadgrip.io.read_drive`)."""
    from roadgrip.io import read_drive

    return read_drive(path, format=fmt, vehicle=vehicle, topics=topics, channels=channels)


@contextmanager
def progress_bar(label: str, total: int) -> Iterator[Callable[[int], None]]:
    """A transient progress bar; yields the callback advancing it by a number of steps."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    with Progress(TextColumn(label), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                  TimeRemainingColumn(), console=console, transient=True) as prog:
        task = prog.add_task(label, total=total)
        yield lambda k: prog.advance(task, k)
