"""Simulator: manoeuvres, friction fields, sensor models, RK4 integration, scenarios.

``maneuvers``  speed and steering patterns (:class:`Maneuver`)
``track``      closed tracks and the pure-pursuit driver (:class:`TrackDriver`)
``friction``   surfaces (:class:`SurfaceTires`) and friction fields over time or position
``sensors``    noise, bias, quantisation, rate and delay (:class:`SensorSpec`)
``engine``     compiled fixed-step RK4 integrators
``runner``     :func:`simulate` -> :class:`roadgrip.drive.Drive` with truth
``scenarios``  :data:`SCENARIOS` and :func:`simulate_scenario`
"""

from importlib import import_module
from typing import TYPE_CHECKING, Any

_EXPORTS = {
    "ClosedTrack": "track",
    "ConstantFriction": "friction",
    "Maneuver": "maneuvers",
    "Patch": "friction",
    "PatchFriction": "friction",
    "PiecewiseTime": "friction",
    "SCENARIOS": "scenarios",
    "Scenario": "scenarios",
    "SensorSpec": "sensors",
    "SurfaceTires": "friction",
    "TrackDriver": "track",
    "brush_surface": "friction",
    "field_from_dict": "friction",
    "mu_at": "friction",
    "simulate": "runner",
    "simulate_scenario": "scenarios",
    "surface_from_preset": "friction",
}
"""Public names and the submodule each comes from; imported on first use (:func:`__getattr__`),
so that listing the scenarios does not compile the integrators nor import pandas."""


def __getattr__(name: str) -> Any:
    """The public name ``name`` from its submodule (PEP 562), cached in the package."""
    try:
        module = _EXPORTS[name]
    except KeyError:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}") from None
    value = getattr(import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


if TYPE_CHECKING:
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
