r"""Sensor models applied to the true signals.

Each measured signal is

``y(t_k) = Q(scale x(t_k - delay) + bias + drift t_k + e_k)``,   ``e_k ~ N(0, noise_std²)`` i.i.d.,

with ``t_k = k / output_rate`` the output clock, ``x`` the true signal at the
internal rate (linearly interpolated at ``t_k - delay``, held at its first value
before ``t = 0``) and ``Q(y) = q round(y / q)`` a uniform quantiser of step ``q``
(none when ``q = 0``). During a dropout (a message that did not arrive) the
channel holds its last value received before it, as a logger that resamples a
bus does; the first sample is always received (a log starts at its first message).

Realistic sensors (:func:`sample_sensor_errors`) draw, per channel, a latency,
a bias and a slow linear drift, a scale error, a quantisation step and a rate
of dropouts, and for the steering channel an offset, a ratio error and a
compliance (:class:`SteeringErrors`, :func:`steering_signal`). The four wheel
speeds come in one message (one latency, one dropout pattern), as do the three
pose channels; a wheel speed's scale error is the relative error of the rolling
radius the estimators assume (a common part, tire wear and pressure, and a
small part per wheel). The ranges are :data:`SENSOR_ERROR_RANGES`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "SENSOR_DRAWS",
    "SENSOR_ERROR_RANGES",
    "SensorErrors",
    "SensorSpec",
    "SteeringErrors",
    "apply_sensor",
    "apply_sensors",
    "dropout_intervals",
    "sample_sensor_errors",
    "sensors_to_dict",
    "steering_signal",
]


@dataclass(frozen=True)
class SensorSpec:
    """One sensor channel.

    Attributes
    ----------
    noise_std : float
        Standard deviation of the white noise, in the signal's unit.
    bias : float
        Constant offset, in the signal's unit.
    quantization : float
        Quantisation step, in the signal's unit (0: none).
    delay : float
        Transport delay [s], ``>= 0``.
    drift : float
        Slow linear drift of the offset, in the signal's unit per second.
    scale : float
        Gain [-] (1: none; ``1 + e`` for a scale error ``e``), > 0.
    dropout_rate : float
        Mean number of dropouts per second [1/s], ``>= 0``.
    dropout_duration : float
        Length of each dropout [s], ``>= 0``.
    """

    noise_std: float = 0.0
    bias: float = 0.0
    quantization: float = 0.0
    delay: float = 0.0
    drift: float = 0.0
    scale: float = 1.0
    dropout_rate: float = 0.0
    dropout_duration: float = 0.0

    def __post_init__(self) -> None:
        for name in ("noise_std", "quantization", "delay", "dropout_rate", "dropout_duration"):
            v = getattr(self, name)
            if not np.isfinite(v) or v < 0:
                raise ValueError(f"sensor {name} must be finite and >= 0, got {v!r}")
        for name in ("bias", "drift"):
            if not np.isfinite(getattr(self, name)):
                raise ValueError(f"sensor {name} must be finite, got {getattr(self, name)!r}")
        if not (np.isfinite(self.scale) and self.scale > 0):
            raise ValueError(f"sensor scale must be finite and > 0, got {self.scale!r}")


def apply_sensor(
    t_true: NDArray[np.float64],
    x_true: NDArray[np.float64],
    t_out: NDArray[np.float64],
    spec: SensorSpec,
    rng: np.random.Generator,
    dropouts: Sequence[tuple[float, float]] = (),
) -> NDArray[np.float64]:
    """Measure one true signal at the output times (module docstring).

    Parameters
    ----------
    t_true, x_true : ndarray, shape (n,)
        True signal on the internal clock.
    t_out : ndarray, shape (m,)
        Output clock [s].
    spec : SensorSpec
    rng : numpy.random.Generator
    dropouts : sequence of (float, float)
        Intervals ``[t0, t1)`` [s] in which no message arrives (:func:`dropout_intervals`).

    Returns
    -------
    ndarray, shape (m,)
    """
    y = np.interp(t_out - spec.delay, t_true, x_true)
    noise = rng.standard_normal(t_out.shape)  # always drawn: streams do not depend on specs
    if spec.scale != 1.0:
        y = spec.scale * y
    y = y + spec.bias + spec.noise_std * noise
    if spec.drift != 0.0:
        y = y + spec.drift * t_out
    if spec.quantization > 0:
        y = spec.quantization * np.round(y / spec.quantization)
    if len(dropouts):
        lost = np.zeros(t_out.shape, bool)
        for t0, t1 in dropouts:
            lost |= (t_out >= t0) & (t_out < t1)
        lost[:1] = False  # a log starts at its first message
        y = y[np.maximum.accumulate(np.where(lost, 0, np.arange(len(y))))]
    return y


def apply_sensors(
    t_true: NDArray[np.float64],
    signals: dict[str, NDArray[np.float64]],
    t_out: NDArray[np.float64],
    specs: dict[str, SensorSpec],
    rng: np.random.Generator,
    dropouts: Mapping[str, Sequence[tuple[float, float]]] | None = None,
) -> dict[str, NDArray[np.float64]]:
    """Measure every signal of ``signals``; channels without a spec are sampled exactly;
    ``dropouts``: each channel's lost intervals [s]."""
    out = {}
    dropouts = dropouts or {}
    for name, x in signals.items():
        out[name] = apply_sensor(t_true, x, t_out, specs.get(name, SensorSpec()), rng, dropouts.get(name, ()))
    return out


