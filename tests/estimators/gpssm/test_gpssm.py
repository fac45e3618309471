"""GP-SSM particle filter (roadgrip.estimators.gpssm).

The output contract, run against stepping, seed determinism, the unexcited drive and
option rejection are the common check's (tests/estimators/test_common.py).
"""

import math

import numpy as np
import pandas as pd
import pytest

from roadgrip.drive import Drive
from roadgrip.estimators.gpssm import (
    GPSSM,
    Context,
    GPSSMConfig,
    Sample,
    copy_state,
    drive_inputs,
    filter_step,
    resample,
    run,
    run_filter,
    step_reference,
)
from roadgrip.estimators.gpssm import linalg as la
from roadgrip.estimators.gpssm.accuracy import curve_accuracy
from roadgrip.estimators.gpssm.guard import step_sigma_ay
from roadgrip.sim.scenarios import simulate_scenario
from roadgrip.vehicle import PRESETS


@pytest.fixture(scope="module")
def snow20():
    return simulate_scenario("snow-slalom", seed=3, duration=20.0)


@pytest.fixture(scope="module")
def snow60():
    return simulate_scenario("snow-slalom", seed=0, duration=60.0)


def _cfg(drive, basis="separable:8", n=24, **kw):
    return GPSSMConfig(basis=basis, particles=n, **kw)


def _samples(drive):
    return [Sample(*row) for row in drive_inputs(drive)]


def _online(cfg, drive, seed=0, curve_times=(), curve_alpha=None):
    """A :class:`GPSSM` fed every sample of ``drive``, and its curves at ``curve_times``."""
    f = GPSSM(cfg, drive.vehicle, seed=seed)
    if curve_alpha is None:
        curve_alpha = np.linspace(-cfg.peak_range, cfg.peak_range, 161)
    pending, curves = sorted(curve_times), {}
    samples = _samples(drive)
    for i, s in enumerate(samples):
        f.step(s)
        while pending and (s.t >= pending[0] or i == len(samples) - 1):
            curves[pending.pop(0)] = f.curves(curve_alpha)
    return f, curves


def test_other_seed_differs(snow20):
    d = snow20.slice_time(0.0, 4.0)
    cfg = _cfg(d)
    a, _ = run_filter(d, cfg, seed=11)
    c, _ = run_filter(d, cfg, seed=12)
    assert not np.allclose(a["vy"], c["vy"])


@pytest.mark.parametrize(("basis", "proposal", "measured_vy", "limit_deg", "ay_noise"), [
    ("tensor:4x4", "conditional", False, None, 0.0), ("separable-odd:6", "conditional", False, None, 0.0),
    ("tensor-odd:5x5", "prior", False, None, 0.0), ("separable:5", "prior", False, None, 0.0),
    ("separable-odd:6", "conditional", True, None, 0.0), ("tensor-odd:5x5", "conditional", False, 1.0, 0.0),
    ("separable:5", "prior", False, 1.0, 0.0), ("separable-odd:6", "conditional", False, None, 0.8),
    ("tensor:4x4", "prior", False, None, 0.8),
])
def test_compiled_step_equals_the_numpy_reference(snow20, basis, proposal, measured_vy, limit_deg, ay_noise):
    # the compiled kernel and the array implementation draw the same random numbers; a
    # stop at walking pace (no learning, vy pinned to 0), the sideslip bound, a measured
    # lateral velocity and a slip limit that the slip angles pass included
    d = snow20.slice_time(0.0, 8.0)
    limit = None if limit_deg is None else math.radians(limit_deg)
    # (no re-initialisation on divergence here: it restarts the particles, which turns
    # the implementations' rounding differences into different paths)
    # (the accelerometer-gain prior 0.1 named: gains that differ between particles, so that
    # the per-particle gain paths are compared; on some paths fastmath's rounding grows
    # past these tolerances in Psi, 1e-7 of 400, as with 0.05 and this seed)
    cfg = _cfg(d, basis, n=24, proposal=proposal, max_sideslip=math.radians(3.0), slip_limit=limit,
               diverge_time=1e3, ay_gain_sigma=0.1)
    if limit is not None:
        assert np.abs(d.col("alpha_f_true")).max() > 2.0 * limit
    rows = drive_inputs(d)
    if measured_vy:
        rows[100:, 5] = d.col("vy_true")[100:]
    rows[40:48, 4] = 0.3  # below min_speed
    # a vibrating accelerometer: the running noise level sets the likelihood's (ay_noise)
    rows[:, 1] += ay_noise * np.random.default_rng(5).standard_normal(len(rows))
    ctx = Context(cfg, d.vehicle)
    a_state = b_state = None
    a_rows, b_rows = [], []
    for r in rows:
        a_state, ea = step_reference(ctx, a_state, Sample(*r), seed=3)
        b_state, eb = filter_step(ctx, b_state, Sample(*r), seed=3)
        a_rows.append(ea)
        b_rows.append(eb)
    a, b = pd.DataFrame(a_rows), pd.DataFrame(b_rows)
    assert a["resampled"].sum() > 5 and (~a["excited"]).sum() > 5
    used = step_sigma_ay(ctx, a_state.guard)
    assert (used > 0.5 * ay_noise) if ay_noise else used == cfg.sigma_ay
    # (atol 1e-8: the per-step axle loads and accelerometer gains carry the rounding
    # differences of fastmath a little further than the paper's static model did)
    pd.testing.assert_frame_equal(a, b, check_exact=False, rtol=1e-7, atol=1e-8)
    np.testing.assert_allclose(b_state.Psi, a_state.Psi, rtol=1e-7, atol=1e-9)
    # (fastmath sums in another order; with each particle's accelerometer gain the slips
    # that enter the information matrices differ from the reference's by ~1e-9 relative)
    np.testing.assert_allclose(la.information(b_state.lin), la.information(a_state.lin), rtol=1e-8)
    c = np.radians(np.linspace(-10, 10, 9))
    from roadgrip.estimators.gpssm import posterior_curves

    np.testing.assert_allclose(posterior_curves(ctx, b_state, c).mean,
                               posterior_curves(ctx, a_state, c).mean, atol=1e-8)


