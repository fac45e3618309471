r"""Multi-body engine: CommonRoad's ``vehicle_dynamics_mb`` driven along a path.

:func:`simulate_multibody` drives a CommonRoad multi-body vehicle
(:mod:`roadgrip.sim.mb_model`: the package's model compiled, its parameters on
a surface of given friction, its tire forces) along a :class:`~roadgrip.sim.mb_driver.Path` with the
closed-loop driver of :mod:`roadgrip.sim.mb_driver`, and turns the recorded
states into a :class:`~roadgrip.drive.Drive`: sensor columns through the
measurement models of :mod:`roadgrip.sim.sensors`, and the truth columns.

* **Settling.** The package's ``init_mb`` state is not an equilibrium of the
  suspension; every drive starts with an unrecorded straight pre-roll at the
  initial speed (:data:`SETTLE_TIME`) so that the heave and pitch transients
  have died out before ``t = 0``.
* **Integration.** Fixed-step RK4 at :data:`INTERNAL_RATE` (stable for
  5-25 m/s); the driver's commands are held over each step.
* **Sensors.** The accelerometer measures the specific force at the CG in body
  axes (the body's roll and pitch leak gravity into ``ax``, ``ay``), the gyro
  the body-z rate; the package's roll and pitch are negated to ISO 8855 first
  (:mod:`roadgrip.sim.mb_model`, wheel names). The truth uses axle sums, which
  do not depend on the wheel naming.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from roadgrip.drive import Drive
from roadgrip.sim.engine import field_code
from roadgrip.sim.friction import FrictionField
from roadgrip.sim.mb_driver import SLIP_LIMIT, MBDriver, MBStepping, Path, integrate_mb
from roadgrip.sim.mb_model import (
    WHEEL_FX,
    WHEEL_FY,
    WHEEL_FZ,
    WHEEL_MU_X,
    WHEEL_MU_Y,
    WHEEL_SENSOR_STATE,
    MBState,
    MBVehicle,
    named_mb_vehicle,
)
from roadgrip.sim.sensors import (
    SensorSpec,
    apply_sensors,
    dropout_intervals,
    sensors_to_dict,
    steering_signal,
)
from roadgrip.vehicle.slip import longitudinal_slip, slip_angles, wheel_centre_speeds

__all__ = ["INTERNAL_RATE", "MAX_SURFACES", "MB_SENSOR_COLUMNS", "SETTLE_TIME", "simulate_multibody"]

INTERNAL_RATE = 1000.0
"""Integration rate of the multi-body engine [Hz]."""

SETTLE_TIME = 3.0
"""Unrecorded straight pre-roll before ``t = 0`` [s]."""

MAX_SURFACES = 4
"""Most surface labels one multi-body drive can use."""


MB_SENSOR_COLUMNS = (
    "ax", "ay", "yaw_rate", "steer", "vx",
    "omega_fl", "omega_fr", "omega_rl", "omega_rr", "x", "y", "psi",
)


_PKG_G = 9.81
"""Gravity inside the package's equations [m/s²]."""


def _specific_force(states, derivs, vehicle, p) -> tuple[NDArray, ...]:
    """Accelerometer at the CG in body axes [m/s²], the body-z angular rate [rad/s],
    and the CG's acceleration in the yaw-aligned horizontal frame [m/s²]."""
    S = MBState
    vx, vy, r = states[:, S.VX], states[:, S.VY], states[:, S.YAW_RATE]
    d = p.a - vehicle.lf  # CG ahead of the sprung-mass centre [m]
    ax = derivs[:, S.VX] - r * vy - r * r * d
    ay = derivs[:, S.VY] + r * vx + derivs[:, S.YAW_RATE] * d
    az = _PKG_G - derivs[:, S.VZ]  # upward specific force; the package's z points down
    phi = -states[:, S.ROLL]  # ISO roll, positive right side down
    theta = -states[:, S.PITCH]  # ISO pitch, positive nose down
    ct, st = np.cos(theta), np.sin(theta)
    cf, sf = np.cos(phi), np.sin(phi)
    fx = ct * ax - st * az
    fz1 = st * ax + ct * az
    fy = cf * ay + sf * fz1
    gyro = r * ct * cf - (-states[:, S.PITCH_RATE]) * sf
    return fx, fy, gyro, ax, ay



