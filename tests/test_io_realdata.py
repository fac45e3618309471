"""Readers of the shared real data sets (skipped where ../shared/data is absent)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from roadgrip.io import read_drive
from roadgrip.io.dart import TRACKED_POINT_FROM_REAR, dart_steer_angle
from roadgrip.io.frictionmaps import quaternion_yaw
from roadgrip.vehicle import PRESETS

DATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "data"
DART = DATA / "dart"
FM = DATA / "frictionmaps"

pytestmark = pytest.mark.realdata

needs_dart = pytest.mark.skipif(not DART.is_dir(), reason=f"DART data set not found at {DART}")
needs_fm = pytest.mark.skipif(not FM.is_dir(), reason=f"frictionmaps data set not found at {FM}")


def _dart_files():
    return sorted(DART.glob("*/*.csv")) if DART.is_dir() else []


def _slope(y, x):
    return float(np.dot(y, x) / np.dot(x, x))


# --------------------------------------------------------------------------- dart
def _steer_reference(s: float) -> float:
    """The authors' fit written out independently, scalar math."""
    a, b, c, d, e = 1.3929, 0.36576, -0.027004, 0.51479, 1.02304
    w = 0.5 * (math.tanh(30 * (s + c)) + 1)
    return w * b * math.tanh(a * (s + c)) + (1 - w) * d * math.tanh(e * (s + c))


def test_dart_steer_map():
    s = np.linspace(-1.0, 1.0, 201)
    delta = dart_steer_angle(s)
    assert np.allclose(delta, [_steer_reference(v) for v in s], rtol=0, atol=1e-15)
    assert np.all(np.diff(delta) > 0)  # monotone
    assert abs(float(dart_steer_angle(0.027004))) < 1e-12  # zero at s = -c
    assert delta.max() < 0.4 and delta.min() > -0.45


@needs_dart
@pytest.mark.parametrize("path", _dart_files(), ids=lambda p: p.parent.name[:9] + "/" + p.name[-18:])
def test_dart_reader(path):
    raw = pd.read_csv(path)
    d = read_drive(path)
    assert d.meta.extra["format"] == "dart"
    assert d.vehicle == PRESETS["jetracer"]
    # padding dropped: no row from the zero sensor clock, one row per sensor update
    ts = raw["elapsed time sensors"].to_numpy()
    assert d.meta.extra["padding_rows_dropped"] == int((ts == 0).sum()) > 0
    assert d.n == len(np.unique(ts[ts != 0]))
    assert d.t[0] == 0.0
    assert np.allclose(d.t + d.meta.extra["sensor_clock_offset_s"], np.unique(ts[ts != 0]))
    assert 9.5 < d.meta.sample_rate < 10.5
    # steering: road-wheel angle in range, equal to the map of the command, sign of the turn
    steer = d.col("steer")
    assert np.abs(steer).max() <= PRESETS["jetracer"].max_steer
    assert np.allclose(steer, dart_steer_angle(d.col("steer_cmd")))
    moving = d.col("vx") > 0.5
    assert np.sign(np.median(steer[moving])) == np.sign(np.median(d.col("yaw_rate")[moving]))
    # wheel speeds from the driveshaft
    assert np.allclose(d.col("omega_rl") * PRESETS["jetracer"].wheel_radius, d.col("vx"))
    # kinematics: yaw rate integrates to the motion-capture heading (units and sign)
    dpsi = np.diff(d.col("psi"))
    rdt = d.col("yaw_rate")[1:] * np.diff(d.t)
    assert 0.9 < _slope(dpsi, rdt) < 1.05
    # ay ~ vx * yaw_rate in the circles (vx from the driveshaft includes spin: ratio <= ~1)
    kin = d.col("vx") * d.col("yaw_rate")
    sel = np.abs(kin) > 1.0
    assert 0.8 < _slope(d.col("ay")[sel], kin[sel]) < 1.1


@needs_dart
def test_dart_pose_is_at_the_cg():
    path = _dart_files()[2]
    raw = pd.read_csv(path)
    raw = raw[raw["elapsed time sensors"] != 0]
    first = raw.drop_duplicates("elapsed time sensors")
    d = read_drive(path)
    back = TRACKED_POINT_FROM_REAR - PRESETS["jetracer"].lr
    psi = d.col("psi")
    # moving the CG forward along the heading gives back the tracked point: compare with
    # the motion-capture sample of each sensor-update row (clocks agree within ~5 ms,
    # i.e. about 2 cm at these speeds)
    xt = d.col("x") + back * np.cos(psi)
    yt = d.col("y") + back * np.sin(psi)
    err = np.hypot(xt - first["vicon x"].to_numpy(), yt - first["vicon y"].to_numpy())
    assert np.percentile(err, 99) < 0.03
    assert np.allclose(np.angle(np.exp(1j * (psi - first["vicon yaw"].to_numpy()))), 0.0, atol=0.05)
    # and the CG is not the tracked point: without the shift the error would be `back`
    err_unshifted = np.hypot(d.col("x") - first["vicon x"].to_numpy(), d.col("y") - first["vicon y"].to_numpy())
    assert np.median(err_unshifted) == pytest.approx(back, abs=0.01)


