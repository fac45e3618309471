"""Vehicle parameters and single-track models.

``params``  :class:`VehicleParams`, presets, YAML I/O
``slip``    slip angles (exact and linearised) and longitudinal slip
``lateral`` lateral-only single-track model of paper 000 (eq. 1-2)
``planar``  planar single-track model with wheel dynamics and combined slip
"""

from roadgrip.vehicle.lateral import (
    LateralInput,
    LateralState,
    lateral_derivatives,
    lateral_discrete,
    lateral_measurement,
    steady_state_linear,
)
from roadgrip.vehicle.params import PRESET_SOURCES, PRESETS, VehicleParams, load_vehicle
from roadgrip.vehicle.planar import (
    PlanarForces,
    PlanarInput,
    PlanarState,
    PlanarTires,
    planar_derivatives,
    planar_forces,
    wheel_speeds,
)
from roadgrip.vehicle.slip import longitudinal_slip, regularized_speed, slip_angles

__all__ = [
    "PRESETS",
    "PRESET_SOURCES",
    "LateralInput",
    "LateralState",
    "PlanarForces",
    "PlanarInput",
    "PlanarState",
    "PlanarTires",
    "VehicleParams",
    "lateral_derivatives",
    "lateral_discrete",
    "lateral_measurement",
    "load_vehicle",
    "longitudinal_slip",
    "planar_derivatives",
    "planar_forces",
    "regularized_speed",
    "slip_angles",
    "steady_state_linear",
    "wheel_speeds",
]
