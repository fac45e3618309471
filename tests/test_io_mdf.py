"""ASAM MDF4 reader: a simulated drive written with asammdf in logger units and read back."""

from __future__ import annotations

import math

import numpy as np
import pytest

from roadgrip.constants import GRAVITY
from roadgrip.drive import SIGNAL_COLUMNS, WHEEL_COLUMNS
from roadgrip.io import read_drive
from roadgrip.io.mdf import load_channel_map, read_mdf

STEER_LSB = 1.0e-4  # [rad / bit] of the integer steering channel's linear conversion
RATE = 50.0  # [Hz]


@pytest.fixture(scope="module")
def source():
    from roadgrip.sim.scenarios import simulate_scenario

    d = simulate_scenario("f1tenth-patches", seed=4, duration=8.0)
    frame = d.data.copy()
    frame["t"] = np.arange(d.n) / RATE  # the logger's clock, exactly the raster
    return frame


CHANNELS = {
    "vehicle": "f1tenth",
    "channels": {
        "ax": {"channel": "IMU_AccX"},
        "ay": {"channel": "IMU_AccY", "sign": -1, "axis": "logger y points right"},
        "yaw_rate": {"channel": "IMU_YawRate"},
        "steer": {"channel": "SteerAngle"},
        "vx": {"channel": "VehSpeed"},
        **{c: {"channel": f"WheelSpd_{c[-2:].upper()}", "unit": "rpm"} for c in WHEEL_COLUMNS},
        "x": {"channel": "PosX"},
        "y": {"channel": "PosY"},
        "psi": {"channel": "Heading"},
    },
    "extras": {"battery": {"channel": "BatteryVoltage"}},
}


def write_mdf(path, frame):
    """The drive's signals in logger units (g, deg/s, km/h, rpm), one integer channel with
    a linear conversion, a wheel-speed group without units and two unused channels."""
    from asammdf import MDF, Signal

    t = frame["t"].to_numpy(float)
    col = {c: frame[c].to_numpy(float) for c in SIGNAL_COLUMNS}
    steer_raw = np.round(col["steer"] / STEER_LSB).astype(np.int16)
    mdf = MDF(version="4.10")
    mdf.append([
        Signal(col["ax"] / GRAVITY, t, name="IMU_AccX", unit="g"),
        Signal(-col["ay"], t, name="IMU_AccY", unit="m/s²"),
        Signal(np.degrees(col["yaw_rate"]), t, name="IMU_YawRate", unit="°/s"),
        Signal(steer_raw, t, name="SteerAngle", unit="rad", conversion={"a": STEER_LSB, "b": 0.0}),
        Signal(col["vx"] * 3.6, t, name="VehSpeed", unit="km/h"),
        Signal(np.full(len(t), 12.4), t, name="BatteryVoltage", unit="V"),
        Signal(np.zeros(len(t)), t, name="BrakeSwitch"),
    ], comment="chassis")
    mdf.append([Signal(col[c] * 60.0 / (2.0 * math.pi), t, name=f"WheelSpd_{c[-2:].upper()}")
                for c in WHEEL_COLUMNS], comment="wheels (no units in the file)")
    mdf.append([Signal(col["x"], t, name="PosX", unit="m"), Signal(col["y"], t, name="PosY", unit="m"),
                Signal(col["psi"], t, name="Heading", unit="rad")], comment="pose")
    mdf.save(path, overwrite=True)
    mdf.close()
    return steer_raw


def test_round_trip_every_canonical_column(tmp_path, source):
    path = tmp_path / "run.mf4"
    steer_raw = write_mdf(path, source)
    d = read_drive(path, channels=CHANNELS)  # format detected from .mf4
    assert d.n == len(source)
    assert list(d.data.columns) == [*SIGNAL_COLUMNS, "battery"]
    np.testing.assert_array_equal(d.t, source["t"])
    rel = 4 * np.finfo(float).eps  # one conversion there and one back
    for c in SIGNAL_COLUMNS[1:]:
        want = source[c].to_numpy(float)
        if c == "steer":  # int16 counts times the file's factor
            want = steer_raw * STEER_LSB
            assert np.abs(d.col(c) - source[c]).max() <= STEER_LSB / 2
        np.testing.assert_allclose(d.col(c), want, rtol=rel, atol=1e-300, err_msg=c)
    ex = d.meta.extra
    assert ex["format"] == "mdf"
    assert ex["units"]["ax"] == "g" and ex["units"]["vx"] == "km/h" and ex["units"]["omega_fl"] == "rpm"
    assert ex["channels_unused"] == ["BrakeSwitch"]
    assert ex["source_rates_hz"]["IMU_AccX"] == pytest.approx(RATE)
    assert ex["rate_hz"] == pytest.approx(RATE)
    np.testing.assert_array_equal(d.data["battery"], 12.4)


