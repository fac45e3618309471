"""The wheel speeds' latency against the accelerometer: the delay line (analytic), its fit
against a latency imposed on a drive, and the classifiers with it (stepping equals the batch)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from roadgrip.drive import WHEEL_COLUMNS, Drive
from roadgrip.estimators import run_estimator
from roadgrip.estimators.classify.brls_config import saturation_config
from roadgrip.estimators.classify.calibration import Calibration
from roadgrip.estimators.classify.grip_model import GripModel, default_grip_model
from roadgrip.estimators.classify.latency import (
    aligned_drive,
    delay_channels,
    delay_line_init,
    fit_wheel_latency,
)
from roadgrip.estimators.classify.slipmap_config import saturation_config as slipmap_saturation
from roadgrip.estimators.online import OnlineEstimator


def _shifted(drive: Drive, cols, k: int) -> Drive:
    """``cols`` delayed by ``k`` samples (the first value held), an independent construction."""
    df = drive.data.copy()
    for c in cols:
        x = df[c].to_numpy()
        df[c] = np.r_[np.full(k, x[0]), x[:-k]]
    return Drive(df, drive.meta)


@pytest.mark.parametrize("latency", [0.05, -0.05])
def test_the_delay_line_holds_each_sample_by_the_latency_in_blocks_or_steps(latency):
    t = np.arange(200) * 0.01
    x = np.column_stack([np.sin(t), np.cos(3 * t)])
    whole, _ = delay_channels(delay_line_init(latency), t, x, latency)
    expect = np.vstack([np.repeat(x[:1], 5, axis=0), x[:-5]])  # 5 samples of 0.01 s
    np.testing.assert_array_equal(whole, expect)
    line, blocks, steps = delay_line_init(latency), [], []
    for lo, hi in ((0, 3), (3, 77), (77, 200)):  # blocks shorter and longer than the delay
        out, line = delay_channels(line, t[lo:hi], x[lo:hi], latency)
        blocks.append(out)
    line = delay_line_init(latency)
    for i in range(t.size):
        out, line = delay_channels(line, t[i:i + 1], x[i:i + 1], latency)
        steps.append(out)
        assert line.t.size <= 7  # the line holds the delay's samples, not the drive
    np.testing.assert_array_equal(np.vstack(blocks), whole)
    np.testing.assert_array_equal(np.vstack(steps), whole)


@pytest.fixture(scope="module")
def planar():
    """The dry minute of the planar dry-gravel-dry (ideal sensors: no latency), seed 2."""
    from roadgrip.sim.scenarios import simulate_scenario

    return simulate_scenario("dry-gravel-dry", seed=2, duration=60.0)


def test_the_fit_finds_a_latency_imposed_on_either_signal(planar):
    base, fit = fit_wheel_latency([planar])
    assert fit["fitted"] and abs(base) <= 0.02  # ideal sensors (the body's pitch lags a little)
    later_ax, fit_ax = fit_wheel_latency([_shifted(planar, ["ax"], 7)])
    later_wheels, _ = fit_wheel_latency([_shifted(planar, WHEEL_COLUMNS, 9)])
    assert fit_ax["fitted"]
    assert later_ax == pytest.approx(base - 0.07, abs=1e-9)
    assert later_wheels == pytest.approx(base + 0.09, abs=1e-9)
    # aligned by the fitted latency, the drive shows no more than the ideal one's
    realigned, _ = aligned_drive(_shifted(planar, WHEEL_COLUMNS, 9), later_wheels)
    assert fit_wheel_latency([realigned])[0] == pytest.approx(base, abs=1e-9)


def _logged_with_own_latencies(planar: Drive) -> Drive:
    """``a_x``, ``a_y`` and the wheel speeds each late by their own message's latency:
    70, 30 and 90 ms (``a_x`` and ``a_y`` are separate messages, as on the multi-body family)."""
    return _shifted(_shifted(_shifted(planar, ["ax"], 7), ["ay"], 3), WHEEL_COLUMNS, 9)


def test_a_vehicle_file_times_ax_by_ay_so_the_calibration_fits_what_remains(planar):
    from roadgrip.estimators.classify import calibrate
    from roadgrip.io.calibration import apply_calibration

    base, _ = fit_wheel_latency([planar])
    # the fitted file's delays, exact: the accelerometer's is a_y's, the speed's the wheels'
    file_cal = {"delay_accelerometer": 0.03, "delay_speed": 0.09}
    read = apply_calibration(_logged_with_own_latencies(planar), file_cal)
    # wheels and a_y back on the drive's clock; a_x moved by a_y's 30 ms, still 40 ms late
    latency, fit = fit_wheel_latency([read])
    assert fit["fitted"] and latency == pytest.approx(base - 0.04, abs=1e-9)
    cal = calibrate([(read, "high")])
    assert cal.diagnostics["wheel_latency"]["latency_s"] == pytest.approx(base - 0.04, abs=1e-9)
    assert cal.diagnostics["sensor_calibration"] == file_cal
    assert Calibration.from_dict(cal.to_dict()).diagnostics["sensor_calibration"] == file_cal
    assert calibrate([(planar, "high")]).diagnostics["sensor_calibration"] == {}


def test_drives_read_with_different_sensor_calibrations_are_refused(planar):
    from roadgrip.estimators.classify import calibrate
    from roadgrip.io.calibration import apply_calibration

    read = apply_calibration(planar, {"delay_speed": 0.05})
    with pytest.raises(ValueError, match=r"different sensor calibrations.*same vehicle file"):
        calibrate([(read, "high"), (planar, "high")])


def test_an_all_wheel_drive_car_has_no_latency_fit(planar):
    awd = Drive(planar.data, replace(planar.meta, vehicle=replace(planar.vehicle, drive="awd")))
    latency, fit = fit_wheel_latency([awd])
    assert latency == 0.0 and not fit["fitted"] and "all-wheel" in fit["reason"]


def test_the_model_rejects_a_latency_beyond_its_bound():
    with pytest.raises(ValueError, match="wheel_latency_s"):
        GripModel(c_long=20.0, c_lat=15.0, mu_high=1.0, mu_low=0.4, wheel_latency_s=0.5)
    m = GripModel(c_long=20.0, c_lat=15.0, mu_high=1.0, mu_low=0.4, wheel_latency_s=-0.08)
    assert GripModel.from_dict(m.to_dict()) == m


@pytest.fixture(scope="module")
def patches():
    from roadgrip.sim.scenarios import simulate_scenario

    return simulate_scenario("f1tenth-patches", seed=2, duration=5.0)


@pytest.mark.parametrize("method", ["brls", "slipmap"])
@pytest.mark.parametrize("latency", [0.03, -0.04])
def test_pushed_samples_give_the_rows_of_the_run_with_a_latency(method, latency, patches):
    model = replace(default_grip_model(patches.vehicle, 1.0, 0.4), wheel_latency_s=latency)
    cal = Calibration(brls=saturation_config(grip=model), slipmap=slipmap_saturation(model))
    whole = run_estimator(method, patches, {"calibration": cal}).table
    plain = run_estimator(method, patches, {"calibration": replace(
        cal, brls=saturation_config(grip=replace(model, wheel_latency_s=0.0)),
        slipmap=slipmap_saturation(replace(model, wheel_latency_s=0.0)))}).table
    assert not np.allclose(whole["vx_hat"], plain["vx_hat"])  # the latency is applied
    online = OnlineEstimator(method, patches.vehicle, {"calibration": cal}, sample_rate=patches.meta.sample_rate)
    rows = []
    for rec in patches.data.to_dict("records"):
        rows += online.push(rec)
    table = online.table(rows + online.finish())
    num = whole.select_dtypes(["number", "bool"]).columns
    np.testing.assert_allclose(table[num].to_numpy(float), whole[num].to_numpy(float), rtol=1e-9, atol=1e-12)
    assert (table["grip_class"] == whole["grip_class"]).all()
    assert isinstance(table, pd.DataFrame)
