"""Named scenarios: physical bounds, excitation, reproducibility, truth, files and CLI."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.optimize import brentq

from roadgrip.constants import GRAVITY
from roadgrip.sim import SCENARIOS, simulate_scenario
from roadgrip.sim.friction import Patch, PatchFriction, mu_at
from roadgrip.tire import model_from_dict
from roadgrip.vehicle.lateral import lateral_measurement

NAMES = [name for name, sc in SCENARIOS.items() if sc.build is not None]  # the single-track engines


@pytest.fixture(scope="module")
def drives():
    """Every scenario at its full length, seed 0 (all of them take a few seconds)."""
    return {name: simulate_scenario(name, seed=0) for name in NAMES}


def _slip80(model) -> float:
    s_peak, mu_peak = model.peak()
    return brentq(lambda s: float(model.mu(s)) - 0.8 * mu_peak, 0.0, s_peak)


def _front_nonlinear_fraction(drive) -> float:
    df = drive.data
    beyond = np.zeros(len(df), bool)
    for label in df["surface"].unique():
        m = (df["surface"] == label).to_numpy()
        a80 = _slip80(drive.true_tire("front", "lateral", label))
        beyond[m] = np.abs(df["alpha_f_true"].to_numpy()[m]) > a80
    return float(beyond.mean())


def test_registry_and_unknown_name():
    assert set(NAMES) == {"snow-slalom", "dry-gravel-dry", "f1tenth-patches", "straight-cruise", "sine-burst"}
    assert set(SCENARIOS) == {*NAMES, "figure-eight", "vehicle-id"}
    for name, sc in SCENARIOS.items():
        assert sc.name == name and sc.duration > 0 and sc.output_rate > 0 and sc.description
        with pytest.raises(AttributeError):
            sc.duration = 1.0  # frozen
    with pytest.raises(ValueError, match=r"snow-slalom.*dry-gravel-dry"):
        simulate_scenario("snow-slalon")


@pytest.mark.parametrize("name", NAMES)
def test_length_rate_vehicle_and_columns(drives, name):
    d, sc = drives[name], SCENARIOS[name]
    assert d.duration == pytest.approx(sc.duration)
    np.testing.assert_allclose(np.diff(d.t), 1.0 / sc.output_rate, rtol=1e-9)
    assert d.vehicle.name == sc.vehicle
    assert d.has_wheel_speeds and d.has_pose
    assert d.meta.truth["scenario"] == name and d.meta.truth["seed"] == 0
    assert d.meta.truth["internal_rate"] >= 500.0
    num = d.data.drop(columns=["surface"])
    assert np.isfinite(num.to_numpy(float)).all()


@pytest.mark.parametrize("name", NAMES)
def test_axle_lateral_force_within_friction_limit(drives, name):
    df = drives[name].data
    surfaces = drives[name].meta.truth["surfaces"]
    for axle in ("f", "r"):
        key = "front" if axle == "f" else "rear"
        peak = df["surface"].map(lambda s, k=key: model_from_dict(surfaces[s][k]).peak()[1]).to_numpy()
        fy = np.abs(df[f"Fy{axle}_true"].to_numpy())
        assert np.all(fy <= 1.01 * peak * df[f"Fz{axle}_true"].to_numpy())
        assert np.all(fy <= 1.01 * df["mu_true"] * df[f"Fz{axle}_true"])


@pytest.mark.parametrize("name", NAMES)
def test_lateral_force_follows_true_curve_when_not_braking(drives, name):
    d = drives[name]
    df = d.data
    free = (np.abs(df["Fxf_true"]) < 1e-3 * df["Fzf_true"]).to_numpy()
    for label in df["surface"].unique():
        m = free & (df["surface"] == label).to_numpy()
        if m.sum() < 10:
            continue
        mu = d.true_tire("front", "lateral", label).mu(df["alpha_f_true"].to_numpy()[m])
        np.testing.assert_allclose(df["Fyf_true"].to_numpy()[m] / df["Fzf_true"].to_numpy()[m], mu,
                                   atol=2e-3)


@pytest.mark.parametrize("name", NAMES)
def test_measurement_noise_matches_recorded_model(drives, name):
    d = drives[name]
    sens = d.meta.truth["sensors"]
    for col in ("yaw_rate", "vx"):
        err = d.data[col] - d.data[f"{col}_true"]
        assert err.std() == pytest.approx(sens[col]["noise_std"], rel=0.1)
        assert abs(err.mean() - sens[col]["bias"]) < 4 * sens[col]["noise_std"] / np.sqrt(len(err))


def test_same_seed_same_drive_other_seed_other_drive():
    for name in NAMES:
        a = simulate_scenario(name, seed=3, duration=20.0)
        b = simulate_scenario(name, seed=3, duration=20.0)
        c = simulate_scenario(name, seed=4, duration=20.0)
        pd.testing.assert_frame_equal(a.data, b.data)
        assert a.meta == b.meta
        assert not np.allclose(a.data["yaw_rate"], c.data["yaw_rate"])


def test_duration_override_is_a_prefix_of_the_full_drive(drives):
    short = simulate_scenario("snow-slalom", seed=0, duration=30.0)
    full = drives["snow-slalom"].data
    # the random manoeuvre is drawn over the run's own horizon, so only shapes agree
    assert short.duration == pytest.approx(30.0) and len(short.data) == 30 * 25 + 1
    assert set(short.data.columns) == set(full.columns)


# --- snow-slalom ------------------------------------------------------------------------
def test_snow_slalom_excites_the_nonlinear_region(drives):
    d = drives["snow-slalom"]
    assert d.meta.truth["model"] == "lateral"
    assert d.true_tire("front").peak()[1] == pytest.approx(0.3)
    assert _front_nonlinear_fraction(d) >= 0.15
    af = np.abs(d.data["alpha_f_true"])
    a80 = _slip80(d.true_tire("front"))
    assert (af < 0.5 * a80).mean() >= 0.2  # and covers small slip angles
    assert (af > 0.25).mean() < 0.01  # mostly below 0.25 rad


@pytest.mark.parametrize("seed", [1, 2])
def test_snow_slalom_excitation_holds_for_other_seeds(seed):
    assert _front_nonlinear_fraction(simulate_scenario("snow-slalom", seed=seed)) >= 0.15


def test_snow_slalom_matches_paper_000_measurement_model(drives):
    """ay = h + D mu (paper 000, eq. 8) with the true frictions, up to the sensor noise."""
    d = drives["snow-slalom"]
    df = d.data
    v = d.vehicle
    x = np.stack([df["vy_true"], df["yaw_rate_true"]], -1)
    u = np.stack([df["steer_true"], df["vx_true"]], -1)
    h, D = lateral_measurement(x, u, v)
    mu = np.stack([df["Fyf_true"] / df["Fzf_true"], df["Fyr_true"] / df["Fzr_true"]], -1)
    ay_model = h[:, 0] + np.einsum("nij,nj->ni", D, mu)[:, 0]
    res = df["ay"] - ay_model
    assert res.std() == pytest.approx(d.meta.truth["sensors"]["ay"]["noise_std"], rel=0.1)
    # free rolling: the wheel speeds carry the speed and the yaw rate
    w = (df["omega_rl"] + df["omega_rr"]) / 2 * v.wheel_radius
    assert np.abs(w - df["vx_true"]).mean() < 0.05


# --- straight-cruise --------------------------------------------------------------------
def test_straight_cruise_barely_excites(drives):
    d = drives["straight-cruise"]
    assert _front_nonlinear_fraction(d) < 0.02
    assert np.abs(d.data["ay"]).max() < 1.0 and np.abs(d.data["vx_true"] - 20.0).max() < 0.2


# --- dry-gravel-dry ---------------------------------------------------------------------
def test_dry_gravel_dry_changes_and_phases(drives):
    d = drives["dry-gravel-dry"]
    df = d.data
    tr = d.meta.truth
    assert [(c["t"], c["from"], c["to"]) for c in tr["changes"]] == [
        (60.0, "dry_asphalt", "gravel"), (120.0, "gravel", "dry_asphalt")]
    t = d.t
    expect = np.where((t >= 60) & (t < 120), "gravel", "dry_asphalt")
    np.testing.assert_array_equal(df["surface"].to_numpy(), expect)
    np.testing.assert_allclose(df["mu_true"], np.where(expect == "gravel", 0.6, 1.0))
    np.testing.assert_allclose(df["mu_true"], mu_at(tr["friction_field"], t, 0.0, 0.0))
    ax, ay = df["ax_true"] if "ax_true" in df else df["ax"], df["ay"]
    for t0 in (0.0, 60.0, 120.0):
        seg = (t >= t0) & (t < t0 + 60.0)
        assert (ax[seg] > 1.5).sum() > 100  # acceleration
        assert (ax[seg] < -2.5).sum() > 50  # braking
        assert (np.abs(ay[seg]) > 3.0).sum() > 100  # cornering
        quiet = (np.abs(ax) < 0.3) & (np.abs(ay) < 0.3)
        assert quiet[seg].mean() > 0.3  # quiet stretches
    kinds = {e["kind"] for e in tr["excited_intervals"]}
    assert kinds == {"acceleration", "braking", "cornering"}
    # longitudinal slip is excited on gravel: wheel-speed slip of the driven axle
    gravel = (t >= 60) & (t < 120)
    assert np.abs(df["kappa_fl_true"][gravel]).max() > 0.03


# --- f1tenth-patches --------------------------------------------------------------------
def test_f1tenth_laps_patches_and_mu_at_position(drives):
    d = drives["f1tenth-patches"]
    df = d.data
    laps = (df["psi_true"].iloc[-1] - df["psi_true"].iloc[0]) / (2 * np.pi)
    assert laps >= 3
    ay = np.abs(df["Fyf_true"] + df["Fyr_true"]) / d.vehicle.mass / GRAVITY
    assert 0.5 <= ay.max() <= 0.9
    ff = d.meta.truth["friction_field"]
    field = PatchFriction(ff["base"], tuple(
        Patch(p["x0"], p["x1"], p["y0"], p["y1"], p["surface"]) for p in ff["patches"]))
    labels = np.array(field.labels)[field.labels_at(d.t, df["x_true"], df["y_true"])]
    np.testing.assert_array_equal(df["surface"].to_numpy(), labels)
    np.testing.assert_allclose(df["mu_true"], [ff["mu"][s] for s in labels])
    np.testing.assert_allclose(df["mu_true"], mu_at(ff, d.t, df["x_true"], df["y_true"]))
    assert set(labels) == {"track", "low_grip", "high_grip"}
    assert (df["x"] - df["x_true"]).std() == pytest.approx(0.03, rel=0.15)
    # the corners on low grip saturate the front axle
    low = df["surface"] == "low_grip"
    assert (np.abs(df["Fyf_true"][low]) > 0.9 * 0.45 * df["Fzf_true"][low]).any()


# --- files and CLI ----------------------------------------------------------------------
@pytest.mark.parametrize("name", NAMES)
def test_parquet_round_trip_is_identical(drives, name, tmp_path):
    d = drives[name]
    path = tmp_path / "d.parquet"
    d.to_parquet(path)
    try:
        from roadgrip.io import read_drive
    except ImportError:  # pragma: no cover - io not installed in this build
        import pyarrow.parquet as pq

        back = pq.read_table(path).to_pandas()
        pd.testing.assert_frame_equal(back, d.data)
        return
    back = read_drive(path)
    pd.testing.assert_frame_equal(back.data, d.data)
    assert back.meta.truth == d.meta.truth
    assert back.true_tire("front").to_dict() == d.true_tire("front").to_dict()


@pytest.mark.parametrize("name", ["snow-slalom", "f1tenth-patches"])
def test_csv_round_trip_is_identical(drives, name, tmp_path):
    io = pytest.importorskip("roadgrip.io")
    d = drives[name]
    path = tmp_path / "d.csv"
    d.to_csv(path)
    back = io.read_drive(path)
    pd.testing.assert_frame_equal(back.data, d.data)
    assert back.meta.truth == d.meta.truth


def test_cli_simulate_and_list(tmp_path):
    from typer.testing import CliRunner

    from roadgrip.cli import app

    out = tmp_path / "s.parquet"
    runner = CliRunner()
    res = runner.invoke(app, ["simulate", "straight-cruise", "-o", str(out), "--seed", "2"])
    assert res.exit_code == 0, res.output
    back = pd.read_parquet(out)
    ref = simulate_scenario("straight-cruise", seed=2)
    np.testing.assert_array_equal(back["yaw_rate"].to_numpy(), ref.data["yaw_rate"].to_numpy())
    res = runner.invoke(app, ["scenarios"])
    assert res.exit_code == 0
    for name in SCENARIOS:
        assert name in res.output


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_other_seeds_stay_finite_and_within_friction(seed):
    for name in NAMES:
        d = simulate_scenario(name, seed=seed)
        df = d.data
        assert np.isfinite(df.drop(columns=["surface"]).to_numpy(float)).all()
        for axle in ("f", "r"):
            assert np.all(np.abs(df[f"Fy{axle}_true"]) <= 1.01 * df["mu_true"] * df[f"Fz{axle}_true"])
        assert np.abs(df["vy_true"]).max() < 0.3 * df["vx_true"].max()  # no spin-out


def test_sine_burst_grows_into_the_front_tires_limit():
    """Four bursts of growing amplitude (SINE_BURSTS): the lateral acceleration peaks grow
    burst by burst to about 0.87 g, and the last burst takes the front slip past the dry
    Magic Formula's peak slip (about 10 deg) while the rear stays below it."""
    import numpy as np

    from roadgrip.sim.scenarios import SINE_BURST_PERIOD, SINE_BURSTS
    from roadgrip.tire import SURFACES

    d = simulate_scenario("sine-burst", seed=0)
    assert d.duration == pytest.approx(30.0, abs=0.05) and d.n == 1501
    ay = np.abs(d.col("ay_true") if d.has("ay_true") else d.col("ay"))
    peaks = [ay[(d.t >= t0) & (d.t <= t0 + 2 * SINE_BURST_PERIOD + 0.3)].max() for t0, _ in SINE_BURSTS]
    assert np.all(np.diff(peaks) > 0)
    assert 0.8 * 9.80665 < peaks[-1] < 0.95 * 9.80665
    peak_slip, _ = SURFACES["dry_asphalt"].lateral.peak()
    assert np.abs(d.col("alpha_f_true")).max() > peak_slip > np.abs(d.col("alpha_r_true")).max()
