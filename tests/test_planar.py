"""Planar single-track model: reductions, bounds, low speed, and the compiled port."""

from __future__ import annotations

import numpy as np
import pytest

from roadgrip.constants import GRAVITY
from roadgrip.signals import axle_loads
from roadgrip.sim import engine
from roadgrip.sim.friction import brush_surface, surface_from_preset, tire_table
from roadgrip.tire import SURFACES
from roadgrip.vehicle import PRESETS
from roadgrip.vehicle.lateral import lateral_derivatives
from roadgrip.vehicle.planar import (
    OMEGA_EPS,
    PlanarInput,
    PlanarState,
    PlanarTires,
    axle_torques,
    free_rolling_omegas,
    planar_derivatives,
    planar_forces,
    wheel_speeds,
)

S = PlanarState


def _tires(name: str = "dry_asphalt") -> PlanarTires:
    s = SURFACES[name]
    return PlanarTires(s.lateral, s.lateral, s.longitudinal, s.longitudinal)


def _random_states(rng, n, vehicle, vmin=2.0, vmax=30.0):
    vx = rng.uniform(vmin, vmax, n)
    vy = rng.normal(0, 0.05 * vx)
    r = rng.normal(0, 0.3, n)
    kf = rng.normal(0, 0.1, n)
    kr = rng.normal(0, 0.1, n)
    x = np.stack([vx, vy, r, vx * (1 + kf) / vehicle.wheel_radius, vx * (1 + kr) / vehicle.wheel_radius], -1)
    return x


def test_straight_rolling_is_an_equilibrium():
    p = PRESETS["sedan"]
    x = np.array([20.0, 0.0, 0.0, 20.0 / p.wheel_radius, 20.0 / p.wheel_radius])
    np.testing.assert_allclose(planar_derivatives(x, np.zeros(3), p, _tires()), 0.0, atol=1e-12)


