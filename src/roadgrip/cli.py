"""The ``roadgrip`` command line (typer + rich).

Every command that takes a drive accepts a canonical CSV/Parquet file or a
shared data set (``--format dart|frictionmaps``, detected where unambiguous).
Errors are printed as one line, ``error: ...``, with exit status 2.
"""

from __future__ import annotations

import sys
from pathlib import Path
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


def _load(path: str, fmt: str | None, vehicle: str | None):
    from roadgrip.io import read_drive

    return read_drive(path, format=fmt, vehicle=vehicle)


@app.command()
def simulate(
    scenario: Annotated[str, typer.Argument(help="Scenario name (see `roadgrip scenarios`).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Output .parquet or .csv.")],
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
    engine: Annotated[str | None, typer.Option(
        help="Simulation engine: the scenario's own single-track model (default) or 'multibody'."
    )] = None,
    vehicle: Annotated[str | None, typer.Option(
        help="Multi-body vehicle: ford-escort (default) or vw-vanagon."
    )] = None,
    duration: Annotated[float | None, typer.Option(help="Simulated time [s] (default: the scenario's).")] = None,
) -> None:
    """Simulate a named scenario with full ground truth."""
    from roadgrip.sim.scenarios import simulate_scenario

    drive = simulate_scenario(scenario, seed=seed, progress=True, engine=engine, vehicle=vehicle,
                              duration=duration)
    drive.save(output)
    console.print(f"wrote {output}: {drive.n} samples, {drive.duration:.1f} s at "
                  f"{drive.meta.sample_rate:.0f} Hz")


@app.command()
def scenarios() -> None:
    """List the named scenarios."""
    from rich.table import Column, Table

    from roadgrip.sim.scenarios import SCENARIOS

    table = Table("engines", "vehicle", "duration [s]", "rate [Hz]", "description")
    table.columns.insert(0, Column("name", no_wrap=True))
    for name, sc in SCENARIOS.items():
        vehicles = sc.vehicle if sc.build is not None else "ford-escort, vw-vanagon"
        if sc.build is not None and "multibody" in sc.engines:
            vehicles += " (multibody: ford-escort, vw-vanagon)"
        table.add_row(name, ", ".join(sc.engines), vehicles, f"{sc.duration:.0f}",
                      f"{sc.output_rate:.0f}", sc.description)
    console.print(table)


@app.command()
def info(
    file: Annotated[str, typer.Argument(help="Drive file or data-set path.")],
    fmt: FormatOpt = None,
    vehicle: VehicleOpt = None,
) -> None:
    """Duration, rates, signal ranges and tire excitation of a drive."""
    from roadgrip.io import describe_drive

    console.print(describe_drive(_load(file, fmt, vehicle)))


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
    drive = _load(drive_path, fmt, vehicle)
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


@app.command()
def calibrate(
    drives: Annotated[list[str], typer.Argument(metavar="DRIVE:LABEL...", help="Labelled drives (label high or low).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="calibration.yaml")],
    vehicle: VehicleOpt = None,
    fmt: FormatOpt = None,
) -> None:
    """Learn bRLS / slipmap references and thresholds from labelled drives."""
    from roadgrip.estimators.brls import calibrate_cli

    calibrate_cli(drives, output, vehicle=vehicle, fmt=fmt, console=console)


@app.command("map")
def map_cmd(
    inputs: Annotated[list[str], typer.Argument(metavar="ESTIMATES_OR_DRIVES...", help="Estimates/drives, or `show MAP.npz`.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="map.npz (or map.png for `show`).")],
    cell: Annotated[float, typer.Option(help="Cell size [m].")] = 0.5,
    csv: Annotated[Path | None, typer.Option(help="Write cells as CSV.")] = None,
    png: Annotated[Path | None, typer.Option(help="Write a PNG heat map.")] = None,
    vehicle: VehicleOpt = None,
    fmt: FormatOpt = None,
) -> None:
    """Fuse friction estimates into a spatial grid (`roadgrip map show MAP -o PNG` to plot)."""
    from roadgrip import mapping

    if inputs and inputs[0] == "show":
        if len(inputs) != 2:
            raise ValueError("usage: roadgrip map show MAP.npz -o MAP.png")
        mapping.show_cli(inputs[1], output, console=console)
        return
    mapping.map_cli(inputs, output, cell=cell, csv=csv, png=png, vehicle=vehicle, fmt=fmt, console=console)


@app.command()
def bench(
    output: Annotated[Path, typer.Option("-o", "--output", help="Output folder for the table.")] = Path("bench"),
    quick: Annotated[bool, typer.Option(help="Reduced run (under 2 minutes).")] = False,
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
) -> None:
    """Run every estimator on every scenario (and the real data where present)."""
    from roadgrip.evaluate import bench_cli

    bench_cli(output, quick=quick, seed=seed, console=console)


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


def main() -> None:
    """Console entry point: one-line errors instead of tracebacks."""
    try:
        app(standalone_mode=False)
    except typer.Exit as exc:
        sys.exit(exc.exit_code)
    except (typer.Abort, KeyboardInterrupt):
        err_console.print("aborted")
        sys.exit(130)
    except Exception as exc:  # the CLI's contract is one clear line
        if hasattr(exc, "show") and hasattr(exc, "exit_code"):  # usage errors
            exc.show()
            sys.exit(exc.exit_code)
        if isinstance(exc, ModuleNotFoundError) and exc.name and exc.name.startswith("roadgrip"):
            msg = f"this command is not available in this build ({exc.name} missing)"
        else:
            msg = str(exc) or type(exc).__name__
        err_console.print(f"[bold red]error:[/] {msg}", highlight=False, soft_wrap=True)
        sys.exit(2)


if __name__ == "__main__":
    main()
