"""Reader for the DART JetRacer recordings (``../shared/data/dart``).

One CSV per run (Lyons et al., TU Delft 2024). Conversions, all recorded in
``meta.extra['conversions']``:

* Padding rows (``elapsed time sensors == 0``) are dropped.
* The onboard sensors update at 10 Hz while rows are written at the ~100 Hz of
  the motion capture, the sensor columns being sample-and-hold. Only the rows
  at which the sensor clock advances are kept (one row per sensor update,
  ~10 Hz), so no sample is repeated.
* The pose is interpolated from the full ~100 Hz motion-capture stream at the
  sensor times mapped to the motion-capture clock by the median offset between
  the two clocks at the update rows (the offset scatters by about +-5 ms; taking
  the pose of the update row instead would misplace it where the logger
  stalled, by up to ~0.3 m). Rows the logger wrote in a burst after a stall,
  all with nearly the same stamp, are re-timed first
  (:func:`repair_burst_stamps`); rows still not later than their predecessor
  are dropped from the pose stream.
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
  ``vicon_t`` [s] (the motion-capture time of the pose, relative to
  ``meta.extra['vicon_epoch_s']``), ``logger_stall`` (1.0 on the first sample
  after missed sensor updates; around these the two clocks disagree and the
  pose can be off by a few tenths of a metre).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from roadgrip.drive import Drive, DriveValidationError
from roadgrip.io._csv import read_csv_numbers
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


def repair_burst_stamps(tv: np.ndarray, burst: float = 0.3) -> tuple[np.ndarray, int]:
    """Re-time rows written in a burst after a logger stall.

    After a stall the logger writes the queued motion-capture rows at once and
    stamps them all with (nearly) the same time, while their poses still advance
    at the nominal cadence. A row whose stamp is less than ``burst`` nominal
    steps before the next one belongs to such a burst; each burst is re-timed at
    the nominal step backwards from the first regular row after it.

    Parameters
    ----------
    tv : ndarray, shape (n,)
        Stamps [s].
    burst : float
        Threshold as a fraction of the median step.

    Returns
    -------
    t : ndarray, shape (n,)
        Repaired stamps.
    n_fixed : int
        Number of re-timed rows.
    """
    t = np.asarray(tv, dtype=float).copy()
    if len(t) < 3:
        return t, 0
    d = np.diff(t)
    step = float(np.median(d))
    in_burst = np.r_[d < burst * step, False]
    n_fixed = 0
    k = 0
    n = len(t)
    while k < n:
        if not in_burst[k]:
            k += 1
            continue
        j = k
        while j < n and in_burst[j]:
            j += 1
        # rows k..j-1 are stamped in a burst; row j closes it (if it exists)
        if j < n:
            t[k:j] = t[j] - (j - np.arange(k, j)) * step
            n_fixed += j - k
        k = j + 1
    return t, n_fixed


def _vicon_stream(raw: pd.DataFrame) -> dict[str, np.ndarray]:
    """Motion-capture rows, burst stamps repaired, strictly increasing; yaw unwrapped."""
    tv, n_fixed = repair_burst_stamps(raw["vicon time"].to_numpy(float))
    keep = np.isfinite(tv) & (tv > np.maximum.accumulate(np.r_[-np.inf, tv[:-1]]))
    if keep.sum() < 2:
        raise ValueError("DART recording: fewer than 2 motion-capture samples")
    return {
        "t": tv[keep],
        "x": raw["vicon x"].to_numpy(float)[keep],
        "y": raw["vicon y"].to_numpy(float)[keep],
        "psi": np.unwrap(raw["vicon yaw"].to_numpy(float)[keep]),
        "n_fixed": n_fixed,
        "n_dropped": int((~keep).sum()),
    }


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
        x, y, psi`` and extras ``throttle, steer_cmd, vicon_t, logger_stall``.
    """
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{path} is a folder; a DART run is one CSV file")
    if not path.is_file():
        raise ValueError(f"no such file: {path}")
    veh = load_vehicle(vehicle if vehicle is not None else "jetracer")
    raw = read_csv_numbers(path, DART_COLUMNS, path.name)
    missing = [c for c in DART_COLUMNS if c not in raw.columns]
    if missing:
        raise ValueError(f"{path.name} is not a DART recording: missing column(s) {missing}")
    n_raw = len(raw)
    vicon = _vicon_stream(raw)
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

    # pose at the sensor times, on the motion-capture clock
    clock_offset = float(np.median(r["vicon time"].to_numpy(float) - t_sens))
    tq = t_sens + clock_offset
    tv = vicon["t"]
    if tq[0] < tv[0] - 0.05 or tq[-1] > tv[-1] + 0.05:
        raise ValueError(f"{path.name}: the motion-capture stream does not cover the sensor samples")
    psi_track = np.interp(tq, tv, vicon["psi"])
    back = TRACKED_POINT_FROM_REAR - veh.lr  # tracked point is this far ahead of the CG
    x = np.interp(tq, tv, vicon["x"]) - back * np.cos(psi_track)
    y = np.interp(tq, tv, vicon["y"]) - back * np.sin(psi_track)
    vx = r["vel encoder"].to_numpy(float)
    omega = vx / veh.wheel_radius
    vicon_epoch = float(tq[0])
    # samples right after missed sensor updates (logger stalls): pose timing uncertain there
    dts = np.diff(t_sens)
    stall = np.r_[0.0, (dts > 1.5 * np.median(dts)).astype(float)]
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
            "vicon_t": tq - vicon_epoch,
            "logger_stall": stall,
        }
    )
    extra = {
        "format": "dart",
        "sensor_clock_offset_s": float(t_sens[0]),
        "vicon_epoch_s": vicon_epoch,
        "vicon_minus_sensor_clock_s": clock_offset,
        "vicon_rows_retimed": int(vicon["n_fixed"]),
        "vicon_rows_dropped": int(vicon["n_dropped"]),
        "rows_raw": int(n_raw),
        "padding_rows_dropped": int(n_pad),
        "rows_kept": len(df),
        "conversions": {
            "sampling": "one row per 10 Hz sensor update (the sample-and-hold repeats at the "
            "~100 Hz motion-capture rows are dropped); pose interpolated from the ~100 Hz "
            "motion capture at the sensor times (median clock offset)",
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
    try:
        return Drive.from_frame(df, veh, source=str(path), extra=extra)
    except DriveValidationError as exc:  # name the file, as the other readers do
        raise DriveValidationError(f"{path.name}: {exc}") from None
