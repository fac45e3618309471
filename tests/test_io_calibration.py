"""The vehicle file's sensor calibration (``roadgrip.io.calibration``): applied by the
reader, so that the library and the command line read the same data from one file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from roadgrip.drive import Drive
from roadgrip.io import read_drive
from roadgrip.io.calibration import apply_calibration, read_calibration, shift_columns
from roadgrip.vehicle import PRESETS

CAL = {"steer_scale": 1.1, "steer_offset": 0.01, "ay_bias": 0.2, "delay_accelerometer": 0.05}


def _drive(n: int = 400, rate: float = 100.0) -> Drive:
    t = np.arange(n) / rate
    df = pd.DataFrame({"t": t, "ax": 0.1 * np.sin(t), "ay": np.sin(2.0 * t), "yaw_rate": 0.1 * np.cos(t),
                       "steer": 0.02 * np.sin(t), "vx": 10.0 + 0.0 * t})
    return Drive.from_frame(df, PRESETS["sedan"], source="test")


def _car(tmp_path: Path, calibration: dict | None) -> Path:
    data = PRESETS["sedan"].to_dict()
    if calibration is not None:
        data["calibration"] = calibration
    p = tmp_path / "car.yaml"
    p.write_text(yaml.safe_dump(data, sort_keys=False))
    return p


def test_read_drive_applies_the_files_calibration(tmp_path: Path):
    raw = _drive()
    f = tmp_path / "d.parquet"
    raw.save(f)
    d = read_drive(f, vehicle=str(_car(tmp_path, CAL)))
    assert d.meta.extra["calibration"] == CAL
    # 50 ms at 100 Hz: the accelerometer moves back 5 samples, the last 5 rows go
    assert d.n == raw.n - 5
    np.testing.assert_allclose(d.col("ay"), raw.col("ay")[5:] - 0.2, atol=1e-12)
    np.testing.assert_allclose(d.col("steer"), 1.1 * raw.col("steer")[:-5] + 0.01, atol=1e-12)
    np.testing.assert_allclose(d.col("yaw_rate"), raw.col("yaw_rate")[:-5], atol=0)
    # a file without one, and a preset name, leave the columns as recorded
    plain = read_drive(f, vehicle=str(_car(tmp_path, None)))
    np.testing.assert_array_equal(plain.col("ay"), raw.col("ay"))
    assert "calibration" not in (plain.meta.extra or {})
    np.testing.assert_array_equal(read_drive(f, vehicle="sedan").col("steer"), raw.col("steer"))


def test_a_second_calibration_is_refused():
    once = apply_calibration(_drive(), CAL)
    with pytest.raises(ValueError, match="already calibrated"):
        apply_calibration(once, CAL)
    assert apply_calibration(once, {}) is once


def test_shift_moves_a_column_back_and_drops_the_unpaired_end():
    d = _drive(n=100)
    out = shift_columns(d, {"ay": 0.03})
    assert out.n == 97
    np.testing.assert_allclose(out.col("ay"), d.col("ay")[3:], atol=1e-12)
    assert out.meta.extra["alignment_s"] == {"ay": 0.03}


def test_bad_calibration_entry_is_named(tmp_path: Path):
    with pytest.raises(ValueError, match="unknown calibration 'steer_gain'"):
        read_calibration(_car(tmp_path, {"steer_gain": 1.0}))
    assert read_calibration("sedan") == {}


def test_a_x_moves_by_its_own_delay_where_the_file_gives_one(tmp_path: Path):
    raw = _drive()
    f = tmp_path / "d.parquet"
    raw.save(f)
    cal = {"delay_accelerometer": 0.05, "delay_accelerometer_x": 0.02}
    d = read_drive(f, vehicle=str(_car(tmp_path, cal)))
    assert d.n == raw.n - 5  # the larger shift decides the dropped end
    np.testing.assert_allclose(d.col("ay"), raw.col("ay")[5:], atol=1e-12)
    np.testing.assert_allclose(d.col("ax"), raw.col("ax")[2:-3], atol=1e-12)
    assert d.meta.extra["alignment_s"] == {"ax": 0.02, "ay": 0.05}
    # a file without the entry (written before it existed) keeps one accelerometer clock
    old = apply_calibration(raw, {"delay_accelerometer": 0.05})
    np.testing.assert_allclose(old.col("ax"), raw.col("ax")[5:], atol=1e-12)
    np.testing.assert_allclose(old.col("ay"), raw.col("ay")[5:], atol=1e-12)
    # a_x's delay alone moves a_x alone
    only_x = apply_calibration(raw, {"delay_accelerometer_x": 0.03})
    np.testing.assert_allclose(only_x.col("ax"), raw.col("ax")[3:], atol=1e-12)
    np.testing.assert_allclose(only_x.col("ay"), raw.col("ay")[:-3], atol=0)


def test_the_gyro_calibration_is_inverted():
    raw = _drive()
    d = apply_calibration(raw, {"yaw_rate_scale": 1.02, "yaw_rate_bias": 0.006})
    np.testing.assert_allclose(d.col("yaw_rate"), (raw.col("yaw_rate") - 0.006) / 1.02, atol=1e-15)
    np.testing.assert_array_equal(d.col("ay"), raw.col("ay"))


def test_the_pose_is_moved_by_its_delay_and_its_heading_unbiased_across_the_wrap():
    # a heading turning through ±pi, recorded wrapped: moved by 30 ms and less a 0.01 rad bias,
    # it stays a wrapped heading and is continuous where the recording wraps
    raw = _drive()
    truth = np.pi - 1.0 + 0.5 * raw.t  # through pi at t = 2 s
    df = raw.data.copy()
    df["x"], df["y"] = np.cos(raw.t), np.sin(raw.t)
    df["psi"] = (truth + 0.01 + np.pi) % (2 * np.pi) - np.pi
    d = apply_calibration(Drive(df, raw.meta), {"delay_pose": 0.03, "pose_heading_bias": 0.01})
    assert d.n == raw.n - 3
    psi = d.col("psi")
    assert np.abs(psi).max() <= np.pi
    np.testing.assert_allclose(np.unwrap(psi), truth[3:], atol=1e-9)
    np.testing.assert_allclose(d.col("x"), np.cos(raw.t[3:]), atol=1e-3)
    np.testing.assert_array_equal(d.col("ay"), raw.col("ay")[:-3])
