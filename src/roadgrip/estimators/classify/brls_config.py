"""Settings of the bRLS classifier: per-channel references and thresholds, and the defaults.

The two channels of paper 002 eq. 4 (longitudinal ``ax = theta_long phi_long``,
lateral ``ay = theta_lat phi_lat``) each carry a :class:`ChannelCalibration`;
:class:`BRLSConfig` adds the bRLS and state-machine settings
(:mod:`roadgrip.estimators.classify.brls_kernel`). :func:`default_config`
derives uncalibrated references from the tire presets.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Any

from roadgrip.constants import GRAVITY
from roadgrip.estimators.classify.common import check_field_types
from roadgrip.estimators.classify.grip_model import GripModel
from roadgrip.inference.kinematic import LATERAL_ACCELERATION_SOURCES
from roadgrip.tire import SURFACES

__all__ = [
    "BRLS_MODELS",
    "BRLSConfig",
    "ChannelCalibration",
    "default_config",
    "gamma_from_noise",
    "saturation_config",
]

BRLS_MODELS = ("stiffness", "saturation")
"""Regressions of the channels: the paper's equivalent stiffness (eq. 4) or the class position
between the saturation model's predictions (:mod:`roadgrip.estimators.classify.grip_model`)."""


@dataclass(frozen=True)
class ChannelCalibration:
    """References and threshold of one bRLS channel (eq. 6, 8).

    Attributes
    ----------
    ref_high, ref_low : float
        Stiffness reference of the high / low state [m/s² per regressor unit].
    threshold : float
        Eq. 8 threshold, between the references.
    gamma : float
        Regressor excitation scale [regressor unit] (:mod:`roadgrip.estimators.classify.brls`); 0 = plain RLS.
    enabled : bool
        Whether the channel runs at all (calibration switches off a channel whose
        estimates do not separate the labelled classes).
    """

    ref_high: float
    ref_low: float
    threshold: float
    gamma: float
    enabled: bool = True

    def __post_init__(self) -> None:
        for name in ("ref_high", "ref_low", "threshold", "gamma"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be finite, got {getattr(self, name)!r}")
        if not self.ref_high > self.ref_low:
            raise ValueError(
                f"ref_high ({self.ref_high}) must exceed ref_low ({self.ref_low})"
            )
        if not self.ref_low <= self.threshold <= self.ref_high:
            raise ValueError(
                f"threshold {self.threshold} must lie between ref_low {self.ref_low} "
                f"and ref_high {self.ref_high}"
            )
        if self.gamma < 0:
            raise ValueError(f"gamma must be >= 0, got {self.gamma}")


@dataclass(frozen=True)
class BRLSConfig:
    """bRLS classifier settings.

    Attributes
    ----------
    long, lat : ChannelCalibration
        Longitudinal (``ax`` vs sum of slips) and lateral (``ay`` vs slip regressor) channels.
    memory_s : float
        Forgetting as a memory time [s]: ``mu = exp(-dt / memory_s)``.
    s0 : float
        Initial ``S`` of both channels.
    s_max : float
        Anti-wind-up bound on ``S``.
    excitation_tau_s : float
        Low-pass time constant of the channel information ``e`` [s].
    excitation_min : float
        ``e`` at which a channel is informed and may switch the state.
    initial_state : {'high', 'low'}
        State before any information.
    theta0_long, theta0_lat : float or None
        Initial estimates; default the initial state's references.
    min_speed : float
        Below this speed [m/s] the regressors are zeroed (no information).
    prefilter_tau_s : float
        Time constant [s] of a first-order low-pass applied alike to each
        channel's regressor and output before bRLS (0 = none). Filtering both
        sides keeps ``y = theta phi`` and removes the noise that a 10 Hz
        inertial sensor leaves at the sample level.
    lateral_regressor : {'axles', 'rear'}
        ``alpha_f cos(delta) + alpha_r`` (eq. 4) or ``2 alpha_r`` (see :func:`regressors`).
    error_clip : float
        Bound on the prediction error ``|eps|`` of eq. 6 [m/s²] (a Huber-type
        robust RLS: a burst of outliers moves the estimate by a bounded amount);
        ``inf`` = the paper's update.
    lateral_acceleration : {'auto', 'imu', 'kinematic'}
        Output of the lateral channel: the accelerometer's ``ay``, or the
        kinematic ``r vx + dvy/dt`` of the upstream stage; ``'auto'`` takes the
        kinematic one when the velocity comes from a pose
        (:func:`roadgrip.inference.kinematic.select_lateral_acceleration`).
    theoretical_slip : bool
        Lateral regressor from the theoretical slips ``tan(alpha) vx / (R omega)``
        instead of the slip angles (see :func:`regressors`).
    model : {'stiffness', 'saturation'}
        ``'stiffness'``: the paper's regressors (eq. 4), stiffness references.
        ``'saturation'``: each channel regresses the measured acceleration's
        position between the high and the low class's prediction of the
        saturation model (whitened, references 1 and 0;
        :func:`roadgrip.estimators.classify.grip_model.channels`).
    grip : GripModel or None
        The saturation model (``None``: derived from the vehicle's parameters,
        :func:`roadgrip.estimators.classify.grip_model.default_grip_model`).
    hold_high_s, hold_low_s : float
        A class is claimed only while some informed channel has supported it
        within this time [s]; then 'unknown', the estimates relax to the
        thresholds and only an estimate past its threshold by a fifth of the
        reference gap claims a class again (the road may have changed).
        ``inf``: the paper's state machine, which holds its state.
    redecide_low_s : float
        A 'low' not supported within this time [s] (below ``hold_low_s``) is still
        claimed, but decided afresh as an expired claim is: the estimates relax to
        the thresholds and the next informed samples, past a threshold by a fifth
        of the reference gap, either support 'low' again or switch to 'high'
        (the old estimate does not slow the switch). ``inf``: never.
    slip_filter_tau_s : float
        Saturation model: time constant [s] of the first-order low-pass of the
        slips and accelerations before the model (0 = none).
    """

    long: ChannelCalibration
    lat: ChannelCalibration
    memory_s: float = 0.5
    s0: float = 100.0
    s_max: float = 1.0e4
    excitation_tau_s: float = 0.3
    excitation_min: float = 0.3
    initial_state: str = "high"
    theta0_long: float | None = None
    theta0_lat: float | None = None
    min_speed: float = 0.5
    prefilter_tau_s: float = 0.0
    lateral_regressor: str = "axles"
    error_clip: float = math.inf
    lateral_acceleration: str = "auto"
    theoretical_slip: bool = False
    model: str = "stiffness"
    grip: GripModel | None = None
    hold_high_s: float = math.inf
    hold_low_s: float = math.inf
    slip_filter_tau_s: float = 0.0
    redecide_low_s: float = math.inf

    def __post_init__(self) -> None:
        if self.model not in BRLS_MODELS:
            raise ValueError(f"model must be one of {BRLS_MODELS}, got {self.model!r}")
        for name in ("hold_high_s", "hold_low_s", "redecide_low_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive (inf = hold), got {getattr(self, name)!r}")
        if self.lateral_acceleration not in LATERAL_ACCELERATION_SOURCES:
            raise ValueError(
                f"lateral_acceleration must be one of {LATERAL_ACCELERATION_SOURCES}, "
                f"got {self.lateral_acceleration!r}"
            )
        if self.lateral_regressor not in ("axles", "rear"):
            raise ValueError(
                f"lateral_regressor must be 'axles' or 'rear', got {self.lateral_regressor!r}"
            )
        if not self.error_clip > 0:
            raise ValueError(f"error_clip must be positive (inf = off), got {self.error_clip!r}")
        for name in ("prefilter_tau_s", "slip_filter_tau_s"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)!r}")
        if not (math.isfinite(self.min_speed) and self.min_speed >= 0):
            raise ValueError(f"min_speed must be >= 0, got {self.min_speed!r}")
        for name in ("memory_s", "s0", "s_max", "excitation_tau_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be positive and finite, got {v!r}")
        if not 0.0 < self.excitation_min < 1.0:
            raise ValueError(f"excitation_min must lie in (0, 1), got {self.excitation_min!r}")
        if self.initial_state not in ("high", "low"):
            raise ValueError(f"initial_state must be 'high' or 'low', got {self.initial_state!r}")
        if not (self.long.enabled or self.lat.enabled):
            raise ValueError("both bRLS channels are disabled: nothing to classify with")

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> BRLSConfig:
        d = dict(d)
        known = {f for f in cls.__dataclass_fields__}
        unknown = set(d) - known
        if unknown:
            raise ValueError(f"unknown bRLS setting(s) {sorted(unknown)}")
        for ch in ("long", "lat"):
            if ch not in d:
                raise ValueError(f"bRLS calibration lacks the {ch!r} channel")
            extra = set(d[ch]) - set(ChannelCalibration.__dataclass_fields__)
            if extra:
                raise ValueError(f"unknown key(s) {sorted(extra)} in bRLS channel {ch!r}")
            check_field_types(ChannelCalibration, d[ch], f"bRLS channel {ch!r}")
            d[ch] = ChannelCalibration(**d[ch])
        if d.get("grip") is not None:
            d["grip"] = GripModel.from_dict(dict(d["grip"]))
        check_field_types(cls, d, "bRLS settings")
        return cls(**d)


