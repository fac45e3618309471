"""Commands ``roadgrip simulate`` and ``roadgrip scenarios``: simulated drives with ground truth."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from roadgrip.cli._common import app, console


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
    from roadgrip.cli import options as opt
    from roadgrip.sim.scenarios import MB_VEHICLES, SCENARIOS, simulate_scenario

    opt.check_choice(scenario, "SCENARIO", SCENARIOS)
    sc = SCENARIOS[scenario]
    opt.check_choice(engine, "--engine", sc.engines)
    multibody = (engine or sc.engines[0]) == "multibody"
    opt.check_choice(vehicle, "--vehicle", MB_VEHICLES if multibody else (sc.vehicle,))
    opt.check_seed(seed)
    opt.check_output(output, "--output", (".parquet", ".pq", ".csv"))
    opt.check_duration(duration, sc.output_rate)

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
