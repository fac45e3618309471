"""Command ``roadgrip bench``: every estimator on every drive."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Group
from rich.text import Text

from roadgrip.cli._common import app, console


def bench_renderable(table, title: str = "benchmark") -> Group:
    """Terminal rendering of a benchmark table: per run one line of speed and status,
    one line of accuracy and one of the honesty rule's figures (a wide table does not fit
    a terminal; this stays readable at 80 columns)."""
    from roadgrip.evaluate.table import accuracy_summary, format_cell, honesty_summary

    lines = [Text(title, style="bold")]
    for _, row in table.iterrows():
        head = Text(f"{row['drive']} / {row['method']}", style="bold")
        if row["status"] == "ok":
            head.append(f"  {format_cell('samples_per_s', row['samples_per_s'])} samples/s, "
                        f"{format_cell('rtf', row['rtf'])}× real time")
        else:
            head.append(f"  {row['status']}", style="red" if str(row["status"]).startswith("error")
                        else "yellow")
        lines.append(head)
        for summary in (accuracy_summary(row), honesty_summary(row)):
            if summary:
                lines.append(Text("    " + summary))
    return Group(*lines)


@contextmanager
def case_progress(label: str, total: int) -> Iterator[tuple[Callable, Callable]]:
    """A transient bar over the cases; yields the ``on_case`` and ``on_done`` callbacks."""
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                  TimeElapsedColumn(), console=console, transient=True) as progress:
        task = progress.add_task(label, total=total)
        yield (lambda c: progress.update(task, description=f"{c.drive} / {c.label}"),
               lambda r: progress.advance(task))


@app.command()
def bench(
    output: Annotated[Path, typer.Option("-o", "--output", help="Output folder for the table.")] = Path("bench"),
    quick: Annotated[bool, typer.Option(help="Reduced run (under 2 minutes).")] = False,
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
) -> None:
    """Run every estimator on every scenario (and the real data where present)."""
    from roadgrip.cli.options import check_folder_output, check_seed
    from roadgrip.evaluate import suite

    check_seed(seed)
    check_folder_output(output, "--output")
    from roadgrip.evaluate.cases import FULL, QUICK, default_cases, real_data_root

    settings = QUICK if quick else FULL
    cases = default_cases(settings)
    with case_progress("benchmark", len(cases)) as (on_case, on_done):
        table, _ = suite.bench(output, settings, seed=seed, cases=cases, on_case=on_case, on_done=on_done)
    console.print(bench_renderable(table, title=f"roadgrip benchmark (seed {seed}, {settings.name})"))
    if real_data_root() is None and settings.real_data:
        console.print("note: ../shared/data not found; real-data rows skipped")
    console.print(f"wrote {output / 'bench.md'} and {output / 'bench.csv'}")
