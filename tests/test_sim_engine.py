"""Compiled integrators against the numpy reference models and an adaptive ODE solver."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from roadgrip.constants import GRAVITY
from roadgrip.sim import engine
from roadgrip.sim.friction import (
    ConstantFriction,
    Patch,
    PatchFriction,
    PiecewiseTime,
    brush_surface,
    surface_from_preset,
    tire_table,
)
from roadgrip.vehicle import PRESETS
from roadgrip.vehicle.lateral import lateral_derivatives
from roadgrip.vehicle.planar import OMEGA_EPS, PlanarTires, axle_torques, planar_derivatives
from roadgrip.vehicle.slip import slip_angles


@pytest.mark.parametrize("surface", ["dry_asphalt", "gravel", "snow", "ice"])
def test_tire_mu_matches_magic_formula(surface):
    s = surface_from_preset(surface)
    table, _ = tire_table([s])
    slip = np.linspace(-1.0, 1.0, 401)
    for role, m in enumerate((s.front, s.rear, s.front_long, s.rear_long)):
        got = np.array([engine.tire_mu(table[0, role], v) for v in slip])
        np.testing.assert_allclose(got, m.mu(slip), rtol=1e-12, atol=1e-14)


def test_tire_mu_matches_brush():
    s = brush_surface("b", 0.45, PRESETS["f1tenth"])
    table, _ = tire_table([s])
    slip = np.linspace(-1.4, 1.4, 401)  # through the sliding limit
    got = np.array([engine.tire_mu(table[0, 0], v) for v in slip])
    np.testing.assert_allclose(got, s.front.mu(slip), rtol=1e-12, atol=1e-14)


def _field(field):
    return engine.field_code(field.encode())


def _lateral_run(dt, duration, vehicle, surf, k_r=0.0):
    n = round(duration / dt)
    th = np.arange(2 * n + 1) * dt / 2
    vx = 12.0 + 2.0 * np.sin(0.3 * th)
    steer = 0.06 * np.sin(1.3 * th) + 0.02 * np.sin(3.1 * th)
    table, _ = tire_table([surf])
    p = engine.LateralParams(mass=vehicle.mass, yaw_inertia=vehicle.yaw_inertia, lf=vehicle.lf, lr=vehicle.lr,
                             fz_front=vehicle.fz_front, fz_rear=vehicle.fz_rear, v_eps=0.5)
    driver = engine.LateralDriver(vx_h=vx, steer_h=steer, rref_h=np.zeros_like(th), k_r=k_r, k_b=0.0,
                                  max_steer=vehicle.max_steer)
    states, st, _ = engine.integrate_lateral(
        np.zeros(engine.LateralSimState.SIZE), dt, n, driver, table, p, _field(ConstantFriction(surf.label)),
    )
    return states, st


def test_lateral_integrator_matches_adaptive_solver_on_reference_model():
    """RK4 at 500 Hz vs solve_ivp (rtol 1e-10) on roadgrip.vehicle.lateral.lateral_derivatives."""
    v = PRESETS["suv"]
    snow = surface_from_preset("snow")
    states, _ = _lateral_run(1 / 500, 10.0, v, snow)
    S = engine.LateralSimState

    def rhs(t, x):
        steer = 0.06 * np.sin(1.3 * t) + 0.02 * np.sin(3.1 * t)
        vx = 12.0 + 2.0 * np.sin(0.3 * t)
        af, ar = slip_angles(vx, x[0], x[1], steer, v)
        return lateral_derivatives(x, np.array([steer, vx]), snow.front.mu(af), snow.rear.mu(ar), v)

    sol = solve_ivp(rhs, (0, 10.0), [0.0, 0.0], rtol=1e-10, atol=1e-12, t_eval=np.arange(0, 10.001, 1.0))
    np.testing.assert_allclose(states[::500, [S.VY, S.YAW_RATE]], sol.y.T, atol=1e-7)
    # the excitation reaches the nonlinear part of the snow curve
    af, _ = slip_angles(12.0, states[:, S.VY], states[:, S.YAW_RATE], 0.0, v)
    assert np.abs(af).max() > 0.03


def test_rk4_convergence_order_is_four():
    v = PRESETS["suv"]
    snow = surface_from_preset("snow")
    T = 4.0
    ref, _ = _lateral_run(1 / 4000, T, v, snow, k_r=0.2)
    errs = []
    for rate in (50, 100, 200):
        s, _ = _lateral_run(1 / rate, T, v, snow, k_r=0.2)
        errs.append(np.abs(s[-1, :2] - ref[-1, :2]).max())
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all((orders > 3.6) & (orders < 4.4)), orders


def test_planar_integrator_matches_adaptive_solver_with_fixed_torques():
    """Open-loop run: constant steer and drive torque (speed controller gains zero)."""
    v = PRESETS["sedan"]
    surf = surface_from_preset("wet_asphalt")
    table, peaks = tire_table([surf])
    tires = PlanarTires(surf.front, surf.rear, surf.front_long, surf.rear_long)
    dt, T = 1e-3, 3.0
    n = round(T / dt)
    a_cmd = 1.5
    torque = v.mass * a_cmd * v.wheel_radius
    steer0 = 0.03
    S = engine.PlanarSimState
    x0 = np.zeros(S.SIZE)
    x0[S.VX] = 15.0
    x0[S.OMEGA_F] = x0[S.OMEGA_R] = 15.0 / v.wheel_radius
    p = engine.PlanarParams(
        mass=v.mass, yaw_inertia=v.yaw_inertia, lf=v.lf, lr=v.lr, cg_height=v.cg_height,
        wheel_radius=v.wheel_radius, wheel_inertia=2 * v.wheel_inertia, v_eps=0.5, gravity=GRAVITY,
        omega_eps=OMEGA_EPS, max_steer=v.max_steer,
    ).vector()
    z = np.zeros(n + 1)
    share = axle_torques(1.0, 0.0, v)[0]
    states, ctrl, _, _ = engine.integrate_planar(
        x0, dt, n,
        engine.PlanarModel(p, table, peaks, lam_wheel=1e3, lam_body=1e2),
        0,
        engine.SteerReference(steer_ff=z + steer0, rref=z, v_ref=z, a_ref=z + a_cmd, k_r=0.0),
        engine.PursuitPath(np.zeros(1), np.zeros(1), np.zeros(1), lookahead0=0.0, lookahead_gain=0.0,
                           speed_preview=0.0),
        engine.SpeedControl(kp=0.0, ki=0.0, drive_front=share, brake_front=0.65, max_drive=1e9, max_brake=1e9),
        _field(ConstantFriction(surf.label)),
    )
    np.testing.assert_allclose(ctrl[:-1, engine.C_DRIVE_F] + ctrl[:-1, engine.C_DRIVE_R], torque)

    def rhs(t, x):
        return planar_derivatives(x, np.array([steer0, torque, 0.0]), v, tires)

    sol = solve_ivp(rhs, (0, T), x0[:S.X], method="Radau", rtol=1e-10, atol=1e-10, t_eval=[1.0, 2.0, 3.0])
    np.testing.assert_allclose(states[[1000, 2000, 3000], :S.X], sol.y.T, rtol=1e-6, atol=1e-6)
    assert states[-1, S.VX] > 15.0 + 0.5 * a_cmd * T  # it accelerated


def test_surface_index_matches_numpy_fields():
    rng = np.random.default_rng(0)
    t = rng.uniform(0, 30, 500)
    x = rng.uniform(-6, 6, 500)
    y = rng.uniform(-4, 4, 500)
    fields = [
        ConstantFriction("a"),
        PiecewiseTime((0.0, 10.0, 20.0), ("a", "b", "a")),
        PatchFriction("a", (Patch(0, 3, 0, 2, "b"), Patch(2, 5, 1, 3, "c"), Patch(-5, -1, -3, 0, "b"))),
    ]
    for f in fields:
        code = _field(f)
        got = np.array([engine.field_surface(code, ti, xi, yi) for ti, xi, yi in zip(t, x, y, strict=True)])
        np.testing.assert_array_equal(got, f.labels_at(t, x, y))
        e = f.encode()  # the flat form the kernels' field_surface unpacks
        flat = np.array([engine.surface_index(e["mode"], ti, xi, yi, e["times"], e["time_idx"], e["rects"],
                                              e["rect_idx"], e["n_rects"], e["base"])
                         for ti, xi, yi in zip(t, x, y, strict=True)])
        np.testing.assert_array_equal(flat, got)
