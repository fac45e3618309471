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
* ``vx_pose``, ``vy_pose``: body-frame velocity differentiated from the pose
  over 0.3 s (:func:`roadgrip.io.derived.body_velocity_from_pose`), NaN within half a window of a jump
  or a gap. Fused by the cascade's stage 1 (it bounds the drift of the
  integrated lateral velocity). At low lateral acceleration (rear slip below
  0.01 rad) ``vy_pose`` follows ``d r`` with ``d`` = 0.15-0.27 m fitted per
  run, close to ``lr`` = 0.208 m, so the pose refers to about the CG; its
  scatter about that line is 0.10-0.16 m/s (robust), its heading offset
  0.004-0.02 rad (``vy_pose / vx_pose`` on straights).
* ``meta.extra['sensor_noise']``: white-noise standard deviations of the
  accelerometers, gyro and odometry speed measured on the native streams
  (IMU at 18-30 Hz) and expressed per tick of the output clock
  (:func:`_stream_noise`); estimated on the resampled, linearly interpolated
  signals they would be 10-20 times too small.

``meta.extra['kinematic_checks']`` holds two consistency ratios (see
:func:`_kinematic_checks`). DS1, DS2, DS3 and DS5 give ``ay / (vx yaw_rate)``
of 0.95-1.09 in turns; DS4 gives about 0.5 with a pose speed about 0.8 of the
odometry speed, so in DS4 the odometry speed (and possibly the accelerometer
scale) disagrees with the pose kinematics: treat its ``vx`` with care.

``calibrate=True`` (off by default) corrects the slip-angle inputs against the
particle-filter pose, per run (:func:`fit_pose_scales`, :func:`fit_steer_gain`;
the fitted values are in ``meta.extra['calibration']``):

* gyro scale ``k_r``: least-squares slope of the pose heading change against
  the integrated gyro yaw rate over windows of ``window`` seconds;
  ``yaw_rate *= k_r``.
* odometry speed scale ``k_v``: least-squares slope of the pose chord
  ``|p(t+W) - p(t)|`` against the chord of the odometry speed integrated along
  the pose heading over the same window; ``vx *= k_v``. Windows that contain a
  flagged ``pose_jump`` or a dropped tick are excluded, and one pass rejects
  windows with residuals above 3 scaled MADs. Assumes the pose is unbiased in
  scale (a LiDAR map at 0.05 m/px) and the side slip small (|vy| << vx), so the
  chord of the odometry path is that of the true path.
* steering gain ``k_d``: the command is not the road-wheel angle (the car turns
  0.5-0.8 times as much as a kinematic car with the commanded angle). The
  effective angle is ``k_d * command``, ``k_d`` the least-squares slope of the
  kinematic angle ``atan(L r / vx)`` (corrected ``r``, ``vx``) against the
  command in steady cornering: command and yaw rate each within 0.02 rad and
  0.3 rad/s over the last 0.3 s, ``|ay| < 0.5 g``, ``vx > 1 m/s``,
  ``|command| > 0.05 rad``. Bounded to (0, 1]: the effective angle never
  exceeds the command. It assumes a constant gain (no speed dependence) and
  folds the understeer below 0.5 g into the gain. With fewer than 20 steady
  samples (DS4 without ``steer_delay``) the gain is left at 1 and
  ``steer_gain_n`` records 0. The command itself is kept as ``steer_cmd``.
  On DS1-DS5 the steady gain is 0.8-1.0: the large turn deficit seen in
  transients is the actuation lag, not a miscalibrated steering.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from roadgrip.constants import GRAVITY
from roadgrip.drive import Drive, DriveValidationError
from roadgrip.io._csv import read_csv_numbers
from roadgrip.io.derived import body_velocity_from_pose, white_noise_std
from roadgrip.io.resample import resample
from roadgrip.vehicle.params import VehicleParams, load_vehicle

__all__ = [
    "ERPM_PER_MPS",
    "fit_pose_scales",
    "fit_steer_gain",
    "is_frictionmaps_dir",
    "quaternion_yaw",
    "read_frictionmaps",
]

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
    first = read_csv_numbers(folder / "imuData.csv", ("s",), f"frictionmaps run {folder.name}: imuData.csv")
    s = first["s"].to_numpy(float) if "s" in first.columns else np.array([])
    s = s[np.isfinite(s)]
    if not len(s):
        raise ValueError(f"frictionmaps run {folder.name}: imuData.csv has no 's' stamps")
    return int(s[0])


