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


# -- physical ranges, text and complex columns, time base, duplicates ------------------------

@pytest.mark.parametrize(("col", "value"), [("omega_fl", 1.7e308), ("vx", 400.0), ("x", 1e19),
                                            ("psi", -1e9), ("yaw_rate", 200.0), ("vx_pose", 1e6),
                                            ("mu_true", 1e12)])
def test_value_outside_physical_range_names_column_value_row_and_range(col, value):
    from roadgrip.drive import SIGNAL_RANGES

    df = _cornering()
    for c in ("omega_fl", "x", "psi", "vx_pose", "mu_true"):
        df[c] = 0.0
    df.loc[33, col] = value
    with pytest.raises(DriveValidationError) as exc:
        validate_frame(df, check_units=False)
    msg = str(exc.value)
    hi = SIGNAL_RANGES.get(col, (0, 1e9, ""))[1]
    assert f"column {col!r}" in msg and f"{value:.6g}" in msg and "row 33" in msg and f"{hi:g}" in msg


@pytest.mark.parametrize("col", ["ay", "vx_pose", "omega_rr"])
def test_text_column_named(col):
    df = _cornering()
    df[col] = df["vx"].astype(str)
    df.loc[7, col] = "n/a"
    with pytest.raises(DriveValidationError, match=f"column '{col}' is not numeric.*'n/a' at row 7"):
        validate_frame(df)


def test_complex_and_duplicated_columns_named():
    df = _cornering()
    df["ay"] = df["ay"] + 0j
    with pytest.raises(DriveValidationError, match="column 'ay' is complex"):
        validate_frame(df)
    df = pd.concat([_cornering(), _cornering()[["vx"]]], axis=1)
    with pytest.raises(DriveValidationError, match="duplicated column name 'vx'"):
        Drive.from_frame(df, PRESETS["sedan"])


@pytest.mark.parametrize(("scale", "unit"), [(1e3, "ms"), (1e6, "µs"), (1e9, "ns")])
def test_time_not_in_seconds_refused_with_its_evidence(scale, unit):
    df = _cornering()
    df["t"] = np.round(df["t"] * scale)
    with pytest.raises(DriveValidationError, match=f"median step {0.01 * scale:g}.* in {unit}".replace("+", r"\+")):
        Drive.from_frame(df, PRESETS["sedan"])


def test_sample_rates_of_real_loggers_accepted():
    for dt in (1e-3, 0.01, 0.1, 0.5):
        df = _cornering(n=40)
        df["t"] = np.arange(40) * dt
        Drive.from_frame(df, PRESETS["sedan"], check_units=False)


def test_duplicated_timestamps_merged_by_from_frame():
    from roadgrip.drive import DriveWarning

    df = _cornering()
    df["surface"] = "snow"
    df.loc[41, "t"] = df.loc[40, "t"]
    df.loc[42, "t"] = df.loc[40, "t"]
    df.loc[42, "surface"] = "ice"
    with pytest.warns(DriveWarning, match=r"2 row\(s\) with a duplicated timestamp.*t = 0\.4 s"):
        d = Drive.from_frame(df, PRESETS["sedan"])
    assert d.n == len(df) - 2
    row = d.data.iloc[40]
    assert row["ay"] == pytest.approx(df.loc[40:42, "ay"].mean())
    assert row["surface"] == "ice"
    assert np.all(np.diff(d.t) > 0)


def _posed(n: int = 300) -> pd.DataFrame:
    """Steady cornering with a consistent pose: heading, position and speed."""
    df = _cornering(n)
    t = df["t"].to_numpy()
    r, vx = df["yaw_rate"].to_numpy(), df["vx"].to_numpy()
    psi = np.concatenate([[0.0], np.cumsum(0.5 * (r[1:] + r[:-1]) * np.diff(t))])
    ds = np.concatenate([[0.0], 0.5 * (vx[1:] + vx[:-1]) * np.diff(t)])
    df["psi"], df["x"], df["y"] = psi, np.cumsum(ds * np.cos(psi)), np.cumsum(ds * np.sin(psi))
    return df


def test_unit_mistakes_against_the_pose_refused_with_evidence():
    import warnings as w

    from roadgrip.drive import DriveWarning

    with w.catch_warnings():
        w.simplefilter("error", DriveWarning)
        Drive.from_frame(_posed(), PRESETS["sedan"])  # consistent: no warning
    df = _posed()
    df["psi"] = np.rad2deg(df["psi"])
    with pytest.raises(DriveValidationError, match=r"psi looks like degrees .* is 5[67]\.\d* over"):
        Drive.from_frame(df, PRESETS["sedan"])
    df = _posed()
    df["vx"] = df["vx"] * 3.6
    with pytest.raises(DriveValidationError, match=r"vx looks like km/h .* is 3\.6\d* over"):
        Drive.from_frame(df, PRESETS["sedan"])