def simulate_multibody(
    vehicle: str | MBVehicle,
    path: Path,
    friction: FrictionField,
    mu: Mapping[str, float],
    *,
    duration: float,
    output_rate: float = 100.0,
    sensors: Mapping[str, SensorSpec] | None = None,
    seed: int = 0,
    name: str = "custom",
    truth_extra: Mapping[str, Any] | None = None,
    lookahead: tuple[float, float] = (4.0, 0.35),
    progress: bool = False,
) -> Drive:
    """Drive a CommonRoad multi-body vehicle along ``path`` and return a :class:`Drive`.

    Parameters
    ----------
    vehicle : str or MBVehicle
        Key of :data:`~roadgrip.sim.mb_model.COMMONROAD_VEHICLES` (``'ford-escort'``,
        ``'vw-vanagon'``), or a vehicle such as one of the random family
        (:func:`roadgrip.sim.vehicle_family.mb_vehicle`); its sensor errors, if it has
        any, apply on top of ``sensors`` (whose noise levels they keep).
    path : Path
        Where and how fast to drive.
    friction : FrictionField
        Surface label over time or position.
    mu : mapping label -> float
        Peak friction of each surface label.
    duration : float
        Recorded time [s] (after the :data:`SETTLE_TIME` pre-roll).
    output_rate : float
        Sample rate of the drive [Hz]; must divide :data:`INTERNAL_RATE`.
    sensors : mapping column -> SensorSpec, optional
        Measurement models (columns without one are exact).
    seed : int
        Seeds the sensor noise and the dropouts.
    name : str
        Scenario name (``meta.source = 'sim:<name>'``).
    truth_extra : mapping, optional
        Extra entries for ``meta.truth``.
    lookahead : (float, float)
        Pure-pursuit look-ahead at standstill [m] and its growth with speed [s].
    progress : bool
        Print a line to stderr before integrating.

    Returns
    -------
    Drive
        Sensor columns, the truth columns of :data:`roadgrip.drive.TRUTH_COLUMNS`
        (``util_f_true`` / ``util_r_true``: axle friction utilisation, the axle's
        force over its friction ellipse, the per-wheel peaks at their camber
        weighted by load), and ``meta.truth`` with ``model = 'multibody'``, the vehicle's
        description (``vehicle``), the sensor models (``sensors``) and, with sensor errors,
        ``sensor_errors`` (the steering's, and each channel's realised ``dropouts`` [s]).
        The truth columns are exact whatever the sensors.
    """
    mbv = named_mb_vehicle(vehicle) if isinstance(vehicle, str) else vehicle
    if duration <= 0 or not np.isfinite(duration):
        raise ValueError(f"duration must be positive, got {duration!r}")
    stride = round(INTERNAL_RATE / output_rate)
    if stride < 1 or abs(stride * output_rate - INTERNAL_RATE) > 1e-6:
        raise ValueError(f"output_rate must divide {INTERNAL_RATE:g} Hz, got {output_rate!r}")
    missing = [lab for lab in friction.labels if lab not in mu]
    if missing:
        raise ValueError(f"friction field uses surface(s) {missing} with no mu; given {sorted(mu)}")
    sensors = dict(sensors or {})
    if mbv.sensors is not None:
        sensors = mbv.sensors.specs(sensors)
    unknown = sorted(set(sensors) - set(MB_SENSOR_COLUMNS))
    if unknown:
        raise ValueError(f"sensor models for unknown column(s) {unknown}; measured columns: {MB_SENSOR_COLUMNS}")
    labels = list(friction.labels)
    if len(labels) > MAX_SURFACES:
        raise ValueError(f"the multi-body engine takes at most {MAX_SURFACES} surfaces, got {len(labels)}")
    params = [mbv.parameter_tuple(float(mu[lab])) for lab in labels]
    # a fixed-length tuple: one compiled integrator for any number of surfaces
    params = tuple(params + [params[-1]] * (MAX_SURFACES - len(params)))
    field = field_code(friction.encode())
    from vehiclemodels.init_mb import init_mb

    p_pkg = mbv.commonroad
    x0 = np.asarray(init_mb([0.0, 0.0, 0.0, float(path.v[0]), 0.0, 0.0, 0.0], p_pkg), float)
    dt = 1.0 / INTERNAL_RATE
    n = round(duration * INTERNAL_RATE)
    if progress:
        print(f"simulating {name} (multi-body, {duration:.0f} s at 1 kHz)", file=sys.stderr, flush=True)
    steps = MBStepping(dt=dt, n_steps=n, n_settle=round(SETTLE_TIME * INTERNAL_RATE), stride=stride)
    driver = MBDriver(lookahead0=float(lookahead[0]), lookahead_gain=float(lookahead[1]), preview=0.6,
                      k_steer=20.0, kp=1.0, ki=0.2, slip_limit=SLIP_LIMIT)
    try:
        states, derivs, inputs, wheels, surf = integrate_mb(x0, steps, params, path.encode(), driver, field)
    except ZeroDivisionError:  # the package divides by each wheel's forward speed, clipped at zero
        raise RuntimeError(f"multi-body simulation of {name} with {mbv.name} failed: a wheel's forward speed "
                           "reached zero while driving (the vehicle spun)") from None
    if not np.all(np.isfinite(states)):
        bad = int(np.argmax(~np.isfinite(states).all(1)))
        raise RuntimeError(f"multi-body simulation diverged (first non-finite state at t = {bad / output_rate:.2f} s)")
    return _drive_from_run(mbv, states, derivs, inputs, wheels, surf, labels, mu, friction,
                           output_rate, sensors, seed, name, truth_extra)


