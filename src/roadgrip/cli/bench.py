"""Command ``roadgrip bench``: every estimator on every drive."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from roadgrip.cli._common import app, console


@app.command()
def bench(
    output: Annotated[Path, typer.Option("-o", "--output", help="Output folder for the table.")] = Path("bench"),
    quick: Annotated[bool, typer.Option(help="Reduced run (under 2 minutes).")] = False,
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
) -> None:
    """Run every estimator on every scenario (and the real data where present)."""
    from roadgrip.evaluate import bench_cli

    bench_cli(output, quick=quick, seed=seed, console=console)
