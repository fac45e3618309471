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
==================  =========  =====================================================
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from roadgrip.drive import Drive
from roadgrip.sim.friction import (
    ConstantFriction,
    surface_from_preset,
)
from roadgrip.sim.maneuvers import (
    Maneuver,
    RandomSpeed,
    RandomSteer,
)
from roadgrip.sim.runner import simulate
from roadgrip.sim.sensors import SensorSpec
from roadgrip.vehicle.params import PRESETS

__all__ = ["SCENARIOS", "Scenario", "simulate_scenario"]


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
        Output sample rate [Hz].
    description : str
    build : callable
        ``build(seed, duration, progress) -> Drive``.
    """

    name: str
    vehicle: str
    duration: float
    output_rate: float
    description: str
    build: Callable[[int, float, bool], Drive]


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
    vehicle = PRESETS["suv"]
    snow = surface_from_preset("snow")
    man = Maneuver(
        speed=RandomSpeed(8.0, 15.0, corr_time=30.0),
        steering=RandomSteer(ay_min=0.5, ay_max=3.3, corr_time=1.0, envelope_period=40.0),
        yaw_gain=0.3,
        sideslip_gain=1.5,
    )
    return simulate(
        vehicle, man, ConstantFriction("snow"), [snow],
        duration=duration, model="lateral", output_rate=25.0, internal_rate=500.0,
        sensors=SNOW_SENSORS, seed=seed, name="snow-slalom", progress=progress,
    )


# ------------------------------------------------------------------------------------
SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario(
            "snow-slalom", "suv", 250.0, 25.0,
            "SUV on snow (mu 0.3), lateral model, random slalom into the nonlinear tire region",
            _snow_slalom,
        ),
    )
}
"""Scenarios by name."""


def simulate_scenario(
    name: str, seed: int = 0, progress: bool = False, duration: float | None = None
) -> Drive:
    """Simulate a named scenario.

    Parameters
    ----------
    name : str
        Key of :data:`SCENARIOS`.
    seed : int
        Same seed, same drive.
    progress : bool
        Show a status line.
    duration : float, optional
        Override the scenario's duration [s] (short runs for tests).

    Raises
    ------
    ValueError
        Unknown scenario name (the message lists the known ones).
    """
    try:
        sc = SCENARIOS[name]
    except KeyError:
        raise ValueError(f"unknown scenario {name!r}; known scenarios: {', '.join(SCENARIOS)}") from None
    dur = sc.duration if duration is None else float(duration)
    if dur <= 0:
        raise ValueError(f"duration must be positive, got {dur}")
    return sc.build(seed, dur, progress)
