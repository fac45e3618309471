"""roadgrip.signals: each shared signal against an analytic or independent computation."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.stats import norm

from roadgrip import signals
from roadgrip.constants import GRAVITY, Z95
from roadgrip.drive import Drive, DriveValidationError
from roadgrip.vehicle.params import PRESETS

SEDAN = PRESETS["sedan"]


def _states(rng, n):
    """Random planar motions: vx [m/s], vy [m/s], yaw rate [rad/s], steer [rad]."""
    return (rng.uniform(3.0, 30.0, n), rng.uniform(-1.0, 1.0, n), rng.uniform(-0.6, 0.6, n),
            rng.uniform(-0.4, 0.4, n))


def _rigid_body_wheel_speeds(vx, vy, r, steer, p):
    """Velocity of each wheel centre from rigid-body kinematics, along the wheel heading."""
    out = []
    for x_w, y_w, steered in ((p.lf, 0.5 * p.track_width, True), (p.lf, -0.5 * p.track_width, True),
                              (-p.lr, 0.5 * p.track_width, False), (-p.lr, -0.5 * p.track_width, False)):
        u, v = vx - r * y_w, vy + r * x_w  # point velocity of the body at (x_w, y_w)
        d = steer if steered else np.zeros_like(steer)
        out.append(u * np.cos(d) + v * np.sin(d))
    return np.stack(out, axis=-1)


def _drive(vehicle, **cols):
    n = len(next(iter(cols.values())))
    df = pd.DataFrame({"t": np.arange(n) * 0.01, **cols})
    return Drive.from_frame(df, vehicle, source="test", check_units=False)


def test_z95_is_the_two_sided_normal_quantile():
    assert Z95 == pytest.approx(norm.ppf(0.975), abs=1e-15)
    assert norm.cdf(Z95) - norm.cdf(-Z95) == pytest.approx(0.95, abs=1e-15)


def test_driven_and_undriven_wheels():
    assert signals.driven_wheels("fwd").tolist() == [True, True, False, False]
    assert signals.driven_wheels("rwd").tolist() == [False, False, True, True]
    assert signals.driven_wheels("awd").tolist() == [True, True, True, True]
    for d in ("fwd", "rwd", "awd"):
        np.testing.assert_array_equal(signals.undriven_wheels(d), ~signals.driven_wheels(d))
        assert signals.driven_wheels(d).shape == (4,)
    signals.driven_wheels("fwd")[0] = False  # a fresh array each call
    assert signals.driven_wheels("fwd")[0]
    with pytest.raises(ValueError, match="'4wd'"):
        signals.driven_wheels("4wd")


def test_wheel_centre_speeds_are_rigid_body_kinematics():
    rng = np.random.default_rng(0)
    vx, vy, r, d = _states(rng, 200)
    got = signals.wheel_centre_speeds(vx, vy, r, d, SEDAN)
    assert got.shape == (200, 4)
    np.testing.assert_allclose(got, _rigid_body_wheel_speeds(vx, vy, r, d, SEDAN), rtol=1e-13, atol=1e-12)


def test_wheel_cg_speeds_recover_vx_from_free_rolling_wheels():
    rng = np.random.default_rng(1)
    vx, vy, r, d = _states(rng, 200)
    omega = _rigid_body_wheel_speeds(vx, vy, r, d, SEDAN) / SEDAN.wheel_radius
    got = signals.wheel_cg_speeds(omega, d, r, SEDAN, vy=vy)
    np.testing.assert_allclose(got, np.repeat(vx[:, None], 4, axis=1), rtol=1e-12)
    # default lateral velocity: the rear axle rolls without side slip, vy = lr r
    omega0 = _rigid_body_wheel_speeds(vx, SEDAN.lr * r, r, d, SEDAN) / SEDAN.wheel_radius
    np.testing.assert_allclose(signals.wheel_cg_speeds(omega0, d, r, SEDAN), got, rtol=1e-12)
    # an absent wheel stays absent
    omega[:5, 1] = np.nan
    assert np.isnan(signals.wheel_cg_speeds(omega, d, r, SEDAN, vy=vy)[:5, 1]).all()


def test_rolling_speed_of_the_free_wheels():
    rng = np.random.default_rng(3)
    omega = rng.uniform(10.0, 40.0, (50, 4))
    wheels = {f"omega_{w}": omega[:, i] for i, w in enumerate(signals.WHEELS)}
    R = SEDAN.wheel_radius
    for layout, idx in (("fwd", [2, 3]), ("rwd", [0, 1]), ("awd", [0, 1, 2, 3])):
        assert np.flatnonzero(signals.speed_wheels(layout)).tolist() == idx
        got, cols = signals.rolling_speed(_drive(SEDAN.replace(drive=layout), **wheels))
        assert cols == tuple(f"omega_{signals.WHEELS[i]}" for i in idx)
        # the plain mean of R omega over those wheels, by hand
        np.testing.assert_allclose(got, R * sum(omega[:, i] for i in idx) / len(idx), rtol=1e-14)
    rear_only = {k: v for k, v in wheels.items() if k.startswith("omega_r")}
    with pytest.raises(DriveValidationError, match="omega_fl"):
        signals.rolling_speed(_drive(SEDAN.replace(drive="rwd"), **rear_only))


def test_wheel_speed_vx_sources():
    rng = np.random.default_rng(2)
    n = 300
    vx, _, r, d = _states(rng, n)
    omega = _rigid_body_wheel_speeds(vx, SEDAN.lr * r, r, d, SEDAN) / SEDAN.wheel_radius
    spin = omega * np.array([1.0, 1.0, 1.3, 1.3])  # the rear axle spins under drive
    wheels = {f"omega_{w}": spin[:, i] for i, w in enumerate(signals.WHEELS)}
    base = {"yaw_rate": r, "steer": d}
    rwd, awd = SEDAN.replace(drive="rwd"), SEDAN.replace(drive="awd")
    # rear drive: the undriven (front) wheels, steer-corrected, give vx exactly
    got, used = signals.wheel_speed_vx(_drive(rwd, **base, **wheels, vx=vx + 1.0))
    assert used == "wheels"
    np.testing.assert_allclose(got, vx, rtol=1e-12)
    # all-wheel drive: a vx column beats four slipping wheels; without one, all four wheels
    assert signals.wheel_speed_vx(_drive(awd, **base, **wheels, vx=vx + 1.0))[1] == "column"
    got, used = signals.wheel_speed_vx(_drive(awd, **base, **wheels))
    assert used == "wheels"
    np.testing.assert_allclose(got, vx * (1.0 + 0.3 / 2), rtol=1e-12)
    # front drive without the rear wheel columns: the vx column, then the pose
    front = {k: v for k, v in wheels.items() if k.startswith("omega_f")}
    assert signals.wheel_speed_vx(_drive(SEDAN, **base, **front, vx=vx))[1] == "column"
    t = np.arange(n) * 0.01
    pose = {"x": 10.0 * t, "y": np.zeros(n), "psi": np.zeros(n)}
    got, used = signals.wheel_speed_vx(_drive(SEDAN, **base, **front, **pose))
    assert used == "pose"
    np.testing.assert_allclose(got, 10.0, rtol=1e-12)
    # a requested source names what it lacks
    with pytest.raises(DriveValidationError, match="omega_rl"):
        signals.wheel_speed_vx(_drive(SEDAN, **base, **front, vx=vx), "wheels")
    with pytest.raises(DriveValidationError, match="'vx'"):
        signals.wheel_speed_vx(_drive(SEDAN, **base, **front), "column")
    with pytest.raises(DriveValidationError, match="'psi'"):
        signals.wheel_speed_vx(_drive(SEDAN, **base, x=pose["x"], y=pose["y"]), "auto")
    with pytest.raises(ValueError, match="'gnss'"):
        signals.wheel_speed_vx(_drive(SEDAN, **base, vx=vx), "gnss")


def test_body_velocity_from_pose_on_a_circle():
    # a point circling at speed v on radius R with a constant sideslip beta:
    # body velocity (v cos beta, v sin beta)
    v, radius, beta, dt = 8.0, 40.0, 0.05, 0.01
    t = np.arange(0.0, 60.0, dt)  # more than one lap: the heading wraps
    th = v / radius * t
    x, y = radius * np.sin(th), radius * (1.0 - np.cos(th))
    psi = np.angle(np.exp(1j * (th - beta)))  # course = heading + beta
    vx, vy = signals.body_velocity_from_pose(t, x, y, psi)
    inner = slice(1, -1)  # central differences: chord of 2 dt, error (v dt / R)² / 6
    np.testing.assert_allclose(vx[inner], v * np.cos(beta), rtol=1e-5)
    np.testing.assert_allclose(vy[inner], v * np.sin(beta), rtol=1e-4)
    # the windowed fit (F1/10 scale: 2 m/s on 3 m), with ten missing ticks and a bad sample
    rate, n, radius, speed, beta = 50.0, 1500, 3.0, 2.0, 0.15
    t = np.arange(n) / rate
    w = speed / radius
    x, y = radius * np.sin(w * t), radius * (1 - np.cos(w * t))
    psi = w * t - beta
    bad = np.zeros(n, bool)
    bad[700] = True
    keep = np.ones(n, bool)
    keep[1000:1010] = False
    vx, vy = signals.body_velocity_from_pose(t[keep], x[keep], y[keep], psi[keep], window=0.3,
                                             bad=bad[keep])
    ok = np.isfinite(vx)
    # a quadratic fit over 0.3 s of a circle at 0.67 rad/s: error of order (w T)^2 / 10
    np.testing.assert_allclose(vx[ok], speed * np.cos(beta), atol=2e-3)
    np.testing.assert_allclose(vy[ok], speed * np.sin(beta), atol=2e-3)
    tk = t[keep]
    # NaN within half a window (7 ticks) of the jump and the gap and at the ends, nowhere else
    near = np.abs(tk - t[700]) <= 7 / rate + 1e-9
    near |= (tk >= t[999] - 6 / rate - 1e-9) & (tk <= t[1010] + 6 / rate + 1e-9)
    near |= (tk < 7 / rate - 1e-9) | (tk > t[-1] - 7 / rate + 1e-9)
    np.testing.assert_array_equal(~ok, near)


def test_pose_velocity_of_a_drive():
    n = 50
    t = np.arange(n) * 0.01
    d = _drive(SEDAN, x=3.0 * t, y=4.0 * t, psi=np.full(n, np.arctan2(4.0, 3.0)))
    vx, vy = signals.pose_velocity(d)
    np.testing.assert_allclose(vx, 5.0, rtol=1e-12)
    np.testing.assert_allclose(vy, 0.0, atol=1e-12)
    with pytest.raises(DriveValidationError, match=r"\['psi'\]"):
        signals.pose_velocity(_drive(SEDAN, x=t, y=t))


def test_axle_loads_by_hand():
    v = PRESETS["suv"]
    m, g, lf, lr, h = v.mass, GRAVITY, v.lf, v.lr, v.cg_height
    L = lf + lr
    ax = np.array([-5.0, 0.0, 3.0])
    f, r = signals.axle_loads(v, ax)
    np.testing.assert_allclose(f, m * g * lr / L - m * ax * h / L, rtol=1e-13)
    np.testing.assert_allclose(r, m * g * lf / L + m * ax * h / L, rtol=1e-13)
    f0, r0 = signals.axle_loads(v)
    assert (f0, r0) == (v.fz_front, v.fz_rear)
    # a front axle that would carry a negative load under hard acceleration is lifted
    f, r = signals.axle_loads(v, 2.0 * g * lr / h)
    assert f == 0.0 and r > m * g


def test_white_noise_std_of_noise_on_a_smooth_signal():
    rng = np.random.default_rng(3)
    t = np.arange(20000) * 0.01
    x = 5.0 * np.sin(0.7 * t) + 0.1 * t + rng.normal(0.0, 0.2, len(t))
    assert signals.white_noise_std(x) == pytest.approx(0.2, rel=0.03)
    assert signals.white_noise_std(np.sin(0.7 * t)) < 1e-4
    assert np.isnan(signals.white_noise_std(x[:11]))


def test_level_accelerations_remove_the_tilt_of_a_rolled_body():
    """A body rolled by K a_y reads a_y cos(phi) + g sin(phi): levelling returns a_y to first order."""
    import dataclasses

    from roadgrip.constants import GRAVITY
    from roadgrip.signals import level_accelerations
    from roadgrip.vehicle import load_vehicle

    veh = dataclasses.replace(load_vehicle("sedan"), roll_gradient=0.0157, pitch_gradient=0.006)
    ay = np.linspace(-5.0, 5.0, 11)
    ax = np.linspace(-6.0, 3.0, 11)
    phi, theta = veh.roll_gradient * ay, veh.pitch_gradient * ax
    ay_meas = ay * np.cos(phi) + GRAVITY * np.sin(phi)
    ax_meas = ax * np.cos(theta) + GRAVITY * np.sin(theta)
    lx, ly = level_accelerations(ax_meas, ay_meas, veh)
    assert np.abs(ly - ay).max() < 0.01 * np.abs(ay).max()  # second-order terms only
    assert np.abs(ay_meas - ay).max() > 0.7  # what was removed
    assert np.abs(lx - ax).max() < 0.01 * np.abs(ax).max()
    plain = load_vehicle("sedan")
    np.testing.assert_array_equal(level_accelerations(ax_meas, ay_meas, plain)[1], ay_meas)


def test_sustained_grip_against_brute_force_and_online():
    from roadgrip.constants import GRAVITY
    from roadgrip.signals import current_grip, grip_step, sustained_grip, sustained_grip_step

    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.005, 0.03, 400))
    ay = rng.normal(2.0, 3.0, 400)
    got = sustained_grip(t, ay, 1.0)
    got_now = current_grip(t, ay, 1.0)
    best, expected, expected_now = 0.0, [], []
    for k in range(len(t)):
        inside = (t > t[k] - 1.0 + 1e-9) & (t <= t[k])
        now = abs(ay[inside].mean()) / GRAVITY if t[k] - t[0] >= 1.0 - 1e-9 else 0.0
        best = max(best, now)
        expected.append(best)
        expected_now.append(now)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(got_now, expected_now, rtol=1e-12, atol=1e-15)
    mem, online = None, []
    mem2, online_now = None, []
    for tk, ak in zip(t, ay, strict=True):
        mem, f = sustained_grip_step(mem, float(tk), float(ak), 1.0)
        online.append(f)
        mem2, n_, _ = grip_step(mem2, float(tk), float(ak), 1.0)
        online_now.append(n_)
    np.testing.assert_array_equal(online, got)
    np.testing.assert_array_equal(online_now, got_now)
    assert got[0] == 0.0 and np.all(np.diff(got) >= 0)
