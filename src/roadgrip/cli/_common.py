"""Shared pieces of the command line: the typer app, consoles, common options.

Every command that takes a drive accepts a canonical CSV/Parquet file, a ROS bag
(``--topics`` topic map), an ASAM MDF4 file (``--channels`` channel map) or a
shared data set (``--format dart|frictionmaps``); the format is detected where
unambiguous.
Errors are printed as one line, ``error: ...``, with exit status 2.

Help texts are plain text: :class:`PlainHelpTyper` makes every command and group
escape its help for rich, so that a unit written in it (``[s]``, ``[m]``) is shown
and not taken for a markup tag.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Annotated, Any

import typer
import typer.core
from rich.console import Console
from rich.markup import escape

from roadgrip.cli.options import vehicle_presets


def _escape_help(cmd: typer.core.TyperCommand | typer.core.TyperGroup) -> None:
    """Escape the help of ``cmd`` and of its options for rich, where typer reads it as markup."""
    if not (typer.core.HAS_RICH and cmd.rich_markup_mode == "rich"):
        return  # click's plain help shows the text as written
    cmd.help = escape(cmd.help) if cmd.help else cmd.help
    cmd.short_help = escape(cmd.short_help) if cmd.short_help else cmd.short_help
    for param in cmd.params:
        text = getattr(param, "help", None)  # arguments and options of typer; click's arguments have none
        if text:
            param.help = escape(text)


class PlainHelpCommand(typer.core.TyperCommand):
    """A command whose help texts are plain text (:func:`_escape_help`)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        _escape_help(self)


class PlainHelpGroup(typer.core.TyperGroup):
    """A group whose help texts are plain text (:func:`_escape_help`)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        _escape_help(self)


class PlainHelpTyper(typer.Typer):
    """``typer.Typer`` whose groups and commands show their help texts as written.

    Typer renders help as rich markup by default, in which ``[s]`` is a style tag and
    vanishes ("Cell size ." for "Cell size [m]."); escaping here, once, keeps every help
    string of the command line written as plain text.
    """

    def __init__(self, **kwargs: Any) -> None:
        kwargs.setdefault("cls", PlainHelpGroup)
        super().__init__(**kwargs)

    def command(self, name: str | None = None, **kwargs: Any) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
        kwargs.setdefault("cls", PlainHelpCommand)
        return super().command(name, **kwargs)


app = PlainHelpTyper(
    add_completion=False,
    no_args_is_help=True,
    help="Online tire-road friction estimation and mapping.",
    pretty_exceptions_enable=False,
)
console = Console()
err_console = Console(stderr=True)

VehicleOpt = Annotated[
    str | None, typer.Option("--vehicle", help=f"Preset name ({vehicle_presets()}) or YAML file.")
]
FormatOpt = Annotated[
    str | None,
    typer.Option("--format", help="Input format: canonical, dart, frictionmaps, rosbag, mdf or can."),
]
TopicsOpt = Annotated[
    str | None,
    typer.Option("--topics", help="ROS bags: topic map YAML, or a shipped map's name (default f1tenth)."),
]
ChannelsOpt = Annotated[
    str | None, typer.Option("--channels", help="MDF4 files: channel map YAML; CAN logs: signal map YAML "
                             "(default the shipped one).")
]
DbcOpt = Annotated[
    str | None, typer.Option("--dbc", help="CAN logs (.blf, .asc, .trc): the DBC file.")
]
AlignOpt = Annotated[bool, typer.Option(
    "--align", help="Remove the estimated sensor delays (those reported reliable) before use.")]


def load_drive(path: str, fmt: str | None, vehicle: str | None,
               topics: str | None = None, channels: str | None = None, dbc: str | None = None):
    """Read a drive file or data set (:func:`roadgrip.io.read_drive`, which applies the
    sensor calibration of a vehicle file: ``roadgrip vehicle fit`` writes it)."""
    from roadgrip.io import read_drive

    return read_drive(path, format=fmt, vehicle=vehicle, topics=topics, channels=channels, dbc=dbc)


@contextmanager
def progress_bar(label: str, total: int) -> Iterator[Callable[[int], None]]:
    """A transient progress bar; yields the callback advancing it by a number of steps."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    with Progress(TextColumn(label), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                  TimeRemainingColumn(), console=console, transient=True) as prog:
        task = prog.add_task(label, total=total)
        yield lambda k: prog.advance(task, k)
