"""The random vehicle family of the multi-body engine and its realistic sensors."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from roadgrip.constants import GRAVITY
from roadgrip.io.canonical import read_canonical_parquet
from roadgrip.sim import mb_model, vehicle_family
from roadgrip.sim.friction import ConstantFriction
from roadgrip.sim.mb_driver import Path
from roadgrip.sim.multibody import simulate_multibody
from roadgrip.sim.scenarios import simulate_scenario
from roadgrip.sim.sensors import (
    SENSOR_DRAWS,
    SENSOR_ERROR_RANGES,
    SensorErrors,
    SensorSpec,
    SteeringErrors,
    sample_sensor_errors,
)
from roadgrip.sim.vehicle_family import FAMILY_RANGES, axle_peak_slip, mb_vehicle, sample_vehicle

S = mb_model.MBState
TRUTH = ("vx_true", "vy_true", "yaw_rate_true", "alpha_f_true", "alpha_r_true", "mu_true", "Fyf_true",
         "Fyr_true", "Fzf_true", "util_f_true", "util_r_true", "x_true", "psi_true", "steer_true", "roll_true")


# -- sampling ----------------------------------------------------------------------------
def test_same_seed_same_vehicle_and_sensors_other_seed_other_vehicle():
    a, b, c = sample_vehicle(11), sample_vehicle(11), sample_vehicle(12)
    assert a.params == b.params and a.description == b.description and a.sensors == b.sensors
    assert a.params != c.params and a.description["sampled"] != c.description["sampled"]
    # the sensor choice does not change the vehicle
    ideal = sample_vehicle(11, sensors="ideal")
    assert ideal.params == a.params and ideal.sensors is None and a.sensors is not None


def test_sampled_values_lie_in_their_ranges_and_the_vehicle_is_consistent():
    layouts = set()
    for seed in range(150):
        v = sample_vehicle(seed, sensors="ideal")
        d = v.description
        for key, value in d["sampled"].items():
            lo, hi = FAMILY_RANGES[key][:2]
            assert lo <= value <= hi, (seed, key, value)
        p, base = v.commonroad, mb_model.commonroad_parameters(d["base_parameter_set"])
        s = d["sampled"]
        assert p.m == pytest.approx(p.m_s + p.m_uf + p.m_ur)
        assert p.m_s == pytest.approx(base.m_s * s["mass_scale"])
        assert p.a + p.b == pytest.approx((base.a + base.b) * s["wheelbase_scale"])
        assert p.a / (p.a + p.b) == pytest.approx(base.a / (base.a + base.b) + s["cg_front_shift"])
        assert p.R_w == pytest.approx(base.R_w * s["wheel_radius_scale"])
        assert p.tire.p_ky1 == -s["cornering_stiffness"] and p.T_sb == s["brake_front_share"]
        front_drive = {"fwd": 1.0, "rwd": 0.0}.get(d["drive"], s.get("awd_front_share"))
        assert p.T_se == front_drive and v.params.drive == d["drive"]
        layouts.add(d["drive"])
        # the base object is untouched, the description survives JSON
        assert base.m == mb_model.commonroad_parameters(d["base_parameter_set"]).m
        assert json.loads(json.dumps(d)) == d
    assert layouts == {"fwd", "rwd", "awd"}


def test_parameter_set_2_is_never_a_base(monkeypatch):
    asked = []
    real = mb_model.commonroad_parameters

    def spy(vehicle_id):
        asked.append(vehicle_id)
        return real(vehicle_id)

    monkeypatch.setattr(vehicle_family, "commonroad_parameters", spy)
    bases = {sample_vehicle(seed, sensors="ideal").description["base"] for seed in range(100)}
    assert bases == {"ford-escort", "vw-vanagon"}
    assert set(asked) == {1, 3}


def test_vehicle_specs_are_named_or_refused():
    assert mb_vehicle("vw-vanagon").sensors is None
    assert mb_vehicle("vw-vanagon", sensors="realistic", seed=4).sensors is not None
    assert mb_vehicle("random:3").sensors is not None and mb_vehicle("random:3", sensors="ideal").sensors is None
    for bad in ("bmw-320i", "random:", "random:-1", "random:1.5"):
        with pytest.raises(ValueError, match="random:SEED"):
            mb_vehicle(bad)
    with pytest.raises(ValueError, match="sensors"):
        mb_vehicle("random:3", sensors="perfect")


def test_sensor_errors_lie_in_their_ranges():
    for seed in range(50):
        e = sample_sensor_errors(np.random.default_rng(seed))
        assert set(e.channels) == set(SENSOR_ERROR_RANGES)
        for col, spec in e.channels.items():
            r = SENSOR_ERROR_RANGES[col]
            assert abs(spec.bias) <= r["bias"] and abs(spec.drift) <= r["drift"]
            radius = SENSOR_DRAWS["wheel_radius_error"][1] if col.startswith("omega_") else 0.0
            assert abs(spec.scale - 1.0) <= r["scale"] + radius
            assert 0.0 <= spec.delay <= 0.15 and spec.quantization == r["quantization"]
        # one message, one latency: the four wheel speeds, and the pose
        assert len({e.channels[c].delay for c in ("omega_fl", "omega_fr", "omega_rl", "omega_rr")}) == 1
        assert len({e.channels[c].delay for c in ("x", "y", "psi")}) == 1
        lo, hi = SENSOR_DRAWS["steering_offset"]
        assert lo <= e.steering.offset <= hi and 0.0 <= e.steering.compliance <= SENSOR_DRAWS["steering_compliance"][1]


# -- the tires: load sensitivity and the true cornering stiffness ------------------------
def test_load_sensitivity_scales_peak_and_slope_as_documented():
    v = sample_vehicle(5, sensors="ideal")
    mu = 0.8
    tire = v.parameter_tuple(mu).tire
    lateral = mb_model.compiled_rhs().formula_lateral
    longitudinal = mb_model.compiled_rhs().formula_longitudinal
    fz0 = tire.fz_nominal
    assert fz0 == pytest.approx(v.params.mass * GRAVITY / 4)
    h = 1e-6
    alphas = np.linspace(-0.6, 0.6, 6001)
    for fz in (0.5 * fz0, fz0, 1.6 * fz0):
        dfz = fz / fz0 - 1
        slope = (lateral(h, 0.0, fz, tire)[0] - lateral(-h, 0.0, fz, tire)[0]) / (2 * h)
        assert abs(slope) == pytest.approx((1 + tire.stiffness_load_y * dfz) * abs(tire.p_ky1) * fz, rel=1e-6)
        peak = np.max(np.abs([lateral(a, 0.0, fz, tire)[0] for a in alphas]))
        assert peak / fz == pytest.approx(mu * (1 + tire.peak_load_y * dfz), rel=1e-4)
        assert lateral(0.1, 0.0, fz, tire)[1] == pytest.approx(mu * (1 + tire.peak_load_y * dfz))
        # the package's curve is shifted by p_hx1 in its own slip, which the slip factor c scales
        k0 = tire.p_hx1 * (1 + tire.peak_load_x * dfz) / (1 + tire.stiffness_load_x * dfz)
        slope_x = (longitudinal(k0 + h, 0.0, fz, tire) - longitudinal(k0 - h, 0.0, fz, tire)) / (2 * h)
        # (the package adds its vertical shift F_z p_vx1 inside the sine: a factor cos(F_z p_vx1))
        shift = fz * (1 + tire.peak_load_x * dfz) * tire.p_vx1
        want = (1 + tire.stiffness_load_x * dfz) * tire.p_kx1 * fz * np.cos(shift)
        assert abs(slope_x) == pytest.approx(want, rel=1e-6)
    # the named vehicles have none: their tire is the package's
    named = mb_model.parameter_tuple(1, mu).tire
    assert lateral(0.05, 0.0, 2000.0, named)[0] == mb_model.compiled_rhs().formula_lateral(0.05, 0.0, 2000.0, named)[0]
    assert named.peak_load_y == named.stiffness_load_y == 0.0


def test_cornering_stiffness_is_the_tires_slope_at_the_static_loads():
    lateral = mb_model.compiled_rhs().formula_lateral
    for seed in (1, 2, 3):
        v = sample_vehicle(seed, sensors="ideal")
        vp, tire = v.params, v.parameter_tuple(1.0).tire
        wb = vp.lf + vp.lr
        for share, c in ((vp.lr / wb, vp.cornering_stiffness_front), (vp.lf / wb, vp.cornering_stiffness_rear)):
            fz = 0.5 * vp.mass * GRAVITY * share
            slope = (lateral(1e-6, 0.0, fz, tire)[0] - lateral(-1e-6, 0.0, fz, tire)[0]) / 2e-6
            assert 2 * abs(slope) == pytest.approx(c, rel=1e-6)


def test_drive_layout_puts_the_engine_torque_on_its_axle():
    """The package's wheel-spin equation: a drive command adds 0.5 T_se m R a / I_y_w to each
    front wheel's spin acceleration and 0.5 (1 - T_se) ... to each rear wheel's."""
    rhs = mb_model.compiled_rhs().mb
    from vehiclemodels.init_mb import init_mb
    for seed in range(12):
        v = sample_vehicle(seed, sensors="ideal")
        p, pt = v.commonroad, v.parameter_tuple(1.0)
        x = np.array(init_mb([0.0, 0.0, 0.0, 15.0, 0.0, 0.0, 0.0], p), float)
        a = 2.0
        d = np.array(rhs(x.copy(), np.array([0.0, a]), pt)) - np.array(rhs(x.copy(), np.zeros(2), pt))
        torque = d[S.OMEGA_LF:S.OMEGA_RR + 1] * p.I_y_w / (0.5 * p.m * p.R_w * a)
        front = {"fwd": 1.0, "rwd": 0.0}.get(v.params.drive, p.T_se)
        np.testing.assert_allclose(torque, [front, front, 1 - front, 1 - front], atol=1e-9)


# -- drives ------------------------------------------------------------------------------
def _circle(vehicle, duration=40.0, radius=60.0, speed=14.0):
    s = np.arange(0.0, speed * duration + 400.0, 0.5)
    lead = 60.0
    th = np.clip(s - lead, 0.0, None) / radius
    x = np.where(s < lead, s, lead + radius * np.sin(th))
    y = np.where(s < lead, 0.0, radius * (1 - np.cos(th)))
    return simulate_multibody(vehicle, Path(x, y, np.full_like(s, speed)), ConstantFriction("road"),
                              {"road": 1.0}, duration=duration)


@pytest.mark.parametrize("seed", [101, 103])
def test_body_roll_gradient_is_the_engines(seed):
    v = sample_vehicle(seed, sensors="ideal")
    d = _circle(v)
    late = d.data[d.t > 25.0]
    assert np.mean(late["roll_true"]) / np.mean(late["ay_true"]) == pytest.approx(d.vehicle.roll_gradient, rel=0.05)
    assert d.vehicle == v.params and d.meta.truth["vehicle"]["sampled"] == v.description["sampled"]


def test_sensor_errors_are_applied_as_recorded_and_the_truth_is_exact():
    """No noise: each channel is its truth column through the recorded errors, exactly."""
    errors = SensorErrors(
        channels={"vx": SensorSpec(bias=0.2, drift=0.01, scale=1.03, delay=0.07, quantization=0.01,
                                   dropout_rate=0.2, dropout_duration=0.4),
                  "x": SensorSpec(bias=-1.0, delay=0.12),
                  "psi": SensorSpec(bias=0.01, scale=0.98, delay=0.03),
                  "steer": SensorSpec(delay=0.05)},
        steering=SteeringErrors(offset=0.01, ratio_error=-0.04, compliance=5e-6))
    v = dataclasses.replace(sample_vehicle(7, sensors="ideal"), sensors=errors)
    d = _circle(v, duration=20.0)
    ideal = _circle(sample_vehicle(7, sensors="ideal"), duration=20.0)
    for col in TRUTH:
        np.testing.assert_array_equal(d.col(col), ideal.col(col))
    t = d.t
    drops = d.meta.truth["sensor_errors"]["dropouts"]["vx"]
    assert len(drops) >= 1 and all(t1 - t0 == pytest.approx(0.4) for t0, t1 in drops)

    def through(col, truth):
        spec = SensorSpec(**d.meta.truth["sensors"][col])
        y = spec.scale * np.interp(t - spec.delay, t, truth) + spec.bias + spec.drift * t
        if spec.quantization:
            y = spec.quantization * np.round(y / spec.quantization)
        return y

    vx = through("vx", d.col("vx_true"))
    lost = np.zeros(len(t), bool)
    for t0, t1 in drops:
        lost |= (t >= t0) & (t < t1)
    lost[0] = False  # a log starts at its first message
    np.testing.assert_allclose(d.col("vx")[~lost], vx[~lost], atol=1e-12)
    held = np.maximum.accumulate(np.where(lost, -1, np.arange(len(t))))
    np.testing.assert_allclose(d.col("vx")[lost], vx[held[lost]], atol=1e-12)
    np.testing.assert_allclose(d.col("x"), through("x", d.col("x_true")), atol=1e-9)
    np.testing.assert_allclose(d.col("psi"), np.angle(np.exp(1j * through("psi", d.col("psi_true")))), atol=1e-9)
    st = d.meta.truth["sensor_errors"]["steering"]
    reported = (1 + st["ratio_error"]) * (d.col("steer_true") + st["compliance"] * d.col("Fyf_true")) + st["offset"]
    np.testing.assert_allclose(d.col("steer"), through("steer", reported), atol=1e-12)


def _delay_by_xcorr(measured, truth, rate, max_lag=0.3):
    """Lag [s] maximising the correlation of the differenced signals (parabolic peak)."""
    a, b = np.diff(measured), np.diff(truth)
    lags = np.arange(round(max_lag * rate) + 1)
    n = len(a) - lags[-1]
    c = np.array([np.corrcoef(a[k:k + n], b[:n])[0, 1] for k in lags])
    k = int(np.argmax(c))
    k = min(max(k, 1), len(c) - 2)
    off = 0.5 * (c[k - 1] - c[k + 1]) / (c[k - 1] - 2 * c[k] + c[k + 1])
    return (k + off) / rate


def test_realistic_drive_delays_match_the_recorded_latencies_and_meta_survives_parquet(tmp_path):
    d = simulate_scenario("dry-gravel-dry", seed=3, engine="multibody", vehicle="random:104", duration=45.0,
                          cache=False)
    tr = d.meta.truth
    assert tr["vehicle"]["name"] == "random:104" and d.vehicle.name == "random:104"
    rate = d.meta.sample_rate
    # the two channels whose truth column is their signal (the accelerometer's is tilted)
    for col, truth in (("yaw_rate", "yaw_rate_true"), ("steer", "steer_true")):
        recorded = tr["sensors"][col]["delay"]
        assert _delay_by_xcorr(d.col(col), d.col(truth), rate) == pytest.approx(recorded, abs=0.005), col
    d.save(tmp_path / "d.parquet")
    e = read_canonical_parquet(tmp_path / "d.parquet")
    assert e.meta.truth["vehicle"] == tr["vehicle"]
    assert e.meta.truth["sensor_errors"] == json.loads(json.dumps(tr["sensor_errors"]))
    assert e.vehicle == d.vehicle


def test_a_family_drive_is_reproducible_from_its_seeds():
    def run(vehicle, seed):
        return simulate_scenario("straight-cruise", seed=seed, engine="multibody", vehicle=vehicle, duration=5.0,
                                 cache=False)

    a, b = run("random:21", 1), run("random:21", 1)
    assert a.data.equals(b.data) and a.meta.truth == b.meta.truth
    other_drive, other_vehicle = run("random:21", 2), run("random:22", 1)
    assert not np.array_equal(a.col("ax"), other_drive.col("ax"))
    # the errors come with the vehicle, not with the drive's seed
    assert a.meta.truth["sensor_errors"]["channels"] == other_drive.meta.truth["sensor_errors"]["channels"]
    assert a.vehicle != other_vehicle.vehicle


# -- excitation --------------------------------------------------------------------------
def _excitation(vehicle: str, duration: float = 60.0):
    v = mb_vehicle(vehicle, sensors="ideal")
    snow = simulate_scenario("snow-slalom", seed=0, engine="multibody", vehicle=vehicle, sensors="ideal",
                             duration=duration, cache=False)
    return snow, axle_peak_slip(v, 0.3)


def test_snow_slalom_drives_a_family_vehicle_past_its_front_peak():
    snow, (peak_f, peak_r) = _excitation("random:102")
    alpha = np.abs(snow.col("alpha_f_true"))
    assert alpha.max() > 2.0 * peak_f
    assert np.quantile(snow.col("util_f_true"), 0.99) > 0.95
    assert np.abs(snow.col("alpha_r_true")).max() < 2.0 * peak_r  # the car understeers: the rear holds


def test_a_spin_is_named():
    """A tire whose lateral peak snaps (curvature 0.22, outside the family's range) spins this van
    in the snow slalom: the engine says so instead of dividing by zero."""
    v = sample_vehicle(117, sensors="ideal")
    snappy = dataclasses.replace(v.commonroad, tire=dataclasses.replace(v.commonroad.tire, p_ey1=0.22))
    from roadgrip.sim.mb_scenarios import MB_BUILDERS

    with pytest.raises(RuntimeError, match="spun"):
        MB_BUILDERS["snow-slalom"](0, 40.0, False, dataclasses.replace(v, commonroad=snappy))


@pytest.mark.slow
@pytest.mark.parametrize("vehicle", ["ford-escort", "vw-vanagon", *(f"random:{s}" for s in range(100, 105))])
def test_scenarios_excite_each_family_vehicle_as_the_named_two(vehicle):
    """Snow slalom (its full 200 s) past the front tires' peak slip, the rear's below twice its
    own; dry-gravel-dry at utilisation >= 0.6 on gravel while cornering (slalom and lane change
    of the gravel segment)."""
    snow, (peak_f, peak_r) = _excitation(vehicle, duration=200.0)
    assert np.abs(snow.col("alpha_f_true")).max() > 2.0 * peak_f
    assert np.abs(snow.col("alpha_r_true")).max() < 2.0 * peak_r  # no spin
    dgd = simulate_scenario("dry-gravel-dry", seed=0, engine="multibody", vehicle=vehicle, sensors="ideal",
                            cache=False)
    t = dgd.t
    corner = (t >= 60.0 + 27.0) & (t < 60.0 + 43.0)
    assert set(dgd.data["surface"][corner]) == {"gravel"}
    util = np.maximum(dgd.col("util_f_true"), dgd.col("util_r_true"))
    assert util[corner].max() >= 0.6


# -- command line ------------------------------------------------------------------------
def test_command_line_simulates_a_family_vehicle(tmp_path):
    from typer.testing import CliRunner

    from roadgrip.cli import app
    from roadgrip.io import read_drive

    out = tmp_path / "r.parquet"
    res = CliRunner().invoke(app, ["simulate", "straight-cruise", "--engine", "multibody", "--vehicle", "random:9",
                                   "--duration", "4", "-o", str(out)])
    assert res.exit_code == 0, res.output
    d = read_drive(out)
    v = sample_vehicle(9)
    assert d.vehicle == v.params and d.meta.truth["vehicle"]["sampled"] == v.description["sampled"]
    assert d.meta.truth["sensor_errors"]["steering"] == dataclasses.asdict(v.sensors.steering)
    res = CliRunner().invoke(app, ["simulate", "straight-cruise", "--engine", "multibody", "--vehicle", "random:9",
                                   "--sensors", "ideal", "--duration", "4", "-o", str(out)])
    assert res.exit_code == 0 and "sensor_errors" not in read_drive(out).meta.truth
    for args, words in ((["--vehicle", "random:x"], ["--vehicle", "random:SEED"]),
                        (["--vehicle", "bmw-320i"], ["--vehicle", "ford-escort", "random:SEED"]),
                        (["--sensors", "perfect"], ["--sensors", "realistic"])):
        res = CliRunner().invoke(app, ["simulate", "straight-cruise", "--engine", "multibody", *args,
                                       "-o", str(out)])
        message = res.output + str(res.exception)  # the entry point prints a ValueError as 'error: ...'
        assert res.exit_code != 0 and all(w in message for w in words), message
