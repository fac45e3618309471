"""``a_x``'s own delay in the vehicle fit (``delay_accelerometer_x``): ``a_x`` and ``a_y``
may be separate messages with their own latencies, so ``a_y``'s delay does not time ``a_x``.
Against the simulator's truth: its sensor clocks agree, so the injected lags are the delays."""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import pytest

from roadgrip.drive import Drive
from roadgrip.inference.vehicle_identification import fit_vehicle
from roadgrip.vehicle import PRESETS

AY_LAG = 8  # samples at 100 Hz: 80 ms
AX_LAG = 2  # 20 ms: a_x 60 ms ahead of a_y
DT = 0.01  # [s]


@functools.cache
def _sim() -> Drive:
    from roadgrip.sim.friction import ConstantFriction, surface_from_preset
    from roadgrip.sim.maneuvers import Maneuver, RandomSpeed, RandomSteer
    from roadgrip.sim.runner import simulate
    from roadgrip.sim.scenarios import CAR_SENSORS

    man = Maneuver(speed=RandomSpeed(8.0, 25.0, corr_time=3.0),  # accelerations and brakings
                   steering=RandomSteer(ay_min=0.5, ay_max=3.5, corr_time=1.0, envelope_period=40.0),
                   yaw_gain=0.3, sideslip_gain=1.5)
    return simulate(PRESETS["sedan"], man, ConstantFriction("dry_asphalt"),
                    [surface_from_preset("dry_asphalt")], duration=120.0, model="lateral",
                    output_rate=100.0, sensors=CAR_SENSORS, seed=1, name="two-clocks")


@functools.cache
def _two_clocks() -> Drive:
    """The drive with ``a_y`` ``AY_LAG`` and ``a_x`` ``AX_LAG`` samples late."""
    d = _sim()
    df = d.data.copy()
    for c, lag in (("ay", AY_LAG), ("ax", AX_LAG)):
        df[c] = np.roll(df[c].to_numpy(), lag)
    return Drive(df.iloc[10:].reset_index(drop=True), d.meta)


@functools.cache
def _fit(pose: bool = True):
    d = _two_clocks()
    if not pose:
        d = Drive(d.data.drop(columns=["x", "y", "psi"]), d.meta)
    return fit_vehicle(d)


def test_both_accelerometer_delays_are_found():
    v = _fit().values
    acc, acc_x = v["delay_accelerometer"], v["delay_accelerometer_x"]
    assert acc.fitted and acc_x.fitted
    assert acc.value == pytest.approx(AY_LAG * DT, abs=0.005)
    assert acc_x.value == pytest.approx(AX_LAG * DT, abs=0.005)
    # the standard error is finite and covers the error
    assert 0 < acc_x.std < 0.01 and abs(acc_x.value - AX_LAG * DT) < 4 * acc_x.std + 0.002
    assert "pose" in acc_x.note
    # the speed is timed through a_x: its delay is the speed sensor's own (0 here), not
    # shifted by a_x's 60 ms lead over a_y
    assert v["delay_speed"].value == pytest.approx(0.0, abs=0.005)


def test_without_a_pose_a_x_keeps_a_ys_delay():
    v = _fit(pose=False).values
    acc, acc_x = v["delay_accelerometer"], v["delay_accelerometer_x"]
    assert acc.fitted and not acc_x.fitted
    assert acc_x.value == acc.value  # the value the calibration applies to a_x in its place
    assert "no pose" in acc_x.note and "delay_accelerometer" in acc_x.note
    assert np.isnan(acc_x.std)


def test_without_a_x_there_is_no_a_x_delay():
    d = _two_clocks()
    v = fit_vehicle(Drive(d.data.drop(columns=["ax"]), d.meta)).values
    assert "delay_accelerometer_x" not in v and v["delay_accelerometer"].fitted


def _error_std(d: Drive, col: str) -> float:
    """Standard deviation [m/s²] of ``col`` against the drive before the lags were injected
    (its ends cut)."""
    truth = _sim().data.set_index("t")
    t = d.t[50:-50]
    return float(np.std(d.col(col)[50:-50] - np.interp(t, truth.index, truth[col])))


def test_the_files_calibration_puts_each_axis_on_the_gyros_clock(tmp_path: Path):
    """The fitted file written, read back, and applied by the reader: both axes aligned."""
    from roadgrip.io import read_drive
    from roadgrip.io.calibration import read_calibration

    car = tmp_path / "car.yaml"
    car.write_text(_fit().to_yaml())
    cal = read_calibration(car)
    assert cal["delay_accelerometer_x"] == _fit().values["delay_accelerometer_x"].value
    assert cal["delay_accelerometer"] == _fit().values["delay_accelerometer"].value
    f = tmp_path / "drive.parquet"
    _two_clocks().save(f)
    d = read_drive(f, vehicle=str(car))
    raw = _two_clocks()
    # each axis is moved back by its own lag, to within a few ms
    assert _error_std(d, "ax") < 0.1 * _error_std(raw, "ax")
    assert _error_std(d, "ay") < 0.1 * _error_std(raw, "ay")
    assert d.meta.extra["alignment_s"]["ax"] == cal["delay_accelerometer_x"]
    # moved by a_y's delay instead (a file without the entry), a_x is off by their difference
    del cal["delay_accelerometer_x"]
    from roadgrip.io.calibration import apply_calibration

    one_clock = apply_calibration(raw, cal)
    assert _error_std(one_clock, "ax") > _error_std(raw, "ax") > 10 * _error_std(d, "ax")


def test_an_undetermined_a_x_delay_is_left_out_of_the_calibration(tmp_path: Path):
    from roadgrip.io.calibration import read_calibration

    car = tmp_path / "car.yaml"
    text = _fit(pose=False).to_yaml()
    car.write_text(text)
    cal = read_calibration(car)
    assert "delay_accelerometer_x" not in cal and "delay_accelerometer" in cal
    assert "# delay_accelerometer_x:" in text and "undetermined" in text


def _pose_held(d: Drive, every: float = 2.0, hold: float = 0.25) -> Drive:
    """``d`` with the logger holding the pose (``x, y, psi`` at once) for ``hold`` [s] every
    ``every`` [s]: 1.2 % of the samples, as a dropping GNSS receiver logs."""
    df = d.data.copy()
    n, k = len(df), round(hold / DT)
    for c in ("x", "y", "psi"):
        v = df[c].to_numpy().copy()
        for i in range(100, n - k, round(every / DT)):
            v[i + 1:i + k] = v[i]
        df[c] = v
    return Drive(df, d.meta)


def test_a_held_pose_still_times_a_x():
    """Differentiated, a held pose is a standstill and then a jump; the fit fills the holds
    (:func:`roadgrip.inference.fit_signals.fill_held`) and finds ``a_x``'s delay as without
    them."""
    v = fit_vehicle(_pose_held(_two_clocks())).values
    acc_x = v["delay_accelerometer_x"]
    assert acc_x.fitted
    assert acc_x.value == pytest.approx(AX_LAG * DT, abs=0.005)
    assert v["delay_pose"].value == pytest.approx(0.0, abs=0.005)
