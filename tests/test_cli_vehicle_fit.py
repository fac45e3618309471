"""`roadgrip vehicle fit DRIVE -o car.yaml`: a table of the identified values and a vehicle file
that --vehicle reads; bad options named before the drive is read."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from roadgrip.cli import app
from roadgrip.vehicle import load_vehicle


@pytest.fixture(scope="module")
def drive_file(tmp_path_factory) -> Path:
    from roadgrip.sim.scenarios import simulate_scenario

    p = tmp_path_factory.mktemp("fit") / "dgd.parquet"
    simulate_scenario("dry-gravel-dry", seed=0, duration=60.0).save(p)
    return p


def test_fit_writes_a_vehicle_file(drive_file, tmp_path):
    out = tmp_path / "car.yaml"
    res = CliRunner().invoke(app, ["vehicle", "fit", str(drive_file), "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert "cornering_stiffness_front" in res.output and "steer_offset" in res.output
    v = load_vehicle(out)
    fields = yaml.safe_load(out.read_text())
    assert v.mass == fields["mass"] == 1500.0
    # run again: the file exists
    res = CliRunner().invoke(app, ["vehicle", "fit", str(drive_file), "-o", str(out)])
    assert res.exit_code != 0 and "--force" in str(res.exception or res.output)


@pytest.mark.parametrize(("args", "message"), [
    (["--mu", "0"], "--mu must be in (0, 2]"),
    (["--roll-lag", "-0.01"], "--roll-lag must be in [0, 0.5] s"),
    (["-o", "car.txt"], "--output must name a .yaml or .yml file"),
])
def test_bad_options_are_named(drive_file, args, message):
    res = CliRunner().invoke(app, ["vehicle", "fit", str(drive_file), *args])
    assert res.exit_code != 0
    assert message in str(res.exception) + res.output