def sensors_to_dict(specs: dict[str, SensorSpec]) -> dict[str, Any]:
    """JSON form for ``meta.truth['sensors']``."""
    return {k: asdict(v) for k, v in specs.items()}


# ---------------------------------------------------------------------------------------
# realistic sensors
# ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SteeringErrors:
    """Errors of the steering-angle channel, before its :class:`SensorSpec`.

    Attributes
    ----------
    offset : float
        Offset of the reported road-wheel angle [rad] (a handwheel sensor's zero error
        over the steering ratio).
    ratio_error : float
        Relative error of the steering ratio the reported angle assumes [-]: the report is
        ``1 + ratio_error`` times the handwheel's share of the road-wheel angle.
    compliance : float
        Steering compliance [rad/N], ``>= 0``: the road wheels turn less than the handwheel
        says by ``compliance`` times the front axle's lateral force.
    """

    offset: float = 0.0
    ratio_error: float = 0.0
    compliance: float = 0.0

    def __post_init__(self) -> None:
        if not np.isfinite(self.offset):
            raise ValueError(f"steering offset must be finite, got {self.offset!r}")
        if not (np.isfinite(self.ratio_error) and self.ratio_error > -1):
            raise ValueError(f"steering ratio_error must be finite and > -1, got {self.ratio_error!r}")
        if not (np.isfinite(self.compliance) and self.compliance >= 0):
            raise ValueError(f"steering compliance must be finite and >= 0, got {self.compliance!r}")


def steering_signal(delta: NDArray[np.float64], fy_front: NDArray[np.float64],
                    errors: SteeringErrors) -> NDArray[np.float64]:
    """The steering angle the sensor reports, before its channel model [rad].

    ``(1 + ratio_error) (delta + compliance F_yf) + offset``.

    Parameters
    ----------
    delta : ndarray, shape (n,)
        True road-wheel angle [rad].
    fy_front : ndarray, shape (n,)
        Front-axle lateral force [N] (positive to the left, as ``delta``).
    errors : SteeringErrors
    """
    return (1.0 + errors.ratio_error) * (delta + errors.compliance * fy_front) + errors.offset