@pytest.mark.parametrize("basis", ["tensor:4x4", "separable:5"])
def test_fast_step_carries_the_posterior_the_reference_solves_for(snow20, basis):
    # 'fast': the compiled step carries M = Psi P_B and Lambda = Lambda0 + Phi - M Psi^T
    # by recursive least squares and moves them at each refactorisation; the reference
    # solves for M and forms Lambda from Phi and Psi every step
    d = snow20.slice_time(0.0, 8.0)
    cfg = _cfg(d, basis, n=24, linalg="fast", refactor_every=30, forgetting=0.995)
    ctx = Context(cfg, d.vehicle)
    a_state = b_state = None
    a_rows, b_rows = [], []
    for smp in _samples(d):
        a_state, ea = step_reference(ctx, a_state, smp, seed=3)
        b_state, eb = filter_step(ctx, b_state, smp, seed=3)
        a_rows.append(ea)
        b_rows.append(eb)
    a, b = pd.DataFrame(a_rows), pd.DataFrame(b_rows)
    assert a["resampled"].sum() > 5 and b_state.lin.c != 1.0  # 6 refactorisations, c far from 1
    # (atol 1e-8: the per-step axle loads and accelerometer gains carry the rounding
    # differences of fastmath a little further than the paper's static model did)
    pd.testing.assert_frame_equal(a, b, check_exact=False, rtol=1e-7, atol=1e-8)
    m = b_state.M.shape[-1]
    B = la.information(b_state.lin) - (1.0 - b_state.lin.c) * np.eye(m)  # Sigma + c I
    M = np.swapaxes(np.linalg.solve(B, np.swapaxes(b_state.Psi, -1, -2)), -1, -2)
    np.testing.assert_allclose(b_state.M, M, rtol=1e-8, atol=1e-10 * np.abs(M).max())
    Lam = cfg.Lambda0 + b_state.Phi - np.matmul(b_state.Psi, np.swapaxes(M, -1, -2))
    np.testing.assert_allclose(b_state.Lam, Lam, rtol=1e-7, atol=1e-12)


@pytest.mark.parametrize(("mode", "lam", "history"), [("exact", 0.97, 64), ("exact", 0.97, 3), ("fast", 0.97, 64)])
def test_linalg_backends_agree_with_direct_inverse(mode, lam, history):
    # exact: H = Sigma + I to rounding for any forgetting; fast: B = Sigma + c I with the
    # prior weight c of the deferred forgetting; a history shorter than the
    # refactorisation period is folded in when full
    rng = np.random.default_rng(0)
    N, G, m = 6, 2, 12
    ref, st = la.init("direct", N, G, m), la.init(mode, N, G, m, history=history)
    gap = 0.0
    for k in range(120):
        if k:
            ref = la.forget(ref, lam, 7)
            st = la.forget(st, lam, 7)
        R = rng.standard_normal((N, G, m, 3))
        phi = R[..., 0]
        x_ref = np.linalg.solve(la.information(ref) - (1.0 - st.c) * (mode == "fast") * np.eye(m), R)
        x, pb = la.solve(st, R)
        tol = 1e-9
        np.testing.assert_allclose(x, x_ref, rtol=tol, atol=tol * np.abs(x_ref).max())
        gap = max(gap, abs(1.0 - st.c))
        ref = la.update(ref, phi, None)
        st = la.update(st, phi, pb)
        if k % 17 == 16:
            idx = rng.integers(0, N, N)
            if k % 2:
                idx = np.sort(idx)  # the in-place path of systematic resampling
            ref, st = la.take(ref, idx), la.take(st, idx)
    np.testing.assert_allclose(la.information(st), la.information(ref), rtol=1e-10)
    assert gap > 0.1  # c moved far from 1 (lam^(-7/2) = 1.11): fast's approximation is exercised


