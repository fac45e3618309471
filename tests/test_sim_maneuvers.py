"""Manoeuvre patterns and closed tracks: shapes, analytic values, reproducibility."""

from __future__ import annotations

import numpy as np
import pytest

from roadgrip.sim.maneuvers import (
    ConstantSpeed,
    DoubleLaneChange,
    Maneuver,
    RandomSpeed,
    RandomSteer,
    Schedule,
    SineSweep,
    Slalom,
    SpeedPhases,
    StepSteer,
    Straight,
    smooth_noise,
)
from roadgrip.sim.track import ClosedTrack
from roadgrip.vehicle import PRESETS

V = PRESETS["sedan"]
T = np.arange(0, 60.0, 0.01)


def test_speed_phases_integrate_the_acceleration():
    sp = SpeedPhases(10.0, ((2.0, 0.0), (4.0, 2.0), (3.0, 0.0), (2.0, -3.0)), ramp=0.5)
    v, a = sp.speed(T, np.random.default_rng(0))
    # each trapezoidal pulse of duration d and ramp r changes the speed by a (d - r)
    assert v[T.searchsorted(8.0)] == pytest.approx(10.0 + 2.0 * 3.5, abs=1e-3)
    assert v[-1] == pytest.approx(10.0 + 2.0 * 3.5 - 3.0 * 1.5, abs=1e-3)
    assert a.max() == pytest.approx(2.0) and a.min() == pytest.approx(-3.0)
    with pytest.raises(ValueError, match="negative speed"):
        SpeedPhases(2.0, ((5.0, -3.0),)).speed(T, np.random.default_rng(0))


def test_slalom_and_lane_change_lateral_acceleration():
    v = np.full_like(T, 15.0)
    r = Slalom(3.0, 4.0).yaw_rate_ref(T, v, V, None)
    np.testing.assert_allclose(r * v, 3.0 * np.sin(2 * np.pi * T / 4.0))
    dlc = DoubleLaneChange(offset=3.5, change_time=2.0, hold_time=1.0, t0=1.0)
    ay = dlc.yaw_rate_ref(T, v, V, None) * v
    dt = T[1] - T[0]
    vy = np.cumsum(ay) * dt
    y = np.cumsum(vy) * dt
    assert y[T.searchsorted(3.5)] == pytest.approx(3.5, abs=0.05)  # in the other lane
    assert abs(y[-1]) < 0.05 and abs(vy[-1]) < 1e-3  # and back, straight


def test_step_and_sweep_use_the_linear_steady_state_gain():
    v = np.full_like(T, 20.0)
    r = StepSteer(0.02, t_step=1.0, rise=0.1).yaw_rate_ref(T, v, V, None)
    gain = 20.0 / (V.wheelbase + V.understeer_gradient * 400.0)
    assert r[-1] == pytest.approx(0.02 * gain)
    assert r[T.searchsorted(0.5)] == 0.0
    sw = SineSweep(0.01, 0.2, 2.0, 20.0, t0=5.0).yaw_rate_ref(T, v, V, None)
    assert np.abs(sw).max() == pytest.approx(0.01 * gain, rel=1e-3)
    assert np.all(sw[T < 5.0] == 0) and np.all(sw[T > 25.0] == 0)


def test_maneuver_feedforward_steering_is_linear_steady_state():
    m = Maneuver(ConstantSpeed(20.0), Slalom(2.0, 5.0), yaw_gain=0.1)
    sig = m.sample(T, V, np.random.default_rng(0))
    np.testing.assert_allclose(sig.steer_ff, (V.wheelbase + V.understeer_gradient * 400.0) * sig.r_ref / 20.0)
    np.testing.assert_allclose(sig.v_ref, 20.0)


def test_random_patterns_are_seeded_and_bounded():
    m = Maneuver(RandomSpeed(8.0, 15.0, 20.0), RandomSteer(0.5, 3.0, 1.0, envelope_period=30.0))
    a = m.sample(T, V, np.random.default_rng(7))
    b = m.sample(T, V, np.random.default_rng(7))
    c = m.sample(T, V, np.random.default_rng(8))
    np.testing.assert_array_equal(a.r_ref, b.r_ref)
    assert not np.allclose(a.r_ref, c.r_ref)
    assert a.v_ref.min() >= 8.0 and a.v_ref.max() <= 15.0
    n = smooth_noise(np.arange(0, 2000.0, 0.05), 1.0, np.random.default_rng(0))
    assert n.std() == pytest.approx(1.0, rel=0.1)
    # correlation time: neighbours 0.05 s apart nearly equal, 5 s apart nearly independent
    assert np.corrcoef(n[:-1], n[1:])[0, 1] > 0.95
    assert abs(np.corrcoef(n[:-100], n[100:])[0, 1]) < 0.1


def test_schedule_windows_and_straight():
    v = np.full_like(T, 10.0)
    sch = Schedule(((10.0, 20.0, Slalom(2.0, 2.0)),), fade=0.5)
    r = sch.yaw_rate_ref(T, v, V, np.random.default_rng(0))
    assert np.all(r[(T < 10.0) | (T > 20.0)] == 0)
    assert np.abs(r[(T > 11) & (T < 19)]).max() == pytest.approx(0.2, rel=1e-3)
    assert np.all(Straight().yaw_rate_ref(T, v, V, None) == 0)


def test_rounded_rectangle_geometry_and_speed_profile():
    tr = ClosedTrack.rounded_rectangle(10.0, 6.0, 1.5, ds=0.02)
    assert tr.length == pytest.approx(2 * (10 - 3) + 2 * (6 - 3) + 2 * np.pi * 1.5, rel=2e-3)
    k = tr.curvature()
    assert np.median(k[k > 0.3]) == pytest.approx(1 / 1.5, rel=0.02)  # corners
    assert np.all(k > -1e-6)  # counter-clockwise: never turns right
    v = tr.speed_profile(v_max=5.0, ay_max=5.0, a_acc=2.0, a_brake=3.0)
    assert v.max() <= 5.0 + 1e-9
    assert v[k > 0.6].max() <= np.sqrt(5.0 * 1.5) + 1e-6
    ds = tr.segment_lengths()
    dv2 = np.diff(np.append(v, v[0]) ** 2)
    assert np.all(dv2 <= 2 * 2.0 * ds + 1e-9) and np.all(dv2 >= -2 * 3.0 * ds - 1e-9)
