"""Long drives in chunks: the cascade streamed equals the cascade over the whole drive, the
reader yields the file's rows without truth, `roadgrip estimate --stream` writes what the
whole run writes, and (slow) two hours of driving run in bounded memory with positive
definite covariances at the throughput of a short drive."""

from __future__ import annotations

import importlib.util
import itertools
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from roadgrip.cli.stream import drive_chunks, stream_estimate
from roadgrip.estimators.cascade import CascadeConfig
from roadgrip.estimators.cascade.estimator import run as cascade_run
from roadgrip.estimators.cascade.stream import run_chunks

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "benchmarks" / "bench_long_drive.py"

# the values prepare derives from a whole drive, given: the chunks then equal the whole run
FIXED = CascadeConfig(accel_std=0.1, gyro_std=0.005, speed_std=0.05, accel_bias_std=0.0)


@pytest.fixture(scope="module")
def dgd():
    from roadgrip.sim.scenarios import simulate_scenario

    return simulate_scenario("dry-gravel-dry", seed=0, duration=60.0)


def _pieces(drive, edges):
    return [drive.with_data(drive.data.iloc[a:b]) for a, b in itertools.pairwise(edges)]


def test_chunks_equal_the_whole_drive(dgd):
    bare = dgd.with_data(dgd.data.drop(columns=["x", "y", "psi"]))
    whole = cascade_run(bare, FIXED).table
    edges = [0, 1234, 1236, 4500, bare.n]  # uneven, one of two samples
    parts = pd.concat([r.table for r in run_chunks(_pieces(bare, edges), FIXED)], ignore_index=True)
    assert list(parts.columns) == list(whole.columns) and len(parts) == len(whole)
    num = whole.select_dtypes("number").columns
    np.testing.assert_allclose(parts[num].to_numpy(float), whole[num].to_numpy(float), rtol=0, atol=1e-9)
    other = whole.columns.difference(num)
    assert (parts[other] == whole[other]).all().all()
    # the sustained-grip floor continues across the seams (it is a running maximum)
    assert parts["grip_floor"].is_monotonic_increasing and parts["grip_floor"].iloc[-1] > 0.1


def test_chunks_with_a_pose_differ_only_near_the_seams(dgd):
    """The pose's derivative is taken per chunk (its smoothing window ends at a seam)."""
    whole = cascade_run(dgd, FIXED).table
    parts = pd.concat([r.table for r in run_chunks(_pieces(dgd, [0, 2000, 4000, dgd.n]), FIXED)],
                      ignore_index=True)
    assert np.nanmax(np.abs(parts["vx"] - whole["vx"])) < 0.05
    for col in ("mu_front", "mu_rear", "mu_front_upper", "mu_rear_lower"):
        assert np.nanmax(np.abs(parts[col] - whole[col])) < 0.01, col


def test_drive_chunks_read_the_rows_without_truth(dgd, tmp_path):
    path = tmp_path / "d.parquet"
    dgd.save(path)
    n, chunks = drive_chunks(path, rows=2500)
    chunks = list(chunks)
    assert n == dgd.n == 6001
    # 2500, 2500 and a rest of 1001 (a rest below two rows would join the chunk before)
    assert [c.n for c in chunks] == [2500, 2500, 1001]
    assert not any(c.endswith("_true") or c == "surface" for c in chunks[0].data.columns)
    both = pd.concat([c.data for c in chunks], ignore_index=True)
    for col in ("t", "ay", "yaw_rate", "omega_rl"):
        np.testing.assert_array_equal(both[col].to_numpy(), dgd.col(col))
    assert chunks[0].vehicle == dgd.vehicle
    _, chunks = drive_chunks(path, rows=3000)  # 3000, 3000 and a rest of one row
    assert [c.n for c in chunks] == [3000, 3001]