def test_refactorisations_invert_the_information_and_match_the_reference(snow20):
    # the compiled step's P_B through refactorisations whose period holds two folds of
    # FOLD_ROWS buffered rows and the fold a step before the refactorisation, with
    # resampling in between: against numpy's inverse of B = Sigma + c I (Sigma from the
    # slots and buffered rows, la.information), and the whole step against the reference
    d = snow20.slice_time(0.0, 8.0)
    J = 2 * la.FOLD_ROWS + 5
    cfg = _cfg(d, "separable-odd:6", n=24, refactor_every=J, diverge_time=1e3)
    ctx = Context(cfg, d.vehicle)
    a_state = b_state = None
    a_rows, b_rows, checked = [], [], set()
    for k, r in enumerate(drive_inputs(d)):
        a_state, ea = step_reference(ctx, a_state, Sample(*r), seed=3)
        b_state, eb = filter_step(ctx, b_state, Sample(*r), seed=3)
        a_rows.append(ea)
        b_rows.append(eb)
        since = b_state.lin.since_refactor
        if k > J and since in (0, la.FOLD_ROWS + 1, J - 1):
            lin = copy_state(b_state).lin
            B = la.information(lin) - (1.0 - lin.c) * np.eye(lin.sigma.shape[-1])
            P = np.linalg.inv(B)
            np.testing.assert_allclose(la.inverse(lin), P, rtol=1e-9, atol=1e-12 * np.abs(P).max())
            checked.add(since)
    a, b = pd.DataFrame(a_rows), pd.DataFrame(b_rows)
    assert checked == {0, la.FOLD_ROWS + 1, J - 1}
    assert len(a) // J >= 3 and a["resampled"].sum() > 5  # three refactorisations at least
    pd.testing.assert_frame_equal(a, b, check_exact=False, rtol=1e-7, atol=1e-8)
    np.testing.assert_allclose(la.information(b_state.lin), la.information(a_state.lin), rtol=1e-8)


def test_refactorisation_refuses_a_matrix_that_is_not_positive_definite():
    st = la.init("exact", 3, 2, 5, history=4)
    st.sigma[1, 0] = -2.0 * np.eye(5)  # Sigma + c0 I indefinite in one slot
    with pytest.raises(ValueError, match="not positive definite"):
        la.refactor(st, 1.0)


@pytest.mark.parametrize("seed", range(5))
def test_take_rows_equals_fancy_indexing(seed):
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((9, 2, 3, 4))
    for idx in (np.sort(rng.integers(0, 9, 9)), rng.integers(0, 9, 9), np.arange(9)):
        expect = a[idx]
        got = la.take_rows(a.copy(), idx)
        np.testing.assert_array_equal(got, expect)


@pytest.mark.parametrize("seed", range(5))
def test_slot_plan_updates_in_place_only_after_the_copies_have_read(seed):
    from roadgrip.estimators.gpssm.kernel_ops import slot_plan

    rng = np.random.default_rng(seed)
    N = 12
    for panc in (np.sort(rng.integers(0, N, N)), rng.permutation(N)[rng.integers(0, N, N)], rng.permutation(N)):
        pdst, order = slot_plan(panc.astype(np.int64))
        assert sorted(pdst) == list(range(N)) and sorted(order) == list(range(N))
        # replay the step on labelled slots: every particle must read its ancestor's content
        slots = np.arange(N) * 10
        got = np.empty(N, np.int64)
        for n in order:
            got[n] = slots[panc[n]]
            slots[pdst[n]] = -1 - n  # overwritten with the particle's own update
        np.testing.assert_array_equal(got, panc * 10)
        assert np.array_equal(np.sort(slots), np.sort(-1 - np.arange(N)))
        # the first reader of a slot keeps it (in place), the others go to unread slots
        for n in range(N):
            if n == np.flatnonzero(panc == panc[n])[0]:
                assert pdst[n] == panc[n]
            else:
                assert pdst[n] not in set(panc)


def test_resampling_keeps_statistics_attached_to_particles(snow20):
    d = snow20.slice_time(0.0, 3.0)
    cfg = _cfg(d, n=10, linalg="direct")
    f, _ = _online(cfg, d, seed=2)
    old = copy_state(f.state_)
    idx = np.array([3, 3, 0, 9, 1, 1, 1, 7, 2, 5])
    new = resample(copy_state(old), idx)
    np.testing.assert_array_equal(new.x, old.x[idx])
    np.testing.assert_array_equal(new.mu, old.mu[idx])
    np.testing.assert_array_equal(new.Psi, old.Psi[idx])
    np.testing.assert_array_equal(new.Phi, old.Phi[idx])
    np.testing.assert_array_equal(new.lin.sigma, old.lin.sigma[idx])
    np.testing.assert_allclose(np.exp(new.logw), 0.1)
    # each particle's posterior mean function travels with it
    H_old = la.information(old.lin)
    M_old = np.linalg.solve(H_old, np.swapaxes(old.Psi, -1, -2))
    H_new = la.information(new.lin)
    M_new = np.linalg.solve(H_new, np.swapaxes(new.Psi, -1, -2))
    np.testing.assert_allclose(M_new, M_old[idx], rtol=1e-12)
    with pytest.raises(ValueError, match="resampling indices"):
        resample(old, np.array([0, 1]))


