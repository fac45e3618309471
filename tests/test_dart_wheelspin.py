"""The units check under wheel spin: the speed from the pose decides, not the encoder."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from roadgrip.constants import GRAVITY
from roadgrip.drive import DriveValidationError, validate_frame
from roadgrip.io import read_drive

DART = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "dart"


def _circle_with_pose(n: int = 400, spin: float = 1.0, seed: int = 3) -> pd.DataFrame:
    """Steady circle at 2 m/s, radius 1 m (ay = 4 m/s²), 10 Hz, encoder = spin x true speed."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.1
    v, r = 2.0, 1.0
    psi = v / r * t
    return pd.DataFrame({
        "t": t, "x": r * np.sin(psi), "y": r * (1 - np.cos(psi)), "psi": psi,
        "yaw_rate": v / r + 0.01 * rng.standard_normal(n),
        "ay": v**2 / r + 0.3 * rng.standard_normal(n),
        "ax": 0.3 * rng.standard_normal(n),
        "vx": spin * v + 0.02 * rng.standard_normal(n),
    })


def test_wheel_spin_with_pose_is_not_taken_for_g():
    df = _circle_with_pose(spin=7.0)  # ay / (vx r) = 1/7: the encoder alone says "ay in g"
    with pytest.raises(DriveValidationError, match="ay looks like it is in g"):
        validate_frame(df.drop(columns=["x", "y", "psi"]))
    validate_frame(df)  # the pose gives the true speed: valid


def test_ay_in_g_still_caught_with_pose():
    df = _circle_with_pose(spin=7.0)
    df["ay"] = df["ay"] / GRAVITY
    with pytest.raises(DriveValidationError, match="ay looks like it is in g"):
        validate_frame(df)


@pytest.mark.realdata
@pytest.mark.skipif(not DART.is_dir(), reason=f"DART data set not found at {DART}")
def test_dart_recording_with_wheel_spin_reads(tmp_path):
    """A shared DART run with its encoder speed raised to 7x the true speed (drift) reads."""
    src = DART / "high_grip_rubbery_floor" / "car_1_Datarecording_09_09_2024_14_12_45.csv"
    raw = pd.read_csv(src)
    raw["vel encoder"] = 7.0 * raw["vel encoder"]
    path = tmp_path / src.name
    raw.to_csv(path, index=False)
    drive = read_drive(path)
    assert drive.n > 100
    pose_speed = np.hypot(np.gradient(drive.col("x"), drive.t), np.gradient(drive.col("y"), drive.t))
    moving = pose_speed > 0.5
    # the encoder reads far above the true speed, and the check did not reject the file
    assert np.median(drive.col("vx")[moving] / pose_speed[moving]) > 5.0