def _read_stream(folder: Path, name: str, cols: tuple[str, ...], s_ref: int) -> pd.DataFrame:
    f = folder / name
    if not f.is_file():
        raise ValueError(f"frictionmaps run {folder.name}: missing {name}")
    df = read_csv_numbers(f, ("s", "ns", *cols), f"frictionmaps run {folder.name}: {name}")
    missing = [c for c in ("s", "ns", *cols) if c not in df.columns]
    if missing:
        raise ValueError(f"frictionmaps run {folder.name}: {name} lacks column(s) {missing}")
    # relative to a whole second: keeps nanosecond resolution in float64
    # (whole seconds below 2**53 subtract exactly in float64)
    t = (df["s"].to_numpy(float) - s_ref) + 1e-9 * df["ns"].to_numpy(float)
    if not np.isfinite(t).all() or np.abs(t).max(initial=0.0) > 1e9:
        i = int(np.flatnonzero(~(np.isfinite(t) & (np.abs(t) <= 1e9)))[0])
        raise ValueError(f"frictionmaps run {folder.name}: {name}: stamp s, ns = {df['s'].iloc[i]}, "
                         f"{df['ns'].iloc[i]} at line {i + 2} is missing or not a time of this run")
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


def _stream_noise(t: np.ndarray, x: np.ndarray, rate: float) -> tuple[float, float]:
    """White-noise standard deviation of a raw stream, expressed per tick of the output clock.

    :func:`roadgrip.io.derived.white_noise_std` of the samples as recorded is the
    noise of one native sample. Estimated on the resampled signal it would be far too small:
    linear interpolation between native samples has zero second difference.
    Interpolated onto a faster clock, the noise of one native sample persists
    over ``rate / native_rate`` ticks; as white noise per tick with the same
    integrated effect its standard deviation is ``s sqrt(rate / native_rate)``.

    Returns
    -------
    std : float
        Per-tick white-noise equivalent [unit of ``x``].
    native_rate : float
        Median rate of the stream [Hz].
    """
    native = 1.0 / float(np.median(np.diff(t)))
    return white_noise_std(x) * np.sqrt(max(rate / native, 1.0)), native


def _robust_slope(y: np.ndarray, x: np.ndarray) -> float:
    """Least-squares slope of ``y = k x`` through 0, refitted once without 3-MAD outliers."""
    k = float(np.dot(x, y) / np.dot(x, x))
    res = y - k * x
    mad = 1.4826 * np.median(np.abs(res - np.median(res)))
    keep = np.abs(res) <= 3.0 * mad if mad > 0 else np.ones_like(res, dtype=bool)
    if keep.sum() >= 10:
        k = float(np.dot(x[keep], y[keep]) / np.dot(x[keep], x[keep]))
    return k