def test_repair_burst_stamps():
    from roadgrip.io.dart import repair_burst_stamps

    true = np.arange(100) * 0.01
    stamped = true.copy()
    stamped[40:55] = 0.55 + np.array([0, -1, -2, 1, 0, -1, 2, 0, 1, -1, 0, 2, 1, 0, -2]) * 1e-6
    fixed, n = repair_burst_stamps(stamped)
    assert n == 15
    assert np.allclose(fixed, true, atol=1e-5)
    assert np.array_equal(repair_burst_stamps(true)[0], true)


@needs_dart
def test_dart_vehicle_override():
    d = read_drive(_dart_files()[0], vehicle="f1tenth")
    assert d.vehicle.name == "f1tenth"


# --------------------------------------------------------------------------- frictionmaps
def test_quaternion_yaw():
    psi = np.linspace(-3.1, 3.1, 13)
    assert np.allclose(quaternion_yaw(0.0, 0.0, np.sin(psi / 2), np.cos(psi / 2)), psi)


@needs_fm
@pytest.mark.parametrize("run", ["DS1", "DS2", "DS3", "DS4", "DS5"])
def test_frictionmaps_reader(run):
    d = read_drive(FM / run)
    assert d.meta.extra["format"] == "frictionmaps"
    assert d.vehicle == PRESETS["f1tenth"]
    assert d.has_pose
    assert d.t[0] == 0.0
    # one uniform clock at 50 Hz (gaps in the recording are skipped, not bridged)
    dt = np.diff(d.t)
    assert np.allclose(np.median(dt), 0.02)
    on_grid = np.abs(dt / 0.02 - np.round(dt / 0.02)) < 1e-6
    assert on_grid.all()
    # the IMU epoch is kept and t restored from it matches the raw stamps' span
    imu = pd.read_csv(FM / run / "imuData.csv")
    t_imu = imu["s"] + 1e-9 * imu["ns"]
    t0 = d.meta.extra["t0_epoch_s"]
    assert t_imu.iloc[0] <= t0 and t0 + d.t[-1] <= t_imu.iloc[-1]
    # SI units after the g / deg/s conversion
    assert np.abs(d.col("yaw_rate")).max() < 5.0
    assert np.abs(d.col("steer")).max() <= 0.34 + 1e-6  # float32 commands
    # yaw rate (gyro, converted) integrates to the particle-filter heading
    ok = (dt < 0.03) & (d.col("pose_jump")[1:] == 0)
    assert 0.9 < _slope(np.diff(d.col("psi"))[ok], (d.col("yaw_rate")[1:] * dt)[ok]) < 1.05


@needs_fm
@pytest.mark.parametrize("run", ["DS1", "DS3", "DS5"])
def test_frictionmaps_lateral_and_longitudinal_axes(run):
    d = read_drive(FM / run)
    vx, r, ay = d.col("vx"), d.col("yaw_rate"), d.col("ay")
    turn = (np.abs(r) > 0.5) & (vx > 1.0)
    # ay (IMU column ax, in g) against vx * yaw_rate in turns: slope about 1
    slope = _slope(ay[turn], (vx * r)[turn])
    assert 0.85 < slope < 1.2, slope
    assert np.corrcoef(ay[turn], (vx * r)[turn])[0, 1] > 0.8
    # ax (minus IMU column ay, in g) against d(vx)/dt: positive, slope about 1
    dt = np.diff(d.t)
    k = np.ones(5) / 5
    acc = np.convolve(np.diff(vx) / dt, k, "same")
    ax = np.convolve(d.col("ax")[1:], k, "same")
    sel = (dt < 0.03) & (np.abs(acc) < 8.0)
    assert 0.7 < _slope(ax[sel], acc[sel]) < 1.3
    assert np.corrcoef(ax[sel], acc[sel])[0, 1] > 0.6