def test_covariances_stay_spd_and_finite_over_a_long_run(snow60):
    cfg = _cfg(snow60, "tensor:5x5", n=16, forgetting=0.99, refactor_every=9)
    table, _ = run_filter(snow60, cfg, seed=4)
    f, curves = _online(cfg, snow60, seed=4, curve_times=(30.0, 60.0))
    assert np.isfinite(table.drop(columns="grip_index").select_dtypes("number").to_numpy()).all()
    st = f.state_
    H = la.information(st.lin)
    np.testing.assert_allclose(H, np.swapaxes(H, -1, -2), atol=1e-9)
    assert np.linalg.eigvalsh(H).min() > 1.0 - 1e-9  # Sigma + I >= I
    # exact mode's inverse still inverts H after thousands of rank-1 updates
    P = la.inverse(st.lin)
    Hb = H - (1.0 - st.lin.c) * np.eye(H.shape[-1])
    np.testing.assert_allclose(P @ Hb, np.broadcast_to(np.eye(H.shape[-1]), H.shape), atol=1e-8)
    Lam = cfg.Lambda0 + st.Phi - st.Psi @ np.linalg.solve(H, np.swapaxes(st.Psi, -1, -2))
    assert np.linalg.eigvalsh(Lam).min() > 0
    for c in curves.values():
        assert np.isfinite(c.mean).all() and (c.lower <= c.mean + 1e-12).all()
        assert (c.mean <= c.upper + 1e-12).all()


def _straight_drive(n=400, seed=0):
    # straight ahead at constant speed: steer 0, the IMU reads noise only
    rng = np.random.default_rng(seed)
    df = pd.DataFrame({
        "t": np.arange(n) * 0.04, "ay": 0.05 * rng.standard_normal(n),
        "yaw_rate": 0.002 * rng.standard_normal(n), "steer": np.zeros(n), "vx": np.full(n, 20.0),
    })
    return Drive.from_frame(df, PRESETS["sedan"], source="straight")


def test_straight_drive_leaves_the_prior_and_says_so():
    d = _straight_drive()
    res = run(d, GPSSMConfig(particles=30), seed=0)
    t = res.table
    assert not t["excited"].any()
    assert not t["peak_observed_front"].any() and not t["peak_observed_rear"].any()
    assert "no excitation" in res.meta["diagnostics"]["information"]
    # the peak is reported as a lower bound only: nothing beyond zero slip was demonstrated
    assert t["mu_front"].iloc[-1] < 0.05
    # and nothing bounds it from above but the physical limit
    assert (t["mu_front_upper"] == GPSSMConfig.peak_max).all() and (t["mu_rear_upper"] == 2.0).all()
    # the paper's setting (tensor basis, fixed accelerometer gain) leaves the prior mean;
    # with the learned gain (the default) the mean stays well inside the prior band too
    alpha = np.radians(np.r_[-12.0:-5.0:1.0, 6.0:13.0:1.0])
    for gain_sigma, tol in ((0.0, 0.05), (0.1, 0.1)):
        f, _ = _online(GPSSMConfig(basis="tensor:10x10", particles=30, ay_gain_sigma=gain_sigma), d)
        c = f.curves(alpha)
        np.testing.assert_allclose(c.mean, c.prior, atol=tol)
        assert (c.upper - c.lower).min() > 0.4  # as wide as the prior band


def test_learns_the_snow_curve_where_the_data_went(snow60):
    cfg = _cfg(snow60, "separable-odd:14", n=80)
    table, curves = run_filter(snow60, cfg, seed=1, curve_times=(60.0,),
                               curve_alpha=np.radians(np.linspace(-15, 15, 121)))
    acc = curve_accuracy(curves[60.0], snow60, min_visits=20)
    for axle in ("front", "rear"):
        assert acc[axle]["bins"] >= 5
        assert acc[axle]["mae"] < 0.04, acc
        assert acc[axle]["coverage"] >= 0.7, acc
    # the prior (peak 0.05) was left far behind; the peak estimate sits near the truth 0.3
    assert abs(table["mu_front"].iloc[-1] - 0.3) < 0.06


def test_upsampling_keeps_recorded_rows_and_interpolates():
    from roadgrip.estimators.gpssm import upsample_inputs

    t = np.arange(5) * 0.1
    data = np.column_stack([t, 2 * t, -t, np.zeros(5), np.full(5, 3.0)])
    out, keep, k = upsample_inputs(data, 0.04)
    assert k == 3 and len(out) == 13 and keep.sum() == 5
    np.testing.assert_allclose(out[keep], data)
    np.testing.assert_allclose(out[:, 1], 2 * out[:, 0])
    same, keep1, k1 = upsample_inputs(data, 0.1)
    assert k1 == 1 and same is data and keep1.all()


def test_bad_inputs_raise_clear_errors(snow20):
    ctx = Context(_cfg(snow20), snow20.vehicle)
    s0 = Sample(0.0, 0.0, 0.0, 0.0, 10.0)
    with pytest.raises(ValueError, match="non-finite"):
        filter_step(ctx, None, s0._replace(ay=math.nan))
    st, _ = filter_step(ctx, None, s0)
    with pytest.raises(ValueError, match="increasing time"):
        filter_step(ctx, st, s0)
    with pytest.raises(ValueError, match="forgetting"):
        GPSSMConfig(forgetting=1.5)
    with pytest.raises(ValueError, match="nu0"):
        GPSSMConfig(nu0=2.0)
    with pytest.raises(ValueError, match="basis"):
        GPSSMConfig(basis="radial:5")
    with pytest.raises(ValueError, match="curve_times"):
        GPSSMConfig(curve_times=(-1.0,))


