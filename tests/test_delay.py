"""Sensor delays (roadgrip.sensor_delay): known lags recovered, and the delays of 0.1-0.6 s
inserted into simulated drives (planar, lateral and multi-body) recovered within 20 ms,
by the library and by `roadgrip info`; `--align` removes them."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from roadgrip.drive import Drive
from roadgrip.io.calibration import shift_columns
from roadgrip.sensor_delay import (
    align_drive,
    estimate_delay,
    lag_correlation,
    masked_lag_correlation,
    sensor_delays,
)

TOL = 0.020
"""Acceptance: an inserted delay recovered within 20 ms [s]."""


def _broadband(t: np.ndarray, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    freqs = rng.uniform(0.1, 1.5, 12)
    phases = rng.uniform(0, 2 * np.pi, 12)
    return sum(np.sin(2 * np.pi * f * t + p) / (1 + f) for f, p in zip(freqs, phases, strict=True))


def _delay_by(drive: Drive, columns, tau: float) -> Drive:
    """``col_new(t) = col(t - tau)``: the columns arrive ``tau`` [s] late."""
    return shift_columns(drive, {c: -tau for c in columns})


def test_lag_correlation_equals_direct_sums():
    rng = np.random.default_rng(3)
    sig, ref = rng.standard_normal(300), rng.standard_normal(300)
    c, es, er = lag_correlation(sig, ref, 7)
    for j, k in enumerate(range(-7, 8)):
        if k >= 0:
            a, b = sig[k:], ref[:300 - k]
        else:
            a, b = sig[:300 + k], ref[-k:]
        assert c[j] == pytest.approx(np.dot(a, b), abs=1e-9)
        assert es[j] == pytest.approx(np.dot(a, a)) and er[j] == pytest.approx(np.dot(b, b))


def test_masked_lag_correlation_equals_direct_sums():
    rng = np.random.default_rng(4)
    sig, ref = rng.standard_normal(300), rng.standard_normal(300)
    ok = rng.uniform(size=300) > 0.3
    c, es, er = masked_lag_correlation(sig, ref, ok, 7)
    for j, k in enumerate(range(-7, 8)):
        i = np.array([i for i in range(300) if ok[i] and 0 <= i - k < 300])
        assert c[j] == pytest.approx(np.dot(sig[i], ref[i - k]), abs=1e-9)
        assert es[j] == pytest.approx(np.dot(sig[i], sig[i]))
        assert er[j] == pytest.approx(np.dot(ref[i - k], ref[i - k]))
    # all samples kept: the plain overlapping sums
    np.testing.assert_allclose(np.stack(masked_lag_correlation(sig, ref, np.ones(300, bool), 7)),
                               np.stack(lag_correlation(sig, ref, 7)), atol=1e-9)


def test_signal_valid_leaves_out_where_the_signal_departs():
    # a signal 0.2 s late except in stretches where it runs 0.15 s early (a braked wheel's
    # speed falling ahead of the car's): left out, they no longer pull the peak
    t = np.arange(0.0, 240.0, 0.01)
    ref = _broadband(t, 5)
    departs = (t % 20.0) < 6.0
    sig = np.where(departs, _broadband(t + 0.15, 5), _broadband(t - 0.2, 5))
    biased = estimate_delay(t, sig, ref)
    assert abs(biased.delay - 0.2) > 0.03
    fit = estimate_delay(t, sig, ref, signal_valid=~departs)
    assert abs(fit.delay - 0.2) < 0.005, fit


@pytest.mark.parametrize(("rate", "tau"), [(25.0, 0.137), (50.0, -0.29), (100.0, 0.6), (10.0, 0.43)])
def test_a_known_fractional_delay_is_recovered(rate, tau):
    t = np.arange(0.0, 240.0, 1.0 / rate)
    rng = np.random.default_rng(1)
    ref = _broadband(t, 0)
    # gain, offset and noise on the delayed signal change nothing
    sig = 1.3 * _broadband(t - tau, 0) + 0.4 + 0.05 * rng.standard_normal(len(t))
    fit = estimate_delay(t, sig, ref)
    assert abs(fit.delay - tau) < 0.004, fit
    assert fit.reliable and fit.peak_corr > 0.95 and fit.std < 0.005


def test_delays_beyond_the_search_and_unexcited_signals_are_not_reliable():
    t = np.arange(0.0, 120.0, 0.02)
    ref = _broadband(t, 2)
    far = estimate_delay(t, _broadband(t - 1.6, 2), ref, max_lag=1.0)
    assert not far.reliable
    rng = np.random.default_rng(0)
    flat = estimate_delay(t, rng.standard_normal(len(t)), rng.standard_normal(len(t)))
    assert flat.peak_corr < 0.2 and not flat.reliable


def test_gaps_in_the_time_base_are_left_out():
    t = np.arange(0.0, 200.0, 0.02)
    keep = (t < 60) | (t > 75)  # a 15 s logger pause
    ref, sig = _broadband(t, 4), _broadband(t - 0.21, 4)
    fit = estimate_delay(t[keep], sig[keep], ref[keep])
    assert abs(fit.delay - 0.21) < 0.004 and fit.reliable


# -- simulated drives -------------------------------------------------------------------
SIMS = {
    "lateral snow-slalom 25 Hz": ("snow-slalom", None, None, 250.0),
    "planar dry-gravel-dry 100 Hz": ("dry-gravel-dry", None, None, 180.0),
    "planar f1tenth-patches 50 Hz": ("f1tenth-patches", None, None, 60.0),
    "multibody snow-slalom ford-escort": ("snow-slalom", "multibody", "ford-escort", 200.0),
    "multibody dry-gravel-dry vw-vanagon": ("dry-gravel-dry", "multibody", "vw-vanagon", 180.0),
}


@pytest.fixture(scope="module", params=list(SIMS))
def sim(request):
    from roadgrip.sim.scenarios import simulate_scenario

    name, engine, vehicle, duration = SIMS[request.param]
    return request.param, simulate_scenario(name, seed=1, engine=engine, vehicle=vehicle, duration=duration)


def _by_sensor(delays):
    return {d.sensor: d for d in delays}


def test_inserted_delays_are_recovered_within_20_ms(sim):
    label, drive = sim
    base = _by_sensor(sensor_delays(drive))
    # the simulators' sensors have no delay: both read about zero
    for name in ("gyro", "accelerometer"):
        assert abs(base[name].delay) < TOL, (label, name, base[name])
        assert base[name].reliable, (label, base[name])
    for tau in (0.1, 0.237, 0.45, 0.6):
        acc = _by_sensor(sensor_delays(_delay_by(drive, ("ax", "ay"), tau)))
        assert abs(acc["accelerometer"].delay - tau) < TOL, (label, tau, acc["accelerometer"])
        assert abs(acc["gyro"].delay) < TOL
        assert acc["accelerometer"].reliable
        gyro = _by_sensor(sensor_delays(_delay_by(drive, ("yaw_rate",), tau)))
        assert abs(gyro["gyro"].delay - tau) < TOL, (label, tau, gyro["gyro"])
        assert gyro["gyro"].reliable
        # the accelerometer is stated against the pose: the gyro's delay hardly moves it (its
        # pair ay~vx*r moves by -tau and the gyro's own pair by +tau; 23 ms apart at most on
        # the 60 s f1tenth drive with tau = 0.6 s)
        assert abs(gyro["accelerometer"].delay - base["accelerometer"].delay) < 1.5 * TOL


def test_without_a_pose_the_accelerometer_is_stated_against_the_gyro(sim):
    label, drive = sim
    bare = drive.with_data(drive.data.drop(columns=["x", "y", "psi"]))
    delayed = _by_sensor(sensor_delays(_delay_by(bare, ("ay",), 0.35)))
    assert set(delayed) == {"accelerometer"} and delayed["accelerometer"].reference == "gyro"
    # without the pose's sideslip rate the reference lacks dvy/dt: a bias of some 10-60 ms
    assert abs(delayed["accelerometer"].delay - 0.35) < 0.07, (label, delayed)


def test_align_drive_removes_the_delays(sim):
    label, drive = sim
    delayed = _delay_by(_delay_by(drive, ("ax", "ay"), 0.3), ("yaw_rate",), 0.15)
    aligned, applied = align_drive(delayed)
    assert {d.sensor for d in applied} == {"gyro", "accelerometer"}
    again = _by_sensor(sensor_delays(aligned))
    for name in ("gyro", "accelerometer"):
        assert abs(again[name].delay) < TOL, (label, again[name])
    assert aligned.meta.extra["alignment_s"]["yaw_rate"] == pytest.approx(0.15, abs=TOL)
    # the aligned signals equal the undelayed ones at the same times
    t = aligned.t
    ay = np.interp(t, drive.t, drive.col("ay"))
    err = np.abs(aligned.col("ay") - ay)
    assert np.median(err) < 0.1 * np.std(ay), label


# -- the command line -------------------------------------------------------------------
@pytest.fixture(scope="module")
def delayed_file(tmp_path_factory):
    from roadgrip.sim.scenarios import simulate_scenario

    drive = simulate_scenario("snow-slalom", seed=2, engine="multibody", vehicle="ford-escort",
                              duration=120.0)
    delayed = _delay_by(_delay_by(drive, ("ax", "ay"), 0.55), ("yaw_rate",), 0.12)
    path = tmp_path_factory.mktemp("delay") / "delayed.parquet"
    delayed.save(path)
    return path


def _row(output: str, sensor: str) -> list[str]:
    line = next(ln for ln in output.splitlines() if re.search(rf"\b{sensor}\b", ln) and "pose" in ln)
    return [c.strip() for c in line.strip("│┃| ").split("│")]


def test_info_reports_the_delays_and_align_removes_them(delayed_file, tmp_path, monkeypatch):
    from typer.testing import CliRunner

    from roadgrip.cli import _common, app

    monkeypatch.setattr(_common.console, "width", 200)  # one table row per line
    res = CliRunner().invoke(app, ["info", str(delayed_file)])
    assert res.exit_code == 0, res.output
    acc, gyro = _row(res.output, "accelerometer"), _row(res.output, "gyro")
    assert abs(float(acc[2]) - 550) <= 1000 * TOL and acc[-1] == "reliable", acc
    assert abs(float(gyro[2]) - 120) <= 1000 * TOL and gyro[-1] == "reliable", gyro
    res = CliRunner().invoke(app, ["info", str(delayed_file), "--align"])
    assert res.exit_code == 0, res.output
    assert "--align: moved yaw_rate" in res.output and "ax/ay" in res.output
    out = tmp_path / "e.parquet"
    res = CliRunner().invoke(app, ["estimate", str(delayed_file), "--method", "cascade", "--align",
                                   "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert "--align: moved" in res.output
    tab = pd.read_parquet(out)
    assert tab["t"].iloc[-1] < pd.read_parquet(delayed_file)["t"].iloc[-1]  # the ends dropped


def test_figure_eight_biases_the_accelerometer_by_its_roll_but_keeps_inserted_delays():
    """On the multi-body figure-eight (braking in the turns, 280 s) the accelerometer reads
    about 40 ms behind the pose although the simulator delays nothing: the body's roll
    leaks gravity into ``ay`` after the lateral acceleration builds up, and the pose's
    smoothed sideslip rate misses the braked crossings. An inserted delay still adds to
    that reading within 20 ms."""
    from roadgrip.sim.scenarios import simulate_scenario

    drive = simulate_scenario("figure-eight", seed=1, engine="multibody", vehicle="ford-escort",
                              duration=280.0)
    base = _by_sensor(sensor_delays(drive))
    assert 0.02 < base["accelerometer"].delay < 0.06 and abs(base["gyro"].delay) < TOL
    for tau in (0.1, 0.6):
        acc = _by_sensor(sensor_delays(_delay_by(drive, ("ax", "ay"), tau)))["accelerometer"]
        assert abs(acc.delay - base["accelerometer"].delay - tau) < TOL, (tau, acc)


DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"


@pytest.mark.realdata
@pytest.mark.skipif(not (DATA / "frictionmaps").is_dir(), reason="shared data not found")
def test_frictionmaps_recordings_gyro_ahead_of_the_pose_accelerometer_behind():
    """The five F1TENTH recordings: the gyro leads the particle-filter pose by 8-29 ms and
    the accelerometer trails the pose by 0-100 ms, every delay reliable (peak correlation
    >= 0.86, standard error <= 15 ms)."""
    from roadgrip.io import read_drive

    for ds in ("DS1", "DS2", "DS3", "DS4", "DS5"):
        delays = _by_sensor(sensor_delays(read_drive(DATA / "frictionmaps" / ds)))
        gyro, acc = delays["gyro"], delays["accelerometer"]
        assert gyro.reliable and acc.reliable, (ds, gyro, acc)
        assert -0.04 < gyro.delay < 0.0, (ds, gyro)
        assert -0.01 < acc.delay < 0.12, (ds, acc)
