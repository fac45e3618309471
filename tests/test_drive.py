"""Drive validation: one test per kind of bad input, each naming the problem."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from roadgrip.constants import GRAVITY
from roadgrip.drive import Drive, DriveValidationError, validate_frame
from roadgrip.vehicle import PRESETS


def _cornering(n: int = 200, seed: int = 0) -> pd.DataFrame:
    """A physically consistent steady-cornering frame (SI units)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.01
    vx = 20.0 + 0.1 * rng.standard_normal(n)
    r = 0.3 * np.sin(2 * np.pi * 0.2 * t) + 0.01 * rng.standard_normal(n)
    return pd.DataFrame(
        {"t": t, "ax": 0.2 * rng.standard_normal(n), "ay": vx * r, "yaw_rate": r,
         "steer": 0.02 * np.sin(2 * np.pi * 0.2 * t), "vx": vx}
    )


def test_good_frame_passes():
    df = _cornering()
    d = Drive.from_frame(df, PRESETS["sedan"])
    assert d.n == len(df)
    assert d.meta.sample_rate == pytest.approx(100.0)


def test_missing_column():
    df = _cornering().drop(columns=["vx"])
    with pytest.raises(DriveValidationError, match=r"missing required column\(s\) \['vx'\]"):
        validate_frame(df, ("t", "vx"))


def test_nan():
    df = _cornering()
    df.loc[17, "ay"] = np.nan
    with pytest.raises(DriveValidationError, match=r"column 'ay' has 1 NaN/inf value\(s\), first at row 17"):
        validate_frame(df)


def test_inf():
    df = _cornering()
    df.loc[5, "yaw_rate"] = np.inf
    with pytest.raises(DriveValidationError, match=r"column 'yaw_rate' has 1 NaN/inf value\(s\), first at row 5"):
        validate_frame(df)


def test_duplicated_time():
    df = _cornering()
    df.loc[40, "t"] = df.loc[39, "t"]
    with pytest.raises(DriveValidationError, match="duplicated timestamps"):
        validate_frame(df)


def test_decreasing_time():
    df = _cornering()
    df.loc[40, "t"] = df.loc[38, "t"] - 0.5
    with pytest.raises(DriveValidationError, match="not increasing: it goes backwards"):
        validate_frame(df)


def test_empty():
    with pytest.raises(DriveValidationError, match="drive is empty"):
        validate_frame(_cornering().iloc[:0])


def test_acceleration_in_g():
    df = _cornering()
    df["ay"] = df["ay"] / GRAVITY
    with pytest.raises(DriveValidationError, match="ay looks like it is in g"):
        validate_frame(df)


def _accelerating(n: int = 1000, seed: int = 1) -> pd.DataFrame:
    """Straight-line speed changes with a noisy speed sensor (SI units)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.01
    ax = 2.0 * np.sin(2 * np.pi * 0.2 * t)
    vx = 15.0 + np.cumsum(ax) * 0.01
    return pd.DataFrame({"t": t, "ax": ax + 0.1 * rng.standard_normal(n),
                         "vx": vx + 0.05 * rng.standard_normal(n)})


def test_longitudinal_acceleration_in_g():
    df = _accelerating()
    validate_frame(df)
    df["ax"] = df["ax"] / GRAVITY
    with pytest.raises(DriveValidationError, match="ax looks like it is in g"):
        validate_frame(df)


def test_acceleration_magnitude_in_wrong_unit():
    df = _cornering()
    df["ax"] = 100.0  # e.g. a raw count or cm/s²
    with pytest.raises(DriveValidationError, match="column 'ax' reaches 100 m/s²: implausible acceleration"):
        validate_frame(df)


def test_yaw_rate_in_deg_per_s():
    df = _cornering()
    df["yaw_rate"] = np.rad2deg(df["yaw_rate"])
    with pytest.raises(DriveValidationError, match=r"yaw_rate.*deg/s"):
        validate_frame(df)


def test_small_yaw_rate_in_deg_per_s_caught_by_kinematics():
    df = _cornering()
    df["yaw_rate"] *= 0.25  # 0.075 rad/s = 4.3 deg/s: plausible magnitude in either unit
    df["ay"] = df["vx"] * df["yaw_rate"]
    df["yaw_rate"] = np.rad2deg(df["yaw_rate"])
    assert df["yaw_rate"].abs().max() < 10.0
    with pytest.raises(DriveValidationError, match="yaw_rate looks like deg/s"):
        validate_frame(df)


def test_steering_in_degrees():
    df = _cornering()
    df["steer"] = np.rad2deg(df["steer"]) * 3.0  # up to about 3.4 deg
    with pytest.raises(DriveValidationError, match=r"steer.*looks like degrees"):
        validate_frame(df)


def test_non_numeric_column():
    df = _cornering()
    df["vx"] = df["vx"].astype(str)
    with pytest.raises(DriveValidationError, match="column 'vx' is not numeric"):
        validate_frame(df)


def test_unit_checks_can_be_skipped():
    df = _cornering()
    df["ay"] = df["ay"] / GRAVITY
    validate_frame(df, check_units=False)


def test_access_helpers():
    d = Drive.from_frame(_cornering().assign(foo=1.0), PRESETS["sedan"], source="s")
    assert d.extra_columns == ["foo"]
    assert not d.has_pose and not d.has_truth
    with pytest.raises(DriveValidationError, match="drive from s has no column 'psi'"):
        d.col("psi")
    with pytest.raises(DriveValidationError, match=r"lacks required column\(s\) \['x'\] \(pose\)"):
        d.require("x", why="pose")
    part = d.slice_time(0.5, 1.0)
    assert part.t[0] == pytest.approx(0.5) and part.t[-1] < 1.0 and part.n == 50


def test_metadata_with_numpy_values_serialises(tmp_path):
    extra = {"n": np.int64(3), "a": np.arange(3), "f": np.float32(0.5), "b": np.bool_(True)}
    d = Drive.from_frame(_cornering(), PRESETS["sedan"], extra=extra)
    p = tmp_path / "d.parquet"
    d.save(p)
    from roadgrip.io import read_drive

    assert read_drive(p).meta.extra == {"n": 3, "a": [0, 1, 2], "f": 0.5, "b": True}
    with pytest.raises(TypeError, match="metadata value of type object is not JSON-serialisable"):
        Drive.from_frame(_cornering(), PRESETS["sedan"], extra={"x": object()}).meta.to_json()
