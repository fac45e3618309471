"""Lateral-only single-track model (paper 000, eq. 1-2) against linear analytics."""

from __future__ import annotations

import numpy as np
import pytest

from roadgrip.constants import GRAVITY
from roadgrip.tire import LinearTire
from roadgrip.vehicle import (
    PRESETS,
    lateral_derivatives,
    lateral_discrete,
    lateral_measurement,
    slip_angles,
    steady_state_linear,
)


def _steady_state(params, steer, vx, t_end=None, dt=None):
    """Integrate eq. 1 with linear tires (RK4) to steady state; return [vy, r]."""
    tf = LinearTire(params.cornering_stiffness_front / params.fz_front)
    tr = LinearTire(params.cornering_stiffness_rear / params.fz_rear)

    def f(x):
        af, ar = slip_angles(vx, x[0], x[1], steer, params, v_eps=0.0)
        return lateral_derivatives(x, np.array([steer, vx]), tf.mu(af), tr.mu(ar), params)

    # time scale of the yaw/sideslip modes ~ m vx / (Cf + Cr)
    tau = max(params.mass * vx / (params.cornering_stiffness_front + params.cornering_stiffness_rear),
              params.yaw_inertia * vx / (params.cornering_stiffness_front * params.lf**2
                                         + params.cornering_stiffness_rear * params.lr**2))
    dt = dt or tau / 20
    n = int((t_end or 150 * tau) / dt)
    x = np.zeros(2)
    for _ in range(n):
        k1 = f(x)
        k2 = f(x + dt / 2 * k1)
        k3 = f(x + dt / 2 * k2)
        k4 = f(x + dt * k3)
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert np.allclose(f(x), 0.0, atol=1e-9), "not converged"
    return x


CASES = [("sedan", 10.0), ("sedan", 25.0), ("suv", 20.0), ("f1tenth", 3.0), ("jetracer", 2.0)]


@pytest.mark.parametrize(("name", "vx"), CASES)
def test_steady_state_yaw_rate_matches_linear_analytic(name, vx):
    p = PRESETS[name]
    steer = 0.01
    _, r = _steady_state(p, steer, vx)
    assert r == pytest.approx(float(steady_state_linear(steer, vx, p)), rel=0.02)


@pytest.mark.parametrize(("name", "vx", "front_scale"), [("sedan", 20.0, 0.6), ("suv", 15.0, 0.7),
                                                         ("sedan", 20.0, 1.5), ("f1tenth", 3.0, 1.0)])
def test_steady_state_understeer_gradient(name, vx, front_scale):
    # the sedan and SUV presets are neutral (equal normalised stiffness front and
    # rear); scale the front stiffness to get understeer (< 1) or oversteer (> 1)
    base = PRESETS[name]
    p = base.replace(cornering_stiffness_front=base.cornering_stiffness_front * front_scale)
    steer = 0.01
    _, r = _steady_state(p, steer, vx)
    ay = vx * r
    k_measured = (steer - p.wheelbase * r / vx) / ay  # delta = l/R + K ay
    assert abs(p.understeer_gradient) > 1e-4
    assert k_measured == pytest.approx(p.understeer_gradient, rel=0.02)


def test_derivatives_match_hand_computation():
    p = PRESETS["sedan"]
    x = np.array([0.3, 0.2])
    u = np.array([0.05, 15.0])
    d = lateral_derivatives(x, u, 0.4, 0.3, p, mu_xf=0.1)
    fyf = p.fz_front * (0.4 * np.cos(0.05) + 0.1 * np.sin(0.05))
    fyr = p.fz_rear * 0.3
    assert d[0] == pytest.approx(-15.0 * 0.2 + (fyf + fyr) / p.mass)
    assert d[1] == pytest.approx((p.lf * fyf - p.lr * fyr) / p.yaw_inertia)


def test_vectorised_over_batch():
    p = PRESETS["suv"]
    rng = np.random.default_rng(2)
    x = rng.normal(size=(7, 2))
    u = np.column_stack([rng.normal(0, 0.05, 7), rng.uniform(5, 30, 7)])
    mf, mr = rng.normal(0, 0.2, 7), rng.normal(0, 0.2, 7)
    batch = lateral_derivatives(x, u, mf, mr, p)
    single = np.array([lateral_derivatives(x[i], u[i], mf[i], mr[i], p) for i in range(7)])
    assert np.allclose(batch, single)


def test_discrete_is_forward_euler_of_derivatives():
    p = PRESETS["sedan"]
    rng = np.random.default_rng(4)
    x = rng.normal(size=(5, 2))
    u = np.column_stack([rng.normal(0, 0.05, 5), rng.uniform(5, 30, 5)])
    mu = rng.normal(0, 0.3, (5, 2))
    dt = 0.01
    a, G = lateral_discrete(x, u, p, dt)
    nxt = a + np.einsum("nij,nj->ni", G, mu)
    assert np.allclose(nxt, x + dt * lateral_derivatives(x, u, mu[:, 0], mu[:, 1], p))


def test_measurement_is_force_over_mass():
    p = PRESETS["sedan"]
    x = np.array([0.3, 0.2])
    u = np.array([0.05, 15.0])
    mu = np.array([0.4, 0.3])
    h, D = lateral_measurement(x, u, p)
    y = h + D @ mu
    d = lateral_derivatives(x, u, mu[0], mu[1], p)
    assert y[0] == pytest.approx(d[0] + u[1] * x[1])  # ay = dvy/dt + vx r
    assert y[1] == x[1]
    # a steady 0.3 g corner: ay equals mu g when both axles use mu
    h, D = lateral_measurement(np.zeros(2), np.array([0.0, 20.0]), p)
    assert (D @ np.array([0.3, 0.3]))[0] == pytest.approx(0.3 * GRAVITY)