def fit_pose_scales(
    t: np.ndarray,
    yaw_rate: np.ndarray,
    vx: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    psi: np.ndarray,
    jump: np.ndarray,
    *,
    window: float = 1.0,
) -> dict[str, float]:
    """Gyro and odometry-speed scales that make them agree with the pose.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Time [s], increasing; ticks may be missing (gaps are not used).
    yaw_rate, vx : ndarray, shape (n,)
        Gyro yaw rate [rad/s] and odometry speed [m/s].
    x, y, psi : ndarray, shape (n,)
        Pose [m, m, rad], ``psi`` unwrapped.
    jump : ndarray of bool, shape (n,)
        Samples where the pose jumped (windows containing one are not used).
    window : float
        Window length [s].

    Returns
    -------
    dict
        ``gyro_scale`` (``k_r``, pose heading rate / gyro), ``speed_scale``
        (``k_v``, pose speed / odometry) and the number of windows used for
        each (``n_yaw``, ``n_speed``).

    Raises
    ------
    ValueError
        Too few usable windows (fewer than 20) for either fit.
    """
    t = np.asarray(t, float)
    dt = np.diff(t)
    h = float(np.median(dt))
    w = max(round(window / h), 1)
    n = len(t)
    if n <= w + 1:
        raise ValueError(f"pose calibration: {n} samples are too few for a {window} s window")
    # cumulative integrals (trapezoid) of the gyro and of the odometry velocity along the pose heading
    cum_r = np.r_[0.0, np.cumsum(0.5 * (yaw_rate[1:] + yaw_rate[:-1]) * dt)]
    vxc, vyc = vx * np.cos(psi), vx * np.sin(psi)
    cum_x = np.r_[0.0, np.cumsum(0.5 * (vxc[1:] + vxc[:-1]) * dt)]
    cum_y = np.r_[0.0, np.cumsum(0.5 * (vyc[1:] + vyc[:-1]) * dt)]
    bad = np.r_[0, np.cumsum((dt > 1.5 * h) | np.asarray(jump, bool)[1:])]
    i0 = np.arange(n - w)
    i1 = i0 + w
    clean = bad[i1] == bad[i0]
    d_gyro = cum_r[i1] - cum_r[i0]
    d_pose = psi[i1] - psi[i0]
    ch_odo = np.hypot(cum_x[i1] - cum_x[i0], cum_y[i1] - cum_y[i0])
    ch_pose = np.hypot(x[i1] - x[i0], y[i1] - y[i0])
    use_r = clean & (np.abs(d_gyro) > 0.1)
    use_v = clean & (ch_odo > 0.3)
    if use_r.sum() < 20 or use_v.sum() < 20:
        raise ValueError(
            f"pose calibration: too few clean turning/moving windows ({int(use_r.sum())} for the gyro, "
            f"{int(use_v.sum())} for the speed; need 20)"
        )
    return {
        "gyro_scale": _robust_slope(d_pose[use_r], d_gyro[use_r]),
        "speed_scale": _robust_slope(ch_pose[use_v], ch_odo[use_v]),
        "n_yaw": int(use_r.sum()),
        "n_speed": int(use_v.sum()),
    }


def fit_steer_gain(
    steer_cmd: np.ndarray,
    yaw_rate: np.ndarray,
    vx: np.ndarray,
    ay: np.ndarray,
    wheelbase: float,
    *,
    steady: np.ndarray | None = None,
    max_ay: float = 0.5 * GRAVITY,
) -> tuple[float, int]:
    """Gain from the steering command to the effective road-wheel angle.

    Least-squares slope of the kinematic angle ``atan(L r / vx)`` against the
    command in steady, moderate cornering (``steady``, ``|ay| < max_ay``,
    ``vx > 1 m/s``, command above 0.05 rad), clipped to (0, 1].

    Parameters
    ----------
    steer_cmd, yaw_rate, vx, ay : ndarray, shape (n,)
        Command [rad], yaw rate [rad/s], speed [m/s], lateral acceleration [m/s^2].
    wheelbase : float
        ``L = lf + lr`` [m].
    steady : ndarray of bool, shape (n,), optional
        Samples in steady cornering (default: all).
    max_ay : float
        Largest lateral acceleration [m/s^2] of the samples used.

    Returns
    -------
    k_d : float
        Gain in (0, 1]; 1 (no correction) with fewer than 20 usable samples.
    n : int
        Samples used (0 when the gain was left at 1).

    Raises
    ------
    ValueError
        A non-positive fitted gain (steering sign or axes wrong).
    """
    use = (np.abs(ay) < max_ay) & (vx > 1.0) & (np.abs(steer_cmd) > 0.05)
    if steady is not None:
        use &= np.asarray(steady, bool)
    if use.sum() < 20:
        return 1.0, 0
    kin = np.arctan(wheelbase * yaw_rate[use] / vx[use])
    k = _robust_slope(kin, steer_cmd[use])
    if not k > 0:
        raise ValueError(f"steering-gain fit: non-positive gain {k:.3f} (steering sign or axes wrong?)")
    return float(min(k, 1.0)), int(use.sum())