@needs_fm
def test_frictionmaps_ds5_motor_speed():
    d = read_drive(FM / "DS5")
    assert "vx_motor" in d.extra_columns
    moving = d.col("vx") > 1.0
    ratio = np.median(d.col("vx_motor")[moving] / d.col("vx")[moving])
    assert 0.9 < ratio < 1.1


@needs_fm
def test_frictionmaps_pose_jumps_flagged():
    d = read_drive(FM / "DS1")
    jump = d.col("pose_jump") > 0
    assert d.meta.extra["pose_jumps"] == int(jump.sum()) > 0
    step = np.hypot(np.diff(d.col("x")), np.diff(d.col("y")))
    # flagged steps are the large ones; unflagged ones respect the speed bound
    assert step[jump[1:]].min() > np.median(step)
    bound = 1.5 * np.abs(d.col("vx")[1:]) * np.diff(d.t) + 0.1
    assert (step[~jump[1:]] <= bound[~jump[1:]]).all()


@needs_fm
def test_frictionmaps_file_inside_run_folder_and_explicit_format():
    a = read_drive(FM / "DS3" / "imuData.csv")
    b = read_drive(FM / "DS3", format="frictionmaps")
    pd.testing.assert_frame_equal(a.data, b.data)


@needs_fm
def test_frictionmaps_steer_delay_improves_fit_to_the_linear_model():
    from roadgrip.io.describe import linear_yaw_rate
    from roadgrip.io.frictionmaps import read_frictionmaps

    def corr(delay):
        d = read_frictionmaps(FM / "DS3", steer_delay=delay)
        r_lin = linear_yaw_rate(d.t, d.col("steer"), d.col("vx"), d.vehicle)
        sel = (d.col("vx") > 1.0) & (np.abs(r_lin) > 0.1)
        return np.corrcoef(d.col("yaw_rate")[sel], r_lin[sel])[0, 1]

    c0, c1, c3 = corr(0.0), corr(0.1), corr(0.3)
    assert c1 > c0 + 0.03 and c1 > c3 and c1 > 0.97
    with pytest.raises(ValueError, match="steer_delay must be a non-negative"):
        read_frictionmaps(FM / "DS3", steer_delay=-0.1)


