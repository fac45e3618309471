"""Commands ``roadgrip report`` and ``roadgrip demo``: the HTML report."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from roadgrip.cli._common import app, console


@app.command()
def report(
    inputs: Annotated[list[str], typer.Argument(metavar="DRIVE_OR_RESULTS...")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Report folder.")] = Path("report"),
) -> None:
    """Write a self-contained HTML report."""
    from roadgrip.report import report_cli

    report_cli(inputs, output, console=console)


@app.command()
def demo(
    out: Annotated[Path, typer.Option("--out", help="Report folder.")] = Path("report"),
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
) -> None:
    """Simulate the built-in drives, run every estimator, write the report."""
    from roadgrip.report import demo_cli

    demo_cli(out, seed=seed, console=console)
