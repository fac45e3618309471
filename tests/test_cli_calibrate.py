"""`roadgrip calibrate` prints what it fitted as a table (parameter, value, unit), the
parameters named as in the calibration file it writes."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from roadgrip.cli import app
from roadgrip.cli.calibrate import read_calibration


@pytest.fixture(scope="module")
def labelled(tmp_path_factory) -> tuple[Path, Path]:
    """The dry and the gravel minute of a simulated dry-gravel-dry drive."""
    from roadgrip.sim.scenarios import simulate_scenario

    drive = simulate_scenario("dry-gravel-dry", seed=2, duration=120.0)
    tmp = tmp_path_factory.mktemp("calibrate")
    hi, lo = tmp / "dry.parquet", tmp / "gravel.parquet"
    drive.slice_time(0, 60).save(hi)
    drive.slice_time(60, 120).save(lo)
    return hi, lo


def _rows(output: str) -> dict[str, tuple[str, str]]:
    """parameter -> (value, unit) of the table's rows."""
    rows = {}
    for line in output.splitlines():
        cells = [c.strip() for c in line.strip().strip("│").split("│")]
        if len(cells) == 3 and cells[0] and cells[0] != "parameter":
            rows[cells[0]] = (cells[1], cells[2])
    return rows


def test_calibrate_prints_the_fitted_parameters_as_a_table(labelled, tmp_path):
    hi, lo = labelled
    out = tmp_path / "cal.yaml"
    res = CliRunner().invoke(app, ["calibrate", f"{hi}:high", f"{lo}:low", "-o", str(out)], env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output
    assert "{'" not in res.output and "': " not in res.output  # no Python dictionary
    # the console may fold the long path onto the next line (its width is set once)
    assert res.output.replace("\n", "").rstrip().endswith(f"wrote {out}")
    doc = read_calibration(out).to_dict()
    rows = _rows(res.output)
    grip = doc["brls"]["grip"]
    assert rows["brls.grip.c_long"] == (f"{grip['c_long']:.4g}", "1/unit slip")
    assert rows["brls.grip.c_lat"] == (f"{grip['c_lat']:.4g}", "1/rad")
    assert rows["brls.grip.resistance_0"] == (f"{grip['resistance_0']:.4g}", "m/s²")
    for name in ("mu_high", "mu_low", "gain_x", "gain_y", "model_error_x", "model_error_y"):
        assert rows[f"brls.grip.{name}"] == (f"{grip[name]:.4g}", "-"), name
    for channel in ("long", "lat"):
        assert rows[f"brls.{channel}.enabled"][0] == ("yes" if doc["brls"][channel]["enabled"] else "no")
        assert rows[f"brls.{channel}.threshold"][0] == f"{doc['brls'][channel]['threshold']:.4g}"
    fit = doc["diagnostics"]["grip_fit"]
    for axis in ("x", "y"):
        assert fit[axis]["fitted"]
        for name in fit[axis]:  # every fitted quantity of each channel, by its name in the file
            assert f"diagnostics.grip_fit.{axis}.{name}" in rows, (axis, name)
        assert rows[f"diagnostics.grip_fit.{axis}.stiffness"][1] == ("1/unit slip" if axis == "x" else "1/rad")
    assert rows["diagnostics.friction.high"] == (f"{doc['friction']['high']:.4g}", "-")
    assert rows["slipmap.config.lowpass_tau_s"][1] == "s"