def test_config_default_is_the_command_default_and_run_leaves_it_alone(snow20):
    assert GPSSMConfig().basis.label() == "separable-odd:20"
    assert GPSSMConfig.from_options({"basis": "separable-odd:20"}) == GPSSMConfig()
    # 6 Hz data: four sub-steps per sample, the noise widened by sqrt(3) for the run only
    d = snow20.slice_time(0.0, 3.0)
    slow = Drive.from_frame(d.data.iloc[::4].reset_index(drop=True), d.vehicle, source="10 Hz")
    cfg = _cfg(slow, "separable:5", n=12)
    res = run(slow, cfg, seed=0)
    assert len(res.table) == slow.n and cfg == _cfg(slow, "separable:5", n=12)
    assert cfg.sigma_ay == 0.15 and res.meta["config"]["sigma_ay"] == 0.15


def test_run_returns_estimates_curves_and_plot(snow20, tmp_path):
    from roadgrip.estimators.base import EstimateResult
    from roadgrip.plots.gpssm import plot_result

    res = run(snow20, GPSSMConfig(particles=20, basis="separable:8", curve_times=(4.0, 10.0)), seed=0)
    res.curves.to_parquet(tmp_path / "c.parquet", index=False)
    plot_result(snow20, res, tmp_path / "f.png")
    res.to_parquet(tmp_path / "e.parquet")
    back = EstimateResult.read_parquet(tmp_path / "e.parquet")
    for col in ("t", "mu_front", "mu_rear", "mu_front_lower", "mu_front_upper", "mu_rear_lower",
                "mu_rear_upper", "peak_observed_front", "peak_observed_rear", "vy", "vy_std", "ess",
                "excited"):
        assert col in back.table.columns
    assert len(back.table) == snow20.n
    assert back.meta["diagnostics"]["ess_min"] > 0
    c = pd.read_parquet(tmp_path / "c.parquet")
    assert set(c["axle"]) == {"front", "rear"} and sorted(set(c["t"])) == [4.0, 10.0]
    for col in ("alpha", "mu_mean", "mu_lower", "mu_upper", "mu_true"):
        assert c[col].notna().all()
    true = snow20.true_tire("front").mu(c.loc[c.axle == "front", "alpha"])
    np.testing.assert_allclose(c.loc[c.axle == "front", "mu_true"], true)
    assert (tmp_path / "f.png").stat().st_size > 10000


def test_sideslip_bound_holds_where_the_unbounded_estimate_exceeds_it():
    # a steady turn at 2 g: the unbounded filter explains it by a sideslip of about 2 deg
    n = 250
    df = pd.DataFrame({
        "t": np.arange(n) * 0.04, "ay": np.full(n, 2.0 * 9.81), "yaw_rate": np.full(n, 1.0),
        "steer": np.full(n, 0.05), "vx": np.full(n, 19.6),
    })
    d = Drive.from_frame(df, PRESETS["sedan"], source="over the limit")
    free, _ = run_filter(d, _cfg(d), seed=0)
    beta = math.radians(1.0)
    ctx = Context(_cfg(d, max_sideslip=beta), d.vehicle)
    state = None
    for s in _samples(d):
        state, est = filter_step(ctx, state, s, 0)
        assert np.all(np.abs(state.x[:, 0]) <= math.tan(beta) * s.vx + 1e-12)
        assert np.isfinite(est.vy) and np.isfinite(est.mu_front)
    assert free["vy"].abs().max() > 1.5 * math.tan(beta) * 19.6  # the bound is active
    with pytest.raises(ValueError, match="max_sideslip"):
        _cfg(d, max_sideslip=2.0)


def test_pose_lateral_velocity_is_measured_and_taken_by_every_particle(snow20):
    from roadgrip.estimators.gpssm import drive_vy

    d = snow20.slice_time(0.0, 8.0)
    vy = drive_vy(d)
    # the simulated pose is exact: its derivative is the lateral velocity to discretisation
    assert np.sqrt(np.mean((vy - d.col("vy_true")) ** 2)) < 0.005
    cfg = _cfg(d, "separable-odd:6", n=24, vy_source="pose", ay_source="kinematic")
    table, _ = run_filter(d, cfg, seed=1)
    moving = d.col("vx") >= cfg.min_speed
    np.testing.assert_allclose(table["vy"].to_numpy()[moving], vy[moving], atol=1e-12)
    # the band is the measurement's own error, slip_sigma |vx| (the particles agree)
    vx = drive_inputs(d, cfg.vx_source, "pose", "kinematic")[:, 4]  # the filter's speed (wheels)
    np.testing.assert_allclose(table["vy_std"].to_numpy()[moving], cfg.slip_sigma * vx[moving], rtol=1e-9)
    # the kinematic lateral acceleration r vx + dvy/dt is the measured one here
    ay = drive_inputs(d, "auto", "pose", "kinematic")[:, 1]
    assert np.sqrt(np.mean((ay - d.col("ay")) ** 2)) < 0.2
    with pytest.raises(ValueError, match="vy_source"):
        _cfg(d, ay_source="kinematic")
    with pytest.raises(ValueError, match="vy_source"):
        _cfg(d, vy_source="gps")