def _vehicle_model_text(mbv: MBVehicle) -> str:
    d = mbv.description
    if "base" in d:
        return (f"commonroad-vehicle-models vehicle_dynamics_mb, parameter set sampled around set "
                f"{d['base_parameter_set']} ({d['base']}) as {mbv.name}")
    return f"commonroad-vehicle-models vehicle_dynamics_mb, parameter set {d.get('parameter_set', '(given)')} ({mbv.name})"


def _axle_truth(wheels, rows):
    fz = wheels[:, rows, WHEEL_FZ].sum(1)
    fx = wheels[:, rows, WHEEL_FX].sum(1)
    fy = wheels[:, rows, WHEEL_FY].sum(1)
    wz = np.maximum(wheels[:, rows, WHEEL_FZ], 0.0)
    tot = np.maximum(wz.sum(1), 1e-9)
    mux = (wheels[:, rows, WHEEL_MU_X] * wz).sum(1) / tot
    muy = (wheels[:, rows, WHEEL_MU_Y] * wz).sum(1) / tot
    util = np.hypot(fx / mux, fy / muy) / tot
    util = np.where(fz > 0, util, 1.0)  # a lifted axle has no grip left
    return fx, fy, fz, util


def _drive_from_run(mbv, states, derivs, inputs, wheels, surf, labels, mu, friction,
                    output_rate, sensors, seed, name, truth_extra) -> Drive:
    S = MBState
    vp, p_pkg = mbv.params, mbv.commonroad
    n_out = states.shape[0]
    t = np.arange(n_out) / output_rate
    r = states[:, S.YAW_RATE]
    vx = states[:, S.VX]
    vy_cg = states[:, S.VY] + r * (p_pkg.a - vp.lf)
    steer = states[:, S.STEER]
    fx_b, fy_b, gyro, ax_h, ay_h = _specific_force(states, derivs, vp, p_pkg)
    true_meas = {
        "ax": fx_b, "ay": fy_b, "yaw_rate": gyro, "steer": steer, "vx": vx,
        "x": states[:, S.X], "y": states[:, S.Y], "psi": states[:, S.PSI],
    }
    for col, idx in WHEEL_SENSOR_STATE.items():
        true_meas[col] = states[:, idx]
    fxf, fyf, fzf, uf = _axle_truth(wheels, [0, 1])
    fxr, fyr, fzr, ur = _axle_truth(wheels, [2, 3])
    children = np.random.SeedSequence(seed).spawn(3)
    rng = np.random.default_rng(children[1])
    dropouts: dict[str, list[tuple[float, float]]] = {}
    reported = dict(true_meas)
    errors = mbv.sensors
    if errors is not None:
        reported["steer"] = steering_signal(steer, fyf, errors.steering)
        # one draw per message: channels sharing a spec's rate and length share its dropouts
        drop_rng = np.random.default_rng(children[2])
        shared: dict[tuple[float, float, float], list[tuple[float, float]]] = {}
        for col in MB_SENSOR_COLUMNS:
            spec = sensors.get(col, SensorSpec())
            key = (spec.dropout_rate, spec.dropout_duration, spec.delay)
            if key not in shared:
                shared[key] = dropout_intervals(spec, float(t[-1]), drop_rng)
            dropouts[col] = shared[key]
    measured = apply_sensors(t, reported, t, sensors, rng, dropouts)
    measured["psi"] = np.angle(np.exp(1j * measured["psi"]))
    af, ar = slip_angles(vx, vy_cg, r, steer, vp)
    mu_arr = np.array([float(mu[lab]) for lab in labels])
    centre = dict(zip(("fl", "fr", "rl", "rr"), wheel_centre_speeds(vx, vy_cg, r, steer, vp).T, strict=True))
    cols: dict[str, Any] = {"t": t}
    cols.update({k: measured[k] for k in MB_SENSOR_COLUMNS})
    cols.update(vx_true=vx, vy_true=vy_cg, yaw_rate_true=r, alpha_f_true=af, alpha_r_true=ar)
    for w in ("fl", "fr", "rl", "rr"):
        cols[f"kappa_{w}_true"] = longitudinal_slip(true_meas[f"omega_{w}"], centre[w], vp.wheel_radius)
    cols.update(
        mu_true=mu_arr[surf], Fxf_true=fxf, Fxr_true=fxr, Fyf_true=fyf, Fyr_true=fyr,
        Fzf_true=fzf, Fzr_true=fzr, util_f_true=uf, util_r_true=ur,
        x_true=states[:, S.X], y_true=states[:, S.Y], psi_true=states[:, S.PSI], steer_true=steer,
        ax_true=ax_h, ay_true=ay_h, roll_true=-states[:, S.ROLL], pitch_true=-states[:, S.PITCH],
        accel_cmd=inputs[:, 1],
    )
    cols["surface"] = np.array(labels, dtype=object)[surf]
    df = pd.DataFrame(cols)
    truth: dict[str, Any] = {
        "scenario": name,
        "seed": int(seed),
        "model": "multibody",
        "engine": "multibody",
        "vehicle_model": _vehicle_model_text(mbv),
        "vehicle": mbv.description,
        "internal_rate": INTERNAL_RATE,
        "settle_time": SETTLE_TIME,
        "force_frame": "wheel",
        "truth_curve": "binned",
        "surfaces": {lab: {"mu": float(mu[lab])} for lab in labels},
        "sensors": sensors_to_dict({c: sensors.get(c, SensorSpec()) for c in MB_SENSOR_COLUMNS}),
        "friction_field": dict(friction.to_dict(), mu={lab: float(mu[lab]) for lab in labels}),
    }
    if errors is not None:
        truth["sensor_errors"] = dict(errors.to_dict(), dropouts={c: [list(iv) for iv in v]
                                                                   for c, v in dropouts.items()})
    truth.update(dict(truth_extra or {}))
    return Drive.from_frame(df, vp, source=f"sim:{name}", truth=truth, check_units=False)