# --------------------------------------------------------------------------- pose calibration
def _synthetic_run(seed=3, n=6000, rate=50.0):
    """Kinematic car on a varying-curvature path; pose integrated from the truth."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / rate
    v = 2.0 + 0.8 * np.sin(2 * np.pi * t / 23.0)
    r = 1.2 * np.sin(2 * np.pi * t / 7.0) + 0.4 * np.sin(2 * np.pi * t / 3.1)
    dt = 1.0 / rate
    psi = np.r_[0.0, np.cumsum(0.5 * (r[1:] + r[:-1]) * dt)]
    x = np.r_[0.0, np.cumsum(0.5 * (v[1:] * np.cos(psi[1:]) + v[:-1] * np.cos(psi[:-1])) * dt)]
    y = np.r_[0.0, np.cumsum(0.5 * (v[1:] * np.sin(psi[1:]) + v[:-1] * np.sin(psi[:-1])) * dt)]
    x = x + rng.normal(0, 0.01, n)
    y = y + rng.normal(0, 0.01, n)
    psi_m = psi + rng.normal(0, 0.005, n)
    # localisation jumps: a 1.5 m / 0.5 rad offset over 40 samples, flagged at both ends
    jump = np.zeros(n, bool)
    for k in (900, 3100, 5000):
        x[k:k + 40] += 1.5
        psi_m[k:k + 40] += 0.5
        jump[[k, k + 40]] = True
    return t, v, r, x, y, psi_m, jump


def test_fit_pose_scales_recovers_known_scales():
    from roadgrip.io.frictionmaps import fit_pose_scales

    t, v, r, x, y, psi, jump = _synthetic_run()
    rng = np.random.default_rng(4)
    gyro = 1.07 * r + rng.normal(0, 0.02, len(t))
    odo = 1.04 * v + rng.normal(0, 0.02, len(t))
    fit = fit_pose_scales(t, gyro, odo, x, y, psi, jump)
    assert fit["gyro_scale"] == pytest.approx(1 / 1.07, rel=3e-3)
    assert fit["speed_scale"] == pytest.approx(1 / 1.04, rel=3e-3)
    # the jumps matter: unflagged, the same data give a worse speed scale
    bad = fit_pose_scales(t, gyro, odo, x, y, psi, np.zeros_like(jump), window=1.0)
    assert abs(bad["speed_scale"] - 1 / 1.04) > abs(fit["speed_scale"] - 1 / 1.04)
    with pytest.raises(ValueError, match="too few"):
        fit_pose_scales(t, gyro, 0.0 * odo, x, y, psi, jump)


def test_fit_steer_gain_recovers_known_gain():
    from roadgrip.io.frictionmaps import fit_steer_gain

    rng = np.random.default_rng(5)
    n, wheelbase = 4000, 0.32
    cmd = np.repeat(rng.uniform(-0.34, 0.34, n // 100), 100)  # held commands
    vx = np.repeat(rng.uniform(1.5, 4.0, n // 100), 100)
    delta = 0.62 * cmd  # effective road-wheel angle
    r = vx * np.tan(delta) / wheelbase + rng.normal(0, 0.01, n)
    ay = vx * r
    k, used = fit_steer_gain(cmd, r, vx, ay, wheelbase)
    assert used > 20
    assert k == pytest.approx(0.62, rel=5e-3)
    # never above the command, and no fit without samples
    assert fit_steer_gain(cmd, 2 * r, vx, 0 * ay, wheelbase)[0] == 1.0
    assert fit_steer_gain(cmd, r, vx, ay, wheelbase, steady=np.zeros(n, bool)) == (1.0, 0)
    with pytest.raises(ValueError, match="non-positive"):
        fit_steer_gain(cmd, -r, vx, ay, wheelbase)


@needs_fm
@pytest.mark.parametrize("run", ["DS3", "DS4"])
def test_frictionmaps_calibration(run):
    from roadgrip.io.frictionmaps import read_frictionmaps

    raw = read_frictionmaps(FM / run)
    d = read_frictionmaps(FM / run, calibrate=True)
    c = d.meta.extra["calibration"]
    assert np.allclose(d.col("yaw_rate"), c["gyro_scale"] * raw.col("yaw_rate"))
    assert np.allclose(d.col("vx"), c["speed_scale"] * raw.col("vx"))
    assert np.allclose(d.col("steer_cmd"), raw.col("steer"))
    assert np.allclose(d.col("steer"), c["steer_gain"] * raw.col("steer"))
    assert 0.0 < c["steer_gain"] <= 1.0
    # an independent estimate (median per-step pose speed ratio) now agrees with the odometry
    before = raw.meta.extra["kinematic_checks"]["pose_speed_over_vx"]
    after = d.meta.extra["kinematic_checks"]["pose_speed_over_vx"]
    assert abs(after - 1.0) < 0.05
    assert abs(after - 1.0) <= abs(before - 1.0) + 0.01


def test_stream_noise_of_an_upsampled_stream():
    """White noise recorded at 20 Hz and interpolated to 50 Hz: per-tick std s sqrt(50 / 20)."""
    from roadgrip.io.frictionmaps import _stream_noise
    from roadgrip.signals import white_noise_std

    rng = np.random.default_rng(6)
    t = np.arange(20000) / 20.0
    x = np.sin(0.5 * t) + rng.normal(0, 0.3, len(t))
    s, native = _stream_noise(t, x, 50.0)
    assert native == pytest.approx(20.0)
    assert s == pytest.approx(0.3 * np.sqrt(50 / 20), rel=0.05)
    # the same estimator on the interpolated signal sees a fraction of the noise
    fine = np.arange(0, t[-1], 1 / 50.0)
    assert white_noise_std(np.interp(fine, t, x)) < 0.3 * 0.3


@needs_fm
@pytest.mark.parametrize("run", ["DS1", "DS3", "DS5"])
def test_frictionmaps_pose_velocity_and_native_noise(run):
    d = read_drive(FM / run, format="frictionmaps")
    vx, vy = d.data["vx_pose"].to_numpy(), d.data["vy_pose"].to_numpy()
    ok = np.isfinite(vx)
    assert ok.mean() > 0.8
    assert np.all(np.isnan(vx[d.data["pose_jump"].to_numpy() > 0]))
    # the pose speed agrees with the odometry (DS4 aside, module docstring)
    moving = ok & (d.col("vx") > 1.0)
    assert np.median(vx[moving] / d.col("vx")[moving]) == pytest.approx(1.0, abs=0.1)
    # at low lateral acceleration the pose vy is the kinematic d r with d about lr (pose near the CG)
    calm = moving & (np.abs(d.col("ay")) < 1.0) & (np.abs(d.col("yaw_rate")) > 0.3)
    d_fit = _slope(vy[calm], d.col("yaw_rate")[calm])
    assert 0.05 < d_fit < 0.3
    noise = d.meta.extra["sensor_noise"]
    assert 15.0 < noise["imu_rate_hz"] < 35.0
    assert noise["accel_std"] > 0.3 and noise["gyro_std"] > 0.01
