"""The named scenarios on the multi-body engine (:mod:`roadgrip.sim.multibody`).

Each builder turns a scenario into a path with a speed profile and a friction
field, and drives a CommonRoad vehicle along it with the engine's closed-loop
driver. The driver does not know the friction: on a slippery surface it asks
for what the path asks for, and the tires saturate.

==================  ==================================================================
scenario            multi-body set-up
==================  ==================================================================
snow-slalom         mu 0.3 everywhere; a slalom whose lateral demand rises and falls
                    between about 0.3 and 1.6 times mu g (period 40 s); 25 Hz
dry-gravel-dry      1.0 -> 0.5 -> 1.0 by time (60 s each); per segment acceleration,
                    braking, a slalom and a double lane change at 0.4-0.5 g; 100 Hz
figure-eight        laps of a lemniscate (524 m a lap) over dry asphalt (1.0) with
                    snow (0.3), gravel (0.6) and a wet crossing (0.6); every second
                    lap the car brakes to 3 m/s on the wet crossing and pulls away
straight-cruise     20 m/s straight; the friction drops from 1.0 to 0.3 half-way,
                    where nothing excites the tires
vehicle-id          an identification drive for ``roadgrip vehicle fit``: dry asphalt
                    (1.0), at each of 8, 12, 16 and 20 m/s a speed pulse, two slaloms
                    (periods about 2.5 s and 4.5 s, 0.3 g) and a lane change in the
                    linear range, then a braking and an acceleration step; 100 Hz
==================  ==================================================================
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from roadgrip.constants import GRAVITY
from roadgrip.drive import Drive
from roadgrip.sim.friction import ConstantFriction, Patch, PatchFriction, PiecewiseTime
from roadgrip.sim.mb_driver import Path
from roadgrip.sim.mb_model import MBVehicle
from roadgrip.sim.multibody import simulate_multibody
from roadgrip.sim.scenarios import DGD_SEGMENT, dgd_truth
from roadgrip.sim.sensors import SensorSpec
from roadgrip.sim.track import ClosedTrack

__all__ = [
    "FIGURE_EIGHT_MU",
    "FIGURE_EIGHT_PATCHES",
    "MB_BUILDERS",
    "MB_SENSORS",
    "VEHICLE_ID_SPEEDS",
    "lemniscate",
]

MB_SENSORS = {
    "ax": SensorSpec(noise_std=0.1),
    "ay": SensorSpec(noise_std=0.1),
    "yaw_rate": SensorSpec(noise_std=0.005),
    "steer": SensorSpec(noise_std=0.001),
    "vx": SensorSpec(noise_std=0.05),
    "omega_fl": SensorSpec(noise_std=0.05),
    "omega_fr": SensorSpec(noise_std=0.05),
    "omega_rl": SensorSpec(noise_std=0.05),
    "omega_rr": SensorSpec(noise_std=0.05),
    "x": SensorSpec(noise_std=0.1),
    "y": SensorSpec(noise_std=0.1),
    "psi": SensorSpec(noise_std=0.005),
}
"""Sensor noise of the multi-body drives (production-grade accelerometer, gyro,
wheel-speed encoders, steering sensor and a localisation pose)."""

_DS = 0.5  # path point spacing [m]


def _straight_path(length: float, lateral=None) -> tuple[NDArray, NDArray]:
    s = np.arange(0.0, length + _DS, _DS)
    y = np.zeros_like(s) if lateral is None else lateral(s)
    return s, y


# ------------------------------------------------------------------------------------
def _snow_slalom(seed: int, duration: float, progress: bool, vehicle: str | MBVehicle) -> Drive:
    rng = np.random.default_rng([seed, 10])
    mu = 0.3
    v = float(rng.uniform(11.0, 13.0))
    wavelength = float(rng.uniform(50.0, 65.0))
    k = 2 * np.pi / wavelength
    env_len = 40.0 * v  # one rise and fall of the demand every 40 s
    phase = float(rng.uniform(0, 2 * np.pi))

    def lateral(s):
        demand = mu * GRAVITY * (0.3 + 1.3 * np.sin(np.pi * s / env_len) ** 2)  # [m/s²]
        amp = demand / (v * k) ** 2
        return amp * np.sin(k * s + phase) - amp[0] * np.sin(phase)

    x, y = _straight_path(v * duration + 300.0, lateral)
    path = Path(x, y, np.full_like(x, v))
    return simulate_multibody(
        vehicle, path, ConstantFriction("snow"), {"snow": mu}, duration=duration,
        output_rate=25.0, sensors=MB_SENSORS, seed=seed, name="snow-slalom", progress=progress,
        truth_extra={"speed": v, "wavelength": wavelength},
    )


# ------------------------------------------------------------------------------------
def _lane_shape(tau: NDArray, offset: float, change_time: float) -> NDArray:
    """Jerk-limited lane change: ``offset (u - sin(2 pi u) / 2 pi)``, ``u = tau / T`` in [0, 1]."""
    u = np.clip(tau / change_time, 0.0, 1.0)
    return offset * (u - np.sin(2 * np.pi * u) / (2 * np.pi))


def _lateral_events(t_of_s: NDArray, t: NDArray, vt: NDArray, events) -> NDArray:
    """Lateral offset [m] of the path at the points reached at ``t_of_s`` [s], given the
    planned speed ``vt`` [m/s] over ``t`` [s] and ``events`` ``(t0, t1, kind, magnitude,
    period)``: a slalom of ``magnitude`` [m/s²] peak lateral acceleration (a full number of
    periods, faded in and out over half a period), or a lane change of ``magnitude`` [m]."""
    y = np.zeros_like(t_of_s)
    for t0, t1, kind, mag, period in events:
        tau = t_of_s - t0
        inside = (t_of_s >= t0) & (t_of_s < t1)
        if kind == "slalom":
            v_ev = np.interp(t0, t, vt)
            k = 2 * np.pi / (v_ev * period)
            amp = mag / (v_ev * k) ** 2
            n_per = np.floor((t1 - t0) / period + 1e-9)
            inside &= tau < n_per * period
            y += np.where(inside, amp * np.sin(2 * np.pi * tau / period)
                          * np.clip(np.minimum(tau, n_per * period - tau) / (0.5 * period), 0, 1), 0.0)
        else:
            hold = (t1 - t0) - 2 * period
            y += np.where(inside, _lane_shape(tau, mag, period)
                          - _lane_shape(tau - period - hold, mag, period), 0.0)
    return y


def _path_from_phases(v0: float, phases, events, t_end: float) -> Path:
    """The path of a straight drive whose speed follows ``phases`` ``(duration [s],
    acceleration [m/s²])`` from ``v0`` [m/s], with the :func:`_lateral_events` placed where
    the car is at their times."""
    t = np.arange(0.0, t_end, 0.01)
    acc = np.zeros_like(t)
    tb = 0.0
    for d, a in phases:
        acc[(t >= tb) & (t < tb + d)] = a
        tb += d
    vt = v0 + np.concatenate([[0.0], np.cumsum(0.5 * (acc[1:] + acc[:-1]) * np.diff(t))])
    st = np.concatenate([[0.0], np.cumsum(0.5 * (vt[1:] + vt[:-1]) * np.diff(t))])
    s = np.arange(0.0, st[-1], _DS)
    t_of_s = np.interp(s, st, t)
    return Path(s, _lateral_events(t_of_s, t, vt, events), np.interp(t_of_s, t, vt))


def _dry_gravel_dry(seed: int, duration: float, progress: bool, vehicle: str | MBVehicle) -> Drive:
    rng = np.random.default_rng([seed, 11])
    labels = ("dry_asphalt", "gravel", "dry_asphalt")
    v0 = 15.0
    phases: list[tuple[float, float]] = []
    events: list[tuple[float, float, str, float, float]] = []  # t0, t1, kind, magnitude, period
    excited = []
    for i in range(len(labels)):
        t0 = i * DGD_SEGMENT
        j = rng.uniform(0.9, 1.1, size=5)
        a_acc, a_brk, ay_sl, a_acc2 = 2.0 * j[0], -3.5 * j[1], 4.5 * j[2], 1.5 * j[3]
        seg = [(8.0, 0.0), (4.0, a_acc), (6.0, 0.0), (3.0, a_brk), (6.0, 0.0), (16.0, 0.0),
               (5.0, 0.0), (4.0, a_acc2), (2.0, 0.0)]
        dv = sum(a * d for d, a in seg)
        seg += [(3.0, -dv / 3.0), (3.0, 0.0)]
        phases += seg
        events.append((t0 + 27.0, t0 + 36.0, "slalom", min(ay_sl, 0.5 * GRAVITY), 3.0 * j[4]))
        events.append((t0 + 37.0, t0 + 43.0, "lane_change", 3.5, 2.5))
        excited += [
            {"t0": t0 + 8.0, "t1": t0 + 12.0, "kind": "acceleration"},
            {"t0": t0 + 18.0, "t1": t0 + 21.0, "kind": "braking"},
            {"t0": t0 + 27.0, "t1": t0 + 43.0, "kind": "cornering"},
            {"t0": t0 + 48.0, "t1": t0 + 52.0, "kind": "acceleration"},
            {"t0": t0 + 54.0, "t1": t0 + 57.0, "kind": "braking"},
        ]
    # planned speed over time, then position over time: events in time become places
    path = _path_from_phases(v0, phases, events, len(labels) * DGD_SEGMENT + 60.0)
    field = PiecewiseTime(tuple(i * DGD_SEGMENT for i in range(len(labels))), labels)
    return simulate_multibody(
        vehicle, path, field, {"dry_asphalt": 1.0, "gravel": 0.5}, duration=duration,
        output_rate=100.0, sensors=MB_SENSORS, seed=seed, name="dry-gravel-dry", progress=progress,
        truth_extra=dgd_truth(field, labels, excited, duration),
    )


# ------------------------------------------------------------------------------------
FIGURE_EIGHT_MU = {"dry_asphalt": 1.0, "snow": 0.3, "gravel": 0.6, "wet": 0.6}
"""Peak friction of the surfaces of ``figure-eight`` [-]."""

FIGURE_EIGHT_PATCHES = (
    Patch(25.0, 70.0, 5.0, 40.0, "snow"),  # upper half of the right lobe's inner bend
    Patch(-70.0, -25.0, -40.0, -5.0, "gravel"),  # lower half of the left lobe
    Patch(-8.0, 8.0, -8.0, 8.0, "wet"),  # the crossing
)
"""Friction patches of ``figure-eight`` (rectangles [m]); dry asphalt elsewhere."""


def lemniscate(a: float = 100.0, ds: float = _DS) -> ClosedTrack:
    """Bernoulli lemniscate of half-width ``a`` [m] (lap about ``5.244 a``), points ``ds`` apart.

    Starts at the crossing heading into the right lobe.
    """
    th = np.linspace(-0.5 * np.pi, 1.5 * np.pi, 200_001)  # right lobe first, from the crossing
    x, y = _lemniscate_xy(a, th)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))])
    q = np.arange(0.0, s[-1] - 0.5 * ds, ds)
    return ClosedTrack(*_lemniscate_xy(a, np.interp(q, s, th)))


def _lemniscate_xy(a: float, th: NDArray) -> tuple[NDArray, NDArray]:
    d = 1.0 + np.sin(th) ** 2
    return a * np.cos(th) / d, a * np.sin(th) * np.cos(th) / d


def _figure_eight(seed: int, duration: float, progress: bool, vehicle: str | MBVehicle) -> Drive:
    rng = np.random.default_rng([seed, 12])
    track = lemniscate()
    field = PatchFriction("dry_asphalt", FIGURE_EIGHT_PATCHES)
    # the driver sees the patches: it plans 0.45 g on dry asphalt and 80 % of mu g on a patch
    labels = np.array(field.labels)[field.labels_at(np.zeros(track.n), track.x, track.y)]
    mu_pts = np.array([FIGURE_EIGHT_MU[lab] for lab in labels])
    ay_plan = np.minimum(0.45, 0.8 * mu_pts) * GRAVITY
    v_lap = track.speed_profile(16.0 * rng.uniform(0.95, 1.05), ay_plan, a_acc=2.0, a_brake=3.0)
    seg = track.segment_lengths()
    s_lap = np.concatenate([[0.0], np.cumsum(seg[:-1])])
    lap = track.length
    n_laps = int(np.ceil(duration * 18.0 / lap)) + 1
    # distance to the crossing (the start of each lap, and the middle of the wet patch)
    d_cross = np.minimum(s_lap, lap - s_lap)
    v_stop, a_brake = 3.0, 3.0
    v_slow = np.minimum(v_lap, np.sqrt(v_stop**2 + 2 * a_brake * d_cross))
    xs, ys, vs = [], [], []
    for i in range(n_laps):
        xs.append(track.x)
        ys.append(track.y)
        vs.append(v_slow if i % 2 == 1 else v_lap)
    v = np.concatenate(vs)
    path = Path(np.concatenate(xs), np.concatenate(ys), v, closed=False)
    return simulate_multibody(
        vehicle, path, field, FIGURE_EIGHT_MU, duration=duration, output_rate=100.0,
        sensors=MB_SENSORS, seed=seed, name="figure-eight", progress=progress,
        truth_extra={"track": {"kind": "lemniscate", "a": 100.0, "lap_length": lap},
                     "braked_laps": "every second lap, to 3 m/s on the wet crossing"},
    )


# ------------------------------------------------------------------------------------
def _straight_cruise(seed: int, duration: float, progress: bool, vehicle: str | MBVehicle) -> Drive:
    rng = np.random.default_rng([seed, 13])
    v = 20.0
    length = v * duration + 200.0
    waves = [(rng.uniform(150.0, 400.0), rng.uniform(0, 2 * np.pi), rng.uniform(0.05, 0.15))
             for _ in range(3)]

    def lateral(s):
        return sum(a * (np.sin(2 * np.pi * s / w + ph) - np.sin(ph)) for w, ph, a in waves)

    x, y = _straight_path(length, lateral)
    drop = 0.5 * v * duration
    field = PatchFriction("dry_asphalt", (Patch(drop, length + 1e3, -1e3, 1e3, "snow"),))
    return simulate_multibody(
        vehicle, Path(x, y, np.full_like(x, v)), field, {"dry_asphalt": 1.0, "snow": 0.3},
        duration=duration, output_rate=100.0, sensors=MB_SENSORS, seed=seed,
        name="straight-cruise", progress=progress, truth_extra={"friction_drop_x": drop},
    )


# ------------------------------------------------------------------------------------
VEHICLE_ID_SPEEDS = (8.0, 12.0, 16.0, 20.0)
"""Speeds [m/s] of the ``vehicle-id`` drive's manoeuvres."""


