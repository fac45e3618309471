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
    from roadgrip.cli.options import check_folder_output, check_input
    from roadgrip.report import write_report

    for path in inputs:
        check_input(path)
    check_folder_output(output, "--output")

    path = write_report(inputs, output,
                        on_run=lambda method, name: console.print(f"running {method} on {name} ..."))
    console.print(f"report: {path.resolve()}")


@app.command()
def demo(
    out: Annotated[Path, typer.Option("--out", help="Report folder.")] = Path("report"),
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
) -> None:
    """Simulate the built-in drives, run every estimator, write the report."""
    from roadgrip.cli.options import check_folder_output, check_seed

    check_seed(seed)
    check_folder_output(out, "--out")
    from roadgrip.cli.bench import bench_renderable, case_progress
    from roadgrip.evaluate.cases import DEMO, default_cases
    from roadgrip.report import run_demo

    with case_progress("demo", len(default_cases(DEMO))) as (on_case, on_done):
        path, table = run_demo(out, seed=seed, settings=DEMO, on_case=on_case, on_done=on_done)
    console.print(bench_renderable(table, title=f"roadgrip demo benchmark (seed {seed})"))
    console.print(f"report written to {path.resolve()}")
