"""Estimator options for particular data sets, next to the readers of those data sets.

An estimator never applies them by itself: the caller (``roadgrip estimate``, the
benchmark) merges them under the options it was given,
``Config.from_options({**preset_options(method, drive), **options})``.
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["dart_options", "frictionmaps_options", "options_for_drive", "preset_options"]

_DART: dict[str, Any] = {
    "sigma_ay": 0.3,
    "sigma_yaw_rate": 0.05,
    "sigma_w0": 0.05,
    "nu0": 50.0,
    "max_dt": 0.02,
    "vx_source": "pose",
    "vy_source": "pose",
    "ay_source": "kinematic",
    "max_sideslip": math.radians(20.0),
}
"""GP-SSM option overrides for the DART JetRacer recordings (``format='dart'``).

The recordings are steady turns in one direction at constant steering. From the IMU alone
a common shift of both axles' slip angles (the lateral velocity) is not identified by such
data, not even with an odd basis, and the learned peak then depends on the random seed
(0.23-0.65 on the rubbery floor over seeds 0-5). The motion-capture pose measures the
velocity, so these options take it:

* ``vy_source='pose'``: the lateral velocity, and with it the slip angles, is measured;
* ``ay_source='kinematic'``: the lateral acceleration ``r vx + dvy/dt`` from the gyro and
  the pose, whose noise on these files is 0.17-0.30 m/s² per sample against 2-3 m/s² for
  the hobby-grade accelerometer (``sigma_ay`` accordingly);
* ``vx_source='pose'``: the rear-driven encoder speed includes up to 30 % wheel spin.

The 10 Hz sensor rate is too slow for a forward-Euler step of this small, stiff car
(``max_dt``); a larger, firmer prior on the process noise (``sigma_w0``, ``nu0``) keeps the
filter from collapsing ``Q`` during the long standstill at the start of each file;
``max_sideslip`` (20 deg) bounds the lateral velocity of runs without a measured one (with
the low-friction prior mean, 0.05, the model's early lateral force is far below the
``m vx r`` the car produces, and ``vy`` would integrate the difference and run away).
"""


def dart_options() -> dict[str, Any]:
    """GP-SSM options for the DART JetRacer recordings (a new dictionary)."""
    return dict(_DART)


_FRICTIONMAPS: dict[str, Any] = {
    "vy_source": "pose",
    "slip_sigma": math.radians(3.0),
    "ay_gain_sigma": 0.0,
}
"""GP-SSM option overrides for the F1/10 recordings of the FrictionMaps data set
(``format='frictionmaps'``).

From the IMU alone the filter does not follow the lateral velocity of these runs: the
steering column is the command, not the road-wheel angle (the car turns 0.5-0.8 times as
much as the command says, 0.1 s later), so the model's front slip angle is wrong whenever
it steers. With the defaults 15-50 % of the samples were flagged diverged, the learned
accelerometer gain wandered over 0.66-1.18 between seeds, and the lateral velocity's
band covered the pose's on 22-64 % of the samples. These options take the lateral
velocity from the localisation, as the DART preset does from motion capture:

* ``vy_source='pose'``: the reader's ``vy_pose`` (differentiated over 0.3 s, NaN near a
  jump of the localisation, where the particles propagate their own);
* ``slip_sigma`` (3 deg): the error of that measurement over the speed. ``vy_pose``
  scatters by 0.10-0.16 m/s about the no-slip line in gentle turns (the reader's
  docstring), 3 deg of slip angle at 2-3 m/s; it widens the reported ``vy_std`` and the
  curve band accordingly;
* ``ay_gain_sigma=0``: the accelerometer's gain is not learned. The car is small and
  stiff (CG 0.075 m high), the reader's kinematic check gives ``ay / (vx r)`` of
  0.95-1.09 in turns on four of the five runs, and a learned gain wandered over
  0.62-1.36 between seeds even with the lateral velocity measured: it absorbed the
  steering command's error, and put observed peaks below the friction the
  accelerometer showed the car using.
"""


def frictionmaps_options() -> dict[str, Any]:
    """GP-SSM options for the FrictionMaps F1/10 recordings (a new dictionary)."""
    return dict(_FRICTIONMAPS)


_BY_FORMAT = {"dart": _DART, "frictionmaps": _FRICTIONMAPS}


def options_for_drive(drive: Any) -> dict[str, Any]:
    """The preset options of a drive's data set: :func:`dart_options` for a drive read
    with ``format='dart'``, :func:`frictionmaps_options` for ``format='frictionmaps'``,
    else none."""
    return dict(_BY_FORMAT.get(drive.meta.extra.get("format"), {}))


def preset_options(method: str, drive: Any) -> dict[str, Any]:
    """The options ``method`` takes for ``drive``'s data set (a new dictionary; GP-SSM on
    DART: :func:`dart_options`, on FrictionMaps: :func:`frictionmaps_options`); options
    given by the caller override them."""
    return options_for_drive(drive) if method == "gpssm" else {}
