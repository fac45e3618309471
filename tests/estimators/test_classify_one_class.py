"""Calibration of the classifiers from drives of one class (a car's dry baseline lap).

The other class's friction reference is mirrored across the class split
(:func:`roadgrip.estimators.classify.common.mirrored_friction`); the car's stiffness, gains
and road load come from the labelled drive. Judged against the simulator's truth on another
seed of the planar ``dry-gravel-dry`` (the slow multi-body acceptance is in
``test_classify_acceptance.py``).
"""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from roadgrip.cli import app
from roadgrip.cli.calibrate import parse_labelled, read_calibration
from roadgrip.constants import GRIP_CLASS_SPLIT
from roadgrip.estimators import run_estimator
from roadgrip.estimators.classify import calibrate
from roadgrip.estimators.classify.common import mirrored_friction
from roadgrip.estimators.classify.fit import fit_slip_offset
from roadgrip.estimators.classify.latency import aligned_drive


@pytest.mark.parametrize(("label", "mu"), [("high", 1.0), ("high", 1.45), ("low", 0.3), ("low", 0.69)])
def test_mirrored_friction_puts_the_split_at_the_geometric_mean(label, mu):
    fr = mirrored_friction(label, mu)
    assert fr[label] == mu
    assert fr["low"] < GRIP_CLASS_SPLIT < fr["high"]
    assert np.sqrt(fr["high"] * fr["low"]) == pytest.approx(GRIP_CLASS_SPLIT, rel=1e-5)


@pytest.mark.parametrize(("label", "mu"), [("high", 0.7), ("high", 0.5), ("low", 0.7), ("low", 0.0),
                                           ("low", float("nan")), ("dry", 1.0)])
def test_mirrored_friction_refuses_a_reference_on_the_wrong_side(label, mu):
    with pytest.raises(ValueError, match=r"split|label"):
        mirrored_friction(label, mu)


@pytest.fixture(scope="module")
def planar_drives():
    """Seeds 2 (calibration) and 3 (test) of the planar dry-gravel-dry (dry 1.0, gravel 0.6 from 60 s)."""
    from roadgrip.sim.scenarios import simulate_scenario

    return (simulate_scenario("dry-gravel-dry", seed=2, duration=120.0),
            simulate_scenario("dry-gravel-dry", seed=3, duration=120.0))


@pytest.fixture(scope="module")
def planar(planar_drives):
    """The dry minute of seed 2 (calibration) and seed 3 whole (test)."""
    cal, test = planar_drives
    return cal.slice_time(0, 60), test


def test_one_gravel_drive_calibrates_the_low_class(planar_drives):
    cal_drive, test = planar_drives
    cal = calibrate([(cal_drive.slice_time(60, 120), "low")])
    assert cal.friction == mirrored_friction("low", 0.6)  # the gravel's truth, mirrored
    truth = np.where(test.col("mu_true") >= GRIP_CLASS_SPLIT, "high", "low")
    i0 = int(np.argmax(truth == "low"))
    for method in ("brls", "slipmap"):
        cls = run_estimator(method, test, {"calibration": cal}).table["grip_class"].to_numpy()
        assert (cls[i0:] == "low").any(), method
        assert not np.any((cls == "high") & (truth == "low")), method
        assert not np.any(cls[:i0] == "low"), method


def test_one_dry_drive_calibrates_both_classifiers(planar):
    dry, test = planar
    cal = calibrate([(dry, "high")])
    # the truth of the dry minute is 1.0; the other class mirrored across the split
    assert cal.friction == mirrored_friction("high", 1.0)
    assert cal.diagnostics["labels"] == "high"
    assert cal.brls.grip.mu_low == cal.friction["low"]
    assert [d["label"] for d in cal.drives] == ["high"]
    truth = np.where(test.col("mu_true") >= GRIP_CLASS_SPLIT, "high", "low")
    i0 = int(np.argmax(truth == "low"))
    for method in ("brls", "slipmap"):
        table = run_estimator(method, test, {"calibration": cal}).table
        cls = table["grip_class"].to_numpy()
        excited = np.flatnonzero(table["excited"].to_numpy()[i0:])
        low = np.flatnonzero(cls[i0:] == "low")
        assert excited.size and low.size, method
        # gravel called 'low' within half a second of its first excited sample
        assert test.t[i0 + low[0]] - test.t[i0 + excited[0]] <= 0.5, method
        assert not np.any((cls == "high") & (truth == "low")), method
        # before the gravel no 'low' (the claim is held after it, by design)
        assert not np.any(cls[:i0] == "low"), method


def test_one_class_calibration_is_refused_where_it_cannot_hold(planar):
    dry, _ = planar
    with pytest.raises(ValueError, match="stiffness model needs"):
        calibrate([(dry, "high")], model="stiffness")
    with pytest.raises(ValueError, match="must give the labelled class"):
        calibrate([(dry, "high")], friction={"low": 0.3})
    with pytest.raises(ValueError, match="split"):  # a 'high' reference below the split
        calibrate([(dry, "high")], friction={"high": 0.6})
    with pytest.raises(ValueError, match="at least one labelled drive"):
        calibrate([])


