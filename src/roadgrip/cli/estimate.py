"""Command ``roadgrip estimate``: one estimator over one drive."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from roadgrip.cli._common import FormatOpt, VehicleOpt, app, console, load_drive


@app.command()
def estimate(
    drive_path: Annotated[str, typer.Argument(metavar="DRIVE", help="Drive file or data-set path.")],
    method: Annotated[str, typer.Option(help="gpssm, brls, slipmap or cascade.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="estimates.parquet")],
    vehicle: VehicleOpt = None,
    fmt: FormatOpt = None,
    particles: Annotated[int | None, typer.Option(help="gpssm: number of particles.")] = None,
    basis: Annotated[str | None, typer.Option(help="gpssm: tensor:10x10 (paper), separable:20, or their -odd variants (default separable-odd:20).")] = None,
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
    linalg: Annotated[str | None, typer.Option(help="gpssm: exact (default) or fast linear algebra (docs/gpssm.md).")] = None,
    calibration: Annotated[str | None, typer.Option(help="brls/slipmap: calibration YAML.")] = None,
    curves: Annotated[Path | None, typer.Option(help="gpssm: write posterior curves here.")] = None,
    curve_times: Annotated[str | None, typer.Option(help="gpssm: comma-separated times [s].")] = None,
    plot: Annotated[Path | None, typer.Option(help="Write a PNG figure.")] = None,
) -> None:
    """Run one estimator over a drive and write its estimates."""
    from roadgrip.estimators import EstimateRequest, run_estimator

    times = None
    if curve_times:
        try:
            times = tuple(float(s) for s in curve_times.split(","))
        except ValueError:
            raise ValueError(f"--curve-times must be comma-separated seconds, got {curve_times!r}") from None
    drive = load_drive(drive_path, fmt, vehicle)
    request = EstimateRequest(
        seed=seed,
        particles=particles,
        basis=basis,
        calibration=calibration,
        curves_path=str(curves) if curves else None,
        curve_times=times,
        plot_path=str(plot) if plot else None,
        progress=True,
        options={"linalg": linalg} if linalg is not None else {},
    )
    result = run_estimator(method, drive, request)
    result.to_parquet(output)
    from roadgrip.report_text import summary_table

    console.print(summary_table(result))
    console.print(f"wrote {output}")
