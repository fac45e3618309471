"""Canonical CSV / Parquet files: lossless round trips, metadata, read_drive errors."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from roadgrip.drive import Drive, DriveValidationError
from roadgrip.io import detect_format, read_drive
from roadgrip.tire import SURFACES
from roadgrip.vehicle import PRESETS


def _synthetic_drive(seed: int = 3, n: int = 500) -> Drive:
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.009, 0.011, n))
    df = pd.DataFrame(
        {
            "t": t,
            "ax": rng.normal(0.0, 1.0, n),
            "ay": np.full(n, np.nan),
            "yaw_rate": rng.normal(0.0, 0.3, n),
            "steer": np.zeros(n),  # integer-valued floats: must stay float
            "vx": 10.0 + rng.normal(0.0, 1.0, n),
            "alpha_f_true": rng.normal(0.0, 0.05, n),
            "mu_true": np.full(n, 0.3),
            "surface": np.where(np.arange(n) < n // 2, "snow", "dry_asphalt"),
            "my_extra": rng.normal(0.0, 1.0, n),
            "my_flag": (np.arange(n) % 7 == 0).astype(float),
            "my_count": np.arange(n),
        }
    )
    # full-precision digits that a short float format would lose
    df["ay"] = df["vx"] * df["yaw_rate"] + rng.normal(0.0, 1e-7, n) * np.pi
    truth = {
        "scenario": "synthetic",
        "surfaces": {
            name: {"front": SURFACES[name].lateral.to_dict(), "rear": SURFACES[name].lateral.to_dict(),
                   "front_long": SURFACES[name].longitudinal.to_dict(),
                   "rear_long": SURFACES[name].longitudinal.to_dict(), "mu": SURFACES[name].mu_peak}
            for name in ("snow", "dry_asphalt")
        },
    }
    return Drive.from_frame(df, PRESETS["suv"], source="test:synthetic", truth=truth,
                            extra={"note": "x", "nested": {"a": [1, 2.5]}})


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_round_trip_is_lossless(tmp_path, suffix):
    d = _synthetic_drive()
    p = tmp_path / f"drive{suffix}"
    d.save(p)
    back = read_drive(p)
    pd.testing.assert_frame_equal(back.data, d.data, check_exact=True)
    for c in d.data.columns:
        if d.data[c].dtype.kind == "f":
            assert np.array_equal(back.data[c].to_numpy(), d.data[c].to_numpy()), c
    assert back.meta.vehicle == d.meta.vehicle
    assert back.meta.truth == d.meta.truth
    assert back.meta.extra == d.meta.extra
    assert back.meta.source == d.meta.source
    assert back.meta.sample_rate == d.meta.sample_rate
    assert back.extra_columns == ["my_extra", "my_flag", "my_count"]
    # the true tire survives: same curve at any slip
    s = np.linspace(-0.3, 0.3, 41)
    assert np.array_equal(back.true_tire("front", surface="snow").mu(s), SURFACES["snow"].lateral.mu(s))


@pytest.mark.slow
@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
@pytest.mark.parametrize(("scenario", "duration"), [("straight-cruise", None), ("snow-slalom", 40.0),
                                                    ("dry-gravel-dry", 40.0)])
def test_simulated_round_trip(tmp_path, suffix, scenario, duration):
    scen = pytest.importorskip("roadgrip.sim.scenarios", reason="simulator not available")
    d = scen.simulate_scenario(scenario, seed=1, duration=duration)
    p = tmp_path / f"sim{suffix}"
    d.save(p)
    back = read_drive(p)
    pd.testing.assert_frame_equal(back.data, d.data, check_exact=True)
    for c in d.data.columns:
        if d.data[c].dtype.kind == "f":
            assert np.array_equal(back.data[c].to_numpy(), d.data[c].to_numpy(), equal_nan=True), c
    assert back.meta == d.meta
    s = np.linspace(-0.2, 0.2, 21)
    assert np.array_equal(back.true_tire().mu(s), d.true_tire().mu(s))


def test_vehicle_override(tmp_path):
    d = _synthetic_drive(n=50)
    p = tmp_path / "d.parquet"
    d.save(p)
    assert read_drive(p).vehicle.name == "suv"
    assert read_drive(p, vehicle="sedan").vehicle == PRESETS["sedan"]


def test_plain_csv_needs_vehicle(tmp_path):
    p = tmp_path / "plain.csv"
    _synthetic_drive(n=50).data.to_csv(p, index=False)
    with pytest.raises(ValueError, match="no roadgrip metadata: pass the vehicle"):
        read_drive(p)
    d = read_drive(p, vehicle="sedan")
    assert d.vehicle.name == "sedan"
    assert d.n == 50
    assert d.data["steer"].dtype == np.float64  # canonical columns come back as floats


def test_missing_file_message(tmp_path):
    with pytest.raises(ValueError, match="no such file"):
        read_drive(tmp_path / "nope.csv")


def test_empty_file_message(tmp_path):
    p = tmp_path / "empty.csv"
    p.write_text("")
    with pytest.raises(ValueError, match="empty"):
        read_drive(p)


def test_header_only_file_message(tmp_path):
    p = tmp_path / "header.csv"
    p.write_text("t,ax\n")
    with pytest.raises(DriveValidationError, match="drive is empty"):
        read_drive(p, vehicle="sedan")


def test_unknown_format_message(tmp_path):
    p = tmp_path / "d.csv"
    _synthetic_drive(n=20).save(p)
    with pytest.raises(ValueError, match="unknown format 'rosbag'"):
        read_drive(p, format="rosbag")
    q = tmp_path / "d.txt"
    q.write_text("t\n0\n")
    with pytest.raises(ValueError, match="cannot tell the format"):
        read_drive(q)


def test_detect_format(tmp_path):
    (tmp_path / "DS9").mkdir()
    (tmp_path / "DS9" / "imuData.csv").write_text(",s,ns\n")
    assert detect_format(tmp_path / "DS9") == "frictionmaps"
    dart = tmp_path / "run.csv"
    dart.write_text("elapsed time sensors,current\n0,0\n")
    assert detect_format(dart) == "dart"
    canon = tmp_path / "c.csv"
    _synthetic_drive(n=10).save(canon)
    assert detect_format(canon) == "canonical"
    with pytest.raises(ValueError, match="cannot tell the format of folder"):
        detect_format(tmp_path)


def test_bad_parquet_message(tmp_path):
    p = tmp_path / "bad.parquet"
    p.write_bytes(b"not parquet at all")
    with pytest.raises(ValueError, match="not a readable Parquet file"):
        read_drive(p)
