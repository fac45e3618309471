"""Simulator: manoeuvres, friction fields, sensor models, RK4 integration, scenarios.

``maneuvers``  speed and steering patterns (:class:`Maneuver`)
``track``      closed tracks and the pure-pursuit driver (:class:`TrackDriver`)
``friction``   surfaces (:class:`SurfaceTires`) and friction fields over time or position
``sensors``    noise, bias, quantisation, rate and delay (:class:`SensorSpec`)
``engine``     compiled fixed-step RK4 integrators
``runner``     :func:`simulate` -> :class:`roadgrip.drive.Drive` with truth
``scenarios``  :data:`SCENARIOS` and :func:`simulate_scenario`
"""

from roadgrip.sim.friction import (
    ConstantFriction,
    Patch,
    PatchFriction,
    PiecewiseTime,
    SurfaceTires,
    brush_surface,
    field_from_dict,
    mu_at,
    surface_from_preset,
)
from roadgrip.sim.maneuvers import Maneuver
from roadgrip.sim.runner import simulate
from roadgrip.sim.scenarios import SCENARIOS, Scenario, simulate_scenario
from roadgrip.sim.sensors import SensorSpec
from roadgrip.sim.track import ClosedTrack, TrackDriver

__all__ = [
    "SCENARIOS",
    "ClosedTrack",
    "ConstantFriction",
    "Maneuver",
    "Patch",
    "PatchFriction",
    "PiecewiseTime",
    "Scenario",
    "SensorSpec",
    "SurfaceTires",
    "TrackDriver",
    "brush_surface",
    "field_from_dict",
    "mu_at",
    "simulate",
    "simulate_scenario",
    "surface_from_preset",
]
