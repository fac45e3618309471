"""Reader for the DART JetRacer recordings (``../shared/data/dart``).

One CSV per run (Lyons et al., TU Delft 2024). Conversions, all recorded in
``meta.extra['conversions']``:

* Padding rows (``elapsed time sensors == 0``) are dropped.
* The onboard sensors update at 10 Hz while rows are written at the ~100 Hz of
  the motion capture, the sensor columns being sample-and-hold. Only the rows
  at which the sensor clock advances are kept (one row per sensor update,
  ~10 Hz), so no sample is repeated; the pose is the motion-capture sample of
  that row.
* ``t`` is the sensor clock shifted to start at 0 (offset in ``meta.extra``).
* ``ax``, ``ay`` [m/s²] and ``yaw_rate`` [rad/s] are the IMU columns as they
  are (already SI, ISO axes).
* ``steer`` is the front road-wheel angle from the normalised steering command
  through the authors' fitted map (:func:`dart_steer_angle`).
* ``vx`` is the encoder speed (rear driveshaft): it includes the rear-wheel
  spin of this rear-wheel-drive car (up to ~30 %), so it is a wheel speed
  rather than the ground speed. ``omega_rl`` = ``omega_rr`` = ``vx / r``.
* ``x``, ``y``, ``psi``: motion-capture pose moved from the tracked point
  (0.115 m ahead of the rear axle) to the CG (``lr`` ahead of the rear axle);
  ``psi`` is unwrapped (continuous).
* Extra columns: ``throttle`` and ``steer_cmd`` (normalised commands),
  ``vicon_t`` [s] (motion-capture clock, shifted by the same offset as the
  motion-capture start).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from roadgrip.drive import Drive
from roadgrip.io._csv import read_csv_exact
from roadgrip.vehicle.params import VehicleParams, load_vehicle

__all__ = ["DART_COLUMNS", "DART_STEER_FIT", "TRACKED_POINT_FROM_REAR", "dart_steer_angle", "read_dart"]

DART_COLUMNS = (
    "elapsed time sensors",
    "acc x (IMU)",
    "acc y (IMU)",
    "W (IMU)",
    "vel encoder",
    "throttle",
    "steering",
    "vicon time",
    "vicon x",
    "vicon y",
    "vicon yaw",
)

DART_STEER_FIT = {"a": 1.3929, "b": 0.36576, "c": -0.027004, "d": 0.51479, "e": 1.02304}
"""Coefficients of the authors' steering-command -> road-wheel-angle fit."""

TRACKED_POINT_FROM_REAR = 0.115
"""Distance of the motion-capture tracked point ahead of the rear axle [m]."""


def dart_steer_angle(s: np.ndarray) -> np.ndarray:
    """Road-wheel angle from the normalised DART steering command.

    ``w = (tanh(30 (s + c)) + 1) / 2``;
    ``delta = w b tanh(a (s + c)) + (1 - w) d tanh(e (s + c))``
    (asymmetric left/right branches blended smoothly at ``s = -c``).

    Parameters
    ----------
    s : array_like, shape (n,)
        Steering command in [-1, 1], positive left.

    Returns
    -------
    ndarray, shape (n,)
        Front road-wheel angle [rad], positive left.
    """
    p = DART_STEER_FIT
    s = np.asarray(s, dtype=float) + p["c"]
    w = 0.5 * (np.tanh(30.0 * s) + 1.0)
    return w * p["b"] * np.tanh(p["a"] * s) + (1.0 - w) * p["d"] * np.tanh(p["e"] * s)


def is_dart_csv(path: Path) -> bool:
    """Whether ``path`` is a CSV whose header names the DART sensor clock."""
    if not path.is_file():
        return False
    with open(path, errors="replace") as fh:
        return "elapsed time sensors" in fh.readline()