def test_parse_labelled_with_a_default_label():
    assert parse_labelled(["a.parquet", "b.parquet:low"], "high") == (
        [("a.parquet", "high"), ("b.parquet", "low")], None)
    assert parse_labelled(["a.parquet:high=1.1"]) == ([("a.parquet", "high")], {"high": 1.1})
    with pytest.raises(ValueError, match="--label"):
        parse_labelled(["a.parquet"])
    with pytest.raises(ValueError, match="--label must be"):
        parse_labelled(["a.parquet"], "dry")
    with pytest.raises(ValueError, match="every class"):
        parse_labelled(["a.parquet:high=1.1", "b.parquet:low"])


def test_cli_calibrate_from_one_dry_drive(planar, tmp_path):
    dry, _ = planar
    path, out = tmp_path / "dry.parquet", tmp_path / "cal.yaml"
    dry.save(path)
    runner = CliRunner()
    res = runner.invoke(app, ["calibrate", str(path), "--label", "high", "-o", str(out)],
                        env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output
    cal = read_calibration(out)
    assert cal.friction == mirrored_friction("high", 1.0)
    assert "(1 labelled drive)" in res.output
    res = runner.invoke(app, ["calibrate", f"{path}:high=1.2", "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert read_calibration(out).friction == mirrored_friction("high", 1.2)
    res = runner.invoke(app, ["calibrate", str(path), "-o", str(out)])
    assert res.exit_code != 0
    assert "--label" in str(res.exception)


def test_cli_calibrate_with_a_fitted_vehicle_file_records_its_sensor_calibration(planar, tmp_path):
    import yaml

    dry, _ = planar
    path, out, car = tmp_path / "dry.parquet", tmp_path / "cal.yaml", tmp_path / "car.yaml"
    dry.save(path)
    sensors = {"delay_speed": 0.02, "delay_accelerometer": 0.01, "ax_bias": 0.05}
    car.write_text(yaml.safe_dump({**dry.vehicle.to_dict(), "calibration": sensors}))
    res = CliRunner().invoke(app, ["calibrate", f"{path}@0-60", "--label", "high", "--vehicle", str(car),
                                   "-o", str(out)], env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output
    assert read_calibration(out).diagnostics["sensor_calibration"] == sensors
    row = next(line for line in res.output.splitlines() if "sensor_calibration.ax_bias" in line)
    assert "m/s²" in row and "0.05" in row


def test_slip_offset_is_the_driven_wheels_scale_error(planar):
    """A 0.6 % scale error of the driven (front) wheel speeds shifts the fitted zero error of
    the driven slip by 1 - 1 / 1.006 (the slip against the free-rolling wheels), and the
    one-class calibration keeps it in the model."""
    from roadgrip.inference.kinematic import drive_lateral_acceleration, estimate_kinematics

    dry, _ = planar
    assert dry.vehicle.drive == "fwd"
    frame = dry.data.copy()
    frame[["omega_fl", "omega_fr"]] *= 1.006
    scaled = dry.with_data(frame)

    def offset(drive):
        kin = estimate_kinematics(drive)
        return fit_slip_offset([(drive, "high", kin, drive_lateral_acceleration(drive, kin, "imu"))])

    b0, fit0 = offset(dry)
    b1, fit1 = offset(scaled)
    assert fit0["fitted"] and fit1["fitted"]
    assert b1 - b0 == pytest.approx(1.0 - 1.0 / 1.006, abs=3e-4)
    cal = calibrate([(scaled, "high")])
    # the calibration fits it on the drive aligned by the wheel speeds' latency (ideal sensors:
    # within a sample step of none), as the classifiers see the drive
    assert abs(cal.brls.grip.wheel_latency_s) <= 0.011
    b_cal, _ = offset(aligned_drive(scaled, cal.brls.grip.wheel_latency_s)[0])
    assert b_cal == pytest.approx(b1, abs=1e-5)
    assert cal.brls.grip.kappa_offset == pytest.approx(b_cal)
    assert cal.diagnostics["slip_zero"]["offset"] == pytest.approx(b_cal)


def test_low_is_held_until_high_evidence_only_where_a_wheel_rolls_freely(planar):
    from roadgrip.estimators.classify.brls_config import (
        BRAKING_ONLY_HOLD_LOW_S,
        CALIBRATED_HOLD_HIGH_S,
    )
    from roadgrip.estimators.classify.fit import low_claim_hold

    assert low_claim_hold("fwd") == low_claim_hold("rwd") == np.inf
    # all-wheel drive: informed in braking only, so a 'low' expires between stops
    assert CALIBRATED_HOLD_HIGH_S <= low_claim_hold("awd") == BRAKING_ONLY_HOLD_LOW_S < np.inf
    cal = calibrate([(planar[0], "high")])  # the planar sedan: front-wheel drive
    assert cal.brls.hold_low_s == cal.slipmap.hold_low_s == np.inf
    assert cal.brls.hold_high_s == cal.slipmap.hold_high_s == CALIBRATED_HOLD_HIGH_S


def test_one_class_calibration_takes_the_traction_slips_first_where_a_wheel_rolls_freely(planar):
    """The braking slips (against a speed coasting on the accelerometer) are the weaker
    evidence: the front-drive sedan's traction slips hold its dry label, so the calibration
    leaves braking out, and the classifiers see no longitudinal evidence in a stop."""
    cal = calibrate([(planar[0], "high")])
    assert cal.diagnostics["long_channel"] == "on"
    assert cal.diagnostics["braking_evidence"] is False
    assert not cal.brls.grip.braking_evidence and not cal.slipmap.grip.braking_evidence
