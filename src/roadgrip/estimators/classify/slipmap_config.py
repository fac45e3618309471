"""Settings of the slip-acceleration map classifier and its uncalibrated defaults.

See :mod:`roadgrip.estimators.classify.slipmap` for the method (paper 002, Sec. V).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

from roadgrip.inference.kinematic import LATERAL_ACCELERATION_SOURCES
from roadgrip.tire import SURFACES, MagicFormula

__all__ = ["SlipMapConfig", "default_config"]


@dataclass(frozen=True)
class SlipMapConfig:
    """Settings of the slip-acceleration classifier.

    Attributes
    ----------
    long_curve, lat_curve : MagicFormula
        Mid-friction reference curves, ``mu`` against slip ratio / slip angle.
    sigma_x, sigma_y : float
        Reliability scales of eq. 9 [m/s²] (paper: 3 and 2).
    slip_min_long, slip_min_lat : float
        Slip bounds of the low-excitation boxes [-] and [rad].
    accel_min : float
        Acceleration bound of the low-excitation boxes [m/s²].
    lowpass_tau_s : float
        Time constant of the output low-pass filter [s].
    hysteresis : float
        Half-width of the class hysteresis band around 0.5 [-].
    info_min : float
        Accumulated weight before a class is claimed [-].
    w_excited : float
        Weight at which a sample counts as excited [-].
    min_speed : float
        Below this speed [m/s] both weights are 0 (slips near standstill carry no information).
    prefilter_tau_s : float
        Time constant [s] of a first-order low-pass applied to the slips and
        accelerations before the maps (0 = none): the noise of a low-rate
        inertial sensor otherwise scatters the samples across the reference curve.
    lateral_acceleration : {'auto', 'imu', 'kinematic'}
        Lateral acceleration placed on the lateral map: the accelerometer's, or
        the kinematic ``r vx + dvy/dt``; ``'auto'`` takes the kinematic one when
        the velocity comes from a pose
        (:func:`roadgrip.inference.kinematic.select_lateral_acceleration`).
    """

    long_curve: MagicFormula
    lat_curve: MagicFormula
    sigma_x: float = 3.0
    sigma_y: float = 2.0
    slip_min_long: float = 0.01
    slip_min_lat: float = 0.01
    accel_min: float = 1.0
    lowpass_tau_s: float = 0.5
    hysteresis: float = 0.1
    info_min: float = 3.0
    w_excited: float = 0.1
    min_speed: float = 0.5
    prefilter_tau_s: float = 0.0
    lateral_acceleration: str = "auto"

    def __post_init__(self) -> None:
        if self.lateral_acceleration not in LATERAL_ACCELERATION_SOURCES:
            raise ValueError(
                f"lateral_acceleration must be one of {LATERAL_ACCELERATION_SOURCES}, "
                f"got {self.lateral_acceleration!r}"
            )
        for name in ("sigma_x", "sigma_y", "lowpass_tau_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be positive, got {v!r}")
        for name in ("slip_min_long", "slip_min_lat", "accel_min", "info_min", "min_speed",
                     "prefilter_tau_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be >= 0, got {v!r}")
        if not 0.0 <= self.hysteresis < 0.5:
            raise ValueError(f"hysteresis must lie in [0, 0.5), got {self.hysteresis!r}")
        if not 0.0 < self.w_excited < 1.0:
            raise ValueError(f"w_excited must lie in (0, 1), got {self.w_excited!r}")

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["long_curve"] = {k: float(self.long_curve.to_dict()[k]) for k in "BCDE"}
        d["lat_curve"] = {k: float(self.lat_curve.to_dict()[k]) for k in "BCDE"}
        for k, v in d.items():
            if isinstance(v, np.generic):
                d[k] = v.item()
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SlipMapConfig:
        d = dict(d)
        unknown = set(d) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f"unknown slipmap setting(s) {sorted(unknown)}")
        for k in ("long_curve", "lat_curve"):
            if k not in d:
                raise ValueError(f"slipmap calibration lacks {k!r}")
            d[k] = MagicFormula(**{c: float(d[k][c]) for c in "BCDE"})
        return cls(**d)


def default_config(mu_mid: float = 0.8) -> SlipMapConfig:
    """Mid-friction curves: the dry-asphalt shapes scaled to peak ``mu_mid``.

    The default 0.8 lies halfway between dry asphalt (1.0) and gravel (0.6),
    the two surfaces of the paper's test; the slopes are scaled alike.
    """
    dry = SURFACES["dry_asphalt"]
    return SlipMapConfig(
        long_curve=replace(dry.longitudinal, D=mu_mid),
        lat_curve=replace(dry.lateral, D=mu_mid),
    )