@dataclass(frozen=True)
class SensorErrors:
    """Sensor errors of one vehicle (:func:`sample_sensor_errors`).

    Attributes
    ----------
    channels : dict
        Column -> :class:`SensorSpec` with the channel's errors; its ``noise_std`` is
        replaced by the scenario's noise level (:meth:`specs`).
    steering : SteeringErrors
    """

    channels: dict[str, SensorSpec] = field(default_factory=dict)
    steering: SteeringErrors = field(default_factory=SteeringErrors)

    def specs(self, noise: Mapping[str, SensorSpec]) -> dict[str, SensorSpec]:
        """Each channel's errors with the scenario's noise level of ``noise``."""
        out = dict(noise)
        for col, spec in self.channels.items():
            out[col] = replace(spec, noise_std=noise[col].noise_std if col in noise else spec.noise_std)
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON form (``meta.truth['sensor_errors']``)."""
        return {"channels": sensors_to_dict(self.channels), "steering": asdict(self.steering)}


def dropout_intervals(spec: SensorSpec, duration: float, rng: np.random.Generator) -> list[tuple[float, float]]:
    """Dropouts of a channel over ``[0, duration]`` [s]: a Poisson process of rate
    ``spec.dropout_rate``, each lasting ``spec.dropout_duration``; sorted ``(t0, t1)``."""
    if spec.dropout_rate <= 0 or spec.dropout_duration <= 0:
        return []
    n = int(rng.poisson(spec.dropout_rate * duration))
    starts = np.sort(rng.uniform(0.0, duration, n))
    return [(float(t0), float(t0 + spec.dropout_duration)) for t0 in starts]


_DEG = np.pi / 180.0
SENSOR_ERROR_RANGES: dict[str, dict[str, float]] = {
    "ax": {"bias": 0.15, "drift": 5e-4, "scale": 0.02, "quantization": 0.01},
    "ay": {"bias": 0.15, "drift": 5e-4, "scale": 0.02, "quantization": 0.01},
    "yaw_rate": {"bias": 0.3 * _DEG, "drift": 1e-3 * _DEG, "scale": 0.02, "quantization": 0.01 * _DEG},
    "steer": {"bias": 0.0, "drift": 0.0, "scale": 0.0, "quantization": 0.1 * _DEG / 16.0},
    "vx": {"bias": 0.0, "drift": 0.0, "scale": 0.01, "quantization": 0.01},
    "omega_fl": {"bias": 0.0, "drift": 0.0, "scale": 0.005, "quantization": 0.02},
    "omega_fr": {"bias": 0.0, "drift": 0.0, "scale": 0.005, "quantization": 0.02},
    "omega_rl": {"bias": 0.0, "drift": 0.0, "scale": 0.005, "quantization": 0.02},
    "omega_rr": {"bias": 0.0, "drift": 0.0, "scale": 0.005, "quantization": 0.02},
    "x": {"bias": 1.0, "drift": 0.005, "scale": 0.0, "quantization": 0.01},
    "y": {"bias": 1.0, "drift": 0.005, "scale": 0.0, "quantization": 0.01},
    "psi": {"bias": 0.5 * _DEG, "drift": 0.0, "scale": 0.0, "quantization": 0.01 * _DEG},
}
"""Half-widths of the uniform draws of each channel's errors, in the channel's SI unit:
``bias`` [u], ``drift`` [u/s], ``scale`` (relative, of ``1 + e``), and the quantisation step
[u] (fixed: a bus signal's resolution; the steering channel's is 0.1 deg at the handwheel over a
ratio of 16). Besides these (:data:`SENSOR_DRAWS`): a latency of 0-150 ms per message, 0-0.02
dropouts a second of 0.05-0.3 s each, a rolling-radius error of +-2 % common to the four wheel
speeds (added to their own +-0.5 %), and the steering's offset (+-1.5 deg), ratio error (+-5 %)
and compliance (0-0.3 deg/kN)."""

SENSOR_DRAWS: dict[str, tuple[float, float]] = {
    "delay": (0.0, 0.15),
    "dropout_rate": (0.0, 0.02),
    "dropout_duration": (0.05, 0.3),
    "wheel_radius_error": (-0.02, 0.02),
    "steering_offset": (-1.5 * _DEG, 1.5 * _DEG),
    "steering_ratio_error": (-0.05, 0.05),
    "steering_compliance": (0.0, 0.3 * _DEG / 1000.0),
}
"""Ranges ``(low, high)`` of the uniform draws not per channel [s, 1/s, s, -, rad, -, rad/N]."""

_MESSAGES = (("ax",), ("ay",), ("yaw_rate",), ("steer",), ("vx",),
             ("omega_fl", "omega_fr", "omega_rl", "omega_rr"), ("x", "y", "psi"))


def sample_sensor_errors(rng: np.random.Generator) -> SensorErrors:
    """Draw realistic sensor errors (module docstring, :data:`SENSOR_ERROR_RANGES`).

    Parameters
    ----------
    rng : numpy.random.Generator

    Returns
    -------
    SensorErrors
        One :class:`SensorSpec` per channel of :data:`SENSOR_ERROR_RANGES` (noise 0:
        the scenario gives it) and the steering errors.
    """
    d = SENSOR_DRAWS
    radius = rng.uniform(*d["wheel_radius_error"])
    channels: dict[str, SensorSpec] = {}
    for message in _MESSAGES:
        delay = rng.uniform(*d["delay"])
        rate = rng.uniform(*d["dropout_rate"])
        length = rng.uniform(*d["dropout_duration"])
        for col in message:
            r = SENSOR_ERROR_RANGES[col]
            bias, drift, scale = (rng.uniform(-r[k], r[k]) for k in ("bias", "drift", "scale"))
            if col.startswith("omega_"):
                scale += radius
            channels[col] = SensorSpec(bias=float(bias), drift=float(drift), scale=float(1.0 + scale),
                                       quantization=r["quantization"], delay=float(delay),
                                       dropout_rate=float(rate), dropout_duration=float(length))
    steering = SteeringErrors(offset=float(rng.uniform(*d["steering_offset"])),
                              ratio_error=float(rng.uniform(*d["steering_ratio_error"])),
                              compliance=float(rng.uniform(*d["steering_compliance"])))
    return SensorErrors(channels, steering)
