"""`--help` shows every help text as written, units in brackets included, and `--vehicle`'s
help names the same presets as its error."""

from __future__ import annotations

import inspect
import re

import click
import pytest
import typer.main
from typer.testing import CliRunner
from typer.utils import get_params_from_function

from roadgrip.cli import app

WIDE = {"COLUMNS": "250"}
UNIT = re.compile(r"\[[^\[\]]+\]")
ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


def _flat(text: str) -> str:
    """Help output as one line of words: colours, panel borders and line breaks removed
    (a help text wrapped over lines reads as written)."""
    return " ".join(re.sub("[│╭╮╰╯─]", " ", ANSI.sub("", text)).split())


def _commands(group: click.Command, path: tuple[str, ...] = ()):
    for name, cmd in group.commands.items():
        if hasattr(cmd, "commands"):  # a group (typer's groups are no click.Group)
            yield from _commands(cmd, (*path, name))
        else:
            yield (*path, name), cmd


def _declared(cmd: click.Command) -> list[tuple[str, str]]:
    """(option, help as written in the source) of each parameter of ``cmd`` with a help text
    (the option ``None`` for an argument)."""
    declared = get_params_from_function(inspect.unwrap(cmd.callback))
    out = []
    for p in cmd.params:
        meta = declared.get(p.name)
        text = getattr(meta.default, "help", None) if meta is not None else None
        if text:
            out.append((max(p.opts, key=len) if p.param_type_name == "option" else None, text))
    return out


COMMANDS = dict(_commands(typer.main.get_command(app)))
WITH_UNITS = {path: [(name, text) for name, text in _declared(cmd) if UNIT.search(text)]
              for path, cmd in COMMANDS.items()}
WITH_UNITS = {path: helps for path, helps in WITH_UNITS.items() if helps}


def test_the_scan_finds_the_options_with_units():
    found = {(" ".join(path), name) for path, helps in WITH_UNITS.items() for name, _ in helps}
    assert {("estimate", "--curve-times"), ("map", "--cell"), ("fleet", "--cell"), ("fleet", "--decay-hours"),
            ("fleet", "--origin"), ("simulate", "--duration")} <= found, found


@pytest.mark.parametrize("path", list(WITH_UNITS), ids=" ".join)
def test_help_shows_the_units_of_every_option(path):
    res = CliRunner().invoke(app, [*path, "--help"], env=WIDE)
    assert res.exit_code == 0, res.output
    out = _flat(res.output)
    for name, text in WITH_UNITS[path]:
        assert name is None or name in out
        assert " ".join(text.split()) in out, f"{' '.join(path)} {name}: {text!r} not shown as written"


@pytest.mark.parametrize("path", list(COMMANDS), ids=" ".join)
def test_command_help_shows_its_brackets(path):
    """Every command's own description too (none carries a unit today; the next one will)."""
    doc = inspect.getdoc(inspect.unwrap(COMMANDS[path].callback)) or ""
    res = CliRunner().invoke(app, [*path, "--help"], env=WIDE)
    assert res.exit_code == 0, res.output
    out = _flat(res.output)
    assert " ".join(doc.split("\n\n")[0].split()) in out
    for unit in UNIT.findall(doc):
        assert unit in out


# -- --vehicle: the presets of the help are those of the error -----------------------------
VEHICLE_COMMANDS = [path for path, cmd in COMMANDS.items()
                    if any("--vehicle" in p.opts and (p.help or "").startswith("Preset name") for p in cmd.params)]


def _listed(text: str, pattern: str) -> set[str]:
    m = re.search(pattern, text)
    assert m is not None, f"{pattern!r} not in {text!r}"
    return {name.strip() for name in m.group(1).split(",")}


def test_every_drive_command_takes_a_preset():
    assert {("info",), ("estimate",), ("calibrate",), ("map",), ("fleet",)} <= set(VEHICLE_COMMANDS)


@pytest.mark.parametrize("path", VEHICLE_COMMANDS, ids=" ".join)
def test_vehicle_help_and_error_name_the_same_presets(path, tmp_path):
    from roadgrip.vehicle.params import PRESETS

    res = CliRunner().invoke(app, [*path, "--help"], env=WIDE)
    in_help = _listed(_flat(res.output), r"--vehicle <str> Preset name \(([^)]*)\) or YAML file")
    drive = tmp_path / "drive.csv"  # exists; the vehicle is refused before any file is read
    drive.write_text("t,ay\n0,0\n")
    args = {"calibrate": [f"{drive}:high", f"{drive}:low", "-o", str(tmp_path / "c.yaml")],
            "fleet": [str(drive), "-o", str(tmp_path / "f.parquet")],
            "map": [str(drive), "-o", str(tmp_path / "m.npz")],
            "estimate": [str(drive), "--method", "brls", "-o", str(tmp_path / "e.parquet")],
            "live": []}.get(path[0], [str(drive)])
    res = CliRunner().invoke(app, [*path, *args, "--vehicle", "tractor"])
    assert res.exit_code != 0
    message = str(res.exception)
    assert message.startswith("--vehicle: unknown vehicle 'tractor'"), message
    in_error = _listed(message, r"not a preset \(([^)]*)\)")
    assert in_help == in_error == set(PRESETS)