def test_command_chooses_the_linear_algebra(snow20, tmp_path):
    from typer.testing import CliRunner

    from roadgrip.cli import app

    src = tmp_path / "drive.parquet"
    snow20.slice_time(0.0, 3.0).to_parquet(src)
    runner = CliRunner()
    out = tmp_path / "est.parquet"
    base = ["estimate", str(src), "--method", "gpssm", "-o", str(out), "--particles", "20"]
    r = runner.invoke(app, [*base, "--linalg", "fast"])
    assert r.exit_code == 0, r.output
    assert "fast" in r.output and len(pd.read_parquet(out)) == snow20.slice_time(0.0, 3.0).n
    r = runner.invoke(app, [*base, "--linalg", "quick"])
    assert r.exit_code != 0 and "linalg" in r.output + str(r.exception)
    r = runner.invoke(app, ["estimate", str(src), "--method", "brls", "-o", str(out), "--linalg", "fast"])
    assert r.exit_code != 0 and "linalg" in r.output + str(r.exception)


@pytest.mark.parametrize("basis", ["tensor:4x4", "separable-odd:6"])
def test_reading_curves_mid_run_does_not_change_the_filter(snow20, basis):
    d = snow20.slice_time(0.0, 10.0)
    cfg = _cfg(d, basis, n=24)
    plain, _ = run_filter(d, cfg, seed=4)
    with_curves, curves = run_filter(d, cfg, seed=4, curve_times=(2.0, 3.0, 5.0, 7.5))
    assert len(curves) == 4
    pd.testing.assert_frame_equal(plain, with_curves, check_exact=True)


def test_writing_the_pending_updates_out_mid_run_does_not_change_the_filter(snow20):
    d = snow20.slice_time(0.0, 8.0)
    cfg = _cfg(d, "tensor:4x4", n=24)
    plain, _ = run_filter(d, cfg, seed=6)
    ctx = Context(cfg, d.vehicle)
    state, rows = None, []
    for i, s in enumerate(_samples(d)):
        state, est = filter_step(ctx, state, s, seed=6)
        rows.append(est._asdict() | {"yaw_rate_est": est.yaw_rate})
        if i in (50, 51, 120):
            la.settle(state.lin)  # ancestors' matrices, pending rank-1 terms, carried P_B f
            assert np.array_equal(state.lin.panc, np.arange(cfg.particles))
    stepped = pd.DataFrame(rows)
    for col in stepped.columns.drop("yaw_rate"):
        np.testing.assert_allclose(plain[col].to_numpy(float), stepped[col].to_numpy(float), rtol=1e-9, atol=1e-12)


def test_step_and_run_hold_blas_to_one_thread(snow20, monkeypatch, two_blas_threads, blas_threads):
    """The kernel and the curves see one BLAS thread however the filter is driven, and the
    caller's setting is back afterwards."""
    from roadgrip.estimators.gpssm import block

    d = snow20.slice_time(0.0, 1.0)
    cfg = _cfg(d)
    seen = []
    real = block.run_steps

    def spy(*args):
        seen.append((max(blas_threads().values()), len(args[4].t)))
        return real(*args)

    monkeypatch.setattr(block, "run_steps", spy)
    run_filter(d.slice_time(0.0, 0.3), cfg, seed=0)
    f = GPSSM(cfg, d.vehicle, seed=0)
    f.step(_samples(d)[0])
    filter_step(Context(cfg, d.vehicle), None, _samples(d)[0])
    assert blas_threads() == two_blas_threads
    # the run in one compiled call, then two single steps
    assert seen == [(1, len(_samples(d.slice_time(0.0, 0.3)))), (1, 1), (1, 1)]


@pytest.mark.parametrize("dof", [3.0, 40.0, 800.0])
def test_mixture_quantile_against_root_finding(dof):
    """The curve band's quantiles of a mixture of t's (normal above 500 degrees of freedom)
    against scipy's root finder on the mixture's CDF, for smooth mixtures and for mixtures of
    narrow components whose CDF is a staircase."""
    from scipy import optimize, stats

    from roadgrip.estimators.gpssm.posterior import mixture_quantile

    rng = np.random.default_rng(7)
    dist = stats.norm if dof > 500 else stats.t(dof)
    for width in (0.05, 1e-4):
        k, n = 60, 9
        loc = rng.normal(0.3, 0.1, (k, n))
        scale = width * rng.uniform(0.5, 2.0, (k, n))
        weight = rng.dirichlet(np.ones(k))
        for p in (0.025, 0.5, 0.975):
            got = mixture_quantile(loc, scale, weight, p, dof)
            for j in range(n):
                m, sd = loc[:, j], scale[:, j]
                ref = optimize.brentq(lambda x, m=m, sd=sd, p=p, wt=weight: wt @ dist.cdf((x - m) / sd) - p,
                                      m.min() - 50 * width, m.max() + 50 * width, xtol=1e-12)
                assert abs(got[j] - ref) <= 1e-7, (width, p, j, got[j], ref)