def test_raster_interpolates_slower_channels_without_extrapolating(tmp_path):
    from asammdf import MDF, Signal

    t_fast = np.arange(201) * 0.01  # 0 .. 2 s at 100 Hz
    t_slow = 0.5 + np.arange(13) * 0.1  # 0.5 .. 1.7 s at 10 Hz
    mdf = MDF(version="4.10")
    mdf.append([Signal(0.1 * t_fast, t_fast, name="ax", unit="m/s^2"),
                Signal(np.zeros(201), t_fast, name="ay", unit="m/s^2"),
                Signal(np.zeros(201), t_fast, name="r", unit="rad/s")])
    mdf.append([Signal(36.0 + 18.0 * t_slow, t_slow, name="v", unit="km/h")])
    mdf.save(tmp_path / "r.mf4", overwrite=True)
    mdf.close()
    cmap = {"channels": {"ax": "ax", "ay": "ay", "yaw_rate": "r", "vx": "v"}}
    d = read_mdf(tmp_path / "r.mf4", cmap, vehicle="f1tenth")
    assert d.t[0] == 0.0 and d.meta.extra["t_origin_s"] == pytest.approx(0.5)
    assert d.t[-1] == pytest.approx(1.2) and d.meta.sample_rate == pytest.approx(100.0)
    t_abs = d.t + 0.5
    np.testing.assert_allclose(d.col("vx"), (36.0 + 18.0 * t_abs) / 3.6, rtol=1e-12)
    np.testing.assert_allclose(d.col("ax"), 0.1 * t_abs, rtol=1e-12)
    assert d.meta.extra["source_rates_hz"]["v"] == pytest.approx(10.0)


def test_channel_without_unit_is_named(tmp_path, source):
    path = tmp_path / "run.mf4"
    write_mdf(path, source.iloc[:100])
    with pytest.raises(ValueError, match=r"needs a channel map \(--channels"):
        read_drive(path)
    cmap = {"vehicle": "f1tenth", "channels": {**CHANNELS["channels"], "omega_fl": {"channel": "WheelSpd_FL"}}}
    with pytest.raises(ValueError, match=r"'WheelSpd_FL' \(for 'omega_fl'\) has no unit in the file"):
        read_mdf(path, cmap)
    cmap["channels"]["omega_fl"] = {"channel": "WheelSpd_FL", "unit": "rad/s"}
    cmap["channels"]["vx"] = {"channel": "VehSpeed", "unit": "m/s"}
    with pytest.raises(ValueError, match=r"the file says 'km/h', the map 'm/s'"):
        read_mdf(path, cmap)
    cmap["channels"]["vx"] = {"channel": "VehSpeedX"}
    with pytest.raises(ValueError, match=r"'VehSpeedX' \(for 'vx'\) not found; channels in the file: .*VehSpeed"):
        read_mdf(path, cmap)


def test_channel_map_errors():
    with pytest.raises(ValueError, match="unit 'deg' measures angle"):
        load_channel_map({"channels": {"ax": {"channel": "a", "unit": "deg"}}})
    with pytest.raises(ValueError, match="not a canonical signal"):
        load_channel_map({"channels": {"t": {"channel": "time"}}})
    with pytest.raises(ValueError, match="unit 'furlong' is not understood"):
        load_channel_map({"channels": {"vx": {"channel": "v", "unit": "furlong"}}})


def test_validation_error_names_the_file(tmp_path, source):
    """A yaw rate scaled back to deg/s by mistake fails the Drive's unit checks."""
    path = tmp_path / "run.mf4"
    write_mdf(path, source)
    cmap = {"vehicle": "f1tenth", "channels": {"ax": "IMU_AccX", "ay": "IMU_AccY", "vx": "VehSpeed",
                                               "yaw_rate": {"channel": "IMU_YawRate", "scale": 180 / math.pi}}}
    with pytest.raises(ValueError, match=r"^run\.mf4: column 'yaw_rate' reaches"):
        read_mdf(path, cmap)
