r"""A seeded family of random vehicles for the multi-body engine.

:func:`sample_vehicle` draws a vehicle around one of the engine's two CommonRoad
parameter sets (:data:`FAMILY_BASES`: set 1, the Ford Escort, and set 3, the VW
Vanagon): its masses and inertias, wheelbase and CG position, CG height, track,
wheel radius, tires (slip stiffnesses, shape and curvature factors, the load
sensitivity of their peaks and stiffnesses), roll stiffness, brake balance and
drive layout, each uniformly within :data:`FAMILY_RANGES`. CommonRoad's set 2
(the BMW 320i) is never a base: it is kept apart for independent evaluation.

The result is a :class:`~roadgrip.sim.mb_model.MBVehicle`: the package's
parameter object the engine integrates, and the estimators' description of the
same vehicle (:class:`~roadgrip.vehicle.params.VehicleParams`) with the true
cornering stiffnesses of its tires at the static wheel loads, its drive layout
and its body gradients. A vehicle sampled from ``random:SEED`` carries realistic
sensor errors drawn with it (:func:`roadgrip.sim.sensors.sample_sensor_errors`)
unless ideal sensors are asked for.

The peaks of the tires are not sampled: the surface's friction is their peak at
the nominal load (a quarter of the vehicle's weight), so that ``mu_true`` keeps
its meaning on every vehicle; their load sensitivity is.

The engine distributes drive and brake torque by the package's splits ``T_se``
and ``T_sb`` (front share; the driver's acceleration command times ``m R_w`` is
the torque): a front-wheel drive has ``T_se = 1``, a rear-wheel drive 0, an
all-wheel drive the front share drawn in ``awd_front_share``.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from roadgrip.constants import GRAVITY
from roadgrip.sim.mb_model import (
    BODY_GRADIENTS,
    COMMONROAD_VEHICLES,
    MBVehicle,
    body_gradients,
    commonroad_parameters,
    named_mb_vehicle,
    single_track_params,
)
from roadgrip.sim.sensors import sample_sensor_errors

__all__ = [
    "DRIVE_LAYOUTS",
    "FAMILY_BASES",
    "FAMILY_RANGES",
    "SENSOR_MODES",
    "axle_peak_slip",
    "fit_truth",
    "mb_vehicle",
    "parse_vehicle_spec",
    "sample_vehicle",
]

FAMILY_BASES: dict[str, int] = {"ford-escort": 1, "vw-vanagon": 3}
"""Base vehicles of the family and their CommonRoad parameter sets (set 2 is never used)."""

FAMILY_RANGES: dict[str, tuple[float, float, str, str]] = {
    "mass_scale": (0.85, 1.20, "-", "sprung and unsprung masses (and the body's inertias) over the base's"),
    "yaw_inertia_scale": (0.90, 1.10, "-", "yaw inertia over the base's scaled by mass and wheelbase²"),
    "wheelbase_scale": (0.95, 1.08, "-", "wheelbase over the base's"),
    "cg_front_shift": (-0.05, 0.05, "-", "sprung mass's a / (a + b) minus the base's (CG position)"),
    "cg_height_scale": (0.90, 1.12, "-", "sprung mass's CG height (and the total's) over the base's"),
    "track_scale": (0.95, 1.06, "-", "both track widths over the base's"),
    "wheel_radius_scale": (0.90, 1.10, "-", "rolling radius over the base's (wheel inertia by its square)"),
    "cornering_stiffness": (16.0, 28.0, "1/rad", "tire's lateral slip stiffness per unit load |p_ky1| (21.9)"),
    "longitudinal_stiffness": (16.0, 28.0, "-", "tire's longitudinal slip stiffness per unit load p_kx1 (22.3)"),
    "shape_lateral": (1.20, 1.50, "-", "lateral shape factor p_cy1 (1.35)"),
    "shape_longitudinal": (1.45, 1.80, "-", "longitudinal shape factor p_cx1 (1.64)"),
    "curvature_lateral": (-0.60, 0.00, "-", "lateral curvature factor p_ey1 (-0.007; a positive one sharpens "
                                             "the peak into a snap: one at 0.22 spun a van in the snow slalom)"),
    "curvature_longitudinal": (0.00, 0.60, "-", "longitudinal curvature factor p_ex1 (0.46)"),
    "peak_load_x": (-0.20, -0.05, "-", "relative change of the longitudinal peak per relative load change"),
    "peak_load_y": (-0.20, -0.05, "-", "relative change of the lateral peak per relative load change"),
    "stiffness_load_x": (-0.35, -0.05, "-", "relative change of p_kx1 F_z / F_z per relative load change"),
    "stiffness_load_y": (-0.35, -0.05, "-", "relative change of |p_ky1| F_z / F_z per relative load change"),
    "roll_stiffness_scale": (0.80, 1.25, "-", "suspension springs and anti-roll torsion over the base's "
                                              "(mass-scaled; dampers by the square root)"),
    "brake_front_share": (0.60, 0.78, "-", "front share of the brake torque T_sb (0.76, 0.64)"),
    "awd_front_share": (0.30, 0.60, "-", "front share of the drive torque T_se of an all-wheel drive"),
}
"""Range of each sampled quantity: ``(low, high, unit, meaning)``; uniform draws. Around the
two bases, from a small hatchback (1040 kg) to a loaded van (1780 kg)."""

DRIVE_LAYOUTS: dict[str, float | None] = {"fwd": 1.0, "rwd": 0.0, "awd": None}
"""Drive layout -> front share of the drive torque (None: drawn in ``awd_front_share``);
equally likely."""

SENSOR_MODES = ("ideal", "realistic")
"""``ideal``: the scenario's sensors as they are (noise only); ``realistic``: with the errors of
:func:`roadgrip.sim.sensors.sample_sensor_errors`."""

_RANDOM_PREFIX = "random:"


def parse_vehicle_spec(spec: str) -> tuple[str, int | None]:
    """``('ford-escort', None)``, ``('vw-vanagon', None)`` or ``('random', SEED)`` from a
    ``--vehicle`` value; a clear error otherwise."""
    if spec in COMMONROAD_VEHICLES:
        return spec, None
    if isinstance(spec, str) and spec.startswith(_RANDOM_PREFIX):
        text = spec[len(_RANDOM_PREFIX):]
        if text.isdigit():
            return "random", int(text)
    known = ", ".join([*COMMONROAD_VEHICLES, "random:SEED (SEED a whole number >= 0)"])
    raise ValueError(f"unknown multi-body vehicle {spec!r}; known: {known}")


def _draw(rng: np.random.Generator, key: str) -> float:
    lo, hi, _, _ = FAMILY_RANGES[key]
    return float(rng.uniform(lo, hi))


def sample_vehicle(seed: int, *, sensors: str = "realistic") -> MBVehicle:
    """The family's vehicle ``random:seed``.

    Parameters
    ----------
    seed : int
        Same seed, same vehicle (and same sensor errors), >= 0.
    sensors : {'realistic', 'ideal'}
        Draw sensor errors with the vehicle, or leave the scenario's sensors as they are.
        The vehicle does not depend on this choice.

    Returns
    -------
    MBVehicle
        ``description`` holds the base, the drive layout and every sampled value of
        :data:`FAMILY_RANGES` (JSON-serialisable).
    """
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"a family vehicle's seed must be a whole number >= 0, got {seed!r}")
    if sensors not in SENSOR_MODES:
        raise ValueError(f"sensors must be one of {SENSOR_MODES}, got {sensors!r}")
    rng = np.random.default_rng([int(seed), 29, 1])
    base = list(FAMILY_BASES)[int(rng.integers(len(FAMILY_BASES)))]
    layout = list(DRIVE_LAYOUTS)[int(rng.integers(len(DRIVE_LAYOUTS)))]
    draws = {key: _draw(rng, key) for key in FAMILY_RANGES}
    if layout != "awd":
        draws.pop("awd_front_share")
    p0 = commonroad_parameters(FAMILY_BASES[base])
    p = _sampled_parameters(p0, draws, layout)
    load = {k: draws[k] for k in ("peak_load_x", "peak_load_y", "stiffness_load_x", "stiffness_load_y")}
    g_new, g_base = body_gradients(p), body_gradients(p0)
    gradients = tuple(BODY_GRADIENTS[base][i] * g_new[i] / g_base[i] for i in range(2))
    name = f"{_RANDOM_PREFIX}{int(seed)}"
    vp = single_track_params(name, p, drive=layout, gradients=gradients,
                             stiffness_load=draws["stiffness_load_y"])
    description: dict[str, Any] = {
        "name": name, "seed": int(seed), "base": base, "base_parameter_set": FAMILY_BASES[base],
        "drive": layout, "sampled": draws,
        "commonroad": {k: float(getattr(p, k)) for k in (
            "m", "m_s", "m_uf", "m_ur", "a", "b", "I_z", "h_s", "h_cg", "T_f", "T_r", "R_w", "I_y_w",
            "K_sf", "K_sr", "K_tsf", "K_tsr", "T_sb", "T_se")},
        "tire": {k: float(getattr(p.tire, k)) for k in ("p_ky1", "p_kx1", "p_cy1", "p_cx1", "p_ey1", "p_ex1")},
        "load_sensitivity": load,
        "nominal_wheel_load": float(p.m * GRAVITY / 4.0),
    }
    errors = sample_sensor_errors(np.random.default_rng([int(seed), 29, 2])) if sensors == "realistic" else None
    return MBVehicle(name=name, commonroad=p, params=vp, load_sensitivity=load, description=description,
                     sensors=errors)


def _sampled_parameters(p0, d: dict[str, float], layout: str):
    """The base's parameter object with the draws applied (a copy; the base is unchanged)."""
    fm, fr = d["mass_scale"], d["roll_stiffness_scale"]
    wb0 = p0.a + p0.b
    wb = wb0 * d["wheelbase_scale"]
    a = (p0.a / wb0 + d["cg_front_shift"]) * wb
    ft, fw, fh = d["track_scale"], d["wheel_radius_scale"], d["cg_height_scale"]
    m_s, m_uf, m_ur = p0.m_s * fm, p0.m_uf * fm, p0.m_ur * fm
    drive_front = DRIVE_LAYOUTS[layout]
    tire = dataclasses.replace(
        p0.tire, p_ky1=-d["cornering_stiffness"], p_kx1=d["longitudinal_stiffness"], p_cy1=d["shape_lateral"],
        p_cx1=d["shape_longitudinal"], p_ey1=d["curvature_lateral"], p_ex1=d["curvature_longitudinal"])
    return dataclasses.replace(
        p0, tire=tire, steering=dataclasses.replace(p0.steering),
        longitudinal=dataclasses.replace(p0.longitudinal), trailer=dataclasses.replace(p0.trailer),
        m=m_s + m_uf + m_ur, m_s=m_s, m_uf=m_uf, m_ur=m_ur, a=a, b=wb - a,
        I_Phi_s=p0.I_Phi_s * fm * ft**2, I_y_s=p0.I_y_s * fm * d["wheelbase_scale"] ** 2,
        I_z=p0.I_z * fm * d["wheelbase_scale"] ** 2 * d["yaw_inertia_scale"],
        I_uf=p0.I_uf * fm * ft**2, I_ur=p0.I_ur * fm * ft**2,
        K_sf=p0.K_sf * fm * fr, K_sr=p0.K_sr * fm * fr,
        K_sdf=p0.K_sdf * fm * np.sqrt(fr), K_sdr=p0.K_sdr * fm * np.sqrt(fr),
        K_tsf=p0.K_tsf * fm * fr * ft**2, K_tsr=p0.K_tsr * fm * fr * ft**2,
        T_f=p0.T_f * ft, T_r=p0.T_r * ft, h_s=p0.h_s * fh, h_cg=p0.h_cg * fh,
        R_w=p0.R_w * fw, I_y_w=p0.I_y_w * fw**2,
        T_sb=d["brake_front_share"], T_se=d["awd_front_share"] if drive_front is None else drive_front,
    )


