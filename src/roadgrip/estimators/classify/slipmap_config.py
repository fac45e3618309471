"""Settings of the slip-acceleration map classifier and its uncalibrated defaults.

See :mod:`roadgrip.estimators.classify.slipmap` for the method (paper 002, Sec. V).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

from roadgrip.estimators.classify.common import check_field_types
from roadgrip.estimators.classify.grip_model import GripModel
from roadgrip.inference.kinematic import LATERAL_ACCELERATION_SOURCES
from roadgrip.tire import SURFACES, MagicFormula

__all__ = ["SLIPMAP_MODELS", "SlipMapConfig", "default_config", "saturation_config"]

SLIPMAP_MODELS = ("curves", "saturation")
"""Reference of the maps: the paper's mid-friction Magic Formula curves, or the
saturation model's two class predictions (:mod:`roadgrip.estimators.classify.grip_model`)."""


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
    model : {'curves', 'saturation'}
        ``'curves'``: the paper's mid-friction curves and eq. 9 weights.
        ``'saturation'``: the reference is halfway between the saturation
        model's two class predictions and a sample's weight is eq. 9's times the
        separation of the predictions, ``1 - exp(-(a_high - a_low)^2 / (4 sigma^2))``
        (no weight where the classes predict the same acceleration;
        :func:`roadgrip.estimators.classify.slipmap_evidence.saturation_evidence`).
    grip : GripModel or None
        The saturation model (``None``: from the vehicle's parameters).
    lateral, longitudinal : bool
        Whether the lateral / longitudinal map counts in the saturation model (see
        :func:`roadgrip.estimators.classify.brls_config.saturation_config`).
    hold_high_s, hold_low_s : float
        A class is claimed only while the evidence has supported it within this
        time [s] (the low-passed evidence rate at least ``support_min`` with the
        index on the class's side); then 'unknown', the index restarts at 1/2
        and a class is claimed again when it leaves the hysteresis band. ``inf``:
        the paper's recursion, which holds its state.
    redecide_low_s : float
        A 'low' not supported within this time [s] (below ``hold_low_s``) is still
        claimed, but decided afresh: the index restarts at 1/2, and only the new
        evidence taking it out of the hysteresis band supports 'low' again or
        switches to 'high'. ``inf``: never.
    support_min : float
        Evidence rate (low-passed ``p_high + p_low``, time constant 0.3 s) at
        which the evidence supports the class.
    paced_by_evidence : bool
        The output low-pass advances at full speed only where the sample's evidence
        ``p_high + p_low`` reaches ``support_min`` (in proportion below it, not at all
        without evidence), so that the index holds through a silence what the evidence
        said, not eq. 16's last transient. ``False``: the paper's low-pass in time.
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
    model: str = "curves"
    grip: GripModel | None = None
    lateral: bool = True
    longitudinal: bool = True
    hold_high_s: float = math.inf
    hold_low_s: float = math.inf
    support_min: float = 0.02
    paced_by_evidence: bool = True
    redecide_low_s: float = math.inf

    def __post_init__(self) -> None:
        if self.model not in SLIPMAP_MODELS:
            raise ValueError(f"model must be one of {SLIPMAP_MODELS}, got {self.model!r}")
        for name in ("hold_high_s", "hold_low_s", "support_min", "redecide_low_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)!r}")
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
        d["grip"] = None if self.grip is None else self.grip.to_dict()
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
        if d.get("grip") is not None:
            d["grip"] = GripModel.from_dict(dict(d["grip"]))
        check_field_types(cls, d, "slip-map settings")
        return cls(**d)


def default_config(mu_mid: float = 0.8) -> SlipMapConfig:
    """The paper's mid-friction curves: the dry-asphalt shapes scaled to peak ``mu_mid``
    (the uncalibrated estimator runs :func:`saturation_config`).

    The default 0.8 lies halfway between dry asphalt (1.0) and gravel (0.6),
    the two surfaces of the paper's test; the slopes are scaled alike.
    """
    dry = SURFACES["dry_asphalt"]
    return SlipMapConfig(
        long_curve=replace(dry.longitudinal, D=mu_mid),
        lat_curve=replace(dry.lateral, D=mu_mid),
        paced_by_evidence=False,
    )


def saturation_config(
    grip: GripModel | None = None, hold_high_s: float = 2.0, hold_low_s: float = 2.0,
    lateral: bool = False,
) -> SlipMapConfig:
    """The slip maps on the saturation model (the uncalibrated default with ``grip=None``).

    The paper's curves stay in the settings but are not used. Direction scales of
    half a noise unit (the evidence is whitened and the inputs prefiltered over
    0.05 s), no exclusion boxes (the separation weight replaces them), an output
    low-pass of 0.25 s paced by the evidence and the claim times of
    :func:`roadgrip.estimators.classify.brls_config.saturation_config`.
    """
    return replace(default_config(), model="saturation", grip=grip, lateral=lateral,
                   sigma_x=0.5, sigma_y=0.5, slip_min_long=0.0, slip_min_lat=0.0, accel_min=0.0,
                   info_min=1.0, prefilter_tau_s=0.05, lowpass_tau_s=0.25, support_min=0.1,
                   hold_high_s=hold_high_s, hold_low_s=hold_low_s, paced_by_evidence=True)
