r"""``simulate``: integrate a vehicle model through a manoeuvre and return a :class:`Drive`.

Two vehicle models are available:

``'lateral'``
    Paper 000's lateral-only single-track model (states ``vy``, yaw rate) with the
    manoeuvre's speed profile as the input ``vx``; free-rolling wheels. This is
    exactly how paper 000 generates its synthetic snow data.
``'planar'``
    :mod:`roadgrip.vehicle.planar`: speed, wheel spin, combined slip and load
    transfer, driven by torques from a speed controller.

Both are integrated by fixed-step RK4 at ``internal_rate`` (>= 500 Hz, a whole
multiple of the output rate) in :mod:`roadgrip.sim.engine`. Truth columns are
exact values at the output times; measured columns pass through the sensor
models of :mod:`roadgrip.sim.sensors`.

Truth conventions
-----------------
* ``Fxf_true``, ``Fyf_true`` (and rear): axle forces in the *tire* frame [N],
  so ``Fyf_true / Fzf_true`` is the combined-slip lateral friction of the front
  axle and equals ``Drive.true_tire('front')`` at ``alpha_f_true`` whenever the
  longitudinal force is zero.
* ``mu_true``: peak friction of the surface under the vehicle's CG [-].
* ``kappa_*_true``: longitudinal slip of each wheel (paper 002, eq. 2).
* ``x_true``, ``y_true``, ``psi_true``, ``steer_true``: exact pose (heading
  unwrapped, so laps count) and steering; the measured ``psi`` is wrapped to
  ``(-pi, pi]`` as a localisation system reports it.
* ``meta.truth``: ``surfaces`` (curves per label), ``sensors`` (noise model of
  each channel), ``scenario``, ``seed``, ``model``, ``internal_rate``, ``v_eps``,
  ``friction_field`` and anything the caller adds.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from roadgrip.constants import GRAVITY, V_EPS
from roadgrip.drive import Drive
from roadgrip.sim import engine
from roadgrip.sim.friction import FrictionField, SurfaceTires, tire_table
from roadgrip.sim.maneuvers import Maneuver
from roadgrip.sim.sensors import SensorSpec, apply_sensors, sensors_to_dict
from roadgrip.sim.track import TrackDriver
from roadgrip.vehicle.lateral import lateral_derivatives
from roadgrip.vehicle.params import VehicleParams
from roadgrip.vehicle.planar import (
    OMEGA_EPS,
    PlanarTires,
    axle_torques,
    free_rolling_omegas,
    planar_forces,
    wheel_speeds,
)
from roadgrip.vehicle.slip import longitudinal_slip, slip_angles, wheel_centre_speeds

__all__ = ["MEASURED_COLUMNS", "MIN_INTERNAL_RATE", "simulate"]

MIN_INTERNAL_RATE = 500.0
"""Lowest internal integration rate [Hz]."""

MEASURED_COLUMNS = (
    "ax", "ay", "yaw_rate", "steer", "vx",
    "omega_fl", "omega_fr", "omega_rl", "omega_rr", "x", "y", "psi",
)


def _internal_rate(output_rate: float, internal_rate: float | None) -> float:
    if output_rate <= 0 or not np.isfinite(output_rate):
        raise ValueError(f"output_rate must be positive, got {output_rate!r}")
    target = MIN_INTERNAL_RATE if internal_rate is None else float(internal_rate)
    if target < MIN_INTERNAL_RATE:
        raise ValueError(f"internal_rate must be >= {MIN_INTERNAL_RATE} Hz, got {target}")
    k = int(np.ceil(target / output_rate - 1e-9))
    return k * output_rate


def _surface_list(friction: FrictionField, surfaces: Mapping[str, SurfaceTires]) -> list[SurfaceTires]:
    missing = [s for s in friction.labels if s not in surfaces]
    if missing:
        raise ValueError(f"friction field uses surface(s) {missing} with no tire curves; given {sorted(surfaces)}")
    return [surfaces[s] for s in friction.labels]


def simulate(
    vehicle: VehicleParams,
    maneuver: Maneuver | TrackDriver,
    friction: FrictionField,
    surfaces: Mapping[str, SurfaceTires] | Sequence[SurfaceTires],
    *,
    duration: float,
    model: str = "planar",
    output_rate: float = 100.0,
    internal_rate: float | None = None,
    sensors: Mapping[str, SensorSpec] | None = None,
    seed: int = 0,
    name: str = "custom",
    v_eps: float = V_EPS,
    initial_pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
    truth_extra: Mapping[str, Any] | None = None,
    progress: bool = False,
) -> Drive:
    """Simulate a drive with full ground truth.

    Parameters
    ----------
    vehicle : VehicleParams
    maneuver : Maneuver or TrackDriver
        Open-loop references (both models) or closed-track driving (planar only).
    friction : FrictionField
        Which surface is where / when.
    surfaces : mapping label -> SurfaceTires, or a sequence of them
        True curves of every label the field uses.
    duration : float
        Simulated time [s].
    model : {'planar', 'lateral'}
    output_rate : float
        Output sample rate [Hz].
    internal_rate : float, optional
        Integration rate [Hz]; rounded up to a multiple of ``output_rate``,
        at least :data:`MIN_INTERNAL_RATE`.
    sensors : mapping column -> SensorSpec, optional
        Measurement models of the columns in :data:`MEASURED_COLUMNS`; columns
        without one are exact.
    seed : int
        Seeds the manoeuvre's randomness and the sensor noise.
    name : str
        Scenario name (``meta.source = 'sim:<name>'``).
    v_eps : float
        Slip regularisation [m/s].
    initial_pose : (x, y, psi)
        Start pose [m, m, rad] for open-loop manoeuvres.
    truth_extra : mapping, optional
        Extra JSON-serialisable entries for ``meta.truth``.
    progress : bool
        Print a line to stderr before integrating.

    Returns
    -------
    Drive
        Columns :data:`MEASURED_COLUMNS` plus ``roadgrip.drive.TRUTH_COLUMNS``.
    """
    if duration <= 0 or not np.isfinite(duration):
        raise ValueError(f"duration must be positive, got {duration!r}")
    if model not in ("planar", "lateral"):
        raise ValueError(f"model must be 'planar' or 'lateral', got {model!r}")
    if not isinstance(surfaces, Mapping):
        surfaces = {s.label: s for s in surfaces}
    rate = _internal_rate(output_rate, internal_rate)
    dt = 1.0 / rate
    n = round(duration * rate)
    surf_list = _surface_list(friction, surfaces)
    table, peaks = tire_table(surf_list)
    field = engine.field_code(friction.encode())
    ss = np.random.SeedSequence(seed)
    rng_man, rng_sens = (np.random.default_rng(s) for s in ss.spawn(2))
    sensors = dict(sensors or {})
    unknown = sorted(set(sensors) - set(MEASURED_COLUMNS))
    if unknown:
        raise ValueError(f"sensor models for unknown column(s) {unknown}; measured columns: {MEASURED_COLUMNS}")

    if progress:
        print(f"simulating {name} ({duration:.0f} s at {rate:.0f} Hz)", file=sys.stderr, flush=True)
    if model == "lateral":
        if not isinstance(maneuver, Maneuver):
            raise ValueError("the lateral model needs an open-loop Maneuver (it has no path follower)")
        true, extra = _run_lateral(vehicle, maneuver, n, dt, table, field, surf_list, v_eps,
                                   initial_pose, rng_man)
    else:
        true, extra = _run_planar(vehicle, maneuver, n, dt, table, peaks, field, surf_list,
                                  v_eps, initial_pose, rng_man)

    t_int = np.arange(n + 1) * dt
    step = round(rate / output_rate)
    idx = np.arange(0, n + 1, step)
    t_out = t_int[idx]
    meas_true = {c: true[c] for c in MEASURED_COLUMNS}
    psi_unwrapped = meas_true["psi"]
    measured = apply_sensors(t_int, meas_true, t_out, sensors, rng_sens)
    measured["psi"] = np.angle(np.exp(1j * measured["psi"]))
    cols: dict[str, Any] = {"t": t_out}
    cols.update(measured)
    for c in ("vx_true", "vy_true", "yaw_rate_true", "alpha_f_true", "alpha_r_true",
              "kappa_fl_true", "kappa_fr_true", "kappa_rl_true", "kappa_rr_true", "mu_true",
              "Fxf_true", "Fxr_true", "Fyf_true", "Fyr_true", "Fzf_true", "Fzr_true"):
        cols[c] = true[c][idx]
    for c in ("x", "y"):
        cols[f"{c}_true"] = true[c][idx]
    cols["psi_true"] = psi_unwrapped[idx]
    cols["steer_true"] = true["steer"][idx]
    labels = np.array([s.label for s in surf_list], dtype=object)
    cols["surface"] = labels[true["surf"][idx]]
    df = pd.DataFrame(cols)
    truth: dict[str, Any] = {
        "scenario": name,
        "seed": int(seed),
        "model": model,
        "internal_rate": rate,
        "v_eps": v_eps,
        "force_frame": "tire",
        "surfaces": {s.label: s.to_dict() for s in surf_list},
        "sensors": sensors_to_dict({c: sensors.get(c, SensorSpec()) for c in MEASURED_COLUMNS}),
        "friction_field": dict(friction.to_dict(), mu={s.label: s.mu for s in surf_list}),
        "max_substeps": int(extra.get("max_substeps", 1)),
    }
    truth.update(dict(truth_extra or {}))
    # Simulated signals are SI by construction: the unit-plausibility heuristics meant
    # for foreign logs are skipped (they can misfire on noisy measured speed); the
    # structural checks (NaN/inf, time order) still run.
    return Drive.from_frame(df, vehicle, source=f"sim:{name}", truth=truth, check_units=False)


def _run_lateral(vehicle, maneuver, n, dt, table, field, surf_list, v_eps, pose0, rng):
    t_h = np.arange(2 * n + 1) * (dt / 2.0)
    sig = maneuver.sample(t_h, vehicle, rng)
    S = engine.LateralSimState
    x0 = np.zeros(S.SIZE)
    x0[S.X], x0[S.Y], x0[S.PSI] = pose0
    p = engine.LateralParams(
        mass=float(vehicle.mass), yaw_inertia=float(vehicle.yaw_inertia), lf=float(vehicle.lf),
        lr=float(vehicle.lr), fz_front=float(vehicle.fz_front), fz_rear=float(vehicle.fz_rear),
        v_eps=float(v_eps),
    )
    driver = engine.LateralDriver(
        vx_h=sig.v_ref, steer_h=sig.steer_ff, rref_h=sig.r_ref, k_r=float(maneuver.yaw_gain),
        k_b=float(maneuver.sideslip_gain), max_steer=float(vehicle.max_steer),
    )
    states, steer, surf = engine.integrate_lateral(x0, dt, n, driver, table, p, field)
    vx = sig.v_ref[::2]
    dvx = sig.a_ref[::2]
    vy, r = states[:, S.VY], states[:, S.YAW_RATE]
    af, ar = slip_angles(vx, vy, r, steer, vehicle, v_eps=v_eps)
    muf = np.empty_like(af)
    mur = np.empty_like(ar)
    for i, s in enumerate(surf_list):
        m = surf == i
        muf[m] = s.front.mu(af[m])
        mur[m] = s.rear.mu(ar[m])
    xdot = lateral_derivatives(states[:, :2], np.stack([steer, vx], -1), muf, mur, vehicle)
    fzf = np.full_like(vx, vehicle.fz_front)
    fzr = np.full_like(vx, vehicle.fz_rear)
    wf, wr = free_rolling_omegas(vx, vy, r, steer, vehicle)
    true = _common_truth(vehicle, vx, vy, r, steer, states[:, S.X], states[:, S.Y], states[:, S.PSI],
                         wf, wr, v_eps)
    true.update(
        ax=dvx - r * vy,
        ay=xdot[:, 0] + vx * r,
        alpha_f_true=af, alpha_r_true=ar,
        Fxf_true=np.zeros_like(vx), Fxr_true=np.zeros_like(vx),
        Fyf_true=fzf * muf, Fyr_true=fzr * mur, Fzf_true=fzf, Fzr_true=fzr,
        mu_true=np.array([s.mu for s in surf_list])[surf], surf=surf,
    )
    return true, {}


def _common_truth(vehicle, vx, vy, r, steer, x, y, psi, wf, wr, v_eps):
    w = wheel_speeds(wf, wr, r, steer, vehicle)
    vc = wheel_centre_speeds(vx, vy, r, steer, vehicle).T
    kap = [longitudinal_slip(wi, vi, vehicle.wheel_radius, v_eps=v_eps) for wi, vi in zip(w, vc, strict=True)]
    return {
        "yaw_rate": r, "steer": steer, "vx": vx, "x": x, "y": y, "psi": psi,
        "omega_fl": w[0], "omega_fr": w[1], "omega_rl": w[2], "omega_rr": w[3],
        "vx_true": vx, "vy_true": vy, "yaw_rate_true": r,
        "kappa_fl_true": kap[0], "kappa_fr_true": kap[1], "kappa_rl_true": kap[2], "kappa_rr_true": kap[3],
    }


def _max_slopes(surf_list):
    kx = max(max(s.front_long.slope0(), s.rear_long.slope0()) for s in surf_list)
    ky = max(max(s.front.slope0(), s.rear.slope0()) for s in surf_list)
    return kx, ky


def _run_planar(vehicle, maneuver, n, dt, table, peaks, field, surf_list, v_eps, pose0, rng):
    S = engine.PlanarSimState
    t = np.arange(n + 1) * dt
    zeros = np.zeros(n + 1)
    empty = np.zeros(1)
    x0 = np.zeros(S.SIZE)
    if isinstance(maneuver, TrackDriver):
        tr = maneuver.track
        path_v = maneuver.path_speed()
        steer_mode = 1
        steer_ff = rref = v_ref = a_ref = zeros
        k_r = 0.0
        path_x, path_y = tr.x.astype(float), tr.y.astype(float)
        x0[S.VX] = path_v[0]
        x0[S.X], x0[S.Y], x0[S.PSI] = tr.x[0], tr.y[0], tr.heading()[0]
        la0, lag, prev = maneuver.lookahead0, maneuver.lookahead_gain, maneuver.speed_preview
    elif isinstance(maneuver, Maneuver):
        sig = maneuver.sample(t, vehicle, rng)
        steer_mode = 0
        steer_ff, rref, v_ref, a_ref = sig.steer_ff, sig.r_ref, sig.v_ref, sig.a_ref
        k_r = maneuver.yaw_gain
        path_x = path_y = path_v = empty
        x0[S.VX] = v_ref[0]
        x0[S.X], x0[S.Y], x0[S.PSI] = pose0
        la0 = lag = prev = 0.0
    else:
        raise ValueError(f"maneuver must be a Maneuver or TrackDriver, got {type(maneuver).__name__}")
    x0[S.OMEGA_F] = x0[S.OMEGA_R] = x0[S.VX] / vehicle.wheel_radius
    iw = 2.0 * vehicle.wheel_inertia
    p = engine.PlanarParams(
        mass=vehicle.mass, yaw_inertia=vehicle.yaw_inertia, lf=vehicle.lf, lr=vehicle.lr,
        cg_height=vehicle.cg_height, wheel_radius=vehicle.wheel_radius, wheel_inertia=iw,
        v_eps=v_eps, gravity=GRAVITY, omega_eps=OMEGA_EPS, max_steer=vehicle.max_steer,
    ).vector()
    kx, ky = _max_slopes(surf_list)
    R = vehicle.wheel_radius
    m = vehicle.mass
    lam_wheel = 1.2 * R**2 * m * GRAVITY * kx / iw
    lam_body = 1.2 * GRAVITY * ky * (1.0 + m * max(vehicle.lf, vehicle.lr) ** 2 / vehicle.yaw_inertia)
    tdf_share = axle_torques(1.0, 0.0, vehicle)[0]
    tbf_share = axle_torques(0.0, 1.0, vehicle)[2]
    model = engine.PlanarModel(p, table, peaks, lam_wheel=float(lam_wheel), lam_body=float(lam_body))
    ref = engine.SteerReference(steer_ff, rref, v_ref, a_ref, k_r=float(k_r))
    path = engine.PursuitPath(path_x, path_y, path_v, lookahead0=float(la0), lookahead_gain=float(lag),
                              speed_preview=float(prev))
    speed = engine.SpeedControl(
        kp=2.0, ki=0.5, drive_front=float(tdf_share), brake_front=float(tbf_share),
        max_drive=float(0.6 * m * GRAVITY * R), max_brake=float(1.0 * m * GRAVITY * R),
    )
    states, ctrl, surf, nsub = engine.integrate_planar(x0, dt, n, model, steer_mode, ref, path, speed, field)
    if not np.all(np.isfinite(states)):
        raise RuntimeError(f"planar simulation diverged (first non-finite state at step "
                           f"{int(np.argmax(~np.isfinite(states).all(1)))})")
    steer = ctrl[:, engine.C_STEER]
    vx, vy, r = states[:, S.VX], states[:, S.VY], states[:, S.YAW_RATE]
    wf, wr = states[:, S.OMEGA_F], states[:, S.OMEGA_R]
    xp = states[:, :5]
    fields = {k: np.empty(n + 1) for k in ("af", "ar", "mxf", "mxr", "myf", "myr", "fzf", "fzr", "ax", "ay")}
    for i, s in enumerate(surf_list):
        msk = surf == i
        if not msk.any():
            continue
        f = planar_forces(xp[msk], steer[msk], vehicle, PlanarTires(s.front, s.rear, s.front_long, s.rear_long),
                          v_eps=v_eps)
        for k, v in (("af", f.alpha_f), ("ar", f.alpha_r), ("mxf", f.mux_f), ("mxr", f.mux_r),
                     ("myf", f.muy_f), ("myr", f.muy_r), ("fzf", f.fzf), ("fzr", f.fzr),
                     ("ax", f.ax), ("ay", f.ay)):
            fields[k][msk] = v
    true = _common_truth(vehicle, vx, vy, r, steer, states[:, S.X], states[:, S.Y], states[:, S.PSI],
                         wf, wr, v_eps)
    fzf, fzr = fields["fzf"], fields["fzr"]
    true.update(
        ax=fields["ax"], ay=fields["ay"],
        alpha_f_true=fields["af"], alpha_r_true=fields["ar"],
        Fxf_true=fzf * fields["mxf"], Fxr_true=fzr * fields["mxr"],
        Fyf_true=fzf * fields["myf"], Fyr_true=fzr * fields["myr"], Fzf_true=fzf, Fzr_true=fzr,
        mu_true=np.array([s.mu for s in surf_list])[surf], surf=surf,
        drive_torque=ctrl[:, engine.C_DRIVE_F] + ctrl[:, engine.C_DRIVE_R],
        brake_torque=ctrl[:, engine.C_BRAKE_F] + ctrl[:, engine.C_BRAKE_R],
    )
    return true, {"max_substeps": int(nsub.max())}