def gamma_from_noise(ref_high: float, ref_low: float, accel_noise: float) -> float:
    """``gamma`` with ``gamma ln 2 = 2 sigma_a / (ref_high - ref_low)`` (:mod:`roadgrip.estimators.classify.brls`)."""
    return 2.0 * accel_noise / ((ref_high - ref_low) * math.log(2.0))


def default_config(accel_noise: float = 0.3) -> BRLSConfig:
    """The paper's stiffness model with references from the tire presets: high = dry
    asphalt, low = gravel (the uncalibrated estimator runs :func:`saturation_config`).

    Lateral: ``theta_lat = g B C D / 2`` (axle loads in the static split, the
    normalised cornering stiffness of the surface's lateral Magic Formula);
    longitudinal: ``theta_long = g B C D / 4`` (four equally loaded wheels).
    Thresholds halfway; gamma from ``accel_noise`` [m/s²].
    """
    hi, lo = SURFACES["dry_asphalt"], SURFACES["gravel"]

    def chan(sh: float, sl: float) -> ChannelCalibration:
        return ChannelCalibration(sh, sl, 0.5 * (sh + sl), gamma_from_noise(sh, sl, accel_noise))

    return BRLSConfig(
        long=chan(GRAVITY * hi.longitudinal.slope0() / 4, GRAVITY * lo.longitudinal.slope0() / 4),
        lat=chan(GRAVITY * hi.lateral.slope0() / 2, GRAVITY * lo.lateral.slope0() / 2),
    )


