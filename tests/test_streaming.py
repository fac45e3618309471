"""Long drives in chunks: the cascade and the two classifiers streamed equal their runs over
the whole drive, the reader yields the file's rows without truth, `roadgrip estimate
--stream` writes what the whole run writes, and (slow) two hours of driving run in bounded
memory with healthy states (positive definite covariances, every row estimated once)."""

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
from roadgrip.estimators.classify import BRLS, SLIPMAP, Calibration
from roadgrip.estimators.classify.stream import run_chunks as classifier_chunks

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


@pytest.fixture(scope="module")
def dgd_full():
    """The whole dry-gravel-dry drive (180 s): both classifiers change class on it."""
    from roadgrip.sim.scenarios import simulate_scenario

    return simulate_scenario("dry-gravel-dry", seed=0)


def _classifier_configs(vehicle):
    """Uncalibrated and calibrated settings of each classifier, with the prefilters on (their
    state crosses the seams) and the kinematic lateral acceleration (its dvy/dt does)."""
    from dataclasses import replace

    from roadgrip.estimators.classify.brls_config import default_config, saturation_config
    from roadgrip.estimators.classify.grip_model import default_grip_model
    from roadgrip.estimators.classify.slipmap_config import default_config as slipmap_default

    paper = replace(default_config(), prefilter_tau_s=0.3, lateral_acceleration="kinematic")
    fitted = saturation_config(default_grip_model(vehicle, 1.0, 0.6), lateral=True)  # braking slips too
    slip = replace(slipmap_default(), prefilter_tau_s=0.5)
    return {
        "brls uncalibrated": BRLS.Config(),
        "brls paper": BRLS.Config(calibration=Calibration(paper)),
        "brls fitted model": BRLS.Config(calibration=Calibration(fitted)),
        "slipmap uncalibrated": SLIPMAP.Config(),
        "slipmap calibrated": SLIPMAP.Config(calibration=Calibration(paper, slipmap=slip)),
    }


CLASSIFIER_CASES = ["brls uncalibrated", "brls paper", "brls fitted model", "slipmap uncalibrated",
                    "slipmap calibrated"]


@pytest.mark.parametrize("case", CLASSIFIER_CASES)
@pytest.mark.parametrize("aid", ["wheels", "pose"])
def test_classifier_chunks_equal_the_whole_drive(dgd_full, case, aid):
    """The kinematic stage, the prefilters, the bRLS channels and state machine or the slip
    map's recursion continue across the seams: the chunks give the whole run's rows. With
    the pose aid (front wheel speeds dropped) the pose and the kinematic lateral
    acceleration's dvy/dt cross the seams too. A restart at every seam does not give them."""
    if aid == "wheels":
        drive = dgd_full.with_data(dgd_full.data.drop(columns=["x", "y", "psi"]))
    else:
        drive = dgd_full.with_data(dgd_full.data.drop(columns=["omega_fl", "omega_fr"]))
    config = _classifier_configs(drive.vehicle)[case]
    est = BRLS if case.startswith("brls") else SLIPMAP
    whole = est.run(drive, config).table
    pieces = _pieces(drive, [0, 1234, 1235, 4500, 9000, drive.n])  # uneven, one of one sample
    results = list(classifier_chunks(pieces, config))
    assert {r.info.derived["aid"] for r in results} == {aid}
    parts = pd.concat([r.table for r in results], ignore_index=True)
    assert list(parts.columns) == list(whole.columns) and len(parts) == len(whole)
    num = whole.select_dtypes("number").columns
    np.testing.assert_allclose(parts[num].to_numpy(float), whole[num].to_numpy(float), rtol=0, atol=1e-12)
    other = whole.columns.difference(num)
    assert (parts[other] == whole[other]).all().all()
    # the comparison has power: restarted at each seam, the rows differ
    restarted = pd.concat([next(classifier_chunks([p], config)).table for p in pieces], ignore_index=True)
    assert not np.allclose(restarted[num].to_numpy(float), whole[num].to_numpy(float), atol=1e-6,
                           equal_nan=True)


def test_classifiers_change_class_on_the_drive(dgd_full):
    """The equality above is checked over class changes, not one class held throughout."""
    bare = dgd_full.with_data(dgd_full.data.drop(columns=["x", "y", "psi"]))
    for case, config in _classifier_configs(bare.vehicle).items():
        est = BRLS if case.startswith("brls") else SLIPMAP
        cls = est.run(bare, config).table["grip_class"]
        assert {"high", "low"} <= set(cls), case


