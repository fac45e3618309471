"""Kalman cascade (paper 003) against simulated truth and analytic results."""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from roadgrip.drive import Drive, DriveValidationError
from roadgrip.estimators import cascade as C
from roadgrip.estimators import run_estimator
from roadgrip.tire import brush_force
from roadgrip.vehicle.params import PRESETS

sys.path.insert(0, str(Path(__file__).parent))
from synthetic import simulate_brush


@pytest.fixture(scope="module")
def drive06():
    return simulate_brush(mu=0.6, duration=40.0, steer_amp=0.3, seed=1)


def _derived(drive, config=None):
    """What ``prepare`` derives from the drive (noise, speed source, resolved defaults)."""
    return C.prepare(drive, config or C.CascadeConfig()).info.derived


def _filter(drive, config=None):
    """Kernel rows and final state of a whole drive."""
    config = config or C.CascadeConfig()
    prep = C.prepare(drive, config)
    return C.run_filter(C.init(prep.info, config), prep.samples)


def test_brush_inverse_is_exact_and_flags_sliding():
    rng = np.random.default_rng(0)
    n = 2000
    mu = rng.uniform(0.1, 1.5, n)
    k = rng.uniform(3.0, 20.0, n)
    fz = rng.uniform(5.0, 5000.0, n)
    slip = rng.uniform(-0.6, 0.6, n)
    f = brush_force(slip, fz, mu, k)
    est, sliding, ok = C.brush_mu_inverse(f, slip, fz, k)
    truly_sliding = np.abs(np.tan(slip)) >= 3 * mu / k
    adhesion = ~truly_sliding & (np.abs(slip) > 1e-3)
    assert adhesion.sum() > 500 and truly_sliding.sum() > 200
    np.testing.assert_allclose(est[adhesion], mu[adhesion], rtol=1e-9)
    assert ok[adhesion].all() and not sliding[adhesion].any()
    # saturated (fully sliding): flagged, and mu = |F| / Fz is still what the model says
    assert sliding[truly_sliding].all()
    np.testing.assert_allclose(est[truly_sliding], mu[truly_sliding], rtol=1e-12)
    # a force at or above the linear-tire force: no finite mu, flagged
    lin = fz * k * np.tan(np.abs(slip))
    est2, _, ok2 = C.brush_mu_inverse(1.01 * lin * np.sign(slip), slip, fz, k)
    assert not ok2.any() and np.isinf(est2).all()
    # zero slip and opposite signs are not identifiable
    assert not C.brush_mu_inverse(1.0, 0.0, 10.0, 5.0)[2]
    assert not C.brush_mu_inverse(-1.0, 0.1, 10.0, 5.0)[2]


