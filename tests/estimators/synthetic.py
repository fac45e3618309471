"""A small independent single-track simulation with brush tires, for the cascade tests.

Constant-speed-tracking planar model (states vx, vy, r, pose), Euler with 10 sub-steps
per output sample, front-wheel longitudinal force from a speed controller.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from roadgrip.constants import GRAVITY
from roadgrip.drive import Drive
from roadgrip.tire import brush_force
from roadgrip.vehicle.params import PRESETS, VehicleParams


def simulate_brush(
    mu=0.6,
    duration=60.0,
    rate=100.0,
    speed=3.0,
    steer_amp=0.25,
    steer_freq=0.4,
    seed=0,
    vehicle: VehicleParams | None = None,
    noise=(0.05, 0.005, 0.02),
    mu_of_xy=None,
):
    """Simulated drive with truth columns; ``mu`` constant or ``mu_of_xy(x, y)``."""
    veh = vehicle or PRESETS["f1tenth"]
    rng = np.random.default_rng(seed)
    m, iz, lf, lr, h = veh.mass, veh.yaw_inertia, veh.lf, veh.lr, veh.cg_height
    kf = veh.cornering_stiffness_front / veh.fz_front
    kr = veh.cornering_stiffness_rear / veh.fz_rear
    n = int(duration * rate)
    sub = 10
    dt = 1.0 / rate / sub
    vx, vy, r, x, y, psi = speed, 0.0, 0.0, 0.0, 0.0, 0.0
    ax_prev = 0.0
    rows = []
    for k in range(n):
        t = k / rate
        for j in range(sub):
            tt = t + j * dt
            delta = steer_amp * np.sin(2 * np.pi * steer_freq * tt) * (0.6 + 0.4 * np.sin(0.05 * tt))
            mu_here = mu if mu_of_xy is None else mu_of_xy(x, y)
            dfz = m * ax_prev * h / veh.wheelbase
            fzf = m * GRAVITY * lr / veh.wheelbase - dfz
            fzr = m * GRAVITY * lf / veh.wheelbase + dfz
            af = delta - np.arctan((vy + lf * r) / vx)
            ar = -np.arctan((vy - lr * r) / vx)
            fyf = float(brush_force(af, fzf, mu_here, kf))
            fyr = float(brush_force(ar, fzr, mu_here, kr))
            fxf = 2.0 * m * (speed - vx) + fyf * np.sin(delta)
            axs = (fxf * np.cos(delta) - fyf * np.sin(delta)) / m
            ays = (fxf * np.sin(delta) + fyf * np.cos(delta) + fyr) / m
            ax_prev = axs
            rdot = (lf * (fxf * np.sin(delta) + fyf * np.cos(delta)) - lr * fyr) / iz
            if j == 0:
                rows.append((t, axs, ays, r, delta, vx, vy, af, ar, fxf, fyf, fyr, fzf, fzr, mu_here, x, y, psi))
            vx, vy, r = vx + dt * (axs + vy * r), vy + dt * (ays - vx * r), r + dt * rdot
            x += dt * (vx * np.cos(psi) - vy * np.sin(psi))
            y += dt * (vx * np.sin(psi) + vy * np.cos(psi))
            psi += dt * r
    a = np.array(rows)
    sa, sr, sv = noise
    df = pd.DataFrame({
        "t": a[:, 0],
        "ax": a[:, 1] + rng.normal(0, sa, n),
        "ay": a[:, 2] + rng.normal(0, sa, n),
        "yaw_rate": a[:, 3] + rng.normal(0, sr, n),
        "steer": a[:, 4],
        "vx": a[:, 5] + rng.normal(0, sv, n),
        "x": a[:, 15], "y": a[:, 16], "psi": a[:, 17],
        "vx_true": a[:, 5], "vy_true": a[:, 6], "yaw_rate_true": a[:, 3],
        "alpha_f_true": a[:, 7], "alpha_r_true": a[:, 8],
        "Fxf_true": a[:, 9], "Fyf_true": a[:, 10], "Fyr_true": a[:, 11],
        "Fzf_true": a[:, 12], "Fzr_true": a[:, 13], "mu_true": a[:, 14],
    })
    return Drive.from_frame(df, veh, source="test:brush-single-track", truth={"mu": mu})