def vehicle_id_plan(seed: int) -> tuple[list[tuple[float, float]], list[tuple], float]:
    """Speed phases ``(duration [s], acceleration [m/s²])``, lateral events (as
    :func:`_lateral_events`) and length [s] of the ``vehicle-id`` drive.

    At each speed of :data:`VEHICLE_ID_SPEEDS`: a speed pulse (1.5 s at 2 m/s², 2 s held,
    1.5 s at -2 m/s²), a slalom of four periods of about 2.5 s and one of three periods of
    about 4.5 s (0.3 g, +-10 % with the seed), a 3.5-m lane change, a 1-s braking step at
    3.5 m/s² and a 1.75-s acceleration step at 2 m/s² back to the speed; then 2 m/s² to the
    next speed. Turning at several speeds separates the steering's scale (``L r / v_x``) from
    the understeer (``a_y = v_x r``); the speed steps, one in every 30 s or so, time the
    longitudinal channels.
    """
    rng = np.random.default_rng([seed, 14])
    phases: list[tuple[float, float]] = []
    events: list[tuple] = []
    t0, v = 0.0, VEHICLE_ID_SPEEDS[0]
    for i, v_next in enumerate(VEHICLE_ID_SPEEDS):
        if i:  # to the next speed at 2 m/s²
            phases.append((abs(v_next - v) / 2.0, math.copysign(2.0, v_next - v)))
            t0 += abs(v_next - v) / 2.0
            v = v_next
        j = rng.uniform(0.9, 1.1, size=3)
        short, long_ = 2.5 * j[0], 4.5 * j[1]
        ay = 0.3 * GRAVITY * j[2]
        phases += [(3.0, 0.0), (1.5, 2.0), (2.0, 0.0), (1.5, -2.0)]
        t0 += 8.0
        t1 = t0 + 2.0
        events.append((t1, t1 + 4 * short, "slalom", ay, short))
        t1 += 4 * short + 1.0
        events.append((t1, t1 + 3 * long_, "slalom", ay, long_))
        t1 += 3 * long_ + 1.0
        events.append((t1, t1 + 6.0, "lane_change", 3.5, 2.0))
        t1 += 7.0
        phases += [(t1 - t0, 0.0), (1.0, -3.5), (3.0, 0.0), (1.75, 2.0), (3.0, 0.0)]
        t0 = t1 + 8.75
    phases.append((6.0, 0.0))
    return phases, events, t0 + 6.0


def _vehicle_id(seed: int, duration: float, progress: bool, vehicle: str | MBVehicle) -> Drive:
    phases, events, length = vehicle_id_plan(seed)
    path = _path_from_phases(VEHICLE_ID_SPEEDS[0], phases, events, max(length, duration) + 30.0)
    return simulate_multibody(
        vehicle, path, ConstantFriction("dry_asphalt"), {"dry_asphalt": 1.0}, duration=duration,
        output_rate=100.0, sensors=MB_SENSORS, seed=seed, name="vehicle-id", progress=progress,
        truth_extra={"speeds": list(VEHICLE_ID_SPEEDS), "manoeuvres_end_s": length},
    )


MB_BUILDERS = {
    "snow-slalom": _snow_slalom,
    "dry-gravel-dry": _dry_gravel_dry,
    "figure-eight": _figure_eight,
    "straight-cruise": _straight_cruise,
    "vehicle-id": _vehicle_id,
}
"""Scenario name -> ``build(seed, duration, progress, vehicle) -> Drive`` on the multi-body engine."""