def test_classifier_chunks_must_follow_in_time(dgd):
    pieces = _pieces(dgd, [0, 3000, dgd.n])
    with pytest.raises(ValueError, match="chunks must follow each other in time"):
        list(classifier_chunks([pieces[0], pieces[0]], SLIPMAP.Config()))
    with pytest.raises(ValueError, match="streams the bRLS or the slip-map classifier, not a CascadeConfig"):
        list(classifier_chunks(pieces, FIXED))


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


def test_stream_command_runs_the_gpssm(dgd, tmp_path):
    """``--stream --method gpssm`` writes the whole run's table, in several chunks too."""
    from typer.testing import CliRunner

    from roadgrip.cli import app
    from roadgrip.estimators import EstimateResult, run_estimator

    src = tmp_path / "d.parquet"
    dgd.save(src)
    opts = ["--particles", "40"]
    res = CliRunner().invoke(app, ["estimate", str(src), "--method", "gpssm", "--stream", *opts, "-o",
                                   str(tmp_path / "s.parquet")])
    assert res.exit_code == 0, res.output
    whole = run_estimator("gpssm", dgd, {"particles": 40}).table
    streamed = EstimateResult.read_parquet(tmp_path / "s.parquet")
    assert streamed.method == "gpssm"
    pd.testing.assert_frame_equal(streamed.table, whole)
    stats = stream_estimate(src, tmp_path / "s.csv", "gpssm", rows=1500, options={"particles": 40})
    assert stats["rows"] == dgd.n
    chunked = pd.read_csv(tmp_path / "s.csv")
    for col in ("mu_front", "mu_rear_lower", "mu_rear_upper", "vy", "ess"):
        np.testing.assert_allclose(chunked[col], whole[col], rtol=1e-12, equal_nan=True)


@pytest.mark.parametrize("method", ["brls", "slipmap"])
def test_stream_command_runs_the_classifiers(dgd, tmp_path, method):
    """``--stream --method brls|slipmap`` (with a calibration file for the bRLS) writes the
    whole run's table; in several chunks too."""
    from typer.testing import CliRunner

    from roadgrip.cli import app
    from roadgrip.cli.calibrate import write_calibration
    from roadgrip.estimators import EstimateResult
    from roadgrip.estimators.classify.brls_config import default_config

    src = tmp_path / "d.parquet"
    dgd.save(src)
    extra = []
    if method == "brls":
        write_calibration(Calibration(default_config()), tmp_path / "cal.yaml")
        extra = ["--calibration", str(tmp_path / "cal.yaml")]
    runner = CliRunner()
    res = runner.invoke(app, ["estimate", str(src), "--method", method, "--stream", "-o",
                              str(tmp_path / "s.parquet"), *extra])
    assert res.exit_code == 0, res.output
    assert "grip class (final):" in res.output and "samples/s, peak memory" in res.output
    res = runner.invoke(app, ["estimate", str(src), "--method", method, "-o", str(tmp_path / "w.parquet"), *extra])
    assert res.exit_code == 0, res.output
    streamed, whole = EstimateResult.read_parquet(tmp_path / "s.parquet"), EstimateResult.read_parquet(tmp_path / "w.parquet")
    assert streamed.method == method and streamed.meta["derived"] == {"aid": "wheels"}
    pd.testing.assert_frame_equal(streamed.table, whole.table)
    options = {"calibration": Calibration(default_config())} if method == "brls" else {}
    stats = stream_estimate(src, tmp_path / "s.csv", method, rows=1500, options=options)
    assert stats["rows"] == dgd.n
    chunked = pd.read_csv(tmp_path / "s.csv")
    assert (chunked["grip_class"] == whole.table["grip_class"]).all()
    np.testing.assert_allclose(chunked["grip_index"], whole.table["grip_index"], rtol=0, atol=1e-12)


