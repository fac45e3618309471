"""Reader for the FrictionMaps F1/10 recordings (``../shared/data/frictionmaps``).

One folder ``DSn`` per run, one CSV per ROS topic, each stamped ``s``, ``ns``
and recorded asynchronously at about 18-44 Hz. Conversions, all recorded in
``meta.extra['conversions']``:

* Time ``s + 1e-9 ns`` (Unix epoch); the streams are resampled onto one
  uniform clock (default 50 Hz) spanning the overlap of the required streams,
  shifted to start at 0 (the epoch is kept in ``meta.extra['t0_epoch_s']``).
  Continuous signals are interpolated linearly, the commands held (zero-order
  hold); nothing is extrapolated and gaps longer than ``max_gap`` (0.25 s; DS5
  has gaps of ~1.8 s) are not bridged: those ticks are dropped, so ``t`` then
  jumps over the gap.
* IMU (``imuData.csv``): the original column description is wrong. The
  accelerations are in g and the rates in deg/s; column ``ax`` is the lateral
  acceleration (+left) and column ``ay`` minus the longitudinal one. So
  ``ay = ax_col * g``, ``ax = -ay_col * g``, ``yaw_rate = wz_col * pi / 180``.
* ``vx``: VESC wheel odometry ``odomData.vx`` [m/s] (motor-speed based, so it
  includes wheel spin) in every run. In DS5 the motor speed from
  ``coreData.RPM`` is added as the extra column ``vx_motor`` =
  ``-RPM / 7800`` [m/s] (RPM is negative forward, ~7.8k ERPM per m/s).
  No wheel-speed columns: the car has one motor and the odometry is its speed.
* ``steer``: the steering command ``commandData.delta`` [rad] (no measured
  steering angle exists); ``speed_cmd``: the speed command ``V`` [m/s]. The
  measured yaw rate follows the linear single-track model driven by this
  command best when the command is delayed by 0.10-0.12 s (all five runs:
  servo and actuation lag); ``steer_delay`` shifts the command stream by that
  much (default 0, the command as sent).
* ``x``, ``y``, ``psi``: particle-filter pose ``pfPoseData`` (map frame), ``psi``
  from the quaternion, unwrapped before interpolation. The localisation
  occasionally jumps; such samples are flagged in the extra column
  ``pose_jump`` (1.0 where the pose moved more than the odometry allows:
  ``|dp| > |vx| dt + 0.1 m + 0.5 |vx| dt``, or the heading changed more than
  ``|yaw_rate| dt + 0.2 rad``), not repaired.

``meta.extra['kinematic_checks']`` holds two consistency ratios (see
:func:`_kinematic_checks`). DS1, DS2, DS3 and DS5 give ``ay / (vx yaw_rate)``
of 0.95-1.09 in turns; DS4 gives about 0.5 with a pose speed about 0.8 of the
odometry speed, so in DS4 the odometry speed (and possibly the accelerometer
scale) disagrees with the pose kinematics: treat its ``vx`` with care.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from roadgrip.constants import GRAVITY
from roadgrip.drive import Drive
from roadgrip.io._csv import read_csv_exact
from roadgrip.io.resample import resample
from roadgrip.vehicle.params import VehicleParams, load_vehicle

__all__ = ["ERPM_PER_MPS", "is_frictionmaps_dir", "quaternion_yaw", "read_frictionmaps"]

ERPM_PER_MPS = 7800.0
"""VESC electrical rpm per m/s of the F1/10 car (README of the data)."""

_REQUIRED = {
    "imuData.csv": ("ax", "ay", "wz"),
    "odomData.csv": ("vx",),
    "commandData.csv": ("V", "delta"),
    "pfPoseData.csv": ("x", "y", "q.x", "q.y", "q.z", "q.w"),
}


def is_frictionmaps_dir(path: Path) -> bool:
    """Whether ``path`` is a run folder (it contains ``imuData.csv``)."""
    return path.is_dir() and (path / "imuData.csv").is_file()


def quaternion_yaw(qx, qy, qz, qw) -> np.ndarray:
    """Yaw (rotation about z) of unit quaternions [rad], in (-pi, pi]."""
    qx, qy, qz, qw = (np.asarray(a, dtype=float) for a in (qx, qy, qz, qw))
    return np.arctan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


def _first_second(folder: Path) -> int:
    """Whole Unix second of the first IMU stamp: the reference of the relative times."""
    f = folder / "imuData.csv"
    try:
        first = pd.read_csv(f, nrows=1)
    except pd.errors.EmptyDataError:
        raise ValueError(f"frictionmaps run {folder.name}: imuData.csv is empty") from None
    if "s" not in first.columns or first.empty:
        raise ValueError(f"frictionmaps run {folder.name}: imuData.csv has no 's' stamps")
    return int(first["s"].iloc[0])


def _read_stream(folder: Path, name: str, cols: tuple[str, ...], s_ref: int) -> pd.DataFrame:
    f = folder / name
    if not f.is_file():
        raise ValueError(f"frictionmaps run {folder.name}: missing {name}")
    try:
        df = read_csv_exact(f)
    except pd.errors.EmptyDataError:
        raise ValueError(f"frictionmaps run {folder.name}: {name} is empty") from None
    missing = [c for c in ("s", "ns", *cols) if c not in df.columns]
    if missing:
        raise ValueError(f"frictionmaps run {folder.name}: {name} lacks column(s) {missing}")
    # relative to a whole second: keeps nanosecond resolution in float64
    t = (df["s"].to_numpy(np.int64) - s_ref).astype(float) + 1e-9 * df["ns"].to_numpy(float)
    out = pd.DataFrame({"t": t})
    for c in cols:
        out[c] = df[c].to_numpy(float)
    # drop repeated stamps (keep the first), sort defensively
    out = out.sort_values("t", kind="stable")
    out = out[np.r_[True, np.diff(out["t"].to_numpy()) > 0]]
    return out.reset_index(drop=True)


def _kinematic_checks(df: pd.DataFrame, jump: np.ndarray) -> dict[str, float]:
    """Least-squares ratios that expose unit, axis and speed problems.

    ``ay_over_vx_yaw_rate``: slope of ``ay`` against ``vx * yaw_rate`` in turns
    (``|yaw_rate| > 0.5 rad/s``, ``vx > 1 m/s``), about 1 when ``ay``, ``vx`` and
    ``yaw_rate`` agree. ``pose_speed_over_vx``: median ratio of the speed
    differentiated from the pose (jumps excluded) to ``vx`` while moving.
    """
    t = df["t"].to_numpy()
    vx = df["vx"].to_numpy()
    r = df["yaw_rate"].to_numpy()
    ay = df["ay"].to_numpy()
    kin = vx * r
    turn = (np.abs(r) > 0.5) & (vx > 1.0)
    out: dict[str, float] = {}
    if turn.sum() >= 20:
        out["ay_over_vx_yaw_rate"] = float(np.dot(ay[turn], kin[turn]) / np.dot(kin[turn], kin[turn]))
    dt = np.diff(t)
    vp = np.hypot(np.diff(df["x"].to_numpy()), np.diff(df["y"].to_numpy())) / dt
    ok = (dt < 1.5 * np.median(dt)) & ~jump[1:] & (vx[1:] > 1.0)
    if ok.sum() >= 20:
        out["pose_speed_over_vx"] = float(np.median(vp[ok] / vx[1:][ok]))
    return out


def read_frictionmaps(
    path: str | Path,
    vehicle: str | Path | VehicleParams | None = None,
    *,
    rate: float = 50.0,
    max_gap: float = 0.25,
    steer_delay: float = 0.0,
) -> Drive:
    """Read one FrictionMaps run folder into a canonical :class:`~roadgrip.drive.Drive`.

    Parameters
    ----------
    path : str or Path
        A ``DSn`` folder (or any file inside it).
    vehicle : preset name, YAML path or VehicleParams, optional
        Default ``'f1tenth'``.
    rate : float
        Output rate [Hz].
    max_gap : float
        Longest stream gap [s] bridged by interpolation.
    steer_delay : float
        Delay [s] applied to the command stream (``steer``, ``speed_cmd``), to
        model the steering actuation lag (about 0.1 s; module docstring).

    Returns
    -------
    Drive
        Columns ``t, ax, ay, yaw_rate, steer, vx, x, y, psi`` and extras
        ``speed_cmd, pose_jump`` (and ``vx_motor`` where ``coreData.csv`` exists).
    """
    folder = Path(path)
    if folder.is_file():
        folder = folder.parent
    if not is_frictionmaps_dir(folder):
        raise ValueError(f"{path} is not a frictionmaps run folder (no imuData.csv)")
    veh = load_vehicle(vehicle if vehicle is not None else "f1tenth")
    s_ref = _first_second(folder)
    raw = {name: _read_stream(folder, name, cols, s_ref) for name, cols in _REQUIRED.items()}

    imu = raw["imuData.csv"]
    imu = pd.DataFrame(
        {
            "t": imu["t"],
            "ax": -imu["ay"] * GRAVITY,
            "ay": imu["ax"] * GRAVITY,
            "yaw_rate": np.deg2rad(imu["wz"]),
        }
    )
    odom = raw["odomData.csv"]
    if not (np.isfinite(steer_delay) and steer_delay >= 0):
        raise ValueError(f"steer_delay must be a non-negative number of seconds, got {steer_delay!r}")
    cmd = raw["commandData.csv"].rename(columns={"V": "speed_cmd", "delta": "steer"})
    cmd["t"] = cmd["t"] + steer_delay
    pf = raw["pfPoseData.csv"]
    pose = pd.DataFrame(
        {
            "t": pf["t"],
            "x": pf["x"],
            "y": pf["y"],
            "psi": np.unwrap(quaternion_yaw(pf["q.x"], pf["q.y"], pf["q.z"], pf["q.w"])),
        }
    )
    streams = {"imu": imu, "odom": odom, "command": cmd, "pose": pose}
    has_core = (folder / "coreData.csv").is_file()
    if has_core:
        core = _read_stream(folder, "coreData.csv", ("RPM",), s_ref)
        streams["core"] = pd.DataFrame({"t": core["t"], "vx_motor": -core["RPM"] / ERPM_PER_MPS})

    # the commands define no span of their own: the clock spans the sensor streams
    t0 = max(s["t"].iloc[0] for s in streams.values())
    t1 = min(s["t"].iloc[-1] for s in streams.values())
    if not t1 > t0:
        raise ValueError(f"frictionmaps run {folder.name}: the streams do not overlap in time")
    ticks = np.arange(int(np.floor((t1 - t0) * rate)) + 1)
    clock = t0 + ticks / rate
    df = resample(streams, clock=clock, hold=("steer", "speed_cmd"), max_gap=max_gap)
    if len(df) < 2:
        raise ValueError(f"frictionmaps run {folder.name}: fewer than 2 samples after resampling")
    n_dropped = len(clock) - len(df)

    # localisation jumps
    t = df["t"].to_numpy()
    dt = np.diff(t)
    step = np.hypot(np.diff(df["x"].to_numpy()), np.diff(df["y"].to_numpy()))
    vx = np.abs(df["vx"].to_numpy())
    allowed = 1.5 * vx[1:] * dt + 0.1
    dpsi = np.abs(np.diff(df["psi"].to_numpy()))
    allowed_psi = np.abs(df["yaw_rate"].to_numpy()[1:]) * dt + 0.2
    jump = np.r_[False, (step > allowed) | (dpsi > allowed_psi)]
    df["pose_jump"] = jump.astype(float)

    checks = _kinematic_checks(df, jump)

    # exact grid times from the tick numbers
    k = np.round((t - t0) * rate)
    epoch = s_ref + t0 + k[0] / rate
    df["t"] = (k - k[0]) / rate
    order = ["t", "ax", "ay", "yaw_rate", "steer", "vx", "x", "y", "psi", "speed_cmd", "pose_jump"]
    if has_core:
        order.append("vx_motor")
    df = df[order]
    extra = {
        "format": "frictionmaps",
        "run": folder.name,
        "t0_epoch_s": epoch,
        "rate_hz": float(rate),
        "max_gap_s": float(max_gap),
        "steer_delay_s": float(steer_delay),
        "ticks_dropped_in_gaps": int(n_dropped),
        "pose_jumps": int(jump.sum()),
        "kinematic_checks": checks,
        "conversions": {
            "t": "s + 1e-9 ns, resampled to a uniform clock on the overlap of the streams, "
            "minus t0_epoch_s; ticks in stream gaps > max_gap dropped",
            "ax": "-imuData.ay * g (column ay is minus the longitudinal acceleration, in g)",
            "ay": "imuData.ax * g (column ax is the lateral acceleration, +left, in g)",
            "yaw_rate": "imuData.wz [deg/s] -> rad/s",
            "vx": "odomData.vx (VESC odometry, motor-speed based)",
            "steer": f"commandData.delta (command, zero-order hold), delayed {steer_delay} s",
            "speed_cmd": "commandData.V (command, zero-order hold)",
            "x/y/psi": "pfPoseData (particle filter), psi from the quaternion, unwrapped",
            "pose_jump": "1 where the pose step exceeds 1.5 |vx| dt + 0.1 m or the heading "
            "step exceeds |yaw_rate| dt + 0.2 rad (not repaired)",
            **({"vx_motor": "-coreData.RPM / 7800 [m/s]"} if has_core else {}),
        },
    }
    return Drive.from_frame(df, veh, source=str(folder), extra=extra)