def mb_vehicle(spec: str, *, sensors: str | None = None, seed: int = 0) -> MBVehicle:
    """The multi-body vehicle of a ``--vehicle`` value.

    Parameters
    ----------
    spec : str
        ``'ford-escort'``, ``'vw-vanagon'`` or ``'random:SEED'``.
    sensors : {'ideal', 'realistic'}, optional
        Default: ideal for a named vehicle, realistic for ``random:``.
    seed : int
        Seeds a named vehicle's realistic sensor errors (a family vehicle's come with it).
    """
    kind, vseed = parse_vehicle_spec(spec)
    if sensors is not None and sensors not in SENSOR_MODES:
        raise ValueError(f"sensors must be one of {', '.join(SENSOR_MODES)}, got {sensors!r}")
    if kind == "random":
        assert vseed is not None
        return sample_vehicle(vseed, sensors=sensors or "realistic")
    vehicle = named_mb_vehicle(kind)
    if sensors == "realistic":
        errors = sample_sensor_errors(np.random.default_rng([int(seed), 29, 3]))
        vehicle = dataclasses.replace(vehicle, sensors=errors)
    return vehicle


def axle_peak_slip(vehicle: MBVehicle, mu: float) -> tuple[float, float]:
    """Slip angle of the peak lateral force of a front and of a rear tire [rad].

    Pure lateral slip at zero camber and each axle's static wheel load, on a surface of
    peak friction ``mu``: the slip past which a tire of the axle is beyond its peak.
    """
    from roadgrip.sim.mb_model import compiled_rhs

    lateral = compiled_rhs().formula_lateral
    tire = vehicle.parameter_tuple(mu).tire
    vp = vehicle.params
    wb = vp.lf + vp.lr
    alphas = np.linspace(0.0, 0.5, 5001)
    out = []
    for share in (vp.lr / wb, vp.lf / wb):
        fz = 0.5 * vp.mass * GRAVITY * share
        fy = np.array([lateral(a, 0.0, fz, tire)[0] for a in alphas])
        out.append(float(alphas[np.argmax(np.abs(fy))]))
    return out[0], out[1]


