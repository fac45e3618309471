"""Commands ``roadgrip vehicle template`` and ``roadgrip vehicle list``: describing a vehicle."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from roadgrip.cli._common import PlainHelpTyper, app, console

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
