"""Slip-acceleration map classifier (paper 002, Sec. V, eq. 9-16)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from test_brls import stepped, sufficiently_excited

from roadgrip.constants import GRAVITY
from roadgrip.estimators import run_estimator
from roadgrip.estimators.classify import SLIPMAP, Calibration, calibrate, slipmap
from roadgrip.estimators.classify.brls_config import default_config as brls_default
from roadgrip.estimators.classify.slipmap_config import SlipMapConfig, default_config
from roadgrip.estimators.classify.slipmap_evidence import SlipMapEvidence, evidence
from roadgrip.estimators.classify.slipmap_kernel import slipmap_batch, slipmap_init, slipmap_step
from roadgrip.evaluate.metrics import count_switches, detection_delays, truth_grip_class
from roadgrip.vehicle import PRESETS

SEDAN = PRESETS["sedan"]  # front-wheel drive


def _ev(kappa_front=0.0, alpha=0.0, ax=0.0, ay=0.0, cfg=None):
    cfg = cfg or default_config()
    kappa = np.array([[kappa_front, kappa_front, 0.0, 0.0]])
    return evidence(kappa, np.array([alpha]), np.array([alpha]), np.array([ax]), np.array([ay]),
                    np.zeros(1), np.ones((1, 4), bool), SEDAN, cfg)


def test_reference_curves_are_the_mid_friction_magic_formula():
    cfg = default_config(0.8)
    L = SEDAN.lf + SEDAN.lr
    ev = _ev(alpha=0.05, ay=3.0)
    assert ev.ay_ref[0] == pytest.approx(GRAVITY * cfg.lat_curve.mu(0.05))  # lr/L + lf/L = 1
    # front-wheel drive accelerating: the front axle share of the weight, with load transfer
    ax = 2.0
    ev = _ev(kappa_front=0.05, ax=ax)
    share = SEDAN.lr / L - SEDAN.cg_height * ax / (GRAVITY * L)
    assert ev.ax_ref[0] == pytest.approx(GRAVITY * share * cfg.long_curve.mu(0.05))
    assert cfg.lat_curve.D == 0.8 and cfg.long_curve.D == 0.8


def test_weights_and_probabilities_eq9_to_15():
    cfg = default_config()
    # far above the lateral reference: high-friction evidence with W_y = 1 - exp(-d²/sigma²)
    ev = _ev(alpha=0.02, ay=8.0)
    d = 8.0 - ev.ay_ref[0]
    w = 1 - np.exp(-(d**2) / cfg.sigma_y**2)
    assert ev.w_y[0] == pytest.approx(w)
    assert ev.p_high[0] == pytest.approx(0.5 * w)  # the longitudinal channel is excluded (box)
    assert ev.p_low[0] == 0.0
    assert ev.p_old[0] == pytest.approx(0.5 * (1 - w) + 0.5)
    # large slip, small acceleration: low-friction evidence
    ev = _ev(alpha=0.1, ay=2.0)
    assert ev.p_low[0] > 0.3 and ev.p_high[0] == 0.0
    # probabilities sum to one
    rng = np.random.default_rng(0)
    for _ in range(50):
        e = _ev(rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), rng.uniform(-8, 8), rng.uniform(-8, 8))
        assert e.p_high[0] + e.p_low[0] + e.p_old[0] == pytest.approx(1.0)


def test_exclusions_quadrant_box_and_speed():
    # low slip and low acceleration: excluded
    ev = _ev(kappa_front=0.002, alpha=0.002, ax=0.5, ay=0.5)
    assert ev.w_x[0] == 0.0 and ev.w_y[0] == 0.0 and ev.p_old[0] == 1.0
    # acceleration against the slip: excluded (2nd/4th quadrant)
    ev = _ev(kappa_front=0.05, ax=-3.0)
    assert ev.w_x[0] == 0.0
    ev = _ev(alpha=0.05, ay=-3.0)
    assert ev.w_y[0] == 0.0
    # same sign: included
    ev = _ev(alpha=-0.05, ay=-9.0)
    assert ev.w_y[0] > 0.5 and ev.p_high[0] > 0.25
    # standstill: nothing
    cfg = default_config()
    kappa = np.array([[0.05, 0.05, 0.0, 0.0]])
    ev = evidence(kappa, np.array([0.05]), np.array([0.05]), np.array([9.0]), np.array([9.0]),
                  np.zeros(1), np.ones((1, 4), bool), SEDAN, cfg, vx=np.array([0.1]))
    assert ev.w_x[0] == 0.0 and ev.w_y[0] == 0.0


def test_recursion_eq16_converges_and_says_unknown_without_information():
    cfg = replace(default_config(), lowpass_tau_s=0.05)
    n = 300
    t = np.arange(n) * 0.01
    z = np.zeros(n)
    ev = SlipMapEvidence(z, z, np.full(n, 0.4), z, np.full(n, 0.2), z, np.full(n, 0.8), z)
    _, out = slipmap_batch(t, ev, cfg)
    assert out.grip_index[-1] == pytest.approx(1.0, abs=1e-3)  # F -> v^H
    assert out.grip_class[-1] == "high"
    ev_lo = ev._replace(p_high=z, p_low=np.full(n, 0.2))
    _, out = slipmap_batch(t, ev_lo, cfg)
    assert out.grip_index[-1] == pytest.approx(0.0, abs=1e-3)
    assert out.grip_class[-1] == "low"
    none = ev._replace(w_x=z, p_high=z, p_old=np.ones(n))
    _, out = slipmap_batch(t, none, cfg)
    assert (out.grip_class == "unknown").all() and (out.grip_index == 0.5).all()
    assert not out.excited.any()
    # step equals batch
    st = slipmap_init()
    _, outb = slipmap_batch(t, ev, cfg)
    for i in range(n):
        e1 = SlipMapEvidence(*(np.atleast_1d(np.asarray(f)[i]) for f in ev))
        st, o = slipmap_step(st, 0.01, e1, cfg)
        assert o.grip_index == pytest.approx(outb.grip_index[i], rel=1e-12)
        assert o.grip_class == outb.grip_class[i]


def test_index_paced_by_evidence_holds_through_the_silence_after_a_transient():
    """2 s of evidence for 'high', three samples of a transient for 'low' (the end of an
    acceleration, a_x and the slips arriving with different latencies), then 3 s without
    evidence. Eq. 16's F ends at the transient's value; the paper's low-pass settles on it
    ('low'); paced by the evidence the index keeps what it had after the transient."""
    from roadgrip.estimators.classify.slipmap_config import saturation_config

    dt, n_hi, n_tr, n_off = 0.01, 200, 3, 300
    n = n_hi + n_tr + n_off
    t = np.arange(n) * dt
    p_high = np.r_[np.full(n_hi, 0.45), np.full(n_tr, 0.03), np.zeros(n_off)]
    p_low = np.r_[np.full(n_hi, 0.05), np.full(n_tr, 0.47), np.zeros(n_off)]
    p_old = 1.0 - p_high - p_low
    w = 2.0 * (p_high + p_low)
    z = np.zeros(n)
    ev = SlipMapEvidence(z, z, w, z, p_high, p_low, p_old, z)
    f = 0.5  # eq. 16 by hand: F_k = p_old F_{k-1} + p_high
    for k in range(n):
        f = p_old[k] * f + p_high[k]
    paced = saturation_config(hold_high_s=np.inf, hold_low_s=np.inf)
    assert paced.paced_by_evidence and not default_config().paced_by_evidence
    _, out_t = slipmap_batch(t, ev, replace(paced, paced_by_evidence=False))
    _, out_e = slipmap_batch(t, ev, paced)
    # with full evidence (rate above support_min) the two are the same recursion
    np.testing.assert_allclose(out_e.grip_index[:n_hi], out_t.grip_index[:n_hi], rtol=1e-12)
    assert out_e.grip_class[n_hi - 1] == out_t.grip_class[n_hi - 1] == "high"
    assert f < 0.2
    assert out_t.grip_index[-1] == pytest.approx(f, abs=1e-3)
    assert out_t.grip_class[-1] == "low"
    after = out_e.grip_index[n_hi + n_tr - 1]
    assert (out_e.grip_index[n_hi + n_tr:] == after).all() and after > 0.6
    assert (out_e.grip_class[n_hi:] == "high").all()
    st = slipmap_init()  # step equals batch, paced
    for i in range(n):
        st, o = slipmap_step(st, dt, SlipMapEvidence(*(np.atleast_1d(np.asarray(a)[i]) for a in ev)), paced)
        assert o.grip_index == pytest.approx(out_e.grip_index[i], rel=1e-12)


def test_config_validation_and_roundtrip():
    cfg = default_config()
    assert SlipMapConfig.from_dict(cfg.to_dict()) == cfg
    with pytest.raises(ValueError, match="lateral_acceleration"):
        replace(cfg, lateral_acceleration="gps")
    with pytest.raises(ValueError, match="sigma_x"):
        replace(cfg, sigma_x=0.0)
    with pytest.raises(ValueError, match="unknown slipmap setting"):
        SlipMapConfig.from_dict({**cfg.to_dict(), "sigma": 1.0})


# --------------------------------------------------------------------------- simulator


@pytest.fixture(scope="module")
def dgd():
    from roadgrip.sim.scenarios import simulate_scenario

    return simulate_scenario("dry-gravel-dry", seed=0)


def test_dry_gravel_dry_detection_and_no_false_switch_paper_presets(dgd):
    """The paper's mid-friction curves on the planar drive (surface presets of different
    stiffness); the uncalibrated default is the saturation model (test below)."""
    table = run_estimator("slipmap", dgd, {"calibration": Calibration(brls_default(), default_config())}).table
    assert table["theta_lat"].isna().all()
    kappa = sum(dgd.col(f"kappa_{w}_true") for w in ("fl", "fr", "rl", "rr"))
    phi_lat = dgd.col("alpha_f_true") * np.cos(dgd.col("steer")) + dgd.col("alpha_r_true")
    exc = sufficiently_excited(dgd.t, kappa, phi_lat, brls_default())
    truth = truth_grip_class(dgd.col("mu_true"))
    cls = table["grip_class"].to_numpy()
    events = detection_delays(dgd.t, cls, truth, exc, hold=1.0)
    assert [e.new_class for e in events] == ["low", "high"]
    for e in events:
        print(f"change at {e.t_change:.1f} s -> {e.new_class}: first excited {e.t_excited:.2f} s, "
              f"detected {e.t_detected:.2f} s, delay from excitation {e.delay_from_excitation:.2f} s")
        assert e.detected and e.t_detected - e.t_excited <= 2.0
    acc = float((cls == truth).mean())
    print(f"fraction of time classified correctly: {acc:.3f}")
    assert count_switches(cls) == 2
    assert acc > 0.75


def test_uncalibrated_default_is_honest_on_the_planar_drive(dgd):
    table = run_estimator("slipmap", dgd).table
    cls = table["grip_class"].to_numpy()
    truth = truth_grip_class(dgd.col("mu_true"))
    assert not ((cls == "low") & (truth == "high")).any()
    assert not ((cls == "high") & (truth == "low")).any()
    assert (cls[(dgd.t > 60) & (dgd.t < 120)] == "low").any()


def test_straight_cruise_never_switches():
    from roadgrip.sim.scenarios import simulate_scenario

    drive = simulate_scenario("straight-cruise", seed=0)
    table = run_estimator("slipmap", drive).table
    assert count_switches(table["grip_class"]) == 0
    assert not (table["grip_class"] == "low").any()


def _config(settings):
    return SLIPMAP.Config(calibration=Calibration(brls_default(), settings))


def test_run_equals_stepping_with_the_prefilter(dgd):
    """The prefilter on (the common check runs the defaults, prefilter off)."""
    short = dgd.slice_time(60.0, 75.0)
    config = _config(replace(default_config(), prefilter_tau_s=0.5))
    batch = SLIPMAP.run(short, config).table
    rows, _ = stepped(SLIPMAP, short, config)
    np.testing.assert_array_equal(batch["grip_class"].to_numpy(), rows["grip_class"].to_numpy())
    np.testing.assert_allclose(batch["grip_index"], rows["grip_index"], rtol=1e-12)
    np.testing.assert_allclose(batch["w_y"], rows["w_y"], rtol=1e-10, atol=1e-15)
    assert (batch["grip_class"] == "low").any()


# --------------------------------------------------------------------------- real data (DART)


@pytest.mark.realdata
def test_dart_run_equals_stepping_with_pose_kinematic_acceleration():
    from test_brls import dart_split

    drive = dart_split()[1][2][0].slice_time(50.0, 70.0)
    settings = replace(default_config(0.5), prefilter_tau_s=0.5)
    rows, info = stepped(SLIPMAP, drive, _config(settings))
    assert info.derived["aid"] == "pose"
    batch = SLIPMAP.run(drive, _config(settings)).table
    np.testing.assert_allclose(batch["grip_index"], rows["grip_index"], rtol=1e-10)
    np.testing.assert_allclose(batch["w_y"], rows["w_y"], rtol=1e-10, atol=1e-15)
    # the lateral map sees the pose-kinematic ay, not the accelerometer's
    imu = slipmap.slipmap_table(drive, replace(settings, lateral_acceleration="imu"))
    assert not np.allclose(batch["w_y"], imu["w_y"])


@pytest.mark.realdata
def test_dart_calibrate_first_halves_classify_second_halves():
    from test_brls import concatenate, dart_split, excited_accuracy

    cal_set, test_set = dart_split()
    options = {"calibration": calibrate(cal_set)}
    accs = {}
    for drive, label in test_set:
        table = run_estimator("slipmap", drive, options).table
        acc = excited_accuracy(table, label)
        name = drive.meta.source.rsplit('/', 1)[-1]
        print(f"slipmap {label:4s} {name}: excited "
              f"{table['excited'].mean():.2f}, correct {acc:.3f} of excited time after 10 s")
        accs[name] = acc
    # acceptance: every test half >= 90 % of its excited time after the settling period
    assert min(accs.values()) >= 0.9, accs
    # concatenation high -> low -> high
    highs = [d for d, lab in test_set if lab == "high"]
    lows = [d for d, lab in test_set if lab == "low"]
    drive, starts = concatenate([highs[1], lows[0], highs[0]])
    table = run_estimator("slipmap", drive, options).table
    t = drive.t
    truth = np.where((t >= starts[1]) & (t < starts[2]), "low", "high")
    events = detection_delays(t, table["grip_class"].to_numpy(), truth, np.ones(t.size, bool), hold=1.0)
    assert [e.new_class for e in events] == ["low", "high"]
    for e in events:
        print(f"slipmap DART concatenation: change at {e.t_change:.1f} s -> {e.new_class}, "
              f"detected after {e.delay_from_change:.1f} s")
        assert e.detected and e.delay_from_change < 3.0
    print(f"slipmap DART concatenation: correct {np.mean(table['grip_class'] == truth):.3f} of the time")
    assert np.mean(table["grip_class"] == truth) > 0.9