def fit_truth(vehicle: MBVehicle, duration: float) -> dict[str, float]:
    """What ``roadgrip vehicle fit`` should find on a drive of ``vehicle`` lasting ``duration`` [s].

    The front cornering stiffness in series with the steering compliance,
    ``1/(1/C_f + c)``, the rear the tire's [N/rad]; each delay its sensor's latency minus the
    gyro's [s] (the speed's: the undriven wheels', or the ``vx`` column's on an all-wheel
    drive; ``a_x``'s its own); the steering offset the road-wheel angle at a zero reading,
    ``-offset/(1 + ratio_error)`` [rad]; the gyro's scale [-] and bias [rad/s] and the pose's
    heading bias [rad], each bias at the drive's middle (a sensor's bias drifts linearly).
    Keyed as :class:`~roadgrip.inference.vehicle_identification.VehicleFit` values.
    """
    vp, ch, st = vehicle.params, vehicle.sensors.channels, vehicle.sensors.steering
    gyro = ch["yaw_rate"].delay
    speed = ch["vx"].delay if vp.drive == "awd" else ch["omega_fl"].delay  # a free-rolling wheel's
    mid = 0.5 * duration
    return {"cornering_stiffness_front": 1.0 / (1.0 / vp.cornering_stiffness_front + st.compliance),
            "cornering_stiffness_rear": vp.cornering_stiffness_rear,
            "delay_accelerometer": ch["ay"].delay - gyro, "steer_delay": ch["steer"].delay - gyro,
            "delay_speed": speed - gyro, "delay_pose": ch["psi"].delay - gyro,
            "delay_accelerometer_x": ch["ax"].delay - gyro,
            "steer_offset": -st.offset / (1.0 + st.ratio_error),
            "yaw_rate_scale": ch["yaw_rate"].scale,
            "yaw_rate_bias": ch["yaw_rate"].bias + ch["yaw_rate"].drift * mid,
            "pose_heading_bias": ch["psi"].bias + ch["psi"].drift * mid}
