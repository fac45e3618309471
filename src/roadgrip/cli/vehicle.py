"""Commands ``roadgrip vehicle template``, ``list`` and ``fit``: describing a vehicle."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from roadgrip.cli._common import (
    ChannelsOpt,
    FormatOpt,
    PlainHelpTyper,
    TopicsOpt,
    VehicleOpt,
    app,
    console,
    load_drive,
)

vehicle_app = PlainHelpTyper(no_args_is_help=True, help="Vehicle descriptions: presets and a YAML template.")
app.add_typer(vehicle_app, name="vehicle")


@vehicle_app.command("template")
def template(
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="Write the template to this .yaml file (default: print it)."
    )] = None,
    force: Annotated[bool, typer.Option(help="Overwrite an existing file.")] = False,
) -> None:
    """A commented vehicle YAML: every field with its unit, meaning and accepted range."""
    from roadgrip.vehicle.params import template_yaml

    text = template_yaml()
    if output is None:
        console.print(text, end="", highlight=False, markup=False, soft_wrap=True)
        return
    if output.suffix.lower() not in (".yaml", ".yml"):
        raise ValueError(f"vehicle file {output.name!r} must end in .yaml or .yml")
    if not output.parent.is_dir():
        raise ValueError(f"folder {output.parent} does not exist")
    if output.exists() and not force:
        raise ValueError(f"{output} exists; pass --force to overwrite it")
    output.write_text(text)
    console.print(f"wrote {output} (edit the values; `name` defaults to {output.stem!r})",
                  highlight=False)


@vehicle_app.command("list")
def list_presets() -> None:
    """The shipped presets, with the multi-body simulator's vehicles marked."""
    from roadgrip.sim.mb_model import COMMONROAD_VEHICLES
    from roadgrip.vehicle.params import PRESETS

    table = Table(title="vehicle presets (--vehicle NAME)")
    for col in ("name", "mass (kg)", "wheelbase (m)", "CG height (m)", "drive", "multi-body"):
        table.add_column(col, justify="left" if col in ("name", "drive", "multi-body") else "right")
    for name, v in PRESETS.items():
        table.add_row(name, f"{v.mass:.4g}", f"{v.wheelbase:.3g}", f"{v.cg_height:.3g}", v.drive,
                      "yes" if name in COMMONROAD_VEHICLES else "")
    console.print(table)
    console.print("multi-body: also a vehicle of `roadgrip simulate --engine multibody --vehicle NAME`",
                  highlight=False)


@vehicle_app.command("fit")
def fit(
    file: Annotated[str, typer.Argument(help="Drive file or data-set path.")],
    output: Annotated[Path | None, typer.Option(
        "-o", "--output", help="Write the fitted vehicle to this .yaml file (default: print the table).")] = None,
    fmt: FormatOpt = None,
    vehicle: VehicleOpt = None,
    topics: TopicsOpt = None,
    channels: ChannelsOpt = None,
    mu: Annotated[float, typer.Option(
        help="Friction of the road driven [-]: the linear range is |a_y| < 0.4 mu g.")] = 1.0,
    roll_lag: Annotated[float | None, typer.Option(
        help="The body's roll behind the lateral acceleration [s], taken off the accelerometer's "
             "delay in proportion to the roll's share of its reading (from the vehicle's "
             "roll_gradient); 0: none; default roadgrip.inference.channel_delays.ROLL_LAG.")] = None,
    start: Annotated[float | None, typer.Option(help="Use the samples from this time [s].")] = None,
    end: Annotated[float | None, typer.Option(help="Use the samples before this time [s].")] = None,
    force: Annotated[bool, typer.Option(help="Overwrite an existing file.")] = False,
) -> None:
    """Identify cornering stiffnesses, steering offset, scale and delay, sensor delays, the
    accelerometer's gains and biases and the wheel radius from a drive, each with its
    standard error; what the drive cannot tell is named and kept from the vehicle."""
    import math

    from roadgrip.cli.options import check_drive_args, check_output
    from roadgrip.inference.vehicle_identification import fit_vehicle

    check_drive_args(file, fmt, vehicle, topics, channels)
    check_output(output, "--output", (".yaml", ".yml"))
    if output is not None and output.exists() and not force:
        raise ValueError(f"{output} exists; pass --force to overwrite it")
    if not (math.isfinite(mu) and 0.0 < mu <= 2.0):
        raise ValueError(f"--mu must be in (0, 2], got {mu!r}")
    if roll_lag is not None and not (math.isfinite(roll_lag) and 0.0 <= roll_lag <= 0.5):
        raise ValueError(f"--roll-lag must be in [0, 0.5] s, got {roll_lag!r}")
    drive = load_drive(file, fmt, vehicle, topics, channels)
    t = drive.t
    t0 = t[0] if start is None else start
    t1 = t[-1] + 1.0 if end is None else end
    if start is not None or end is not None:
        drive = drive.slice_time(t0, t1)
    res = fit_vehicle(drive, mu=mu) if roll_lag is None else fit_vehicle(drive, mu=mu, roll_lag=roll_lag)
    table = Table(title=f"vehicle fit: {Path(file).name}, {drive.duration:.1f} s, "
                        f"{res.samples} linear-range samples")
    for col in ("quantity", "value", "std. error", "unit", "status"):
        table.add_column(col, justify="right" if col in ("value", "std. error") else "left",
                         no_wrap=col == "quantity")
    for v in res.values.values():
        val = f"{v.value:.5g}" if math.isfinite(v.value) else "-"
        sd = f"{v.std:.2g}" if math.isfinite(v.std) else "-"
        table.add_row(v.name, val, sd, v.unit, v.status)
    console.print(table)
    for v in res.values.values():
        if not v.fitted:
            console.print(f"{v.name}: undetermined, {v.note}", highlight=False)
    if output is not None:
        output.write_text(res.to_yaml())
        console.print(f"wrote {output} (use it with --vehicle {output})", highlight=False)