def test_compiled_brush_equals_tire_module():
    rng = np.random.default_rng(4)
    M = rng.uniform(0.1, 1.2, (50, 2))
    for af, ar in ((0.0, 0.0), (0.03, -0.02), (-0.2, 0.4)):
        Z = C.friction_measurement(M, af, ar, 20.0, 11.0, 7.0, 13.0, 0.0, 0.0, 0.05, 2.0)
        np.testing.assert_allclose(Z[:, 0], brush_force(af, 20.0, M[:, 0], 7.0), rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(Z[:, 1], brush_force(ar, 11.0, M[:, 1], 13.0), rtol=1e-13, atol=1e-13)


def test_combined_slip_leaves_the_friction_circle_to_the_lateral_force():
    """With a longitudinal force Fx on the axle, the lateral brush saturates at sqrt((mu Fz)² - Fx²)."""
    M = np.array([[0.6, 0.6], [1.0, 0.3]])
    fzf, fzr, fxf, fxr = 20.0, 11.0, -0.5 * 20.0, 0.4 * 11.0
    Z = C.friction_measurement(M, 0.4, -0.4, fzf, fzr, 7.0, 13.0, fxf, fxr, 0.05, 2.0)  # both saturated
    np.testing.assert_allclose(np.hypot(Z[:, 0], fxf), M[:, 0] * fzf, rtol=1e-12)
    np.testing.assert_allclose(np.hypot(Z[1, 1], fxr), np.hypot(0.05, 0.4) * fzr, rtol=1e-12)  # Fx alone > mu Fz
    np.testing.assert_allclose(np.hypot(Z[0, 1], fxr), 0.6 * fzr, rtol=1e-12)
    # in the linear range the force does not depend on the friction left
    lin = C.friction_measurement(M, 1e-4, 1e-4, fzf, fzr, 7.0, 13.0, fxf, fxr, 0.05, 2.0)
    np.testing.assert_allclose(lin[:, 0], fzf * 7.0 * np.tan(1e-4), rtol=1e-3)


def test_force_models_match_rigid_body_equations():
    veh = PRESETS["f1tenth"]
    X = np.array([[3.0, 0.5, 0.1, 2.0, 10.0, 6.0]])
    d, dt = 0.2, 0.01
    Y = C.force_transition(X, d, dt, veh.mass, veh.yaw_inertia, veh.lf, veh.lr)[0]
    fx = 2.0 * np.cos(d) - 10.0 * np.sin(d)
    fy = 2.0 * np.sin(d) + 10.0 * np.cos(d) + 6.0
    mz = veh.lf * (2.0 * np.sin(d) + 10.0 * np.cos(d)) - veh.lr * 6.0
    vx_n, vy_n = C.rotate_integrate(3.0, 0.1, 0.5, fx / veh.mass, fy / veh.mass, dt)
    np.testing.assert_allclose(Y[:3], [vx_n,
                                        0.5 + dt * mz / veh.yaw_inertia,
                                        vy_n], rtol=1e-14)
    np.testing.assert_array_equal(Y[3:], X[0, 3:])
    Z = C.force_measurement(X, d, veh.mass)[0]
    np.testing.assert_allclose(Z, [3.0, 0.5, 0.1, fx / veh.mass, fy / veh.mass], rtol=1e-14)


def test_velocity_step_integrates_the_kinematics():
    from scipy.integrate import solve_ivp

    vx, vy, r, ax, ay, dt = 3.0, 0.1, 1.5, 0.8, 4.0, 0.02

    def rhs(_, v):  # body-frame kinematics, eq. 2 with ISO signs
        return [ax + v[1] * r, ay - v[0] * r]

    ref = solve_ivp(rhs, (0.0, dt), [vx, vy], rtol=1e-12, atol=1e-12).y[:, -1]
    got = np.array(C.rotate_integrate(vx, vy, r, ax, ay, dt))
    euler = np.array([vx + dt * (ax + vy * r), vy + dt * (ay - vx * r)])
    err = np.abs(got - ref).max()
    assert err < 1e-5  # third order in r dt; the Euler step errs by O(dt²)
    assert np.abs(euler - ref).max() > 50 * err


def test_tracks_states_forces_and_friction(drive06):
    res = C.run(drive06)
    tab = res.table
    df = drive06.data
    k0 = 300  # after the initial transient
    for est, true, tol in (("vx", "vx_true", 0.02), ("vy", "vy_true", 0.03),
                           ("alpha_f", "alpha_f_true", 0.01), ("alpha_r", "alpha_r_true", 0.01)):
        rmse = np.sqrt(np.mean((tab[est][k0:] - df[true][k0:]) ** 2))
        assert rmse < tol, (est, rmse)
    for est, true in (("Fyf", "Fyf_true"), ("Fyr", "Fyr_true")):
        rmse = np.sqrt(np.mean((tab[est][k0:] - df[true][k0:]) ** 2))
        assert rmse < 0.1 * df[true].std(), (est, rmse)
    last = tab.iloc[-1]
    for axle in ("front", "rear"):
        assert abs(last[f"mu_{axle}"] - 0.6) < 0.08
        assert last[f"mu_{axle}_lower"] < 0.6 < last[f"mu_{axle}_upper"]
    # single-sample observations are unbiased on average
    for axle in ("front", "rear"):
        sel = tab[f"excited_{axle}"]
        w = 1 / tab.loc[sel, f"mu_{axle}_obs_std"] ** 2
        assert sel.sum() > 200
        assert abs((w * tab.loc[sel, f"mu_{axle}_obs"]).sum() / w.sum() - 0.6) < 0.03
    assert res.meta["diagnostics"]["samples with all covariances positive definite [%]"] == 100.0


def test_variance_grows_without_excitation():
    straight = simulate_brush(mu=0.6, duration=20.0, steer_amp=0.0, seed=2)
    cfg = C.CascadeConfig(mu_prior=0.9, mu_prior_std=0.4)
    tab = C.run(straight, cfg).table
    assert not tab["excited"].any()
    np.testing.assert_allclose(tab["mu_front_std"].iloc[-1], 0.4, rtol=1e-3)
    # from a confident state, the variance grows as the random walk says (the paper's model)
    cfg = dataclasses.replace(cfg, accel_std=0.05, gyro_std=0.005, speed_std=0.02, mu_length=0.0)
    prep = C.prepare(straight, cfg)
    st = C.init(prep.info, cfg)._replace(friction_cov=np.eye(2) * 0.01)
    stds = []
    for s in prep.samples[:200]:
        st, row = C.step(st, s)
        stds.append(row["mu_front_std"])
    dt = 1 / 100.0
    np.testing.assert_allclose(stds[-1] ** 2, 0.01 + cfg.mu_rate_std**2 * dt * 199, rtol=1e-3)
    assert np.all(np.diff(stds) > 0)


def _confidently_wrong_obs(tab, axle, mu):
    """Excited samples whose observation misses ``mu`` by more than 1.96 of its total std."""
    ex = tab[f"excited_{axle}"].to_numpy(bool)
    sd = np.hypot(tab[f"mu_{axle}_obs_std"], tab[f"mu_{axle}_obs_sys"]).to_numpy()
    return int(np.sum(ex & (np.abs(tab[f"mu_{axle}_obs"].to_numpy() - mu) > 1.96 * sd)))


def test_slip_error_prior_until_the_consistency_check_has_evidence(drive06):
    from roadgrip.estimators.cascade.kernel import consistency_mean_square

    # before any evidence the prior; with much evidence the residuals' own mean square
    assert consistency_mean_square(0.0, 0.0, 0.03**2, 0.2, 0.0) == pytest.approx(0.03**2)
    assert consistency_mean_square(0.99 * 0.01**2, 0.99, 0.03**2, 0.0, 0.99) == pytest.approx(0.01**2)
    # the prior's weight fades with the evidence: after 3 tau in the band it is 2 % above it
    assert consistency_mean_square(0.95 * 0.01**2, 0.95, 0.03**2, 0.4, 0.95) == pytest.approx(0.01**2, rel=0.03)
    # the kinematic check's evidence fades it too: no band sample, a full pose check, nothing left
    assert consistency_mean_square(0.0, 0.0, 0.03**2, 0.4, 1.0) == 0.0
    # a steering sensor 0.04 rad off: every front slip angle is biased from the first sample
    # (the pose does not see it: the band's front residual does, the prior until then)
    df = drive06.data.copy()
    df["steer"] = df["steer"] + 0.04
    biased = Drive(df, drive06.meta)
    assumed_exact = C.run(biased, C.CascadeConfig(slip_error_prior=0.0)).table
    assert _confidently_wrong_obs(assumed_exact, "front", 0.6) > 5  # 11 measured
    tab = C.run(biased, C.CascadeConfig(slip_error_prior=0.03)).table
    assert _confidently_wrong_obs(tab, "front", 0.6) == 0
    assert _confidently_wrong_obs(tab, "rear", 0.6) == 0
    # exact slip angles: the prior only delays the first observations, which stay accurate
    clean = C.run(drive06, C.CascadeConfig(slip_error_prior=0.03)).table
    for axle in ("front", "rear"):
        sel = clean[f"excited_{axle}"].to_numpy(bool)
        assert sel.sum() > 200
        w = 1 / clean.loc[sel, f"mu_{axle}_obs_std"] ** 2
        assert abs((w * clean.loc[sel, f"mu_{axle}_obs"]).sum() / w.sum() - 0.6) < 0.03


def test_pose_slip_error_is_the_bias_beyond_the_pose_noise():
    """The kinematic check against the pose, against the formula worked by hand."""
    from roadgrip.estimators.cascade.kernel import pose_slip_error

    # no pose seen yet: the prior
    assert pose_slip_error(0.0, 0.0, 10.0, 0.0, 0.03**2, 0.01, 2.0) == pytest.approx(0.03**2)
    # half the window filled with a mean of 0.2 m/s at 10 m/s, noiseless pose: 0.02 rad
    assert pose_slip_error(0.1, 0.5, 10.0, 0.0, 0.0, 0.0, 2.0) == pytest.approx(0.02**2)
    # a full window with pose noise 0.01 m²/s: s² = 0.01 / (2 * 2) / 100 = 2.5e-5 rad² off
    s2 = 0.01 / 4.0 / 100.0
    assert pose_slip_error(0.2, 1.0, 10.0, 0.0, 0.0, 0.01, 2.0) == pytest.approx(0.02**2 - s2)
    # with a prior, the part the noise has not resolved, prior s² / (prior + s²)
    prior = 0.03**2
    assert pose_slip_error(0.2, 1.0, 10.0, 0.0, prior, 0.01, 2.0) == pytest.approx(
        0.02**2 - s2 + prior * s2 / (prior + s2))
    # a bias within the pose's noise shows nothing; the sign does not matter
    assert pose_slip_error(0.004, 1.0, 10.0, 0.0, 0.0, 0.01, 2.0) == 0.0
    assert pose_slip_error(-0.2, 1.0, 10.0, 0.0, 0.0, 0.01, 2.0) == pytest.approx(0.02**2 - s2)
    # the early window is noisier: s² (2 - w) / w at weight w
    w = 0.25
    s2w = 0.01 * (2.0 - w) / (2.0 * 2.0 * w) / 100.0
    assert pose_slip_error(0.2 * w, w, 10.0, 0.0, 0.0, 0.01, 2.0) == pytest.approx(0.02**2 - s2w)


def test_latency_slip_error_is_the_latency_times_the_change_of_ay():
    """The accelerometer latency's slip-angle error against the formula worked by hand."""
    from roadgrip.estimators.cascade.kernel import latency_slip_error

    # 0.05 s times a 2 m/s² change at 10 m/s: 0.01 m/s² s / (m/s) = 0.01 rad
    assert latency_slip_error(2.0, 10.0, 0.0, 0.05**2) == pytest.approx(0.01**2)
    assert latency_slip_error(-2.0, -10.0, 0.0, 0.05**2) == pytest.approx(0.01**2)
    # no change of ay, or a known clock: nothing
    assert latency_slip_error(0.0, 10.0, 0.0, 0.05**2) == 0.0
    assert latency_slip_error(2.0, 10.0, 0.0, 0.0) == 0.0
    # the speed is regularised as the slip angles are
    assert latency_slip_error(2.0, 0.0, 0.1, 0.05**2) == pytest.approx((0.05 * 2.0 / 0.1) ** 2)


def test_an_accelerometer_behind_the_gyro_is_assumed_with_accel_latency_std(drive06):
    """An accelerometer 0.1 s behind the gyro on the steering sine: every change of ay moves vy,
    and the observations taken in those changes are confidently wrong when the clocks are
    assumed one; with the latency assumed (0.06 s) none is (on this sine, where ay never
    rests, that leaves no observation at all: the price of an unknown clock)."""
    from roadgrip.io.calibration import shift_columns

    late = shift_columns(drive06, {"ay": -0.1})
    assumed_one_clock = C.run(late, C.CascadeConfig()).table
    assert _confidently_wrong_obs(assumed_one_clock, "front", 0.6) > 20  # 70 measured
    assumed_late = C.run(late, C.CascadeConfig(accel_latency_std=0.06)).table
    for axle in ("front", "rear"):
        assert _confidently_wrong_obs(assumed_late, axle, 0.6) == 0


def test_friction_returns_to_the_prior_over_distance():
    """With a correlation length L, an unexcited state decays to the prior as exp(-distance / L)."""
    straight = simulate_brush(mu=0.6, duration=5.0, steer_amp=0.0, seed=2)
    cfg = C.CascadeConfig(mu_prior=0.9, mu_prior_std=0.4, mu_length=1.5, accel_std=0.05, gyro_std=0.005,
                          speed_std=0.02)
    prep = C.prepare(straight, cfg)
    st = C.init(prep.info, cfg)._replace(friction_mean=np.array([0.3, 0.3]), friction_cov=np.eye(2) * 1e-4)
    rows = []
    for s in prep.samples[:150]:
        st, row = C.step(st, s)
        rows.append(row)
    # the same recursion, written out from the rows' speeds
    m, v, q = 0.3, 1e-4, cfg.mu_rate_std**2
    for k, row in enumerate(rows):
        dt = 0.0 if k == 0 else row["t"] - rows[k - 1]["t"]
        a = np.exp(-abs(row["vx"]) * dt / cfg.mu_length)
        m = 0.9 + a * (m - 0.9)
        v = min(a * a * v + (1 - a * a) * 0.16 + q * dt, 0.16)
        assert row["mu_front"] == pytest.approx(m, abs=1e-12)
        assert row["mu_front_std"] == pytest.approx(np.sqrt(v), rel=1e-9)
    travelled = sum(abs(r["vx"]) for r in rows[1:]) * 0.01
    assert travelled > 2 * cfg.mu_length  # the test covers a real return
    assert abs(rows[-1]["mu_front"] - 0.9) < 0.6 * np.exp(-travelled / cfg.mu_length) + 1e-9


def test_online_steps_give_the_stage_estimates_and_state_of_run(drive06):
    short = drive06.slice_time(0.0, 3.0)
    cfg = C.CascadeConfig()
    tab = C.run(short, cfg).table
    prep = C.prepare(short, cfg)
    st = C.init(prep.info, cfg)
    rows = []
    for s in prep.samples:
        st, row = C.step(st, s)
        rows.append(row)
    np.testing.assert_allclose([r["Fyf"] for r in rows], tab["Fyf"], rtol=0, atol=1e-9)
    np.testing.assert_allclose([r["vy"] for r in rows], tab["vy"], rtol=0, atol=1e-12)
    np.testing.assert_allclose([r["x_front"] for r in rows], tab["x_front"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(st.friction_cov, _filter(short, cfg)[1].friction_cov, atol=1e-14)
    np.testing.assert_array_equal([r["grip_floor"] for r in rows], tab["grip_floor"])
    np.testing.assert_array_equal([r["grip_now"] for r in rows], tab["grip_now"])
    np.testing.assert_allclose([r["mu_rear_upper"] for r in rows], tab["mu_rear_upper"], rtol=0, atol=1e-12)


def test_stepping_past_the_noise_window_keeps_the_batch_noise_levels_in_bounded_memory(drive06):
    """One sample at a time over 40 s (twenty noise updates, more than NOISE_WINDOW): the
    running noise levels in force are those of the batch run, the rows its rows, and the
    memory holds the window and at most RECENT_BLOCKS unjoined one-sample blocks."""
    from roadgrip.estimators.cascade.running_noise import NOISE_WINDOW, RECENT_BLOCKS

    cfg = C.CascadeConfig()
    prep = C.prepare(drive06, cfg)
    assert prep.info.derived["noise_running"]  # the drive gives no noise: it is estimated
    st = C.init(prep.info, cfg)
    rows, spans = [], []
    for s in prep.samples:
        st, row = C.step(st, s)
        rows.append(row)
        mem = st.noise_memory
        assert len(mem.recent) < RECENT_BLOCKS
        spans.append(float(mem.joined()[0][-1] - mem.joined()[0][0]))
    assert drive06.duration > NOISE_WINDOW + 5.0
    assert max(spans) < NOISE_WINDOW + RECENT_BLOCKS * 0.011
    out, end = _filter(drive06, cfg)
    for name in ("var_acc", "var_gyro", "var_speed"):
        assert getattr(st.params, name) == getattr(end.params, name)
    np.testing.assert_allclose([r["mu_front"] for r in rows], out[:, C.Out.MU_F], rtol=0, atol=1e-9)
    np.testing.assert_allclose([r["vy"] for r in rows], out[:, C.Out.VY], rtol=0, atol=1e-12)


def test_upper_bound_never_below_the_sustained_lateral_acceleration(drive06):
    """A car that held |a_y| for a second proves mu >= |a_y| / g: no band may end below it,
    even one that a confident prior would put there."""
    cfg = C.CascadeConfig(mu_prior=0.2, mu_prior_std=0.05, mu_bounds=(0.05, 2.0))
    res = C.run(drive06, cfg)
    tab = res.table
    from roadgrip.signals import sustained_grip

    floor = sustained_grip(drive06.t, drive06.col("ay"))  # no roll: levelled = measured
    assert floor.max() > 0.45  # the drive holds 0.6 g-ish turns
    np.testing.assert_allclose(tab["grip_floor"], floor, rtol=0, atol=1e-15)
    for axle in ("front", "rear"):
        assert np.all(tab[f"mu_{axle}_upper"] >= floor)
    assert res.meta["summary"]["UpperBound"] >= floor[-1]
    # and the road summary's lower end is at least the grip the car uses now (the last
    # second's, which forgets a surface the car has left)
    from roadgrip.signals import current_grip

    now = current_grip(drive06.t, drive06.col("ay"))
    np.testing.assert_allclose(tab["grip_now"], now, rtol=0, atol=1e-15)
    assert np.all(now <= floor + 1e-15)
    assert res.meta["summary"]["LowerBound"] >= now[-1]
    assert res.meta["summary"]["MostProbable"] >= now[-1]


def test_run_columns_and_option_checks(drive06, tmp_path):
    res = run_estimator("cascade", drive06)
    for col in ("vx", "vy", "Fyf", "Fyr", "x", "y", "x_front", "mu_front_obs"):
        assert col in res.table.columns
    assert res.meta["summary"]["LowerBound"] < res.meta["summary"]["MostProbable"]
    with pytest.raises(ValueError, match="particles"):
        run_estimator("cascade", drive06, {"particles": 10})
    with pytest.raises(ValueError, match="jerkstd"):
        run_estimator("cascade", drive06, {"jerkstd": 1.0})
    with pytest.raises(ValueError, match="mu_rate_std"):
        C.CascadeConfig(mu_rate_std=-1.0)
    with pytest.raises(ValueError, match="speed_source"):
        C.CascadeConfig(speed_source="gps")
    no_speed = Drive.from_frame(drive06.data.drop(columns=["vx"]), drive06.vehicle)
    with pytest.raises(DriveValidationError, match="speed measurement"):
        C.run(no_speed)
    path = tmp_path / "est.parquet"
    res.to_parquet(path)
    back = pd.read_parquet(path)
    assert len(back) == drive06.n and "mu_front_obs" in back.columns


def test_speed_sources():
    d = simulate_brush(mu=0.6, duration=2.0, seed=3)
    veh = d.vehicle
    v = d.col("vx_true")
    rpm = v * 60.0 * veh.gear_ratio / (2 * np.pi * veh.wheel_radius)
    df = d.data.drop(columns=["vx"]).assign(motor_rpm=rpm)
    d2 = Drive.from_frame(df, veh)
    got, src, _ = C.measured_speed(d2)
    assert "gear ratio" in src
    np.testing.assert_allclose(got, v, rtol=1e-12)
    w = v / veh.wheel_radius
    df3 = d.data.drop(columns=["vx"]).assign(omega_fl=w, omega_fr=w, omega_rl=w, omega_rr=w)
    got3, src3, share = C.measured_speed(Drive.from_frame(df3, veh))
    assert share == 0.5  # f1tenth is four-wheel driven: all four wheels
    assert "wheel" in src3
    np.testing.assert_allclose(got3, v, rtol=1e-12)


def test_command_line_estimate_map_and_show(drive06, tmp_path):
    from typer.testing import CliRunner

    from roadgrip.cli import app

    src = tmp_path / "drive.parquet"
    drive06.to_parquet(src)
    est, png = tmp_path / "est.parquet", tmp_path / "casc.png"
    runner = CliRunner()
    r = runner.invoke(app, ["estimate", str(src), "--method", "cascade", "-o", str(est), "--plot", str(png)])
    assert r.exit_code == 0, r.output
    tab = pd.read_parquet(est)
    for col in ("t", "mu_front", "mu_rear", "mu_front_lower", "mu_front_upper", "mu_rear_lower",
                "mu_rear_upper", "excited", "vx", "vy", "Fyf", "Fyr", "x", "y"):
        assert col in tab.columns
    assert png.stat().st_size > 20_000
    out, csv, mpng = tmp_path / "map.npz", tmp_path / "cells.csv", tmp_path / "map.png"
    r = runner.invoke(app, ["map", str(est), str(src), "-o", str(out), "--cell", "0.5", "--csv", str(csv),
                            "--png", str(mpng)])
    assert r.exit_code == 0, r.output
    cells = pd.read_csv(csv)
    # the estimates file and the drive (run through the cascade) give the same observations
    assert cells["n_obs"].sum() == 2 * (tab["excited_front"].sum() + tab["excited_rear"].sum())
    r = runner.invoke(app, ["map", "show", str(out), "-o", str(tmp_path / "show.png")])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "show.png").stat().st_size > 10_000
    r = runner.invoke(app, ["estimate", str(src), "--method", "cascade", "-o", str(est), "--particles", "5"])
    assert r.exit_code != 0


@pytest.mark.slow
def test_covariances_stay_positive_definite_over_one_hour():
    sim = pytest.importorskip("roadgrip.sim.scenarios")
    drive = sim.simulate_scenario("f1tenth-patches", 11, duration=3600.0)
    out, st = _filter(drive)
    assert drive.duration >= 3599.0
    assert out[:, C.Out.PD_OK].all()
    assert out[:, C.Out.REPAIRS].sum() == 0
    for col in (C.Out.VAR_F, C.Out.VAR_R, C.Out.FYF_VAR, C.Out.FYR_VAR):
        assert np.all(out[:, col] > 0) and np.all(np.isfinite(out[:, col]))
    assert np.all(np.isfinite(out[:, [C.Out.MU_F, C.Out.MU_R, C.Out.VX, C.Out.VY]]))
    # the final state is still positive definite in every stage
    for P in (st.velocity_cov[:2, :2], st.force_cov, st.friction_cov):
        assert np.linalg.eigvalsh(P).min() > 0


def _smoothed_noise(rng, n, std, window=31):
    """White noise smoothed by a moving average of ``window`` samples, scaled to ``std``."""
    e = np.convolve(rng.normal(size=n + window), np.ones(window) / window, mode="valid")[:n]
    return std * e / e.std()


def test_pose_velocity_bounds_the_lateral_velocity_drift(drive06):
    """A lateral-accelerometer scale error makes the integrated vy wrong in every turn; a pose
    velocity fused in stage 1 bounds the error."""
    rng = np.random.default_rng(4)
    df = drive06.data.copy()
    df["ay"] = 0.8 * df["ay"]
    cfg = C.CascadeConfig(accel_model_std=1.0, pose_velocity_std=0.02)
    k0 = 300
    plain = C.run(drive06.with_data(df), dataclasses.replace(cfg, pose_window=0.0)).table
    err_plain = np.sqrt(np.mean((plain["vy"][k0:] - df["vy_true"][k0:]) ** 2))
    # without the columns, the velocity differentiated from the drive's own x, y, psi
    own = C.run(drive06.with_data(df), cfg)
    err_own = np.sqrt(np.mean((own.table["vy"][k0:] - df["vy_true"][k0:]) ** 2))
    assert own.meta["derived"]["pose_velocity"] == "derived"
    assert err_own < 0.7 * err_plain, (err_own, err_plain)
    posed = df.assign(vx_pose=df["vx_true"] + _smoothed_noise(rng, len(df), 0.02),
                      vy_pose=df["vy_true"] + _smoothed_noise(rng, len(df), 0.02))
    posed.loc[1000:1100, ["vx_pose", "vy_pose"]] = np.nan  # a stretch without pose (a jump)
    tab = C.run(drive06.with_data(posed), cfg).table
    err = np.sqrt(np.mean((tab["vy"][k0:] - df["vy_true"][k0:]) ** 2))
    assert err_plain > 0.3
    assert err < 0.15 and err < 0.35 * err_plain, (err, err_plain)
    assert np.isfinite(tab[["vy", "mu_front", "mu_rear"]].to_numpy()).all()
    # switched off by pose_velocity_std = 0: the columns are ignored
    off = C.run(drive06.with_data(posed), dataclasses.replace(cfg, pose_velocity_std=0.0)).table
    ref = C.run(drive06.with_data(df), dataclasses.replace(cfg, pose_velocity_std=0.0)).table
    np.testing.assert_array_equal(off["vy"], ref["vy"])
    bad = posed.copy()
    bad.loc[50, "vy_pose"] = np.inf
    with pytest.raises(DriveValidationError, match="vy_pose"):
        C.run(drive06.with_data(bad), cfg)


def test_steering_command_lag_widens_the_front_slip_angle():
    """With a steering response time, a command step adds its not-yet-followed part to std(alpha_f)."""
    d = simulate_brush(mu=0.6, duration=8.0, steer_amp=0.0, seed=5)
    df = d.data.copy()
    k_step = 500
    df.loc[k_step:, "steer"] = df.loc[k_step:, "steer"] + 0.2
    drv = d.with_data(df)
    tau, dt = 0.1, 0.01
    lagged = C.run(drv, C.CascadeConfig(steer_response_time=tau)).table
    measured = C.run(drv, C.CascadeConfig(steer_response_time=0.0)).table
    k = np.arange(k_step, k_step + 40)
    expected = (0.2 * (1 - dt / tau) ** (k - k_step + 1)) ** 2
    got = lagged["alpha_f_std"].to_numpy()[k] ** 2 - measured["alpha_f_std"].to_numpy()[k] ** 2
    np.testing.assert_allclose(got, expected, rtol=1e-6, atol=1e-12)
    # before the step the command is constant and both agree; the rear axle is not affected
    np.testing.assert_allclose(lagged["alpha_f_std"][:k_step], measured["alpha_f_std"][:k_step], atol=1e-12)
    np.testing.assert_allclose(lagged["alpha_r_std"], measured["alpha_r_std"], atol=1e-12)
    # a drive that declares its steering a command gets 0.1 s by default
    cmd = Drive.from_frame(df, d.vehicle, extra={"steer_is_command": True})
    assert _derived(cmd)["steer_response_time"] == 0.1
    assert _derived(drv)["steer_response_time"] == 0.0
    # the configuration itself is not changed
    res = C.run(cmd)
    assert res.meta["config"]["steer_response_time"] is None and res.meta["derived"]["steer_response_time"] == 0.1


def test_reader_noise_replaces_the_estimate_from_resampled_signals(drive06):
    """Noise measured by the reader on the native streams takes precedence over the drive estimate."""
    est = _derived(drive06)["noise"]
    native = {"accel_std": 0.9, "gyro_std": 0.04, "speed_std": 0.03}
    d = Drive.from_frame(drive06.data, drive06.vehicle, extra={"sensor_noise": native})
    got = _derived(d)["noise"]
    assert got["accel_std"] == 0.9 and got["gyro_std"] == 0.04
    # speed_std applies to the vx column only; the configuration still wins
    assert got["speed_std"] == (0.03 if "vx" in C.measured_speed(d)[1] else est["speed_std"])
    assert _derived(d, C.CascadeConfig(accel_std=0.2))["noise"]["accel_std"] == 0.2


DATA = Path(__file__).resolve().parents[2] / ".." / "shared" / "data"


@pytest.mark.realdata
def test_frictionmaps_run_gives_finite_estimates_and_a_map():
    path = DATA / "frictionmaps" / "DS3"
    if not path.is_dir():
        pytest.skip(f"real data not found at {path}")
    from roadgrip import mapping as M
    from roadgrip.io import read_drive

    drive = read_drive(str(path), format="frictionmaps")
    res = C.run(drive)
    tab = res.table
    for col in ("mu_front", "mu_rear", "mu_front_lower", "mu_rear_upper", "vx", "vy", "Fyf", "Fyr"):
        assert np.isfinite(tab[col]).all(), col
    diag = res.meta["diagnostics"]
    assert diag["covariance repairs"] == 0
    # standstills in the run switch the accelerometer bias states on
    assert res.meta["derived"]["accel_bias_std"] > 0
    # the noise measured on the native streams (not the 10x smaller estimate from the
    # resampled signals) makes stage 2 consistent: mean NIS near its 5 degrees of freedom
    assert diag["accel noise std [m/s2]"] > 0.3
    assert diag["mean NIS stage 2 (5 dof)"] < 7.5
    # the pose velocity bounds the lateral-velocity drift
    ok = np.isfinite(drive.data["vy_pose"]).to_numpy() & (drive.data["vx"].to_numpy() > 1.0)
    assert np.sqrt(np.mean((tab["vy_ekf"].to_numpy()[ok] - drive.data["vy_pose"].to_numpy()[ok]) ** 2)) < 0.2
    # DS3 is driven slowly (99 % of |ay| below 0.35 g): the tires stay far from saturation,
    # the data carry (almost) no peak-friction information and the map keeps its prior
    assert tab["excited_front"].mean() < 0.02 and tab["excited_rear"].mean() < 0.02
    grid = M.grid_from_estimates(tab, 0.5)
    mean, std = grid.posterior()
    seen = grid.n_obs > 0
    assert np.all((mean[seen] > 0) & (mean[seen] < 2.0))
    assert np.all(std[~seen] == grid.prior_std)