@pytest.mark.parametrize(("extra", "message"), [
    (["--method", "gpssm", "--curves", "{tmp}/c.parquet"], "--curves need the whole drive"),
    (["--method", "slipmap", "--vss", "{tmp}/v.jsonl"], "--vss need the whole drive"),
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


def _bench():
    spec = importlib.util.spec_from_file_location("bench_long_drive", BENCH)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    return bench


@pytest.fixture(scope="module")
def two_hours(tmp_path_factory):
    """Two hours of driving (720 000 samples at 100 Hz) and its first ten minutes."""
    bench = _bench()
    folder = tmp_path_factory.mktemp("long")
    path, short = folder / "long.parquet", folder / "short.parquet"
    assert bench.write_long_drive(path, 2.0) == 720_000
    bench._short_copy(str(path), str(short))
    return path, short


@pytest.mark.slow
@pytest.mark.parametrize("method", ["cascade", "brls", "slipmap"])
def test_two_hours_streamed_in_bounded_memory(two_hours, method):
    """Two hours streamed: the resident memory does not grow after the first hour and the
    peak stays below 1 GiB; after every chunk the state is healthy (the cascade: the
    covariances of all three stages positive definite and every row's standard deviations
    finite and positive; the bRLS: both channels' covariances positive and estimates finite;
    the slip map: its recursion finite with the index in [0, 1]) and every classifier row
    carries a grip class and a finite grip index, as every row of the whole run does. The
    throughput against the ten-minute drive's is a speed figure:
    ``benchmarks/bench_long_drive.py`` prints it (a timed assertion here would measure the
    other tests sharing the machine)."""
    path, short = two_hours
    proc = subprocess.run([sys.executable, str(BENCH), "--one", method, str(path), str(short)],
                          capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-2000:]
    r = json.loads(proc.stdout.strip().splitlines()[-1])
    assert r["mode"] == "streamed" and r["rows"] == 720_000 and r["chunks"] == 12
    assert r["peak_rss_mib"] < 1024
    # memory follows the row group (one hour here), not the length: no growth after the
    # first hour
    assert r["rss_second_half_mib"] < r["rss_first_half_mib"] + 32, r
    if method == "cascade":
        assert r["min_cov_eig"] > 0 and r["bad_std_rows"] == 0 and r["nan_mu_rows"] == 0, r
    else:
        assert r["bad_state_chunks"] == 0 and r["bad_class_rows"] == 0, r
        if method == "brls":
            assert r["min_cov_eig"] > 0, r
    # every row passes through the estimator once: chunks neither skip nor repeat rows
    assert sum(r["chunk_rows"]) == r["rows"], r


@pytest.mark.slow
def test_two_hours_of_gpssm_streamed_in_bounded_memory(two_hours):
    """The GP-SSM (the command's defaults, 200 particles) over the same two hours, streamed:
    resident memory below 1 GiB and not growing after the first hour; after every chunk
    every particle's information matrix at least ``I`` and its posterior ``Lambda``
    positive definite, every row's peak bands finite and holding the estimate, every
    row whose weights collapsed (effective sample size below 1.5) flagged ``collapsed`` or
    ``diverged``, and fewer than 0.5 % of the rows flagged ``diverged``. No throughput
    comparison (``SHORT`` '-'): about twelve minutes of filtering here;
    ``benchmarks/bench_long_drive.py --methods gpssm`` prints it."""
    path, _ = two_hours
    proc = subprocess.run([sys.executable, str(BENCH), "--one", "gpssm", str(path), "-"],
                          capture_output=True, text=True, timeout=3600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    r = json.loads(proc.stdout.strip().splitlines()[-1])
    assert r["mode"] == "streamed" and r["rows"] == 720_000 and r["chunks"] == 12
    assert sum(r["chunk_rows"]) == r["rows"], r
    assert r["peak_rss_mib"] < 1024
    assert r["rss_second_half_mib"] < r["rss_first_half_mib"] + 32, r
    assert r["min_info_eig"] >= 1.0 - 1e-8 and r["min_cov_eig"] > 0, r
    assert r["bad_band_rows"] == 0, r
    # any row whose weights collapsed is flagged (the flag itself: test_gpssm_guard)
    assert r["collapsed_unflagged_rows"] == 0, r
    # the sedan's own model family: none of its 720 000 rows diverged here (4 % of the
    # rows did while straight driving pulled the accelerometer gain down,
    # GPSSMConfig.ay_gain_gate); the bound leaves room for another machine's rounding
    assert r["diverged_rows"] < 0.005 * r["rows"], r


def test_describe_chunks_equals_the_whole_description(dgd):
    """Counts, extremes, means, the truth and ay fractions as over the whole drive; the yaw
    proxy's linear model restarts per chunk (within a point of the whole drive's); the
    units and signs are judged on the first chunk (so named: its evidence is the chunk's,
    e.g. no cornering yet for ay ~ vx r), over the same identities, none refused."""
    from roadgrip.io.describe import describe_chunks, describe_drive

    whole = describe_drive(dgd)
    parts = describe_chunks(_pieces(dgd, [0, 1500, 3000, 4500, dgd.n]))
    first = " (first chunk)"
    assert [s.title.removesuffix(first) for s in parts] == [s.title for s in whole]
    for a, b in zip(parts, whole, strict=True):
        if a.title.endswith(first):
            assert [r[0] for r in a.rows] == [r[0] for r in b.rows], (a.rows, b.rows)
            assert all(r[-1] in ("consistent", "unverified") for r in a.rows), a.rows
            continue
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