def read_dart(path: str | Path, vehicle: str | Path | VehicleParams | None = None) -> Drive:
    """Read one DART run into a canonical :class:`~roadgrip.drive.Drive`.

    Parameters
    ----------
    path : str or Path
        The run's CSV file.
    vehicle : preset name, YAML path or VehicleParams, optional
        Default ``'jetracer'``.

    Returns
    -------
    Drive
        ~10 Hz samples with ``t, ax, ay, yaw_rate, steer, vx, omega_rl, omega_rr,
        x, y, psi`` and extras ``throttle, steer_cmd, vicon_t``.
    """
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{path} is a folder; a DART run is one CSV file")
    if not path.is_file():
        raise ValueError(f"no such file: {path}")
    veh = load_vehicle(vehicle if vehicle is not None else "jetracer")
    try:
        raw = read_csv_exact(path)
    except pd.errors.EmptyDataError:
        raise ValueError(f"{path.name} is empty") from None
    missing = [c for c in DART_COLUMNS if c not in raw.columns]
    if missing:
        raise ValueError(f"{path.name} is not a DART recording: missing column(s) {missing}")
    n_raw = len(raw)
    ts = raw["elapsed time sensors"].to_numpy(float)
    raw = raw[ts != 0].reset_index(drop=True)
    n_pad = n_raw - len(raw)
    if len(raw) < 2:
        raise ValueError(f"{path.name} has no sensor samples after dropping the padding rows")
    ts = raw["elapsed time sensors"].to_numpy(float)
    # first row of each sensor update (the sensor clock advances)
    keep = np.r_[True, np.diff(ts) > 0]
    r = raw[keep].reset_index(drop=True)
    t_sens = r["elapsed time sensors"].to_numpy(float)
    if (np.diff(t_sens) <= 0).any():
        raise ValueError(f"{path.name}: the sensor clock goes backwards")

    psi_track = np.unwrap(r["vicon yaw"].to_numpy(float))
    back = TRACKED_POINT_FROM_REAR - veh.lr  # tracked point is this far ahead of the CG
    x = r["vicon x"].to_numpy(float) - back * np.cos(psi_track)
    y = r["vicon y"].to_numpy(float) - back * np.sin(psi_track)
    vx = r["vel encoder"].to_numpy(float)
    omega = vx / veh.wheel_radius
    vicon_t = r["vicon time"].to_numpy(float)
    df = pd.DataFrame(
        {
            "t": t_sens - t_sens[0],
            "ax": r["acc x (IMU)"].to_numpy(float),
            "ay": r["acc y (IMU)"].to_numpy(float),
            "yaw_rate": r["W (IMU)"].to_numpy(float),
            "steer": dart_steer_angle(r["steering"].to_numpy(float)),
            "vx": vx,
            "omega_rl": omega,
            "omega_rr": omega,
            "x": x,
            "y": y,
            "psi": psi_track,
            "throttle": r["throttle"].to_numpy(float),
            "steer_cmd": r["steering"].to_numpy(float),
            "vicon_t": vicon_t - vicon_t[0],
        }
    )
    extra = {
        "format": "dart",
        "sensor_clock_offset_s": float(t_sens[0]),
        "vicon_epoch_s": float(vicon_t[0]),
        "rows_raw": int(n_raw),
        "padding_rows_dropped": int(n_pad),
        "rows_kept": len(df),
        "conversions": {
            "sampling": "one row per 10 Hz sensor update (the sample-and-hold repeats at the "
            "~100 Hz motion-capture rows are dropped); pose = motion-capture sample of that row",
            "t": "elapsed time sensors - first value [s]",
            "steer": "road-wheel angle from the steering command, authors' fit "
            f"{DART_STEER_FIT}",
            "vx": "vel encoder (rear driveshaft speed; includes rear-wheel spin, up to ~30 %)",
            "omega_rl/omega_rr": "vel encoder / wheel_radius [rad/s] (driveshaft: both rear wheels)",
            "x/y": f"vicon point moved {back:.4f} m back along the heading to the CG "
            f"(tracked point {TRACKED_POINT_FROM_REAR} m ahead of rear axle, lr = {veh.lr} m)",
            "psi": "vicon yaw, unwrapped",
            "ax/ay/yaw_rate": "IMU columns as recorded (m/s², rad/s, ISO axes)",
        },
    }
    return Drive.from_frame(df, veh, source=str(path), extra=extra)