def test_curve_band_holds_the_slip_scale_where_vy_is_not_measured(snow20):
    """Without a measured lateral velocity the slip angles' scale is not identified
    (GPSSMConfig.slip_scale_sigma): the curve band holds the learned mean curve at
    ``alpha / (1 + s)`` and ``alpha (1 + s)`` where it rises; the particles and the mean
    are those of ``s = 0``, whose band holds neither. A measured ``vy`` fixes the scale."""
    d = snow20.slice_time(0.0, 10.0)
    a = np.radians(np.linspace(0.4, 1.6, 7))  # the rising part of the snow curve
    cfg = _cfg(d, "separable-odd:8")
    assert cfg.slip_scale_sigma == 0.5
    k = 1.0 + cfg.slip_scale_sigma
    f, _ = _online(cfg, d)
    f0, _ = _online(_cfg(d, "separable-odd:8", slip_scale_sigma=0.0), d)
    c, c0 = f.curves(a), f0.curves(a)
    np.testing.assert_array_equal(c.mean, c0.mean)
    below, above = f.curves(a / k).mean, f.curves(a * k).mean
    assert (np.diff(c.mean, axis=1) > 0).all()
    assert (c.lower <= below).all() and (c.upper >= above).all()
    assert not ((c0.lower <= below).all() and (c0.upper >= above).all())
    assert ((c.upper - c.lower) > (c0.upper - c0.lower)).all()
    # with the lateral velocity measured the scale is known: slip_scale_sigma is not used
    rows = drive_inputs(d)
    rows[:, 5] = d.col("vy_true")
    bands = []
    for s in (0.0, 0.5):
        g = GPSSM(_cfg(d, "separable-odd:8", vy_source="pose", slip_scale_sigma=s), d.vehicle, seed=0)
        for r in rows:
            g.step(Sample(*r))
        cp = g.curves(a)
        bands.append(np.stack([cp.lower, cp.upper]))
    np.testing.assert_array_equal(bands[0], bands[1])


def test_curve_is_held_flat_beyond_the_slip_limit(snow20):
    d = snow20.slice_time(0.0, 4.0)
    # (the spread over the slip angles' scale, slip_scale_sigma, reaches a multiple of
    # alpha: the band past the limit is flat from twice it; the test above holds that spread)
    cfg = _cfg(d, "separable-odd:8", slip_scale_sigma=0.0)
    b = cfg.basis
    assert cfg.alpha_limit == pytest.approx(b.L - 2.0 * b.ell)  # 26 deg
    f, _ = _online(cfg, d)
    lim = cfg.alpha_limit
    a = np.array([0.5 * lim, lim, lim + math.radians(2.0), b.L, 1.5 * b.L])
    c = f.curves(np.concatenate([a, -a]))
    for ax in range(2):
        for arr, first in ((c.mean, 1), (c.prior, 1), (c.lower, 2), (c.upper, 2)):
            # the band also spreads over the slip-angle uncertainty (a fraction of a
            # degree here), so it is flat from a little past the limit
            for side in (0, 5):
                np.testing.assert_allclose(arr[ax, side + first:side + 5], arr[ax, side + first],
                                           rtol=0, atol=1e-12)
        # past the limit the curve keeps the uncertainty it has there, not the vanishing
        # variance of the basis at its boundary
        assert c.upper[ax, 4] - c.lower[ax, 4] > 4.0 * cfg.curve_sigma_floor
        assert abs(c.mean[ax, 0] - c.mean[ax, 1]) > 1e-4
    with pytest.raises(ValueError, match="slip_limit"):
        _cfg(d, slip_limit=1.1 * b.L)
    assert _cfg(d, slip_limit=0.2).alpha_limit == 0.2


@pytest.mark.slow
def test_slip_past_the_basis_domain_does_not_run_away():
    # snow-slalom seed 2: at 24 s the driver steers 34 deg and the true front slip reaches
    # 32 deg, past the basis domain (L = 30 deg). Holding the curve flat past L - 2 ell
    # keeps the lateral velocity; with the limit at L it runs away (the friction there is
    # the prior's, about 0.04, with nothing left to sample)
    d = simulate_scenario("snow-slalom", seed=2).slice_time(0.0, 30.0)
    assert np.abs(d.col("alpha_f_true")).max() > math.radians(31.0)
    rms, flagged = {}, {}
    for name, limit in (("default", None), ("at L", math.radians(30.0))):
        # the paper's model (fixed accelerometer gain): with the learned gain this basis
        # loses the lateral velocity here for another reason (0.60 / 0.70 m/s, docs/gpssm.md)
        cfg = GPSSMConfig(basis="tensor-odd:10x10", particles=200, slip_limit=limit, ay_gain_sigma=0.0)
        table, _ = run_filter(d, cfg, seed=2)
        err = table["vy"].to_numpy() - d.col("vy_true")
        t = table["t"].to_numpy()
        rms[name] = [float(np.sqrt(np.mean(err[t >= t0] ** 2))) for t0 in (20.0, 27.0)]
        flagged[name] = table["diverged"].to_numpy()
    assert rms["default"][0] < 0.5 and rms["default"][1] < 0.1, rms
    # the first pass of the front slip past 20 deg, where this basis has learned nothing,
    # leaves the yaw rate unexplained for a second on average (mean normalised innovation
    # about 200) with vy 0.6 m/s off: flagged for 3 s (74 of 750 samples from 22.8 s), and
    # re-initialised, after which vy is back on the truth (the rms above)
    assert flagged["default"].mean() < 0.12, flagged["default"].mean()
    # with the limit at L the lateral velocity ran away (to 5 m/s, 0.4 m/s rms from 20 s)
    # before the guard's per-sample test noticed; the windowed test now flags and
    # re-initialises it within the same second as the default's (11 % of the samples
    # flagged, 0.25 m/s rms from 20 s), after which the filter is back on the truth
    assert flagged["at L"].any(), rms
    assert rms["at L"][1] < 0.1, rms


