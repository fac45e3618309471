"""Friction-independent kinematic state estimation: speed, sideslip and slips."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from roadgrip.drive import Drive, DriveValidationError
from roadgrip.inference.kinematic import (
    KinematicConfig,
    KinematicEstimator,
    drive_lateral_acceleration,
    estimate_kinematics,
    kinematic_init,
    kinematic_lateral_acceleration,
    kinematic_samples,
    kinematics_from,
    select_lateral_acceleration,
    wheel_slips,
)
from roadgrip.vehicle import PRESETS
from roadgrip.vehicle.slip import longitudinal_slip, slip_angles

SEDAN = PRESETS["sedan"]  # front-wheel drive
R = SEDAN.wheel_radius


def _straight(n=2000, dt=0.01, v0=20.0, ax=None, spin=None, seed=0):
    """Straight drive with exact kinematics; ``spin`` (n, 4) multiplies the wheel speeds."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    ax = np.zeros(n) if ax is None else ax
    v = v0 + np.concatenate([[0.0], np.cumsum(ax[:-1]) * dt])
    omega = np.repeat((v / R)[:, None], 4, axis=1)
    if spin is not None:
        omega = omega * spin
    df = pd.DataFrame({
        "t": t, "ax": ax + 0.02 * rng.standard_normal(n), "ay": 0.02 * rng.standard_normal(n),
        "yaw_rate": np.zeros(n), "steer": np.zeros(n),
        **{c: omega[:, i] for i, c in enumerate(("omega_fl", "omega_fr", "omega_rl", "omega_rr"))},
    })
    return Drive.from_frame(df, SEDAN, source="test"), v


def test_speed_ignores_driven_wheel_spin():
    n = 2000
    ax = np.where((np.arange(n) > 500) & (np.arange(n) < 1200), 2.0, 0.0)
    spin = np.ones((n, 4))
    spin[(ax > 0), :2] = 1.3  # front (driven) wheels spin 30 % while accelerating
    drive, v = _straight(n, ax=ax, spin=spin)
    out = estimate_kinematics(drive)
    assert np.max(np.abs(out.vx - v)) < 0.1
    # the driven-wheel slip is seen, the undriven wheels roll
    k = out.kappa[(ax > 0)]
    assert np.median(k[:, 0]) == pytest.approx(0.3 / 1.3, abs=0.01)
    assert np.max(np.abs(k[:, 2:])) < 0.01


def test_speed_coasts_on_ax_through_braking_slip():
    n = 2000
    ax = np.where((np.arange(n) > 500) & (np.arange(n) < 1000), -5.0, 0.0)
    spin = np.ones((n, 4))
    spin[(ax < 0)] = 0.9  # all four wheels 10 % slower while braking
    drive, v = _straight(n, ax=ax, spin=spin)
    out = estimate_kinematics(drive)
    assert np.max(np.abs(out.vx - v)) < 0.1
    assert np.median(out.kappa[ax < 0], axis=0) == pytest.approx([-0.1] * 4, abs=0.01)


def test_wheel_slips_match_the_slip_definitions():
    rng = np.random.default_rng(2)
    n = 50
    vx = rng.uniform(5, 30, n)
    vy = rng.uniform(-1, 1, n)
    r = rng.uniform(-0.5, 0.5, n)
    d = rng.uniform(-0.1, 0.1, n)
    omega = rng.uniform(10, 100, (n, 4))
    omega[:, 3] = np.nan
    kappa, af, ar = wheel_slips(vx, vy, r, d, omega, SEDAN)
    af0, ar0 = slip_angles(vx, vy, r, d, SEDAN)
    np.testing.assert_allclose(af, af0)
    np.testing.assert_allclose(ar, ar0)
    h = SEDAN.track_width / 2
    np.testing.assert_allclose(kappa[:, 2], longitudinal_slip(omega[:, 2], vx - r * h, R))
    v_fr = (vx + r * h) * np.cos(d) + (vy + SEDAN.lf * r) * np.sin(d)
    np.testing.assert_allclose(kappa[:, 1], longitudinal_slip(omega[:, 1], v_fr, R))
    assert (kappa[:, 3] == 0).all()
    # pure rolling gives zero slip
    k0, _, _ = wheel_slips(vx, 0 * vx, 0 * vx, 0 * vx, np.repeat((vx / R)[:, None], 4, 1), SEDAN)
    np.testing.assert_allclose(k0, 0.0, atol=1e-12)


