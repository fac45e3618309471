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
        help="Multi-body vehicle: ford-escort (default), vw-vanagon, or random:SEED (a vehicle "
             "sampled around those two, its parameters in the drive's metadata)."
    )] = None,
    sensors: Annotated[str | None, typer.Option(
        help="Multi-body sensors: ideal (noise only; default for a named vehicle) or realistic "
             "(latency, bias, drift, scale, quantisation, dropouts, steering errors; default for random:SEED)."
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
    if multibody and vehicle is not None and vehicle.startswith("random:"):
        if not vehicle[len("random:"):].isdigit():
            raise ValueError(f"--vehicle must be one of {', '.join(MB_VEHICLES)} or random:SEED "
                             f"(SEED a whole number), got {vehicle!r}")
        opt.check_seed(int(vehicle[len("random:"):]), "--vehicle random:SEED")
    else:
        opt.check_choice(vehicle, "--vehicle", (*MB_VEHICLES, "random:SEED") if multibody else (sc.vehicle,))
    if sensors is not None and not multibody:
        raise ValueError("--sensors applies to the multibody engine (--engine multibody)")
    opt.check_choice(sensors, "--sensors", ("ideal", "realistic"))
    opt.check_seed(seed)
    opt.check_output(output, "--output", (".parquet", ".pq", ".csv"))
    opt.check_duration(duration, sc.output_rate)

    drive = simulate_scenario(scenario, seed=seed, progress=True, engine=engine, vehicle=vehicle,
                              sensors=sensors, duration=duration)
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
        vehicles = sc.vehicle if sc.build is not None else "ford-escort, vw-vanagon, random:SEED"
        if sc.build is not None and "multibody" in sc.engines:
            vehicles += " (multibody: ford-escort, vw-vanagon, random:SEED)"
        table.add_row(name, ", ".join(sc.engines), vehicles, f"{sc.duration:.0f}",
                      f"{sc.output_rate:.0f}", sc.description)
    console.print(table)
