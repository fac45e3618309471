"""simulate(): low speed, manoeuvre kinds, input errors, truth bookkeeping."""

from __future__ import annotations

import numpy as np
import pytest

from roadgrip.constants import GRAVITY, V_EPS
from roadgrip.sim import (
    ClosedTrack,
    ConstantFriction,
    Maneuver,
    PiecewiseTime,
    SensorSpec,
    TrackDriver,
    engine,
    simulate,
    surface_from_preset,
)
from roadgrip.sim.friction import tire_table
from roadgrip.sim.maneuvers import (
    ConstantSpeed,
    DoubleLaneChange,
    SineSweep,
    SpeedPhases,
    StepSteer,
)
from roadgrip.vehicle import PRESETS
from roadgrip.vehicle.planar import OMEGA_EPS

SEDAN = PRESETS["sedan"]
DRY = surface_from_preset("dry_asphalt")
SNOW = surface_from_preset("snow")


def test_planar_finite_down_to_half_a_metre_per_second():
    man = Maneuver(SpeedPhases(8.0, ((1.0, 0.0), (3.5, -2.5), (6.0, 0.0))), StepSteer(0.1, 6.0, 0.5))
    d = simulate(SEDAN, man, ConstantFriction("dry_asphalt"), [DRY], duration=10.0, output_rate=100.0)
    num = d.data.drop(columns=["surface"]).to_numpy(float)
    assert np.isfinite(num).all()
    assert d.data["vx_true"].iloc[-100:].mean() == pytest.approx(0.5, abs=0.05)
    assert d.meta.truth["max_substeps"] > 1  # the stiff wheel mode was sub-stepped
    assert np.abs(d.data[["kappa_fl_true", "kappa_rl_true"]].to_numpy()).max() < 0.2


def test_lateral_model_finite_at_half_a_metre_per_second():
    man = Maneuver(ConstantSpeed(0.5), StepSteer(0.3, 0.5, 0.2))
    d = simulate(PRESETS["suv"], man, ConstantFriction("snow"), [SNOW], duration=5.0,
                 model="lateral", output_rate=25.0)
    assert np.isfinite(d.data.drop(columns=["surface"]).to_numpy(float)).all()
    # kinematic steady state at crawling speed (the tires barely slip): zero slip angles
    # with the regularised speed u = sqrt(vx² + V_EPS²) give r = u tan(delta) / l
    r_kin = np.hypot(0.5, V_EPS) * np.tan(0.3) / PRESETS["suv"].wheelbase
    assert d.data["yaw_rate_true"].iloc[-1] == pytest.approx(r_kin, rel=0.1)


def test_braking_to_standstill_stays_finite():
    v = SEDAN
    table, peaks = tire_table([DRY])
    dt, n = 1e-3, 6000
    p = engine.PlanarParams(
        mass=v.mass, yaw_inertia=v.yaw_inertia, lf=v.lf, lr=v.lr, cg_height=v.cg_height,
        wheel_radius=v.wheel_radius, wheel_inertia=2 * v.wheel_inertia, v_eps=0.5, gravity=GRAVITY,
        omega_eps=OMEGA_EPS, max_steer=v.max_steer,
    ).vector()
    S = engine.PlanarSimState
    x0 = np.zeros(S.SIZE)
    x0[S.VX] = 5.0
    x0[S.OMEGA_F] = x0[S.OMEGA_R] = 5.0 / v.wheel_radius
    z = np.zeros(n + 1)
    lam_w = 1.2 * v.wheel_radius**2 * v.mass * GRAVITY * DRY.front_long.slope0() / (2 * v.wheel_inertia)
    states, ctrl, _, nsub = engine.integrate_planar(
        x0, dt, n,
        engine.PlanarModel(p, table, peaks, lam_wheel=lam_w, lam_body=100.0),
        0,
        engine.SteerReference(steer_ff=z, rref=z, v_ref=z, a_ref=z - 3.0, k_r=0.0),
        engine.PursuitPath(np.zeros(1), np.zeros(1), np.zeros(1), lookahead0=0.0, lookahead_gain=0.0,
                           speed_preview=0.0),
        engine.SpeedControl(kp=0.0, ki=0.0, drive_front=1.0, brake_front=0.65, max_drive=1e5,
                            max_brake=0.5 * v.mass * GRAVITY * v.wheel_radius),
        engine.field_code(ConstantFriction("dry_asphalt").encode()),
    )
    assert np.isfinite(states).all()
    assert np.all(ctrl[:, engine.C_BRAKE_F] > 0)  # braking throughout
    assert abs(states[-1, S.VX]) < 0.05 and abs(states[-1, S.OMEGA_F]) < 1.0  # stopped, wheels held
    assert nsub.max() > 1


