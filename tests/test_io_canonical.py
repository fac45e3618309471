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
    with pytest.raises(ValueError, match="unknown format 'hdf5'"):
        read_drive(p, format="hdf5")
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


# -- what real loggers write --------------------------------------------------------------

def _plain(n: int = 60) -> str:
    t = np.arange(n) * 0.01
    return "t,ax,ay,vx\n" + "".join(f"{a:.2f},0.1,{0.01 * i:.2f},10\n" for i, a in enumerate(t))


def _expected(text: str) -> pd.DataFrame:
    import io

    return pd.read_csv(io.StringIO(text)).astype(float)


@pytest.mark.parametrize("encode", ["bom", "utf-16", "utf-16-le", "gzip", "bz2", "xz", "comments",
                                    "crlf"])
def test_logger_dialects_read_to_the_same_drive(tmp_path, encode):
    import bz2
    import gzip
    import lzma

    text = _plain()
    raw = {
        "bom": b"\xef\xbb\xbf" + text.encode(),
        "utf-16": text.encode("utf-16"),
        "utf-16-le": text.encode("utf-16-le"),
        "gzip": gzip.compress(text.encode()),
        "bz2": bz2.compress(text.encode()),
        "xz": lzma.compress(text.encode()),
        "comments": ("# logger v2\n" + text.replace("\n0.30,", "\n# logger restarted here\n0.30,")).encode(),
        "crlf": text.replace("\n", "\r\n").encode(),
    }[encode]
    p = tmp_path / "drive.csv"  # the name says nothing of the compression
    p.write_bytes(raw)
    d = read_drive(p, vehicle="sedan")
    pd.testing.assert_frame_equal(d.data, _expected(text), check_exact=True)


def _refusal(tmp_path, raw: bytes, **kw) -> str:
    from roadgrip.io.canonical import read_canonical_csv

    p = tmp_path / "bad.csv"
    p.write_bytes(raw)
    with pytest.raises(ValueError) as exc:
        read_canonical_csv(p, PRESETS["sedan"], **kw)
    msg = str(exc.value)
    assert "\n" not in msg.strip()
    return msg


def test_refusals_name_file_line_and_problem(tmp_path):
    import gzip

    text = _plain()
    msg = _refusal(tmp_path, text.replace("t,ax,ay,vx", "t,ax,ay,ay").encode())
    assert "bad.csv:1" in msg and "duplicated column name 'ay'" in msg
    msg = _refusal(tmp_path, text.replace("\n0.20,0.1", "\n0.20,abc").encode())
    assert "bad.csv:22" in msg and "'ax'" in msg and "'abc'" in msg
    msg = _refusal(tmp_path, text.replace("0.20,0.1,0.20,10", "0.20,0.1,0.20,10,5").encode())
    assert "bad.csv:22" in msg and "more fields" in msg
    msg = _refusal(tmp_path, gzip.compress(text.encode())[:40])
    assert "bad.csv" in msg and "gzip" in msg and "truncated" in msg
    msg = _refusal(tmp_path, bytes(range(256)) * 4)
    assert "bad.csv:" in msg and "not utf-8 text" in msg
    thousands = text.replace(",10\n", ',"1,000.5"\n')
    msg = _refusal(tmp_path, thousands.encode())
    assert "bad.csv:2" in msg and "'vx'" in msg and "thousands=" in msg


def test_separators_read_only_where_stated(tmp_path):
    from roadgrip.io.canonical import read_canonical_csv

    comma = _plain().replace(",", ";").replace(".", ",")
    msg = _refusal(tmp_path, comma.encode())
    assert "bad.csv:2" in msg and "decimal=','" in msg
    d = read_canonical_csv(tmp_path / "bad.csv", PRESETS["sedan"], decimal=",")
    pd.testing.assert_frame_equal(d.data, _expected(_plain()), check_exact=True)
    (tmp_path / "k.csv").write_text("t,odometer\n" + "".join(f'{0.01 * i:.2f},"1,000.5"\n'
                                                                for i in range(30)))
    d = read_canonical_csv(tmp_path / "k.csv", PRESETS["sedan"], thousands=",")
    assert np.all(d.col("odometer") == 1000.5)


def test_empty_time_rows_dropped_with_warning(tmp_path):
    text = _plain().replace("\n0.10,0.1", "\n,0.1")
    p = tmp_path / "d.csv"
    p.write_text(text)
    with pytest.warns(UserWarning, match=r"d.csv:12: 1 row\(s\) with an empty time"):
        d = read_drive(p, vehicle="sedan")
    assert d.n == 59 and 0.1 not in d.t


def test_duplicated_timestamps_merged_with_warning(tmp_path):
    from roadgrip.drive import DriveWarning

    text = _plain().replace("\n0.10,0.1,0.10,10\n", "\n0.10,0.1,0.10,10\n0.10,0.3,0.10,12\n")
    p = tmp_path / "d.csv"
    p.write_text(text)
    with pytest.warns(DriveWarning, match=r"1 row\(s\) with a duplicated timestamp.*t = 0.1 s"):
        d = read_drive(p, vehicle="sedan")
    assert d.n == 60
    row = d.data[d.data["t"] == 0.1].iloc[0]
    assert row["ax"] == pytest.approx(0.2) and row["vx"] == pytest.approx(11.0)


def test_time_in_milliseconds_refused_with_evidence(tmp_path):
    n = 60
    text = "t,ax\n" + "".join(f"{10 * i},0.1\n" for i in range(n))
    p = tmp_path / "d.csv"
    p.write_text(text)
    with pytest.raises(DriveValidationError, match=r"'t' has a median step of 10 .* in ms: divide 't' by 1000"):
        read_drive(p, vehicle="sedan")
    text = "t,ax\n" + "".join(f"{1_700_000_000_000_000_000 + 10_000_000 * i},0.1\n" for i in range(n))
    p.write_text(text)
    with pytest.raises(DriveValidationError, match=r"'t' .* physical range .* in ns: divide 't' by 1e\+09"):
        read_drive(p, vehicle="sedan")


def test_drive_with_a_reversing_segment_reads_without_error(tmp_path):
    """Forward, stop, reverse while turning: speed, wheel speeds and pose consistent."""
    n, dt = 1500, 0.01
    t = np.arange(n) * dt
    vx = np.where(t < 5, 8.0, np.where(t < 7, 8.0 - 5.5 * (t - 5), -3.0))  # reverses at about 6.5 s
    r = 0.25 * np.sin(0.8 * t)
    psi = np.concatenate([[0.0], np.cumsum(0.5 * (r[1:] + r[:-1]) * dt)])
    x = np.concatenate([[0.0], np.cumsum(vx[1:] * np.cos(psi[1:]) * dt)])
    y = np.concatenate([[0.0], np.cumsum(vx[1:] * np.sin(psi[1:]) * dt)])
    omega = vx / PRESETS["sedan"].wheel_radius
    df = pd.DataFrame({"t": t, "ax": np.gradient(vx, t), "ay": vx * r, "yaw_rate": r, "steer": 0.05 * r,
                       "vx": vx, **{f"omega_{w}": omega for w in ("fl", "fr", "rl", "rr")},
                       "x": x, "y": y, "psi": psi})
    p = tmp_path / "reverse.csv"
    df.to_csv(p, index=False)
    d = read_drive(p, vehicle="sedan")
    assert d.n == n and d.col("vx").min() == -3.0
