"""The multi-body engine against the CommonRoad package it compiles, and its physics."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest
from vehiclemodels.init_mb import init_mb
from vehiclemodels.utils import tire_model
from vehiclemodels.vehicle_dynamics_mb import vehicle_dynamics_mb

from roadgrip.constants import GRAVITY
from roadgrip.signals import level_accelerations
from roadgrip.sim import mb_model
from roadgrip.sim.friction import ConstantFriction
from roadgrip.sim.mb_driver import MBPath, Path
from roadgrip.sim.multibody import simulate_multibody
from roadgrip.sim.scenarios import MB_VEHICLES, SCENARIOS, simulate_scenario
from roadgrip.vehicle.params import PRESETS

S = mb_model.MBState
MB_SCENARIOS = [name for name, sc in SCENARIOS.items() if "multibody" in sc.engines]


def _package_params(vehicle_id: int, mu: float | None):
    """The package's own parameter object with roadgrip's tire changes applied to a copy."""
    p = mb_model.commonroad_parameters(vehicle_id)
    over = dict.fromkeys(("p_hy1", "p_hy3", "p_vy1", "p_vy3"), 0.0)
    if mu is not None:
        over = mb_model.tire_overrides(p, mu)
    return dataclasses.replace(p, tire=dataclasses.replace(p.tire, **over))


def _random_states(vehicle_id: int, n: int, rng) -> np.ndarray:
    """States around a settled car at 5-25 m/s: every state perturbed."""
    p = mb_model.commonroad_parameters(vehicle_id)
    out = []
    for _ in range(n):
        v = rng.uniform(5.0, 25.0)
        x = np.array(init_mb([0.0, 0.0, rng.uniform(-0.1, 0.1), v, rng.uniform(-3, 3),
                              rng.uniform(-0.5, 0.5), rng.uniform(-0.05, 0.05)], p), float)
        scale = np.full(S.SIZE, 0.01)
        scale[[S.X, S.Y]] = 10.0
        scale[[S.OMEGA_LF, S.OMEGA_RF, S.OMEGA_LR, S.OMEGA_RR]] = 0.05 * v / p.R_w
        scale[[S.VY, S.VY_F, S.VY_R]] = 0.5
        scale[[S.Z, S.Z_F, S.Z_R]] = 0.005
        out.append(x + scale * rng.standard_normal(S.SIZE))
    return np.array(out)


@pytest.mark.parametrize("vehicle_id", [1, 3])
@pytest.mark.parametrize("mu", [None, 1.0, 0.3])
def test_compiled_rhs_equals_the_package_function(vehicle_id, mu):
    rng = np.random.default_rng(vehicle_id)
    rhs = mb_model.compiled_rhs().mb
    p_tuple = mb_model.parameter_tuple(vehicle_id, mu)
    p_pkg = _package_params(vehicle_id, mu)
    for x in _random_states(vehicle_id, 40, rng):
        u = rng.uniform([-0.5, -6.0], [0.5, 4.0])
        got = np.array(rhs(x.copy(), u.copy(), p_tuple))
        want = np.array(vehicle_dynamics_mb(list(x), list(u), p_pkg))
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9)


def test_camber_shifts_are_kept_when_asked():
    p = mb_model.parameter_tuple(1, None, camber_shifts=True)
    assert p.tire.p_vy1 == mb_model.commonroad_parameters(1).tire.p_vy1 != 0.0
    assert mb_model.parameter_tuple(1, None).tire.p_vy1 == 0.0


@pytest.mark.parametrize("vehicle_id", [1, 3])
def test_wheel_forces_reproduce_the_package_accelerations(vehicle_id):
    """The per-wheel truth, summed as the package sums it, gives the package's d vx/dt and
    d r/dt: the truth's kinematics, loads and tire calls are the ones inside the model."""
    rng = np.random.default_rng(10 + vehicle_id)
    p = mb_model.parameter_tuple(vehicle_id, 0.6)
    rhs = mb_model.compiled_rhs().mb
    w = np.empty((4, mb_model.WHEEL_SIZE))
    for x in _random_states(vehicle_id, 30, rng):
        u = np.zeros(2)
        f = np.array(rhs(x.copy(), u, p))
        mb_model.wheel_forces(x, p, w)
        fx, fy = w[:, mb_model.WHEEL_FX], w[:, mb_model.WHEEL_FY]
        c, s = np.cos(x[S.STEER]), np.sin(x[S.STEER])
        sum_x = fx[2] + fx[3] + (fx[0] + fx[1]) * c - (fy[0] + fy[1]) * s
        assert f[S.VX] == pytest.approx(sum_x / p.m + x[S.YAW_RATE] * x[S.VY], rel=1e-9, abs=1e-9)
        # wheel spin: I dw/dt = -R Fx (no torque input)
        np.testing.assert_allclose(f[S.OMEGA_LF:S.OMEGA_RR + 1], -p.R_w * fx / p.I_y_w, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("mu", [0.3, 0.6, 1.0])
def test_friction_scaling_sets_the_pure_slip_peaks(mu):
    """In pure slip the force never exceeds mu_y Fz (to 1e-6), the peak over slip equals mu
    at zero camber, and the slip of the peak shrinks with mu (stiffness kept)."""
    p = mb_model.parameter_tuple(1, mu).tire
    alphas = np.linspace(-0.4, 0.4, 4001)
    peaks = []
    for fz in (1500.0, 4000.0, 7000.0):
        for gamma in (-0.05, -0.01, 0.0, 0.02, 0.06):
            fy, mu_y = zip(*(tire_model.formula_lateral(a, gamma, fz, p) for a in alphas), strict=True)
            util = np.abs(np.array(fy)) / (np.array(mu_y) * fz)
            assert util.max() <= 1 + 1e-6
            if gamma == 0.0:
                assert util.max() == pytest.approx(1.0, abs=1e-4)
                peaks.append(abs(alphas[np.argmax(np.array(fy))]))
        fx = [tire_model.formula_longitudinal(k, 0.0, fz, p) for k in np.linspace(-1, 1, 4001)]
        assert np.max(np.abs(fx)) / fz <= mu * (1 + 1e-6)
        assert np.max(np.abs(fx)) / fz == pytest.approx(mu, abs=2e-3)
    if mu < 1.0:
        p1 = mb_model.parameter_tuple(1, 1.0).tire
        a_peak_1 = abs(alphas[np.argmax([tire_model.formula_lateral(a, 0.0, 4000.0, p1)[0] for a in alphas])])
        assert peaks[0] < 0.8 * a_peak_1
    # without zeroing the camber-gated shifts the bound fails: the adaptation matters
    raw = mb_model.parameter_tuple(1, mu, camber_shifts=True).tire
    fy_raw = max(tire_model.formula_lateral(a, 0.01, 4000.0, raw)[0] for a in alphas)
    assert fy_raw / (mu * 4000.0) > 1.01


def _circle_drive(vehicle: str, radius: float, speed: float, mu: float, duration: float):
    s = np.arange(0.0, speed * duration + 400.0, 0.5)
    lead = 60.0
    th = np.clip(s - lead, 0.0, None) / radius
    x = np.where(s < lead, s, lead + radius * np.sin(th))
    y = np.where(s < lead, 0.0, radius * (1 - np.cos(th)))
    path = Path(x, y, np.full_like(s, speed))
    return simulate_multibody(vehicle, path, ConstantFriction("road"), {"road": mu}, duration=duration)


@pytest.mark.parametrize("vehicle", MB_VEHICLES)
def test_steady_circle_lateral_acceleration_is_v2_over_r(vehicle):
    d = _circle_drive(vehicle, 60.0, 14.0, 1.0, 40.0)
    late = d.data[d.t > 25.0]
    x, y = late["x_true"].to_numpy(), late["y_true"].to_numpy()
    # circle through the trajectory (algebraic least squares)
    A = np.c_[2 * x, 2 * y, np.ones_like(x)]
    cx, cy, c = np.linalg.lstsq(A, x**2 + y**2, rcond=None)[0]
    r_fit = np.sqrt(c + cx**2 + cy**2)
    v2 = late["vx_true"] ** 2 + late["vy_true"] ** 2
    ay = late["ay_true"]
    assert np.mean(ay) == pytest.approx(np.mean(v2) / r_fit, rel=0.01)
    assert np.std(ay) < 0.01 * np.mean(ay)
    # the accelerometer rolls with the body: it reads more than the true lateral acceleration
    roll = late["roll_true"].to_numpy()
    assert np.mean(roll) > 0.01  # ISO: a left turn rolls the body to the right
    expected = np.mean(ay * np.cos(roll) + GRAVITY * np.sin(roll))
    assert np.mean(late["ay"]) == pytest.approx(expected, abs=0.05)
    # the preset's roll gradient is the engine's, and levelling removes the tilt
    assert np.mean(roll) / np.mean(ay) == pytest.approx(d.vehicle.roll_gradient, rel=0.05)
    ay_level = level_accelerations(late["ax"], late["ay"], d.vehicle)[1]
    assert np.mean(ay_level) == pytest.approx(np.mean(ay), rel=0.01)
    # the vehicle's own yaw rate and wheel-speed kinematics: outer (right) wheels faster
    assert np.mean(late["omega_fr"] - late["omega_fl"]) > 0
    r = np.mean(late["yaw_rate_true"])
    dw = np.mean(late["omega_rr"] - late["omega_rl"]) * d.vehicle.wheel_radius
    assert dw == pytest.approx(r * mb_model.commonroad_parameters(mb_model.COMMONROAD_VEHICLES[vehicle]).T_r, rel=0.05)


def _sustained(values: np.ndarray, rate: float, window: float = 1.0) -> np.ndarray:
    n = max(1, round(window * rate))
    return np.convolve(values, np.ones(n) / n, mode="valid")


@pytest.mark.parametrize("vehicle", MB_VEHICLES)
def test_snow_caps_the_sustained_lateral_acceleration(vehicle):
    d = simulate_scenario("snow-slalom", seed=0, engine="multibody", vehicle=vehicle, duration=60.0)
    ay = _sustained(np.abs(d.col("ay_true")), d.meta.sample_rate)
    assert ay.max() < 0.3 * GRAVITY * 1.03
    # and the driver did ask for more: both axles saturated for a while
    assert np.mean(d.col("util_f_true") > 0.9) > 0.05
    assert ay.max() > 0.25 * GRAVITY


def test_truth_curve_is_reproduced_from_the_truth_columns():
    """Binned Fy/Fz of the front axle against its single-track slip angle equals the package's
    pure-slip tire function at the drive's axle loads (split evenly, zero camber)."""
    d = simulate_scenario("snow-slalom", seed=1, engine="multibody", duration=60.0)
    tire = mb_model.parameter_tuple(1, 0.3).tire
    a = d.col("alpha_f_true")
    fz = d.col("Fzf_true")
    pure = np.abs(d.col("Fxf_true")) < 0.02 * fz
    mu = d.col("Fyf_true") / fz
    edges = np.arange(-0.08, 0.0801, 0.005)
    checked = 0
    for lo, hi in itertools.pairwise(edges):
        sel = pure & (a >= lo) & (a < hi)
        if sel.sum() < 30:
            continue
        model = np.mean([tire_model.formula_lateral(-ai, 0.0, 0.5 * f, tire)[0] / (0.5 * f)
                         for ai, f in zip(a[sel], fz[sel], strict=True)])
        assert np.mean(mu[sel]) == pytest.approx(model, abs=0.03), (lo, hi)
        checked += 1
    assert checked >= 6


@pytest.mark.slow
@pytest.mark.parametrize("vehicle", MB_VEHICLES)
@pytest.mark.parametrize("scenario", MB_SCENARIOS)
def test_every_scenario_runs_for_both_vehicles_and_seeds(scenario, vehicle):
    for seed in (0, 1):
        d = simulate_scenario(scenario, seed=seed, engine="multibody", vehicle=vehicle, duration=40.0)
        assert d.meta.truth["model"] == "multibody"
        assert d.vehicle == PRESETS[vehicle]
        num = d.data.select_dtypes("number")
        assert np.isfinite(num.to_numpy()).all()
        assert d.duration == pytest.approx(40.0, abs=0.05)
        vx = d.col("vx_true")
        assert vx.min() > 1.0 and vx.max() < 30.0
        # the driver stayed in control: no spin (body sideslip below 10 deg)
        assert np.max(np.abs(np.arctan2(d.col("vy_true"), vx))) < np.radians(10)
        assert set(np.unique(d.data["surface"])) <= set(d.meta.truth["surfaces"])


def test_seed_reproducible_and_cached(tmp_path, monkeypatch):
    monkeypatch.setenv("ROADGRIP_DRIVE_CACHE", str(tmp_path))
    a = simulate_scenario("straight-cruise", seed=3, engine="multibody", duration=8.0)
    files = list(tmp_path.glob("straight-cruise-*.parquet"))
    assert len(files) == 1
    b = simulate_scenario("straight-cruise", seed=3, engine="multibody", duration=8.0)
    c = simulate_scenario("straight-cruise", seed=3, engine="multibody", duration=8.0, cache=False)
    for other in (b, c):
        np.testing.assert_array_equal(a.data.select_dtypes("number").to_numpy(),
                                      other.data.select_dtypes("number").to_numpy())
    assert b.meta.truth == a.meta.truth
    d = simulate_scenario("straight-cruise", seed=4, engine="multibody", duration=8.0)
    assert len(list(tmp_path.glob("straight-cruise-*.parquet"))) == 2
    assert not np.array_equal(a.col("ay"), d.col("ay"))


def test_friction_drop_and_patches_follow_the_position():
    d = simulate_scenario("straight-cruise", seed=0, engine="multibody", duration=20.0)
    drop = d.meta.truth["friction_drop_x"]
    x = d.col("x_true")
    np.testing.assert_array_equal(d.col("mu_true"), np.where(x >= drop, 0.3, 1.0))


def test_path_encoding_for_the_compiled_driver():
    path = Path([0.0, 1.0, 3.0, 6.0], [0.0, 0.0, 0.0, 0.0], [5.0, 6.0, 7.0, 8.0], closed=True)
    enc = path.encode()
    assert isinstance(enc, MBPath)
    for name in ("x", "y", "v"):
        np.testing.assert_array_equal(getattr(enc, name), getattr(path, name))
    np.testing.assert_array_equal(enc.a, path.acceleration())
    assert enc.closed is True


def test_bad_requests_are_named():
    with pytest.raises(ValueError, match="runs on engine"):
        simulate_scenario("f1tenth-patches", engine="multibody")
    with pytest.raises(ValueError, match="unknown multi-body vehicle"):
        simulate_scenario("snow-slalom", engine="multibody", vehicle="tractor")
    with pytest.raises(ValueError, match="applies to the multibody engine"):
        simulate_scenario("snow-slalom", vehicle="vw-vanagon")
    with pytest.raises(ValueError, match="no mu"):
        simulate_multibody("ford-escort", Path([0, 1, 2], [0, 0, 0], [5, 5, 5]),
                              ConstantFriction("ice"), {"snow": 0.3}, duration=1.0)


def test_command_line_simulates_on_the_multibody_engine(tmp_path):
    from tests.test_cli_foundation import _roadgrip

    out = tmp_path / "mb.parquet"
    res = _roadgrip("simulate", "snow-slalom", "--engine", "multibody", "--vehicle", "vw-vanagon",
                    "--duration", "12", "--seed", "2", "-o", str(out))
    assert res.returncode == 0, res.stderr
    from roadgrip.io import read_drive

    d = read_drive(out)
    assert d.meta.truth["model"] == "multibody" and d.vehicle == PRESETS["vw-vanagon"]
    assert d.duration == pytest.approx(12.0, abs=0.05) and d.meta.sample_rate == pytest.approx(25.0)
    listing = _roadgrip("scenarios")
    assert listing.returncode == 0
    rows = {line.split("│")[1].strip(): line for line in listing.stdout.splitlines() if line.count("│") > 3}
    assert "multibody" in rows["figure-eight"] and "lateral, multibody" in rows["snow-slalom"]
    assert "multibody" not in rows["f1tenth-patches"]
    bad = _roadgrip("simulate", "f1tenth-patches", "--engine", "multibody", "-o", str(out))
    assert bad.returncode == 2 and "--engine must be one of planar" in bad.stderr


def test_identification_drive_turns_at_every_speed():
    """``vehicle-id``: both slaloms and the lane change of each block run at its speed of
    ``VEHICLE_ID_SPEEDS`` (the fit separates the steering's scale from the understeer by the
    speed), and the plan ends at the last speed."""
    from roadgrip.sim.mb_scenarios import VEHICLE_ID_SPEEDS, vehicle_id_plan

    for seed in (0, 10):
        phases, events, length = vehicle_id_plan(seed)
        assert sum(d for d, _ in phases) == pytest.approx(length)
        bounds = np.cumsum([0.0, *(d for d, _ in phases)])

        def speed_at(t, bounds=bounds, phases=phases):
            v = VEHICLE_ID_SPEEDS[0]
            for (d, a), t0 in zip(phases, bounds[:-1], strict=True):
                v += a * min(max(t - t0, 0.0), d)
            return v

        assert len(events) == 3 * len(VEHICLE_ID_SPEEDS)
        for i, (t0, t1, _kind, _mag, _period) in enumerate(events):
            want = VEHICLE_ID_SPEEDS[i // 3]
            # constant speed through the manoeuvre: no speed phase overlaps it
            assert speed_at(t0) == pytest.approx(want) and speed_at(t1) == pytest.approx(want), (seed, i)
        assert speed_at(length) == pytest.approx(VEHICLE_ID_SPEEDS[-1])