@pytest.mark.parametrize("preset,surface", [("suv", "snow"), ("sedan", "gravel"), ("sedan", "dry_asphalt")])
def test_reduces_to_lateral_model_with_zero_torque_and_free_rolling(preset, surface):
    """Zero torques, free-rolling axles (kappa = 0), no load transfer: eq. 1 of paper 000."""
    p = PRESETS[preset].replace(cg_height=1e-9)
    rng = np.random.default_rng(0)
    n = 200
    vx = rng.uniform(3, 25, n)
    vy = rng.normal(0, 0.3, n)
    r = rng.normal(0, 0.3, n)
    steer = rng.normal(0, 0.05, n)
    wf, wr = free_rolling_omegas(vx, vy, r, steer, p)
    x = np.stack([vx, vy, r, wf, wr], -1)
    u = np.stack([steer, np.zeros(n), np.zeros(n)], -1)
    tires = _tires(surface)
    d = planar_derivatives(x, u, p, tires)
    f = planar_forces(x, steer, p, tires)
    np.testing.assert_allclose(f.kappa_f, 0.0, atol=1e-12)
    np.testing.assert_allclose(f.kappa_r, 0.0, atol=1e-12)
    mu_f, mu_r = tires.front.mu(f.alpha_f), tires.rear.mu(f.alpha_r)
    ref = lateral_derivatives(np.stack([vy, r], -1), np.stack([steer, vx], -1), mu_f, mu_r, p)
    np.testing.assert_allclose(d[:, S.VY], ref[:, 0], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(d[:, S.YAW_RATE], ref[:, 1], rtol=1e-9, atol=1e-9)


def test_friction_ellipse_bounds_the_forces():
    p = PRESETS["sedan"]
    rng = np.random.default_rng(1)
    x = _random_states(rng, 5000, p)
    x[:, S.VY] = rng.normal(0, 3.0, 5000)  # large slip angles too
    steer = rng.uniform(-0.5, 0.5, 5000)
    tires = _tires("gravel")
    f = planar_forces(x, steer, p, tires)
    dx, dy = tires.front_long.peak()[1], tires.front.peak()[1]
    assert np.all((f.mux_f / dx) ** 2 + (f.muy_f / dy) ** 2 <= 1 + 1e-12)
    assert np.all(np.abs(f.muy_r) <= dy + 1e-12)
    # the ellipse is active somewhere, and pure lateral slip is untouched where it is not
    rho = np.hypot(tires.front_long.mu(f.kappa_f) / dx, tires.front.mu(f.alpha_f) / dy)
    assert (rho > 1).any() and (rho < 1).any()
    inside = rho < 1
    np.testing.assert_allclose(f.muy_f[inside], tires.front.mu(f.alpha_f[inside]))


def test_load_transfer_matches_signals_axle_loads_and_sums_to_weight():
    p = PRESETS["sedan"]
    rng = np.random.default_rng(2)
    x = _random_states(rng, 500, p)
    f = planar_forces(x, np.zeros(500), p, _tires())
    np.testing.assert_allclose(f.fzf + f.fzr, p.mass * GRAVITY, rtol=1e-12)
    fzf, fzr = axle_loads(p, f.ax)
    np.testing.assert_allclose(f.fzf, fzf)
    np.testing.assert_allclose(f.fzr, fzr)
    # the solved ax is consistent with the forces it produces
    np.testing.assert_allclose(f.ax, (f.fxf + f.fxr) / p.mass, rtol=1e-10, atol=1e-10)
    # braking moves load forward
    assert np.corrcoef(f.ax, f.fzf)[0, 1] < -0.99


def test_drive_torque_accelerates_and_brake_decelerates():
    p = PRESETS["sedan"]
    x = np.array([15.0, 0.0, 0.0, 15.0 / p.wheel_radius, 15.0 / p.wheel_radius])
    d_drive = planar_derivatives(x, np.array([0.0, 500.0, 0.0]), p, _tires())
    d_brake = planar_derivatives(x, np.array([0.0, 0.0, 800.0]), p, _tires())
    # torque spins up the driven (front) wheel only at first; brakes slow both
    assert d_drive[S.OMEGA_F] > 0 and d_drive[S.OMEGA_R] == 0
    assert d_brake[S.OMEGA_F] < 0 and d_brake[S.OMEGA_R] < 0
    tdf, tdr, tbf, tbr = axle_torques(500.0, 800.0, p)
    assert (tdf, tdr) == (500.0, 0.0)
    assert tbf + tbr == pytest.approx(800.0)


@pytest.mark.parametrize("vx", [0.5, 0.1, 0.0])
def test_finite_at_low_speed_and_standstill(vx):
    p = PRESETS["sedan"]
    rng = np.random.default_rng(3)
    x = np.array([vx, 0.0, 0.0, 0.0, 0.0]) + np.stack(
        [np.zeros(50), rng.normal(0, 0.2, 50), rng.normal(0, 0.2, 50), rng.normal(0, 5, 50), rng.normal(0, 5, 50)], -1)
    u = np.stack([rng.normal(0, 0.3, 50), rng.uniform(0, 500, 50), rng.uniform(0, 2000, 50)], -1)
    d = planar_derivatives(x, u, p, _tires())
    assert np.all(np.isfinite(d))
    f = planar_forces(x, u[:, 0], p, _tires())
    # |R w - v| <= 2 max(|v|, |R w|): the regularised slip stays within [-2, 2]
    assert np.all(np.abs(f.kappa_f) <= 2.0) and np.all(np.abs(f.kappa_r) <= 2.0)


def test_brake_friction_is_continuous_at_zero_spin():
    p = PRESETS["sedan"]
    eps = 1e-9
    xp = np.array([0.0, 0.0, 0.0, eps, eps])
    xm = np.array([0.0, 0.0, 0.0, -eps, -eps])
    u = np.array([0.0, 0.0, 1000.0])
    np.testing.assert_allclose(planar_derivatives(xp, u, p, _tires()), planar_derivatives(xm, u, p, _tires()), atol=1e-3)
    assert OMEGA_EPS > 0


def test_vectorised_equals_loop():
    p = PRESETS["suv"]
    rng = np.random.default_rng(4)
    x = _random_states(rng, 20, p).reshape(4, 5, 5)
    u = np.stack([rng.normal(0, 0.1, 20), rng.uniform(0, 300, 20), rng.uniform(0, 300, 20)], -1).reshape(4, 5, 3)
    d = planar_derivatives(x, u, p, _tires("snow"))
    assert d.shape == (4, 5, 5)
    for i in range(4):
        for j in range(5):
            np.testing.assert_allclose(d[i, j], planar_derivatives(x[i, j], u[i, j], p, _tires("snow")))


@pytest.mark.parametrize("which", ["mf", "brush"])
def test_compiled_rhs_matches_numpy_reference(which):
    p = PRESETS["f1tenth"] if which == "brush" else PRESETS["sedan"]
    surf = brush_surface("b", 0.7, p) if which == "brush" else surface_from_preset("wet_asphalt")
    tires = PlanarTires(surf.front, surf.rear, surf.front_long, surf.rear_long)
    table, peaks = tire_table([surf])
    pv = np.zeros(engine.P_SIZE)
    pv[engine.P_MASS], pv[engine.P_IZ] = p.mass, p.yaw_inertia
    pv[engine.P_LF], pv[engine.P_LR], pv[engine.P_H] = p.lf, p.lr, p.cg_height
    pv[engine.P_R], pv[engine.P_IW] = p.wheel_radius, 2 * p.wheel_inertia
    pv[engine.P_VEPS], pv[engine.P_G], pv[engine.P_WEPS] = 0.5, GRAVITY, OMEGA_EPS
    rng = np.random.default_rng(5)
    x = _random_states(rng, 300, p, 0.3, 20.0)
    u = np.stack([rng.normal(0, 0.1, 300), rng.uniform(0, 50, 300) * p.mass * p.wheel_radius / 10,
                  rng.uniform(0, 50, 300) * p.mass * p.wheel_radius / 10], -1)
    ref = planar_derivatives(x, u, p, tires)
    tdf, tdr, tbf, tbr = axle_torques(u[:, PlanarInput.DRIVE_TORQUE], u[:, PlanarInput.BRAKE_TORQUE], p)
    out = np.zeros(engine.PlanarSimState.SIZE)
    for i in range(300):
        s = np.zeros(engine.PlanarSimState.SIZE)
        s[:5] = x[i]
        engine.planar_rhs(s, u[i, 0], tdf[i], tdr[i], tbf[i], tbr[i], table[0], peaks[0], pv, out)
        np.testing.assert_allclose(out[:5], ref[i], rtol=1e-9, atol=1e-9)


def test_wheel_speeds_mean_and_split():
    p = PRESETS["sedan"]
    fl, fr, rl, rr = wheel_speeds(50.0, 48.0, 0.4, 0.1, p)
    assert (fl + fr) / 2 == pytest.approx(50.0) and (rl + rr) / 2 == pytest.approx(48.0)
    assert fr - fl == pytest.approx(0.4 * p.track_width * np.cos(0.1) / p.wheel_radius)
    assert rr - rl == pytest.approx(0.4 * p.track_width / p.wheel_radius)
    assert PlanarState.SIZE == 5 and PlanarInput.SIZE == 3
