"""Output of the Kalman cascade: the estimates table from the kernel's rows, the summary, diagnostics."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from roadgrip.constants import Z95
from roadgrip.estimators.cascade.kernel import Out

__all__ = ["diagnostics", "output_columns", "summary"]


def output_columns(out: NDArray[np.float64], t: NDArray[np.float64],
                   pose: tuple[NDArray[np.float64], ...] | None, lf: float, lr: float,
                   floor: NDArray[np.float64] | None = None,
                   now: NDArray[np.float64] | None = None) -> dict[str, NDArray]:
    """Columns of the estimates table from kernel rows ``out`` (n, Out.SIZE) at times ``t`` [s].

    The contract columns (:data:`roadgrip.estimators.base.CONTRACT_COLUMNS`;
    the 95 % band is ``mu ± Z95 std``, clipped at 0, its upper end at least the
    friction the car demonstrably used, ``floor``: the largest levelled
    ``|a_y| / g`` sustained for a second so far, :func:`roadgrip.signals.sustained_grip`,
    column ``grip_floor``), the friction it uses now, ``now`` (the ``|a_y| / g`` of the
    last second, :func:`roadgrip.signals.current_grip`, column ``grip_now``: the floor
    of lower bounds, which must forget a surface the car has left) and the stage
    estimates.
    With ``pose = (x, y[, psi])`` [m, m, rad] the positions ``x, y`` and, with
    the heading, the axle positions ``x_front, y_front, x_rear, y_rear``
    (``lf``, ``lr`` [m] from the CG), which the friction grid uses.
    """
    std_f = np.sqrt(out[:, Out.VAR_F])
    std_r = np.sqrt(out[:, Out.VAR_R])
    exc_f = out[:, Out.EXC_F] > 0.5
    exc_r = out[:, Out.EXC_R] > 0.5
    floor = np.zeros(len(t)) if floor is None else np.asarray(floor, dtype=float)
    now = np.zeros(len(t)) if now is None else np.asarray(now, dtype=float)
    tab = {
        "t": t,
        "mu_front": out[:, Out.MU_F],
        "mu_rear": out[:, Out.MU_R],
        "mu_front_lower": np.maximum(out[:, Out.MU_F] - Z95 * std_f, 0.0),
        "mu_front_upper": np.maximum(out[:, Out.MU_F] + Z95 * std_f, floor),
        "mu_rear_lower": np.maximum(out[:, Out.MU_R] - Z95 * std_r, 0.0),
        "mu_rear_upper": np.maximum(out[:, Out.MU_R] + Z95 * std_r, floor),
        "grip_floor": floor,
        "grip_now": now,
        "excited": exc_f | exc_r,
        "vx": out[:, Out.VX],
        "vy": out[:, Out.VY],
        "yaw_rate_est": out[:, Out.YAW_RATE],
        "Fxf": out[:, Out.FXF],
        "Fyf": out[:, Out.FYF],
        "Fyr": out[:, Out.FYR],
        "Fx_front": out[:, Out.FX_F],
        "Fx_rear": out[:, Out.FX_R],
        "Fyf_std": np.sqrt(out[:, Out.FYF_VAR]),
        "Fyr_std": np.sqrt(out[:, Out.FYR_VAR]),
        "alpha_f": out[:, Out.ALPHA_F],
        "alpha_r": out[:, Out.ALPHA_R],
        "alpha_f_std": np.sqrt(out[:, Out.ALPHA_F_VAR]),
        "alpha_r_std": np.sqrt(out[:, Out.ALPHA_R_VAR]),
        "force_noise_front": np.sqrt(out[:, Out.R3_F]),
        "force_noise_rear": np.sqrt(out[:, Out.R3_R]),
        "Fzf": out[:, Out.FZF],
        "Fzr": out[:, Out.FZR],
        "mu_front_std": std_f,
        "mu_rear_std": std_r,
        "excited_front": exc_f,
        "excited_rear": exc_r,
        "mu_front_obs": out[:, Out.OBS_F],
        "mu_front_obs_std": np.sqrt(out[:, Out.OBS_VAR_F]),
        "mu_rear_obs": out[:, Out.OBS_R],
        "mu_rear_obs_std": np.sqrt(out[:, Out.OBS_VAR_R]),
        "mu_front_obs_sys": out[:, Out.SYS_F],
        "mu_rear_obs_sys": out[:, Out.SYS_R],
        "vx_ekf": out[:, Out.VX_EKF],
        "vy_ekf": out[:, Out.VY_EKF],
    }
    if pose is not None:
        x, y, *heading = pose
        tab["x"], tab["y"] = x, y
        if heading:
            c, s = np.cos(heading[0]), np.sin(heading[0])
            tab["x_front"], tab["y_front"] = x + lf * c, y + lf * s
            tab["x_rear"], tab["y_rear"] = x - lr * c, y - lr * s
    return tab


def summary(row: Mapping[str, Any]) -> dict[str, float]:
    """VSS-style summary of one output row: both axles combined by inverse-variance weights.

    ``MostProbable`` is the weighted mean of ``mu_front`` and ``mu_rear``,
    the bounds ``± Z95`` of its standard deviation; the upper bound at least the row's
    ``grip_floor`` (the friction the car demonstrably used, 0 without), the lower bound
    and the most probable value at least its ``grip_now`` (the friction it uses on the
    present surface).
    """
    wf, wr = 1.0 / row["mu_front_std"] ** 2, 1.0 / row["mu_rear_std"] ** 2
    mp = (wf * row["mu_front"] + wr * row["mu_rear"]) / (wf + wr)
    sd = 1.0 / np.sqrt(wf + wr)
    floor = float(row.get("grip_floor", 0.0))
    lo = max(mp - Z95 * sd, float(row.get("grip_now", 0.0)), 0.0)
    return {"MostProbable": float(max(mp, lo)), "LowerBound": float(lo),
            "UpperBound": float(max(mp + Z95 * sd, floor))}


def diagnostics(table: pd.DataFrame, out: NDArray[np.float64], derived: Mapping[str, Any]) -> dict[str, Any]:
    """Run diagnostics for the report: inputs used, excitation, filter consistency and health."""
    noise = derived["noise"]
    return {
        "speed source": derived["speed_source"],
        "accel noise std [m/s2]": noise["accel_std"],
        "gyro noise std [rad/s]": noise["gyro_std"],
        "speed noise std [m/s]": noise["speed_std"],
        "excited front [%]": float(100 * table["excited_front"].mean()),
        "excited rear [%]": float(100 * table["excited_rear"].mean()),
        "mean NIS stage 2 (5 dof)": float(np.mean(out[:, Out.NIS2])),
        "covariance repairs": int(out[:, Out.REPAIRS].sum()),
        "samples with all covariances positive definite [%]": float(100 * out[:, Out.PD_OK].mean()),
    }