def test_missing_signals_are_named():
    df = pd.DataFrame({"t": np.arange(5) * 0.01, "ax": np.zeros(5), "ay": np.zeros(5),
                       "yaw_rate": np.zeros(5), "steer": np.zeros(5)})
    with pytest.raises(DriveValidationError, match="no wheel speeds, pose or vx"):
        estimate_kinematics(Drive.from_frame(df, SEDAN))
    with pytest.raises(DriveValidationError, match="steer"):
        estimate_kinematics(Drive.from_frame(df.drop(columns="steer"), SEDAN))
    with pytest.raises(ValueError, match="velocity_aid"):
        KinematicConfig(velocity_aid="gps")


@pytest.fixture(scope="module")
def dgd():
    from roadgrip.sim.scenarios import simulate_scenario

    return simulate_scenario("dry-gravel-dry", seed=0)


def test_dry_gravel_dry_accuracy_against_truth(dgd):
    out = estimate_kinematics(dgd)
    vx_rmse = float(np.sqrt(np.mean((out.vx - dgd.col("vx_true")) ** 2)))
    beta_true = np.arctan2(dgd.col("vy_true"), dgd.col("vx_true"))
    beta_rmse = float(np.degrees(np.sqrt(np.mean((out.beta - beta_true) ** 2))))
    af_rmse = float(np.degrees(np.sqrt(np.mean((out.alpha_f - dgd.col("alpha_f_true")) ** 2))))
    k_rmse = float(np.sqrt(np.mean((out.kappa[:, 0] - dgd.col("kappa_fl_true")) ** 2)))
    print(f"dry-gravel-dry: vx RMSE {vx_rmse:.4f} m/s, sideslip RMSE {beta_rmse:.4f} deg, "
          f"alpha_f RMSE {af_rmse:.4f} deg, kappa_fl RMSE {k_rmse:.5f}")
    assert vx_rmse < 0.05
    assert beta_rmse < 0.2
    assert af_rmse < 0.2
    assert k_rmse < 0.005
    # sideslip is really tracked in the manoeuvres, not just near zero
    big = np.abs(beta_true) > np.radians(0.5)
    assert big.sum() > 100
    assert np.corrcoef(out.beta[big], beta_true[big])[0, 1] > 0.95