def test_drive_chunks_name_unreadable_metadata(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.table({"t": [0.0, 0.01], "ax": [0.0, 0.0]})
    path = tmp_path / "broken.parquet"
    pq.write_table(table.replace_schema_metadata({b"roadgrip": b'{"vehicle": 3'}), path)
    with pytest.raises(ValueError, match=r"broken.parquet: unreadable roadgrip metadata"):
        drive_chunks(path)


def test_stream_command_writes_what_the_whole_run_writes(dgd, tmp_path):
    from typer.testing import CliRunner

    from roadgrip.cli import app
    from roadgrip.estimators import EstimateResult

    src = tmp_path / "d.parquet"
    dgd.save(src)
    res = CliRunner().invoke(app, ["estimate", str(src), "--method", "cascade", "--stream", "-o",
                                   str(tmp_path / "s.parquet")])
    assert res.exit_code == 0, res.output
    assert "samples/s, peak memory" in res.output
    res = CliRunner().invoke(app, ["estimate", str(src), "--method", "cascade", "-o", str(tmp_path / "w.parquet")])
    assert res.exit_code == 0, res.output
    streamed, whole = EstimateResult.read_parquet(tmp_path / "s.parquet"), EstimateResult.read_parquet(tmp_path / "w.parquet")
    assert streamed.method == "cascade" and streamed.meta["streamed"]["chunk_rows"] > 0
    pd.testing.assert_frame_equal(streamed.table, whole.table)
    # several chunks, CSV output: the rows of the Parquet chunks
    stats = stream_estimate(src, tmp_path / "s.csv", "cascade", rows=1500, options={"accel_std": 0.1})
    assert stats["rows"] == dgd.n and stats["duration_s"] == pytest.approx(dgd.duration)
    assert len(pd.read_csv(tmp_path / "s.csv")) == dgd.n


@pytest.mark.parametrize(("extra", "message"), [
    (["--method", "brls"], "--stream runs cascade, not 'brls'"),
    (["--method", "gpssm"], "--stream runs cascade, not 'gpssm'"),
    (["--method", "cascade", "--plot", "{tmp}/p.png"], "--plot need the whole drive"),
    (["--method", "cascade", "--align"], "--align need the whole drive"),
])
def test_stream_refuses_what_it_cannot_do_before_reading(extra, message, tmp_path, monkeypatch):
    from typer.testing import CliRunner

    import roadgrip.cli.stream
    from roadgrip.cli import app

    def no_work(*a, **k):
        raise AssertionError("the drive was read")

    monkeypatch.setattr(roadgrip.cli.stream, "drive_chunks", no_work)
    src = tmp_path / "d.parquet"
    src.write_bytes(b"PAR1")
    extra = [a.format(tmp=tmp_path) for a in extra]
    res = CliRunner().invoke(app, ["estimate", str(src), "--stream", "-o", str(tmp_path / "e.parquet"), *extra])
    assert res.exit_code != 0 and message in str(res.exception), res.exception


@pytest.mark.slow
def test_two_hours_streamed_in_bounded_memory(tmp_path):
    """Two hours (720 000 samples at 100 Hz): the resident memory does not grow after the
    first hour and the peak stays below 1 GiB; the covariances of
    all three stages are positive definite after every chunk and every row's standard
    deviations finite and positive. The throughput against the ten-minute drive's is a speed
figure: ``benchmarks/bench_long_drive.py`` prints it (a timed assertion here would measure the
other tests sharing the machine)."""
    spec = importlib.util.spec_from_file_location("bench_long_drive", BENCH)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    path, short = tmp_path / "long.parquet", tmp_path / "short.parquet"
    assert bench.write_long_drive(path, 2.0) == 720_000
    bench._short_copy(str(path), str(short))
    proc = subprocess.run([sys.executable, str(BENCH), "--one", "cascade", str(path), str(short)],
                          capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-2000:]
    r = json.loads(proc.stdout.strip().splitlines()[-1])
    assert r["rows"] == 720_000 and r["chunks"] == 12
    assert r["peak_rss_mib"] < 1024
    # memory follows the row group (one hour here), not the length: no growth after the
    # first hour
    assert r["rss_second_half_mib"] < r["rss_first_half_mib"] + 32, r
    assert r["min_cov_eig"] > 0 and r["bad_std_rows"] == 0 and r["nan_mu_rows"] == 0, r
    # every row passes through the filter once: chunks neither skip nor repeat rows
    assert sum(r["chunk_rows"]) == r["rows"], r


def test_describe_chunks_equals_the_whole_description(dgd):
    """Counts, extremes, means, the truth and ay fractions as over the whole drive; the yaw
    proxy's linear model restarts per chunk (within a point of the whole drive's)."""
    from roadgrip.io.describe import describe_chunks, describe_drive

    whole = describe_drive(dgd)
    parts = describe_chunks(_pieces(dgd, [0, 1500, 3000, 4500, dgd.n]))
    assert [s.title for s in parts] == [s.title for s in whole]
    for a, b in zip(parts, whole, strict=True):
        if a.title != "nonlinear tire excitation":
            assert a.rows == b.rows, a.title
            continue
        for ra, rb in zip(a.rows, b.rows, strict=True):
            if ra[0] == "yaw":
                assert abs(float(ra[1].rstrip("%")) - float(rb[1].rstrip("%"))) <= 1.0, (ra, rb)
            else:
                assert ra == rb


def test_info_reads_a_long_drive_in_chunks(dgd, tmp_path, monkeypatch):
    from typer.testing import CliRunner

    import roadgrip.cli.info as info
    from roadgrip.cli import app

    src = tmp_path / "d.parquet"
    dgd.save(src)
    monkeypatch.setattr(info, "LONG_ROWS", 1000)
    monkeypatch.setattr(info, "INFO_CHUNK_ROWS", 2000)
    from roadgrip.cli import _common

    monkeypatch.setattr(_common.console, "width", 200)
    res = CliRunner().invoke(app, ["info", str(src)])
    assert res.exit_code == 0, res.output
    assert "read in chunks" in res.output and "from the first 20 s of 6001 rows" in res.output
    assert "6001" in res.output and "nonlinear tire excitation" in res.output


def test_peak_memory_of_a_child_is_its_own():
    """A process started from a large one reports its own peak, not its parent's (Linux
    keeps ``ru_maxrss`` across ``execve``; the streamed run is measured in a child)."""
    from roadgrip.cli.stream import peak_rss_bytes

    ballast = np.ones(40_000_000)  # 320 MB resident in this process
    parent = peak_rss_bytes()
    child = subprocess.run([sys.executable, "-c", "from roadgrip.cli.stream import peak_rss_bytes; "
                            "print(peak_rss_bytes())"], capture_output=True, text=True, check=True)
    assert parent > ballast.nbytes
    assert int(child.stdout) < parent - 250e6, (int(child.stdout), parent)
