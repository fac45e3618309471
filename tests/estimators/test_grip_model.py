"""The classifiers' saturation model, claim expiry and the calibration's time windows."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from roadgrip.cli.calibrate import split_window
from roadgrip.constants import GRAVITY, GRIP_CLASS_SPLIT
from roadgrip.estimators.classify.brls_config import saturation_config
from roadgrip.estimators.classify.brls_kernel import brls_batch
from roadgrip.estimators.classify.grip_model import (
    GripModel,
    class_predictions,
    default_grip_model,
    demonstrated_channel,
    predict_accelerations,
    shape,
    traction_slips,
)
from roadgrip.estimators.classify.slipmap_config import saturation_config as slipmap_saturation
from roadgrip.estimators.classify.slipmap_evidence import SlipMapEvidence
from roadgrip.estimators.classify.slipmap_kernel import slipmap_batch
from roadgrip.vehicle import PRESETS

SEDAN = PRESETS["sedan"]  # front-wheel drive


def test_shape_slope_one_and_peak_one():
    x = np.array([1e-6])
    assert shape(x, 1.4)[0] / 1e-6 == pytest.approx(1.0, rel=1e-6)
    grid = np.linspace(0, 20, 20001)
    assert shape(grid, 1.4).max() == pytest.approx(1.0, abs=1e-6)
    # peak where 1.4 atan(x / 1.4) = pi / 2
    assert grid[np.argmax(shape(grid, 1.4))] == pytest.approx(1.4 * math.tan(math.pi / 2.8), abs=1e-2)


def _one(v):
    return np.array([float(v)])


def test_linear_limit_and_saturation_of_the_predictions():
    m = default_grip_model(SEDAN, 1.0, 0.5)
    L = SEDAN.lf + SEDAN.lr
    k = 1e-4
    ax_meas = 0.0
    ax, ay = predict_accelerations(_one(k), _one(0.0), _one(0.0), _one(0.0), _one(0.0), _one(ax_meas),
                                   SEDAN, m, 1.0)
    # linear: front axle force c k Fz_f (static load with ax = 0)
    assert ax[0] == pytest.approx(m.c_long * k * GRAVITY * SEDAN.lr / L, rel=1e-3)
    assert ay[0] == 0.0
    # the stiffness does not depend on the friction
    ax_low, _ = predict_accelerations(_one(k), _one(0.0), _one(0.0), _one(0.0), _one(0.0),
                                      _one(ax_meas), SEDAN, m, 0.3)
    assert ax_low[0] == pytest.approx(ax[0], rel=1e-2)
    # saturation: at the shape's peak slip the axle transfers mu Fz
    x_peak = 1.4 * math.tan(math.pi / 2.8)
    for mu in (1.0, 0.4):
        ax_p, _ = predict_accelerations(_one(mu * x_peak / m.c_long), _one(0.0), _one(0.0), _one(0.0),
                                        _one(0.0), _one(0.0), SEDAN, m, mu)
        assert ax_p[0] == pytest.approx(mu * GRAVITY * SEDAN.lr / L, rel=1e-6)
    # the two classes predict the same in the linear range, differently at the low class's peak
    cp = class_predictions(_one(k), _one(0.0), _one(0.0), _one(0.0), _one(0.0), _one(0.0), SEDAN, m)
    assert abs(cp.ax_high[0] - cp.ax_low[0]) < 1e-3 * cp.sigma_x[0]
    cp = class_predictions(_one(0.5 * x_peak / m.c_long), _one(0.0), _one(0.0), _one(0.0), _one(0.0),
                           _one(0.0), SEDAN, m)
    assert cp.ax_high[0] - cp.ax_low[0] > 1.0


def test_driven_slip_against_the_free_rolling_wheels_ignores_the_speed_error():
    # true speed 20 m/s, driven (front) wheels at 20.4 m/s, rear free rolling
    true_slip = 1.0 - 20.0 / 20.4
    def slip(w, v):
        return (w - v) / max(w, v)  # eq. 2

    for v_est in (19.0, 20.0, 21.0):  # the kinematic stage's speed, wrong by -1..+1 m/s
        kappa = np.array([[slip(20.4, v_est), slip(20.4, v_est), slip(20.0, v_est), slip(20.0, v_est)]])
        kf, kr, on = traction_slips(kappa, np.ones((1, 4), bool), _one(1.0), SEDAN)
        assert kf[0] == pytest.approx(true_slip, rel=1e-9) and kr[0] == 0.0 and on[0]
    # braking: no longitudinal information
    _, _, on = traction_slips(np.zeros((1, 4)), np.ones((1, 4), bool), _one(-1.0), SEDAN)
    assert not on[0]


def test_grip_model_roundtrip_and_validation():
    m = default_grip_model(SEDAN, 1.0, 0.5)
    assert GripModel.from_dict(m.to_dict()) == m
    with pytest.raises(ValueError, match="mu_low < mu_high"):
        GripModel(20.0, 20.0, mu_high=0.5, mu_low=0.6)
    with pytest.raises(ValueError, match="unknown grip model"):
        GripModel.from_dict({**m.to_dict(), "stiffnes": 1.0})


def test_demonstrated_channel_shows_high_grip_above_the_split_and_never_low():
    m = replace(default_grip_model(SEDAN, 1.0, 0.49), lateral_evidence="demonstrated", accel_noise=0.3)
    a_low = GRIP_CLASS_SPLIT * GRAVITY + 2.0 * 0.3  # gain 1, the margin of two noise units
    a_high = 1.0 * GRAVITY
    ay = np.array([0.0, 3.0, -a_low + 1e-9, a_low + 0.3, -(a_low + 1.0), a_high, -(a_high + 2.0)])
    phi, y = demonstrated_channel(ay, m)
    np.testing.assert_allclose(phi[:3], 0.0)  # below what a low road can carry: nothing
    np.testing.assert_allclose(y[:3], 0.0)
    # between: the class position y / phi is exactly 1 (high), whatever the sign of a_y
    np.testing.assert_allclose(phi[3:6], [1.0, 1.0 / 0.3, (a_high - a_low) / 0.3])
    np.testing.assert_allclose(y[3:6], phi[3:6])
    # above the high class's most: a position above 1, still high
    assert phi[6] == pytest.approx((a_high - a_low) / 0.3) and y[6] / phi[6] > 1.0
    # a gain below 1 does not lower the split's acceleration; a gain above raises it
    np.testing.assert_allclose(demonstrated_channel(ay, replace(m, gain_y=0.8))[0], phi)
    assert demonstrated_channel(np.array([a_low + 0.3]), replace(m, gain_y=1.1))[0][0] == 0.0
    with pytest.raises(ValueError, match="lateral_evidence"):
        replace(m, lateral_evidence="pose")
    assert GripModel.from_dict(m.to_dict()) == m
    off = replace(m, braking_evidence=False)
    back = GripModel.from_dict(off.to_dict())
    assert back == off and back.braking_evidence is False and back.lateral_evidence == "demonstrated"


def test_brls_claim_expires_and_is_made_afresh():
    cfg = saturation_config(hold_high_s=2.0, hold_low_s=2.0)
    t = np.arange(0.0, 12.0, 0.01)
    phi = np.where(t < 2.0, 3.0, np.where(t >= 8.0, 3.0, 0.0))
    y = np.where(t < 2.0, 3.0, np.where(t >= 8.0, 0.0, 0.0))  # high-grip data, nothing, low-grip data
    z = np.zeros_like(t)
    _, out = brls_batch(t, phi, y, z, z, cfg)
    cls = out.grip_class
    assert (cls[(t > 1.0) & (t < 2.0)] == "high").all()
    assert (cls[(t > 4.5) & (t < 8.0)] == "unknown").all()  # 2 s after the last support
    assert (cls[t > 9.0] == "low").all()
    # with the paper's state machine (held state) the class would stay known
    _, held = brls_batch(t, phi, y, z, z, replace(cfg, hold_high_s=math.inf, hold_low_s=math.inf))
    assert (held.grip_class[(t > 4.5) & (t < 8.0)] == "high").all()


def test_slipmap_claim_expires():
    cfg = slipmap_saturation(hold_high_s=2.0, hold_low_s=2.0)
    t = np.arange(0.0, 10.0, 0.01)
    w = np.where(t < 2.0, 0.9, 0.0)
    z = np.zeros_like(t)
    ev = SlipMapEvidence(z, z, w, z, 0.5 * w, z, 1.0 - 0.5 * w, z)
    _, out = slipmap_batch(t, ev, cfg)
    assert (out.grip_class[(t > 1.0) & (t < 2.0)] == "high").all()
    assert (out.grip_class[t > 4.5] == "unknown").all()


def test_calibrate_time_windows():
    assert split_window("a.parquet@10-20") == ("a.parquet", (10.0, 20.0))
    assert split_window("dir/a.parquet@120-") == ("dir/a.parquet", (120.0, math.inf))
    assert split_window("a.parquet") == ("a.parquet", None)
    for bad in ("a.parquet@20-10", "a.parquet@x-1", "a.parquet@5"):
        with pytest.raises(ValueError, match="time window"):
            split_window(bad)


def test_braking_onset_separates_dry_from_gravel_on_the_multibody_van():
    """Braking slips against the coasting speed carry the class: at the onset of each
    0.5 g stop of a multi-body dry -> gravel -> dry drive, the class position of the
    longitudinal channel (weighted by its separation) lies on the high class's side on
    dry asphalt and on the low class's on gravel; coasting, neither braking nor traction,
    carries nothing."""
    from roadgrip.estimators.classify.grip_model import braking_samples, channels
    from roadgrip.inference.kinematic import estimate_kinematics
    from roadgrip.sim.scenarios import simulate_scenario

    drive = simulate_scenario("dry-gravel-dry", seed=1, engine="multibody", vehicle="vw-vanagon")
    veh = drive.vehicle
    # the tire's normalised slip stiffness and the accelerometer's pitch gain, not fitted
    model = GripModel(c_long=22.0, c_lat=13.0, mu_high=1.0, mu_low=0.5, model_error_x=0.05,
                      gain_x=1.0 + GRAVITY * veh.pitch_gradient)
    kin = estimate_kinematics(drive)
    ax = drive.col("ax")
    ch, _ = channels(kin, ax, drive.col("ay"), drive.col("steer"), veh, model)
    brake = braking_samples(kin, ax)
    t, mu = drive.t, drive.col("mu_true")
    hard = brake & (ax < -3.0)
    onsets = np.flatnonzero(hard & ~np.r_[False, hard[:-1]])
    positions = {}
    for i in onsets:
        sel = hard & (t >= t[i]) & (t < t[i] + 0.5)
        info = np.sum(ch.phi_long[sel] ** 2)
        if info > 1.0:  # the classes predict different decelerations (near saturation)
            theta = np.sum(ch.phi_long[sel] * ch.y_long[sel]) / info
            positions.setdefault(float(mu[i]), []).append(theta)
    assert set(positions) == {0.5, 1.0}, positions
    assert min(positions[1.0]) > 0.7 and max(positions[0.5]) < 0.3, positions
    # without braking evidence, and while coasting, the channel is silent
    quiet, _ = channels(kin, ax, drive.col("ay"), drive.col("steer"), veh, model, braking=False)
    assert not quiet.phi_long[brake].any()
    coast = (np.abs(ax) < 0.3) & (np.abs(drive.col("ay")) < 0.3)
    assert not ch.phi_long[coast & (ax <= 0)].any()  # only traction speaks below braking


def test_hard_braking_indicator_is_the_first_order_step_response():
    """The prefilter's hard-braking indicator is the first-order response to
    ``ax < -BRAKING_ACCEL`` over ``BRAKING_ONSET_TAU``: a stop is at its onset for
    ``BRAKING_ONSET_S`` from rest, and a stop that follows a release soon is at its onset
    for less (the indicator has not decayed), both to the analytic response."""
    from roadgrip.estimators.classify.slipmap_evidence import (
        BRAKING_ONSET_S,
        BRAKING_ONSET_TAU,
        PREFILTER_SIZE,
        prefilter,
    )
    from roadgrip.inference.kinematic import KinematicOutput

    dt = 0.01
    t = np.arange(0.0, 12.0, dt)
    ax = np.where((t >= 1.0) & (t < 4.0), -5.0, np.where((t >= 5.0) & (t < 8.0), -5.0, 0.2))
    n = t.size
    z = np.zeros(n)
    kin = KinematicOutput(vx=np.full(n, 20.0), vy=z, beta=z, alpha_f=z, alpha_r=z,
                          kappa=np.zeros((n, 4)), wheels_valid=np.ones((n, 4), bool))
    _, _, _, braking, _ = prefilter(kin, ax, z, t, 0.05, dt, np.zeros(PREFILTER_SIZE))
    # the recursion of the prefilter, y += (1 - exp(-dt / tau)) (u - y), in closed form
    u = (ax < -1.0).astype(float)
    a = np.exp(-dt / BRAKING_ONSET_TAU)
    y = np.zeros(n)
    for i in range(n):
        y[i] = a * (y[i - 1] if i else 0.0) + (1.0 - a) * u[i]
    np.testing.assert_allclose(braking.hard, y, atol=1e-12)
    onset = braking.onset()
    first = (t >= 1.0) & (t < 4.0)
    held = t[first & onset]
    # sampled: the first sample of a stop already counts one step of the response
    assert held[0] == pytest.approx(1.0) and held[-1] == pytest.approx(1.0 + BRAKING_ONSET_S, abs=2.5 * dt)
    # second stop: the indicator starts from y(5 s) and the onset ends where it reaches the level
    y0 = braking.hard[np.searchsorted(t, 5.0) - 1]
    level = 1.0 - math.exp(-BRAKING_ONSET_S / BRAKING_ONSET_TAU)
    expected = BRAKING_ONSET_TAU * math.log((1.0 - y0) / (1.0 - level))
    second = t[(t >= 5.0) & (t < 8.0) & onset]
    assert 0.1 < expected < BRAKING_ONSET_S - 0.1
    assert second[-1] - 5.0 == pytest.approx(expected, abs=2.5 * dt)
    assert not onset[(t >= 1.0 + BRAKING_ONSET_S) & (t < 4.0)].any()


def test_slip_map_votes_with_the_onset_of_a_stop_only_on_the_multibody_van():
    """With a fitted model the slip map takes braking evidence at the onset of a stop:
    on a multi-body dry -> gravel -> dry drive, each near-saturating stop votes 'high' on
    dry asphalt and 'low' on gravel in its first 0.8 s, and the rest of the stop, where
    the coasting speed's bias grows, carries no longitudinal evidence. Without a fitted
    model braking carries none at all."""
    from roadgrip.estimators.classify.grip_model import braking_samples
    from roadgrip.estimators.classify.slipmap import Front, front_batch, front_init
    from roadgrip.estimators.classify.slipmap_evidence import (
        PREFILTER_SIZE,
        evidence_from_kinematics,
        prefilter,
    )
    from roadgrip.sim.scenarios import simulate_scenario

    drive = simulate_scenario("dry-gravel-dry", seed=1, engine="multibody", vehicle="vw-vanagon")
    veh = drive.vehicle
    model = GripModel(c_long=22.0, c_lat=13.0, mu_high=1.0, mu_low=0.5, model_error_x=0.05,
                      gain_x=1.0 + GRAVITY * veh.pitch_gradient)
    votes = {}
    for grip in (model, None):
        cfg = slipmap_saturation(grip=grip)
        front = Front.for_drive(drive, cfg.lateral_acceleration)
        (kin, ay, _ax), _ = front_batch(drive, front, front_init())
        kin_f, ax_f, ay_f, braking, _ = prefilter(kin, drive.col("ax"), ay, drive.t, cfg.prefilter_tau_s,
                                                  0.01, np.zeros(PREFILTER_SIZE))
        ev = evidence_from_kinematics(kin_f, ax_f, ay_f, drive.col("steer"), veh, cfg, braking)
        brake = braking_samples(kin_f, ax_f)
        votes[grip is None] = (ev, brake, braking.onset())
    ev, brake, onset = votes[False]
    t, mu = drive.t, drive.col("mu_true")
    starts = np.flatnonzero(brake & ~np.r_[False, brake[:-1]])
    by_surface = {}
    for i in starts:
        sel = brake & onset & (t >= t[i]) & (t < t[i] + 1.0)
        if ev.w_x[sel].sum() > 1.0:  # the classes predict different decelerations
            by_surface.setdefault(float(mu[i]), []).append(float((ev.p_high - ev.p_low)[sel].sum()))
    assert set(by_surface) == {0.5, 1.0}, by_surface
    assert min(by_surface[1.0]) > 0.0 and max(by_surface[0.5]) < 0.0, by_surface
    assert not ev.w_x[brake & ~onset].any()
    ev0, brake0, _ = votes[True]
    assert not ev0.w_x[brake0].any()


def test_channels_of_one_sample_at_a_time_equal_the_whole_array():
    """The live path gives :func:`channels` one sample (scalars, ``kappa`` of shape (4,)); a
    batch gives the drive. Both loop over the same compiled per-sample function, so every
    sample's regressions and predictions are the same floats, braking and demonstrated
    channels included."""
    from roadgrip.estimators.classify.grip_model import channels
    from roadgrip.inference.kinematic import KinematicOutput

    rng = np.random.default_rng(3)
    n = 400
    kin = KinematicOutput(vx=rng.uniform(-1.0, 30.0, n), vy=np.zeros(n), beta=np.zeros(n),
                          kappa=rng.normal(0.0, 0.05, (n, 4)), alpha_f=rng.normal(0.0, 0.05, n),
                          alpha_r=rng.normal(0.0, 0.04, n), wheels_valid=rng.random((n, 4)) > 0.1)
    ax, ay, steer = rng.normal(0.0, 3.0, n), rng.normal(0.0, 4.0, n), rng.normal(0.0, 0.1, n)
    for model in (default_grip_model(SEDAN, 1.0, 0.4),
                  replace(default_grip_model(SEDAN, 1.0, 0.4), lateral_evidence="demonstrated",
                          kappa_offset=0.01, alpha_offset_f=0.02, resistance_2=1e-3)):
        ch, cp = channels(kin, ax, ay, steer, SEDAN, model)
        assert np.any(ch.phi_long != 0.0) and np.any(ch.phi_lat != 0.0)
        for i in range(n):
            one = KinematicOutput(float(kin.vx[i]), 0.0, 0.0, kin.kappa[i], float(kin.alpha_f[i]),
                                  float(kin.alpha_r[i]), kin.wheels_valid[i])
            ch1, cp1 = channels(one, float(ax[i]), float(ay[i]), float(steer[i]), SEDAN, model)
            assert [a[0] for a in (*ch1, *cp1)] == [a[i] for a in (*ch, *cp)]