def test_unobserved_peak_is_bounded_from_below_only():
    # dry asphalt (peak 1.0) driven gently: the peak is not reached, the learned curve
    # past the visited range is the weak prior's, and a band taken from it put the peak
    # below 0.82-0.91. The band of an unobserved peak is [lower bound, peak_max]
    d = simulate_scenario("dry-gravel-dry", seed=0).slice_time(0.0, 40.0)
    true_peak = d.true_tire("front", surface="dry_asphalt").peak()[1]
    cfg = _cfg(d, "separable-odd:12", n=60, peak_max=1.6)
    t, _ = run_filter(d, cfg, seed=0)
    for axle in ("front", "rear"):
        unobs = t[~t[f"peak_observed_{axle}"]]
        assert len(unobs) > 0.5 * len(t)
        assert (unobs[f"mu_{axle}_upper"] == 1.6).all()
        assert (unobs[f"mu_{axle}_lower"] <= true_peak).all()
        late = unobs[unobs["t"] > 20.0]
        assert late[f"mu_{axle}"].max() > 0.2  # a lower bound that says something
    with pytest.raises(ValueError, match="peak_max"):
        _cfg(d, peak_max=0.0)


def test_protocol_step_leaves_its_input_state_alone_and_skips_sub_steps(snow20):
    from roadgrip.estimators.gpssm import ESTIMATOR

    d = snow20.slice_time(0.0, 1.0)
    cfg = _cfg(d, "separable:5", n=12, max_dt=0.02)  # two sub-steps per 25 Hz sample
    prepared = ESTIMATOR.prepare(d, cfg)
    assert prepared.info.derived["substeps"] == 2 and len(prepared.samples) == 2 * d.n - 1
    state = ESTIMATOR.init(prepared.info, cfg, 0)
    rows = []
    for sample in prepared.samples:
        before = None if state.state is None else copy_state(state.state)
        new, row = ESTIMATOR.step(state, sample)
        if before is not None:
            np.testing.assert_array_equal(state.state.x, before.x)
            np.testing.assert_array_equal(state.state.Psi, before.Psi)
            assert state.state.k == before.k
        assert (row is None) == (not sample.recorded)
        rows.append(row)
        state = new
    assert sum(r is not None for r in rows) == d.n


def test_progress_counts_every_output_row(snow20):
    d = snow20.slice_time(0.0, 4.3)
    calls = []
    res = run(d, _cfg(d, "separable:5", n=12), seed=0, progress=calls.append)
    assert sum(calls) == len(res.table) == d.n and max(calls) == 50



@pytest.mark.parametrize("linalg", ["exact", "fast"])
def test_a_run_in_blocks_equals_stepping_bit_for_bit(snow20, linalg):
    # run_filter hands the compiled step blocks of samples (split where curves are read
    # and where progress is reported); stepping hands it one sample at a time, through
    # states copied in between (the protocol's step): the same numbers, to the last bit,
    # across refactorisations (every 80 steps) and resampling
    d = snow20.slice_time(0.0, 9.0)
    cfg = _cfg(d, "separable-odd:6", n=24, linalg=linalg)
    calls = []
    table, _ = run_filter(d, cfg, seed=2, curve_times=(3.0,), progress=calls.append)
    from roadgrip.estimators.gpssm import ESTIMATOR

    prepared = ESTIMATOR.prepare(d, cfg)
    fs = ESTIMATOR.init(prepared.info, cfg, 2)
    rows = []
    for s in prepared.samples:
        fs, row = ESTIMATOR.step(fs, s)
        rows.append(row)
    stepped = pd.DataFrame(rows)
    assert len(calls) > 2 and table["resampled"].sum() > 5
    for col in stepped.columns:
        np.testing.assert_array_equal(table[col].to_numpy(), stepped[col].to_numpy(), err_msg=col)


def test_run_many_equals_runs_one_after_another(snow20):
    from roadgrip.estimators.gpssm import run_many

    drives = [snow20.slice_time(0.0, 3.0), snow20.slice_time(5.0, 8.0), snow20.slice_time(10.0, 12.0)]
    cfg = _cfg(drives[0], "separable-odd:6", n=24, curve_times=(1.0,))
    seeds = [0, 5, 7]
    together = run_many(drives, cfg, seeds, workers=2)
    for d, s, res in zip(drives, seeds, together, strict=True):
        alone = run(d, cfg, seed=s)
        pd.testing.assert_frame_equal(res.table, alone.table, check_exact=True)
        pd.testing.assert_frame_equal(res.curves, alone.curves, check_exact=True)
        assert res.meta["seed"] == s
    with pytest.raises(ValueError, match="one seed per drive"):
        run_many(drives, cfg, [0, 1])