def test_step_equals_batch(dgd):
    short = dgd.slice_time(25.0, 40.0)
    batch = estimate_kinematics(short)
    est = KinematicEstimator(short.vehicle)
    rows = [est.step(s) for s in kinematic_samples(short)]
    np.testing.assert_allclose(batch.vx, [r.vx for r in rows], rtol=1e-12)
    np.testing.assert_allclose(batch.vy, [r.vy for r in rows], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(batch.kappa, np.array([r.kappa for r in rows]), rtol=1e-10, atol=1e-15)
    with pytest.raises(ValueError, match="time must increase"):
        est.step(next(iter(kinematic_samples(short))))


@pytest.mark.parametrize("pose", [False, True])
def test_blocks_from_a_state_equal_the_whole_drive(dgd, pose):
    """A drive in consecutive blocks, each from the state the block before ended in, gives
    the whole drive's estimates (with the pose aid the previous pose crosses the seams)."""
    drive = dgd.slice_time(20.0, 45.0)
    if pose:  # rear wheel speeds only: the pose gives the speed
        drive = drive.with_data(drive.data.drop(columns=["omega_fl", "omega_fr"]))
    whole = estimate_kinematics(drive)
    state, parts = kinematic_init(), []
    for a, b in ((0, 700), (700, 701), (701, drive.n)):
        out, state = kinematics_from(state, drive.with_data(drive.data.iloc[a:b]))
        parts.append(out)
    for field in ("vx", "vy", "beta", "kappa", "alpha_f", "alpha_r"):
        np.testing.assert_array_equal(np.concatenate([getattr(p, field) for p in parts]),
                                      getattr(whole, field), err_msg=field)
    assert state.started and state.t == drive.t[-1] and state.vx == whole.vx[-1]
    # from a fresh state at the last seam the lateral velocity starts over from zero
    fresh, _ = kinematics_from(kinematic_init(), drive.with_data(drive.data.iloc[701:]))
    assert not np.array_equal(fresh.vy, whole.vy[701:])
    with pytest.raises(ValueError, match="time must increase: the block starts at"):
        kinematics_from(state, drive.with_data(drive.data.iloc[:10]))


def test_pose_aid_recovers_speed_and_sideslip_on_a_circle():
    """No wheel speeds: body velocity from the pose (e.g. motion capture) on a steady circle."""
    n, dt = 600, 0.1
    t = np.arange(n) * dt
    vx, vy, r = 2.0, -0.15, 1.5  # body-frame velocity [m/s] and yaw rate [rad/s]
    psi = r * t
    # world velocity = Rot(psi) [vx, vy]; integrate exactly for a constant body velocity
    x = (vx * np.sin(psi) + vy * (np.cos(psi) - 1.0)) / r
    y = (-vx * (np.cos(psi) - 1.0) + vy * np.sin(psi)) / r
    df = pd.DataFrame({"t": t, "ax": np.full(n, -r * vy), "ay": np.full(n, r * vx),
                       "yaw_rate": np.full(n, r), "steer": np.full(n, 0.2), "x": x, "y": y,
                       "psi": psi})
    drive = Drive.from_frame(df, PRESETS["jetracer"], source="test")
    out = estimate_kinematics(drive)  # 'auto' -> pose
    np.testing.assert_allclose(out.vx[5:], vx, rtol=0.01)
    np.testing.assert_allclose(out.vy[5:], vy, atol=0.01)
    est = KinematicEstimator(drive.vehicle, aid="pose")
    rows = [est.step(s) for s in kinematic_samples(drive)]
    np.testing.assert_allclose([r_.vy for r_ in rows], out.vy, rtol=1e-12, atol=1e-15)


def _circle_drive(n=600, dt=0.1, vx=2.0, vy=-0.15, r=1.5, ay_noise=3.0, seed=0):
    """Steady circle with a pose; the accelerometer's ay carries white noise of ``ay_noise``."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    psi = r * t
    x = (vx * np.sin(psi) + vy * (np.cos(psi) - 1.0)) / r
    y = (-vx * (np.cos(psi) - 1.0) + vy * np.sin(psi)) / r
    df = pd.DataFrame({"t": t, "ax": np.full(n, -r * vy),
                       "ay": r * vx + ay_noise * rng.standard_normal(n),
                       "yaw_rate": np.full(n, r), "steer": np.full(n, 0.2), "x": x, "y": y,
                       "psi": psi})
    return Drive.from_frame(df, PRESETS["jetracer"], source="test")


def test_kinematic_lateral_acceleration_from_the_pose_ignores_accelerometer_noise():
    vx, r = 2.0, 1.5
    drive = _circle_drive(vx=vx, r=r)
    out = estimate_kinematics(drive)  # pose aid
    ay_kin = kinematic_lateral_acceleration(drive.t, out.vx, out.vy, drive.col("yaw_rate"))
    # centripetal r vx (constant vy), independent of the accelerometer's 3 m/s² noise
    np.testing.assert_allclose(ay_kin[5:], r * vx, rtol=0.01)
    assert np.std(drive.col("ay")) > 2.5
    used = drive_lateral_acceleration(drive, out, "auto")
    np.testing.assert_array_equal(used, ay_kin)  # pose aid -> kinematic
    np.testing.assert_array_equal(drive_lateral_acceleration(drive, out, "imu"), drive.col("ay"))


def test_kinematic_lateral_acceleration_carries_dvy_dt():
    """Straight heading, lateral velocity ramping at a: ay = dvy/dt = a (r = 0)."""
    n, dt, vx, a = 300, 0.1, 2.0, 0.8
    t = np.arange(n) * dt
    df = pd.DataFrame({"t": t, "ax": np.zeros(n), "ay": np.zeros(n), "yaw_rate": np.zeros(n),
                       "steer": np.zeros(n), "x": vx * t, "y": 0.5 * a * t**2, "psi": np.zeros(n)})
    drive = Drive.from_frame(df, PRESETS["jetracer"], source="test")
    out = estimate_kinematics(drive)
    ay_kin = kinematic_lateral_acceleration(drive.t, out.vx, out.vy, drive.col("yaw_rate"))
    assert ay_kin[0] == 0.0  # no previous sample
    np.testing.assert_allclose(ay_kin[3:], a, rtol=1e-6)


def test_lateral_acceleration_source_selection():
    assert select_lateral_acceleration("auto", "pose", 1.0, 2.0) == 2.0
    assert select_lateral_acceleration("auto", "wheels", 1.0, 2.0) == 1.0
    assert select_lateral_acceleration("imu", "pose", 1.0, 2.0) == 1.0
    assert select_lateral_acceleration("kinematic", "wheels", 1.0, 2.0) == 2.0
    with pytest.raises(ValueError, match="lateral acceleration source"):
        select_lateral_acceleration("gps", "pose", 1.0, 2.0)


DART = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "dart"


@pytest.mark.realdata
def test_dart_kinematic_lateral_acceleration_is_the_quieter_measurement():
    """On every DART run the pose-kinematic ay follows the accelerometer's mean, with a tenth of its noise.

    Noise per sample: median absolute first difference / (0.6745 sqrt 2) over the
    moving samples (the signals change slowly at 10 Hz, so the differences are noise).
    """
    if not DART.is_dir():
        pytest.skip(f"DART data not found at {DART} (../shared/data beside the checkout)")
    from roadgrip.io import read_drive

    def noise(x, m):
        d = np.diff(x)[m[1:] & m[:-1]]
        return 1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(2.0)

    for path in sorted(DART.glob("*/*.csv")):
        drive = read_drive(path, format="dart")
        out = estimate_kinematics(drive)
        m = out.vx > 0.5
        ay_kin = drive_lateral_acceleration(drive, out, "auto")
        ay_imu = drive.col("ay")
        n_kin, n_imu = noise(ay_kin, m), noise(ay_imu, m)
        bias = float(np.mean(ay_imu[m] - ay_kin[m]))
        print(f"{path.name}: ay noise accelerometer {n_imu:.2f} m/s², pose kinematics {n_kin:.2f} m/s², "
              f"mean difference {bias:+.2f} m/s²")
        assert n_kin < 0.2 * n_imu
        assert abs(bias) < 0.5


@pytest.mark.parametrize("vehicle", ["vw-vanagon", "ford-escort"])
def test_braking_speed_on_a_pitching_body_of_the_multibody_engine(vehicle):
    """A braked body pitches and its accelerometer reads part of gravity: levelled by the
    vehicle's pitch gradient, the speed coasting through braking stays on the multi-body
    engine's truth; with the gradient taken as 0 it drifts by the gravity leak."""
    from roadgrip.sim.scenarios import simulate_scenario

    drive = simulate_scenario("dry-gravel-dry", seed=1, engine="multibody", vehicle=vehicle)
    vx = drive.col("vx_true")
    braking = (drive.col("accel_cmd") < -1.0) & (vx > 5.0)
    assert braking.sum() > 300
    rms = {}
    for label, params in (("levelled", drive.vehicle),
                          ("unlevelled", drive.vehicle.replace(pitch_gradient=0.0, roll_gradient=0.0))):
        out = estimate_kinematics(Drive.from_frame(drive.data, params, source="test", check_units=False))
        rms[label] = float(np.sqrt(np.mean((out.vx - vx)[braking] ** 2)))
    # measured: 0.048 / 0.41 m/s (van), 0.091 / 0.45 m/s (sedan)
    assert rms["levelled"] < 0.12, rms
    assert rms["unlevelled"] > 3 * rms["levelled"], rms