@pytest.mark.parametrize("steering", [
    DoubleLaneChange(3.5, 2.5, 1.0, t0=2.0),
    SineSweep(0.03, 0.2, 2.0, 10.0, t0=1.0),
    StepSteer(0.04, 1.0, 0.2),
])
def test_open_loop_manoeuvres_run_planar_and_lateral(steering):
    man = Maneuver(ConstantSpeed(15.0), steering, yaw_gain=0.05)
    for model in ("planar", "lateral"):
        d = simulate(SEDAN, man, ConstantFriction("dry_asphalt"), [DRY], duration=12.0, model=model)
        assert np.abs(d.data["yaw_rate_true"]).max() > 0.05
        assert np.isfinite(d.data["alpha_f_true"]).all()


def test_planar_and_lateral_agree_in_the_linear_region_at_constant_speed():
    man = Maneuver(ConstantSpeed(15.0), SineSweep(0.01, 0.2, 1.0, 10.0, t0=0.5))
    pl = simulate(SEDAN.replace(cg_height=1e-6), man, ConstantFriction("dry_asphalt"), [DRY],
                  duration=11.0, internal_rate=1000.0)
    la = simulate(SEDAN, man, ConstantFriction("dry_asphalt"), [DRY], duration=11.0,
                  model="lateral", internal_rate=1000.0)
    r_pl, r_la = pl.data["yaw_rate_true"], la.data["yaw_rate_true"]
    assert np.abs(r_pl - r_la).max() < 0.02 * np.abs(r_la).max()


def test_delay_and_rate_reach_the_output():
    man = Maneuver(SpeedPhases(10.0, ((1.0, 0.0), (8.0, 1.0))))
    sensors = {"vx": SensorSpec(delay=0.05)}
    d = simulate(SEDAN, man, ConstantFriction("dry_asphalt"), [DRY], duration=8.0,
                 output_rate=50.0, sensors=sensors)
    np.testing.assert_allclose(np.diff(d.t), 0.02)
    t = d.t
    mid = (t > 3) & (t < 7)
    # during a 1 m/s² ramp a 50 ms delay lags the speed by 0.05 m/s
    np.testing.assert_allclose((d.data["vx_true"] - d.data["vx"])[mid], 0.05, atol=5e-3)
    assert d.meta.truth["sensors"]["vx"]["delay"] == 0.05


def test_piecewise_surfaces_and_true_tire_per_surface():
    gravel = surface_from_preset("gravel")
    field = PiecewiseTime((0.0, 3.0), ("dry_asphalt", "gravel"))
    d = simulate(SEDAN, Maneuver(ConstantSpeed(15.0)), field, [DRY, gravel], duration=6.0)
    assert set(d.data["surface"]) == {"dry_asphalt", "gravel"}
    assert d.true_tire("front", "lateral", "gravel").peak()[1] == pytest.approx(0.6)
    assert d.true_tire("rear", "longitudinal", "dry_asphalt").to_dict() == DRY.rear_long.to_dict()


def test_clear_errors():
    man = Maneuver(ConstantSpeed(10.0))
    f = ConstantFriction("dry_asphalt")
    with pytest.raises(ValueError, match="internal_rate"):
        simulate(SEDAN, man, f, [DRY], duration=1.0, internal_rate=100.0)
    with pytest.raises(ValueError, match="gravel"):
        simulate(SEDAN, man, ConstantFriction("gravel"), [DRY], duration=1.0)
    with pytest.raises(ValueError, match="model"):
        simulate(SEDAN, man, f, [DRY], duration=1.0, model="bicycle")
    with pytest.raises(ValueError, match="duration"):
        simulate(SEDAN, man, f, [DRY], duration=0.0)
    with pytest.raises(ValueError, match="unknown column"):
        simulate(SEDAN, man, f, [DRY], duration=1.0, sensors={"speed": SensorSpec()})
    track = ClosedTrack.rounded_rectangle(10, 6, 1.5)
    with pytest.raises(ValueError, match="lateral model"):
        simulate(SEDAN, TrackDriver(track, 4.0, 5.0), f, [DRY], duration=1.0, model="lateral")
