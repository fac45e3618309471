"""Named, seed-reproducible scenarios (``roadgrip scenarios`` lists them).

==================  =========  =====================================================
name                vehicle    what it exercises
==================  =========  =====================================================
snow-slalom         suv        paper 000: lateral model on snow (mu 0.3), random
                               slalom reaching the nonlinear tire region at times
dry-gravel-dry      sedan      paper 002: dry -> gravel -> dry with acceleration,
                               braking, cornering and quiet phases in each segment
f1tenth-patches     f1tenth    paper 003: laps of a closed track with low- and
                               high-grip patches; pose with localisation noise
straight-cruise     sedan      no excitation: straight at constant speed
sine-burst          sedan      30 s: four sine-steer bursts at 11 m/s growing to
                               0.87 g on dry asphalt (a short manoeuvre)
figure-eight        (mb)       laps of a figure-eight with snow, gravel and a wet
                               crossing braked on every second lap
vehicle-id          (mb)       identification drive for ``roadgrip vehicle fit``: dry,
                               slaloms and speed steps at 8, 12, 16 and 20 m/s
==================  =========  =====================================================

Engines
-------
Each scenario runs on one or more engines (:attr:`Scenario.engines`, the first
is the default): ``'lateral'`` and ``'planar'`` are roadgrip's own single-track
models (the models inside the estimators), ``'multibody'`` is the independent
CommonRoad multi-body vehicle of :mod:`roadgrip.sim.multibody`, driven by the
builders of :mod:`roadgrip.sim.mb_scenarios` with a vehicle of
:data:`MB_VEHICLES` or one of the random family ``random:SEED``
(:mod:`roadgrip.sim.vehicle_family`), with ideal or realistic sensors. Multi-body drives are cached on disk by content hash when
``ROADGRIP_DRIVE_CACHE`` names a folder (or ``cache=True``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from roadgrip.sim.friction import (
    ConstantFriction,
    Patch,
    PatchFriction,
    PiecewiseTime,
    brush_surface,
    surface_from_preset,
)
from roadgrip.sim.maneuvers import (
    ConstantSpeed,
    DoubleLaneChange,
    Maneuver,
    RandomSpeed,
    RandomSteer,
    Schedule,
    Slalom,
    SpeedPhases,
    Straight,
)
from roadgrip.sim.sensors import SensorSpec
from roadgrip.sim.track import ClosedTrack, TrackDriver
from roadgrip.vehicle.params import PRESETS

if TYPE_CHECKING:  # the runner (pandas, compiled kernels) is imported by the builders that run it
    from roadgrip.drive import Drive

__all__ = ["MB_VEHICLES", "SCENARIOS", "Scenario", "simulate_scenario"]


@dataclass(frozen=True)
class Scenario:
    """A named simulation set-up.

    Attributes
    ----------
    name : str
    vehicle : str
        Vehicle preset name.
    duration : float
        Default simulated time [s].
    output_rate : float
        Output sample rate [Hz] of the default engine.
    description : str
    build : callable or None
        ``build(seed, duration, progress) -> Drive`` on the single-track engine
        (None for a multi-body-only scenario).
    engines : tuple of str
        Engines the scenario runs on; the first is the default.
    multibody_duration : float, optional
        Default simulated time on the multi-body engine [s].
    """

    name: str
    vehicle: str
    duration: float
    output_rate: float
    description: str
    build: Callable[[int, float, bool], Drive] | None
    engines: tuple[str, ...] = ()
    multibody_duration: float | None = None


# ------------------------------------------------------------------------------------
# snow-slalom (paper 000)
# ------------------------------------------------------------------------------------
SNOW_SENSORS = {
    "ay": SensorSpec(noise_std=0.05),
    "ax": SensorSpec(noise_std=0.05),
    "yaw_rate": SensorSpec(noise_std=0.002),
    "steer": SensorSpec(noise_std=0.0005),
    "vx": SensorSpec(noise_std=0.02),
    "omega_fl": SensorSpec(noise_std=0.05),
    "omega_fr": SensorSpec(noise_std=0.05),
    "omega_rl": SensorSpec(noise_std=0.05),
    "omega_rr": SensorSpec(noise_std=0.05),
}


def _snow_slalom(seed: int, duration: float, progress: bool) -> Drive:
    from roadgrip.sim.runner import simulate

    vehicle = PRESETS["suv"]
    snow = surface_from_preset("snow")
    man = Maneuver(
        speed=RandomSpeed(8.0, 15.0, corr_time=30.0),
        steering=RandomSteer(ay_min=0.6, ay_max=3.5, corr_time=1.0, envelope_period=40.0),
        yaw_gain=0.3,
        sideslip_gain=1.5,
    )
    return simulate(
        vehicle, man, ConstantFriction("snow"), [snow],
        duration=duration, model="lateral", output_rate=25.0, internal_rate=500.0,
        sensors=SNOW_SENSORS, seed=seed, name="snow-slalom", progress=progress,
    )


# ------------------------------------------------------------------------------------
# dry-gravel-dry (paper 002)
# ------------------------------------------------------------------------------------
CAR_SENSORS = {
    "ay": SensorSpec(noise_std=0.05),
    "ax": SensorSpec(noise_std=0.05),
    "yaw_rate": SensorSpec(noise_std=0.002),
    "steer": SensorSpec(noise_std=0.0005),
    "vx": SensorSpec(noise_std=0.05),
    "omega_fl": SensorSpec(noise_std=0.05, quantization=0.02),
    "omega_fr": SensorSpec(noise_std=0.05, quantization=0.02),
    "omega_rl": SensorSpec(noise_std=0.05, quantization=0.02),
    "omega_rr": SensorSpec(noise_std=0.05, quantization=0.02),
    "x": SensorSpec(noise_std=0.1),
    "y": SensorSpec(noise_std=0.1),
    "psi": SensorSpec(noise_std=0.005),
}

DGD_SEGMENT = 60.0
"""Length of each surface segment of ``dry-gravel-dry`` [s]."""


def _dgd_segment(t0: float, rng) -> tuple[list, list, list]:
    """Speed phases, steering windows and labelled excitation intervals of one segment.

    Each segment: quiet cruise, acceleration, quiet, braking, quiet, slalom and a
    double lane change, quiet, acceleration, quiet, gentle braking, quiet. The
    magnitudes vary by +-10 % with the seed.
    """
    j = rng.uniform(0.9, 1.1, size=5)
    a_acc, a_brk, ay_sl, a_acc2 = 2.0 * j[0], -3.5 * j[1], 4.0 * j[2], 1.5 * j[3]
    phases = [(8.0, 0.0), (4.0, a_acc), (6.0, 0.0), (3.0, a_brk), (6.0, 0.0), (16.0, 0.0),
              (5.0, 0.0), (4.0, a_acc2), (2.0, 0.0)]
    # return to the segment's initial speed with a gentle braking phase
    dv = sum(a * (d - 0.5) for d, a in phases)
    phases += [(3.0, -dv / 2.5), (3.0, 0.0)]
    steer = [
        (t0 + 27.0, t0 + 36.0, Slalom(ay_sl, 3.0 * j[4])),
        (t0 + 36.5, t0 + 43.0, DoubleLaneChange(3.5, 2.5, 1.0)),
    ]
    excited = [
        {"t0": t0 + 8.0, "t1": t0 + 12.0, "kind": "acceleration"},
        {"t0": t0 + 18.0, "t1": t0 + 21.0, "kind": "braking"},
        {"t0": t0 + 27.0, "t1": t0 + 43.0, "kind": "cornering"},
        {"t0": t0 + 48.0, "t1": t0 + 52.0, "kind": "acceleration"},
        {"t0": t0 + 54.0, "t1": t0 + 57.0, "kind": "braking"},
    ]
    return phases, steer, excited


def dgd_truth(field: PiecewiseTime, labels, excited: list[dict], duration: float) -> dict:
    """``meta.truth`` entries of a dry-gravel-dry drive: surface changes, segments and the
    labelled excitation intervals that start within ``duration`` [s]."""
    return {
        "changes": [c for c in field.changes if c["t"] < duration],
        "segments": [
            {"t0": i * DGD_SEGMENT, "t1": (i + 1) * DGD_SEGMENT, "surface": s}
            for i, s in enumerate(labels) if i * DGD_SEGMENT < duration
        ],
        "excited_intervals": [e for e in excited if e["t0"] < duration],
    }


def _dry_gravel_dry(seed: int, duration: float, progress: bool) -> Drive:
    from roadgrip.sim.runner import simulate

    vehicle = PRESETS["sedan"]
    rng = np.random.default_rng([seed, 2])
    labels = ("dry_asphalt", "gravel", "dry_asphalt")
    phases, windows, excited = [], [], []
    for i in range(len(labels)):
        p, w, e = _dgd_segment(i * DGD_SEGMENT, rng)
        phases += p
        windows += w
        excited += e
    field = PiecewiseTime(tuple(i * DGD_SEGMENT for i in range(len(labels))), labels)
    man = Maneuver(SpeedPhases(15.0, tuple(phases)), Schedule(tuple(windows)), yaw_gain=0.1)
    surfaces = [surface_from_preset("dry_asphalt"), surface_from_preset("gravel")]
    return simulate(
        vehicle, man, field, surfaces,
        duration=duration, model="planar", output_rate=100.0, internal_rate=1000.0,
        sensors=CAR_SENSORS, seed=seed, name="dry-gravel-dry", progress=progress,
        truth_extra=dgd_truth(field, labels, excited, duration),
    )


# ------------------------------------------------------------------------------------
# straight-cruise
# ------------------------------------------------------------------------------------
def _straight_cruise(seed: int, duration: float, progress: bool) -> Drive:
    from roadgrip.sim.runner import simulate

    vehicle = PRESETS["sedan"]
    man = Maneuver(ConstantSpeed(20.0), Straight(ay_std=0.05, corr_time=4.0), yaw_gain=0.05)
    return simulate(
        vehicle, man, ConstantFriction("dry_asphalt"), [surface_from_preset("dry_asphalt")],
        duration=duration, model="planar", output_rate=100.0, internal_rate=1000.0,
        sensors=CAR_SENSORS, seed=seed, name="straight-cruise", progress=progress,
    )


# ------------------------------------------------------------------------------------
# f1tenth-patches (paper 003)
# ------------------------------------------------------------------------------------
F1TENTH_TRACK = {"kind": "rounded_rectangle", "length": 10.0, "width": 6.0, "radius": 1.5}
"""Centre line of the ``f1tenth-patches`` track [m], laps counter-clockwise from (0, -3)."""

F1TENTH_MU = {"track": 0.7, "low_grip": 0.45, "high_grip": 0.9}
"""Peak friction of the three surfaces of ``f1tenth-patches`` [-]."""

F1TENTH_PATCHES = (
    Patch(3.0, 6.5, -4.0, -1.2, "low_grip"),  # bottom-right corner and its entry
    Patch(-6.5, -2.5, 0.5, 4.0, "high_grip"),  # top-left corner
    Patch(3.0, 4.6, 2.0, 4.0, "low_grip"),  # exit half of the top-right corner
)

F1TENTH_SENSORS = {
    "ay": SensorSpec(noise_std=0.1),
    "ax": SensorSpec(noise_std=0.1),
    "yaw_rate": SensorSpec(noise_std=0.005),
    "steer": SensorSpec(noise_std=0.002),
    "vx": SensorSpec(noise_std=0.03),
    "omega_fl": SensorSpec(noise_std=0.2),
    "omega_fr": SensorSpec(noise_std=0.2),
    "omega_rl": SensorSpec(noise_std=0.2),
    "omega_rr": SensorSpec(noise_std=0.2),
    "x": SensorSpec(noise_std=0.03),
    "y": SensorSpec(noise_std=0.03),
    "psi": SensorSpec(noise_std=0.01),
}


def _f1tenth_patches(seed: int, duration: float, progress: bool) -> Drive:
    from roadgrip.sim.runner import simulate

    vehicle = PRESETS["f1tenth"]
    geo = F1TENTH_TRACK
    track = ClosedTrack.rounded_rectangle(geo["length"], geo["width"], geo["radius"], ds=0.05)
    rng = np.random.default_rng([seed, 3])
    driver = TrackDriver(
        track, v_max=4.5 * rng.uniform(0.95, 1.05), ay_max=0.55 * 9.80665 * rng.uniform(0.95, 1.05),
        a_acc=2.5, a_brake=3.0, lookahead0=0.6, lookahead_gain=0.12, speed_preview=0.4,
    )
    surfaces = [brush_surface(k, mu, vehicle) for k, mu in F1TENTH_MU.items()]
    field = PatchFriction("track", F1TENTH_PATCHES)
    return simulate(
        vehicle, driver, field, surfaces,
        duration=duration, model="planar", output_rate=50.0, internal_rate=1000.0,
        sensors=F1TENTH_SENSORS, seed=seed, name="f1tenth-patches", v_eps=0.1, progress=progress,
        truth_extra={"track": dict(geo, lap_length=track.length)},
    )


# ------------------------------------------------------------------------------------
# sine-burst: a short manoeuvre of a public peer's kind
# ------------------------------------------------------------------------------------
SINE_BURSTS = ((2.0, 3.0), (9.0, 5.0), (16.0, 7.0), (23.0, 8.5))
"""``(start [s], lateral-acceleration amplitude [m/s²])`` of the four bursts of
``sine-burst``, each two periods of :data:`SINE_BURST_PERIOD`."""

SINE_BURST_PERIOD = 1.5
"""Period of the steering sine of ``sine-burst`` [s]."""


def _sine_burst(seed: int, duration: float, progress: bool) -> Drive:
    from roadgrip.sim.runner import simulate

    vehicle = PRESETS["sedan"]
    rng = np.random.default_rng([seed, 5])
    j = rng.uniform(0.95, 1.05, size=len(SINE_BURSTS))
    windows = tuple((t0, t0 + 2 * SINE_BURST_PERIOD, Slalom(amp * k, SINE_BURST_PERIOD))
                    for (t0, amp), k in zip(SINE_BURSTS, j, strict=True))
    man = Maneuver(ConstantSpeed(11.0), Schedule(windows, fade=0.3), yaw_gain=0.3, sideslip_gain=1.5)
    return simulate(
        vehicle, man, ConstantFriction("dry_asphalt"), [surface_from_preset("dry_asphalt")],
        duration=duration, model="lateral", output_rate=50.0, internal_rate=500.0,
        sensors=SNOW_SENSORS, seed=seed, name="sine-burst", progress=progress,
    )


# ------------------------------------------------------------------------------------
SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario(
            "snow-slalom", "suv", 250.0, 25.0,
            "SUV on snow (mu 0.3), lateral model, random slalom into the nonlinear tire region",
            _snow_slalom, ("lateral", "multibody"), 200.0,
        ),
        Scenario(
            "dry-gravel-dry", "sedan", 3 * DGD_SEGMENT, 100.0,
            "sedan, dry asphalt -> gravel -> dry asphalt; acceleration, braking, cornering, quiet",
            _dry_gravel_dry, ("planar", "multibody"), 3 * DGD_SEGMENT,
        ),
        Scenario(
            "f1tenth-patches", "f1tenth", 60.0, 50.0,
            "F1/10 car lapping a 10 x 6 m track with low- and high-grip patches in the corners",
            _f1tenth_patches, ("planar",),
        ),
        Scenario(
            "straight-cruise", "sedan", 120.0, 100.0,
            "sedan on dry asphalt, straight at 20 m/s: almost no excitation (multi-body: the "
            "friction drops to 0.3 half-way)",
            _straight_cruise, ("planar", "multibody"), 120.0,
        ),
        Scenario(
            "sine-burst", "sedan", 30.0, 50.0,
            "sedan on dry asphalt at 11 m/s, lateral model: four sine-steer bursts growing to "
            "0.87 g (a short manoeuvre)",
            _sine_burst, ("lateral",),
        ),
        Scenario(
            "figure-eight", "ford-escort", 280.0, 100.0,
            "car lapping a 524 m figure-eight over dry asphalt with snow, gravel and a wet "
            "crossing braked to 3 m/s on every second lap",
            None, ("multibody",), 280.0,
        ),
        Scenario(
            "vehicle-id", "ford-escort", 225.0, 100.0,
            "identification drive for `roadgrip vehicle fit` on dry asphalt: slaloms, a lane "
            "change and braking and acceleration steps at 8, 12, 16 and 20 m/s",
            None, ("multibody",), 225.0,
        ),
    )
}
"""Scenarios by name."""


MB_VEHICLES = ("ford-escort", "vw-vanagon")
"""Named vehicles of the multi-body engine (CommonRoad parameter sets 1 and 3); ``random:SEED``
names a vehicle of the random family around them (:mod:`roadgrip.sim.vehicle_family`)."""


def simulate_scenario(
    name: str,
    seed: int = 0,
    progress: bool = False,
    duration: float | None = None,
    *,
    engine: str | None = None,
    vehicle: str | None = None,
    sensors: str | None = None,
    cache: bool | None = None,
) -> Drive:
    """Simulate a named scenario.

    Parameters
    ----------
    name : str
        Key of :data:`SCENARIOS`.
    seed : int
        Same seed, same drive.
    progress : bool
        Print a line to stderr before integrating.
    duration : float, optional
        Override the scenario's duration [s] (short runs for tests).
    engine : str, optional
        One of the scenario's :attr:`Scenario.engines` (default: its first).
    vehicle : str, optional
        Multi-body vehicle (:data:`MB_VEHICLES`, default ``'ford-escort'``, or
        ``'random:SEED'``, a vehicle of :mod:`roadgrip.sim.vehicle_family`);
        the single-track engines use the scenario's own vehicle.
    sensors : {'ideal', 'realistic'}, optional
        Multi-body sensors: the scenario's noise only, or with sampled errors
        (latency, bias, drift, scale, quantisation, dropouts, steering errors;
        :func:`roadgrip.sim.sensors.sample_sensor_errors`). Default: ideal for a named
        vehicle, realistic for ``random:SEED``.
    cache : bool, optional
        Read and write multi-body drives in the folder ``ROADGRIP_DRIVE_CACHE``
        (default: whenever that variable is set).

    Raises
    ------
    ValueError
        Unknown scenario, engine or vehicle (the message lists the known ones).
    """
    try:
        sc = SCENARIOS[name]
    except KeyError:
        raise ValueError(f"unknown scenario {name!r}; known scenarios: {', '.join(SCENARIOS)}") from None
    engine = sc.engines[0] if engine is None else engine
    if engine not in sc.engines:
        raise ValueError(f"scenario {name!r} runs on engine(s) {', '.join(sc.engines)}, not {engine!r}")
    if engine != "multibody":
        if sensors is not None:
            raise ValueError(f"--sensors applies to the multibody engine, not to {engine!r}")
        if vehicle is not None and vehicle != sc.vehicle:
            raise ValueError(f"scenario {name!r} on the {engine} engine drives its own vehicle "
                             f"{sc.vehicle!r}; --vehicle applies to the multibody engine")
        dur = sc.duration if duration is None else float(duration)
        if dur <= 0:
            raise ValueError(f"duration must be positive, got {dur}")
        assert sc.build is not None
        return sc.build(seed, dur, progress)
    vehicle = MB_VEHICLES[0] if vehicle is None else vehicle
    dur = float(sc.multibody_duration or sc.duration) if duration is None else float(duration)
    if not (dur > 0 and np.isfinite(dur)):
        raise ValueError(f"duration must be positive, got {dur}")
    from roadgrip.sim import drive_cache
    from roadgrip.sim.mb_scenarios import MB_BUILDERS
    from roadgrip.sim.vehicle_family import mb_vehicle

    mbv = mb_vehicle(vehicle, sensors=sensors, seed=int(seed))
    mode = "ideal" if mbv.sensors is None else "realistic"

    def build() -> Drive:
        return MB_BUILDERS[name](seed, dur, progress, mbv)

    request = {"scenario": name, "engine": engine, "vehicle": vehicle, "seed": int(seed), "duration": dur}
    if mode == "realistic":
        request["sensors"] = mode
    return drive_cache.cached(build, enabled=cache, **request)