def read_frictionmaps(
    path: str | Path,
    vehicle: str | Path | VehicleParams | None = None,
    *,
    rate: float = 50.0,
    max_gap: float = 0.25,
    steer_delay: float = 0.0,
    calibrate: bool = False,
    window: float = 1.0,
    pose_velocity_window: float = 0.3,
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
    calibrate : bool
        Scale ``yaw_rate`` and ``vx`` to the pose and replace ``steer`` by the
        fitted effective road-wheel angle (module docstring); the command is
        then kept as the extra column ``steer_cmd``.
    window : float
        Window [s] of the pose calibration (:func:`fit_pose_scales`).
    pose_velocity_window : float
        Fit window [s] of the body velocity differentiated from the pose
        (:func:`roadgrip.io.derived.body_velocity_from_pose`, columns ``vx_pose, vy_pose``).

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

    calib: dict[str, float] = {}
    if calibrate:
        calib = fit_pose_scales(
            t, df["yaw_rate"].to_numpy(), df["vx"].to_numpy(), df["x"].to_numpy(), df["y"].to_numpy(),
            df["psi"].to_numpy(), jump, window=window,
        )
        df["yaw_rate"] = df["yaw_rate"] * calib["gyro_scale"]
        df["vx"] = df["vx"] * calib["speed_scale"]
        df["steer_cmd"] = df["steer"]
        # steady: command and yaw rate nearly constant over the last 0.3 s (ticks; gaps ignored)
        nw = max(round(0.3 * rate), 2)
        span = {c: df[c].rolling(nw).max() - df[c].rolling(nw).min() for c in ("steer", "yaw_rate")}
        steady = ((span["steer"] < 0.02) & (span["yaw_rate"] < 0.3)).to_numpy()
        calib["steer_gain"], calib["steer_gain_n"] = fit_steer_gain(
            df["steer"].to_numpy(), df["yaw_rate"].to_numpy(), df["vx"].to_numpy(), df["ay"].to_numpy(),
            veh.lf + veh.lr, steady=steady,
        )
        df["steer"] = df["steer"] * calib["steer_gain"]

    checks = _kinematic_checks(df, jump)
    # sensor noise from the native streams (per output tick; see _stream_noise)
    s_ax, r_imu = _stream_noise(imu["t"].to_numpy(), imu["ax"].to_numpy(), rate)
    s_ay, _ = _stream_noise(imu["t"].to_numpy(), imu["ay"].to_numpy(), rate)
    s_r, _ = _stream_noise(imu["t"].to_numpy(), imu["yaw_rate"].to_numpy(), rate)
    s_v, r_odo = _stream_noise(odom["t"].to_numpy(), odom["vx"].to_numpy(), rate)
    noise = {
        "accel_std": max(s_ax, s_ay),
        "gyro_std": s_r * calib.get("gyro_scale", 1.0),
        "speed_std": s_v * calib.get("speed_scale", 1.0),
        "imu_rate_hz": r_imu,
        "odom_rate_hz": r_odo,
    }
    df["vx_pose"], df["vy_pose"] = body_velocity_from_pose(
        t, df["x"].to_numpy(), df["y"].to_numpy(), df["psi"].to_numpy(), window=pose_velocity_window, bad=jump
    )

    # exact grid times from the tick numbers
    k = np.round((t - t0) * rate)
    epoch = s_ref + t0 + k[0] / rate
    df["t"] = (k - k[0]) / rate
    order = ["t", "ax", "ay", "yaw_rate", "steer", "vx", "x", "y", "psi", "speed_cmd", "pose_jump", "vx_pose",
             "vy_pose"]
    if has_core:
        order.append("vx_motor")
    if calibrate:
        order.append("steer_cmd")
    df = df[order]
    extra = {
        "format": "frictionmaps",
        "run": folder.name,
        "t0_epoch_s": epoch,
        "rate_hz": float(rate),
        "max_gap_s": float(max_gap),
        "steer_delay_s": float(steer_delay),
        "steer_is_command": True,
        "ticks_dropped_in_gaps": int(n_dropped),
        "pose_jumps": int(jump.sum()),
        "kinematic_checks": checks,
        "calibration": calib,
        "sensor_noise": noise,
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
            "vx_pose/vy_pose": f"body velocity differentiated from the pose over {pose_velocity_window} s "
            "(roadgrip.io.derived.body_velocity_from_pose); NaN near jumps and gaps",
            "pose_jump": "1 where the pose step exceeds 1.5 |vx| dt + 0.1 m or the heading "
            "step exceeds |yaw_rate| dt + 0.2 rad (not repaired)",
            **({"vx_motor": "-coreData.RPM / 7800 [m/s]"} if has_core else {}),
        },
    }
    try:
        return Drive.from_frame(df, veh, source=str(folder), extra=extra)
    except DriveValidationError as exc:  # name the file, as the other readers do
        raise DriveValidationError(f"frictionmaps run {folder.name}: {exc}") from None