SATURATION_PHI_HALF = 0.3
"""Separation of the class predictions, in noise units, at which a sample's bRLS weight is 1/2."""

UNCALIBRATED_HOLD_S = 2.0
"""Claim time of both classes without a calibration [s]: the defaults support a claim
only about the road just measured."""

CALIBRATED_HOLD_HIGH_S = 3.0
"""Claim time of 'high' with a calibration [s]; 'low' is held (``inf``) until evidence
of high grip: a wrong 'high' on a road that has turned slippery is the dangerous error,
a 'low' held onto a grippier road the cautious one (where the evidence of high grip comes
at the next acceleration: see :data:`BRAKING_ONLY_HOLD_LOW_S`)."""

CALIBRATED_REDECIDE_LOW_S = 8.0
"""Age [s] from which a calibrated classifier decides a held 'low' afresh
(``redecide_low_s``): the next informed samples either support it again or switch to
'high' (or, informed but undecided, withdraw it) without the old estimate's inertia, so
that a dry acceleration within the honesty rule's 10 s after a change
(:data:`roadgrip.evaluate.honesty.CHANGE_MAX_S`) ends the 'low' at once (0.1-0.2 s into
it on the random family, where the held estimate took 0.7-1.6 s). 'low' stays claimed
until then: on the known multi-body cars the gravel's slalom comes 9-26 s after the last
braking with no channel informed (the lateral one off), and an 8 s expiry costs 0.08-0.20
of the accuracy at high utilisation there."""

BRAKING_ONLY_HOLD_LOW_S = 5.0
"""Claim time of 'low' with a calibration on an all-wheel-drive car [s]: no wheel rolls
freely, so the longitudinal channel is informed in braking only, and a 'low' held until
evidence of high grip would outlive a return to a grippy road until the next stop (on the
random family's all-wheel drives 20 s past the change). The same hold as 'high' would lose
'low' on gravel between stops sooner (its share of the gravel minute 0.06-0.10 at 3 s,
0.10-0.13 at 5 s, 0.15-0.18 at 8 s, against 0.69 held)."""


def saturation_config(
    grip: GripModel | None = None, hold_high_s: float = UNCALIBRATED_HOLD_S,
    hold_low_s: float = UNCALIBRATED_HOLD_S, lateral: bool = False,
) -> BRLSConfig:
    """bRLS on the saturation model: both channels with references 1 (high) and 0 (low).

    The regressions are whitened (unit noise), so ``gamma`` puts the measurement
    weight at 1/2 where the two classes' predictions differ by one noise unit;
    the threshold is halfway. The weight is 1/2 where the predictions differ by
    :data:`SATURATION_PHI_HALF` noise units: a single sample says little, but the
    memory accumulates about a hundred of them per second at 100 Hz.

    The lateral channel is off unless ``lateral``: it needs the sideslip, which the
    kinematic stage estimates well only with a pose or in quasi-linear driving (on
    the multi-body drives the accelerometer's roll leak drifts it by as much as the
    slip angles themselves in sustained cornering); a calibration turns it on where
    the labelled drives show that it separates the classes. ``grip=None`` derives the model from the vehicle's
    parameters at run time (the uncalibrated default).
    """
    chan = ChannelCalibration(1.0, 0.0, 0.5, SATURATION_PHI_HALF / math.log(2.0))
    return BRLSConfig(long=chan, lat=replace(chan, enabled=lateral), memory_s=1.0,
                      slip_filter_tau_s=0.05, model="saturation", grip=grip,
                      hold_high_s=hold_high_s, hold_low_s=hold_low_s)
